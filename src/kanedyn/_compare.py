"""One model, several formulations: the same motion, or not, and who is right.

:func:`compare_formulations` derives a built-in model by each method in the
formulation registry, starts every run from the same physical state
(coordinates and their rates; multipliers of the augmented Lagrangean at
zero), integrates them with the same tolerances and reports, per method: how
far the coordinates drift from the first method's, the Newton–Euler residual
of every body with the identified constraint forces
(:func:`kanedyn.check_newton_euler`), the velocity-constraint residual, the
energy drift and the CPU time.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ._errors import ModelError
from ._newton_euler import check_newton_euler
from ._simulate import simulate

__all__ = ["compare_formulations", "FormulationComparison", "NONHOLONOMIC_EXAMPLES"]

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
        ``{method: NewtonEulerCheck}``.
    constraint_residual : dict
        ``{method: max |velocity-constraint residual|}`` (``nan`` when it
        cannot be evaluated).
    energy_drift : dict
        ``{method: max |E - E(0)|}`` (``nan`` for models without an energy).
    cpu_time : dict
        ``{method: seconds}`` of the integration.
    messages : dict
        ``{method: the integrator's message}``.
    """

    model: str
    methods: tuple
    t: np.ndarray
    coordinates: dict
    deviation: dict
    newton_euler: dict
    constraint_residual: dict
    energy_drift: dict
    cpu_time: dict
    messages: dict

    def table(self):
        """The figures as a text table."""
        head = (f"{'method':<11} {'max|q-q_ref|':>13} {'N-E force':>10} {'N-E moment':>11} "
                f"{'N-E rel':>9} {'constraint':>11} {'energy':>10} {'cpu [s]':>8}")
        lines = [f"{self.model}: t = 0..{self.t[-1]:g} s "
                 f"(reference: {self.methods[0]}; N-E multipliers: "
                 + ", ".join(f"{m} {self.newton_euler[m].source}" for m in self.methods)
                 + ")", head]
        for m in self.methods:
            ne = self.newton_euler[m]
            rel = ne.max / ne.inertia_scale if ne.inertia_scale else np.nan
            lines.append(f"{m:<11} {self.deviation[m]:13.3e} {ne.max_force:10.2e} "
                         f"{ne.max_moment:11.2e} {rel:9.1e} "
                         f"{self.constraint_residual[m]:11.2e} "
                         f"{self.energy_drift[m]:10.2e} {self.cpu_time[m]:8.3f}")
        return "\n".join(lines)


def _rate_name(q_name):
    return q_name + "_d"


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


def _velocity_residual(res, checkers):
    """Largest velocity-constraint residual of a run.

    A model without velocity constraints of its own (the augmented
    Lagrangean's) is measured with another model whose states it contains.
    """
    model = res.model
    if model.n_u_dep:
        return float(np.max(np.abs(res.constraint_residuals[model.n_q_dep:]), initial=0.0))
    names = list(model.state_names)
    checker = next((c for c in checkers if set(c.state_names) <= set(names)), None)
    if checker is None:
        return float("nan")
    idx = [names.index(n) for n in checker.state_names]
    worst = 0.0
    for k in range(res.t.size):
        c = checker.constraint_residuals(res.t[k], res.y[idx, k])[checker.n_q_dep:]
        worst = max(worst, float(np.max(np.abs(c), initial=0.0)))
    return worst


def compare_formulations(name, methods=("kane", "lagrange", "augmented"), t_end=None,
                         rtol=1e-10, atol=1e-12, n_points=201, **options):
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
    **options
        Model options (as for :func:`kanedyn.models.build`).

    Returns
    -------
    FormulationComparison
    """
    from . import models
    methods = tuple(methods)
    if not methods:
        raise ModelError("give at least one formulation to compare")
    definition = models.build(name, **options)
    t_end = definition.t_end if t_end is None else float(t_end)
    t_eval = np.linspace(0.0, t_end, n_points)
    built = {m: definition.numeric(definition.derive(method=m)) for m in methods}
    ref = built[methods[0]]
    y_ref = ref.state(definition.initial(ref))
    qdot_ref = ref.rhs(0.0, y_ref)[:ref.n_q]
    q_names = ref.state_names[:ref.n_q]
    checkers = [mdl for mdl in built.values() if mdl.n_u_dep]
    out = {key: {} for key in ("coordinates", "deviation", "newton_euler",
                               "constraint_residual", "energy_drift", "cpu_time",
                               "messages")}
    for m in methods:
        model = built[m]
        y0 = y_ref if m == methods[0] else _initial_state(model, ref, y_ref, qdot_ref)
        start = time.process_time()
        res = simulate(model, (0.0, t_end), y0, t_eval=t_eval, rtol=rtol, atol=atol)
        out["cpu_time"][m] = time.process_time() - start
        out["messages"][m] = res.message
        q = np.array([res[n] for n in q_names])
        out["coordinates"][m] = q
        out["newton_euler"][m] = check_newton_euler(res)
        out["constraint_residual"][m] = _velocity_residual(res, checkers)
        energy = res.energy
        out["energy_drift"][m] = (float(np.max(np.abs(energy - energy[0])))
                                  if energy is not None else float("nan"))
    q0 = out["coordinates"][methods[0]]
    for m in methods:
        q = out["coordinates"][m]
        n = min(q.shape[1], q0.shape[1])
        out["deviation"][m] = float(np.max(np.abs(q[:, :n] - q0[:, :n]), initial=0.0))
    return FormulationComparison(model=name, methods=methods, t=t_eval, **out)
