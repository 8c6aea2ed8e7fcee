r"""Inverse dynamics of a :class:`NumericModel`: the generalized forces needed.

For a state :math:`(q, u)` and accelerations :math:`\dot u` (independent
speeds given, dependent ones completed from the constraints) the generalized
forces that must act on the independent speeds for the motion to happen are

.. math::

    \tau = \left(M\dot u - f\right)_{ind} + A_r^T \left(M\dot u - f\right)_{dep},
    \qquad A_r = -B_{dep}^{-1} B_{ind},

with :math:`M, f` Kane's unreduced mass matrix and forcing
(:math:`f = F_r - F^*_r|_{\dot u = 0}`), :math:`B` the velocity-constraint
matrix and :math:`\dot u_{dep}` from the acceleration constraints
:math:`K_a\dot u + f_a = 0`.  For an open chain :math:`\tau = M\dot u - f`.

The function is generated code (both backends) taking :math:`\dot u` as
inputs.  For a tree of joints derived by Kane's method the inertia forces
:math:`M\dot u` come from the engine's recursive pass
(:func:`kanedyn.engine.composite_inertia_forces`: spatial accelerations down
the tree, inertia wrenches summed up it, :math:`O(n)` for a chain); otherwise
from the product with the mass-matrix entries, which the derivation holds as
named intermediates.  No matrix is assembled or factorized, except the small
:math:`B_{dep}` and :math:`K_{a,dep}` blocks of closed chains.
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..engine import composite_inertia_forces, inertia_components
from .backends._python import compile_python, generate_python

__all__ = ["inverse_dynamics", "one_point"]


def _workspace(model):
    """``(program, kinematics)`` the inverse function is built on, made on first use.

    An extension (:meth:`~kanedyn.engine.Program.copy`) of the equations'
    program and kinematics, kept by ``model``: the intermediates the inverse
    function adds go there, so the equations (``eom``) stay as derived and
    models built from them later are unaffected.
    """
    found = model.__dict__.get("_inverse_workspace")
    if found is None:
        eom = _equations(model)
        prog = eom._program.copy()
        kin = eom._kinematics.on(prog) if getattr(eom, "_kinematics", None) else None
        found = model.__dict__["_inverse_workspace"] = (prog, kin)
    return found


def _equations(model):
    eom = getattr(model, "_eom", None)
    if eom is None:
        raise ModelError("inverse dynamics needs the model's equations, which a model "
                         "restored from a file does not carry; use the model built by "
                         "eom.numeric(...)")
    return eom


def _specification(model):
    """Arguments and outputs of the generated ``inverse`` function.

    The outputs are expressions of the program :func:`_workspace` gives (not
    of ``model._eom._program``, which is left unchanged).
    """
    eom = _equations(model)
    if model.multiplier_form:
        raise ModelError(f"inverse dynamics is not available for the {eom.method!r} "
                         "formulation's multiplier form; use kd.kane")
    args, dynamics = model._functions["dynamics"]
    o = model.n_u
    mass, force = dynamics[1][1], dynamics[2][1]
    udot = list(eom._table.udot)
    prog, kin = _workspace(model)
    inertia = _recursive_inertia_forces(eom, o, udot, model._substitutions, kin)
    if inertia is None:  # the product with the mass-matrix entries
        inertia = [sm.Add(*[mass[r * o + s] * udot[s] for s in range(o)]) for r in range(o)]
    tau = [inertia[r] - force[r] for r in range(o)]
    inverse_args = dict(args, r=list(args["r"]) + udot)
    return inverse_args, [((o,), tau), dynamics[3], dynamics[4], dynamics[5]]


def _tree_bodies(eom, kin):
    """``(bodies, body_terms, masses, inertias)`` of a Kane model's rigid bodies
    and particles on ``kin.prog`` (where new intermediates go), or ``None`` (not
    Kane's method, or flexible bodies)."""
    if eom.method != "kane" or getattr(eom, "_kinematics", None) is None:
        return None
    bodies = list(eom.bodies)
    if any(not isinstance(b, (me.RigidBody, me.Particle)) for b in bodies) \
            or len(bodies) != len(eom._body_terms):
        return None
    prog = kin.prog
    masses = [prog.let(kin.internal(b.mass, f"mass of {b.name}"), f"m_{b.name}")
              for b in bodies]
    inertias = [inertia_components(kin, b, f"body {b.name}")[1]
                if isinstance(b, me.RigidBody) else None for b in bodies]
    return bodies, [t.on(prog) for t in eom._body_terms], masses, inertias


def _recursive_inertia_forces(eom, o, rates, substitutions, kin=None):
    """``M u'`` of a Kane tree by the engine's recursive pass, else ``None``.

    New intermediates go to ``kin.prog`` (by default a copy of the equations'
    program: ``eom`` itself is never extended).
    """
    if eom.method != "kane" or getattr(eom, "_kinematics", None) is None:
        return None
    if kin is None:
        kin = eom._kinematics.on(eom._program.copy())
    found = _tree_bodies(eom, kin)
    if found is None:
        return None
    rows = composite_inertia_forces(kin, *found, rates, o)
    if rows is None or not substitutions:
        return rows
    return [kin.prog.subs(e, substitutions) for e in rows]


def _generated(model):
    """The specification, without the constraint outputs when no speed is
    dependent (the function then returns the tuple ``(tau,)``)."""
    args, outputs = _specification(model)
    return args, (outputs if model.n_u_dep else outputs[:1])


def _function(model, vectorized):
    """The generated ``inverse`` (or ``inverse_batch``) function, made on first use.

    ``inverse_batch`` takes one column per point and returns outputs with the
    point axis last; on the C backend it is the module's ``inverse_rows``
    (every point in one call).  A C module also brings ``inverse_point`` (see
    :func:`one_point`) and ``constraints_rows`` (:func:`_complete`)."""
    key = "inverse_batch" if vectorized else "inverse"
    fn = model._fn.get(key)
    if fn is not None:
        return fn
    d = model._data
    if d["backend"] == "c":
        from .backends._c import fingerprint, generate_c_units, load_module
        args, outputs = _generated(model)
        prog = _workspace(model)[0]
        functions = dict(model._functions, inverse=(args, outputs))
        table = model._eom._table
        module = load_module(
            fingerprint(prog, functions, model._sizes, model._cse, lanes=False),
            lambda: generate_c_units(prog, functions, model._sizes,
                                     describe=lambda e: str(table.external(e)),
                                     cse=model._cse, lanes=False))
        functions = model._fn  # the same dict throughout (the model may move meanwhile)
        functions.update(inverse=module.inverse, inverse_batch=_stacked(module.inverse_rows),
                         inverse_point=getattr(module, "inverse_point", None),
                         constraint_rows=getattr(module, "constraints_rows", None))
        return functions[key]
    sources = d.setdefault("inverse_sources", {})
    if key not in sources:
        args, outputs = _generated(model)
        sources[key] = generate_python(_workspace(model)[0], key, args, outputs,
                                       vectorized=vectorized, cse=vectorized)
    fn = model._fn[key] = compile_python(sources[key], key)
    return fn


def _rows(value, name, sizes, count):
    """``value`` as a float array of shape ``(rows, count)``; rows in ``sizes``."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] not in sizes or a.shape[1] != count:
        raise ValueError(f"{name} must have shape (n, N) with n in {sorted(set(sizes))} "
                         f"(one column per point, as res.y), or (n,); got {np.shape(value)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has entries that are not finite")
    return a


def inverse_dynamics(model, t, q, u, udot):
    r"""Generalized forces on the independent speeds that produce ``udot``.

    Parameters
    ----------
    model : NumericModel
    t : float or array_like, shape (N,)
        Times, s.
    q : array_like, shape (n_q_ind, N) or (n_q, N), or 1-D for one point
        Coordinates: independent ones, or all, the dependent ones then being
        starting guesses for Newton's method on the configuration
        constraints (needed for closed chains, whose dependent coordinates
        zero is rarely close to; with independent ones only, each point
        starts from the previous point's solution, the first from zero).
    u : array_like, shape (n_u_ind, N) or (n_u, N), or 1-D
        Speeds, likewise completed from the velocity constraints.
    udot : array_like, shape (n_u_ind, N) or (n_u, N), or 1-D
        Rates of the independent speeds (dependent entries, when given, are
        ignored: they follow from the acceleration constraints).

    Returns
    -------
    ndarray, shape (n_u_ind, N), or (n_u_ind,) for 1-D inputs
        :math:`\tau`, in the units of the generalized forces of each
        independent speed (N for a translation rate in m/s, N m for an
        angular rate in rad/s), with the model's specified inputs at their
        given values.

    Notes
    -----
    The general way, for trajectories and closed chains;
    :meth:`NumericModel.inverse_dynamics` first tries the direct call of
    :func:`one_point` for one point.
    """
    single = np.ndim(q) == 1 and np.ndim(u) == 1 and np.ndim(udot) == 1
    count = 1 if np.ndim(q) == 1 else np.shape(q)[-1]
    n, o = model.n_q, model.n_u
    l, m = model.n_q_dep, model.n_u_dep
    nq, p = n - l, o - m
    q = _rows(q, "q", (nq, n), count)
    u = _rows(u, "u", (p, o), count)
    udot = _rows(udot, "udot", (p, o), count)[:p]
    ts = np.broadcast_to(np.asarray(t, dtype=float), (count,))
    Y = np.zeros((model.n_states, count))
    Y[:q.shape[0]] = q
    Y[n:n + u.shape[0]] = u
    fn = _function(model, vectorized=count > 1)  # first: a C module brings constraint_rows
    if l or m:
        _complete(model, ts, Y, warm=q.shape[0] < n)
    R = (np.array([model._input_values(ts[i], Y[:, i]) for i in range(count)]).T
         if model._inputs else np.zeros((0, count)))
    U = np.zeros((o, count))
    U[:p] = udot
    if count == 1:
        out = _point(fn, model, ts[0], Y[:, 0], np.concatenate([R[:, 0], U[:, 0]]), p, m)
        out = out[:, None]
    else:
        out = _batch(fn, model, ts, Y, R, U, p, m)
    return out[:, 0] if single else out


def _complete(model, ts, Y, warm, tol=1e-12):
    """Dependent coordinates and speeds of every column of ``Y``, in place.

    Points whose coordinates already satisfy the configuration constraints
    (``max |h| <= tol``, e.g. from a closed-form inverse kinematics) skip
    Newton's method; their dependent speeds come from one batched solve of
    the velocity constraints (linear in the speeds), the blocks checked for
    singularity as :meth:`NumericModel.consistent_state` checks them.  Other
    points, and any whose block is singular, go through
    ``consistent_state`` (which names what fails).  With ``warm``, a point's
    dependent coordinates start from the previous point's.
    """
    n, o, l, m = model.n_q, model.n_u, model.n_q_dep, model.n_u_dep
    nq, count = n - l, Y.shape[1]
    every = model._fn.get("constraint_rows") if not (warm or model._inputs) else None
    if every is not None:  # the terms at every point in one compiled call
        H, _, B, c = every(ts, np.ascontiguousarray(Y.T), model._p, np.zeros((count, 0)))
        off = ~(np.max(np.abs(H), axis=1, initial=0.0) <= tol) if l else np.zeros(count, bool)
        for i in np.flatnonzero(off):
            Y[:, i] = model.consistent_state(ts[i], Y[:, i], tol=tol)
        rows = np.flatnonzero(~off) if m else []
        B, c = B[rows], c[rows]
    else:
        rows, blocks, residuals = [], [], []
        for i in range(count):
            if warm and i:
                Y[nq:n, i] = Y[nq:n, i - 1]
            h, _, Bi, ci = model._constraint_terms(ts[i], Y[:, i])
            if l and not np.max(np.abs(h)) <= tol:
                Y[:, i] = model.consistent_state(ts[i], Y[:, i], tol=tol)
            elif m:
                rows.append(i)
                blocks.append(Bi)
                residuals.append(ci)
        B, c = np.array(blocks), np.array(residuals)
    if not len(rows):
        return
    dep = B[:, :, o - m:]
    scale = np.maximum(np.max(np.abs(B), axis=(1, 2)), 1e-300)
    try:
        inverse = np.linalg.inv(dep)
        # 1/|inv|_F bounds the smallest singular value within a factor sqrt(m)
        ok = np.all(np.isfinite(inverse), axis=(1, 2))
        ok[ok] = 1.0 / np.linalg.norm(inverse[ok], axis=(1, 2)) > 1e-12 * scale[ok] * m
    except np.linalg.LinAlgError:  # some block exactly singular
        inverse, ok = None, np.zeros(len(rows), dtype=bool)
    rows = np.asarray(rows)
    for i in rows[~ok]:  # singular: the general way, which reports it
        Y[:, i] = model.consistent_state(ts[i], Y[:, i], tol=tol)
    if np.any(ok):
        Y[n + o - m:, rows[ok]] -= (inverse[ok] @ c[ok][..., None])[..., 0].T


def _stacked(rows):
    """The compiled ``inverse_rows`` in the layout of the vectorized function:
    arguments with one column per point, outputs with the point axis last."""
    def stacked(t, Y, params, RU):
        outs = rows(np.ascontiguousarray(t, dtype=float), np.ascontiguousarray(Y.T), params,
                    np.ascontiguousarray(RU.T))
        return [np.moveaxis(out, 0, -1) for out in outs]
    return stacked


def _is_vector(x):
    return x.ndim == 1 if type(x) is np.ndarray else np.ndim(x) == 1


def one_point(model):
    """The direct call for one point of a model without dependent coordinates
    or speeds, or ``False``.

    The returned ``one(t, q, u, udot)`` fills fresh state and input vectors
    and calls the generated function once (no shape bookkeeping for a
    trajectory, no stacking); it returns ``None`` for anything other than a
    scalar time and three 1-D arrays of all coordinates, speeds and rates
    whose entries are finite, which :func:`inverse_dynamics` then checks (and
    reports) the general way.  A C model without specified inputs does the
    checks and the call in C for float64 arrays (``inverse_point``).
    """
    if model.n_q_dep or model.n_u_dep:
        return False
    fn = _function(model, vectorized=False)
    n, o, params = model.n_q, model.n_u, model._p
    k = len(model._inputs) if model._inputs else 0
    inputs = model._input_values if k else None
    scalars = (float, int, np.float64, np.float32, np.int64, np.int32)

    def checked(t, q, u, udot):
        if type(t) not in scalars or not (_is_vector(q) and _is_vector(u)
                                          and _is_vector(udot)):
            return None
        if len(q) != n or len(u) != o or len(udot) != o:
            return None
        y = np.concatenate((q, u), dtype=float)
        ru = (np.concatenate((inputs(t, y), udot), dtype=float) if k
              else np.asarray(udot, dtype=float))
        if not math.isfinite(sum(y.tolist()) + sum(ru.tolist())):
            return None  # nan or inf (or huge values): the general way
        return fn(t, y, params, ru)[0]

    point = model._fn.get("inverse_point")  # C: the checks and the call in one step
    if point is None:
        return checked

    def one(t, q, u, udot):
        tau = point(t, q, u, udot, params)
        return tau if tau is not None else checked(t, q, u, udot)

    return one


def _point(fn, model, t, y, ru, p, m):
    """One point; ``ru``: the inputs' values then all rates (dependent ones zero)."""
    if not m:
        return fn(t, y, model._p, ru)[0]
    tau, B, K, fa = fn(t, y, model._p, ru)
    o = K.shape[1]
    udot = ru[len(ru) - o:]
    ru = ru.copy()
    ru[len(ru) - m:] = np.linalg.solve(K[:, p:], -(fa + K[:, :p] @ udot[:p]))
    tau = fn(t, y, model._p, ru)[0]
    Ar = -np.linalg.solve(B[:, p:], B[:, :p])
    return tau[:p] + Ar.T @ tau[p:]


def _batch(fn, model, t, Y, R, U, p, m):
    if not m:
        return fn(t, Y, model._p, np.vstack([R, U]))[0]
    tau, B, K, fa = fn(t, Y, model._p, np.vstack([R, U]))
    K, B = np.moveaxis(K, -1, 0), np.moveaxis(B, -1, 0)
    rhs = -(fa.T + (K[:, :, :p] @ U[:p].T[:, :, None])[..., 0])
    U = U.copy()
    U[p:] = np.linalg.solve(K[:, :, p:], rhs[..., None])[..., 0].T
    tau = fn(t, Y, model._p, np.vstack([R, U]))[0]
    X = np.linalg.solve(B[:, :, p:], B[:, :, :p])  # -A_r
    return tau[:p] - (np.swapaxes(X, 1, 2) @ tau[p:].T[:, :, None])[..., 0].T
