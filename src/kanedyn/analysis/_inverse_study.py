r"""Inverse-dynamics study of an actuated model along a named platform trajectory.

:func:`inverse_study` takes a model definition that declares its actuators
(``definition.actuators``) and body groups (``definition.body_groups``),
prescribes a platform motion (``"quintic"``: rest to rest from the home pose
to an offset pose; ``"sinusoid"``: about the home pose), completes the
dependent coordinates, speeds and rates by inverse kinematics (closed form
where the model has one, else Newton's method warm-started along the
trajectory) and returns an :class:`InverseStudy`: the actuator forces, their
parts by cause and by body group, and the power balance.
:meth:`InverseStudy.forward_check` drives the forward model with the computed
forces and measures how closely the platform follows the prescription.
"""

from __future__ import annotations

import csv
import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._errors import KanedynError, ModelError
from .._output_files import replacing, save_figure

__all__ = ["InverseStudy", "inverse_study", "TRAJECTORIES", "trajectory_offsets"]

#: Named trajectories of :func:`inverse_study`.
TRAJECTORIES = ("quintic", "sinusoid")

# closed-form inverse kinematics: model name -> (geometry constants it assumes)
_GEOMETRY = {"3rrr": ("R_b", "r_p", "l_1", "l_2"),
             "out-parallel-6dof": ("R_b", "r_p", "L")}


# the pose a pose file gives (kanedyn.analysis.read_pose_csv)
_POSE_FILE_NAMES = ("x", "y", "z", "phi_x", "phi_y", "phi_z")


def trajectory_offsets(definition):
    """Offset of each pose component for the named trajectories (m or rad).

    5 cm and 10° in each pose axis; 3 cm and 5° for the planar 3-RRR, whose
    legs have less reach.  An angle is a pose component named ``phi...``.
    """
    names = [str(s).removesuffix("(t)") for s in definition.symbols["pose"]]
    small = definition.name == "3rrr"
    length, angle = (0.03, np.radians(5.0)) if small else (0.05, np.radians(10.0))
    return np.array([angle if n.startswith("phi") else length for n in names])


def _pose_motion(name, home, offsets, t_end):
    """``f(t) -> (pose, rate, accel)``, each of shape ``(len(t), n)``."""
    from ..models import quintic_pose, sinusoid_pose
    if name == "quintic":
        return lambda t: quintic_pose(t, home, home + offsets, t_end)
    if name == "sinusoid":
        n = home.size
        phase = 2 * np.pi * np.arange(n) / n
        return lambda t: sinusoid_pose(t, home, offsets, 1.0 / t_end, phase)
    raise KanedynError(f"unknown trajectory {name!r}; available: {', '.join(TRAJECTORIES)}")


class _Kinematics:
    """Inverse kinematics of one model, a point or a trajectory at a time."""

    def __init__(self, definition, model, overrides):
        from ..models import out_parallel_ik, planar_3rrr_ik
        self.model = model
        geometry = _GEOMETRY.get(definition.name)
        changed = geometry is not None and any(
            str(k) in geometry for k in overrides)
        closed = {"3rrr": planar_3rrr_ik, "out-parallel-6dof": out_parallel_ik}
        self.closed = None if changed else closed.get(definition.name)
        geometry = definition.symbols.get("geometry")
        if self.closed is not None and geometry is not None:
            self.closed = functools.partial(self.closed, geometry=geometry)
        self.method = ("closed form" if self.closed is not None
                       else "Newton (warm-started)")
        y0 = definition.initial(model)
        self.guess = np.asarray(y0[:model.n_q], float)

    def __call__(self, t, pose, rate, accel):
        """Coordinates, speeds and rates, shapes ``(k, n_q)``, ``(k, n_u)``, ``(k, n_u)``."""
        if self.closed is not None:
            q, u, ud = self.closed(pose, rate, accel)
            return np.atleast_2d(q), np.atleast_2d(u), np.atleast_2d(ud)
        from ..models import newton_ik
        model = self.model
        Y, Ud = newton_ik(model, t, pose, rate, accel, guess=self.guess)
        self.guess = Y[-1, :model.n_q].copy()
        return Y[:, :model.n_q], Y[:, model.n_q:], Ud


def _unit(actuator):
    return "N m" if getattr(actuator, "frame", None) is not None else "N"


@dataclass(frozen=True)
class InverseStudy:
    r"""Actuator forces along a prescribed motion, taken apart, with the power balance.

    Attributes
    ----------
    model_name, trajectory : str
    t : numpy.ndarray, shape (N,)
        Times, s.
    pose_names : tuple of str
    pose, pose_rate, pose_accel : numpy.ndarray, shape (N, n_pose)
        Prescribed platform pose (m, rad) and its rates.
    q, u, udot : numpy.ndarray, shape (N, n_q), (N, n_u), (N, n_u)
        All coordinates, speeds and rates after the inverse kinematics.
    ik_method : str
        ``"closed form"`` or ``"Newton (warm-started)"``.
    names, units : tuple of str
        Actuator names (``definition.actuators``) and their units (N or N m).
    forces : numpy.ndarray, shape (k, N)
    condition : numpy.ndarray, shape (N,)
        Condition number of the actuator-rate Jacobian at each point.
    causes, groups : dict
        ``{cause or group: array (k, N)}`` (see :class:`kanedyn.ActuatorParts`).
    power : PowerBalance
        Arrays of shape ``(N,)``, W.
    rates, rate_derivatives : numpy.ndarray, shape (k, N)
        Actuator rates :math:`\dot s` and :math:`\ddot s` (m/s, m/s² or rad/s,
        rad/s²).
    motors : MotorTorques or None
        Motor torques, speeds and powers when every actuator has a
        :class:`~kanedyn.BallScrew` (:func:`kanedyn.analysis.motor_torques`).
    limit_check : LimitCheck or None
        The actuator limits checked along the path, with the first violation
        (:func:`kanedyn.analysis.check_actuator_limits`); None without limits.
    """

    model_name: str
    trajectory: str
    t: np.ndarray
    pose_names: tuple
    pose: np.ndarray
    pose_rate: np.ndarray
    pose_accel: np.ndarray
    q: np.ndarray
    u: np.ndarray
    udot: np.ndarray
    ik_method: str
    names: tuple
    units: tuple
    forces: np.ndarray
    condition: np.ndarray
    causes: dict
    groups: dict
    power: object
    rates: np.ndarray = None
    rate_derivatives: np.ndarray = None
    motors: object = None
    limit_check: object = None
    extra: dict = field(default_factory=dict, repr=False, compare=False)

    # ------------------------------------------------------------ summaries
    def peak_forces(self):
        """``{actuator: largest absolute force}`` (N or N m)."""
        return {n: float(np.max(np.abs(f))) for n, f in zip(self.names, self.forces)}

    @property
    def peak_actuator(self):
        """Name of the actuator with the largest absolute force."""
        return self.names[int(np.argmax(np.max(np.abs(self.forces), axis=1)))]

    def power_residual(self):
        """Largest absolute power-balance residual over the peak absolute actuator power.

        A relative number (dimensionless).
        """
        scale = float(np.max(np.abs(self.power.actuator)))
        worst = float(np.max(np.abs(self.power.residual)))
        return worst / scale if scale > 0 else worst

    # ---------------------------------------------------------- round trip
    def forward_check(self, rtol=1e-11, atol=1e-11, method="DOP853"):
        """Drive the forward model with the computed forces; the largest pose error.

        The actuator forces are an exact function of time (pose -> inverse
        kinematics -> :meth:`ActuatorMap.forces`), applied as specified inputs
        through each actuator's ``to_loads``; actuators with a transmission
        bring their drive-train inertia (``inertia_element()``) into the
        forward model's bodies.  Integrated from the prescribed initial state.

        Returns
        -------
        float
            ``max |pose(t) - prescribed pose(t)|`` over the output times (m and
            rad mixed). ``inf`` when the integration fails.
        """
        res = self.extra["forward"](rtol, atol, method)
        if not res.success:
            return float("inf")
        n = len(self.pose_names)
        return float(np.max(np.abs(res.y[:n].T - self.pose)))

    # ---------------------------------------------------------------- files
    def to_csv(self, directory):
        """Write ``forces.csv``, ``causes.csv``, ``groups.csv``, ``power.csv``.

        With ball screws also ``motors.csv``: each motor's torque (N m), speed
        (rad/s), power (W) and torque parts (N m).

        Returns the list of paths written.
        """
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        head = ["t [s]"] + [f"{n}" for n in self.pose_names]
        rows = np.column_stack([self.t, self.pose])
        tables = {
            "forces.csv": (head + [f"{n} [{u}]" for n, u in zip(self.names, self.units)]
                           + ["condition"],
                           np.column_stack([rows, self.forces.T, self.condition])),
            "causes.csv": self._parts_table(self.causes),
            "groups.csv": self._parts_table(self.groups),
        }
        pw = self.power
        powers = {"actuator": pw.actuator, "kinetic_rate": pw.kinetic_rate,
                  "drive_rate": pw.drive_rate, "potential_rate": pw.potential_rate,
                  "wrench_power": pw.wrench_power, "residual": pw.residual}
        tables["power.csv"] = (["t [s]"] + [f"{k} [W]" for k in powers],
                               np.column_stack([self.t, *powers.values()]))
        if self.motors is not None:
            tables["motors.csv"] = _motor_table(self.motors)
        paths = []
        for name, (header, data) in tables.items():
            path = out / name
            with replacing(path, newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(header)
                writer.writerows([[repr(float(x)) for x in row] for row in data])
            paths.append(path)
        return paths

    def _parts_table(self, parts):
        header, cols = ["t [s]"], [self.t]
        for i, (n, u) in enumerate(zip(self.names, self.units)):
            for part, arr in parts.items():
                header.append(f"{n}:{part} [{u}]")
                cols.append(arr[i])
        return header, np.column_stack(cols)

    def plot(self, directory):
        """Write ``forces.png``, ``decomposition.png`` and ``power.png``; their paths.

        With ball screws also ``motors.png`` (torque and power per motor) and
        ``motor_decomposition.png`` (the peak motor's torque by part).
        """
        from ._plotting import pyplot
        plt = pyplot()
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        what = f"{self.model_name}, {self.trajectory} trajectory"
        unit = " / ".join(sorted(set(self.units)))
        paths = []

        fig, ax = plt.subplots(figsize=(8, 4.5))
        for n, f in zip(self.names, self.forces):
            ax.plot(self.t, f, label=n)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"actuator force [{unit}]")
        ax.set_title(f"Actuator forces: {what}")
        ax.grid(True, alpha=0.3)
        ax.legend(ncol=min(len(self.names), 3), fontsize="small")
        paths.append(_save(plt, fig, out / "forces.png"))

        name = self.peak_actuator
        i = self.names.index(name)
        u = self.units[i]
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
        for ax, parts, kind in ((axes[0], self.causes, "cause"),
                                (axes[1], self.groups, "body group")):
            ax.plot(self.t, self.forces[i], "k", lw=2.2, label="total")
            for part, arr in parts.items():
                if np.max(np.abs(arr[i])) > 1e-12 * max(1.0, np.max(np.abs(self.forces[i]))):
                    ax.plot(self.t, arr[i], label=part)
            ax.set_xlabel("t [s]")
            ax.set_title(f"{name} by {kind}")
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize="small")
        axes[0].set_ylabel(f"{name} [{u}]")
        fig.suptitle(f"Decomposition of the peak actuator's force: {what}")
        paths.append(_save(plt, fig, out / "decomposition.png"))

        pw = self.power
        fig, (ax, axr) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True,
                                      gridspec_kw={"height_ratios": [3, 1]})
        ax.plot(self.t, pw.actuator, "k", lw=2.2, label="actuator power Σ f·ṡ")
        ax.plot(self.t, pw.kinetic_rate + pw.drive_rate, label="dT/dt (bodies + drives)")
        ax.plot(self.t, pw.potential_rate, label="dV/dt")
        if np.any(pw.wrench_power):
            ax.plot(self.t, -pw.wrench_power, label="− wrench power")
        ax.set_ylabel("power [W]")
        ax.set_title(f"Power balance: {what}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
        axr.plot(self.t, pw.residual, "r", label="residual")
        axr.set_xlabel("t [s]")
        axr.set_ylabel("residual [W]")
        axr.grid(True, alpha=0.3)
        axr.legend(fontsize="small")
        paths.append(_save(plt, fig, out / "power.png"))
        if self.motors is not None:
            paths += _plot_motors(plt, self.motors, what, out)
        return paths


def _motor_table(motors):
    header, cols = ["t [s]"], [motors.t]
    for i, n in enumerate(motors.names):
        for label, arr in (("torque [N m]", motors.torque), ("speed [rad/s]", motors.speed),
                           ("power [W]", motors.power)):
            header.append(f"{n}:{label}")
            cols.append(arr[i])
        for part, arr in motors.parts.items():
            header.append(f"{n}:torque {part} [N m]")
            cols.append(arr[i])
    return header, np.column_stack(cols)


def _plot_motors(plt, motors, what, out):
    fig, (ax, axp) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for n, tau, power in zip(motors.names, motors.torque, motors.power):
        ax.plot(motors.t, tau, label=n)
        axp.plot(motors.t, power, label=n)
    ax.set_ylabel("motor torque [N m]")
    ax.set_title(f"Motor torques and powers: {what}")
    axp.set_ylabel("motor power [W]")
    axp.set_xlabel("t [s]")
    for a in (ax, axp):
        a.grid(True, alpha=0.3)
        a.legend(ncol=min(len(motors.names), 3), fontsize="small")
    paths = [_save(plt, fig, out / "motors.png")]

    i = int(np.argmax(np.max(np.abs(motors.torque), axis=1)))
    name = motors.names[i]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(motors.t, motors.torque[i], "k", lw=2.2, label="total")
    scale = max(1.0, float(np.max(np.abs(motors.torque[i]))))
    for part, arr in motors.parts.items():
        if np.max(np.abs(arr[i])) > 1e-12 * scale:
            ax.plot(motors.t, arr[i], label=part)
    back = motors.back_driven[i]
    if back.any():
        ax.fill_between(motors.t, 0, 1, where=back, color="0.85", alpha=0.6,
                        transform=ax.get_xaxis_transform(), label="back-driven")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{name} motor torque [N m]")
    ax.set_title(f"{name} motor torque by part: {what}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", ncol=2)
    paths.append(_save(plt, fig, out / "motor_decomposition.png"))
    return paths


def _save(plt, fig, path):
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def _gravity_symbol(definition):
    for s in definition.constants:
        if str(s) == "g":
            return s
    return None


def inverse_study(definition, trajectory="quintic", t_end=None, points=201,
                  backend="numpy", constants=None, model=None, wrench=None, poses=None,
                  limits=None):
    r"""Actuator forces of a parallel model along a named trajectory.

    Parameters
    ----------
    definition : ModelDefinition or str
        A model with ``actuators`` declared (``3rrr``, ``stewart-platform``,
        ``out-parallel-6dof``), or its name.
    trajectory : {"quintic", "sinusoid"}
        ``"quintic"``: rest to rest from the home pose to the home pose plus
        :func:`trajectory_offsets` in every pose axis over ``t_end``;
        ``"sinusoid"``: those offsets as amplitudes about the home pose, one
        period over ``t_end``, the axes' phases spread over 2π.
    t_end : float, optional
        Duration, s (default: the definition's ``t_end``).
    points : int
        Number of trajectory points (at least 2).
    backend : {"numpy", "c"}
    constants : dict, optional
        Overrides of the definition's constants (``{name: value}``).
    model : NumericModel, optional
        Built from ``definition.derive()`` without the drive-train elements
        (derived here if omitted).
    wrench : array_like, shape (6,), or WrenchTable or callable, optional
        An external wrench on the platform, ``Fx, Fy, Fz`` (N), ``Mx, My, Mz``
        (N m) in the ground frame, constant or a function of time
        (:func:`kanedyn.analysis.with_platform_wrench`).  Not together with
        ``model``: build that from ``with_platform_wrench(definition, wrench)``.
    poses : PoseTable, optional
        A platform trajectory read from a pose file
        (:func:`kanedyn.analysis.read_pose_csv`), in place of ``trajectory``
        and ``t_end``: the ``points`` times span the table's; the model's pose
        must be ``x, y, z, phi_x, phi_y, phi_z``.  Any object with the
        table's ``t``, ``source`` and call will do; its ``label``, when it
        has one, names the trajectory.
    limits : dict, optional
        ``{quantity: limit}`` of ``force``, ``speed``, ``torque``,
        ``motor_speed`` (:func:`kanedyn.analysis.check_actuator_limits`),
        checked along the path into ``InverseStudy.limit_check``.

    Returns
    -------
    InverseStudy

    Raises
    ------
    ModelError
        When the model declares no actuators.
    ConstraintError
        When a pose of the trajectory is out of reach.
    """
    from ..models import build
    from ..numerics import ActuatorMap
    if isinstance(definition, str):
        definition = build(definition)
    if not definition.actuators:
        raise ModelError(f"model {definition.name!r} declares no actuators; inverse studies "
                         "need definition.actuators (3rrr, stewart-platform, "
                         "out-parallel-6dof)")
    if poses is None and trajectory not in TRAJECTORIES:
        raise KanedynError(f"unknown trajectory {trajectory!r}; available: "
                           f"{', '.join(TRAJECTORIES)}")
    if int(points) < 2:
        raise KanedynError(f"inverse_study needs at least 2 points, got {points}")
    if poses is not None:
        if t_end is not None:
            raise KanedynError("inverse_study: give poses or t_end, not both (the pose "
                               "table sets the times)")
        t0, t_end = float(poses.t[0]), float(poses.t[-1])
        trajectory = getattr(poses, "label", None) or f"pose file {Path(poses.source).name}"
    else:
        t0 = 0.0
        t_end = float(definition.t_end if t_end is None else t_end)
        if not t_end > 0:
            raise KanedynError(f"t_end must be positive, got {t_end!r}")
    if wrench is not None:
        from ._platform_wrench import with_platform_wrench
        if model is not None:
            raise KanedynError("inverse_study: give a wrench or a model, not both (build "
                               "the model from with_platform_wrench(definition, wrench))")
        if hasattr(wrench, "check_covers"):
            wrench.check_covers(t0, t_end)
        definition = with_platform_wrench(definition, wrench)
    overrides = dict(constants or {})
    if model is None:
        model = definition.numeric(definition.derive(), constants=overrides, backend=backend)
    amap = ActuatorMap(model, definition.actuators)
    pose_syms = list(definition.symbols["pose"])
    pose_names = tuple(str(s).removesuffix("(t)") for s in pose_syms)
    y0 = definition.initial(model)
    home = np.array([y0[model.index(n)] for n in pose_names], float)
    if poses is not None:
        if pose_names != _POSE_FILE_NAMES:
            raise KanedynError(f"{poses.source}: a pose file gives x, y, z, phi_x, phi_y, "
                               f"phi_z; model {definition.name!r} has the pose "
                               f"{', '.join(pose_names)}")
        motion = poses
    else:
        motion = _pose_motion(trajectory, home, trajectory_offsets(definition), t_end)
    t = np.linspace(t0, t_end, int(points))
    pose, rate, accel = motion(t)
    ik = _Kinematics(definition, model, overrides)
    q, u, udot = ik(t, pose, rate, accel)
    forces, condition, rates, rate_dots = [], [], [], []
    for j in range(t.size):
        r = amap.forces(t[j], np.concatenate([q[j], u[j]]), udot[j])
        forces.append(r.forces)
        condition.append(r.condition)
        rates.append(r.rates)
        rate_dots.append(r.rate_derivatives)
    rates, rate_dots = np.array(rates).T, np.array(rate_dots).T
    gravity = _gravity_symbol(definition)
    parts = amap.parts(t, q.T, u.T, udot.T, groups=definition.body_groups, gravity=gravity)
    power = amap.power_balance(t, q.T, u.T, udot.T, gravity=gravity)
    motors = _motors(definition, amap, t, parts.groups, rates, rate_dots)
    forces = np.array(forces).T
    units = tuple(_unit(a) for a in definition.actuators)
    limit_check = None if limits is None else _limit_check(amap.names, units, t, forces,
                                                           rates, motors, limits)

    def forward(rtol, atol, method):
        return _forward(definition, model, amap, motion, t, q[0], u[0], overrides,
                        rtol, atol, method)

    return InverseStudy(
        model_name=definition.name, trajectory=trajectory, t=t, pose_names=pose_names,
        pose=pose, pose_rate=rate, pose_accel=accel, q=q, u=u, udot=udot,
        ik_method=ik.method, names=amap.names,
        units=units, forces=forces, condition=np.array(condition),
        causes=dict(parts.causes), groups=dict(parts.groups), power=power,
        rates=rates, rate_derivatives=rate_dots, motors=motors, limit_check=limit_check,
        extra={"model": model, "actuator_map": amap, "definition": definition,
               "forward": forward})


def _limit_check(names, units, t, forces, rates, motors, limits):
    from ._actuator_limits import check_actuator_limits
    unit = "/".join(sorted(set(units)))
    values = {"force": forces, "speed": rates,
              "torque": None if motors is None else motors.torque,
              "motor_speed": None if motors is None else motors.speed}
    quantity_units = {"force": unit, "speed": "m/s" if unit == "N" else "rad/s",
                      "torque": "N m", "motor_speed": "rad/s"}
    return check_actuator_limits(t, names, values, quantity_units, limits)


def _motors(definition, amap, t, groups, rates, rate_dots):
    """Motor torques when every actuator drives through a ball screw, else None."""
    from ..modeling import BallScrew
    from ._motor_torques import motor_torques
    screws = [a.transmission for a in definition.actuators]
    if not all(isinstance(s, BallScrew) for s in screws):
        return None
    nut = {g: v for g, v in groups.items() if g != "drive train"}
    return motor_torques(amap.names, screws, t, nut, rates, rate_dots)


def _forward(definition, model, amap, motion, t, q0, u0, overrides, rtol, atol, method):
    """Simulate the forward model driven by the exact forces of ``amap`` along ``motion``."""
    from ..formulations import formulate
    from ..modeling import drive_inputs
    from ..simulation import simulate
    kane_args = dict(definition.kane_args)
    symbols, loads, elements = drive_inputs(definition.actuators)
    ik = _Kinematics(definition, model, overrides)
    cache = {}

    def forces_at(time):
        if time not in cache:
            cache.clear()
            pose, rate, accel = motion(np.array([time]))
            q, u, ud = ik(np.array([time]), pose, rate, accel)
            y = np.concatenate([q[0], u[0]])
            cache[time] = amap.forces(time, y, ud[0]).forces
        return cache[time]

    inputs = {F: (lambda time, i=i: float(forces_at(time)[i])) for i, F in enumerate(symbols)}
    kane_args.update(loads=list(kane_args.get("loads") or []) + loads,
                     bodies=list(kane_args["bodies"]) + elements)
    eom = formulate(**kane_args)
    driven = eom.numeric(constants=model.constants, specified=inputs)
    y0 = np.concatenate([q0, u0])
    return simulate(driven, (float(t[0]), float(t[-1])), y0, method=method, rtol=rtol,
                    atol=atol, t_eval=t)
