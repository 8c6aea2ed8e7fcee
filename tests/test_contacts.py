"""Contacts with Coulomb friction, stick-slip, separation and impacts.

Checked against closed forms (REFERENCES.md: the particle sliding inside a
sphere; stick-slip times of a block on a turning plane; bounce heights; the
ladder leaving a smooth wall), against independent computations (Newton-Euler
with the geometry written out by hand; Routh's piecewise-linear impact
process in the plane) and against the energy balance.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import models

TIGHT = dict(rtol=1e-10, atol=1e-10)


def _model(name, constants=None, **options):
    definition = models.build(name, **options)
    eom = kd.kane(**definition.kane_args)
    values = dict(definition.constants)
    values.update(constants or {})
    model = eom.numeric(constants=values)
    return definition, model, model.state(definition.initial_state)


# --------------------------------------------------------------- closed forms
def test_sphere_slug_speed_normal_force_and_great_circle():
    definition, model, y0 = _model("sphere-slug")
    R, mu = 1.0, 0.2
    t_eval = np.linspace(0.0, 5.0, 51)
    res = kd.simulate(model, (0.0, 5.0), y0, t_eval=t_eval, **TIGHT)
    assert res.success, res.message
    r, v = res.y[:3], res.y[3:]
    speed = np.linalg.norm(v, axis=0)
    v0 = math.sqrt(10.0)
    exact = v0 / (1 + mu * v0 * t_eval / R)
    assert np.max(np.abs(speed / exact - 1)) < 1e-8
    normal = res.contact_forces["wall"]["normal"]
    assert np.max(np.abs(normal / (exact ** 2 / R) - 1)) < 1e-8
    plane = np.cross(y0[:3], y0[3:])
    plane /= np.linalg.norm(plane)
    assert np.max(np.abs(plane @ r)) < 1e-9       # a great circle
    assert np.max(np.abs(np.linalg.norm(r, axis=0) - R)) < 1e-9
    # friction work equals the kinetic energy lost
    assert abs(res.dissipated_work[-1] - (res.kinetic_energy[-1] - res.kinetic_energy[0])) \
        < 1e-8


def test_block_on_turning_plane_stops_sticks_and_slips_at_closed_form_times():
    definition, model, y0 = _model("block-on-incline")
    g, mu_k, mu_s, th0, w, t1 = 9.81, 0.4, 0.5, 0.2, 0.5, 1.0
    res = kd.simulate(model, (0.0, 2.0), y0, **TIGHT)
    assert res.success, res.message
    changes = [(c.old, c.new) for c in res.mode_history]
    # it starts sliding: the initial mode is not a change
    assert changes == [("slip", "stick"), ("stick", "slip")]
    assert res.contact_forces["incline"]["mode"][0] == "slip"
    decel = g * (mu_k * math.cos(th0) - math.sin(th0))
    t_stop = 1.0 / decel                                      # v0 = 1 m/s down the slope
    assert abs(res.mode_history[0].t - t_stop) < 1e-9
    s_stop = 1.0 - 1.0 / (2 * decel)
    # sticking on the turning plane: g sin th - w^2 s = mu_s g cos th
    theta = math.atan(mu_s) + math.asin(w ** 2 * s_stop / (g * math.sqrt(1 + mu_s ** 2)))
    assert abs(res.mode_history[1].t - (t1 + (theta - th0) / w)) < 1e-9
    assert abs(res["s"][np.searchsorted(res.t, 1.5)] - s_stop) < 1e-8


def test_bouncing_ball_apex_heights_and_restitution():
    definition, model, y0 = _model("bouncing-ball")
    e, r = 0.8, 0.05

    def apex(t, y):
        return y[3]
    apex.direction = -1
    res = kd.simulate(model, (0.0, 3.0), y0, events=apex, **TIGHT)
    assert res.success, res.message
    heights = res.y_events[0][:, 1] - r  # the first at t = 0, dropped from 1 m
    assert res.t_events[0][0] == 0.0 and len(heights) >= 6
    expected = 1.0 * e ** (2 * np.arange(len(heights)))
    assert np.max(np.abs(heights / expected - 1)) < 1e-8
    for impact in res.impacts:
        assert impact.separation_speeds[0] == pytest.approx(e * impact.approach_speeds[0],
                                                            rel=1e-10)
    assert np.max(np.abs(res.energy_balance())) < 1e-8


def test_ball_comes_to_rest_with_its_weight_on_the_floor():
    definition, model, y0 = _model("bouncing-ball", constants={"e": 0.5})
    res = kd.simulate(model, (0.0, 3.0), y0, **TIGHT)
    assert res.success, res.message
    assert res.mode_history[-1].new == "slip"  # frictionless: resting contacts slide
    normal = res.contact_forces["floor"]["normal"]
    assert normal[-1] == pytest.approx(0.1 * 9.81, rel=1e-9)
    assert abs(res["z"][-1] - 0.05) < 1e-8


def test_ball_bounces_accumulate_and_it_rests_at_the_zeno_time():
    """Bounces with e = 0.8 after a 1 m drop accumulate at t1 (1 + e) / (1 - e),
    t1 = sqrt(2 h / g); the run passes that instant with the ball at rest."""
    definition, model, y0 = _model("bouncing-ball")
    res = kd.simulate(model, (0.0, 5.0), y0, **TIGHT)
    assert res.success, res.message
    e, t1 = 0.8, math.sqrt(2 * 1.0 / 9.81)
    zeno = t1 * (1 + e) / (1 - e)
    assert len(res.impacts) > 50
    rest = res.mode_history[-1]
    assert (rest.old, rest.new) == ("separated", "slip")
    assert "too slow to bounce" in rest.reason
    # the bounces left out when the contact closes last a few microseconds
    assert zeno - 1e-5 < rest.t <= zeno
    assert abs(res["z"][-1] - 0.05) < 1e-8
    assert res["u_x"][-1] == pytest.approx(0.5, rel=1e-9)  # frictionless floor


def test_smooth_ladder_leaves_the_wall_at_two_thirds_of_its_height():
    definition, model, y0 = _model("ladder", frictionless=True, angle=1.2)
    res = kd.simulate(model, (0.0, 0.7), y0, **TIGHT)
    leave = [c for c in res.mode_history if c.contact == "wall" and c.new == "separated"]
    assert len(leave) == 1
    k = np.searchsorted(res.t, leave[0].t)
    theta = res["theta"][k]
    top_height = -2.0 * math.sin(theta)  # L sin of the angle with the floor
    assert top_height / (2.0 * math.sin(1.2)) == pytest.approx(2 / 3, abs=1e-8)


def test_rough_ladder_at_a_steep_angle_stays_and_a_shallow_one_slides():
    _, steep, y_steep = _model("ladder", angle=1.2)  # tan > (1 - mu_f mu_w)/(2 mu_f)
    res = kd.simulate(steep, (0.0, 1.0), y_steep)
    assert np.max(np.abs(res.y[3:])) < 1e-8
    _, shallow, y_shallow = _model("ladder", angle=0.9)
    res = kd.simulate(shallow, (0.0, 0.5), y_shallow)
    assert res["u_x"][-1] > 0.1


# ------------------------------------------------------------- energy balance
@pytest.mark.parametrize("name, t_end", [("ladder", 2.0), ("falling-rod", 2.0),
                                         ("slug-ellipsoid", 8.0)])
def test_energy_balance_friction_work_and_impact_losses(name, t_end):
    definition, model, y0 = _model(name)
    res = kd.simulate(model, (0.0, t_end), y0, **TIGHT)
    assert res.success, res.message
    assert res.impacts
    assert np.max(np.abs(res.energy_balance())) < 1e-8
    for impact in res.impacts:
        assert impact.energy_loss >= -1e-12
    if name != "slug-ellipsoid":  # fixed surfaces: the kinetic energy never jumps up
        assert all(i.kinetic_energy_jump <= 1e-12 for i in res.impacts)
        assert all(i.energy_loss == pytest.approx(-i.kinetic_energy_jump, abs=1e-12)
                   for i in res.impacts)
    assert res.dissipated_work[-1] <= 0


def test_slug_on_the_tank_slides_separates_flies_and_hits_again():
    definition, model, y0 = _model("slug-ellipsoid")
    res = kd.simulate(model, (0.0, 8.0), y0)
    kinds = {(c.old, c.new) for c in res.mode_history}
    assert ("slip", "separated") in kinds and ("separated", "slip") in kinds
    assert len(res.impacts) > 3
    assert np.ptp(res["z"]) > 0.1  # a motion in space, not in the equator


# -------------------------------------------------------------- Newton-Euler
def _rod_geometry(y, L=2.0):
    """Ends A (+L/2 along the rod) and C of the planar rod, in (x, z)."""
    x, z, theta = y[:3]
    axis = np.array([math.cos(theta), math.sin(theta)])
    centre = np.array([x, z])
    return centre, centre + L / 2 * axis, centre - L / 2 * axis


def test_ladder_contact_forces_satisfy_newton_euler_and_coulomb():
    definition, model, y0 = _model("ladder", angle=0.9)
    m, L, g, mu = 10.0, 2.0, 9.81, {"floor": 0.3, "wall": 0.2}
    I = m * L ** 2 / 12
    res = kd.simulate(model, (0.0, 0.6), y0, t_eval=np.linspace(0.05, 0.6, 12), **TIGHT)
    forces = res.contact_forces
    checked = 0
    for k in range(res.t.size):
        y = res.y[:, k]
        modes = tuple(forces[n]["mode"][k] for n in ("floor", "wall", "top-floor"))
        if modes[:2] != ("slip", "slip"):
            continue
        sol = model.contact_dynamics(res.t[k], y, list(modes))
        a = sol.udot
        centre, foot, top = _rod_geometry(y, L)
        w = y[5]
        F_floor = np.array([forces["floor"]["friction"][k, 0], forces["floor"]["normal"][k]])
        F_wall = np.array([forces["wall"]["normal"][k], forces["wall"]["friction"][k, 2]])
        # Newton: m a_G = sum F + m g
        assert np.allclose(m * a[:2], F_floor + F_wall + [0, -m * g], atol=1e-9)
        # Euler about G (the y axis points into the page: theta grows x -> z)
        moment = sum((p - centre)[0] * F[1] - (p - centre)[1] * F[0]
                     for p, F in ((foot, F_floor), (top, F_wall)))
        assert I * a[2] == pytest.approx(moment, abs=1e-9)
        # Coulomb: against the slip, magnitude mu N
        v_foot = y[3] - w * (foot - centre)[1]
        v_top = y[4] + w * (top - centre)[0]
        assert F_floor[0] == pytest.approx(-mu["floor"] * F_floor[1] * np.sign(v_foot),
                                           abs=1e-9)
        assert F_wall[1] == pytest.approx(-mu["wall"] * F_wall[0] * np.sign(v_top), abs=1e-9)
        assert F_floor[1] > 0 and F_wall[0] > 0
        checked += 1
    assert checked >= 5


def test_slug_contact_force_against_newton_and_the_tank_geometry():
    definition, model, y0 = _model("slug-ellipsoid")
    a_, b_, c_, mu, Om, tau, A, w = 0.8, 0.6, 0.5, 0.3, 2.0, 1.0, 0.3, 3.0
    res = kd.simulate(model, (0.0, 0.6), y0, t_eval=np.linspace(0.05, 0.55, 11), **TIGHT)
    forces = res.contact_forces["tank"]
    for k in range(res.t.size):
        t, y = res.t[k], res.y[:, k]
        assert forces["mode"][k] == "slip"
        sol = model.contact_dynamics(t, y, ["slip"])
        F = forces["normal"][k] * sol.points[0].normal + forces["friction"][k]
        assert np.allclose(sol.udot, F, atol=1e-10)  # m a = F, m = 1, zero g
        # the tank: rotation psi about z, centre X(t) along x
        psi = Om * (t + tau * (math.exp(-t / tau) - 1))
        spin = Om * (1 - math.exp(-t / tau))
        Rot = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0],
                        [0, 0, 1]])
        centre = np.array([A * (1 - math.cos(w * t)), 0, 0])
        centre_v = np.array([A * w * math.sin(w * t), 0, 0])
        r = Rot.T @ (y[:3] - centre)
        assert (r / [a_, b_, c_]) @ (r / [a_, b_, c_]) == pytest.approx(1.0, abs=1e-9)
        inward = -Rot @ (r / np.array([a_, b_, c_]) ** 2)
        inward /= np.linalg.norm(inward)
        slip = y[3:] - centre_v - np.cross([0, 0, spin], y[:3] - centre)
        slip -= (slip @ inward) * inward
        N = F @ inward
        assert N == pytest.approx(forces["normal"][k], rel=1e-10)
        friction = F - N * inward
        assert np.allclose(friction, -mu * N * slip / np.linalg.norm(slip), atol=1e-9)


# --------------------------------------------------------------------- impacts
def _routh(W, v0, mu, e):
    """Planar impact at one point by Routh's method (Poisson restitution).

    W : 2x2 (tangential, normal) inverse inertia in contact space.  Along
    the normal impulse p the velocity is piecewise linear; the breakpoints
    are where the slip stops and where compression ends.
    """
    v, p, Pt, pc = np.array(v0, float), 0.0, 0.0, None
    can_stick = abs(W[0, 1] / W[0, 0]) <= mu
    for _ in range(10):
        end = np.inf if pc is None else (1 + e) * pc
        if abs(v[0]) < 1e-14 and can_stick:
            ratio = -W[0, 1] / W[0, 0]          # tangential impulse keeping v_t = 0
        elif abs(v[0]) < 1e-14:               # it slips the way W drives it
            ratio = -mu * np.sign(W[0, 1])
        else:
            ratio = -mu * np.sign(v[0])
        rate = W @ [ratio, 1.0]
        stops = [end]
        if pc is None and rate[1] > 0:
            stops.append(p - v[1] / rate[1])
        if abs(v[0]) >= 1e-14 and rate[0] * v[0] < 0:
            stops.append(p - v[0] / rate[0])
        step = min(s for s in stops if s > p) - p
        v, p, Pt = v + step * rate, p + step, Pt + step * ratio
        if pc is None and abs(v[1]) < 1e-12:
            pc = p
        if pc is not None and p >= (1 + e) * pc * (1 - 1e-14):
            return np.array([Pt, p]), v


def _rod_at_impact(theta, v_centre, omega, mu=0.4, e=0.5, law="poisson"):
    """The falling rod with end A touching the floor, about to hit."""
    definition = models.build("falling-rod", mu=mu, restitution=e, law=law)
    eom = kd.kane(**definition.kane_args)
    model = eom.numeric(constants=definition.constants)
    z = 0.5 * math.sin(-theta)  # A at height zero (L = 1)
    return model, np.array([-0.5 * math.cos(theta), z, theta, *v_centre, omega])


@pytest.mark.parametrize("theta, v_centre, omega, after", [
    (-0.6, (1.0, -2.0), 0.0, "slides on"),    # |W_tn / W_tt| = 0.71 > mu
    (-1.2, (0.1, -2.0), 0.0, "sticks"),       # |W_tn / W_tt| = 0.28 < mu: the slip stops
    (-0.6, (-0.3, -2.0), 0.0, "reverses"),    # the slip stops and reverses
    (-0.3, (-0.5, -1.0), -2.0, "reverses"),
])
def test_impact_with_friction_matches_routh(theta, v_centre, omega, after):
    mu, e, m, L = 0.4, 0.5, 1.0, 1.0
    model, y = _rod_at_impact(theta, v_centre, omega, mu, e)
    res = kd.simulate(model, (0.0, 1e-3), y)
    impact = res.impacts[0]
    assert impact.t == 0.0 and impact.contacts == ("floor-A",)
    # contact space of end A by hand: v_A = v_G + omega x r
    r = 0.5 * L * np.array([math.cos(theta), math.sin(theta)])  # G -> A in (x, z)
    k_cross_r = np.array([-r[1], r[0]])  # d v_A / d omega (omega about -y: z cross)
    I = m * L ** 2 / 12
    W = np.eye(2) / m + np.outer(k_cross_r, k_cross_r) / I
    v_A = np.array(v_centre) + omega * k_cross_r
    P, v_after = _routh(W, v_A, mu, e)
    outcome = {1: "slides on", 0: "sticks", -1: "reverses"}[
        int(np.sign(np.round(v_after[0] * v_A[0], 12)))]
    assert outcome == after
    assert np.allclose(impact.impulses[0][[0, 2]], P, rtol=1e-9, atol=1e-12)
    assert impact.energy_loss >= 0
    assert impact.energy_loss == pytest.approx(-0.5 * P @ (v_A + v_after), rel=1e-9)


def test_random_impacts_never_gain_energy():
    rng = np.random.default_rng(3)
    for law in ("poisson", "newton"):
        for _ in range(25):
            mu, e = rng.uniform(0, 1.2), rng.uniform(0, 1)
            theta, omega = rng.uniform(-1.5, -0.05), rng.uniform(-5, 5)
            v_z = -rng.uniform(0.1, 3) - max(0.0, 0.5 * math.cos(theta) * omega)
            model, y = _rod_at_impact(theta, (rng.uniform(-2, 2), v_z), omega, mu, e, law)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                res = kd.simulate(model, (0.0, 1e-4), y)
            impact = res.impacts[0]
            assert impact.energy_loss >= -1e-12
            assert impact.kinetic_energy_jump <= 1e-12
            if law == "newton" and not caught:
                assert impact.separation_speeds[0] == pytest.approx(
                    e * impact.approach_speeds[0], rel=1e-9, abs=1e-12)


def test_newton_restitution_that_would_gain_energy_falls_back_with_a_warning():
    """Newton's law with friction and slip reversal can create energy (Kane's paradox)."""
    model, y = _rod_at_impact(-0.7254, (-1.838, -2.223), 0.0, mu=0.8855, e=0.9655,
                              law="newton")
    with pytest.warns(RuntimeWarning, match=r"floor-A.*would gain .* J.*Poisson"):
        res = kd.simulate(model, (0.0, 1e-4), y)
    assert res.impacts[0].energy_loss > 0
    assert res.impacts[0].kinetic_energy_jump < 0


def _ball_in_corner(e=0.6, mu=0.0):
    x, z = me.dynamicsymbols("x z")
    ux, uz = me.dynamicsymbols("u_x u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x + z * N.z)
    C.set_vel(N, ux * N.x + uz * N.z)
    ball = me.Particle("ball", C, 2.0)
    contacts = [kd.Contact(C.locatenew("B", -0.1 * N.z), kd.Plane(N, O, N.z), mu_k=mu,
                           restitution=e, name="floor"),
                kd.Contact(C.locatenew("L", -0.1 * N.x), kd.Plane(N, O, N.x), mu_k=mu,
                           restitution=e, name="wall")]
    eom = kd.kane(frame=N, q_ind=[x, z], u_ind=[ux, uz],
                  kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[ball], contacts=contacts)
    return eom.numeric()


def test_simultaneous_impacts_in_a_corner():
    model = _ball_in_corner(e=0.6)
    res = kd.simulate(model, (0.0, 0.01), [0.1, 0.1, -1.0, -2.0])
    impact = res.impacts[0]
    assert set(impact.contacts) == {"floor", "wall"}
    assert np.allclose(res.y[2:, -1], [0.6, 1.2], rtol=1e-10)
    assert impact.energy_loss == pytest.approx(0.5 * 2.0 * (1 - 0.36) * 5.0, rel=1e-10)


@pytest.mark.parametrize("vx, expected", [(0.3, 0.0), (3.0, 3.0 - 0.4 * 1.5 * 2.0)])
def test_rod_landing_flat_on_both_ends(vx, expected):
    """Both ends hit at once: no rotation; the slip stops or is slowed by mu (1+e) |v_z|."""
    model, _ = _rod_at_impact(0.0, (0.0, 0.0), 0.0, mu=0.4, e=0.5)
    y = np.array([0.0, 0.0, 0.0, vx, -2.0, 0.0])
    res = kd.simulate(model, (0.0, 1e-3), y)
    impact = res.impacts[0]
    assert len(impact.contacts) == 2
    assert res["u_x"][-1] == pytest.approx(expected, abs=1e-9)
    assert abs(res["omega"][-1]) < 1e-9
    assert impact.energy_loss > 0


def test_surface_on_a_moving_body_gets_the_reaction():
    """A block sliding on a free cart: momentum is conserved, the slip stops on time."""
    m, M, mu, g, v0 = 1.0, 3.0, 0.25, 9.81, 2.0
    xc, xb, zb = me.dynamicsymbols("x_c x_b z_b")
    uc, ub, wb = me.dynamicsymbols("u_c u_b w_b")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    cart = O.locatenew("C", xc * N.x)
    cart.set_vel(N, uc * N.x)
    block = O.locatenew("B", xb * N.x + zb * N.z)
    block.set_vel(N, ub * N.x + wb * N.z)
    top = kd.Contact(block, kd.Plane(N, cart, N.z, name="deck"), mu_k=mu, name="deck")
    eom = kd.kane(frame=N, q_ind=[xc, xb, zb], u_ind=[uc, ub, wb],
                  kd_eqs=[xc.diff() - uc, xb.diff() - ub, zb.diff() - wb],
                  bodies=[me.Particle("cart", cart, M), me.Particle("block", block, m)],
                  loads=[(block, -m * g * N.z)], contacts=[top])
    res = kd.simulate(eom.numeric(), (0.0, 1.5), [0, 0, 0, 0, v0, 0], **TIGHT)
    momentum = M * res["u_c"] + m * res["u_b"]
    assert np.max(np.abs(momentum - m * v0)) < 1e-9
    stop = [c for c in res.mode_history if c.new == "stick"]
    assert stop[0].t == pytest.approx(v0 / (mu * g * (1 + m / M)), rel=1e-9)
    assert res["u_c"][-1] == pytest.approx(m * v0 / (m + M), rel=1e-9)
    assert res["u_b"][-1] == pytest.approx(m * v0 / (m + M), rel=1e-9)


def test_viscous_friction():
    m, c, v0 = 2.0, 0.7, 1.5
    x, z = me.dynamicsymbols("x z")
    ux, uz = me.dynamicsymbols("u_x u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + z * N.z)
    P.set_vel(N, ux * N.x + uz * N.z)
    floor = kd.Contact(P, kd.Plane(N, O, N.z), viscous=c, name="floor")
    eom = kd.kane(frame=N, q_ind=[x, z], u_ind=[ux, uz],
                  kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[me.Particle("p", P, m)],
                  loads=[(P, -m * 9.81 * N.z)], contacts=[floor])
    t = np.linspace(0, 3, 31)
    res = kd.simulate(eom.numeric(), (0.0, 3.0), [0, 0, v0, 0], t_eval=t, **TIGHT)
    assert np.allclose(res["u_x"], v0 * np.exp(-c * t / m), rtol=1e-8)
    assert np.allclose(res.contact_forces["floor"]["friction"][:, 0], -c * res["u_x"],
                       rtol=1e-9)


def test_bilateral_contact_pulls_and_friction_uses_the_magnitude():
    """A particle held on the outside of a sphere: N = -m v^2/R, v = v0/(1 + mu v0 t/R)."""
    q = me.dynamicsymbols("x y z")
    u = me.dynamicsymbols("u_x u_y u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    P.set_vel(N, u[0] * N.x + u[1] * N.y + u[2] * N.z)
    bead = kd.Contact(P, kd.Sphere(N, O, 1.0, inside=False), mu_k=0.2, kind="bilateral",
                      name="shell")
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=[a.diff() - b for a, b in zip(q, u)],
                  bodies=[me.Particle("p", P, 1.0)], contacts=[bead])
    t = np.linspace(0, 3, 31)
    res = kd.simulate(eom.numeric(), (0.0, 3.0), [1, 0, 0, 0, 2, 0], t_eval=t, **TIGHT)
    exact = 2.0 / (1 + 0.2 * 2.0 * t)
    assert np.allclose(np.linalg.norm(res.y[3:], axis=0), exact, rtol=1e-8)
    assert np.allclose(res.contact_forces["shell"]["normal"], -exact ** 2, rtol=1e-8)
    assert res.mode_history == []  # slides from the start to the end: no change
    assert set(res.contact_forces["shell"]["mode"]) == {"slip"}


# ----------------------------------------------- the plain Kane form, compared
def test_given_normal_load_form_matches_contact_form_on_a_flat_floor():
    """Friction as a load with a given normal force (mg) equals the contact form here."""
    mu, m, g, v0 = 0.3, 2.0, 9.81, 1.5
    x, ux = me.dynamicsymbols("x u_x")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, ux * N.x)
    plain = kd.kane(frame=N, q_ind=[x], u_ind=[ux], kd_eqs=[x.diff() - ux],
                    bodies=[me.Particle("block", P, m)],
                    loads=[(P, -mu * m * g * sm.sign(ux) * N.x)]).numeric()
    t_stop = v0 / (mu * g)

    def stopped(t, y):
        return y[-1]
    stopped.terminal, stopped.direction = True, -1
    a = kd.simulate(plain, (0.0, 2.0), [0.0, v0], events=stopped, **TIGHT)
    assert a.t[-1] == pytest.approx(t_stop, rel=1e-9)

    x2, z2 = me.dynamicsymbols("x z")
    u2 = me.dynamicsymbols("u_x u_z")
    Q = O.locatenew("Q", x2 * N.x + z2 * N.z)
    Q.set_vel(N, u2[0] * N.x + u2[1] * N.z)
    contact = kd.Contact(Q, kd.Plane(N, O, N.z), mu_k=mu, name="floor")
    full = kd.kane(frame=N, q_ind=[x2, z2], u_ind=list(u2),
                   kd_eqs=[x2.diff() - u2[0], z2.diff() - u2[1]],
                   bodies=[me.Particle("block", Q, m)], loads=[(Q, -m * g * N.z)],
                   contacts=[contact]).numeric()
    b = kd.simulate(full, (0.0, 2.0), [0.0, 0.0, v0, 0.0], t_eval=a.t[:-1], **TIGHT)
    assert np.allclose(b["x"], a["x"][:-1], atol=1e-9)
    assert b.mode_history[-1].new == "stick"
    assert b.mode_history[-1].t == pytest.approx(t_stop, rel=1e-9)
    assert np.allclose(b.contact_forces["floor"]["normal"], m * g, rtol=1e-9)


# ------------------------------------------------------------------ bad input
def _particle_on(surface_for, initial, kind="unilateral"):
    q = me.dynamicsymbols("x y z")
    u = me.dynamicsymbols("u_x u_y u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    P.set_vel(N, u[0] * N.x + u[1] * N.y + u[2] * N.z)
    contact = kd.Contact(P, surface_for(N, O), kind=kind, name="c1")
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=[a.diff() - b for a, b in zip(q, u)],
                  bodies=[me.Particle("p", P, 1.0)], contacts=[contact])
    return eom.numeric(), list(initial) + [0.0, 0.0, 0.0]


def test_point_off_its_surface_says_how_far():
    model, y0 = _particle_on(lambda N, O: kd.Sphere(N, O, 1.0), [1.25, 0, 0],
                             kind="bilateral")
    with pytest.raises(kd.ModelError, match=r"c1.*not on its surface.*0\.25 m"):
        kd.simulate(model, (0, 1), y0)
    model, y0 = _particle_on(lambda N, O: kd.Plane(N, O, N.z), [0, 0, -0.5])
    with pytest.raises(kd.ModelError, match=r"c1.*0\.5 m inside"):
        kd.simulate(model, (0, 1), y0)


def test_vanishing_normal_is_an_error():
    x, y, z = kd.SURFACE_COORDINATES
    model, y0 = _particle_on(lambda N, O: kd.ImplicitSurface(N, O, z ** 3), [0, 0, 0])
    with pytest.raises(kd.ModelError, match=r"c1.*normal vanishes"):
        kd.simulate(model, (0, 1), y0)


def test_bad_coefficients_are_errors():
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    plane = kd.Plane(N, O, N.z)
    with pytest.raises(kd.ModelError, match="mu_k must be >= 0"):
        kd.Contact(O, plane, mu_k=-0.1)
    with pytest.raises(kd.ModelError, match=r"restitution must be in \[0.0, 1.0\]"):
        kd.Contact(O, plane, restitution=1.5)
    definition = models.build("bouncing-ball")
    eom = kd.kane(**definition.kane_args)
    values = dict(definition.constants)
    e = definition.symbols["e"]
    values[e] = -0.2
    with pytest.raises(kd.ModelError, match=r"floor.*restitution.*\[0, 1\].*-0\.2"):
        eom.numeric(constants=values)
    values[e] = 0.5
    values[sm.Symbol("mu", positive=True)] = -0.3
    with pytest.raises(kd.ModelError, match=r"floor.*must not be negative"):
        eom.numeric(constants=values)
