r"""The fit of :func:`~kanedyn.identify` and its result: estimates, their
covariance and confidence intervals.

At the optimum :math:`\hat\theta`, with :math:`J` the Jacobian of the weighted
residuals :math:`r_i = (h_i - d_i)/\sigma_i`,

.. math::

    \operatorname{Cov}\hat\theta = s^2 (J^TJ)^{-1},\qquad
    s^2 = \frac{\sum_i r_i^2}{N - k}\ \text{(noise estimated) or } 1
    \ \text{(noise given)},

(from the singular value decomposition of :math:`J`, never by forming
:math:`J^TJ`), the standard errors are the square roots of its diagonal and
the intervals :math:`\hat\theta_j \pm q\,\mathrm{se}_j` with :math:`q` the
quantile of Student's t with :math:`N - k` degrees of freedom (noise
estimated) or of the normal distribution (noise given) at the level asked
for.  These are the linearized (Wald) intervals: exact for a model linear
in its unknowns with Gaussian noise, approximate otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ModelError

__all__ = ["IdentificationResult", "fit"]

_MAX_ROUNDS = 8


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    r"""What :func:`~kanedyn.identify` found; immutable.

    Attributes
    ----------
    names : tuple of str
        The unknowns: the fitted constants, then the fitted initial states
        (``"theta(t0)"``, with ``" [record k]"`` for several records).
    estimates : dict
        ``{name: value}`` (SI units of the constant or state).
    standard_errors : dict
        ``{name: standard error}``; ``inf`` for an unknown the data do not
        determine.
    intervals : dict
        ``{name: (lower, upper)}``, the confidence intervals at ``level``.
    level : float
        Their confidence level (0.95: 95 %).
    covariance, correlation : ndarray, shape (k, k)
        In the order of ``names``.
    parameters : dict
        ``{constant: value}``, the fitted constants only.
    initial_states : tuple of ndarray
        Each record's initial state at the estimate (all states).
    sigma : dict
        ``{channel: noise standard deviation}`` used in the final weights.
    sigma_estimated : tuple of str
        The channels whose noise was estimated from the residuals.
    residuals : tuple of dict
        Per record, ``{channel: prediction - data}`` at the samples.
    records : tuple of MeasuredRecord
    cost : float
        :math:`\tfrac12\sum r_i^2` of the weighted residuals.
    reduced_chi_square : float
        :math:`\sum r_i^2/(N - k)`: near 1 when the given noise levels are right.
    dof : int
        :math:`N - k`, measured values less unknowns.
    not_identifiable : tuple of str
        Unknowns that the Jacobian at the estimate does not determine (it is
        rank deficient along directions that involve them).
    success : bool
    message : str
    iterations : int
        Evaluations of the residuals (each an integration with sensitivities).
    jacobian_evaluations : int
    method : str
        ``"single shooting"`` or ``"multiple shooting (M segments), then single
        shooting"``.
    model : NumericModel
        The model with the fitted constants.
    """

    names: tuple
    estimates: dict
    standard_errors: dict
    intervals: dict
    level: float
    covariance: np.ndarray
    correlation: np.ndarray
    parameters: dict
    initial_states: tuple
    sigma: dict
    sigma_estimated: tuple
    residuals: tuple
    records: tuple
    cost: float
    reduced_chi_square: float
    dof: int
    not_identifiable: tuple
    success: bool
    message: str
    iterations: int
    jacobian_evaluations: int
    method: str
    model: object

    def simulate(self, record=0, t_eval=None, **options):
        """The fitted model run over a record (``kd.simulate``).

        Parameters
        ----------
        record : int
            Which record: its initial state at the estimate, its inputs, its
            time span.
        t_eval : array_like, optional
            Output times (default: the record's samples).
        **options
            Passed to :func:`kanedyn.simulate` (default ``rtol=atol=1e-10``).

        Returns
        -------
        SimulationResult
        """
        from ..simulation import simulate
        rec = self.records[record]
        model = self.model.with_inputs(rec.inputs) if rec.inputs else self.model
        options.setdefault("rtol", 1e-10)
        options.setdefault("atol", 1e-10)
        return simulate(model, (rec.t0, float(rec.t[-1])), self.initial_states[record],
                        t_eval=rec.t if t_eval is None else t_eval, **options)

    def rows(self):
        """``[(name, estimate, standard error, lower, upper)]``."""
        return [(n, self.estimates[n], self.standard_errors[n], *self.intervals[n])
                for n in self.names]

    def table(self):
        """The estimates and their intervals as a plain-text table."""
        from tabulate import tabulate
        pct = f"{100 * self.level:g} %"
        rows = [(n, f"{v:.8g}", f"{se:.3g}", f"{lo:.8g}", f"{hi:.8g}",
                 f"{100 * se / abs(v):.3g}" if v and np.isfinite(se) else "")
                for n, v, se, lo, hi in self.rows()]
        return tabulate(rows, headers=["unknown", "estimate", "std. error",
                                       f"{pct} lower", f"{pct} upper", "rel. error %"],
                        tablefmt="simple", disable_numparse=True)

    def __repr__(self):
        values = ", ".join(f"{n} = {self.estimates[n]:.6g} ± {self.standard_errors[n]:.2g}"
                           for n in self.names)
        return f"<IdentificationResult {values}: {self.message}>"


# ------------------------------------------------------------------- fit
def _initial_sigma(e, data):
    """A first noise level of a channel: the RMS misfit of the guess (a floor
    keeps it positive)."""
    rms = float(np.sqrt(np.mean(e ** 2)))
    scale = float(np.max(np.abs(data))) if data.size else 1.0
    return max(rms, 1e-9 * scale, 1e-300)


def _null_directions(J, names):
    """``(names involved, text)`` of the directions along which ``J`` (columns
    scaled to unit length) is rank deficient."""
    norms = np.linalg.norm(J, axis=0)
    zero = [names[j] for j in np.flatnonzero(~(norms > 0))]
    if zero:
        return zero, (f"the measured channels do not depend on {', '.join(zero)}")
    from ._identify import RANK_TOLERANCE
    _, S, Vt = np.linalg.svd(J / norms, full_matrices=False)
    small = np.flatnonzero(S < RANK_TOLERANCE * S[0])
    if not small.size:
        return [], ""
    involved, combos = [], []
    for i in small:
        v = Vt[i]
        big = np.flatnonzero(np.abs(v) > 0.1)
        involved += [names[j] for j in big if names[j] not in involved]
        v = v if v[big[0]] > 0 else -v
        terms = [f"{'- ' if v[j] < 0 else '+ ' if n else ''}{abs(v[j]):.2f} {names[j]}"
                 for n, j in enumerate(big)]
        combos.append(" ".join(terms))
    return involved, (f"the Jacobian has rank {J.shape[1] - small.size} of {J.shape[1]}: "
                      f"the outputs do not change along {'; '.join(combos)} (relative "
                      "changes)")


def fit(problem, segments, level, max_iterations, tolerance):
    """Solve ``problem`` and build the :class:`IdentificationResult`."""
    from .._signals import Stopped, holding, interruption
    from ._identify import SIGMA_CHANGE, _Failed, _Interrupted, _least_squares, _Shooting
    names = problem.row_channels()
    rows = np.array(names)
    channels = list(dict.fromkeys(names))
    x = problem.theta0()
    try:
        e, E = problem.single(x)
    except _Failed as exc:
        raise ModelError(f"identify: the model cannot be integrated at the initial guess: "
                         f"{exc}") from None
    data_of = {c: np.concatenate([ch.data for chans in problem.channels for ch in chans
                                  if ch.name == c]) for c in channels}
    sigma = {c: problem.sigma_given.get(c) or _initial_sigma(e[rows == c], data_of[c])
             for c in channels}
    unknown = [c for c in channels if c not in problem.sigma_given]

    def weights():
        return 1.0 / np.array([sigma[c] for c in rows])

    w = weights()
    involved, text = _null_directions(E * w[:, None], problem.names)
    if involved:
        raise ModelError(f"identify: {', '.join(involved)} cannot be identified from these "
                         f"data at the initial guess: {text}; measure other channels, fix "
                         "some of them, or excite the model otherwise")
    stop = {"signal": None}

    def on_signal(signum):
        if stop["signal"] is not None:
            raise Stopped(signum)
        stop["signal"] = signum

    if segments == "auto":
        from ._identify import auto_segments
        shortest = min(rec.t.size for rec in problem.records)
        segments = 1 if problem.constrained else auto_segments(problem.growth, shortest)
    counts = {"nfev": 0, "njev": 0}
    method = "single shooting"
    failure = None
    settled = not unknown
    rounds = 0
    with holding(on_signal):
        try:
            if segments > 1:
                shoot = _Shooting(problem, segments, x)
                method = f"multiple shooting ({segments} segments), then single shooting"

                def fun(z):
                    e, _, c, _ = shoot.evaluate(z)
                    return np.concatenate([e * w, c])

                def jac(z):
                    _, E, _, C = shoot.evaluate(z)
                    return np.vstack([E * w[:, None], C])

                res = _least_squares(fun, jac, shoot.z0, shoot.lower, shoot.upper, tolerance,
                                     max_iterations, lambda: stop["signal"] is not None)
                counts["nfev"] += res.nfev
                counts["njev"] += res.njev or 0
                x = res.x[:problem.k]
            while True:
                rounds += 1
                res = _least_squares(lambda x: problem.single(x)[0] * w,
                                     lambda x: problem.single(x)[1] * w[:, None], x,
                                     problem.lower, problem.upper, tolerance, max_iterations,
                                     lambda: stop["signal"] is not None)
                counts["nfev"] += res.nfev
                counts["njev"] += res.njev or 0
                x = res.x
                if not unknown:
                    break
                e, _ = problem.single(x)
                n, k = e.size, problem.k
                change = 0.0
                for c in unknown:
                    ec = e[rows == c]
                    new = float(np.sqrt(np.sum(ec ** 2) / (ec.size - k * ec.size / n)))
                    new = max(new, 1e-300)
                    change = max(change, abs(new / sigma[c] - 1.0))
                    sigma[c] = new
                w = weights()
                if change < SIGMA_CHANGE:
                    settled = True
                    break
                if rounds >= _MAX_ROUNDS:
                    break
        except _Interrupted as exc:
            x = np.asarray(exc.args[0])[:problem.k]
            failure = f"{interruption(stop['signal'])}: the last iterate is returned"
            res = None
        except _Failed as exc:
            failure = f"the fit stopped: {exc}"
            res = None
    return _result(problem, x, sigma, unknown, w, level, res, counts, method, failure,
                   settled, rounds)


def _result(problem, x, sigma, unknown, w, level, res, counts, method, failure, settled,
            rounds):
    from scipy import stats

    from ._identify import _Failed
    names = problem.names
    k = problem.k
    values = problem.values(x)
    try:
        e, E = problem.single(x)
    except _Failed as exc:  # the last iterate cannot be integrated: no statistics
        e, E = None, None
        failure = failure or f"the fit stopped: {exc}"
    nan = np.full((k, k), np.nan)
    covariance, se = nan, np.full(k, np.nan)
    involved, rank_text, chi2, s2 = [], "", np.nan, np.nan
    dof = problem.n_data - k
    if e is not None:
        r = e * w
        J = E * w[:, None]
        chi2 = float(np.sum(r ** 2) / dof)
        s2 = chi2 if unknown else 1.0
        involved, rank_text = _null_directions(J, names)
        U, S, Vt = np.linalg.svd(J, full_matrices=False)
        keep = S > 0
        inv = (Vt[keep].T / S[keep] ** 2) @ Vt[keep]
        covariance = s2 * inv * np.outer(problem.scales, problem.scales)
        se = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
        for name in involved:
            j = names.index(name)
            se[j] = np.inf
            covariance[j, :] = covariance[:, j] = np.nan
    quantile = float(stats.t.ppf(0.5 + level / 2, dof) if unknown
                     else stats.norm.ppf(0.5 + level / 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = covariance / np.outer(se, se)
    intervals = {n: (float(v - quantile * s), float(v + quantile * s))
                 for n, v, s in zip(names, values, se)}
    # the message
    if failure is not None:
        success, message = False, failure
    elif res is not None and res.status <= 0:
        success, message = False, f"least_squares did not converge: {res.message.rstrip('.')}"
    else:
        success = True
        message = (f"converged: {res.message.rstrip('.')}" if res is not None
                   else "converged")
    notes = []
    if involved:
        success = False
        notes.append(f"not identifiable: {', '.join(involved)} ({rank_text})")
    at_bound = [names[j] for j in range(problem.n_p)
                if np.isfinite(problem.lower[j]) and abs(x[j] - problem.lower[j]) < 1e-9
                or np.isfinite(problem.upper[j]) and abs(x[j] - problem.upper[j]) < 1e-9]
    if at_bound:
        notes.append(f"{', '.join(at_bound)} at a bound: the interval assumes an interior "
                     "optimum and is not valid there")
    if unknown and not settled and failure is None:
        notes.append(f"the noise estimates had not settled after {rounds} rounds")
    if notes:
        message += "; " + "; ".join(notes)
    residuals, initial = [], []
    model = problem.fitted_model(x)
    at = 0
    for kk, rec in enumerate(problem.records):
        m = model.with_inputs(rec.inputs) if rec.inputs else model
        initial.append(problem.initial_state(m, kk, x))
        d = {}
        for c in problem.channels[kk]:
            d[c.name] = (e[at:at + rec.t.size].copy() if e is not None
                         else np.full(rec.t.size, np.nan))
            at += rec.t.size
        residuals.append(d)
    return IdentificationResult(
        names=names, estimates=dict(zip(names, map(float, values))),
        standard_errors=dict(zip(names, map(float, se))), intervals=intervals,
        level=float(level), covariance=covariance, correlation=correlation,
        parameters=dict(zip(problem.pnames, map(float, values[:problem.n_p]))),
        initial_states=tuple(initial), sigma=dict(sigma), sigma_estimated=tuple(unknown),
        residuals=tuple(residuals), records=tuple(problem.records),
        cost=float(0.5 * np.sum((e * w) ** 2)) if e is not None else np.nan,
        reduced_chi_square=chi2, dof=dof, not_identifiable=tuple(involved), success=success,
        message=message, iterations=counts["nfev"], jacobian_evaluations=counts["njev"],
        method=method, model=model)
