r"""Simulation of models with contacts: modes, events and impacts.

Each contact is ``separated``, sliding (``slip``) or sticking (``stick``).
Between events the equations for the current modes are integrated with
``solve_ivp`` (see :func:`kanedyn.numerics._contact_dynamics.solve_modes`), together
with the work of the friction forces (a quadrature, for energy balances).
Terminal events end each segment:

* a separated contact's gap closes: an impact if it approaches, after which
  it bounces or stays in contact;
* a unilateral contact's normal force falls to zero: it separates;
* a sliding contact's slip velocity stops: it sticks if the static friction
  can hold it, else it slides on in the direction the forces drive it (a
  reversal, recorded as ``slip -> slip``); the slip velocity is taken free of
  the other contacts' drift (:func:`kanedyn.numerics._contact_dynamics.slip_velocities`);
* a sticking contact's friction reaches its limit :math:`\mu_s N`: it slides.

After every event the modes are made consistent (forces within their
limits) before integration resumes; every change is recorded.  The modes the
simulation starts in are not changes.  An output at an event time belongs to
the segment the event ends (the state before the event, the forces of the
modes that end there).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from .._errors import ModelError
from ..numerics import (SEPARATED, SLIP, STICK, SlipReference, contact_points,
                        segment_jacobian, solve_modes)
from ._impact import resolve_impact
from ._run_guard import INTERRUPTED, RunGuard, guarded_event, guarded_method

__all__ = ["simulate_contacts", "ModeChange"]

_MAX_STALLED_SEGMENTS = 1000  # mode changes in a row without time advancing
#: a sliding contact's "slow" speed is at least this many times its "still" one
_SLOW_STILL = 10.0
#: 1 - cos(20 deg): a slip turned this far from its reference stops at half its
#: still speed (:func:`_slip_stop_value`, KD_STALL_TURN of the compiled segments)
_STALL_TURN = 0.06030737921409157


class ModeChange(tuple):
    """``(t, contact, old mode, new mode, reason)``."""

    __slots__ = ()

    def __new__(cls, t, contact, old, new, reason):
        return super().__new__(cls, (float(t), contact, old, new, reason))

    def __getnewargs__(self):  # pickling: the five fields, not one tuple
        return tuple(self)

    t = property(lambda self: self[0])
    contact = property(lambda self: self[1])
    old = property(lambda self: self[2])
    new = property(lambda self: self[3])
    reason = property(lambda self: self[4])


def _segment_jacobian(model, rhs, modes, directions, stabilization):
    """The exact Jacobian of a segment's integration in its ``modes``
    (:func:`kanedyn.numerics.segment_jacobian`), or forward differences of
    ``rhs`` at the states where the modes are statically indeterminate (their
    forces, chosen by least friction, have no derivatives)."""
    exact = segment_jacobian(model, modes, directions, stabilization)

    def jac(t, z):
        try:
            return exact(t, z)
        except ModelError:
            f = rhs(t, z)
            steps = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(z))
            return np.column_stack([(rhs(t, z + h * e) - f) / h
                                    for h, e in zip(steps, np.eye(len(z)))])

    return jac


class _Solver:
    """solve_modes with a one-entry cache (rhs and events share evaluations)."""

    def __init__(self, model, stabilization):
        self.model = model
        self.stabilization = stabilization
        self.key = None
        self.value = None

    def __call__(self, t, y, modes, directions):
        key = (t, y.tobytes(), tuple(modes))
        if key != self.key:
            self.value = solve_modes(self.model, t, y, modes, directions, self.stabilization)
            self.key = key
        return self.value


def _in_contact(mode):
    return mode != SEPARATED


def _touching_mode(coef, point, tol):
    """Sliding or sticking for a contact that touches (frictionless ones slide)."""
    if coef["mu_s"] == 0 or np.linalg.norm(point.slip_velocity) > tol["slip"]:
        return SLIP
    return STICK


def _free_normal_acceleration(solver, t, y, modes, directions, c):
    r"""How fast contact ``c`` would leave its surface if it were free.

    The normal acceleration of the free contact point less the stabilized
    one a contact keeps (Baumgarte's :math:`-2\omega\dot d - \omega^2 d`):
    negative when staying in contact needs a pushing normal force; zero (to
    rounding) at the instant a normal force vanishes.
    """
    free = list(modes)
    free[c] = SEPARATED
    solution = solver(t, y, free, directions)
    point = solution.points[c]
    w = solver.stabilization
    held = -(2 * w * point.normal_speed + w * w * point.distance)
    return float(point.normal @ point.jacobian @ solution.udot + point.normal_rate - held)


def settle(model, solver, t, y, modes, directions, tol, reasons, stopped=None):
    """Modes consistent with the state: forces within limits, gaps open.

    Returns new ``(modes, directions)``; ``reasons`` collects
    ``(contact index, old, new, reason)``.  ``stopped``: ``{contact: slip
    speed}`` of the slips that have just stopped (:func:`_stopped`), the speed
    free of the other contacts' drift, against which their stick is judged (a
    sticking contact's own slip speed, which carries that drift, for the others).
    """
    modes, directions = list(modes), list(directions)
    stopped = stopped or {}
    points = contact_points(model, t, y)
    for c, point in enumerate(points):  # kinematic state
        coef = model.contacts[c]
        touching = point.distance <= tol["distance"]
        leaving = point.normal_speed > tol["speed"]
        if (modes[c] == SEPARATED and touching and not leaving
                and (coef["kind"] == "bilateral"
                     or _free_normal_acceleration(solver, t, y, modes, directions, c)
                     < -tol["acceleration"])):
            new = _touching_mode(coef, point, tol)
            reasons.append((c, modes[c], new, "touches the surface"))
            modes[c] = new
        elif _in_contact(modes[c]):
            if coef["kind"] == "unilateral" and leaving:
                reasons.append((c, modes[c], SEPARATED, "moves away from the surface"))
                modes[c] = SEPARATED
            elif modes[c] == STICK and stopped.get(
                    c, np.linalg.norm(point.slip_velocity)) > tol["slip"]:
                reasons.append((c, STICK, SLIP, "slips"))
                modes[c] = SLIP
    for _ in range(4 * len(modes) + 4):  # forces within their limits
        solution = solver(t, y, modes, directions)
        changed = False
        for c, mode in enumerate(modes):
            coef = model.contacts[c]
            N = solution.normal_force[c]
            if mode == SEPARATED:
                continue
            if coef["kind"] == "unilateral" and N < -tol["force"]:
                reasons.append((c, mode, SEPARATED, "the normal force would pull"))
                modes[c] = SEPARATED
                changed = True
                break
            if mode == STICK:
                ft = solution.friction[c] + coef["viscous"] * solution.points[c].slip_velocity
                limit = coef["mu_s"] * abs(N)
                if np.linalg.norm(ft) > limit + tol["force"]:
                    modes[c] = SLIP
                    directions[c] = SlipReference(-ft / np.linalg.norm(ft), still=tol["slip"])
                    reasons.append((c, STICK, SLIP, "static friction cannot hold it"))
                    changed = True
                    break
        if not changed:
            return modes, directions
    raise RuntimeError("the contact modes do not settle: no mode assignment keeps the "
                       "normal forces pushing and the friction within its cone (Painleve's "
                       "paradox, or chattering)")


def _slip_stop_value(vt, reference):
    """The "slip stops" event of a sliding contact: its zero ends the segment.

    Zero where the slip velocity ``vt`` (3,) loses its component along the
    reference direction while the slip is slow (a stop), not where a fast slip
    has merely turned by 90 degrees (see :func:`kanedyn.numerics.slip_direction`).
    For a slip whose segment began near the ``still`` speed (below
    ``1e3 * _SLOW_STILL`` times it: its ``slow`` speed is ``_SLOW_STILL`` times
    it), also where it falls to half the ``still`` speed having turned from the
    reference (by :data:`_STALL_TURN` or more; by less, at a proportionally
    lower speed): so slow, its direction is at the integration's error (the
    foot of a light leg sliding to a stop), and it would be integrated at a
    crawl without reaching zero.  The compiled contact segments compute the
    same (``_c_contact``).
    """
    along, speed = float(vt @ reference.direction), float(np.linalg.norm(vt))
    value = max(along, speed - reference.slow)
    if reference.slow <= _SLOW_STILL * reference.still and speed > 0:
        turn = min(1.0, (1.0 - along / speed) / _STALL_TURN)
        value = min(value, speed - 0.5 * reference.still * turn)
    return value


def _events(model, solver, points, modes, directions, n_states):
    """Terminal event functions for the current modes: (function, contact, kind)."""
    events = []
    for c, mode in enumerate(modes):
        coef = model.contacts[c]
        if mode == SEPARATED:
            # the event function starts positive even where a contact leaves
            # from a rounding-level penetration (else a flight shorter than
            # one step would go unnoticed); the margin is small enough that
            # the bounces it feeds (approach speed sqrt(2 a margin)) stay
            # below the speed at which impacts become plastic
            offset = max(0.0, -points[c].distance) + 1e-14

            def gap(t, z, c=c, offset=offset):
                return contact_points(model, t, z[:n_states])[c].distance + offset
            gap.offset = offset
            events.append((gap, c, "gap", -1))
            continue
        if coef["kind"] == "unilateral":
            def normal(t, z, c=c):
                return solver(t, z[:n_states], modes, directions).normal_force[c]
            events.append((normal, c, "lift-off", -1))
        if mode == SLIP and directions[c] is not None and coef["mu_s"] > 0:
            # the slip velocity is free of the other contacts' drift
            reference = directions[c]

            def stop(t, z, c=c, reference=reference):
                vt = solver(t, z[:n_states], modes, directions).slip_velocity[c]
                return _slip_stop_value(vt, reference)
            events.append((stop, c, "slip stops", -1))
        elif mode == STICK:
            def margin(t, z, c=c, coef=coef):
                sol = solver(t, z[:n_states], modes, directions)
                ft = sol.friction[c] + coef["viscous"] * sol.points[c].slip_velocity
                return coef["mu_s"] * abs(sol.normal_force[c]) - np.linalg.norm(ft)
            events.append((margin, c, "friction limit", -1))
    out = []
    for fn, c, kind, direction in events:
        fn.terminal = True
        fn.direction = direction
        out.append((fn, c, kind))
    return out


def simulate_contacts(model, t_span, y0, *, method="RK45", t_eval=None, rtol=1e-8,
                      atol=1e-8, events=None, modes=None, stabilization=10.0,
                      max_segments=100000, rest_speed=None, progress=None, guard=None,
                      compiled=True, **options):
    """Integrate a model with contacts (see the module docstring).

    Returns ``(t, y, status, message, extras)``: output times and states
    (``y`` shape (n_states, N)), the solve_ivp-style status and message, and
    a dict with the mode history, impacts, per-point modes and slip
    directions, the work of friction and of all contact forces, event records
    and counters.  ``guard`` (a :class:`kanedyn.simulation._run_guard.RunGuard`) ends the
    run at a non-finite derivative or on Ctrl-C with what was computed.
    ``compiled``: integrate the segments a ``backend="c"`` model's compiled
    contact loop handles (``RK45``, no user events, no ``t_eval`` or other
    solver options; see :func:`_compiled_segment`) in C; ``False``: always
    the Python reference path (``solve_ivp`` on :func:`solve_modes`).
    """
    guard = guard if guard is not None else RunGuard(model)
    stepper = guarded_method(method, guard)
    exact = isinstance(options.get("jac"), str)  # "exact": per segment, in its modes
    if exact:
        options = {key: value for key, value in options.items() if key != "jac"}
    t0, t1 = (float(v) for v in t_span)
    n = model.n_states
    k = len(model.contacts)
    solver = _Solver(model, stabilization)
    scale = max(1.0, float(np.max(np.abs(y0))))
    tol = {"distance": max(100 * atol, 1e-10), "speed": max(100 * atol, 1e-10),
           "slip": max(100 * atol, 1e-10), "force": 1e-9, "acceleration": 1e-9,
           "lift": 1e-2 * atol}
    rest = rest_speed if rest_speed is not None else max(1e3 * atol, 1e-6) * scale
    names = [c["name"] for c in model.contacts]
    user_events = [] if events is None else (
        list(events) if isinstance(events, (list, tuple)) else [events])
    segment_c = getattr(getattr(model, "_module", None), "contact_segment", None)
    if not (compiled and segment_c is not None and method == "RK45" and not user_events
            and t_eval is None and not options and not model.n_u_dep
            and np.ndim(rtol) == 0 and np.ndim(atol) == 0):
        segment_c = None

    y = np.array(y0, dtype=float)
    directions = [None] * k
    history = []
    impacts = []
    reasons = []
    given = modes is not None
    modes = list(modes) if given else [SEPARATED] * k
    _check_initial(model, t0, y, modes, tol)
    start = list(modes)
    bounces = {}  # contact -> (time, separation speed) of its last bounce
    y, modes, directions = _resolve(model, solver, t0, y, modes, directions, tol, rest,
                                    reasons, impacts, bounces)
    initial = _changes(t0, names, start, modes, reasons)
    if not given:
        # the modes a contact starts in are not changes (a contact that starts
        # closed does not "touch the surface" at t0); an impact at t0 is
        hit = {names[c] for c, _, _, why in reasons if why == "impact"}
        initial = [change for change in initial if change.contact in hit]
    history.extend(initial)
    initial_modes = dict(zip(names, modes))

    ts, ys, point_modes, point_dirs, work = [], [], [], [], []
    t_events = [[] for _ in user_events]
    y_events = [[] for _ in user_events]
    counters = {"nfev": 0, "njev": 0, "nlu": 0}
    status, message = 0, "the integration reached the end of the interval"
    t, dissipated, contact_work = t0, 0.0, 0.0
    first = True
    boundary = None  # (t, state with the work integrals, modes, directions) of the last event
    stalled = 0  # segments in a row that end where they start

    def keep_point(tt, z, frozen_modes, frozen_dirs):
        """Keep the state ``z`` (with the two work integrals) at ``tt`` as an
        output point of sparse outputs, when it is later than the last one kept
        (a run that stops between output times loses nothing it computed)."""
        if (t_eval is not None and np.all(np.isfinite(z))
                and tt > max((seg[-1] for seg in ts if seg.size), default=-np.inf)):
            ts.append(np.array([tt]))
            ys.append(np.asarray(z[:n], dtype=float)[:, None])
            work.append(np.asarray(z[n:], dtype=float)[:, None])
            point_modes.append(tuple(frozen_modes))
            point_dirs.append(tuple(frozen_dirs))

    for _ in range(max_segments):
        if guard.interrupted:
            status, message = -1, INTERRUPTED
            if boundary is not None:  # where the last segment ended (before its impacts,
                keep_point(*boundary)    # as an output point at an impact's time is)
            break
        points = contact_points(model, t, y)
        # the reference slip directions of this segment, from slip velocities
        # free of the other contacts' drift
        slips = solver(t, y, modes, directions).slip_velocity
        for c in range(k):
            speed = np.linalg.norm(slips[c])
            if modes[c] != SLIP:
                directions[c] = None
            elif speed > tol["slip"]:
                # "slow" well above "still": a slow slip held near the still speed
                # by its frozen direction turns away from the reference (and stops)
                directions[c] = SlipReference(slips[c] / speed,
                                              max(1e-3 * speed, _SLOW_STILL * tol["slip"]),
                                              tol["slip"])
            # else: a slip that starts keeps the direction it starts in
        solver.key = None  # the directions changed: no cached solution is valid
        mode_events = _events(model, solver, points, modes, directions, n)
        frozen_modes, frozen_dirs = list(modes), list(directions)

        def rhs(tt, z, frozen_modes=frozen_modes, frozen_dirs=frozen_dirs):
            if guard.hurried:  # a second stop signal: no more evaluations
                guard.skipped = True
                return np.full(len(z), np.nan)
            try:
                sol = solver(tt, z[:n], frozen_modes, frozen_dirs)
            except ModelError as exc:  # e.g. an input's function raised: its message
                guard.fail(tt, z[:n], str(exc))
                return np.full(len(z), np.nan)
            out = np.concatenate([sol.qdot, sol.udot, [sol.dissipation, sol.power]])
            if not np.all(np.isfinite(out)):
                guard.fail(tt, z[:n])
            return out

        guarded = [guarded_event(f, k, guard) for k, f in enumerate(user_events)]
        wrapped = [(lambda tt, z, f=f: f(tt, z[:n])) for f in guarded]
        for w, f in zip(wrapped, guarded):
            w.terminal = getattr(f, "terminal", False)
            w.direction = getattr(f, "direction", 0)
        all_events = [e for e, _, _ in mode_events] + wrapped
        seg_eval = None
        if t_eval is not None:
            keep = (t_eval >= t) if first else (t_eval > t)
            seg_eval = t_eval[keep & (t_eval <= t1)]
        z0 = np.concatenate([y, [dissipated, contact_work]])
        sol = None
        guard.last_step = None  # a step of an earlier segment may lie past its end
        if segment_c is not None:  # the model's module now: an optimized one may have come
            sol = _compiled_segment(model._module.contact_segment, model, t, t1, z0,
                                    frozen_modes, frozen_dirs, mode_events, stabilization,
                                    rtol, atol, guard)
        try:
            if sol is None:
                jac = ({"jac": _segment_jacobian(model, rhs, frozen_modes, frozen_dirs,
                                                 stabilization)} if exact else {})
                sol = solve_ivp(rhs, (t, t1), z0, method=stepper, t_eval=seg_eval,
                                events=all_events or None, rtol=rtol, atol=atol, **options,
                                **jac)
        except np.linalg.LinAlgError as exc:
            status, message = -1, f"singular contact equations at t={t:.6g} ({exc})"
            break
        for key in counters:
            counters[key] += getattr(sol, key, 0)
        seg_t, seg_z = np.asarray(sol.t, dtype=float), np.asarray(sol.y).reshape(n + 2, -1)
        if not first and t_eval is None and seg_t.size and seg_t[0] == t:
            seg_t, seg_z = seg_t[1:], seg_z[:, 1:]
        ts.append(seg_t)
        ys.append(seg_z[:n])
        work.append(seg_z[n:])
        point_modes.extend([tuple(frozen_modes)] * seg_t.size)
        point_dirs.extend([tuple(frozen_dirs)] * seg_t.size)
        n_mode = len(mode_events)
        for i in range(len(user_events)):
            if sol.t_events is not None and len(sol.t_events[n_mode + i]):
                t_events[i].extend(sol.t_events[n_mode + i])
                y_events[i].extend(np.asarray(sol.y_events[n_mode + i])[:, :n])
        first = False
        if sol.status == -1:
            status, message = -1, guard.stop_reason or sol.message
            if guard.last_step is not None:  # the state the solver accepted last
                keep_point(*guard.last_step, frozen_modes, frozen_dirs)
            break
        if sol.status == 0:
            break
        t_segment_start = t
        # a terminal event: the latest event time is where the segment ended
        last = [(float(te[-1]), np.asarray(ye)[-1]) for te, ye in zip(sol.t_events, sol.y_events)
                if len(te)]
        t, z = max(last, key=lambda item: item[0])
        boundary = (t, z, frozen_modes, frozen_dirs)
        y, dissipated, contact_work = z[:n].copy(), float(z[n]), float(z[n + 1])
        fired_user = [i for i in range(len(user_events))
                      if getattr(user_events[i], "terminal", False)
                      and len(sol.t_events[n_mode + i]) and sol.t_events[n_mode + i][-1] == t]
        if fired_user:
            status, message = 1, "a termination event occurred"
            break
        fired = [(c, kind) for i, (_, c, kind) in enumerate(mode_events)
                 if len(sol.t_events[i]) and sol.t_events[i][-1] == t]
        reasons = []
        new_modes = list(modes)
        before = list(directions)
        stop_fired, stopping = set(), {}
        for c, kind in fired:
            if kind == "gap":
                new_modes[c] = STICK  # touching; settled below (impact if approaching)
                reasons.append((c, SEPARATED, STICK, "the gap closes"))
            elif kind == "lift-off":
                new_modes[c] = SEPARATED
                reasons.append((c, modes[c], SEPARATED, "the normal force vanishes"))
            elif kind == "slip stops":  # or a slow slip turned away: a new reference
                stop_fired.add(c)
            elif kind == "friction limit":
                sol_c = solver(t, y, modes, directions)
                ft = sol_c.friction[c]
                new_modes[c] = SLIP
                directions[c] = SlipReference(-ft / max(np.linalg.norm(ft), 1e-300),
                                              still=tol["slip"])
                reasons.append((c, STICK, SLIP, "the friction reaches mu_s N"))
        if stop_fired:
            # every sliding contact whose slip has stopped (a bead in a corner
            # stops on the floor and on the wall at once) tries to stick
            stopping = _stopped(solver, t, y, modes, directions, tol, stop_fired)
            for c in stopping:
                new_modes[c] = STICK
                reasons.append((c, SLIP, STICK, "the slip stops"))
        try:
            y, new_modes, directions = _resolve(model, solver, t, y, new_modes, directions,
                                                tol, rest, reasons, impacts, bounces,
                                                stopping)
        except (RuntimeError, np.linalg.LinAlgError) as exc:
            status, message = -1, f"stopped at t={t:.6g}: {exc}"
            break
        history.extend(_changes(t, names, modes, new_modes, reasons))
        history.extend(_restarts(t, names, stopping, new_modes, before, directions, reasons))
        modes = new_modes
        if t >= t1:
            break
        stalled = stalled + 1 if t - t_segment_start <= 1e-12 * max(abs(t1 - t0), 1e-300) \
            else 0
        if stalled > _MAX_STALLED_SEGMENTS:
            status, message = -1, (f"the contact modes change {stalled} times at t={t:.6g} "
                                   "without time advancing (chattering); last modes: "
                                   + ", ".join(f"{nm} {md}" for nm, md in zip(names, modes)))
            break
    else:
        status, message = -1, f"more than {max_segments} mode changes (chattering?)"
    t_out = np.concatenate(ts) if ts else np.zeros(0)
    y_out = np.concatenate(ys, axis=1) if ys else np.zeros((n, 0))
    extras = {"mode_history": history, "impacts": impacts, "point_modes": point_modes,
              "point_directions": point_dirs, "modes": tuple(modes),
              "initial_modes": initial_modes,
              "dissipated_work": np.concatenate(work, axis=1)[0] if work else np.zeros(0),
              "contact_work": np.concatenate(work, axis=1)[1] if work else np.zeros(0),
              "t_events": [np.asarray(v) for v in t_events],
              "y_events": [np.asarray(v).reshape(-1, n) for v in y_events],
              "counters": counters, "stabilization": stabilization}
    return t_out, y_out, status, message, extras


_EVENT_CODES = {"gap": 0, "lift-off": 1, "slip stops": 2, "friction limit": 3}


class _Segment:
    """What :func:`_compiled_segment` returns: the fields of ``solve_ivp``'s
    result that :func:`simulate_contacts` reads."""

    def __init__(self, t, y, status, t_events, y_events, nfev):
        self.t, self.y, self.status = t, y, status
        self.t_events, self.y_events = t_events, y_events
        self.nfev, self.njev, self.nlu = nfev, 0, 0
        self.message = "compiled contact segment"


def _compiled_segment(segment_c, model, t, t1, z0, modes, directions, mode_events,
                      stabilization, rtol, atol, guard):
    """One segment in the compiled contact loop, or ``None`` (Python path).

    The generated ``contact_segment`` (:mod:`kanedyn.numerics.backends._c_contact`)
    handles no active contact or one active unilateral contact; anything
    else, or a failure inside it (singular, not finite, step too small), is
    left to ``solve_ivp`` on :func:`solve_modes`, which then reproduces the
    reference behaviour (including its error handling) for that segment.
    ``guard``: the run's; a stop signal or its time limit ends the segment
    after its step, with what it has (a failure, as ``solve_ivp`` reports one).
    """
    active = [c for c, mode in enumerate(modes) if mode != SEPARATED]
    if len(active) > 1 or any(model.contacts[c]["kind"] != "unilateral" for c in active):
        return None
    k = len(modes)
    codes = {SEPARATED: 0, SLIP: 1, STICK: 2}
    ref = np.zeros((k, 3))
    slow, still, offset = np.full(k, np.inf), np.zeros(k), np.zeros(k)
    has_ref = np.zeros(k, dtype=np.intc)
    for c, d in enumerate(directions):
        if d is not None:
            has_ref[c] = 1
            ref[c], slow[c], still[c] = d.direction, d.slow, d.still
    ev_c = np.array([c for _, c, _ in mode_events], dtype=np.intc)
    ev_kind = np.array([_EVENT_CODES[kind] for _, _, kind in mode_events], dtype=np.intc)
    for fn, c, kind in mode_events:
        if kind == "gap":
            offset[c] = fn.offset
    coef = model.contacts
    spec = (np.array([codes[m] for m in modes], dtype=np.intc), has_ref, ref, slow, still,
            offset, np.array([float(coef[c]["mu_k"]) for c in range(k)]),
            np.array([float(coef[c]["mu_s"]) for c in range(k)]),
            np.array([float(coef[c]["viscous"]) for c in range(k)]), float(stabilization),
            ev_c, ev_kind)
    status, ts, zs, event, nfev = segment_c(float(t), float(t1), z0, model._p, spec,
                                            float(rtol), float(atol), guard.stop_flag,
                                            guard.seconds_left())
    if status == 2:
        return None
    t_events = [np.zeros(0) for _ in mode_events]
    y_events = [np.zeros((0, zs.shape[1])) for _ in mode_events]
    if status == 1:
        t_events[event] = ts[-1:]
        y_events[event] = zs[-1:]
    # 3: stopped (the run's guard says why)
    return _Segment(ts, zs.T, -1 if status == 3 else status, t_events, y_events, nfev)


def _stopped(solver, t, y, modes, directions, tol, fired):
    """Sliding contacts whose slip has stopped at ``(t, y)``: ``{contact: its slip
    speed}``.

    Stopped: the slip speed, free of the other contacts' drift, is at most
    ``min(1e3 tol_slip, 0.1 slow)`` of the contact's reference (a slow slip
    that merely turned away from its reference gets a new one instead).
    Besides the contacts whose stop event ``fired``, the ones whose slip was
    under way when their segment began (not one that has just started from
    rest) count.
    """
    slips = solver(t, y, modes, directions).slip_velocity
    out = {}
    for c, mode in enumerate(modes):
        if mode != SLIP or directions[c] is None:
            continue
        if c not in fired and not np.isfinite(directions[c].slow):
            continue
        speed = float(np.linalg.norm(slips[c]))
        if speed <= min(tol["slip"] * 1e3, 0.1 * directions[c].slow):
            out[c] = speed
    return out


def _restarts(t, names, stopped, after, before, directions, reasons):
    """A slip that stopped and slides on in another direction (a reversal).

    Its mode is ``slip`` before and after, so :func:`_changes` does not see
    it; it is recorded as ``slip -> slip`` with why it did not stick.
    """
    out = []
    for c in sorted(stopped):
        if after[c] != SLIP or directions[c] is None or before[c] is None:
            continue
        turn = float(directions[c].direction @ before[c].direction)
        if turn > 1 - 1e-6:
            continue
        why = [r for i, old, new, r in reasons if i == c and (old, new) == (STICK, SLIP)]
        what = "the slip stops and reverses" if turn < 0 else "the slip stops and turns"
        out.append(ModeChange(t, names[c], SLIP, SLIP, "; ".join([what, *why])))
    return out


def _changes(t, names, before, after, reasons):
    """One ModeChange per contact whose mode changed, with all its reasons."""
    out = []
    for c, (a, b) in enumerate(zip(before, after)):
        if a != b:
            why = "; ".join(dict.fromkeys(r for i, _, _, r in reasons if i == c))
            out.append(ModeChange(t, names[c], a, b, why))
    return out


def _check_initial(model, t, y, modes, tol):
    """Bad initial states of contacts are errors that say what is wrong."""
    with np.errstate(invalid="ignore", divide="ignore"):  # a vanishing normal: below
        points = contact_points(model, t, y)
    for c, point in enumerate(points):
        coef = model.contacts[c]
        if not point.grad_norm > 0:
            raise ModelError(f"contact {coef['name']}: the surface normal vanishes at the "
                             "contact point (the gap function has a zero gradient there)")
        d = point.distance
        if coef["kind"] == "bilateral" and abs(d) > tol["distance"]:
            raise ModelError(f"contact {coef['name']}: the point is not on its surface at "
                             f"the initial state: {d:.3g} m {'off' if d > 0 else 'inside'}")
        if d < -tol["distance"]:
            raise ModelError(f"contact {coef['name']}: the point starts {-d:.3g} m inside "
                             "its surface")


def _resolve(model, solver, t, y, modes, directions, tol, rest, reasons, impacts, bounces,
             stopped=None):
    """Impacts of approaching contacts, then consistent modes.

    ``bounces`` maps a contact to the time and separation speed of its last
    bounce; it is updated here.  A contact that hits again after a flight
    that could not have lifted it by more than ``tol["lift"]`` (separation
    speed times flight time; a hundredth of ``atol``, below what the
    integration resolves) is at rest on its surface: its impact is plastic,
    like one slower than ``rest`` (else the bounces of a contact pressed onto
    its surface at a speed the rounding of the gap keeps up, a Zeno sequence,
    go on without end).  ``stopped``: as for :func:`settle`.
    """
    points = contact_points(model, t, y)
    touching = [c for c, p in enumerate(points) if p.distance <= tol["distance"]]
    hitting = [c for c in touching if points[c].normal_speed < -tol["speed"]]
    if hitting:
        involved = sorted(set(hitting) | {c for c in touching if _in_contact(modes[c])})
        # too slow to bounce again, or bouncing too little to leave: plastic
        plastic = {c: 0.0 for c in hitting if -points[c].normal_speed < rest
                   or (c in bounces
                       and bounces[c][1] * (t - bounces[c][0]) <= tol["lift"])}
        y, record = resolve_impact(model, t, y, involved, points, plastic)
        impacts.append(record)
        points = contact_points(model, t, y)
        for c in involved:
            if points[c].normal_speed > rest:
                new = SEPARATED
                bounces[c] = (t, points[c].normal_speed)
            else:
                new = _touching_mode(model.contacts[c], points[c], tol)
                bounces.pop(c, None)
            if new != modes[c]:
                reasons.append((c, modes[c], new, "impact" if c not in plastic
                                else "impact (too slow to bounce: it stays)"))
                modes[c] = new
    modes, directions = settle(model, solver, t, y, modes, directions, tol, reasons, stopped)
    return y, modes, directions
