r"""Exact second derivatives of a model's state derivative, contracted with weights.

For :math:`f = [\dot q;\ \dot u]`, :math:`\dot q = g(q, u, r)` and the
accelerations :math:`w = \dot u` solving :math:`E(x, w) = \tau(q, u, w) - f_u
= 0` (:math:`x = (y, r)`, :math:`E_w = M`, :math:`E` linear in :math:`w`),
differentiating :math:`E(x, w(x)) = 0` twice gives

.. math::

    M\, w_{xx} = -\begin{bmatrix} I \\ w_x \end{bmatrix}^T E''
                  \begin{bmatrix} I \\ w_x \end{bmatrix},
    \qquad w_x = -M^{-1} E_x,

with :math:`E''` the Hessian of :math:`E` in :math:`(x, w)`.  The same
holds with :math:`x` extended by chosen constants :math:`p` (free parameters
of an optimal control problem) and the time :math:`t`; their columns of
:math:`w_x`, :math:`-M^{-1} E_p` and :math:`-M^{-1} E_t`, are generated too.  So for weights
:math:`\lambda = [\lambda_q; \lambda_u]` on the rows of :math:`f`, with
:math:`\nu = M^{-T}\lambda_u`,

.. math::

    \frac{\partial^2 (\lambda^T f)}{\partial x^2} =
    \begin{bmatrix} I \\ w_x \end{bmatrix}^T
    \Bigl(\textstyle\sum_i \lambda_{q,i}\, g_i'' - \sum_i \nu_i\, E_i''\Bigr)
    \begin{bmatrix} I \\ w_x \end{bmatrix} .

The second derivatives :math:`g_i''` and :math:`E_i''` in :math:`(y, r, w)`
are generated code: forward differentiation, twice, of the equations'
straight-line program (:meth:`kanedyn.engine.Program.jacobian`).  On the
NumPy backend they are printed as NumPy code evaluated on every point at
once, the solves and the contraction done in NumPy; on the C backend the
solves and the contraction are generated too, all of it one C function
evaluated at every point in one call (:mod:`.backends._c_hessians`).
:math:`w_x` is that of :func:`~kanedyn.numerics.jacobians`.  For models
without dependent speeds or coordinates and without contacts (others are
refused, saying why).
"""

from __future__ import annotations

import math

import numpy as np

from .._errors import ModelError
from ._jacobians import broadcast_rows

__all__ = ["hessians_unavailable", "weighted_hessians", "weighted_hessian_pattern",
           "names_time"]


def hessians_unavailable(model):
    """Why :func:`weighted_hessians` cannot serve ``model`` (text), or ``None``."""
    from ._jacobians import derivatives_unavailable
    reason = derivatives_unavailable(model)
    if reason:
        return reason
    if model.n_u_dep or model.n_q_dep:
        return ("exact second derivatives are generated for models without constraints "
                f"only; this one has {model.n_q_dep} dependent coordinates and "
                f"{model.n_u_dep} dependent speeds")
    if model.contacts:
        return "exact second derivatives are not generated for models with contacts"
    if getattr(model, "_eom", None) is None:
        return "exact second derivatives need the model's equations (a model built by " \
               "eom.numeric(...), not one restored from a file)"
    return None


def names_time(model):
    """Whether the state derivative of ``model`` (a model :func:`weighted_hessians`
    serves) depends on the time explicitly: whether the time is among the
    leaves of its kinematic equations, mass matrix and forces."""
    from ._inverse import _workspace
    prog, _ = _workspace(model)
    _, dynamics = model._functions["dynamics"]
    return any(prog.t in prog.deps(e) for _, exprs in dynamics for e in exprs)


def _specification(model, parameters=(), time=False):
    """``(program, arguments, outputs, pattern)``: arguments ``(t, y, p, r)``
    with ``r`` the inputs then :math:`w`; outputs ``M`` (o, o) and the second
    derivatives of ``[g; E]`` in ``v = (y, r, e, w)``, ((n + o) * nv, nv),
    ``e`` the constants of indices ``parameters`` then (``time``) t; with
    ``e``, a third output: :math:`E_e`, (o, len(e)); ``pattern`` that of the
    contracted Hessian (:func:`_contracted_pattern`).  A change here changes
    the C module's code: bump :data:`.backends._c_hessians._GENERATION`,
    part of its cache key."""
    from ._inverse import _recursive_inertia_forces, _workspace
    import sympy as sm
    eom = model._eom
    args, dynamics = model._functions["dynamics"]
    o = model.n_u
    qdot, mass, force = dynamics[0][1], dynamics[1][1], dynamics[2][1]
    prog, kin = _workspace(model)
    w = list(eom._table.udot)
    inertia = _recursive_inertia_forces(eom, o, w, model._substitutions, kin)
    if inertia is None:
        inertia = [sm.Add(*[mass[r * o + s] * w[s] for s in range(o)]) for r in range(o)]
    rows = list(qdot) + [inertia[r] - force[r] for r in range(o)]
    extra = [args["p"][i] for i in parameters] + ([prog.t] if time else [])
    v = list(args["y"]) + list(args["r"]) + extra + w
    first = prog.jacobian(rows, v, guarded=True)
    second = prog.jacobian(list(first), v, guarded=True)
    outputs = [((o, o), list(mass)), ((len(rows) * len(v), len(v)), list(second))]
    if extra:
        start, n = len(v) - o - len(extra), len(rows) - o
        outputs.append(((o, len(extra)), [first[n + i, start + j] for i in range(o)
                                          for j in range(len(extra))]))
    nr, nv = len(rows), len(v)
    # the groups of entries whose any() the contracted pattern takes: of the
    # first derivatives E_x by column (g's rows and w's columns unused), of
    # the second by unordered pair of variables
    r, c = np.divmod(np.arange(nr * nv), nv)
    first_groups = np.where((r >= nr - o) & (c < nv - o), c, -1)
    i, j = np.divmod(np.arange(nr * nv * nv) % (nv * nv), nv)
    second_groups = np.minimum(i, j) * nv + np.maximum(i, j)
    pattern = _contracted_pattern(_nonzero(prog, list(first), first_groups),
                                  _nonzero(prog, list(second), second_groups), nr, o)
    return prog, dict(args, r=list(args["r"]) + w), outputs, pattern


#: a derivative whose explicit expression has at most this many nodes is
#: expanded to tell whether it is identically zero (larger ones are taken as
#: nonzero unless they are SymPy's zero)
EXPANDED_NODES = 400

#: a derivative of this magnitude or more at a random point (its leaves in
#: [0.5, 1.5)) is not identically zero (terms that cancel leave rounding)
_SHOWN_NONZERO = 1e-8


def _nonzero(prog, derivatives, groups):
    """(len(derivatives),) bool: where the derivatives (of ``prog``) can be
    nonzero, as the pattern reads them: whether any entry of each group
    (``groups``: the group of each entry, -1 for one the pattern does not
    read) is.  Beside SymPy's zero, one whose explicit expression (of at
    most :data:`EXPANDED_NODES` nodes) expands to zero is zero: terms of the
    model's forces that cancel (a point's centripetal acceleration along the
    normal of its partial velocity) otherwise keep entries of the Hessian
    that are zero at every point.  A group with an entry whose value at a
    random point (the program's ``shadow``) is clearly not zero is not
    zero; the others' entries are expanded the smallest first, until one is
    not zero (the rest need not be)."""
    import sympy as sm
    from ..engine import SAMPLE_SEEDS
    out = np.array([e != 0 for e in derivatives], dtype=bool)
    candidates = np.flatnonzero(out & (groups >= 0))
    sampled = np.abs(np.array(prog.shadow([derivatives[k] for k in candidates],
                                          SAMPLE_SEEDS[0]), dtype=complex))
    members, sizes, shown = {}, {}, set()
    for k, value in zip(candidates, sampled):
        members.setdefault(int(groups[k]), []).append(int(k))
        if value > _SHOWN_NONZERO:  # (NaN is not: the evaluation failed)
            shown.add(int(groups[k]))
    for group in (g for g in members if g not in shown):
        for k in sorted(members[group], key=lambda k: prog.tree_size(derivatives[k], sizes)):
            e = derivatives[k]
            if prog.tree_size(e, sizes) > EXPANDED_NODES or sm.expand(prog.expand(e)) != 0:
                break  # the group can be nonzero
            out[k] = False
    return out


def _contracted_pattern(first, second, rows, o):
    r"""Where :math:`\partial^2 (\lambda^T f)/\partial x^2` can be nonzero for
    some weights and point: (nx, nx) bool, symmetric.

    ``first`` ((rows * nv,) bool) and ``second`` ((rows * nv * nv,)) say which
    first and second derivatives of the rows of ``[g; E]`` in ``v = (x, w)``
    are not identically zero (the last ``o`` rows :math:`E`).  Then
    :math:`\Phi` is nonzero where any row's second derivative is (in either
    order),
    :math:`W = -M^{-1} E_x` in each column where any row of :math:`E_x` is
    (:math:`M^{-1}` taken as full), and the Hessian
    :math:`\Phi_{xx} + \Phi_{xw} W + W^T \Phi_{wx} + W^T \Phi_{ww} W`
    where any of its terms is."""
    nv = first.size // rows
    nx = nv - o
    Phi = second.reshape(rows, nv, nv).any(axis=0)
    Phi = (Phi | Phi.T).astype(int)  # each derivative's two orders: either may look nonzero
    W = np.broadcast_to(first.reshape(rows, nv)[rows - o:, :nx].any(axis=0), (o, nx))
    W = W.astype(int)
    cross = Phi[:nx, nx:] @ W
    return (Phi[:nx, :nx] + cross + cross.T + W.T @ Phi[nx:, nx:] @ W) > 0


def _c_specification(model, parameters, time):
    """``(program, arguments, outputs)`` of the C module's ``hessians``
    (:mod:`.backends._c_hessians`): its run-time inputs the inputs, w, the
    weights and the columns of w_x of the states and inputs (row-major);
    its output the contracted Hessian."""
    from .backends._c_hessians import contracted_hessian
    prog, args, ((_, mass), (shape, second), *E_e), pattern = _specification(
        model, parameters, time)
    o, nv = model.n_u, shape[1]
    weights, W, H = contracted_hessian(prog, mass, second, E_e[0][1] if E_e else [],
                                       model.n_q, o, nv - o)
    return prog, dict(args, r=args["r"] + weights + W), [((nv - o, nv - o), H)], pattern


def _function(model, parameters=(), time=False):
    """The generated code, made on first use and kept by the model (and the
    copies :meth:`NumericModel.with_constants` makes), one per choice of extra
    variables: on C, the module of :mod:`.backends._c_hessians`; otherwise the
    NumPy function of M, the second derivatives (and E_e)."""
    kept = model.__dict__.setdefault("_weighted_hessians", {})
    key = (tuple(int(i) for i in parameters), bool(time))
    found = kept.get(key)
    if found is None and model._data["backend"] == "c":
        from .backends._c_hessians import hessian_module
        found = kept[key] = hessian_module(model, f"parameters={key[0]} time={key[1]}",
                                           lambda: _c_specification(model, *key))
    elif found is None:
        from .backends._python import compile_python, generate_python
        prog, args, outputs, pattern = _specification(model, *key)
        source = generate_python(prog, "hessians", args, outputs, vectorized=True, cse=True)
        found = kept[key] = compile_python(source, "hessians")
        model.__dict__.setdefault("_weighted_hessian_patterns", {})[key] = pattern
    return found


def weighted_hessian_pattern(model, parameters=(), time=False):
    """Where :func:`weighted_hessians` can be nonzero, at any point and for any
    weights: the entries of its result not identically zero.

    Parameters
    ----------
    model, parameters, time
        As for :func:`weighted_hessians`.

    Returns
    -------
    ndarray of bool, shape (nx, nx)
        Symmetric, in the columns of :func:`weighted_hessians`.  Made from
        the structure of the model's first and second derivatives, where
        they are not identically zero (SymPy's zero, or a small one that
        expands to zero: :data:`EXPANDED_NODES`; the mass matrix's inverse
        taken as full); on the C backend it is part of the Hessian's module (a cached
        module is loaded without differentiating anything).
    """
    reason = hessians_unavailable(model)
    if reason:
        raise ModelError(reason)
    fn = _function(model, parameters, time)
    if model._data["backend"] == "c":
        found = fn.hessian_pattern(0.0, np.zeros(model.n_states), model._p, np.zeros(0))[0]
        return np.asarray(found) != 0
    key = (tuple(int(i) for i in parameters), bool(time))
    return model.__dict__["_weighted_hessian_patterns"][key].copy()


def weighted_hessians(model, t, Y, R, weights, jacobians=None, parameters=(), time=False):
    r""":math:`\partial^2 (\lambda_k^T f)/\partial x^2` at each of N points,
    :math:`x = (y, r)`, or :math:`x = (y, r, p, t)` with ``parameters`` or
    ``time``.

    Parameters
    ----------
    model : NumericModel
    t : ndarray, shape (N,)
        Times, s.
    Y : ndarray, shape (N, n_states)
    R : ndarray, shape (N, n_inputs)
    weights : ndarray, shape (N, n_states)
        :math:`\lambda_k`, one weight per row of :math:`f` (units: those of
        the Lagrangian over those of :math:`f`).
    jacobians : Jacobians, optional
        ``model.jacobians(t, Y, r=R)`` when already at hand.
    parameters : sequence of int, optional
        Indices (into :attr:`NumericModel.constants`) of constants :math:`p`
        to differentiate in too.
    time : bool, optional
        Differentiate in the time too (the model's explicit dependence on it).

    Returns
    -------
    ndarray, shape (N, nx, nx)
        Symmetric; the columns are the states, the inputs, then the chosen
        constants and the time (``nx = n_states + n_inputs +
        len(parameters) + time``).
    """
    reason = hessians_unavailable(model)
    if reason:
        raise ModelError(reason)
    Y = np.asarray(Y, dtype=float)
    R = np.asarray(R, dtype=float).reshape(len(Y), -1)
    N, n, o = len(Y), model.n_q, model.n_u
    ns, nr, ne = model.n_states, R.shape[1], len(parameters) + bool(time)
    nx = ns + nr + ne
    J = jacobians if jacobians is not None else model.jacobians(t, Y, r=R)
    fn = _function(model, parameters, time)
    weights = np.asarray(weights, dtype=float).reshape(N, ns)
    if model._data["backend"] == "c":  # fn: the module of .backends._c_hessians
        return _compiled(model, fn, t, Y, R, weights, J)
    T = np.broadcast_to(np.asarray(t, dtype=float), (N,))
    r_args = [*R.T, *J.f[:, n:].T]
    mass, second, *E_e = fn(T, np.ascontiguousarray(Y.T), model._p, r_args)
    # points on the last axis throughout: elementwise work on rows of length N
    mass = np.broadcast_to(np.asarray(mass, dtype=float), (o, o, N))
    nv = nx + o
    second = np.broadcast_to(np.asarray(second, dtype=float),
                             ((n + o) * nv, nv, N)).reshape(n + o, nv, nv, N)
    nu = np.linalg.solve(np.moveaxis(mass, -1, 0).swapaxes(1, 2),
                         weights[:, n:, None])[..., 0]
    c = np.concatenate([weights[:, :n], -nu], axis=1).T  # (n + o, N)
    phi = np.einsum("ik,iabk->abk", c, second)
    W = [np.moveaxis(J.state[:, n:, :], 0, -1), np.moveaxis(J.inputs[:, n:, :], 0, -1)]
    if ne:  # w_e = -M^{-1} E_e
        E_e = np.broadcast_to(np.asarray(E_e[0], dtype=float), (o, ne, N))
        W.append(np.moveaxis(-np.linalg.solve(np.moveaxis(mass, -1, 0),
                                              np.moveaxis(E_e, -1, 0)), 0, -1))
    W = np.concatenate(W, axis=1)  # w_x, (o, nx, N)
    cross = np.einsum("abk,bjk->ajk", phi[:nx, nx:], W)
    H = phi[:nx, :nx] + cross + cross.transpose(1, 0, 2)
    H = H + np.einsum("bik,bck,cjk->ijk", W, phi[nx:, nx:], W, optimize=True)
    return np.ascontiguousarray(np.moveaxis(H, -1, 0))


def _compiled(model, module, t, Y, R, weights, J):
    """:func:`weighted_hessians` from the C module: every point in one call."""
    N, n = len(Y), model.n_q
    T = np.ascontiguousarray(broadcast_rows(np.asarray(t, dtype=float), (N,)))
    W = np.concatenate([J.state[:, n:, :], J.inputs[:, n:, :]], axis=2).reshape(N, -1)
    inputs = np.concatenate([R, J.f[:, n:], weights, W], axis=1)
    H = module.hessians_rows(T, np.ascontiguousarray(Y), model._p, inputs)[0]
    with np.errstate(over="ignore", invalid="ignore"):  # (a sum of large entries)
        total = np.add.reduce(H, axis=None)
    if math.isfinite(total):  # every entry finite (as a rule, found so at once)
        return H
    bad = np.flatnonzero(~np.isfinite(H).reshape(N, -1).all(axis=1))
    if len(bad):  # M's factors are written out without a check of their pivots
        raise np.linalg.LinAlgError(
            f"the exact Hessian is not finite at {len(bad)} point(s) (the first at t = "
            f"{T[bad[0]]:g}): the mass matrix is singular there, or the model's terms "
            "are not finite")
    return H
