r"""The nonlinear program of a transcribed optimal control problem.

:class:`CollocationNLP` gives what an NLP solver asks for (:mod:`._solvers`):
bounds, the objective and its gradient, the constraints, the pattern and the
values of their sparse Jacobian.  Its constraint rows, in order:

1. the dynamics' defects, ``(N - 1) * n_rows`` (:class:`._transcription.Defects`;
   with Hermite-Simpson and LGR those of :class:`._interval.IntervalDefects`);
2. the path constraints, one row per point each: the N nodes, then (with
   Hermite-Simpson and LGR) the interior points;
3. for a model with constraints, the configuration and velocity constraint
   residuals :math:`[h(q_k);\ c(q_k, u_k)]` at every point (the dependent
   states are then not collocated: they follow from these);
4. the instance constraints, one row each.

The dynamics and their exact derivatives (``model.jacobians`` on every stage
point in one call) are evaluated once per decision vector and shared by the
constraints, the Jacobian and the objective.  With a free duration the
derivative :math:`\partial f/\partial t` of an explicitly time-dependent model
is taken by central differences of ``f`` (the only derivative not generated;
exactly zero for an autonomous model, which with ``hessian="exact"``, whose
generated code tells, is not evaluated); so it is when the start time is a
variable (a phase of a :class:`._multiphase.MultiphaseProblem` after a free
duration).
"""

from __future__ import annotations

import numpy as np

from .._errors import ModelError
from ._transcription import Layout, defects_for

__all__ = ["CollocationNLP", "largest_violation", "violations", "index_arrays"]

INFINITY = 1e20  # IPOPT's "no bound" beyond 1e19

#: a decision vector of at most this many bytes is compared with the held
#: one as bytes (two copies: quicker at this size than an array of entries)
KEY_BYTES_COMPARED = 1 << 16

#: the integer type of the sparse patterns' rows and columns: IPOPT's
#: ``Index`` (a 32-bit C int), half the size of NumPy's default int64
INDEX = np.int32


def _finite(bound):
    return np.clip(np.asarray(bound, dtype=float), -INFINITY, INFINITY)


def check_index_range(n_rows, n_cols):
    """Refuse a matrix of ``n_rows`` x ``n_cols`` whose indices do not fit
    :data:`INDEX` (:class:`ModelError`, naming its size)."""
    limit = int(np.iinfo(INDEX).max)
    if max(n_rows, n_cols) > limit:
        raise ModelError(f"the NLP's matrix of {n_rows} x {n_cols} is too large for IPOPT's "
                         f"32-bit indices (at most {limit}); use fewer nodes")


def index_arrays(rows, cols, n_rows, n_cols):
    """A sparse pattern ``(rows, cols)`` joined from pieces into arrays of
    :data:`INDEX`, without a full-size int64 copy in between.

    Parameters
    ----------
    rows, cols : sequence of integer arrays
        The pieces, in order (each row piece as long as its column piece).
    n_rows, n_cols : int
        The matrix's shape, checked against the index type's range.
    """
    check_index_range(n_rows, n_cols)
    return (np.concatenate(rows, dtype=INDEX, casting="same_kind"),
            np.concatenate(cols, dtype=INDEX, casting="same_kind"))


def _joined(parts):
    """The pieces of a callback's vector joined, a single piece as it is
    (each piece a new array: not copied once more)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


class CollocationNLP:
    """The NLP of ``problem`` (an :class:`OptimalControlProblem`).

    ``start_time``: where it starts, s (default: the problem's); with
    ``free_start_time`` the start time is the decision vector's last entry
    instead (a phase of a multiphase problem). ``hessian``: ``"exact"`` for
    the Lagrangian's Hessian from the second derivatives (:mod:`._hessian`).

    The bounds ``x_lower``, ``x_upper`` (n,) and ``g_lower``, ``g_upper``
    (m,) (beyond 1e19 none, as IPOPT reads them) are made when read, not
    held: a solver reads them once and keeps what it needs.
    """

    #: ``jacobian`` and ``hessian`` give a new array at each call (the
    #: interior point takes the fixed variables' entries out of it in place)
    returns_new_arrays = True

    def __init__(self, problem, start_time=None, free_start_time=False,
                 hessian="limited-memory"):
        self.problem = pb = problem
        self.start_time = pb.start_time if start_time is None else float(start_time)
        self.layout = L = Layout.of(pb, free_start_time)
        self.defects = defects_for(pb.method, L, pb.collocated_rows, pb.degree)
        self.n = L.n_variables
        #: split_interior's empty arrays when the layout has no interior points
        self._no_interior = (np.zeros((0, L.n_states)), np.zeros((0, L.n_inputs)))
        for a in self._no_interior:
            a.flags.writeable = False
        self._cache_key = None
        self._models = {}
        self.n_residuals = pb.n_residuals
        self._instance_columns = [self._instance_column_indices(inst) for inst in pb.instances]
        self.m = (self.defects.n_rows + L.n_points * (len(pb.path) + pb.n_residuals)
                  + len(pb.instances))
        check_index_range(self.m, self.n)  # refused here, not when a solver asks
        #: the exact Hessian of the Lagrangian (:mod:`._hessian`), or ``None``
        self.exact_hessian = None
        #: the model names no time: its df/dt is zero, not taken by differences
        self._timeless = False
        if hessian == "exact":
            from ..numerics import names_time
            from ._hessian import LagrangianHessian
            self.exact_hessian = LagrangianHessian(self)
            self._timeless = not names_time(pb.model)

    # ------------------------------------------------------------ layout
    def _instance_column_indices(self, inst):
        """The decision variables an instance constraint names: its points'
        states and inputs, the free parameters, a free duration."""
        L = self.layout
        c = [L.state_index(k, j) if kind == "state" else L.input_index(k, j)
             for kind, j, k in inst.at]
        c += [L.free_start + j for j in range(L.n_free)]
        if L.free_duration:
            c.append(L.duration_index)
        return np.array(c)

    def jacobian_structure(self):
        """``(rows, cols)`` of the constraint Jacobian's entries, :data:`INDEX`
        (made when asked, not held: a solver keeps its own)."""
        pb, L = self.problem, self.layout
        ns, nf, K = L.n_states, L.n_free, L.n_points
        rows, cols = self.defects.pattern()
        start = self.defects.n_rows
        point = np.arange(K)[:, None]
        y_cols, r_cols = L.point_columns()
        # path constraints: dense in y_k, r_k, p, T, t0
        for _ in pb.path:
            c = [y_cols, r_cols, np.broadcast_to(L.free_start + np.arange(nf), (K, nf))]
            if L.free_duration:
                c.append(np.full((K, 1), L.duration_index))
            if L.free_start_time:
                c.append(np.full((K, 1), L.start_index))
            c = np.concatenate(c, axis=1)
            rows.append(np.broadcast_to(start + point, c.shape).ravel())
            cols.append(c.ravel())
            start += K
        # constraint residuals at every point: dense in y_k
        if pb.n_residuals:
            nc = pb.n_residuals
            r = start + point[:, :, None] * nc + np.arange(nc)[None, :, None]
            c = y_cols[:, None, :]
            shape = (K, nc, ns)
            rows.append(np.broadcast_to(r, shape).ravel())
            cols.append(np.broadcast_to(c, shape).ravel())
            start += K * nc
        # instance constraints
        for c in self._instance_columns:
            rows.append(np.full(len(c), start))
            cols.append(c)
            start += 1
        return index_arrays(rows, cols, self.m, self.n)

    @property
    def x_lower(self):
        return self._variable_bounds()[0]

    @property
    def x_upper(self):
        return self._variable_bounds()[1]

    @property
    def g_lower(self):
        return self._row_bounds()[0]

    @property
    def g_upper(self):
        return self._row_bounds()[1]

    def _variable_bounds(self):
        """``(lower, upper)`` of the decision variables, shapes (n,)."""
        pb, L = self.problem, self.layout
        N = L.nodes
        lo = np.empty(self.n)
        hi = np.empty(self.n)
        sb, ib = pb.state_bounds, pb.input_bounds
        lo[:L.input_start] = np.tile(sb[:, 0], N)
        hi[:L.input_start] = np.tile(sb[:, 1], N)
        lo[L.input_start:L.free_start] = np.tile(ib[:, 0], N)
        hi[L.input_start:L.free_start] = np.tile(ib[:, 1], N)
        lo[L.free_start:L.free_start + L.n_free] = pb.free_bounds[:, 0]
        hi[L.free_start:L.free_start + L.n_free] = pb.free_bounds[:, 1]
        if L.free_duration:
            lo[L.duration_index], hi[L.duration_index] = pb.duration_bounds
        if L.n_interior:
            K = L.n_interior
            inner_inputs = L.interior_start + K * L.n_states
            lo[L.interior_start:inner_inputs] = np.tile(sb[:, 0], K)
            hi[L.interior_start:inner_inputs] = np.tile(sb[:, 1], K)
            lo[inner_inputs:inner_inputs + K * L.n_inputs] = np.tile(ib[:, 0], K)
            hi[inner_inputs:inner_inputs + K * L.n_inputs] = np.tile(ib[:, 1], K)
        if L.free_start_time:
            lo[L.start_index], hi[L.start_index] = -np.inf, np.inf
        for k, values in ((0, pb.initial), (N - 1, pb.final)):
            for j, value in values.items():
                lo[L.state_index(k, j)] = hi[L.state_index(k, j)] = value
        return _finite(lo), _finite(hi)

    def _row_bounds(self):
        """``(lower, upper)`` of the rows, shapes (m,)."""
        pb, L = self.problem, self.layout
        n_defects = self.defects.n_rows
        g_lo, g_hi = [np.zeros(n_defects)], [np.zeros(n_defects)]
        K = L.n_points
        for path in pb.path:
            g_lo.append(np.full(K, path.lower))
            g_hi.append(np.full(K, path.upper))
        g_lo.append(np.zeros(K * pb.n_residuals))
        g_hi.append(np.zeros(K * pb.n_residuals))
        for inst in pb.instances:
            g_lo.append([inst.lower])
            g_hi.append([inst.upper])
        return _finite(np.concatenate(g_lo)), _finite(np.concatenate(g_hi))

    # --------------------------------------------------------- evaluation
    def _model(self, P):
        """The model with the free parameters ``P`` (the auxiliary variables,
        which it does not contain, left out)."""
        pb = self.problem
        n = len(pb.free_columns)
        if not n:
            return pb.model
        key = tuple(float(v) for v in P[:n])
        model = self._models.get(key)
        if model is None:
            if len(self._models) > 8:
                self._models.clear()
            model = pb.model.with_constants(dict(zip(pb.symbols.free, key)))
            self._models[key] = model
        return model

    def _evaluate(self, z):
        """Everything at ``z``, computed once per decision vector."""
        z = np.asarray(z, dtype=float)
        held = self._cache_key
        # the same point to the bit (its own copy is the key: the caller may
        # write to its array later); a short vector's bytes are compared (no
        # array of the entries' comparisons), a long one's without copies
        if held is not None and held.shape == z.shape and (
                held.tobytes() == z.tobytes() if z.nbytes <= KEY_BYTES_COMPARED
                else (held.view(np.uint64) == z.view(np.uint64)).all()):
            return self._cache
        self.forget_evaluation()  # the last point's arrays not held with the new ones
        z = z.copy()  # the key, and the views below
        pb, L = self.problem, self.layout
        Y, R, P, T = L.split(z, pb.duration_value)
        Yi, Ri = L.split_interior(z) if L.interior else self._no_interior
        t0 = L.start_time(z, self.start_time)
        h = T / (L.nodes - 1)
        model = self._model(P)
        free_columns = pb.free_columns
        evaluated, rates, lagrange = [], [], []
        for t, Ys, Rs in self.defects.points(t0, h, Y, R, Yi, Ri):
            J = model.jacobians(t, Ys, r=Rs, parameters=bool(free_columns))
            Pf = None
            if L.n_free:  # the auxiliary variables' columns (last) are zero
                Pf = np.zeros(J.f.shape + (L.n_free,))
                if free_columns:
                    Pf[..., :len(free_columns)] = J.parameters[:, :, free_columns]
            evaluated.append((J.f, J.state, J.inputs, Pf, J.constraints))
            if L.free_duration or L.free_start_time:
                rates.append(np.zeros_like(J.f) if self._timeless
                             else self._time_rate(model, t, Ys, Rs, T))
            if pb.lagrange is not None:
                lagrange.append(pb.lagrange(t, Ys, Rs, P, T))
        point_constraints = None
        if pb.n_residuals:
            group = self.defects.point_group
            if group is not None:  # a group that holds every point
                point_constraints = evaluated[group][4]
            else:
                point_constraints = model.jacobians(t0 + h * np.arange(L.nodes), Y,
                                                    r=R).constraints
        self._cache_key, self._cache = z, dict(
            z=z, Y=Y, R=R, P=P, T=T, t0=t0, h=h, model=model, Yi=Yi, Ri=Ri,
            Yp=np.concatenate([Y, Yi]) if len(Yi) else Y,
            Rp=np.concatenate([R, Ri]) if len(Ri) else R,
            evaluated=[e[:4] for e in evaluated], rates=rates or None, lagrange=lagrange,
            point_constraints=point_constraints)
        return self._cache

    def forget_evaluation(self):
        """Drop what :meth:`_evaluate` keeps of the last decision vector (a
        few arrays per point; the next call evaluates again)."""
        self._cache_key = self._cache = None

    @staticmethod
    def _time_rate(model, t, Y, R, T):
        delta = 1e-6 * max(1.0, abs(float(T)))
        up = model.jacobians(t + delta, Y, r=R).f
        down = model.jacobians(t - delta, Y, r=R).f
        return (up - down) / (2 * delta)

    def _point_times(self, e):
        """Every point's time, (n_points,), of the evaluation ``e`` (made on
        the first call and kept with it)."""
        t = e.get("t_points")
        if t is None:
            t = e["t_points"] = e["t0"] + e["T"] * self.layout.positions()
        return t

    # ---------------------------------------------------------- objective
    def objective(self, z):
        e = self._evaluate(z)
        pb = self.problem
        value = 0.0
        if pb.lagrange is not None:
            value += self.defects.quadrature(e["h"], e["lagrange"])
        if pb.mayer is not None:
            value += float(self._mayer(e)[0][0])
        return value

    def _mayer(self, e):
        tf = e["t0"] + e["T"]
        return self.problem.mayer(np.array([tf]), e["Y"][-1:], e["R"][-1:], e["P"], e["T"])

    def gradient(self, z):
        e = self._evaluate(z)
        pb, L = self.problem, self.layout
        N, ns, nr, K = L.nodes, L.n_states, L.n_inputs, L.n_interior
        if pb.lagrange is not None:
            gY, gR, gYi, gRi, gP, gT, gt0 = self.defects.quadrature_gradient(
                e["h"], e["lagrange"])
        else:
            gY, gR, gYi, gRi = np.zeros((N, ns)), np.zeros((N, nr)), None, None
            gP, gT, gt0 = np.zeros(L.n_free), 0.0, 0.0
        if gYi is None and K:
            gYi, gRi = np.zeros((K, ns)), np.zeros((K, nr))
        if pb.mayer is not None:
            _, d_t, d_y, d_r, d_p, d_T = self._mayer(e)
            gY[-1] += d_y[0]
            gR[-1] += d_r[0]
            gP += d_p[0]
            gT += d_t[0] + d_T[0]
            gt0 += d_t[0]
        return L.join(gY, gR, gP, gT, gYi, gRi, gt0)

    # -------------------------------------------------------- constraints
    def constraints(self, z):
        e = self._evaluate(z)
        pb = self.problem
        parts = [self.defects.values(e["Y"], e["h"], e["evaluated"], e["Yi"], e["R"], e["Ri"])]
        t = self._point_times(e) if pb.path or pb.n_residuals else None
        for path in pb.path:
            parts.append(path.term(t, e["Yp"], e["Rp"], e["P"], e["T"])[0])
        if pb.n_residuals:
            model = e["model"]
            parts.append(np.concatenate([model.constraint_residuals(tk, yk)
                                         for tk, yk in zip(t, e["Yp"])]))
        for inst in pb.instances:
            parts.append([inst.value(self._instance_arguments(inst, e))])
        return _joined(parts)

    def _instance_arguments(self, inst, e):
        values = [e["Y"][k, j] if kind == "state" else e["R"][k, j] for kind, j, k in inst.at]
        return np.concatenate([values, e["P"], [e["T"]]])

    def jacobian(self, z):
        e = self._evaluate(z)
        pb, L = self.problem, self.layout
        parts = [self.defects.jacobian(e["h"], e["T"], e["evaluated"], e["rates"])]
        t = self._point_times(e) if pb.path else None
        for path in pb.path:
            _, d_t, d_y, d_r, d_p, d_T = path.term(t, e["Yp"], e["Rp"], e["P"], e["T"])
            block = [d_y, d_r, d_p]
            if L.free_duration:
                block.append((d_t * L.positions() + d_T)[:, None])
            if L.free_start_time:
                block.append(d_t[:, None])
            parts.append(np.concatenate(block, axis=1).ravel())
        if pb.n_residuals:
            parts.append(e["point_constraints"].ravel())
        for inst in pb.instances:
            grad = inst.gradient(self._instance_arguments(inst, e))
            if not L.free_duration:
                grad = grad[:-1]
            parts.append(grad)
        return _joined(parts)

    def hessian_structure(self):
        """Lower triangle of the Lagrangian's Hessian (``hessian="exact"``)."""
        return self.exact_hessian.structure()

    def hessian(self, z, multipliers, objective_factor):
        """The Hessian's values at ``z`` (IPOPT's ``obj_factor`` and ``lambda``)."""
        return self.exact_hessian.values(z, objective_factor, multipliers)

    # ---------------------------------------------------------- reporting
    def violation(self, z):
        """Largest violation of a constraint or a bound at ``z``."""
        return largest_violation(self, z)


def violations(nlp, z):
    """``(rows, bounds)``: each row's and each variable's violation of its
    bounds at ``z`` (0 where satisfied), shapes (m,) and (n,), in the units
    of the row or the variable."""
    z = np.asarray(z, dtype=float)
    g = nlp.constraints(z)
    rows = np.maximum(np.maximum(nlp.g_lower - g, g - nlp.g_upper), 0.0)
    bounds = np.maximum(np.maximum(nlp.x_lower - z, z - nlp.x_upper), 0.0)
    return rows, bounds


def largest_violation(nlp, z):
    """Largest violation of a constraint or a bound of ``nlp`` at ``z``."""
    rows, bounds = violations(nlp, z)
    return float(max(np.max(rows, initial=0.0), np.max(bounds, initial=0.0)))
