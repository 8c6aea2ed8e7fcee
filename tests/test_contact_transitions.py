"""Mode transitions of contacts: where a slip stops, reverses or starts.

Checked against closed forms: the bead sliding on the floor and the wall of a
tube spinning about the vertical (a linear ODE in the tube frame while it
slides; the forces while it sticks), and the block pushed up an incline
steeper than its friction angle (constant deceleration up, acceleration down,
the reversal time).
"""

from __future__ import annotations

import math

import numpy as np
import sympy.physics.mechanics as me
import pytest

import kanedyn as kd
from kanedyn import models
from kanedyn.numerics._contact_dynamics import SlipReference

TIGHT = dict(rtol=1e-10, atol=1e-10)
M, G, MU, B = 1.0, 9.81, 0.3, 0.05  # the bead-in-tube defaults


def _bead_model(omega):
    definition = models.build("bead-in-tube", omega=omega)
    model = kd.kane(**definition.kane_args).numeric(constants=definition.constants)
    return model, model.state(definition.initial_state)


def _along_tube(res, omega):
    """The bead's coordinate along the tube, x_E (its coordinates are inertial)."""
    return np.cos(omega * res.t) * res["x"] + np.sin(omega * res.t) * res["y"]


def _linear(p, q, c, x0, v0):
    """x(t), v(t) of x'' + p x' + q x = c (q != 0, real distinct roots)."""
    r1, r2 = np.roots([1.0, p, q])
    xp = c / q
    a = (v0 - r2 * (x0 - xp)) / (r1 - r2)
    b = x0 - xp - a
    return (lambda t: xp + a * np.exp(r1 * t) + b * np.exp(r2 * t),
            lambda t: a * r1 * np.exp(r1 * t) + b * r2 * np.exp(r2 * t), (r1, r2, a, b))


def _inward(omega, x0=1.0, v0=-1.0):
    """The bead sliding towards the axis: x'' + 2 mu W x' - W^2 x = mu (g + W^2 b)."""
    x, v, (r1, r2, a, b) = _linear(2 * MU * omega, -omega ** 2, MU * (G + omega ** 2 * B),
                                   x0, v0)
    t_stop = math.log(-r2 * b / (r1 * a)) / (r1 - r2)  # v(t_stop) = 0
    return x, v, t_stop


def _tube_components(res, force, omega):
    """Inertial friction vectors (N, 3) in the tube frame: along, across, vertical."""
    c, s = np.cos(omega * res.t), np.sin(omega * res.t)
    return np.stack([c * force[:, 0] + s * force[:, 1], -s * force[:, 0] + c * force[:, 1],
                     force[:, 2]], axis=1)


# ------------------------------------------------------------ slip, then stick
def test_bead_in_tube_slides_stops_and_sticks_as_the_closed_form():
    omega = 1.0
    model, y0 = _bead_model(omega)
    x, v, t_stop = _inward(omega)
    x_stop = x(t_stop)
    assert omega ** 2 * x_stop < MU * (G + omega ** 2 * B)  # static friction holds it
    t_eval = np.linspace(0.0, 1.0, 41)
    res = kd.simulate(model, (0.0, 1.0), y0, t_eval=t_eval, **TIGHT)
    assert res.success, res.message
    # both contacts start closed: no t = 0 entry; both stop at the closed-form time
    assert [(c.contact, c.old, c.new) for c in res.mode_history] == [
        ("floor", "slip", "stick"), ("wall", "slip", "stick")]
    for change in res.mode_history:
        assert change.t == pytest.approx(t_stop, rel=1e-9)
    forces = res.contact_forces
    floor = _tube_components(res, forces["floor"]["friction"], omega)
    wall = _tube_components(res, forces["wall"]["friction"], omega)
    sliding = res.t < t_stop
    # sliding: x(t); N_floor = m g, N_wall = m (W^2 b - 2 W x'), friction mu N outwards
    x_tube = _along_tube(res, omega)
    assert np.allclose(x_tube[sliding], x(res.t[sliding]), rtol=0, atol=1e-9)
    n_wall = M * (omega ** 2 * B - 2 * omega * v(res.t[sliding]))
    assert np.allclose(forces["floor"]["normal"][sliding], M * G, rtol=1e-9)
    assert np.allclose(forces["wall"]["normal"][sliding], n_wall, rtol=1e-8)
    assert np.allclose(floor[sliding], [MU * M * G, 0, 0], rtol=0, atol=1e-8)
    assert np.allclose(wall[sliding], np.outer(MU * n_wall, [1, 0, 0]), rtol=0, atol=1e-8)
    # sticking: stays at x_stop; the floor carries the weight, the wall normal the
    # centripetal force across the tube, the frictions the one along it, shared
    # so that both use the same fraction of their cones
    stuck = res.t > t_stop
    assert stuck.sum() > 10
    assert np.allclose(x_tube[stuck], x_stop, rtol=0, atol=1e-9)
    assert all(m == "stick" for m in np.asarray(forces["floor"]["mode"])[stuck])
    assert np.allclose(forces["floor"]["normal"][stuck], M * G, rtol=1e-8)
    assert np.allclose(forces["wall"]["normal"][stuck], M * omega ** 2 * B, rtol=1e-8)
    pull = M * omega ** 2 * x_stop
    share = G / (G + omega ** 2 * B)
    assert np.allclose(floor[stuck], [-pull * share, 0, 0], rtol=0, atol=1e-8)
    assert np.allclose(wall[stuck], [-pull * (1 - share), 0, 0], rtol=0, atol=1e-8)
    # energy: the friction dissipates, the spinning wall drives the bead
    assert np.max(np.abs(res.energy_balance())) < 1e-8


@pytest.mark.parametrize("tolerances, rel", [(TIGHT, 2e-8), ({}, 3e-6)])
def test_forces_at_the_output_where_the_slip_stops_are_those_of_the_slip(tolerances, rel):
    """The output at the stop ends the sliding segment: slip-mode forces, along the tube."""
    omega = 1.0
    model, y0 = _bead_model(omega)
    _, _, t_stop = _inward(omega)
    res = kd.simulate(model, (0.0, 0.5), y0, **tolerances)
    assert res.success, res.message
    k = int(np.argmin(np.abs(res.t - t_stop)))
    assert res.t[k] == pytest.approx(t_stop, rel=1e-7)
    forces = res.contact_forces
    assert (forces["floor"]["mode"][k], forces["wall"]["mode"][k]) == ("slip", "slip")
    assert (forces["floor"]["mode"][k + 1], forces["wall"]["mode"][k + 1]) == \
        ("stick", "stick")
    floor = _tube_components(res, forces["floor"]["friction"], omega)
    # full mu N along the tube, against the inward slip; nothing across it
    assert floor[k, 0] == pytest.approx(MU * M * G, rel=1e-8)
    assert abs(floor[k, 1]) < 1e-8 * MU * M * G
    # the wall normal force m (W^2 b - 2 W x') reaches m W^2 b: no jump into the stick
    n_wall = forces["wall"]["normal"]
    # (up to Baumgarte's term on the drift: 4e-10 N tight, 4e-8 N at the defaults)
    assert n_wall[k] == pytest.approx(M * omega ** 2 * B, rel=rel)
    assert n_wall[k + 1] == pytest.approx(M * omega ** 2 * B, rel=rel)
    assert np.all(n_wall[: k + 1] >= M * omega ** 2 * B * (1 - rel))


def test_drift_across_the_wall_does_not_set_the_floor_slip_direction():
    """A slip nearly stopped along the tube, 3e-11 m/s across the wall (constraint drift)."""
    omega = 1.0
    model, y0 = _bead_model(omega)
    y = y0.copy()
    # at t = 0 the tube frame is N; relative velocity (-5e-12, 3e-11, 0) at (1, b, 0)
    y[3:6] = np.array([-5e-12, 3e-11, 0.0]) + omega * np.array([-B, 1.0, 0.0])
    for directions in (None, [SlipReference(np.array([-1.0, 0, 0]), 1e-3, 1e-10)] * 2):
        sol = model.contact_dynamics(0.0, y, ["slip", "slip"], directions)
        assert sol.friction[0] == pytest.approx([MU * M * G, 0, 0], abs=1e-12)
        # m W^2 b (W = 1), up to the Baumgarte term on the drift (6e-10 N)
        assert sol.normal_force[1] == pytest.approx(M * B, rel=1e-7)
        assert sol.slip_velocity[0] == pytest.approx([-5e-12, 0, 0], abs=1e-17)


# ----------------------------------------------------------- slip reversals
def test_bead_in_a_faster_tube_reverses_on_both_contacts_then_leaves_the_wall():
    """W^2 x_stop > mu (g + W^2 b): both slips reverse; sliding out, the Coriolis force
    pulls the bead off the wall where x' = W b / 2."""
    omega = 2.5
    model, y0 = _bead_model(omega)
    x_in, _, t_stop = _inward(omega)
    x_stop = x_in(t_stop)
    assert omega ** 2 * x_stop > MU * (G + omega ** 2 * B)
    # sliding out: x'' - 2 mu W x' - W^2 x = -mu (g + W^2 b) from (x_stop, 0)
    x_out, v_out, _ = _linear(-2 * MU * omega, -omega ** 2, -MU * (G + omega ** 2 * B),
                              x_stop, 0.0)
    lo, hi = 0.0, 1.0
    for _ in range(200):  # bisection on the closed form: v_out = W b / 2
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if v_out(mid) < omega * B / 2 else (lo, mid)
    t_leave = t_stop + 0.5 * (lo + hi)
    res = kd.simulate(model, (0.0, 0.2), y0, **TIGHT)
    assert res.success, res.message
    history = [(c.contact, c.old, c.new) for c in res.mode_history]
    assert history == [("floor", "slip", "slip"), ("wall", "slip", "slip"),
                       ("wall", "slip", "separated")]
    for change in res.mode_history[:2]:
        assert change.t == pytest.approx(t_stop, rel=1e-9)
        assert change.reason.startswith("the slip stops and reverses")
    assert res.mode_history[2].t == pytest.approx(t_leave, rel=1e-8)
    later = (res.t > t_stop) & (res.t <= t_leave)
    assert np.allclose(_along_tube(res, omega)[later], x_out(res.t[later] - t_stop), rtol=0,
                       atol=1e-9)
    assert np.max(np.abs(res.energy_balance())) < 1e-8


def test_block_pushed_up_a_steep_incline_reverses_without_sticking():
    """mu < tan(alpha): up at -g (sin a + mu cos a), reverses at v0 / that, down at
    g (sin a - mu cos a); the reversal is one slip -> slip entry of the mode history."""
    definition = models.build("block-on-incline")
    sym = definition.symbols
    alpha, mu, v0 = 0.5, 0.3, 2.0
    constants = dict(definition.constants)
    constants.update({sym["theta0"]: alpha, sym["mu_k"]: mu, sym["mu_s"]: mu,
                      sym["t1"]: 100.0})  # the plane does not turn
    model = kd.kane(**definition.kane_args).numeric(constants=constants)
    y0 = model.state({sym["s"]: 0.0, sym["h"]: 0.0, sym["us"]: v0, sym["uh"]: 0.0})
    up = G * (math.sin(alpha) + mu * math.cos(alpha))
    down = G * (math.sin(alpha) - mu * math.cos(alpha))
    t_rev = v0 / up
    t = np.linspace(0.0, 1.0, 21)
    res = kd.simulate(model, (0.0, 1.0), y0, t_eval=t, **TIGHT)
    assert res.success, res.message
    assert [(c.old, c.new) for c in res.mode_history] == [("slip", "slip")]
    change = res.mode_history[0]
    assert change.t == pytest.approx(t_rev, rel=1e-12)
    assert change.reason == "the slip stops and reverses; static friction cannot hold it"
    s_rev = v0 ** 2 / (2 * up)
    exact = np.where(t < t_rev, v0 * t - up * t ** 2 / 2, s_rev - down * (t - t_rev) ** 2 / 2)
    assert np.allclose(res["s"], exact, rtol=0, atol=1e-9)
    speed = np.where(t < t_rev, v0 - up * t, -down * (t - t_rev))
    assert np.allclose(res["u_s"], speed, rtol=0, atol=1e-9)
    # friction mu N against the slip: down the slope, then up it
    friction = res.contact_forces["incline"]["friction"]
    slope = np.array([0.0, math.cos(alpha), math.sin(alpha)])  # E.y in N
    along = friction @ slope
    n_force = M * G * math.cos(alpha)
    assert np.allclose(along, np.where(t < t_rev, -mu * n_force, mu * n_force), rtol=1e-9)


def test_modes_given_for_the_start_are_checked_and_changes_recorded():
    """A block at rest on a plane steeper than its friction angle, started as 'stick'
    on request: static friction cannot hold it, and that change is recorded at t0."""
    definition = models.build("block-on-incline")
    sym = definition.symbols
    constants = dict(definition.constants)
    constants.update({sym["theta0"]: 0.5, sym["mu_k"]: 0.3, sym["mu_s"]: 0.3,
                      sym["t1"]: 100.0})
    model = kd.kane(**definition.kane_args).numeric(constants=constants)
    y0 = model.state({sym["s"]: 0.0, sym["h"]: 0.0, sym["us"]: 0.0, sym["uh"]: 0.0})
    res = kd.simulate(model, (0.0, 0.5), y0, modes=["stick"], **TIGHT)
    assert [(c.t, c.old, c.new, c.reason) for c in res.mode_history] == [
        (0.0, "stick", "slip", "static friction cannot hold it")]
    res = kd.simulate(model, (0.0, 0.5), y0, **TIGHT)  # found from the state: no entry
    assert res.mode_history == []
    down = G * (math.sin(0.5) - 0.3 * math.cos(0.5))
    assert res["s"][-1] == pytest.approx(-down * 0.5 ** 2 / 2, abs=1e-9)


@pytest.mark.parametrize("backend", ["numpy", "c"])  # c: the compiled contact segments
def test_slow_slip_turned_by_a_side_force_stops_at_the_closed_form(backend):
    """A puck launched slowly (1e-3 m/s, 1000 times the stick speed of 1e-6 m/s at the
    default tolerances) along x on a floor, pushed along y by half its friction: the
    slip turns towards the force while it slows and stops at the closed form
    (``v = C tan(phi/2)^(1/k) / sin(phi)``, ``phi`` the slip's angle from the force,
    ``k = F / (mu m g)``; ``dt = -v dphi / (a sin phi)``), within the time it takes
    to lose half the stick speed, then sticks.  Its slow-slip speed was once 1e-3
    of the launch speed, no more than the stick speed: the slip direction, frozen
    below the stick speed, then held the slip there and it never stopped."""
    from scipy.integrate import quad
    x, y, z = me.dynamicsymbols("x y z")
    ux, uy, uz = me.dynamicsymbols("u_x u_y u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + y * N.y + z * N.z)
    P.set_vel(N, ux * N.x + uy * N.y + uz * N.z)
    mu, k, v0 = 0.5, 0.5, 1e-3
    a = k * mu * G  # the side force per unit mass
    floor = kd.Contact(P, kd.Plane(N, O, N.z), mu_k=mu, name="floor")
    model = kd.kane(frame=N, q_ind=[x, y, z], u_ind=[ux, uy, uz],
                    kd_eqs=[x.diff() - ux, y.diff() - uy, z.diff() - uz],
                    bodies=[me.Particle("puck", P, M)],
                    loads=[(P, M * (a * N.y - G * N.z))],
                    contacts=[floor]).numeric(backend=backend)
    C = v0 / math.tan(math.pi / 4) ** (1 / k)  # v at phi = 90 deg
    t_stop = quad(lambda p: C * math.tan(p / 2) ** (1 / k) / math.sin(p) ** 2 / a,
                  0.0, math.pi / 2)[0]
    res = kd.simulate(model, (0.0, 3 * t_stop), {x: 0, y: 0, z: 0, ux: v0, uy: 0, uz: 0},
                      timeout=120)
    assert res.success
    (change,) = res.mode_history
    assert (change.old, change.new) == ("slip", "stick")
    # the stop is found below half the stick speed; the slip slows at mu g - a there
    assert abs(change.t - t_stop) < 0.5e-6 / (mu * G - a)
    assert np.max(np.abs(res.y[3:, res.t > change.t])) < 1e-9
