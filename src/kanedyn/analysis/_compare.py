"""One model, several formulations: the same motion, or not, at what cost.

:func:`compare_formulations` derives a built-in model by each method in the
formulation registry, starts every run from the same physical state
(coordinates and their rates; multipliers of the augmented Lagrangean at
zero), integrates them with the same integrator and tolerances and reports,
per method: the operation counts of the generated equations, how far the
coordinates drift from the first method's, the Newton–Euler residual of
every body with the identified constraint forces
(:func:`kanedyn.check_newton_euler`), the position- and velocity-level
constraint errors over time, the energy error, and the CPU time per
simulated second.  :func:`work_precision` adds the CPU time at equal
accuracy, from runs at several tolerances against a tight reference.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .._errors import ModelError
from .._output_files import save_figure
from ._newton_euler import check_newton_euler
from ..simulation import simulate

__all__ = ["compare_formulations", "FormulationComparison", "work_precision",
           "WorkPrecision", "NONHOLONOMIC_EXAMPLES", "method_colors"]

#: Built-in models whose constraint forces are all identified, for
#: ``kanedyn compare nonholonomic``.
NONHOLONOMIC_EXAMPLES = ("knife-edge", "rolling-disk-contact", "sphere-turntable",
                         "nonholonomic-particle")


@dataclass(frozen=True)
class FormulationComparison:
    """Per-method figures of one model (see :func:`compare_formulations`).

    Attributes
    ----------
    model : str
    methods : tuple of str
    t : ndarray, shape (N,)
        Common output times, s.
    coordinates : dict
        ``{method: ndarray (n_q, N)}`` in the reference method's coordinate
        order.
    deviation : dict
        ``{method: max |q - q_ref|}`` over the run.
    newton_euler : dict
        ``{method: NewtonEulerCheck}``; empty where the check is not
        available for the model (see ``newton_euler_note``).
    position_error, velocity_error : dict
        ``{method: ndarray (N,)}``: largest absolute configuration- and
        velocity-constraint residual at each output time (``nan`` where it
        cannot be evaluated).
    energy_error : dict
        ``{method: ndarray (N,)}``: :math:`E(t) - E(0)`, J (``None`` for
        models without an energy).
    operations : dict
        ``{method: dict}``: operations of everything the right-hand side
        evaluates after joint common subexpression elimination
        (``multiplications``, ``additions``, ``powers``, ``functions``,
        ``total``) and the number of named intermediates.
    cpu_time : dict
        ``{method: seconds}`` of the integration (process time).
    evaluations : dict
        ``{method: number of right-hand-side evaluations}``.
    projections : dict
        ``{method: number of drift projections}``.
    messages : dict
        ``{method: the integrator's message}``.
    integrator : str
        The ``solve_ivp`` method used for every formulation.
    units : dict
        ``{"coordinates": {name: unit or None}, "position": [units],
        "velocity": [units]}``: units of the coordinates and of the
        configuration and velocity constraints (for the plot's labels).
    newton_euler_note : str
        Why there is no Newton-Euler check (``""`` where there is one).
    """

    model: str
    methods: tuple
    t: np.ndarray
    coordinates: dict
    deviation: dict
    newton_euler: dict
    position_error: dict
    velocity_error: dict
    energy_error: dict
    operations: dict
    cpu_time: dict
    evaluations: dict
    projections: dict
    messages: dict
    integrator: str = "RK45"
    units: dict = field(default_factory=dict)
    newton_euler_note: str = ""

    @property
    def constraint_residual(self):
        """``{method: max velocity-constraint residual}`` over the run."""
        return {m: _peak(self.velocity_error[m]) for m in self.methods}

    @property
    def position_residual(self):
        """``{method: max configuration-constraint residual}`` over the run."""
        return {m: _peak(self.position_error[m]) for m in self.methods}

    @property
    def energy_drift(self):
        """``{method: max |E - E(0)|}`` (``nan`` without an energy)."""
        return {m: _peak(self.energy_error[m]) if self.energy_error[m] is not None
                else float("nan") for m in self.methods}

    @property
    def cpu_per_second(self):
        """``{method: CPU seconds per simulated second}``."""
        span = float(self.t[-1] - self.t[0]) or 1.0
        return {m: self.cpu_time[m] / span for m in self.methods}

    def table(self):
        """The figures as a text table (a title line, then one row per method)."""
        from tabulate import tabulate
        sources = (", ".join(f"{m} {self.newton_euler[m].source}" for m in self.methods)
                   if self.newton_euler else "no N-E check")
        title = (f"{self.model}: t = 0..{self.t[-1]:g} s, {self.integrator} "
                 f"(reference: {self.methods[0]}; N-E multipliers: {sources})")
        headers = ("method", "mul", "add", "fun", "max|q-q_ref|", "N-E force", "N-E moment",
                   "N-E rel", "|h| max", "|c| max", "|dE| max", "nfev", "proj", "cpu/s")
        pos, vel, drift = self.position_residual, self.constraint_residual, self.energy_drift
        per_second = self.cpu_per_second
        rows = []
        for m in self.methods:
            ne = self.newton_euler.get(m)
            ops = self.operations[m]
            figures = (None, None, None) if ne is None else (
                ne.max_force, ne.max_moment,
                ne.max / ne.inertia_scale if ne.inertia_scale else np.nan)
            rows.append((m, ops["multiplications"], ops["additions"], ops["functions"],
                         self.deviation[m], *figures, pos[m], vel[m], drift[m],
                         self.evaluations[m], self.projections[m], per_second[m]))
        formats = ("", "d", "d", "d", ".3e", ".2e", ".2e", ".1e", ".1e", ".1e", ".1e", "d",
                   "d", ".3f")
        lines = [title, tabulate(rows, headers=headers, floatfmt=formats, intfmt="d",
                                 missingval="n/a")]
        if self.newton_euler_note:
            lines.append(f"N-E columns n/a: {self.newton_euler_note}")
        unidentified = sorted({n for ne in self.newton_euler.values() for n in ne.unidentified})
        if unidentified:
            lines.append(f"N-E residuals hold the forces of {', '.join(unidentified)}: "
                         "constraints given as scalar equations identify no force on a body "
                         "(write them as kd.VectorConstraint to check them)")
        bad = [f"{m}: {self.messages[m]}" for m in self.methods
               if "reached the end" not in self.messages[m]]
        if bad:
            lines.append("did not finish: " + "; ".join(bad))
        return "\n".join(lines)

    def plot(self, path=None):
        """Constraint errors, energy error and deviation against time.

        One colour per method in every panel (the figure's legend); the
        deviation from the reference method gets one panel per unit of the
        coordinates (lengths and angles apart); logarithmic axes only where
        the values allow them.

        Parameters
        ----------
        path : str or Path, optional
            Save the figure there (PNG, PDF, ... by suffix).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ._plotting import draw_nonnegative, pyplot, unit_text
        plt = pyplot()
        colors = method_colors(self.methods)
        ref = self.methods[0]
        q_units = self.units.get("coordinates", {})
        names = list(q_units) or [f"q{i + 1}" for i in range(len(self.coordinates[ref]))]
        by_unit = {}
        for i, name in enumerate(names):
            by_unit.setdefault(q_units.get(name), []).append(i)
        panels = [(self.position_error, "position-level |h| "
                   + unit_text(self.units.get("position") or [None]), False),
                  (self.velocity_error, "velocity-level |c| "
                   + unit_text(self.units.get("velocity") or [None]), False),
                  ({m: None if v is None else np.abs(v) for m, v in self.energy_error.items()},
                   "|E - E(0)| [J]", False)]
        for unit, rows in by_unit.items():
            what = {"rad": "angles", "m": "lengths"}.get(unit, "coordinates")
            panels.append(({m: None if m == ref else np.max(np.abs(
                self.coordinates[m][rows, :self.t.size]
                - self.coordinates[ref][rows, :self.coordinates[m].shape[1]]), axis=0,
                initial=0.0) for m in self.methods},
                f"max |q - q_{ref}|, {what} {unit_text([unit])}", True))
        ncols = 2
        nrows = -(-len(panels) // ncols)
        fig, axes = plt.subplots(nrows, ncols, figsize=(11, 3.2 * nrows + 1.0), sharex=True,
                                 squeeze=False, layout="constrained")
        for ax, (series, label, deviation) in zip(axes.flat, panels):
            shown = {m: v for m, v in series.items()
                     if v is not None and np.any(np.isfinite(v) & (v != 0))}
            if shown:
                draw_nonnegative(ax, self.t, shown, colors=colors)
            else:
                ax.text(0.5, 0.5, "zero or not defined for every method",
                        transform=ax.transAxes, ha="center", va="center", color="0.4")
            quiet = [m for m in self.methods if m not in shown and not (deviation and m == ref)]
            if quiet and shown:
                ax.text(0.99, 0.98, "zero or undefined: " + ", ".join(quiet),
                        transform=ax.transAxes, ha="right", va="top", fontsize="x-small",
                        color="0.4")
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
        for ax in axes.flat[len(panels):]:
            ax.set_visible(False)
        for ax in axes[-1]:
            ax.set_xlabel("t [s]")
        for ax in axes.flat[len(panels) - ncols:len(panels)]:
            ax.set_xlabel("t [s]")
            ax.xaxis.set_tick_params(labelbottom=True)
        from matplotlib.lines import Line2D
        handles = [Line2D([], [], color=colors[m], lw=2) for m in self.methods]
        labels = [m + (" (reference)" if m == ref else "") for m in self.methods]
        fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 4),
                   fontsize="small", frameon=False)
        fig.suptitle(f"{self.model}: formulations compared ({self.integrator})",
                     fontsize="medium")
        if path is not None:
            save_figure(fig, path, dpi=120)
        return fig


def method_colors(methods):
    """``{method: colour}``: one colour per method, the same in every panel."""
    return {m: f"C{i % 10}" for i, m in enumerate(methods)}


def _peak(values):
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    return float(np.max(np.abs(finite))) if finite.size else float("nan")


def _initial_state(model, ref_model, y_ref, qdot_ref):
    """Map the reference state (q, u) to ``model``'s states by name."""
    ref_names = list(ref_model.state_names)
    q_names = ref_names[:ref_model.n_q]
    y = np.zeros(model.n_states)
    for i, name in enumerate(model.state_names):
        if name in ref_names:
            y[i] = y_ref[ref_names.index(name)]
        elif name.endswith("_d") and name[:-2] in q_names:
            y[i] = qdot_ref[q_names.index(name[:-2])]
        elif name.startswith("lam_"):
            y[i] = 0.0  # augmented Lagrangean multipliers start at zero
        else:
            raise ModelError(f"cannot map state {name} of the {model!r} to the reference "
                             "model's states")
    return model.state(y)


def _constraint_errors(res, checkers):
    """Configuration- and velocity-constraint residual histories of a run.

    A model without constraints of its own (the augmented Lagrangean's) is
    measured with another model whose states it contains.
    """
    model, N = res.model, res.t.size
    if model.n_q_dep or model.n_u_dep:
        r = np.abs(res.constraint_residuals)
        l = model.n_q_dep
        return (np.max(r[:l], axis=0, initial=0.0), np.max(r[l:], axis=0, initial=0.0))
    names = list(model.state_names)
    checker = next((c for c in checkers if set(c.state_names) <= set(names)), None)
    if checker is None:
        return np.zeros(N), np.zeros(N)
    idx = [names.index(n) for n in checker.state_names]
    pos, vel = np.full(N, np.nan), np.full(N, np.nan)
    for k in range(N):
        if np.all(np.isfinite(res.y[idx, k])):
            c = np.abs(checker.constraint_residuals(res.t[k], res.y[idx, k]))
            pos[k] = np.max(c[:checker.n_q_dep], initial=0.0)
            vel[k] = np.max(c[checker.n_q_dep:], initial=0.0)
    return pos, vel


def _operations(eom):
    counts = eom.operation_counts()
    out = dict(counts["kinds"])
    out["total"] = counts["all_cse"]
    out["intermediates"] = counts["intermediates"]
    return out


@dataclass(frozen=True)
class _Setup:
    """The models of one comparison, their common start and output times."""

    methods: tuple
    eoms: dict
    built: dict
    starts: dict
    t_end: float
    t_eval: np.ndarray
    q_names: tuple


def _models(name, methods, constants, options, t_end, n_points, backend="numpy"):
    """Derive and build every method's model; map the reference start to each."""
    from .. import models
    methods = tuple(methods)
    if not methods:
        raise ModelError("give at least one formulation to compare")
    definition = models.build(name, **options)
    eoms = {m: definition.derive(method=m) for m in methods}
    built = {m: definition.numeric(eoms[m], constants=constants, backend=backend)
             for m in methods}
    ref = built[methods[0]]
    y_ref = ref.state(definition.initial(ref))
    qdot_ref = ref.rhs(0.0, y_ref)[:ref.n_q]
    starts = {m: y_ref if m == methods[0] else _initial_state(built[m], ref, y_ref, qdot_ref)
              for m in methods}
    t_end = definition.t_end if t_end is None else float(t_end)
    return _Setup(methods=methods, eoms=eoms, built=built, starts=starts, t_end=t_end,
                  t_eval=np.linspace(0.0, t_end, n_points),
                  q_names=tuple(ref.state_names[:ref.n_q]))


def _coordinates(res, q_names):
    return np.array([res[n] for n in q_names])


def compare_formulations(name, methods=("kane", "lagrange", "augmented"), t_end=None,
                         rtol=1e-10, atol=1e-12, n_points=201, integrator="RK45",
                         constants=None, backend="numpy", **options):
    """Simulate a built-in model under several formulations and compare.

    Parameters
    ----------
    name : str
        A built-in model (``kanedyn list``).
    methods : sequence of str
        Keys of :data:`kanedyn.FORMULATIONS`; the first is the reference.
    t_end : float, optional
        Default: the model's.
    rtol, atol : float
        Integration tolerances (the same for every method).
    n_points : int
        Output times.
    integrator : str
        ``solve_ivp`` method for every formulation (``"BDF"`` for stiff
        runs, as the penalty formulation may need).
    constants : dict, optional
        Parameter values replacing the model's defaults (``{"A": 0.0}``).
    backend : {"numpy", "c"}
        Numerical backend of every formulation's model.
    **options
        Model options (as for :func:`kanedyn.models.build`).

    Returns
    -------
    FormulationComparison
    """
    setup = _models(name, methods, constants, options, t_end, n_points, backend)
    methods, eoms, built, starts = setup.methods, setup.eoms, setup.built, setup.starts
    t_end, t_eval, q_names = setup.t_end, setup.t_eval, setup.q_names
    checkers = [mdl for mdl in built.values() if mdl.n_u_dep or mdl.n_q_dep]
    keys = ("coordinates", "deviation", "newton_euler", "position_error", "velocity_error",
            "energy_error", "operations", "cpu_time", "evaluations", "projections",
            "messages")
    out = {key: {} for key in keys}
    note = ""
    for m in methods:
        start = time.process_time()
        res = simulate(built[m], (0.0, t_end), starts[m], t_eval=t_eval, rtol=rtol,
                       atol=atol, method=integrator)
        out["cpu_time"][m] = time.process_time() - start
        out["messages"][m] = res.message
        out["evaluations"][m] = int(res.nfev)
        out["projections"][m] = int(res.projections)
        out["coordinates"][m] = _coordinates(res, q_names)
        try:
            out["newton_euler"][m] = check_newton_euler(res)
        except ModelError as exc:  # not for this model (flexible bodies): a column less
            note = str(exc)
        out["position_error"][m], out["velocity_error"][m] = _constraint_errors(res, checkers)
        energy = res.energy
        out["energy_error"][m] = None if energy is None else energy - energy[0]
        out["operations"][m] = _operations(eoms[m])
    ref_model = built[methods[0]]
    checker = checkers[0] if checkers else None
    units = {"coordinates": {n: ref_model.state_units.get(n) for n in q_names},
             "position": list(checker.constraint_units[0]) if checker else [],
             "velocity": list(checker.constraint_units[1]) if checker else []}
    q0 = out["coordinates"][methods[0]]
    for m in methods:
        q = out["coordinates"][m]
        n = min(q.shape[1], q0.shape[1])
        out["deviation"][m] = float(np.max(np.abs(q[:, :n] - q0[:, :n]), initial=0.0))
    if note:  # the check is all or nothing for a model
        out["newton_euler"] = {}
    return FormulationComparison(model=name, methods=methods, t=t_eval,
                                 integrator=integrator, units=units, newton_euler_note=note,
                                 **out)


@dataclass(frozen=True)
class WorkPrecision:
    """CPU time against accuracy per method (see :func:`work_precision`).

    Attributes
    ----------
    model : str
    methods : tuple of str
    tolerances : tuple of float
        The ``rtol`` of each run (``atol = rtol * atol_ratio``).
    error : dict
        ``{method: ndarray (k,)}``: max |q - q_ref| over the run at each
        tolerance (the reference: the first method at ``reference_rtol``).
    cpu_per_second : dict
        ``{method: ndarray (k,)}``: CPU seconds per simulated second.
    target : float
        The accuracy at which :attr:`at_target` compares the methods.
    error_unit : str
        Unit of the error as an axis label shows it (``"[m, rad]"`` when the
        coordinates mix lengths and angles, ``"[?]"`` when unknown).
    """

    model: str
    methods: tuple
    tolerances: tuple
    error: dict
    cpu_per_second: dict
    target: float
    error_unit: str = "[?]"

    @property
    def at_target(self):
        """``{method: CPU s per simulated s at error = target}`` (log interpolation).

        ``nan`` when no run of the method reached the target accuracy.
        """
        out = {}
        for m in self.methods:
            err, cpu = self.error[m], self.cpu_per_second[m]
            ok = np.isfinite(err) & (err > 0)
            err, cpu = err[ok], cpu[ok]
            if not err.size or err.min() > self.target:
                out[m] = float("nan")
            elif err.max() <= self.target:
                out[m] = float(cpu.min())
            else:
                order = np.argsort(err)
                out[m] = float(np.exp(np.interp(np.log(self.target), np.log(err[order]),
                                                np.log(cpu[order]))))
        return out

    def table(self):
        """The figures as a text table: error / CPU s per simulated s at each tolerance."""
        from tabulate import tabulate
        title = (f"{self.model}: max |q - q_ref| / CPU s per simulated s; "
                 f"at error {self.target:.0e}: CPU s per simulated s")
        headers = ["method", *(f"rtol {t:.0e}" for t in self.tolerances), "at target"]
        target = self.at_target
        rows = [[m, *(f"{e:.1e} / {c:.4f}" for e, c in zip(self.error[m],
                                                          self.cpu_per_second[m])),
                 f"{target[m]:.4f}"] for m in self.methods]
        return title + "\n" + tabulate(rows, headers=headers, disable_numparse=True,
                                        colalign=("left",) + ("right",) * (len(headers) - 1))

    def plot(self, path=None):
        """Work-precision diagram: CPU time against error, log-log, a line per method.

        Each point is one run, labelled with its ``rtol``; the target
        accuracy is a vertical line.  Runs that failed or matched the
        reference exactly (no error to place on a log axis) are left out and
        listed on the figure.

        Parameters
        ----------
        path : str or Path, optional
            Save the figure there.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ._plotting import legend_beside, pyplot
        plt = pyplot()
        colors = method_colors(self.methods)
        fig, ax = plt.subplots(figsize=(9, 5.5), layout="constrained")
        left_out = []
        for m in self.methods:
            err, cpu = np.asarray(self.error[m]), np.asarray(self.cpu_per_second[m])
            ok = np.isfinite(err) & (err > 0) & np.isfinite(cpu) & (cpu > 0)
            left_out += [f"{m} at rtol {tol:.0e}" for tol, good in zip(self.tolerances, ok)
                         if not good]
            if not np.any(ok):
                continue
            ax.plot(err[ok], cpu[ok], "o-", color=colors[m], label=m)
            for tol, e, c in zip(np.asarray(self.tolerances)[ok], err[ok], cpu[ok]):
                ax.annotate(f"{tol:.0e}", (e, c), textcoords="offset points", xytext=(4, 4),
                            fontsize="x-small", color=colors[m])
        ax.axvline(self.target, color="0.4", ls="--", lw=0.9,
                   label=f"target error {self.target:.0e}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"error: max |q - q_ref| over the run {self.error_unit}")
        ax.set_ylabel("CPU time per simulated second [s/s]")
        ax.grid(True, which="major", alpha=0.3)
        legend_beside(ax, title="method (points: rtol)")
        if left_out:
            ax.text(0.01, 0.01, "not drawn (failed or exact): " + ", ".join(left_out),
                    transform=ax.transAxes, fontsize="x-small", color="0.4", va="bottom")
        ax.set_title(f"{self.model}: work-precision (reference: {self.methods[0]} at a "
                     "tight tolerance)", fontsize="medium")
        if path is not None:
            save_figure(fig, path, dpi=120)
        return fig


def work_precision(name, methods, tolerances=(1e-6, 1e-8, 1e-10), t_end=None,
                   target=1e-6, reference_rtol=1e-12, atol_ratio=1e-2, n_points=101,
                   integrator="RK45", constants=None, backend="numpy", **options):
    """CPU time per simulated second at equal accuracy.

    Every method runs at each tolerance; its error is the largest deviation
    of the coordinates from a reference run of the first method at
    ``reference_rtol`` (DOP853).  Methods that describe another motion (the
    augmented Lagrangean on nonholonomic systems) have large errors by
    design.

    Parameters
    ----------
    name : str
        A built-in model.
    methods : sequence of str
        Formulations; the first gives the reference.
    tolerances : sequence of float
        ``rtol`` of the runs.
    t_end : float, optional
    target : float
        Accuracy at which :attr:`WorkPrecision.at_target` compares.
    reference_rtol : float
    atol_ratio : float
        ``atol = atol_ratio * rtol``.
    n_points : int
    integrator : str
    constants : dict, optional
    backend : {"numpy", "c"}
        Numerical backend of every formulation's model.
    **options
        Model options.

    Returns
    -------
    WorkPrecision
    """
    setup = _models(name, methods, constants, options, t_end, n_points, backend)
    methods, built, starts = setup.methods, setup.built, setup.starts
    t_end, t_eval, q_names = setup.t_end, setup.t_eval, setup.q_names
    reference = simulate(built[methods[0]], (0.0, t_end), starts[methods[0]], t_eval=t_eval,
                         method="DOP853", rtol=reference_rtol, atol=reference_rtol * 1e-2)
    q_ref = _coordinates(reference, q_names)
    error = {m: np.full(len(tolerances), np.nan) for m in methods}
    cpu = {m: np.full(len(tolerances), np.nan) for m in methods}
    for m in methods:
        for k, tol in enumerate(tolerances):
            start = time.process_time()
            res = simulate(built[m], (0.0, t_end), starts[m], t_eval=t_eval, rtol=tol,
                           atol=tol * atol_ratio, method=integrator)
            cpu[m][k] = (time.process_time() - start) / t_end
            q = _coordinates(res, q_names)
            if res.success and q.shape == q_ref.shape:
                error[m][k] = float(np.max(np.abs(q - q_ref)))
    from ._plotting import unit_text
    q_units = built[methods[0]].state_units
    return WorkPrecision(model=name, methods=methods, tolerances=tuple(tolerances),
                         error=error, cpu_per_second=cpu, target=float(target),
                         error_unit=unit_text([q_units.get(n) for n in q_names]))
