"""Flexible bodies: derivation, compilation, right-hand side and integration speed.

Three measurements, each a part that can be run alone (``--parts``):

1. ``robot``: the elastic one-degree-of-freedom robot of the kind Meghdari &
   Fahimi studied: a motor-driven hub (a rigid body turning about the
   vertical axis) carrying a flexible link (a uniform beam, Craig–Bampton with
   4 normal modes, clamped at the hub) with a payload particle at its tip node,
   moving in a horizontal plane under a torque on the hub. Written as a user
   writes it with :func:`kanedyn.kane`. Times: member (finite elements and
   reduction), derivation, C compilation (``eom.numeric(backend="c")`` with an
   empty compile cache), derivation + compilation, right-hand side per call
   from Python on the numpy and C backends.
2. ``chain``: k = 1 .. 5 flexible links (4 modes each), link j hinged at the
   tip node of link j - 1 (revolute about the local z axis of that node's
   frame, :meth:`FlexibleBody.node_frame` / :meth:`FlexibleBody.node_point`):
   derivation, compilation, right-hand side per call (numpy and C),
   operation counts.
3. ``spinup``: the spin-up beam of Kane, Ryan & Banerjee (1987), a cantilever
   on a hub whose angle is prescribed, 0 .. 20 s: ``kd.simulate`` with the
   compiled RK45 loop on the C backend against ``scipy.integrate.solve_ivp``
   (RK45) driving the numpy backend's ``model.rhs``, same tolerances; thread
   CPU times (the compiled runs interleaved in rounds), ratio and the largest
   difference of the tip deflection.

SymPy's ``KanesMethod`` and PyDy have no flexible body; the peer of part 1
(``--sympy``, section 1b) is the robot written by hand in SymPy's
``LagrangesMethod`` from the same inertia data, its right-hand side timed
interleaved with kanedyn's. The other figures are absolute times on this
machine, set against the project's targets.

Usage::

    python benchmarks/bench_flexible.py                      # all parts, ~3 minutes
    python benchmarks/bench_flexible.py --parts robot spinup # some parts
    python benchmarks/bench_flexible.py --quick --max-links 3
    python benchmarks/bench_flexible.py --markdown

Progress goes to stderr, the tables to stdout. Needs a C compiler.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import os
import platform
import shutil
import sys
import tempfile

import numpy as np
import scipy
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp
from sympy.core.cache import clear_cache

import kanedyn as kd

# bench_numerics lives next to this script (on sys.path when run directly)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _timing import interleaved, optimized_modules_only, ratio_text, winner  # noqa: E402
from bench_numerics import (best_seconds, cpu_name, format_table, load_average, log,  # noqa: E402
                            section, source_revision, timed, verdict)

PARTS = ("robot", "chain", "spinup")
N_MODES = 4

#: The robot: hub inertia about the vertical axis (kg m^2), payload (kg), motor
#: torque (N m) and the link: a 1 m aluminium strip, 50 mm tall and 4 mm thick
#: (rho A = 0.54 kg/m, E A = 1.4e7 N, EI = 18.7 N m^2 for bending in the
#: horizontal plane, G J = 28 N m^2), made 1e4 times stiffer out of the plane
#: than in it so that its 4 lowest modes all bend in the plane.
ROBOT = {"hub_inertia": 0.05, "payload": 0.1, "torque": 0.5, "length": 1.0,
         "mass_per_length": 0.54, "EA": 1.4e7, "GJ": 28.0, "EI_y": 1.87e5,
         "EI_z": 18.7, "n_elements": 12}
#: Links of the chain (the robot's link).
LINK = {key: ROBOT[key] for key in ("length", "mass_per_length", "EA", "GJ", "EI_y",
                                    "EI_z", "n_elements")}
#: The spin-up beam (REFERENCES.md): L, rho A, EI in the plane; E A = 7e10 * 4e-4;
#: out of the plane 1e4 times stiffer (the reference is in-plane bending only).
SPINUP = {"length": 10.0, "mass_per_length": 1.2, "EA": 2.8e7, "GJ": 1.0e4,
          "EI_y": 1.4e8, "EI_z": 1.4e4, "n_elements": 20, "T": 15.0, "Omega": 6.0,
          "t_end": 20.0, "tol": 1e-8, "samples": 401}
#: Targets of issue 13.
ROBOT_BUILD_TARGET_S = 3.0
ROBOT_C_RHS_TARGET_US = 5.0


# ----------------------------------------------------------------- helpers
def machine_info():
    """One line describing the machine and the versions measured."""
    cpu = cpu_name()
    return (f"{datetime.date.today().isoformat()} | {platform.platform()} | CPU {cpu} "
            f"({os.cpu_count()} logical, load {load_average()}) | "
            f"Python {platform.python_version()} | NumPy {np.__version__} | "
            f"SciPy {scipy.__version__} | SymPy {sm.__version__} | "
            f"kanedyn {kd.__version__} (git {source_revision()})")


def fresh_start():
    """Empty SymPy's global cache and collect garbage before a timing."""
    clear_cache()
    gc.collect()


def cpu_seconds():
    """CPU time of this process and its finished children (the compiler), s."""
    times = os.times()
    return times.user + times.system + times.children_user + times.children_system


def timed_cpu(func):
    """``(result, wall seconds, CPU seconds)`` of one call of ``func()``."""
    cpu = cpu_seconds()
    result, wall = timed(func)
    return result, wall, cpu_seconds() - cpu


def compile_c(eom, **options):
    """``(model, wall s, CPU s)`` of ``eom.numeric(backend="c")`` with nothing cached.

    Each call points ``KANEDYN_CACHE_DIR`` at a new empty directory and empties
    the backend's per-process table of loaded modules (private; fine for a
    benchmark), so the time includes code generation, compilation and import.
    """
    from kanedyn.numerics.backends import _c

    cache = tempfile.mkdtemp(prefix="kanedyn-bench-cache-")
    previous = os.environ.get("KANEDYN_CACHE_DIR")
    os.environ["KANEDYN_CACHE_DIR"] = cache
    _c._LOADED.clear()
    try:
        return timed_cpu(lambda: eom.numeric(backend="c", **options))
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        if previous is None:
            os.environ.pop("KANEDYN_CACHE_DIR", None)
        else:
            os.environ["KANEDYN_CACHE_DIR"] = previous


def beam_member(name, data, n_modes=N_MODES):
    """A uniform beam along body x, Craig–Bampton reduced, clamped at node 0.

    Returns
    -------
    ReducedMember
    """
    member = kd.flexible.BeamMember.uniform(name, data["length"],
                                            mass_per_length=data["mass_per_length"], EA=data["EA"],
                                            GJ=data["GJ"], EI_y=data["EI_y"], EI_z=data["EI_z"],
                                            n_elements=data["n_elements"])
    return member.craig_bampton(n_modes=n_modes)


def generic_state(model, seed=0, modal=0.01, angle=0.5, speed=0.5):
    """A generic state: joint angles and speeds up to 0.5, modal ones up to 0.01."""
    rng = np.random.default_rng(seed)
    y = np.zeros(model.n_states)
    for k, name in enumerate(model.state_names):
        scale = modal if ("eta_" in name or "zeta_" in name) else (
            angle if k < model.n_q else speed)
        y[k] = rng.uniform(-scale, scale)
    return y


def rhs_times(models, y, repeat, min_time, extra=None):
    """µs per ``model.rhs(0.0, y)`` call for each backend, and their difference.

    The backends (and ``extra``, ``{name: func}`` timed beside them) are timed
    interleaved in ``repeat`` rounds (:func:`_timing.interleaved`, thread CPU
    time); ``out[name]`` is the minimum in µs, ``out["timings"]`` the
    :class:`_timing.Timing` of each.
    """
    contenders = {name: (lambda m=m: m.rhs(0.0, y)) for name, m in models.items()}
    contenders.update(extra or {})
    timings = interleaved(contenders, rounds=repeat, min_time=min_time)
    out = {name: t.best * 1e6 for name, t in timings.items()}
    out["timings"] = timings
    a, b = (models[k].rhs(0.0, y) for k in ("numpy", "c"))
    out["diff"] = float(np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1e-300))
    return out


# ----------------------------------------------------------------- 1. robot
def robot_definition(member):
    """The one-link flexible robot, written as a user writes it.

    Parameters
    ----------
    member : ReducedMember
        The link.

    Returns
    -------
    dict
        ``kane`` (keyword arguments of :func:`kanedyn.kane`), ``constants``,
        ``specified``.
    """
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta, omega = me.dynamicsymbols("theta omega")
    torque = me.dynamicsymbols("tau")
    I_hub, m_payload = sm.symbols("I_hub m_payload")
    H = me.ReferenceFrame("H")
    H.orient_axis(N, N.z, theta)
    H.set_ang_vel(N, omega * N.z)
    hub = me.RigidBody("hub", O, H, 0, (me.inertia(H, 0, 0, I_hub), O))
    link = kd.FlexibleBody("link", H, O, member)
    payload = me.Particle("payload", link.node_point(member.n_nodes - 1), m_payload)
    return {"kane": {"frame": N, "q_ind": [theta, *link.q], "u_ind": [omega, *link.u],
                     "kd_eqs": [theta.diff() - omega, *link.kd_eqs],
                     "bodies": [hub, link, payload], "loads": [(H, torque * N.z)]},
            "constants": {I_hub: ROBOT["hub_inertia"], m_payload: ROBOT["payload"]},
            "specified": {torque: ROBOT["torque"]}}


def build_times(derive, build):
    """Best wall and CPU times of derivation, C build and their sum, from (wall, CPU) pairs."""
    totals = [(d[0] + b[0], d[1] + b[1]) for d, b in zip(derive, build)]
    out = {}
    for key, pairs in (("derive", derive), ("compile", build), ("total", totals)):
        out[f"{key}_s"] = min(p[0] for p in pairs)
        out[f"{key}_cpu"] = min(p[1] for p in pairs)
    return out


def measure_robot(repeat, min_time, peer=True):
    """Part 1: one table row (a dict) for the flexible robot."""
    member_s = []
    for _ in range(repeat):
        member, seconds = timed(lambda: beam_member("link", ROBOT))
        member_s.append(seconds)
    derive, build = [], []
    for _ in range(repeat):
        fresh_start()

        def derive_robot():
            definition = robot_definition(member)
            return definition, kd.kane(**definition["kane"])
        (definition, eom), wall, cpu = timed_cpu(derive_robot)
        derive.append((wall, cpu))
        options = {"constants": definition["constants"], "specified": definition["specified"]}
        model_c, wall, cpu = compile_c(eom, **options)
        build.append((wall, cpu))
        log(f"robot: derived in {derive[-1][0]:.2f} s, compiled in {wall:.2f} s")
    plain = [compile_c(eom, cse=False, **options) for _ in range(repeat)]
    y = generic_state(model_c)
    no_cse = {"compile_s": min(p[1] for p in plain), "compile_cpu": min(p[2] for p in plain),
              "c": best_seconds(lambda: plain[-1][0].rhs(0.0, y), repeat, min_time) * 1e6}
    model_np, numpy_s = timed(lambda: eom.numeric(**options))
    row = {"label": "robot", "no_cse": no_cse, "member_s": min(member_s), "numpy_s": numpy_s,
           "n_states": model_c.n_states, "counts": eom.operation_counts()}
    row.update(build_times(derive, build))
    row["sympy"] = measure_sympy_robot(member, y, model_np) if peer else None
    extra = {"peer": row["sympy"].pop("rhs")} if peer else None
    times = rhs_times({"numpy": model_np, "c": model_c}, y, repeat, min_time, extra)
    times.pop("peer", None)
    row.update(times)
    if peer:
        timings = row["timings"]
        row["sympy"]["rhs_us"] = timings["peer"].best * 1e6
        row["sympy"]["winner_numpy"] = winner({k: timings[k] for k in ("peer", "numpy")})
        row["sympy"]["winner_c"] = winner({k: timings[k] for k in ("peer", "c")})
    return row


# ------------------------------------------------- 1b. a hand-written SymPy peer
def sympy_robot(member):
    r"""The robot written by hand for SymPy's ``LagrangesMethod``, same inertia data.

    SymPy has no flexible body, so the link's kinetic energy is written from the
    same inertia invariants kanedyn uses,
    :math:`T = \tfrac12 w^T M_b(\eta) w` with
    :math:`M_b = M_0 + \sum_i \eta_i M_{1,i} + \tfrac12\sum_{ij}\eta_i\eta_j M_{2,ij}`
    and :math:`w = (0, 0, 0, 0, 0, \dot\theta, \dot\eta)`; strain energy
    :math:`\tfrac12\eta^TK\eta`; the payload at the tip node
    :math:`x + \Phi\eta + \tfrac12\eta^TG\eta` in the hub frame. (Kane's method
    in SymPy would need these generalized inertia forces written out by hand;
    Lagrange's equations of the same energies are the natural SymPy form.)

    Returns
    -------
    dict
        ``method`` (the ``LagrangesMethod``, equations not yet formed),
        ``state`` (``[theta, eta, theta', eta']``), ``parameters``
        (``[I_hub, m_payload, tau]``) and their ``values``.
    """
    inv = kd.modeling.InertiaInvariants(member, stiffening=True)
    m = member.n_modes
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta = me.dynamicsymbols("theta")
    eta = list(me.dynamicsymbols(f"eta1:{m + 1}"))
    I_hub, m_payload, torque = sm.symbols("I_hub m_payload tau")
    H = N.orientnew("H", "Axis", [theta, N.z])
    t = me.dynamicsymbols._t
    w = [0, 0, 0, 0, 0, theta.diff(t)] + [e.diff(t) for e in eta]
    active = [a for a in range(len(w)) if w[a] != 0]

    def entry(a, b):
        value = inv.M0[a, b] + sum(inv.M1[i, a, b] * eta[i] for i in range(m))
        return value + sum(inv.M2[i, j, a, b] * eta[i] * eta[j]
                           for i in range(m) for j in range(m)) / 2
    T_link = sum(w[a] * entry(a, b) * w[b] for a in active for b in active) / 2
    V = sum(inv.stiffness[i, j] * eta[i] * eta[j] for i in range(m) for j in range(m)) / 2
    tip = member.n_nodes - 1
    Phi, _ = member.node_modes(tip)
    G = member.second_order[tip]
    x = member.nodes[tip] - member.nodes[member.reference_node]
    r = [x[a] + sum(Phi[a, i] * eta[i] for i in range(m))
         + sum(G[a, i, j] * eta[i] * eta[j] for i in range(m) for j in range(m)) / 2
         for a in range(3)]
    P = O.locatenew("P", r[0] * H.x + r[1] * H.y + r[2] * H.z)
    v_P = P.pos_from(O).dt(N)
    T = I_hub * theta.diff(t)**2 / 2 + T_link + m_payload * v_P.dot(v_P) / 2
    q = [theta] + eta
    method = me.LagrangesMethod(T - V, q, forcelist=[(H, torque * N.z)], frame=N)
    return {"method": method, "state": q + [c.diff(t) for c in q],
            "parameters": [I_hub, m_payload, torque],
            "values": np.array([ROBOT["hub_inertia"], ROBOT["payload"], ROBOT["torque"]])}


def measure_sympy_robot(member, y, model):
    """SymPy's derivation, lambdify and right-hand side for the hand-written robot.

    Parameters
    ----------
    member : ReducedMember
    y : numpy.ndarray
        The state of kanedyn's timing (same order: ``[theta, eta, omega, zeta]``).
    model : NumericModel
        kanedyn's numpy model, for the agreement of the right-hand sides.

    Returns
    -------
    dict
        ``derive_s`` (building the energies, ``form_lagranges_equations`` and
        reading ``mass_matrix_full`` / ``forcing_full``), ``lambdify_s``,
        ``rhs`` (a function of no arguments: lambdified matrices +
        ``numpy.linalg.solve`` at ``y``, timed by the caller beside kanedyn's),
        ``diff`` (largest relative difference from kanedyn's ``model.rhs``).
    """
    fresh_start()

    def derive():
        peer = sympy_robot(member)
        peer["method"].form_lagranges_equations()
        return peer, peer["method"].mass_matrix_full, peer["method"].forcing_full
    (peer, mass, forcing), derive_s, derive_cpu = timed_cpu(derive)
    log(f"robot: SymPy LagrangesMethod derived in {derive_s:.2f} s")
    matrices, lambdify_s = timed(lambda: sm.lambdify([peer["state"], peer["parameters"]],
                                                     [mass, forcing], cse=True))
    values = peer["values"]

    def rhs(t, state):
        M, F = matrices(state, values)
        return np.linalg.solve(M, F).ravel()
    ours = model.rhs(0.0, y)
    return {"derive_s": derive_s, "derive_cpu": derive_cpu, "lambdify_s": lambdify_s,
            "rhs": lambda: rhs(0.0, y),
            "diff": float(np.max(np.abs(rhs(0.0, y) - ours)) / np.max(np.abs(ours)))}


PEER_COLUMNS = ("tool", "derive s (CPU)", "to numerical s", "rhs µs (spread)",
                "rhs vs SymPy", "faster rhs (clear)", "rel. diff of rhs")


def peer_cells(robot):
    """Rows of the SymPy comparison: SymPy, kanedyn numpy, kanedyn C."""
    peer, t = robot["sympy"], robot["timings"]

    def us(name, digits):
        return f"{t[name].best * 1e6:.{digits}f} ({t[name].spread:.0%})"

    return [["SymPy LagrangesMethod + lambdify",
             f"{peer['derive_s']:.2f} ({peer['derive_cpu']:.2f})",
             f"{peer['lambdify_s']:.2f}", us("peer", 0), "1", "-", f"{peer['diff']:.1e}"],
            ["kanedyn kd.kane, numpy", f"{robot['derive_s']:.2f} ({robot['derive_cpu']:.2f})",
             f"{robot['numpy_s']:.2f}", us("numpy", 0), ratio_text(t["peer"], t["numpy"]),
             (peer["winner_numpy"] or "none").replace("peer", "SymPy"), "0 (reference)"],
            ["kanedyn kd.kane, C", f"{robot['derive_s']:.2f} ({robot['derive_cpu']:.2f})",
             f"{robot['compile_s']:.2f}", us("c", 2), ratio_text(t["peer"], t["c"]),
             (peer["winner_c"] or "none").replace("peer", "SymPy"), f"{robot['diff']:.1e}"]]


PEER_NOTES = """\
- SymPy has no flexible body; the peer is the robot written by hand from the same
  inertia invariants (M_b(eta) to second order, modal stiffness, the payload at the
  tip node to second order): me.LagrangesMethod(T - V, [theta, eta], forcelist=[hub
  torque]), form_lagranges_equations() and reading mass_matrix_full / forcing_full
  (derive s, one run, SymPy's cache cleared first), then sm.lambdify([state,
  parameters], [M_full, F_full], cse=True) ("to numerical s") and
  numpy.linalg.solve per call ("rhs µs", same state as above). kanedyn's derive s
  covers building its bodies and kd.kane; "to numerical s" is eom.numeric().
- rhs µs: the three timed interleaved in rounds (thread CPU time), minimum and
  spread (median / min - 1); "rhs vs SymPy" is SymPy's minimum / this one's with
  both spreads; "faster rhs (clear)" names the faster of the pair (SymPy, this)
  only where the ranges [min, median] do not overlap.
- Writing the energies took no modelling in SymPy only because kanedyn computed
  the invariants; a SymPy user would have to derive them from the finite-element
  model first. Kane's method proper (KanesMethod) would need the generalized
  inertia forces of the link written out by hand as loads."""


# ----------------------------------------------------------------- 2. chain
def chain_definition(k, member):
    """k flexible links in a horizontal plane, each hinged at its predecessor's tip.

    Joint j turns link j about the z axis of the frame at the tip node of link
    j - 1 (about N.z at the fixed point O for the first link) by ``q_j``; its
    speed is ``u_j = q_j'``.

    Returns
    -------
    dict
        Keyword arguments of :func:`kanedyn.kane`.
    """
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    q = me.dynamicsymbols(f"q1:{k + 1}")
    u = me.dynamicsymbols(f"u1:{k + 1}")
    tip = member.n_nodes - 1
    parent, joint = N, O
    bodies, q_ind, u_ind, kd_eqs = [], [], [], []
    for j in range(k):
        A = me.ReferenceFrame(f"A{j + 1}")
        A.orient_axis(parent, parent.z, q[j])
        link = kd.FlexibleBody(f"link{j + 1}", A, joint, member)
        bodies.append(link)
        q_ind += [q[j], *link.q]
        u_ind += [u[j], *link.u]
        kd_eqs += [q[j].diff() - u[j], *link.kd_eqs]
        parent, joint = link.node_frame(tip), link.node_point(tip)
    return {"frame": N, "q_ind": q_ind, "u_ind": u_ind, "kd_eqs": kd_eqs,
            "bodies": bodies, "loads": []}


def measure_chain(k, member, repeat, min_time):
    """Part 2: one table row for the chain of ``k`` flexible links."""
    derive = []
    for _ in range(repeat):
        fresh_start()
        eom, wall, cpu = timed_cpu(lambda: kd.kane(**chain_definition(k, member)))
        derive.append((wall, cpu))
    model_c, wall, cpu = compile_c(eom)
    build = [(wall, cpu)] * repeat
    log(f"chain k={k}: derived in {derive[-1][0]:.2f} s, compiled in {wall:.2f} s")
    model_np, numpy_s = timed(eom.numeric)
    counts, counts_s = timed(eom.operation_counts)
    row = {"label": f"chain k={k}", "k": k, "numpy_s": numpy_s,
           "n_states": model_c.n_states, "counts": counts, "counts_s": counts_s}
    row.update(build_times(derive, build))
    row.update(rhs_times({"numpy": model_np, "c": model_c}, generic_state(model_c),
                         repeat, min_time))
    return row


BUILD_COLUMNS = ("model", "states", "member s", "derive s (CPU)", "C build s (CPU)",
                 "derive+C s (CPU)",
                 "numpy build s", "rhs numpy µs", "rhs C µs", "numpy/C",
                 "rel. diff", "intermediates", "ops M/F", "ops all+CSE")


def build_cells(row):
    """Table cells of one row of :func:`measure_robot` / :func:`measure_chain`."""
    counts = row["counts"]
    member = f"{row['member_s']:.3f}" if "member_s" in row else "-"
    wall_cpu = [f"{row[key + '_s']:.2f} ({row[key + '_cpu']:.2f})"
                for key in ("derive", "compile", "total")]
    return [row["label"], str(row["n_states"]), member, *wall_cpu, f"{row['numpy_s']:.2f}",
            f"{row['numpy']:.0f} ({row['timings']['numpy'].spread:.0%})",
            f"{row['c']:.2f} ({row['timings']['c'].spread:.0%})",
            f"{row['numpy'] / row['c']:.0f}x",
            f"{row['diff']:.1e}", f"{counts['intermediates']:,}",
            f"{counts['mass_matrix']:,}/{counts['forcing']:,}", f"{counts['all_cse']:,}"]


BUILD_NOTES = """\
- member s: kd.flexible.BeamMember.uniform(...) and .craig_bampton(n_modes={modes}) ({elements}
  Euler–Bernoulli elements; in-plane EI_z, out-of-plane stiff, so the {modes} modes bend
  in the plane). derive s: building the frames, bodies (kd.FlexibleBody, node points
  and frames) and kd.kane(...), SymPy's cache cleared first; best of {repeat}.
- C build s: eom.numeric(backend="c") with an empty compile cache (C code generation,
  gcc -O2, import); robot: best of {repeat}, chains: one run. numpy build s: eom.numeric().
  Wall times, in parentheses CPU times (this process plus the compiler), the
  better measure on a shared machine; derive+C: best of the sums.
- rhs: model.rhs(0.0, y) at one generic state (joint angles and speeds up to 0.5,
  modal coordinates and speeds up to 0.01), numpy and C interleaved in {repeat} rounds
  of at least {min_time:g} s thread CPU time: minimum (spread = median / min - 1).
  rel. diff: max|rhs_numpy - rhs_C| / max|rhs_numpy|.
- ops: eom.operation_counts(): mass matrix / forcing (each with the intermediates
  it needs) and everything the right-hand side evaluates after the joint CSE of the
  C generator; intermediates: the named intermediates of the compact equations.
- Robot: hub inertia {hub} kg m², link {length} m, {mpl} kg/m, EI {EI} N m² in the
  plane, payload particle {payload} kg at the tip node, hub torque {torque} N m
  (a specified input). Chains: the same link, no hub, no payload, no loads."""


# ---------------------------------------------------------------- 3. spin-up
def spinup_angle(t):
    """The prescribed hub angle theta(t) (SymPy Piecewise), rad."""
    T, Om = SPINUP["T"], SPINUP["Omega"]
    ramp = (Om / T) * (t**2 / 2 + (T / (2 * sm.pi))**2 * (sm.cos(2 * sm.pi * t / T) - 1))
    return sm.Piecewise((ramp, t < T), (Om * t - Om * T / 2, True))


def spinup_models():
    """The spin-up beam: ``(eom, model_c, model_numpy, member, compile_s)``."""
    member = beam_member("beam", SPINUP)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta = me.dynamicsymbols("theta")
    B = N.orientnew("B", "Axis", [theta, N.z])
    beam = kd.FlexibleBody("beam", B, O, member, stiffening=True)
    eom = kd.kane(frame=N, q_ind=list(beam.q), u_ind=list(beam.u),
                  kd_eqs=list(beam.kd_eqs), bodies=[beam])
    specified = {theta: spinup_angle(me.dynamicsymbols._t)}
    model_c, compile_s, _ = compile_c(eom, specified=specified)
    model_np = eom.numeric(specified=specified)
    return eom, model_c, model_np, member, compile_s


def tip_deflection(member, eta):
    """In-plane tip deflection (m, body y) for modal coordinates ``eta`` of shape (m, k).

    ``Phi_y eta + 1/2 eta^T G_y eta`` at the last node (second order included).
    """
    tip = member.n_nodes - 1
    Phi, _ = member.node_modes(tip)
    G = member.second_order[tip, 1]
    return Phi[1] @ eta + 0.5 * np.einsum("ik,ij,jk->k", eta, G, eta)


def measure_spinup(repeat):
    """Part 3: rows of the integration comparison, and facts about the runs."""
    eom, model_c, model_np, member, compile_s = spinup_models()
    m = member.n_modes
    t_end, tol = SPINUP["t_end"], SPINUP["tol"]
    t_eval = np.linspace(0.0, t_end, SPINUP["samples"])
    y0 = np.zeros(model_c.n_states)
    runs = {
        "kd.simulate, C backend (compiled RK45)": lambda: kd.simulate(
            model_c, (0.0, t_end), y0, rtol=tol, atol=tol, t_eval=t_eval),
        "solve_ivp RK45 + C model.rhs": lambda: solve_ivp(
            model_c.rhs, (0.0, t_end), y0, method="RK45", rtol=tol, atol=tol, t_eval=t_eval),
        "solve_ivp RK45 + numpy model.rhs": lambda: solve_ivp(
            model_np.rhs, (0.0, t_end), y0, method="RK45", rtol=tol, atol=tol,
            t_eval=t_eval),
    }
    repeats = {label: (1 if "numpy" in label else repeat) for label in runs}
    results = {}

    def keep(label, run):
        def call():
            results[label] = run()
        return call
    # the compiled runs interleaved in rounds, the slow numpy run once
    fast = [label for label in runs if repeats[label] > 1]
    timings = interleaved({label: keep(label, runs[label]) for label in fast},
                          rounds=repeat, min_time=0)
    timings.update(interleaved({label: keep(label, runs[label]) for label in runs
                                if label not in fast}, rounds=1, min_time=0))
    rows, tips = [], {}
    for label in runs:
        result, best = results[label], timings[label].best
        if not result.success:
            raise RuntimeError(f"spin-up, {label}: integration failed: {result.message}")
        tips[label] = tip_deflection(member, np.asarray(result.y)[:m])
        rows.append({"label": label, "seconds": best, "timing": timings[label],
                     "nfev": int(result.nfev),
                     "runs": repeats[label], "method": getattr(result, "method", "RK45")})
        log(f"spin-up: {label}: {best:.3f} s, nfev {result.nfev}")
    reference = tips["solve_ivp RK45 + numpy model.rhs"]
    for row in rows:
        row["tip_diff"] = float(np.max(np.abs(tips[row["label"]] - reference)))
    info = {"compile_s": compile_s, "method": rows[0]["method"],
            "tip_max": float(np.max(np.abs(reference))),
            "tip_end": float(reference[-1]), "n_states": model_c.n_states,
            "rhs_c_us": best_seconds(lambda: model_c.rhs(1.0, y0 + 1e-3), 5, 0.1) * 1e6,
            "rhs_np_us": best_seconds(lambda: model_np.rhs(1.0, y0 + 1e-3), 5, 0.1) * 1e6,
            "counts": eom.operation_counts(), "winner": winner({k: timings[k] for k in fast})}
    return rows, info


SPIN_COLUMNS = ("integration", "CPU s (spread)", "numpy solve_ivp / this", "nfev", "runs",
                "max |tip - tip_numpy| m")


def spin_cells(row, numpy_seconds):
    """Table cells of one row of :func:`measure_spinup`."""
    spread = f"{row['timing'].spread:.0%}" if row["runs"] > 1 else "one run"
    return [row["label"], f"{row['seconds']:.3f} ({spread})",
            f"{numpy_seconds / row['seconds']:.1f}x",
            str(row["nfev"]), str(row["runs"]), f"{row['tip_diff']:.1e}"]


SPIN_NOTES = """\
- Kane, Ryan & Banerjee's spin-up beam: L = {L} m, rho A = {rhoA} kg/m, EI = {EI} N m²
  in the plane (out of the plane 1e4 times stiffer), {elements} elements,
  Craig–Bampton {modes} modes (in-plane bending), stiffening=True, hub angle
  theta(t) prescribed through eom.numeric(specified={{theta: Piecewise(...)}}),
  T = {T} s, Omega_s = {Om} rad/s; 0 .. {t_end} s from rest, rtol = atol = {tol:g},
  output at {samples} points (t_eval).
- {n_states} states; right-hand side per call: C {c_us:.2f} µs, numpy {np_us:.0f} µs;
  C build (empty cache) {compile_s:.2f} s; kd.simulate reported method {method!r}.
- CPU s: thread CPU time, minimum of "runs" complete runs (kd.simulate's checks
  included); the compiled runs interleaved in rounds (spread = median / min - 1),
  the numpy run once. Clearly faster of the compiled two (ranges [min, median]
  apart): {winner}.
  tip: in-plane tip deflection Phi_y eta + 1/2 eta^T G_y eta at the output points;
  difference from the numpy solve_ivp run, largest over the output points.
- The deflection stays bounded (largest {tip_max:.3f} m, {tip_end:.2e} m at t = {t_end} s)
  as the reference says of the stiffened model."""


# ------------------------------------------------------------------ output
def targets_summary(robot, spin_rows):
    """The issue's targets and whether this run meets them."""
    lines = []
    if robot is not None:
        lines.append(f"- robot derive + C build < {ROBOT_BUILD_TARGET_S:g} s "
                     f"({robot['total_s']:.2f} s wall, {robot['total_cpu']:.2f} s CPU; "
                     f"best CPU: derive {robot['derive_cpu']:.2f}, C build "
                     f"{robot['compile_cpu']:.2f}): "
                     f"{verdict(robot['total_cpu'] < ROBOT_BUILD_TARGET_S)} (CPU)")
        lines.append(f"- robot C rhs < {ROBOT_C_RHS_TARGET_US:g} µs ({robot['c']:.2f} µs): "
                     f"{verdict(robot['c'] < ROBOT_C_RHS_TARGET_US)}")
        plain = robot["no_cse"]
        lines.append(f"- (for comparison) eom.numeric(backend='c', cse=False), no joint "
                     f"CSE before gcc: C build {plain['compile_s']:.2f} s wall, "
                     f"{plain['compile_cpu']:.2f} s CPU; derive + C build "
                     f"{robot['derive_cpu'] + plain['compile_cpu']:.2f} s CPU; "
                     f"rhs {plain['c']:.2f} µs")
    if spin_rows:
        ours, theirs = spin_rows[0], spin_rows[-1]
        speed_up = theirs["seconds"] / ours["seconds"]
        lines.append(f"- (no target) spin-up: kd.simulate (C) {speed_up:.0f}x "
                     f"faster than solve_ivp + numpy; tip deflections agree to "
                     f"{ours['tip_diff']:.1e} m")
    return "\n".join(lines)


def run(args):
    """The selected parts; prints the report to stdout."""
    repeat, min_time = (3, 0.05) if args.quick else (5, 0.2)
    header = "kanedyn flexible bodies: " + machine_info()
    md = args.markdown
    robot, rows, spin_rows = None, [], []
    if "robot" in args.parts:
        robot = measure_robot(repeat, min_time, peer=args.sympy)
        rows.append(robot)
    if "chain" in args.parts:
        member = beam_member("link", LINK)
        for k in range(1, args.max_links + 1):
            rows.append(measure_chain(k, member, repeat, min_time))
    if "spinup" in args.parts:
        spin_rows, spin_info = measure_spinup(repeat)

    print(header)
    print(f"load average at the end: {load_average()}")
    print()
    if rows:
        print(section("1-2. Flexible robot and chains of flexible links: build and rhs",
                      format_table(BUILD_COLUMNS, [build_cells(r) for r in rows], md),
                      BUILD_NOTES.format(modes=N_MODES, elements=LINK["n_elements"],
                                         repeat=repeat, min_time=min_time,
                                         hub=ROBOT["hub_inertia"], length=ROBOT["length"],
                                         mpl=ROBOT["mass_per_length"], EI=ROBOT["EI_z"],
                                         payload=ROBOT["payload"], torque=ROBOT["torque"]),
                      md))
    if robot is not None and robot["sympy"] is not None:
        print(section("1b. The robot by hand in SymPy (LagrangesMethod, same inertia data)",
                      format_table(PEER_COLUMNS, peer_cells(robot), md), PEER_NOTES, md))
    if spin_rows:
        numpy_seconds = spin_rows[-1]["seconds"]
        print(section(f"3. Spin-up beam, 0 .. {SPINUP['t_end']:g} s",
                      format_table(SPIN_COLUMNS,
                                   [spin_cells(r, numpy_seconds) for r in spin_rows], md),
                      SPIN_NOTES.format(L=SPINUP["length"], rhoA=SPINUP["mass_per_length"],
                                        EI=SPINUP["EI_z"], elements=SPINUP["n_elements"],
                                        modes=N_MODES, T=SPINUP["T"], Om=SPINUP["Omega"],
                                        t_end=SPINUP["t_end"], tol=SPINUP["tol"],
                                        samples=SPINUP["samples"],
                                        n_states=spin_info["n_states"],
                                        c_us=spin_info["rhs_c_us"],
                                        np_us=spin_info["rhs_np_us"],
                                        compile_s=spin_info["compile_s"],
                                        method=spin_info["method"],
                                        tip_max=spin_info["tip_max"],
                                        tip_end=spin_info["tip_end"],
                                        winner=spin_info["winner"] or "none"), md))
    print("**Targets**" if md else "Targets\n=======")
    print()
    print(targets_summary(robot, spin_rows))


def main(argv=None):
    """Parse the command line and run the benchmark."""
    optimized_modules_only()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS),
                        help="which measurements (default: all)")
    parser.add_argument("--max-links", type=int, default=5,
                        help="largest chain of flexible links (default 5)")
    parser.add_argument("--sympy", action=argparse.BooleanOptionalAction, default=True,
                        help="time the hand-written SymPy robot too (default: yes)")
    parser.add_argument("--quick", action="store_true",
                        help="3 timing runs of >= 0.05 s instead of 5 of >= 0.2 s")
    parser.add_argument("--markdown", action="store_true", help="print markdown tables")
    args = parser.parse_args(argv)
    run(args)


if __name__ == "__main__":
    main()
