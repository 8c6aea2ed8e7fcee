r"""Linearization of constrained equations of motion about any operating point.

With coordinates :math:`q = [q_i; q_d]`, speeds :math:`u = [u_i; u_d]`, inputs
:math:`r` and the operating point :math:`(q^*, u^*, r^*)`:

* configuration constraints :math:`h(q)=0` give :math:`\delta q = P_q\,\delta q_i`;
* velocity constraints :math:`B(q)u + b(q) = 0` give
  :math:`\delta u = P_u\,\delta u_i + P_{uq}\,\delta q_i`;
* Kane's reduced equations :math:`R(q)\,E = 0`, :math:`E = M\dot u - f`,
  :math:`R = [I\;\, A_r^T]`, vary as :math:`R\,(\delta E - \partial_q(B^T\lambda^*)
  \,\delta q) = 0`, where :math:`E^* = B^T\lambda^*` is the unreduced residual at
  the operating point (generally non-zero: it carries the constraint forces);
  together with the varied acceleration constraints this gives
  :math:`S\,\delta\dot u = -(D_q\delta q + D_u\delta u + D_r\delta r)`.

Here :math:`\lambda^* = B_{dep}^{-T} E^*_{dep}`, so that
:math:`-R\,\partial_q(B^T\lambda^*)` is exactly :math:`(\partial_q R)\,E^*`:
the result is the exact derivative of the reduced equations for any
accelerations :math:`\dot u^*`.  These are computed from the equations of motion
(the operating point need not be an equilibrium), or taken from the operating
point when it gives them, as SymPy's ``Linearizer`` does (it substitutes the
operating point's :math:`\dot u` into the terms proportional to them).  All
derivatives are exact (forward differentiation of the equations' program); the
numerical linear algebra pivots, so the order in which constraints are given
does not matter.  Results have SymPy's forms: ``(A, B, r)`` with
:math:`\delta\dot x_i = A\,\delta x_i + B\,\delta r`, :math:`x_i = [q_i; u_i]`,
or ``(M, A, B, r)`` of the implicit form
:math:`M\,[\delta\dot q; \delta\dot u] = A\,\delta x_i + B\,\delta r`
(rows: kinematic equations, acceleration constraints, reduced dynamic
equations; see :func:`linearize_symbolic`).
"""

from __future__ import annotations

import warnings

import numpy as np
import sympy as sm

from .backends._python import compile_python, generate_python
from .._errors import ConstraintError
from ..engine import name_of

__all__ = ["linearize_numeric", "linearize_symbolic", "linearization_terms",
           "linearize_compiled"]


class _Terms:
    """Symbolic Jacobians needed for linearization (compact expressions).

    ``inputs`` are the internal symbols of the specified inputs that become
    columns of B.
    """

    def __init__(self, eom, inputs):
        prog = eom._program
        table = eom._table
        q, u = list(table.q), list(table.u)
        o, m = len(u), len(eom.u_dep)
        inputs = list(inputs)
        self.inputs_ext = [table.external(s) for s in inputs]
        self.w = [sm.Dummy(f"w{k}") for k in range(o)]  # udot at the op point
        self.mu = [sm.Dummy(f"mu{k}") for k in range(m)]  # multipliers at the op point
        force = [a - b for a, b in zip(eom._active, eom._remainder)]
        E = [sum((eom._mass[r][s] * self.w[s] for s in range(o)), sm.S.Zero) - force[r]
             - sum((eom._vel_B[c][r] * self.mu[c] for c in range(m)), sm.S.Zero)
             for r in range(o)]
        acc = [sum((eom._acc_K[c][s] * self.w[s] for s in range(o)), sm.S.Zero)
               + eom._acc_f[c] for c in range(m)]
        vel = list(eom._vel_c)
        J = prog.jacobian
        self.outputs = {
            "g_q": J(eom._qdot, q), "g_u": J(eom._qdot, u), "g_r": J(eom._qdot, inputs),
            "h_q": J(eom._config, q),
            "c_q": J(vel, q), "B": sm.Matrix(eom._vel_B) if m else sm.zeros(0, o),
            "E_q": J(E, q), "f_u": J(force, u), "f_r": J(force, inputs),
            "a_q": J(acc, q), "a_u": J(acc, u),
            "S_M": sm.Matrix(eom._mass), "K_a": sm.Matrix(eom._acc_K) if m else sm.zeros(0, o),
        }
        self.inputs = inputs


def linearization_terms(eom, inputs=None):
    """Cached :class:`_Terms` of an EquationsOfMotion.

    ``inputs`` defaults to every specified input that is not a derivative.
    """
    if inputs is None:  # sorted as SymPy sorts its r
        found = [(ext, int_) for ext, int_ in eom._table.specified.items()
                 if not isinstance(ext, sm.Derivative) and ext in eom.specified]
        inputs = [int_ for _, int_ in sorted(found, key=lambda e: sm.default_sort_key(e[0]))]
    cache = eom.__dict__.setdefault("_linearization_cache", {})
    key = tuple(inputs)
    if key not in cache:
        cache[key] = _Terms(eom, inputs)
    return cache[key]


# ------------------------------------------------------------- linear algebra
class _NumpyAlgebra:
    @staticmethod
    def solve(A, B):
        return np.linalg.solve(A, B)

    @staticmethod
    def vstack(*blocks):
        return np.vstack(blocks)

    @staticmethod
    def hstack(*blocks):
        return np.hstack(blocks)

    @staticmethod
    def eye(n):
        return np.eye(n)

    @staticmethod
    def zeros(r, c):
        return np.zeros((r, c))


class _SympyAlgebra:
    """SymPy matrices; ``solver`` as SymPy's ``linear_solver`` ("LU", another
    method name of ``Matrix.solve``, or a callable ``f(A, b)``)."""

    def __init__(self, solver="LU"):
        if callable(solver):
            self.solve = solver
        elif solver == "LU":
            self.solve = lambda A, B: A.LUsolve(B)
        elif isinstance(solver, str):
            self.solve = lambda A, B: A.solve(B, method=solver)
        else:
            raise ValueError(f"linear_solver must be a method name or a callable, "
                             f"got {solver!r}")

    @staticmethod
    def vstack(*blocks):
        return sm.Matrix.vstack(*blocks)

    @staticmethod
    def hstack(*blocks):
        return sm.Matrix.hstack(*blocks)

    @staticmethod
    def eye(n):
        return sm.eye(n)

    @staticmethod
    def zeros(r, c):
        return sm.zeros(r, c)


def _assemble(v, dims, la, names, implicit=False):
    r"""Linearized equations from evaluated Jacobians ``v`` (dict of matrices).

    Returns ``(A, B)`` of :math:`\delta\dot x_i = A\,\delta x_i + B\,\delta r`,
    or with ``implicit`` SymPy's ``(M, A, B)`` of
    :math:`M [\delta\dot q; \delta\dot u] = A\,\delta x_i + B\,\delta r`.
    """
    n, l, o, m, s = dims
    p = o - m
    ni = n - l
    if l:
        hd = v["h_q"][:, ni:]
        _check_rank(hd, l, "configuration constraints", names["q_dep"], la)
        P_q = la.vstack(la.eye(ni), -la.solve(hd, v["h_q"][:, :ni]))
    else:
        P_q = la.eye(n)
    if m:
        Bd = v["B"][:, p:]
        _check_rank(Bd, m, "velocity constraints", names["u_dep"], la)
        Bi = v["B"][:, :p]
        P_u = la.vstack(la.eye(p), -la.solve(Bd, Bi))
        P_uq = la.vstack(la.zeros(p, ni), -la.solve(Bd, v["c_q"] @ P_q))
        Ar_T = (-la.solve(Bd, Bi)).T
        R = la.hstack(la.eye(p), Ar_T)
    else:
        P_u = la.eye(o)
        P_uq = la.zeros(o, ni)
        R = la.eye(o)
    dqd_q = v["g_q"] @ P_q + v["g_u"] @ P_uq
    dqd_u = v["g_u"] @ P_u
    if implicit:
        # rows as SymPy's Linearizer: kinematic (n), acceleration constraints
        # (m), reduced dynamic equations (p); columns of M: q' then u'
        M = la.vstack(la.hstack(la.eye(n), la.zeros(n, o)),
                      la.hstack(la.zeros(m, n), v["K_a"]),
                      la.hstack(la.zeros(p, n), -(R @ v["S_M"])))
        A = la.vstack(la.hstack(dqd_q, dqd_u),
                      la.hstack(-(v["a_q"] @ P_q + v["a_u"] @ P_uq), -(v["a_u"] @ P_u)),
                      la.hstack(R @ v["E_q"] @ P_q - R @ v["f_u"] @ P_uq,
                                -(R @ v["f_u"] @ P_u)))
        B = (la.vstack(v["g_r"], la.zeros(m, s), -(R @ v["f_r"])) if s
             else la.zeros(n + o, 0))
        return M, A, B
    S = la.vstack(R @ v["S_M"], v["K_a"])
    D_q = la.vstack(R @ v["E_q"], v["a_q"])
    D_u = la.vstack(-(R @ v["f_u"]), v["a_u"])
    D_r = la.vstack(-(R @ v["f_r"]), la.zeros(m, s))
    dud_q = -la.solve(S, D_q @ P_q + D_u @ P_uq)
    dud_u = -la.solve(S, D_u @ P_u)
    dud_r = -la.solve(S, D_r) if s else la.zeros(o, 0)
    A = la.vstack(la.hstack(dqd_q[:ni, :], dqd_u[:ni, :]),
                  la.hstack(dud_q[:p, :], dud_u[:p, :]))
    B = la.vstack(v["g_r"][:ni, :], dud_r[:p, :]) if s else la.zeros(ni + p, 0)
    return A, B


def _check_rank(matrix, k, what, names, la):
    if isinstance(matrix, np.ndarray):
        singular = np.linalg.matrix_rank(matrix) < k
    else:
        singular = matrix.rank() < k
    if singular:
        raise ConstraintError(
            f"cannot linearize: the {what} cannot be solved for "
            f"{', '.join(names)} at the operating point (singular Jacobian); "
            "choose other dependent variables or another operating point")


def _names(eom):
    return {"q_dep": [name_of(s) for s in eom.q_dep],
            "u_dep": [name_of(s) for s in eom.u_dep]}


def _dims(eom, terms):
    return (len(eom.q), len(eom.q_dep), len(eom.u), len(eom.u_dep), len(terms.inputs))


# ----------------------------------------------------------------- numeric
def linearize_numeric(model, y, t=0.0, r=None, udot=None, implicit=False):
    r"""A and B of a :class:`NumericModel` about the state ``y``.

    Parameters
    ----------
    model : NumericModel
    y : array_like
        Operating point ``[q, u]``; dependent entries must satisfy the
        constraints (see :meth:`NumericModel.consistent_state`).
    t : float
    r : array_like, optional
        Values of the model's specified inputs (non-derivative ones) at the
        operating point; by default their providers are evaluated at ``(t, y)``.
    udot : array_like, optional
        Accelerations :math:`\dot u` at the operating point, all ``n_u`` of
        them or the independent ones (the dependent ones then follow from the
        acceleration constraints); by default they are computed from the
        equations of motion.  Given values are used as given (as SymPy's
        ``Linearizer`` does); a warning tells when they do not satisfy the
        equations of motion.
    implicit : bool
        Return SymPy's implicit form ``(M, A, B, r)`` instead.

    Returns
    -------
    A : ndarray, shape (n_q - n_q_dep + n_u - n_u_dep,) * 2
    B : ndarray
    r : list of str
        Names of the inputs (columns of B).
    """
    eom = getattr(model, "_eom", None)
    if eom is None:
        raise ValueError("this model was unpickled without its equations; "
                         "linearize it from EquationsOfMotion.numeric(...)")
    table = eom._table
    runtime = [s for s, _ in model._inputs]
    inputs = [s for s in runtime if not isinstance(table.external(s), sm.Derivative)]
    terms = linearization_terms(eom, inputs)
    fn = model.__dict__.get("_linearization_fn")
    if fn is None:
        fn = _compile_terms(model, eom, terms)
        model._linearization_fn = fn
    y = _operating_point(model, t, y)
    o, m = model.n_u, model.n_u_dep
    rt = list(model._r(t, y))
    if r is not None:
        rt = _override_inputs(model, terms, rt, r)
    # accelerations and multipliers at the operating point
    qd, mass, force, vel_B, acc_K, acc_f = model._fn["dynamics"](t, y, model._p, rt)
    M, f = model._assemble(mass, force, vel_B, acc_K, acc_f)
    if udot is None:
        udot = np.linalg.solve(M, f)
    else:
        udot = _given_accelerations(np.atleast_1d(np.asarray(udot, dtype=float)),
                                    acc_K, acc_f, o, m, eom)
        residual = M @ udot - f
        scale = max(1.0, float(np.max(np.abs(f))), float(np.max(np.abs(M @ udot))))
        if np.max(np.abs(residual)) > 1e-8 * scale:
            warnings.warn(
                "the accelerations of the operating point do not satisfy the equations "
                f"of motion (largest residual {np.max(np.abs(residual)):.3g}); they are "
                "used as given, as SymPy's Linearizer does", RuntimeWarning, stacklevel=3)
    E = mass @ udot - force
    mu = np.linalg.solve(vel_B[:, o - m:].T, E[o - m:]) if m else np.zeros(0)
    values = fn(t, y, model._p, list(rt) + list(udot) + list(mu))
    v = dict(zip(_OUTPUT_ORDER, values))
    names = [name_of(s) for s in terms.inputs_ext]
    out = _assemble(v, _dims(eom, terms), _NumpyAlgebra, _names(eom), implicit=implicit)
    return (*out, names)


def linearize_compiled(model, y, t=0.0, r=None):
    r"""``(A, B, r)`` of :func:`linearize_numeric` from :meth:`NumericModel.jacobians`
    (the model's backend, C where it has one), or ``None`` where that does
    not apply (no exact derivatives, or inputs that are derivatives).

    :math:`A = F P`: the rows of the independent states of the full-state
    derivative :math:`\partial f/\partial y`, times the variations of all
    states that keep the constraints, :math:`\delta y = P\,\delta x_i`
    (from :math:`\partial h/\partial q` and :math:`\partial c/\partial (q, u)`).
    """
    from ._jacobians import derivatives_unavailable
    eom = getattr(model, "_eom", None)
    if derivatives_unavailable(model) or eom is None:
        return None
    table = eom._table
    if any(isinstance(table.external(s), sm.Derivative) for s, _ in model._inputs):
        return None
    y = _operating_point(model, t, y)
    if r is not None:
        r = np.atleast_1d(np.asarray(r, dtype=float))
        if r.size != len(model._inputs):
            raise ValueError(f"r must have {len(model._inputs)} entries "
                             f"({', '.join(model.input_names)})")
    J = model.jacobians(t, y, r=r)
    n, l, o, m = model.n_q, model.n_q_dep, model.n_u, model.n_u_dep
    ni, p = n - l, o - m
    names = _names(eom)
    h_q, c_y = J.constraints[:l, :n], J.constraints[l:]
    P_q = np.eye(n)[:, :ni]
    if l:
        _check_rank(h_q[:, ni:], l, "configuration constraints", names["q_dep"],
                    _NumpyAlgebra)
        P_q = np.vstack([np.eye(ni), -np.linalg.solve(h_q[:, ni:], h_q[:, :ni])])
    P_u, P_uq = np.eye(o), np.zeros((o, ni))
    if m:
        c_u = c_y[:, n:]
        _check_rank(c_u[:, p:], m, "velocity constraints", names["u_dep"], _NumpyAlgebra)
        P_u = np.vstack([np.eye(p), -np.linalg.solve(c_u[:, p:], c_u[:, :p])])
        P_uq = np.vstack([np.zeros((p, ni)), -np.linalg.solve(c_u[:, p:], c_y[:, :n] @ P_q)])
    P = np.block([[P_q, np.zeros((n, p))], [P_uq, P_u]])
    rows = list(range(ni)) + list(range(n, n + p))
    return (J.state[rows] @ P, J.inputs[rows],
            [name_of(table.external(s)) for s, _ in model._inputs])


def _operating_point(model, t, y):
    """``y`` as an array, refused where it does not satisfy the constraints."""
    y = model._check_y(y)
    res = model.constraint_residuals(t, y)
    if res.size and np.max(np.abs(res)) > 1e-8:
        raise ConstraintError(
            "the operating point does not satisfy the constraints (largest residual "
            f"{np.max(np.abs(res)):.3g}); use model.consistent_state(t, y) first")
    return y


def _given_accelerations(udot, acc_K, acc_f, o, m, eom):
    """All ``o`` accelerations from all of them or the ``o - m`` independent ones."""
    if udot.size == o:
        return udot
    if m and udot.size == o - m:
        p = o - m
        dep = np.linalg.solve(acc_K[:, p:], -(acc_f + acc_K[:, :p] @ udot))
        return np.concatenate([udot, dep])
    raise ValueError(f"udot must have {o} entries ({', '.join(map(name_of, eom.u))})"
                     + (f" or {o - m} (the independent ones)" if m else ""))


_OUTPUT_ORDER = ("g_q", "g_u", "g_r", "h_q", "c_q", "B", "E_q", "f_u", "f_r", "a_q",
                 "a_u", "S_M", "K_a")


def _compile_terms(model, eom, terms):
    """Generate the Jacobians for this model's constants and inputs."""
    prog = eom._program
    table = eom._table
    subs = model._substitutions
    runtime = [s for s, _ in model._inputs]
    const_by_name = {str(s): s for s in eom.constants}
    for value in subs.values():  # constants of exact input expressions (Omega * t)
        const_by_name.update((str(s), s) for s in value.free_symbols)
    const_syms = [const_by_name[k] for k in model._data["constants"]]
    outputs = []
    for key in _OUTPUT_ORDER:
        mat = terms.outputs[key]
        outputs.append((mat.shape, [prog.subs(e, subs) for e in mat]))
    args = {"y": list(table.q) + list(table.u), "p": const_syms,
            "r": runtime + terms.w + terms.mu}
    source = generate_python(prog, "linearization", args, outputs)
    return compile_python(source, "linearization")


def _override_inputs(model, terms, rt, r):
    r = list(np.atleast_1d(np.asarray(r, dtype=float)))
    if len(r) != len(terms.inputs):
        raise ValueError(f"r must have {len(terms.inputs)} entries "
                         f"({', '.join(map(str, terms.inputs_ext))})")
    runtime = [s for s, _ in model._inputs]
    out = list(rt)
    for sym, value in zip(terms.inputs, r):
        out[runtime.index(sym)] = value
    return out


# ---------------------------------------------------------------- symbolic
def _op_point_dict(op_point):
    if op_point is None:
        return {}
    if isinstance(op_point, dict):
        return dict(op_point)
    out = {}
    for d in op_point:
        out.update(d)
    return out


def _split_op_point(eom, op):
    r"""``(state values, {u: u' value})`` of an operating point.

    Keys are symbols or names (matched by name, never parsed).  Values of
    the coordinates' rates :math:`\dot q` are accepted and unused (the
    linearization follows them from :math:`\dot q = g(q, u)`, as SymPy's
    explicit kinematics does); accelerations of auxiliary speeds likewise.
    """
    t = eom._table.t
    by_name = {}
    for s in eom.q + eom.u + eom.u_aux:
        by_name[name_of(s)] = s
        by_name[name_of(s.diff(t))] = s.diff(t)
    for ext in eom._table.specified:
        by_name.setdefault(name_of(ext), ext)
    state, accelerations = {}, {}
    for key, value in op.items():
        if isinstance(key, str):
            if key not in by_name:
                import difflib
                close = difflib.get_close_matches(key, list(by_name), n=3)
                hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
                raise ValueError(f"{key!r} is not a coordinate, speed or input of this "
                                 f"model{hint}")
            key = by_name[key]
        if isinstance(key, sm.Derivative) and key.variables == (t,):
            f = key.expr
            if f in eom.u:
                accelerations[f] = value
                continue
            if f in eom.q or f in eom.u_aux:
                continue  # q' follows from (q, u); auxiliary speeds vanish
        state[key] = value
    return state, accelerations


def _as_value(value):
    """An operating-point value as a SymPy expression; text is never parsed."""
    if isinstance(value, str):
        raise ValueError(f"operating-point values must be numbers or SymPy expressions, "
                         f"not text ({value!r})")
    return sm.sympify(value, strict=True)


def linearize_symbolic(eom, op_point=None, A_and_B=True, constants=None, specified=None,
                       t=0.0, simplify=False, linear_solver="LU"):
    r"""Linearize :class:`EquationsOfMotion` about an operating point.

    Parameters
    ----------
    op_point : dict or iterable of dicts, optional
        ``{symbol or name: value}`` for coordinates, speeds, inputs and,
        optionally, the speeds' time derivatives :math:`\dot u` (as SymPy's
        ``KanesMethod.linearize`` takes them).  Given accelerations are used as
        given; without them they are computed from the equations of motion at
        the operating point.  With constraints, the independent speeds'
        accelerations suffice (the dependent ones follow from the acceleration
        constraints).  Rates :math:`\dot q` may be given and are unused.
    A_and_B : bool
        ``True``: ``(A, B, r)`` with
        :math:`\delta\dot x_i = A\,\delta x_i + B\,\delta r`,
        :math:`x_i = [q_{ind}; u_{ind}]`.  ``False``: SymPy's implicit form
        ``(M, A, B, r)`` with
        :math:`M\,[\delta\dot q; \delta\dot u] = A\,\delta x_i + B\,\delta r`:
        ``M`` is ``(n_q + n_u) x (n_q + n_u)``, ``A`` is
        ``(n_q + n_u) x (n_q - n_q_dep + n_u - n_u_dep)``, ``B`` is
        ``(n_q + n_u) x n_r``; rows are the kinematic equations, the
        acceleration constraints and the reduced dynamic equations, as
        SymPy's ``Linearizer`` orders them.  (SymPy's default is ``False``,
        kanedyn's ``True``.)
    constants : dict, optional
        With constants the result is numerical (NumPy arrays, ``r`` a list of
        names); the operating point must then give every independent
        coordinate and speed (dependent ones are completed from the
        constraints).  Without, it is symbolic (SymPy matrices, ``r`` a
        column matrix of the inputs sorted as SymPy sorts them; with no
        inputs ``B`` and ``r`` are empty 0 x 0 matrices, as SymPy's).
    specified : dict, optional
        Values of specified inputs (numerical path).
    simplify : bool
        Simplify the symbolic results (SymPy's option; can be slow).
    linear_solver : str or callable
        How the symbolic linear systems are solved (SymPy's option): "LU"
        (``Matrix.LUsolve``), another method of ``Matrix.solve``, or
        ``f(A, b)``.
    """
    op = _op_point_dict(op_point)
    state, accelerations = _split_op_point(eom, op)
    if constants is not None:
        return _linearize_with_constants(eom, state, accelerations, constants,
                                         specified or {}, t, implicit=not A_and_B)
    if specified:
        raise ValueError("specified= is used with constants= (numerical "
                         "linearization); for a symbolic result give the inputs' "
                         "values in op_point")
    out = _linearize_symbolic(eom, state, accelerations, not A_and_B,
                              _SympyAlgebra(linear_solver))
    if simplify:
        for mat in out[:-1]:
            mat.simplify()
    return out


def _linearize_with_constants(eom, state, accelerations, constants, specified, t,
                              implicit):
    model = eom.numeric(constants=constants, specified=specified)
    y = model.state(state, t, what="operating-point value")
    udot = None
    if accelerations:
        udot = _acceleration_list(eom, accelerations, lambda v: float(_as_value(v)))
    return linearize_numeric(model, y, t=t, udot=udot, implicit=implicit)


def _acceleration_list(eom, accelerations, convert):
    """The given accelerations in the order of ``eom.u`` (all or the independent)."""
    t = eom._table.t
    o, p = len(eom.u), len(eom.u_ind)
    for group in (eom.u, eom.u_ind):
        if all(s in accelerations for s in group):
            return [convert(accelerations[s]) for s in group]
    missing = [name_of(s.diff(t)) for s in eom.u_ind if s not in accelerations]
    raise ValueError(
        "the operating point gives some accelerations but not "
        + ", ".join(missing or [name_of(s.diff(t)) for s in eom.u[p:o]
                                if s not in accelerations])
        + "; give all of them (or those of the independent speeds), or none to "
        "have them computed from the equations of motion")


def _linearize_symbolic(eom, state, accelerations, implicit, la):
    terms = linearization_terms(eom)
    prog = eom._program
    table = eom._table
    mapping = {}
    for key, value in state.items():
        key = sm.sympify(key, strict=True)
        internal = table.internal(key, "operating point")
        if not internal.is_Symbol:
            raise ValueError(f"cannot use {key} as an operating-point variable")
        mapping[internal] = table.internal(_as_value(value), "operating point")
    o, m = len(eom.u), len(eom.u_dep)
    memo = dict(table._ext)

    def at_op(mat):
        return mat.applyfunc(lambda e: prog.expand(prog.subs(e, mapping), memo=memo))

    v = {key: at_op(mat) for key, mat in terms.outputs.items()}
    # accelerations and multipliers at the operating point
    mass = at_op(sm.Matrix(eom._mass))
    force = at_op(sm.Matrix([a - b for a, b in zip(eom._active, eom._remainder)]))
    if accelerations:
        given = sm.Matrix(_acceleration_list(eom, accelerations, _as_value))
        if given.rows < o:  # the dependent ones from the acceleration constraints
            p = o - m
            K, fa = v["K_a"], at_op(sm.Matrix(eom._acc_f))
            given = given.col_join(la.solve(K[:, p:], -(fa + K[:, :p] * given)))
        udot = given
    else:
        udot = la.solve(at_op(eom._compact_mass_matrix), at_op(eom._compact_forcing))
    E = mass * udot - force
    mu = la.solve(v["B"][:, o - m:].T, E[o - m:, :]) if m else sm.zeros(0, 1)
    sub = {table.external(w): val for w, val in zip(terms.w, udot)}
    sub.update({table.external(c): val for c, val in zip(terms.mu, mu)})
    v = {key: mat.xreplace(sub) for key, mat in v.items()}
    out = _assemble(v, _dims(eom, terms), la, _names(eom), implicit=implicit)
    r = sm.Matrix(terms.inputs_ext)
    if not terms.inputs:
        out = (*out[:-1], sm.Matrix())  # SymPy's empty B
    return (*out, r)
