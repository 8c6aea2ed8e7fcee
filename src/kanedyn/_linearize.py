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

The accelerations :math:`\dot u^*` at the operating point are computed from the
equations of motion (they need not be an equilibrium).  All derivatives are
exact (forward differentiation of the equations' program); the linear algebra is
numerical with pivoting, so the order in which constraints are given does not
matter.  The result has SymPy's form ``(A, B, r)`` with
:math:`\delta\dot x_i = A\,\delta x_i + B\,\delta r`, :math:`x_i = [q_i; u_i]`.
"""

from __future__ import annotations

import numpy as np
import sympy as sm

from ._codegen import compile_python, generate_python
from ._errors import ConstraintError
from ._symbols import name_of

__all__ = ["linearize_numeric", "linearize_symbolic", "linearization_terms"]


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
    if inputs is None:
        inputs = [int_ for ext, int_ in eom._table.specified.items()
                  if not isinstance(ext, sm.Derivative) and ext in eom.specified]
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
    @staticmethod
    def solve(A, B):
        return A.LUsolve(B)

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


def _assemble(v, dims, la, names):
    """A and B from evaluated Jacobians ``v`` (dict of matrices)."""
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
    S = la.vstack(R @ v["S_M"], v["K_a"])
    D_q = la.vstack(R @ v["E_q"], v["a_q"])
    D_u = la.vstack(-(R @ v["f_u"]), v["a_u"])
    D_r = la.vstack(-(R @ v["f_r"]), la.zeros(m, s))
    dud_q = -la.solve(S, D_q @ P_q + D_u @ P_uq)
    dud_u = -la.solve(S, D_u @ P_u)
    dud_r = -la.solve(S, D_r) if s else la.zeros(o, 0)
    dqd_q = v["g_q"] @ P_q + v["g_u"] @ P_uq
    dqd_u = v["g_u"] @ P_u
    A = la.vstack(la.hstack(dqd_q[:ni, :], dqd_u[:ni, :]),
                  la.hstack(dud_q[:p, :], dud_u[:p, :]))
    B = la.vstack(v["g_r"][:ni, :], dud_r[:p, :]) if s else la.zeros(ni + p, 0)
    return A, B


def _check_rank(matrix, k, what, names, la):
    if la is _NumpyAlgebra:
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
def linearize_numeric(model, y, t=0.0, r=None):
    """A and B of a :class:`NumericModel` about the state ``y``.

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
    y = model._check_y(y)
    res = model.constraint_residuals(t, y)
    if res.size and np.max(np.abs(res)) > 1e-8:
        raise ConstraintError(
            "the operating point does not satisfy the constraints (largest residual "
            f"{np.max(np.abs(res)):.3g}); use model.consistent_state(t, y) first")
    o, m = model.n_u, model.n_u_dep
    rt = list(model._r(t, y))
    if r is not None:
        rt = _override_inputs(model, terms, rt, r)
    # accelerations and multipliers at the operating point
    qd, mass, force, vel_B, acc_K, acc_f = model._fn["dynamics"](t, y, model._p, rt)
    M, f = model._assemble(mass, force, vel_B, acc_K, acc_f)
    udot = np.linalg.solve(M, f)
    E = mass @ udot - force
    mu = np.linalg.solve(vel_B[:, o - m:].T, E[o - m:]) if m else np.zeros(0)
    values = fn(t, y, model._p, list(rt) + list(udot) + list(mu))
    v = dict(zip(_OUTPUT_ORDER, values))
    A, B = _assemble(v, _dims(eom, terms), _NumpyAlgebra, _names(eom))
    return A, B, [name_of(s) for s in terms.inputs_ext]


_OUTPUT_ORDER = ("g_q", "g_u", "g_r", "h_q", "c_q", "B", "E_q", "f_u", "f_r", "a_q",
                 "a_u", "S_M", "K_a")


def _compile_terms(model, eom, terms):
    """Generate the Jacobians for this model's constants and inputs."""
    prog = eom._program
    table = eom._table
    subs = model._substitutions
    runtime = [s for s, _ in model._inputs]
    const_by_name = {str(s): s for s in eom.constants}
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


def linearize_symbolic(eom, op_point=None, A_and_B=True, constants=None, specified=None,
                       t=0.0):
    """Linearize :class:`EquationsOfMotion` (see :meth:`EquationsOfMotion.linearize`).

    With ``constants`` given, the result is numerical (NumPy arrays); the
    operating point must then give every independent coordinate and speed
    (dependent ones are completed from the constraints).  Without, it is
    symbolic (SymPy matrices, op-point values substituted; accelerations at
    the operating point are solved for symbolically).
    """
    op = _op_point_dict(op_point)
    if not A_and_B:
        raise NotImplementedError(
            "only A_and_B=True is supported: kanedyn returns (A, B, r) with "
            "x' = A x + B r over the independent states")
    if constants is not None:
        return _linearize_with_constants(eom, op, constants, specified or {}, t)
    return _linearize_symbolic(eom, op)


def _linearize_with_constants(eom, op, constants, specified, t):
    model = eom.numeric(constants=constants, specified=specified)
    y = model.state(op, t, what="operating-point value")
    return linearize_numeric(model, y, t=t)


def _linearize_symbolic(eom, op):
    terms = linearization_terms(eom)
    prog = eom._program
    table = eom._table
    mapping = {}
    for key, value in op.items():
        key = sm.sympify(key)
        internal = table.internal(key, "operating point")
        if not internal.is_Symbol:
            raise ValueError(f"cannot use {key} as an operating-point variable")
        mapping[internal] = table.internal(sm.sympify(value), "operating point")
    o, m = len(eom.u), len(eom.u_dep)

    def at_op(mat):
        return mat.applyfunc(lambda e: table.external(prog.expand(prog.subs(e, mapping))))

    v = {key: at_op(mat) for key, mat in terms.outputs.items()}
    # accelerations and multipliers at the operating point
    mass = at_op(sm.Matrix(eom._mass))
    force = at_op(sm.Matrix([a - b for a, b in zip(eom._active, eom._remainder)]))
    M = at_op(eom._compact_mass_matrix)
    f = at_op(eom._compact_forcing)
    udot = M.LUsolve(f)
    E = mass * udot - force
    mu = v["B"][:, o - m:].T.LUsolve(E[o - m:, :]) if m else sm.zeros(0, 1)
    sub = {table.external(w): val for w, val in zip(terms.w, udot)}
    sub.update({table.external(c): val for c, val in zip(terms.mu, mu)})
    v = {key: mat.xreplace(sub) for key, mat in v.items()}
    A, B = _assemble(v, _dims(eom, terms), _SympyAlgebra, _names(eom))
    return A, B, sm.Matrix(terms.inputs_ext)
