r"""Parameter identification: ``identify`` fits constants (and initial states)
of a numerical model to measured records by weighted least squares.

.. math::

    \min_{\theta}\ \tfrac12 \sum_{\text{records}}\sum_{c}\sum_i
        \Big(\frac{h_c(t_i;\theta) - d_{c,i}}{\sigma_c}\Big)^2,
    \qquad \theta = (p,\ y_0)

with :math:`h_c` a state or the rate of a state along the model's trajectory.

The trajectory and its derivatives :math:`\partial y(t_i)/\partial\theta` come
from one integration of the state with its forward sensitivities
(:func:`kanedyn.sensitivity`, on the model's exact derivatives), so the
Jacobian of the residuals is exact to the integration's tolerance, and
``scipy.optimize.least_squares`` (trust-region reflective: Gauss-Newton steps
with Levenberg-Marquardt-like regularization, bounds allowed) solves the
problem.  With ``segments > 1`` the first solve is by multiple shooting: each
record is cut into segments whose initial states are unknowns too, started
from the data where a state is measured, and joined by continuity residuals of
large weight; the trajectory cannot wander far from the data during the
iterations, which widens the region from which the fit converges.  A single
shooting solve from its result then gives the estimate, on one continuous
trajectory per record, and the Jacobian of the statistics (:mod:`._estimates`).

Unknown noise levels are estimated from the residuals, one per channel (the
same channel of several records shares it), alternating with the fit until
they settle.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .._errors import ModelError, OptionError
from ._records import as_records

__all__ = ["identify"]

#: the largest relative change of a noise estimate at which the alternation stops
SIGMA_CHANGE = 0.01
#: relative singular value (Jacobian with columns of unit length) below which a
#: direction of the unknowns is taken as not determined by the data
RANK_TOLERANCE = 1e-8
#: weight of the continuity residuals of multiple shooting, per unit of a state's scale
CONTINUITY_WEIGHT = 1e4
#: ``segments="auto"``: multiple shooting when a change of the initial state grows
#: more than this along a record at the initial guess (see :func:`_growth`)
AUTO_GROWTH = 1e3


def auto_segments(growth, samples):
    """The number of segments ``segments="auto"`` takes: 1 (single shooting) up to
    a growth of :data:`AUTO_GROWTH`; beyond, one segment per factor of 3 of
    growth, at least 2 and at most one per 4 samples of the shortest record."""
    if not growth <= AUTO_GROWTH:  # (nan: the largest number of segments)
        cap = max(2, samples // 4)
        return cap if not np.isfinite(growth) else int(min(max(2, math.ceil(
            math.log(growth) / math.log(3.0))), cap))
    return 1


class _Failed(Exception):
    """The model could not be integrated at an iterate."""


class _Interrupted(Exception):
    """A stop signal arrived during the fit."""


def _name(key):
    if isinstance(key, str):
        return key.strip().removesuffix("(t)")
    from ..engine import name_of
    return name_of(key)


class _Channel:
    """A measured channel of a record: a state (``kind="state"``) or the rate of
    one (``"rate"``), with the index of that state."""

    def __init__(self, name, kind, index, data):
        self.name, self.kind, self.index, self.data = name, kind, index, data


class _Problem:
    """The unknowns, the records and the evaluation of residuals and Jacobian."""

    def __init__(self, model, records, parameters, initial, y0, sigma, bounds, method,
                 rtol, atol, growth=True):
        from ..numerics import derivatives_unavailable
        if not (hasattr(model, "jacobians") and hasattr(model, "state_names")):
            raise ModelError(f"identify needs a NumericModel, got {type(model).__name__} "
                             "(make one with eom.numeric(constants=...))")
        reason = derivatives_unavailable(model)
        if reason:
            raise ModelError(f"identify needs the model's exact derivatives: {reason}")
        self.model = model
        self.records = records
        self.method, self.rtol, self.atol = method, rtol, atol
        states = list(model.state_names)
        constants = list(model.constants)
        self.pnames = self._names(parameters, constants, "parameters", "constant",
                                  "constants")
        self.inames = self._names(initial, states, "initial", "state", "states")
        dependent = set(states[model.n_q - model.n_q_dep:model.n_q]) | set(
            states[model.n_q + model.n_u - model.n_u_dep:])
        bad = [n for n in self.inames if n in dependent]
        if bad:
            raise ModelError(f"initial: {', '.join(bad)} follow(s) from the constraints; fit "
                             "the initial values of independent states only")
        if not self.pnames and not self.inames:
            raise ModelError("nothing to fit: name constants in parameters= (and/or states "
                             "in initial=)")
        self.constrained = bool(model.n_q_dep or model.n_u_dep)
        self.p0 = np.array([model.constants[n] for n in self.pnames], dtype=float)
        self.n_p, self.n_i = len(self.pnames), len(self.inames)
        self.k = self.n_p + self.n_i * len(records)
        self.channels = [self._channels(rec, k, states) for k, rec in enumerate(records)]
        self.starts = [self._start_guess(rec, k, y0) for k, rec in enumerate(records)]
        self._units(states)
        self.n_data = sum(rec.size for rec in records)
        if self.n_data <= self.k:
            raise ModelError(f"too few data: {self.n_data} measured values for {self.k} "
                             f"unknowns ({', '.join(self.names)}); the fit and its noise "
                             "estimate need more values than unknowns")
        self.sigma_given = self._sigma(sigma)
        self.scales = self._scales()
        self.lower, self.upper = self._bounds(bounds or {})
        self._cache = {}
        # the growth (segments="auto"): from the first evaluation, at the initial guess
        self.growth = None if growth else math.nan

    # ------------------------------------------------------------ checks
    @staticmethod
    def _names(given, known, option, kind, kinds):
        if isinstance(given, str) or not hasattr(given, "__iter__"):
            given = [given]
        names = [_name(g) for g in given]
        unknown = [n for n in names if n not in known]
        if unknown:
            raise ModelError(f"{option}: {', '.join(map(repr, unknown))} is not a {kind} of "
                             f"the model; its {kinds}: {', '.join(known) or 'none'}")
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ModelError(f"{option} names {', '.join(twice)} twice")
        return tuple(names)

    @property
    def names(self):
        """The unknowns: the constants, then each record's initial states
        (``theta(t0)``, with ``[record k]`` when there are several records)."""
        many = len(self.records) > 1
        out = list(self.pnames)
        for k in range(len(self.records)):
            out += [f"{n}(t0)" + (f" [record {k}]" if many else "") for n in self.inames]
        return tuple(out)

    def _label(self, k):
        rec = self.records[k]
        return rec.name or f"record {k}"

    def _channels(self, rec, k, states):
        if rec.t.size < 2:
            raise ModelError(f"{self._label(k)}: 1 sample; a record needs at least 2")
        out = []
        for name, data in rec.values.items():
            if name in states:
                out.append(_Channel(name, "state", states.index(name), data))
            elif name.endswith("_dot") and name[:-4] in states:
                out.append(_Channel(name, "rate", states.index(name[:-4]), data))
            else:
                raise ModelError(
                    f"{self._label(k)}: channel {name!r} is not an output of the model: "
                    f"measured channels are states ({', '.join(states)}) or their rates "
                    f"(a state's name and _dot, e.g. {states[-1]}_dot)")
        return out

    def _units(self, states):
        units = self.model.state_units
        for k, rec in enumerate(self.records):
            for name, unit in rec.units.items():
                state = name[:-4] if name.endswith("_dot") and name not in states else name
                expected = units.get(state)
                if unit is None or expected is None:
                    continue
                if name != state:
                    expected = f"{expected}/s"
                if unit.replace(" ", "") != expected.replace(" ", ""):
                    raise ModelError(f"{self._label(k)}: column {name!r} is in {unit!r}; the "
                                     f"model's {name} is in {expected!r} (convert the "
                                     "column)")

    def _start_guess(self, rec, k, y0):
        given = rec.y0 if rec.y0 is not None else y0
        if given is None:
            raise ModelError(f"{self._label(k)}: no initial state: give y0= (to identify "
                             "or to the record), the guess of the fitted ones included")
        model = self.model
        if isinstance(given, dict):
            values = {}
            for key, value in given.items():
                name = _name(key)
                if name not in model.state_names:
                    raise ModelError(f"{self._label(k)}: y0 names {key}, not a state of the "
                                     f"model ({', '.join(model.state_names)})")
                values[name] = value
            for name in self.inames:  # a fitted one need not be given: its first sample
                if name not in values:
                    found = [c for c in self.channels[k] if c.name == name]
                    if not found:
                        raise ModelError(f"{self._label(k)}: no guess of the initial {name}: "
                                         "give it in y0 (it is not measured)")
                    values[name] = float(found[0].data[0])
            y = model.state(values, rec.t0, what=f"{self._label(k)}: initial value")
        else:
            y = model.state(np.array(given, dtype=float), rec.t0,
                            what=f"{self._label(k)}: initial value")
        return y

    def _sigma(self, sigma):
        """``{channel: sigma}`` known: ``sigma=`` of identify, then the records' own."""
        names = {c.name for chans in self.channels for c in chans}
        out = {}
        if sigma is not None:
            given = sigma if isinstance(sigma, dict) else dict.fromkeys(names, sigma)
            for key, value in given.items():
                name = _name(key)
                if name not in names:
                    raise ModelError(f"sigma names {key!r}, which no record measures "
                                     f"({', '.join(sorted(names))})")
                if isinstance(value, (bool, str)) or not isinstance(value, numbers.Real) \
                        or not (math.isfinite(value) and value > 0):
                    raise ModelError(f"sigma of {name}: a positive finite number, got "
                                     f"{value!r}")
                out[name] = float(value)
        for k, rec in enumerate(self.records):
            for name, value in (rec.sigma or {}).items():
                if name in out and out[name] != value:
                    raise ModelError(f"{self._label(k)}: sigma of {name} = {value:g}, but "
                                     f"{out[name]:g} elsewhere: one noise level per channel")
                out[name] = value
        return out

    def _scales(self):
        scales = [abs(v) if v != 0 else 1.0 for v in self.p0]
        for k in range(len(self.records)):
            for name in self.inames:
                j = self.model.state_names.index(name)
                data = [np.ptp(c.data) for c in self.channels[k] if c.name == name]
                scales.append(max(abs(self.starts[k][j]), *data, 1e-12)
                              if data or self.starts[k][j] else 1.0)
        return np.array(scales)

    def _bounds(self, bounds):
        lower, upper = np.full(self.k, -np.inf), np.full(self.k, np.inf)
        if not isinstance(bounds, dict):
            raise ModelError(f"bounds must be a dict {{constant: (lower, upper)}}, got "
                             f"{type(bounds).__name__}")
        for key, pair in bounds.items():
            name = _name(key)
            if name not in self.pnames:
                raise ModelError(f"bounds name {key!r}, not one of the fitted constants "
                                 f"({', '.join(self.pnames)})")
            try:
                lo, hi = (-np.inf if pair[0] is None else float(pair[0]),
                          np.inf if pair[1] is None else float(pair[1]))
            except (TypeError, ValueError, IndexError):
                raise ModelError(f"bounds of {name} must be a pair (lower, upper), got "
                                 f"{pair!r}") from None
            j = self.pnames.index(name)
            if math.isnan(lo) or math.isnan(hi) or lo >= hi:
                raise ModelError(f"bounds of {name}: ({lo:g}, {hi:g}) is not an interval")
            if not lo <= self.p0[j] <= hi:
                raise ModelError(f"the model's {name} = {self.p0[j]:g}, the guess, lies "
                                 f"outside its bounds ({lo:g}, {hi:g})")
            lower[j], upper[j] = lo / self.scales[j], hi / self.scales[j]
        return lower, upper

    # -------------------------------------------------------- unknowns
    def theta0(self):
        x = list(self.p0)
        for k in range(len(self.records)):
            x += [self.starts[k][self.model.state_names.index(n)] for n in self.inames]
        return np.array(x) / self.scales

    def values(self, x):
        """The unknowns' values from the scaled vector ``x``."""
        return np.asarray(x) * self.scales

    def fitted_model(self, x):
        v = self.values(x)
        if not self.n_p:
            return self.model
        return self.model.with_constants(dict(zip(self.pnames, map(float, v[:self.n_p]))))

    def initial_state(self, model, k, x):
        """Record ``k``'s initial state at ``x`` (consistent with the constraints)."""
        v = self.values(x)
        y = self.starts[k].copy()
        cols = self.n_p + self.n_i * k + np.arange(self.n_i)
        for name, value in zip(self.inames, v[cols]):
            y[self.model.state_names.index(name)] = value
        if self.constrained:
            y = model.consistent_state(self.records[k].t0, y)
        return y

    def _start_derivative(self, model, k, x, y):
        """``d y_start / d x`` (n_states, k): the fitted initial states, and for a
        model with constraints the consistent completion (central differences)."""
        n = self.model.n_states
        D = np.zeros((n, self.k))
        cols = self.n_p + self.n_i * k + np.arange(self.n_i)
        if not self.constrained:
            for name, col in zip(self.inames, cols):
                D[self.model.state_names.index(name), col] = self.scales[col]
            return D
        for col in list(range(self.n_p)) + list(cols):
            h = 1e-6
            up, down = x.copy(), x.copy()
            up[col] += h
            down[col] -= h
            ys = [self.initial_state(self.fitted_model(z), k, z) for z in (up, down)]
            D[:, col] = (ys[0] - ys[1]) / (2 * h)
        return D

    # ----------------------------------------------------- evaluation
    def _integrate(self, model, rec, k, y_start, t_span, t_eval, D0, every=False):
        """``(run and its sensitivities, dY)``: ``dY = d y(t_eval) / d unknowns``
        (shape (N, n_states, D0's columns)) from ``D0 = d y_start / d unknowns``,
        the sensitivities integrated along the columns of ``D0`` that are not zero
        only, or, with ``every``, all of ``d y / d y_start`` (the growth's)."""
        from ..simulation import sensitivity
        used = np.flatnonzero(np.any(D0 != 0, axis=0))
        try:
            s = sensitivity(model, t_span, y_start, parameters=list(self.pnames),
                            t_eval=t_eval, method=self.method, rtol=self.rtol, atol=self.atol,
                            directions=None if every else D0[:, used])
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            raise _Failed(f"{self._label(k)}: the integration failed ({exc})") from None
        if not s.success or s.t.size != len(t_eval) or not np.all(np.isfinite(s.y)):
            raise _Failed(f"{self._label(k)}: the integration stopped at t = "
                          f"{(s.t[-1] if s.t.size else t_span[0]):g} s ({s.message})")
        if every:
            dY = s.initial @ D0
        else:
            dY = np.zeros(s.initial.shape[:2] + (D0.shape[1],))
            dY[:, :, used] = s.initial
        if self.n_p:
            dY[:, :, :self.n_p] += s.parameters * self.scales[:self.n_p]
        return s, dY

    def _predict(self, model, k, rec, idx, Y, dY):
        """Predictions and their derivatives (rows: channels, then samples ``idx``)."""
        rates = any(c.kind == "rate" for c in self.channels[k])
        J = None
        if rates:
            J = model.jacobians(rec.t[idx], Y, parameters=bool(self.n_p))
            cols = [list(model.constants).index(n) for n in self.pnames]
        preds, derivs = [], []
        follow = None
        if rates:  # inputs that are functions of the state (none: zeros)
            from ..numerics import through_inputs
            parts = [through_inputs(model, ti, yi, Ji)
                     for ti, yi, Ji in zip(rec.t[idx], Y, J.inputs)]
            if any(np.ndim(p) for p in parts):
                n = model.n_states
                follow = np.array([p if np.ndim(p) else np.zeros((n, n)) for p in parts])
        for c in self.channels[k]:
            if c.kind == "state":
                preds.append(Y[:, c.index])
                derivs.append(dY[:, c.index, :])
            else:
                row = J.state[:, c.index, :]
                if follow is not None:
                    row = row + follow[:, c.index, :]
                preds.append(J.f[:, c.index])
                d = np.einsum("nj,njk->nk", row, dY)
                if self.n_p:
                    d[:, :self.n_p] += J.parameters[:, c.index, cols] * self.scales[:self.n_p]
                derivs.append(d)
        return preds, derivs

    def single(self, x):
        """``(e, E)``: the residuals prediction - data (channels in order, samples in
        order, record after record) and their derivatives by the scaled unknowns."""
        key = ("single", np.asarray(x).tobytes())
        if key in self._cache:
            return self._cache[key]
        model = self.fitted_model(x)
        es, Es = [], []
        first, growth = self.growth is None, 0.0
        for k, rec in enumerate(self.records):
            m = model.with_inputs(rec.inputs) if rec.inputs else model
            y = self.initial_state(m, k, x)
            D0 = self._start_derivative(m, k, x, y)
            # the first evaluation integrates all of d y / d y_start, for the growth
            s, dY = self._integrate(m, rec, k, y, (rec.t0, float(rec.t[-1])), rec.t, D0,
                                    every=first)
            if first:
                growth = max(growth, _growth(s))
            preds, derivs = self._predict(m, k, rec, np.arange(rec.t.size), s.y.T, dY)
            for c, pred, d in zip(self.channels[k], preds, derivs):
                es.append(pred - c.data)
                Es.append(d)
        out = (np.concatenate(es), np.vstack(Es))
        if first:
            self.growth = growth
        self._cache.clear()
        self._cache[key] = out
        return out

    def row_channels(self):
        """The channel name of every residual row (the order of :meth:`single`)."""
        return [c.name for k, rec in enumerate(self.records) for c in self.channels[k]
                for _ in range(rec.t.size)]

    def predictions(self, x):
        """``[{channel: prediction at the samples}]`` per record at ``x``."""
        e, _ = self.single(x)
        out, at = [], 0
        for k, rec in enumerate(self.records):
            d = {}
            for c in self.channels[k]:
                d[c.name] = e[at:at + rec.t.size] + c.data
                at += rec.t.size
            out.append(d)
        return out


def _growth(s):
    r"""The largest amplification of a change of the initial state along a run,
    :math:`\max_i \|D^{-1} S_{y_0}(t_i) D\|_2` with :math:`D` the states' ranges."""
    D = np.ptp(s.y, axis=1)
    D = np.where(D > 0, D, 1.0)
    scaled = s.initial * D[None, None, :] / D[None, :, None]
    return float(np.max(np.linalg.norm(scaled, ord=2, axis=(1, 2))))


# --------------------------------------------------------- multiple shooting
class _Shooting:
    """Multiple shooting of a :class:`_Problem`: each record in ``segments`` pieces,
    the pieces' initial states unknowns too (scaled by the states' ranges), joined
    by continuity residuals."""

    def __init__(self, problem, segments, x0):
        from ..simulation import simulate
        self.p = problem
        self.pieces = []
        model = problem.fitted_model(x0)
        n = problem.model.n_states
        z = [x0]
        self.state_scales = []
        for k, rec in enumerate(problem.records):
            N = rec.t.size
            bounds = np.unique(np.round(np.linspace(0, N - 1, segments + 1)).astype(int))
            self.pieces.append(bounds)
            m = model.with_inputs(rec.inputs) if rec.inputs else model
            y = problem.initial_state(m, k, x0)
            run = simulate(m, (rec.t0, float(rec.t[-1])), y, t_eval=rec.t, rtol=problem.rtol,
                           atol=problem.atol, method=problem.method, backend="scipy")
            Y = run.y if run.t.size == N else np.repeat(y[:, None], N, axis=1)
            for c in problem.channels[k]:  # start the pieces from the data where measured
                if c.kind == "state":
                    Y[c.index] = c.data
            scale = np.maximum(np.ptp(Y, axis=1), 1e-6 * np.max(np.abs(Y), axis=1))
            scale[scale == 0] = 1.0
            self.state_scales.append(scale)
            for b in bounds[1:-1]:
                z.append(Y[:, b] / scale)
        self.z0 = np.concatenate(z)
        self.n = n
        self.lower = np.concatenate([problem.lower, np.full(self.z0.size - problem.k, -np.inf)])
        self.upper = np.concatenate([problem.upper, np.full(self.z0.size - problem.k, np.inf)])

    def evaluate(self, z):
        """``(e, E, c, C)``: data residuals (the layout of ``_Problem.single``) and
        continuity residuals, with their derivatives by ``z``."""
        p, n = self.p, self.n
        x = z[:p.k]
        model = p.fitted_model(x)
        nz = z.size
        es, Es, cs, Cs = [], [], [], []
        at = p.k
        for k, rec in enumerate(p.records):
            m = model.with_inputs(rec.inputs) if rec.inputs else model
            bounds, scale = self.pieces[k], self.state_scales[k]
            rows = {c.name: ([], []) for c in p.channels[k]}
            n_seg = len(bounds) - 1
            for j in range(n_seg):
                first, last = bounds[j], bounds[j + 1]
                idx = np.arange(first, last + 1 if j == n_seg - 1 else last)
                if j == 0:
                    y = p.initial_state(m, k, x)
                    D0 = np.zeros((n, nz))
                    D0[:, :p.k] = p._start_derivative(m, k, x, y)
                    t0 = rec.t0
                else:
                    cols = at + (j - 1) * n + np.arange(n)
                    y = z[cols] * scale
                    D0 = np.zeros((n, nz))
                    D0[:, cols] = np.diag(scale)
                    t0 = float(rec.t[first])
                t_end = float(rec.t[idx[-1]] if j == n_seg - 1 else rec.t[last])
                t_eval = rec.t[idx] if j == n_seg - 1 else np.append(rec.t[idx], t_end)
                s, dY = p._integrate(m, rec, k, y, (t0, t_end), t_eval, D0)
                preds, derivs = p._predict(m, k, rec, idx, s.y.T[:idx.size], dY[:idx.size])
                for c, pred, d in zip(p.channels[k], preds, derivs):
                    rows[c.name][0].append(pred - c.data[idx])
                    rows[c.name][1].append(d)
                if j < n_seg - 1:  # continuity with the next piece's start
                    nxt = at + j * n + np.arange(n)
                    w = CONTINUITY_WEIGHT / scale
                    cs.append(w * (s.y[:, -1] - z[nxt] * scale))
                    C = w[:, None] * dY[-1]
                    C[:, nxt] -= np.diag(w * scale)
                    Cs.append(C)
            for c in p.channels[k]:
                es.append(np.concatenate(rows[c.name][0]))
                Es.append(np.vstack(rows[c.name][1]))
            at += (n_seg - 1) * n
        empty = np.zeros((0, nz))
        return (np.concatenate(es), np.vstack(Es), np.concatenate(cs) if cs else np.zeros(0),
                np.vstack(Cs) if Cs else empty)


# ------------------------------------------------------------------ solve
def _least_squares(fun, jac, x0, lower, upper, tolerance, max_iterations, stop):
    from scipy.optimize import least_squares

    def f(x):
        if stop():
            raise _Interrupted(x)
        return fun(x)

    return least_squares(f, x0, jac=jac, bounds=(lower, upper), method="trf",
                         x_scale="jac", ftol=tolerance, xtol=tolerance, gtol=tolerance,
                         max_nfev=max_iterations)


def identify(model, data, parameters=(), *, initial=(), y0=None, sigma=None, bounds=None,
             segments="auto", level=0.95, method="DOP853", rtol=1e-9, atol=1e-11,
             max_iterations=100, tolerance=1e-10):
    r"""Fit constants (and initial states) of ``model`` to measured records.

    Weighted least squares on the model's trajectories, with the exact
    Jacobian from forward sensitivities (:func:`kanedyn.sensitivity`) and
    ``scipy.optimize.least_squares``:

    .. math::

        \min_{p,\,y_0}\ \tfrac12\sum_{c,i}\Big(\frac{h_c(t_i; p, y_0) -
        d_{c,i}}{\sigma_c}\Big)^2 ,

    then the covariance :math:`s^2 (J^TJ)^{-1}` of the estimates from the
    weighted Jacobian :math:`J` at the optimum (:math:`s^2` the residuals'
    mean square when the noise is estimated, 1 when it is given) and
    confidence intervals at ``level``.

    Parameters
    ----------
    model : NumericModel
        With exact derivatives (``model.jacobians``).  Its values of the fitted
        constants are the initial guess.
    data : MeasuredRecord, str, os.PathLike, (t, dict) or a list of them
        The records: :class:`MeasuredRecord`, CSV files
        (:meth:`MeasuredRecord.from_csv`), or pairs ``(t, {channel:
        values})``.  A channel is a state's name, or a state's name with
        ``_dot`` for its rate (an accelerometer's ``omega_dot``).
    parameters : sequence of str or symbols
        The constants to fit (keys of ``model.constants``).
    initial : sequence of str or symbols, optional
        States whose initial values are fitted too, one value per record
        (independent states only).
    y0 : dict or array_like, optional
        The initial state of the records that carry none; the fitted ones'
        entries are guesses (a fitted state that is measured and not given
        starts from its first sample).
    sigma : float or dict, optional
        The noise's standard deviation, ``{channel: sigma}`` or one for all;
        channels without one get theirs estimated from the residuals (one per
        channel name, shared by the records).
    bounds : dict, optional
        ``{constant: (lower, upper)}`` (``None`` for no bound on a side).
    segments : int or "auto"
        1: single shooting.  More: first a multiple-shooting solve with each
        record cut into that many segments (the estimate then comes from a
        single-shooting solve started from it), for records along which the
        model's motion is unstable or chaotic.  ``"auto"``: single shooting,
        unless a change of the initial state grows by more than
        :data:`AUTO_GROWTH` along a record at the initial guess (then one
        segment per factor of 3 of that growth); models with constraints
        always take single shooting.
    level : float
        Confidence level of the intervals (0.95: 95 %).
    method, rtol, atol
        The integration of the states and sensitivities (``solve_ivp``).
    max_iterations : int
        Largest number of evaluations of the residuals per solve.
    tolerance : float
        ``least_squares``'s ``ftol``, ``xtol`` and ``gtol``.

    Returns
    -------
    IdentificationResult
        Also when the fit fails or is interrupted (Ctrl-C: the last iterate),
        with ``success=False`` and the reason in ``message``; a fit whose
        Jacobian is rank deficient at the optimum names the unknowns the data
        do not determine.

    Raises
    ------
    ModelError
        A constant or state the model lacks, a channel naming no output, a
        bad record (times, NaN), too few data for the unknowns, or unknowns
        that the data cannot determine at the initial guess (rank-deficient
        Jacobian): each message names the culprit.
    OptionError
        An option out of its range.

    Examples
    --------
    >>> import numpy as np
    >>> import kanedyn as kd
    >>> model = kd.models.build("pendulum").numeric(constants={"m": 1.0, "l": 1.0,
    ...                                                         "g": 9.0})
    >>> t = np.linspace(0.0, 2.0, 41)
    >>> truth = kd.simulate(model.with_constants({"g": 9.81}), (0, 2), [0.3, 0.0],
    ...                     t_eval=t, rtol=1e-11, atol=1e-11)
    >>> fit = kd.identify(model, (t, {"q": truth["q"]}), ["g"], y0=[0.3, 0.0],
    ...                   sigma=1e-3)
    >>> round(fit.estimates["g"], 6)
    9.81
    """
    for option, value, ok, want in (
            ("level", level, lambda v: 0 < v < 1, "a number between 0 and 1 (0.95: 95 %)"),
            ("rtol", rtol, lambda v: v > 0, "a positive number"),
            ("atol", atol, lambda v: v > 0, "a positive number"),
            ("tolerance", tolerance, lambda v: v > 0, "a positive number")):
        if isinstance(value, bool) or not isinstance(value, numbers.Real) \
                or not math.isfinite(value) or not ok(value):
            raise OptionError(f"identify: {option} must be {want}, got {value!r}")
    checks = [("max_iterations", max_iterations)] + ([] if segments == "auto" else
                                                     [("segments", segments)])
    for option, value in checks:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
            raise OptionError(f"identify: {option} must be an integer >= 1"
                              + (' or "auto"' if option == "segments" else "")
                              + f", got {value!r}")
    records = as_records(data)
    problem = _Problem(model, records, parameters, initial, y0, sigma, bounds, method,
                       rtol, atol, growth=segments == "auto")
    if segments != "auto" and segments > 1 and problem.constrained:
        raise OptionError("identify: segments > 1 (multiple shooting) is for models "
                          "without constraints; use segments=1")
    from ._estimates import fit
    return fit(problem, segments, level, max_iterations, tolerance)
