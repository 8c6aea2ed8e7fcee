r"""Inverse dynamics of a parallel manipulator along a prescribed platform motion.

:func:`inverse_study` prescribes the platform pose of a parallel model (the
models whose independent coordinates are the platform pose:
``3rrr``, ``stewart-platform``, and any model declaring ``actuators``),
solves the inverse kinematics, and returns the actuator forces along the
trajectory, taken apart by cause and by body group
(:meth:`kanedyn.ActuatorMap.parts`), with the power balance
(:meth:`kanedyn.ActuatorMap.power_balance`).  :meth:`InverseStudy.forward_check`
closes the loop: the forward equations of the same model, driven by the
computed actuator forces as loads, are integrated from the prescribed initial
state and their platform pose is compared with the prescribed one.

Named trajectories (:data:`TRAJECTORIES`), built from the model's home pose
(its initial state), with :math:`T` the study's length:

``quintic``   rest to rest (:func:`kanedyn.models.quintic_pose`) in :math:`T`
              from the home pose to the home pose offset by 5 cm along every
              translation axis and 10° about every rotation axis;
``sinusoid``  :func:`kanedyn.models.sinusoid_pose` about the home pose on every
              axis, amplitude 2 cm or 5°, ``2/T`` Hz, phases spread by
              :math:`2\pi/n` over the ``n`` axes.

Inverse kinematics: closed form for ``3rrr``
(:func:`kanedyn.models.planar_3rrr_ik`); otherwise Newton's method on the
configuration constraints warm-started along the trajectory
(:func:`kanedyn.models.newton_ik`), with the Stewart platform's leg lengths
checked against their closed form (:func:`kanedyn.models.stewart_leg_lengths`).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy.physics.mechanics as me

from .._errors import ConstraintError, ModelError
from ..formulations import kane
from ..modeling import JointActuator, LinearActuator
from ..models import newton_ik, planar_3rrr_ik, quintic_pose, sinusoid_pose, stewart_leg_lengths
from ..numerics import ActuatorMap
from ..simulation import simulate
from ._plotting import pyplot

__all__ = ["inverse_study", "InverseStudy", "ForwardCheck", "TRAJECTORIES",
           "parallel_actuators", "parallel_body_groups"]

#: Named platform trajectories of :func:`inverse_study`.
TRAJECTORIES = ("quintic", "sinusoid")

_OFFSET = {"m": 0.05, "rad": np.radians(10.0)}
_AMPLITUDE = {"m": 0.02, "rad": np.radians(5.0)}


# ------------------------------------------------ actuators and body groups
def _bodies(definition):
    return {b.name: b for b in definition.kane_args["bodies"]}


def parallel_actuators(definition):
    """The actuators of a parallel model: ``definition.actuators`` when declared.

    Until every model declares its own, the 3-RRR gets joint torques on
    ``theta1..3`` (``motor1..3``, N m, on the proximal links, reacting on the
    ground) and the Stewart platform axial forces on ``s1..6`` (``leg1..6``,
    N, piston against cylinder).

    Returns
    -------
    tuple of Actuator
        Empty for a model without actuators.
    """
    declared = tuple(getattr(definition, "actuators", ()) or ())
    if declared:
        return declared
    sym, bodies = definition.symbols, _bodies(definition)
    if definition.name == "3rrr":
        N = sym["N"]
        return tuple(JointActuator(f"motor{i + 1}", th, frame=bodies[f"proximal{i + 1}"].frame,
                                   reaction_frame=N, axis=N.z)
                     for i, th in enumerate(sym["theta"]))
    if definition.name == "stewart-platform":
        out = []
        for j, s in enumerate(sym["s"]):
            piston, cylinder = bodies[f"piston{j + 1}"], bodies[f"cylinder{j + 1}"]
            out.append(JointActuator(f"leg{j + 1}", s, point=piston.masscenter,
                                     reaction_point=cylinder.masscenter,
                                     axis=piston.frame.z))
        return tuple(out)
    return ()


def parallel_body_groups(definition):
    """``{group: body names}`` of a parallel model: ``definition.body_groups`` when declared.

    Stand-ins: 3-RRR ``platform``, ``proximal links``, ``distal links``;
    Stewart platform ``platform``, ``struts`` (cylinders and pistons).
    """
    declared = dict(getattr(definition, "body_groups", {}) or {})
    if declared:
        return declared
    names = list(_bodies(definition))
    if definition.name == "3rrr":
        return {"platform": ["platform"],
                "proximal links": [b for b in names if b.startswith("proximal")],
                "distal links": [b for b in names if b.startswith("distal")]}
    if definition.name == "stewart-platform":
        return {"platform": ["platform"],
                "struts": [b for b in names if b.startswith(("cylinder", "piston"))]}
    return {}


def _check_parallel(definition):
    actuators = parallel_actuators(definition)
    pose = definition.symbols.get("pose")
    if not actuators or not pose:
        raise ModelError(f"model {definition.name} declares no actuators and platform pose; "
                         "inverse studies need a parallel model (e.g. 3rrr, "
                         "stewart-platform)")
    return actuators, list(pose)


# ------------------------------------------------------------- trajectory
class _Motion:
    """The prescribed pose ``(pose, rate, accel)`` at any times, shape ``(k, n)`` each."""

    def __init__(self, name, home, units, t_end):
        if name not in TRAJECTORIES:
            raise ModelError(f"unknown trajectory {name!r}; known: {', '.join(TRAJECTORIES)}")
        bad = [i for i, unit in enumerate(units) if unit not in _OFFSET]
        if bad:
            raise ModelError(f"trajectory {name}: pose component(s) {bad} have units "
                             f"{[units[i] for i in bad]}, neither m nor rad")
        self.name, self.home, self.t_end = name, np.asarray(home, float), float(t_end)
        self.offset = np.array([_OFFSET[u] for u in units])
        self.amplitude = np.array([_AMPLITUDE[u] for u in units])
        n = len(units)
        self.frequency = 2.0 / self.t_end
        self.phase = 2 * np.pi * np.arange(n) / n

    def __call__(self, t):
        if self.name == "quintic":
            return quintic_pose(t, self.home, self.home + self.offset, self.t_end)
        pose, rate, accel = sinusoid_pose(t, self.home, self.amplitude, self.frequency,
                                          self.phase)
        # about the home pose: subtract the offset of the phases at t = 0
        return pose - self.amplitude * np.sin(self.phase), rate, accel


class _Kinematics:
    """Inverse kinematics of a parallel model at given times: states and all rates."""

    def __init__(self, definition, model, n_pose):
        self.definition, self.model, self.n_pose = definition, model, n_pose
        self.guess = definition.initial(model)[:model.n_q]

    def __call__(self, t, pose, rate, accel):
        model, name = self.model, self.definition.name
        t = np.atleast_1d(np.asarray(t, float))
        if name == "3rrr":
            geometry = {k: model.constants[k] for k in ("R_b", "r_p", "l_1", "l_2")}
            q, u, ud = planar_3rrr_ik(pose, rate, accel, geometry=geometry)
            Y = np.hstack([np.atleast_2d(q), np.atleast_2d(u)])
            Ud = np.atleast_2d(ud)
        else:
            Y, Ud = newton_ik(model, t, pose, rate, accel, guess=self.guess)
            if name == "stewart-platform":
                self._check_lengths(Y)
        self.guess = Y[-1, :model.n_q].copy()
        return Y, Ud

    def _check_lengths(self, Y):
        model = self.model
        geometry = {k: model.constants[k] for k in ("R_b", "r_p")}
        closed = stewart_leg_lengths(Y[:, :6], geometry=geometry)
        first = model.state_names.index("s1")
        gap = np.max(np.abs(Y[:, first:first + 6] - closed))
        if not gap < 1e-9:
            raise ConstraintError(f"stewart-platform: Newton's leg lengths differ from the "
                                  f"closed form by {gap:.3g} m")


# ----------------------------------------------------------------- results
@dataclass(frozen=True)
class ForwardCheck:
    """Forward dynamics driven by the inverse-dynamics forces, against the prescription.

    Attributes
    ----------
    t : numpy.ndarray, shape (N,)
        Output times, s.
    pose, prescribed : numpy.ndarray, shape (n_pose, N)
        Simulated and prescribed platform pose (m, rad).
    error : numpy.ndarray, shape (N,)
        Largest pose-component difference at each time (m or rad).
    max_error : float
    success : bool
        The integration's success.
    message : str
    rhs_evaluations : int
    """

    t: np.ndarray
    pose: np.ndarray
    prescribed: np.ndarray
    error: np.ndarray
    max_error: float
    success: bool
    message: str
    rhs_evaluations: int


@dataclass(frozen=True)
class InverseStudy:
    r"""Actuator forces along a prescribed platform motion (see :func:`inverse_study`).

    Arrays have one column per point, as ``SimulationResult.y``.

    Attributes
    ----------
    model_name, trajectory : str
    names : tuple of str
        Actuators.
    units : tuple of str
        Unit of each actuator's force (``"N"`` or ``"N m"``; ``"?"`` unknown).
    pose_names : tuple of str
    pose_units : tuple of str
    t : numpy.ndarray, shape (N,)
        Times, s.
    pose, pose_rate, pose_accel : numpy.ndarray, shape (n_pose, N)
        The prescribed platform motion.
    q, u, udot : numpy.ndarray, shape (n_q, N) / (n_u, N)
        All coordinates, speeds and speed rates after the inverse kinematics.
    forces : numpy.ndarray, shape (k, N)
        Actuator forces along their rates.
    causes, groups : dict
        ``{cause or group: array (k, N)}`` (:class:`kanedyn.ActuatorParts`);
        each sums to ``forces``.
    power : kanedyn.numerics.PowerBalance
        Actuator power and the energies' rates, W.
    condition : numpy.ndarray, shape (N,)
        Condition number of the actuator-rate Jacobian.
    """

    model_name: str
    trajectory: str
    names: tuple
    units: tuple
    pose_names: tuple
    pose_units: tuple
    t: np.ndarray
    pose: np.ndarray
    pose_rate: np.ndarray
    pose_accel: np.ndarray
    q: np.ndarray
    u: np.ndarray
    udot: np.ndarray
    forces: np.ndarray
    causes: dict
    groups: dict
    power: object
    condition: np.ndarray
    _context: dict = field(default_factory=dict, repr=False, compare=False)

    # ------------------------------------------------------------ numbers
    @property
    def peak_forces(self):
        """``{actuator: largest absolute force}`` over the trajectory."""
        return {n: float(np.max(np.abs(f))) for n, f in zip(self.names, self.forces)}

    @property
    def power_residual(self):
        """Largest absolute power-balance residual over the largest absolute actuator power.

        The residual itself (W) when the actuators do no work.
        """
        scale = float(np.max(np.abs(self.power.actuator)))
        worst = float(np.max(np.abs(self.power.residual)))
        return worst / scale if scale > 0 else worst

    # -------------------------------------------------------- round trip
    def force_function(self):
        """``f(t) -> forces (k,)``: the actuator forces at any time, exactly.

        The prescribed pose at ``t`` goes through the inverse kinematics and
        :meth:`kanedyn.ActuatorMap.forces`; the last time's forces are kept,
        so that the ``k`` specified inputs of one right-hand side share one
        solve.
        """
        ctx = self._context
        motion, amap = ctx["motion"], ctx["amap"]
        kin = _Kinematics(ctx["definition"], amap.model, len(self.pose_names))
        kin.guess = self.q[:, 0].copy()
        p = amap.model.n_u_ind
        last = {}

        def forces(t):
            t = float(t)
            if last.get("t") != t:
                pose, rate, accel = motion(np.array([t]))
                Y, Ud = kin(np.array([t]), pose, rate, accel)
                last["t"], last["f"] = t, amap.forces(t, Y[0], Ud[0, :p]).forces
            return last["f"]

        return forces

    def forward_check(self, method="DOP853", rtol=1e-11, atol=1e-11, points=None):
        """Integrate the forward model driven by the actuator forces; compare the pose.

        The forward equations are those of the same model with each
        actuator's load (``actuator.to_loads(F(t))``, ``F`` a specified
        input) added, and the drive trains' inertia elements in the bodies.
        They start from the prescribed initial state.

        Parameters
        ----------
        method : str
            ``solve_ivp`` method (DOP853 or Radau for tight tolerances).
        rtol, atol : float
        points : int, optional
            Output times; default: those of the study.

        Returns
        -------
        ForwardCheck
        """
        ctx = self._context
        definition, amap = ctx["definition"], ctx["amap"]
        forward = _forward_model(definition, amap, self.force_function(), ctx["constants"])
        t = self.t if points is None else np.linspace(self.t[0], self.t[-1], int(points))
        y0 = np.concatenate([self.q[:, 0], self.u[:, 0]])
        res = simulate(forward, (float(t[0]), float(t[-1])), y0, method=method, rtol=rtol,
                       atol=atol, t_eval=t)
        n = len(self.pose_names)
        prescribed = ctx["motion"](res.t)[0].T
        pose = res.y[:n]
        error = np.max(np.abs(pose - prescribed), axis=0) if res.t.size else np.zeros(0)
        worst = float(np.max(error)) if error.size else float("inf")
        return ForwardCheck(t=res.t, pose=pose, prescribed=prescribed, error=error,
                            max_error=worst, success=bool(res.success),
                            message=str(res.message), rhs_evaluations=int(res.nfev))

    # --------------------------------------------------------------- files
    def to_csv(self, directory):
        """Write ``forces.csv``, ``causes.csv``, ``groups.csv`` into ``directory``.

        ``forces.csv``: time (s), the prescribed pose, the actuator forces,
        the actuator power, the energies' rate and the power residual (W).
        ``causes.csv`` / ``groups.csv``: one column ``actuator:part`` per
        actuator and cause or group.

        Returns
        -------
        list of pathlib.Path
        """
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        bal = self.power
        energy = bal.kinetic_rate + bal.drive_rate + bal.potential_rate - bal.wrench_power
        main = {"t [s]": self.t}
        main.update({f"{n} [{u}]": row for n, u, row in
                     zip(self.pose_names, self.pose_units, self.pose)})
        main.update({f"{n} [{u}]": row for n, u, row in zip(self.names, self.units,
                                                            self.forces)})
        main.update({"actuator power [W]": bal.actuator, "energy rate [W]": energy,
                     "power residual [W]": bal.residual})
        paths = [_write(directory / "forces.csv", main)]
        for label, parts in (("causes", self.causes), ("groups", self.groups)):
            cols = {"t [s]": self.t}
            for part, arr in parts.items():
                cols.update({f"{n}:{part} [{u}]": row for n, u, row in
                             zip(self.names, self.units, arr)})
            paths.append(_write(directory / f"{label}.csv", cols))
        return paths

    def plot(self, directory):
        """Write ``forces.png``, ``causes.png``, ``groups.png`` and ``power.png``.

        Returns
        -------
        list of pathlib.Path
        """
        plt = pyplot()
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        title = f"{self.model_name}, {self.trajectory} trajectory"
        paths = []
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for n, u, f in zip(self.names, self.units, self.forces):
            ax.plot(self.t, f, label=f"{n} [{u}]")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"actuator force {_unit_label(self.units)}")
        ax.set_title(f"Actuator forces: {title}")
        ax.legend(ncol=2, fontsize="small")
        ax.grid(alpha=0.3)
        paths.append(_save(fig, directory / "forces.png", plt))
        for label, parts in (("causes", self.causes), ("groups", self.groups)):
            fig = self._parts_figure(plt, parts, f"Actuator forces by {label[:-1]}: {title}")
            paths.append(_save(fig, directory / f"{label}.png", plt))
        fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        bal = self.power
        energy = bal.kinetic_rate + bal.drive_rate + bal.potential_rate - bal.wrench_power
        top.plot(self.t, bal.actuator, label="actuator power  Σ f·ṡ")
        top.plot(self.t, energy, "--", label="dT/dt + dV/dt − P_wrench")
        top.set_ylabel("power [W]")
        top.set_title(f"Power balance: {title}")
        top.legend(fontsize="small")
        top.grid(alpha=0.3)
        bottom.plot(self.t, bal.residual, color="C3", label="residual")
        bottom.set_xlabel("time [s]")
        bottom.set_ylabel("residual [W]")
        bottom.legend(fontsize="small")
        bottom.grid(alpha=0.3)
        paths.append(_save(fig, directory / "power.png", plt))
        return paths

    def _parts_figure(self, plt, parts, title):
        k = len(self.names)
        cols = 3 if k > 4 else k
        rows = -(-k // cols)
        fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3 * rows + 0.8),
                                 sharex=True, squeeze=False)
        scale = 1e-9 * np.max(np.abs(self.forces))  # leave out parts at round-off
        shown = [p for p, arr in parts.items() if np.max(np.abs(arr)) > scale]
        for i, ax in enumerate(axes.flat):
            if i >= k:
                ax.set_visible(False)
                continue
            for j, part in enumerate(shown):
                ax.plot(self.t, parts[part][i], color=f"C{j}", label=part)
            ax.plot(self.t, self.forces[i], "k--", lw=1, label="total")
            ax.set_title(self.names[i], fontsize="medium")
            ax.set_ylabel(f"[{self.units[i]}]")
            ax.grid(alpha=0.3)
            if i // cols == rows - 1 or i + cols >= k:
                ax.set_xlabel("time [s]")
        handles, labels = axes.flat[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize="small")
        fig.suptitle(title)
        fig.tight_layout(rect=(0, 0.06, 1, 1))
        return fig

    def _repr_html_(self):
        rows = "".join(f"<tr><td>{n}</td><td>{v:.4g} {u}</td></tr>"
                       for (n, v), u in zip(self.peak_forces.items(), self.units))
        return (f"<p><b>{self.model_name}</b>, {self.trajectory} trajectory, "
                f"{self.t.size} points, power-balance residual "
                f"{self.power_residual:.2e}</p><table><tr><th>actuator</th>"
                f"<th>peak |force|</th></tr>{rows}</table>")


def _unit_label(units):
    return f"[{', '.join(sorted(set(units)))}]"


def _save(fig, path, plt):
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _write(path, columns):
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(columns))
        for row in zip(*columns.values()):
            writer.writerow([repr(float(v)) for v in row])
    return path


def _force_unit(actuator, state_units):
    if isinstance(actuator, LinearActuator):
        return "N"
    expr = getattr(actuator, "expression", None)
    units = {state_units.get(str(s.func)) for s in me.find_dynamicsymbols(expr)} \
        if expr is not None else {None}
    if units == {"rad"}:
        return "N m"
    if units == {"m"}:
        return "N"
    return "?"


def _forward_model(definition, amap, force_of_t, constants):
    """The model's forward equations with the actuators' loads as specified inputs."""
    args = dict(definition.kane_args)
    loads, bodies, specified = list(args["loads"]), list(args["bodies"]), {}
    for i, actuator in enumerate(amap.actuators):
        magnitude = me.dynamicsymbols(f"F_{actuator.name}")
        loads += actuator.to_loads(magnitude)
        specified[magnitude] = (lambda t, i=i: force_of_t(t)[i])
        element = getattr(actuator, "inertia_element", None)
        element = element() if element is not None else None
        if element is not None:
            bodies.append(element)
        elif actuator.reflected_inertia != 0:
            raise ModelError(f"actuator {actuator.name!r}: its transmission's inertia cannot "
                             "be put into the forward equations (no inertia_element)")
    args.update(loads=loads, bodies=bodies)
    eom = kane(**args)
    return definition.numeric(eom, constants=constants, specified=specified)


# -------------------------------------------------------------- the study
def inverse_study(definition, trajectory="quintic", t_end=None, points=201, backend="numpy",
                  constants=None, eom=None):
    """Actuator forces of a parallel model along a named platform trajectory.

    Parameters
    ----------
    definition : ModelDefinition
        A parallel model (``kd.models.build("3rrr")``, ``"stewart-platform"``,
        or one declaring ``actuators``).
    trajectory : {"quintic", "sinusoid"}
        See :mod:`kanedyn.analysis._inverse_study`.
    t_end : float, optional
        Length of the manoeuvre, s (default: the model's ``t_end``).
    points : int
        Trajectory points (at least 2).
    backend : {"numpy", "c"}
        Backend of the numerical model.
    constants : dict, optional
        ``{name or symbol: value}`` overriding the model's constants.
    eom : EquationsOfMotion, optional
        Already derived equations of ``definition``.

    Returns
    -------
    InverseStudy

    Raises
    ------
    ModelError
        For a model without actuators or platform pose, an unknown trajectory.
    ConstraintError
        When a pose is out of reach.
    """
    actuators, pose_syms = _check_parallel(definition)
    if trajectory not in TRAJECTORIES:
        raise ModelError(f"unknown trajectory {trajectory!r}; known: {', '.join(TRAJECTORIES)}")
    t_end = float(definition.t_end if t_end is None else t_end)
    if not (np.isfinite(t_end) and t_end > 0):
        raise ModelError(f"t_end must be a finite number > 0, got {t_end!r}")
    if int(points) < 2:
        raise ModelError(f"points must be at least 2, got {points!r}")
    eom = definition.derive() if eom is None else eom
    model = definition.numeric(eom, constants=constants, backend=backend)
    amap = ActuatorMap(model, actuators)
    units = model.state_units
    pose_names = tuple(str(s.func) for s in pose_syms)
    if model.state_names[:len(pose_names)] != pose_names:
        raise ModelError(f"model {definition.name}: the pose {pose_names} must be the first "
                         f"coordinates, not {model.state_names[:len(pose_names)]}")
    pose_units = tuple(units.get(n) for n in pose_names)
    home = definition.initial(model)[:len(pose_names)]
    motion = _Motion(trajectory, home, pose_units, t_end)
    t = np.linspace(0.0, t_end, int(points))
    pose, rate, accel = motion(t)
    Y, Ud = _Kinematics(definition, model, len(pose_names))(t, pose, rate, accel)
    n, p = model.n_q, model.n_u_ind
    q, u, udot = Y[:, :n].T, Y[:, n:].T, Ud.T
    g = next((s for s in eom.constants if str(s) == "g"), None)
    groups = {k: list(v) for k, v in parallel_body_groups(definition).items()}
    parts = amap.parts(t, q, u, udot, groups=groups, gravity=g)
    power = amap.power_balance(t, q, u, udot, gravity=g)
    condition = np.array([amap.forces(t[i], Y[i], Ud[i, :p]).condition
                          for i in range(t.size)])
    context = dict(definition=definition, amap=amap, motion=motion,
                   constants=dict(constants or {}))
    return InverseStudy(
        model_name=definition.name, trajectory=trajectory, names=amap.names,
        units=tuple(_force_unit(a, units) for a in actuators), pose_names=pose_names,
        pose_units=pose_units, t=t, pose=pose.T, pose_rate=rate.T, pose_accel=accel.T,
        q=q, u=u, udot=udot, forces=parts.total, causes=parts.causes, groups=parts.groups,
        power=power, condition=condition, _context=context)
