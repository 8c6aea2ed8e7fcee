"""``kanedyn inverse``: actuator forces of a parallel model along a named trajectory."""

from __future__ import annotations

from .._errors import KanedynError
from .._number_text import finite_number
from .._progress import Progress
from ..models import build
from ._options import (add_backend_argument, add_model_argument, check_output_dir, numeric_model,
                       parse_sets, point_count, positive_float)

__all__ = ["add_parser", "cmd_inverse"]

_TRAJECTORIES = ("quintic", "sinusoid")


def add_parser(sub):
    """Add the ``inverse`` sub-command to ``sub``."""
    p = sub.add_parser("inverse", help="actuator forces along a prescribed platform motion: "
                                       "by cause, by body group, power balance")
    add_model_argument(p)
    p.add_argument("--trajectory", choices=_TRAJECTORIES, default=None,
                   help="quintic: rest to rest from the home pose to an offset pose; "
                        "sinusoid: about the home pose (default quintic)")
    p.add_argument("--poses", default=None, metavar="FILE.csv",
                   help="platform trajectory from a CSV file with the header "
                        "t,x,y,z,roll,pitch,yaw (body-fixed X-Y-Z angles) or "
                        "t,x,y,z,qw,qx,qy,qz [s, m, rad], splined (C2); instead of "
                        "--trajectory and --t-end")
    p.add_argument("--t-end", type=positive_float, default=None,
                   help="duration [s] (default: the model's)")
    p.add_argument("--points", type=point_count, default=201,
                   help="trajectory points (at least 2)")
    p.add_argument("--out", default=None,
                   help="output directory for CSV files and plots (none if omitted)")
    add_backend_argument(p)
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="model option or parameter (m_p=12)")
    p.add_argument("--wrench", default=None, metavar="Fx,Fy,Fz,Mx,My,Mz | FILE.csv",
                   help="external wrench on the platform, in the ground frame: six "
                        "numbers [N, N m], or a CSV file with the header t,Fx,Fy,Fz,Mx,My,Mz "
                        "covering the trajectory (interpolated linearly)")
    p.add_argument("--machine", default=None, metavar="FILE.toml",
                   help="out-parallel-6dof: the machine's geometry, masses, drive trains "
                        "and (optionally) actuator limits from a TOML file")
    p.add_argument("--limit", default=None, metavar="force=N,speed=V,torque=T,motor_speed=W",
                   help="actuator limits checked along the path [N, m/s, N m, rad/s]; "
                        "over a machine file's [limits]; the first violation is named")
    p.add_argument("--check", action="store_true",
                   help="also drive the forward model with the forces (DOP853, "
                        "rtol = atol = 1e-11) and print the largest pose error")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_inverse)


def cmd_inverse(args):
    """Run an inverse-dynamics study; print peak forces and the power-balance residual."""
    import numpy as np

    from ..analysis import inverse_study
    options, values = parse_sets(args.model, args.set)
    # the folder first: building the model takes seconds (the Stewart platform's 6)
    out = check_output_dir(args.out) if args.out is not None else None
    definition = build(args.model, **options)  # checks the options
    if not definition.actuators:
        raise KanedynError(f"model {args.model!r} declares no actuators; "
                           "kanedyn inverse needs one that does (3rrr, stewart-platform, "
                           "out-parallel-6dof)")
    names = {str(s) for s in definition.constants}
    unknown = sorted(set(values) - names)
    if unknown:
        raise KanedynError(f"--set {unknown[0]}: not an option or parameter of "
                           f"{definition.name}; parameters: {', '.join(sorted(names))}")
    limits = {}
    if args.machine is not None:
        definition, limits = _machine_option(args.machine, definition)
    limits.update(_limit_option(args.limit))
    poses = _poses_option(args)
    if args.wrench is not None:
        from ..analysis import with_platform_wrench
        wrench = _wrench_option(args.wrench)
        if hasattr(wrench, "check_covers"):
            span = ((poses.t[0], poses.t[-1]) if poses is not None
                    else (0.0, definition.t_end if args.t_end is None else args.t_end))
            _option_error("--wrench", wrench.check_covers, *span)
        definition = _option_error("--wrench", with_platform_wrench, definition, wrench)
    progress = Progress(enabled=not args.quiet)
    progress.stage(f"deriving {definition.title}")
    model = numeric_model(definition, definition.derive(), args.backend, values)
    trajectory = args.trajectory or "quintic"
    progress.stage(f"inverse kinematics and actuator forces, "
                   f"{args.poses or trajectory} trajectory, {args.points} points")
    study = inverse_study(definition, trajectory=trajectory, t_end=args.t_end,
                          points=args.points, constants=values, model=model, poses=poses,
                          limits=limits or None)
    progress.done()
    span = (f"over {study.t[-1]:g} s" if poses is None
            else f"t = {study.t[0]:g} .. {study.t[-1]:g} s ({poses.orientation}, "
                 f"{poses.t.size} rows, cubic spline)")
    print(f"{definition.name}: {study.trajectory} trajectory {span}, "
          f"{study.t.size} points; inverse kinematics: {study.ik_method}")
    if args.wrench is not None:
        print(f"external wrench on the platform (ground frame): {args.wrench}")
    width = max(len(n) for n in study.names)
    print(f"  {'actuator':<{width}}  {'peak |force|':>14}  {'rms':>12}")
    for n, u, f in zip(study.names, study.units, study.forces):
        peak = f"{np.max(np.abs(f)):.6g} {u}"
        rms = f"{np.sqrt(np.mean(f ** 2)):.6g} {u}"
        print(f"  {n:<{width}}  {peak:>14}  {rms:>12}")
    pw = study.power
    print(f"peak actuator power {np.max(np.abs(pw.actuator)):.6g} W; power-balance "
          f"residual {np.max(np.abs(pw.residual)):.3e} W "
          f"({study.power_residual():.3e} of the peak)")
    print(f"largest condition number of the actuator Jacobian: {np.max(study.condition):.4g}")
    if study.motors is not None:
        _print_motors(study.motors)
    if study.limit_check is not None:
        _print_limits(study.limit_check)
    if args.check:
        progress.stage("forward simulation driven by the computed forces (DOP853, 1e-11)")
        error = study.forward_check()
        progress.done()
        print(f"forward check: largest pose error {error:.3e} (m, rad)")
    if out is not None:
        written = study.to_csv(out) + study.plot(out)
        print("wrote " + ", ".join(str(p) for p in written))
    return 0


def _machine_option(path, definition):
    """The out-parallel model built from a machine file, and the file's limits."""
    from ..models import out_parallel_6dof, read_out_parallel_machine
    if definition.name != "out-parallel-6dof":
        raise KanedynError(f"--machine {path}: machine files describe out-parallel-6dof, "
                           f"not {definition.name}")
    machine = _option_error("--machine", read_out_parallel_machine, path)
    return out_parallel_6dof(machine), dict(machine.limits)


def _limit_option(text):
    """``{quantity: limit}`` from ``force=300,torque=0.5``; each number checked."""
    from ..analysis import LIMIT_QUANTITIES
    if text is None:
        return {}
    limits = {}
    for item in text.split(","):
        name, sep, cell = (part.strip() for part in item.partition("="))
        if not sep or name not in LIMIT_QUANTITIES:
            raise KanedynError(f"--limit {text}: {item.strip()!r} is not QUANTITY=VALUE with "
                               f"QUANTITY one of {', '.join(LIMIT_QUANTITIES)}")
        x = finite_number(cell)
        if x is None or not x > 0:
            raise KanedynError(f"--limit {text}: {name} = {cell!r} is not a finite number > 0")
        limits[name] = x
    return limits


def _print_limits(check):
    parts = [f"{q} {v:.6g} {check.units[q]} (peak {check.peaks[q]:.6g})"
             for q, v in check.limits.items()]
    print("actuator limits: " + "; ".join(parts))
    if check.ok:
        print("  all within limits along the path")
        return
    count = ", ".join(f"{q} {n}" for q, n in check.violations.items() if n)
    print(f"  LIMIT EXCEEDED, first at {check.first.describe()}; points x actuators over: "
          f"{count}")


def _poses_option(args):
    """The pose table of ``--poses``, or None; refused together with its alternatives."""
    if args.poses is None:
        return None
    for flag, value in (("--trajectory", args.trajectory), ("--t-end", args.t_end)):
        if value is not None:
            raise KanedynError(f"--poses {args.poses}: the pose file sets the trajectory and "
                               f"its times; drop {flag}")
    from ..analysis import read_pose_csv
    return _option_error("--poses", read_pose_csv, args.poses)


def _option_error(option, fn, *args):
    try:
        return fn(*args)
    except KanedynError as exc:
        raise KanedynError(f"{option}: {exc}") from None


def _wrench_option(text):
    """Six comma-separated numbers, or the path of a wrench CSV file."""
    from ..analysis import read_wrench_csv
    parts = text.split(",")
    if len(parts) == 6 and not text.lower().endswith(".csv"):
        values = []
        for name, cell in zip(("Fx", "Fy", "Fz", "Mx", "My", "Mz"), parts):
            x = finite_number(cell)
            if x is None:
                raise KanedynError(f"--wrench {text}: {name} = {cell.strip()!r} is not a "
                                   "finite number")
            values.append(x)
        return values
    if not text.lower().endswith(".csv"):
        raise KanedynError(f"--wrench {text}: give six numbers Fx,Fy,Fz,Mx,My,Mz [N, N m] "
                           "or a .csv file")
    return _option_error("--wrench", read_wrench_csv, text)


def _print_motors(motors):
    import numpy as np
    width = max(len(n) for n in motors.names)
    print("motors (ball screws; forward efficiency where F·ṡ >= 0, back-driving where < 0):")
    print(f"  {'actuator':<{width}}  {'peak |torque|':>15}  {'peak |speed|':>16}  "
          f"{'peak |power|':>13}  {'back-driven':>11}")
    for i, n in enumerate(motors.names):
        share = 100.0 * np.mean(motors.back_driven[i])
        print(f"  {n:<{width}}  {np.max(np.abs(motors.torque[i])):>11.6g} N m  "
              f"{np.max(np.abs(motors.speed[i])):>10.6g} rad/s  "
              f"{np.max(np.abs(motors.power[i])):>11.6g} W  {share:>10.3g}%")
