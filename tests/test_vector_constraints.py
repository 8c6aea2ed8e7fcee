"""Built-in models with vector constraints: identified forces against closed forms.

Every joint of these models is a vector constraint, so the multipliers are
constraint-force magnitudes along known directions.  Each test compares the
identified directions with hand-derived vectors, the magnitudes with closed
forms or hand balances (derived in the models' docstrings, not from
kanedyn's equations), and checks Newton's and Euler's laws body by body.
"""

import re

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.cli import main

TIGHT = dict(rtol=1e-10, atol=1e-10)
MODELS = ("rod-bead", "pin-slot", "knife-edge", "rolling-disk-contact", "block-wedge")


@pytest.fixture(scope="module")
def built():
    """``{name: (definition, eom, numeric model)}``, derived once."""
    out = {}
    for name in MODELS:
        definition = kd.models.build(name)
        eom = definition.derive()
        out[name] = (definition, eom, definition.numeric(eom))
    return out


def _same_vector(a, b, frame):
    return all(sm.simplify(c) == 0 for c in (a - b).to_matrix(frame))


def _directions(eom, name):
    """``[(point name, unit vector, body name or None)]`` of an identified force."""
    return [(loc.name, vec, None if body is None else body.name)
            for kind, loc, vec, body in eom.identified_forces[name] if kind == "force"]


def _newton_euler_ok(res, tol=1e-10):
    """Residuals with Kane's multipliers and with fitted ones; returns the maxima."""
    maxima = []
    for multipliers in (None, "fit"):
        check = kd.check_newton_euler(res, multipliers=multipliers)
        assert check.source == ("equations" if multipliers is None else "fit")
        assert check.max <= tol * max(1.0, check.inertia_scale), check.table()
        maxima.append(check.max)
    return maxima


def _udot(model, res, name):
    """Acceleration of speed ``name`` along a simulation, from the equations."""
    k = model.index(name)
    return np.array([model.rhs(t, y)[k] for t, y in zip(res.t, res.y.T)])


@pytest.mark.parametrize("name", MODELS)
def test_registered_and_consistent(built, name):
    definition, eom, model = built[name]
    assert definition.name == name and name in kd.models.REGISTRY
    assert model.identified_names
    assert set(model.identified_names) <= set(eom.identified_forces)
    y0 = model.state(definition.initial(model))
    assert np.max(np.abs(model.constraint_residuals(0.0, y0))) < 1e-12
    assert set(model.constraint_forces(0.0, y0)) == set(model.identified_names)


# ------------------------------------------------------------------ rod-bead
def test_rod_bead_closed_form(built):
    definition, eom, model = built["rod-bead"]
    s = definition.symbols
    N, A = s["N"], s["A"]
    assert [(p, b) for p, _, b in _directions(eom, "N_h")] == [("P", None)]
    assert _same_vector(_directions(eom, "N_h")[0][1], A.y, N)
    assert _same_vector(_directions(eom, "N_v")[0][1], A.z, N)

    m, omega, g = 0.7, 2.5, 9.81
    model = definition.numeric(eom, constants={"m": m, "omega": omega, "g": g})
    r0, v0 = 0.2, -0.3
    t = np.linspace(0, 1.2, 61)
    res = kd.simulate(model, (0, 1.2), model.state({"r": r0, "u1": v0}), t_eval=t,
                      constraint_forces=True, **TIGHT)
    r_exact = r0 * np.cosh(omega * t) + v0 / omega * np.sinh(omega * t)
    rdot_exact = r0 * omega * np.sinh(omega * t) + v0 * np.cosh(omega * t)
    np.testing.assert_allclose(res["r"], r_exact, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res["N_h"], 2 * m * omega * rdot_exact, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res["N_v"], m * g, rtol=0, atol=1e-10)
    _newton_euler_ok(res)


def test_rod_bead_unidentified_vertical_force_shows(built):
    """The vertical guide as a plain velocity constraint: its force is missing."""
    definition, _, _ = built["rod-bead"]
    s = definition.symbols
    args = dict(definition.kane_args)
    args.update(velocity_constraints=[s["u"][2]],
                constraints=[kd.PointVelocity(s["P"], s["A"].y,
                                              relative_to=(s["A"], s["O"]), names="N_h")])
    eom = kd.kane(**args)
    model = definition.numeric(eom)
    res = kd.simulate(model, (0, 0.5), model.state(definition.initial(model)), **TIGHT)
    check = kd.check_newton_euler(res)
    assert check.source == "equations"
    # the rod's vertical force m g is unexplained
    assert check.max_force == pytest.approx(0.5 * 9.81, rel=1e-12)
    assert kd.check_newton_euler(res, multipliers="fit").max_force == pytest.approx(
        0.5 * 9.81, rel=1e-12)


# ------------------------------------------------------------------ pin-slot
def test_pin_slot_identified_directions(built):
    definition, eom, _ = built["pin-slot"]
    s = definition.symbols
    N, A = s["N"], s["A"]
    slot = _directions(eom, "N_slot")
    assert [(p, b) for p, _, b in slot] == [("P", "crank"), ("P", "lever")]
    assert _same_vector(slot[0][1], A.y, N)       # perpendicular to the slot
    assert _same_vector(slot[1][1], -A.y, N)      # and its reaction on the lever
    for name, point, body, axis in (("R_Ax", "A_o", "lever", N.x),
                                    ("R_Ay", "A_o", "lever", N.y),
                                    ("R_Bx", "B_o", "crank", N.x),
                                    ("R_By", "B_o", "crank", N.y)):
        (p, vec, b), = _directions(eom, name)
        assert (p, b) == (point, body) and _same_vector(vec, axis, N)


def test_pin_slot_reactions_and_newton_euler(built):
    definition, eom, model = built["pin-slot"]
    c = {str(k): v for k, v in definition.constants.items()}
    t = np.linspace(0, 1.0, 101)
    res = kd.simulate(model, (0, 1.0), model.state(definition.initial(model)), t_eval=t,
                      constraint_forces=True, **TIGHT)
    assert res.success and np.max(res.constraint_residual) < 1e-8
    assert np.ptp(res["theta_B"]) > 2 * np.pi  # the crank turns round
    m_A, m_B, g = c["m_A"], c["m_B"], c["g"]
    ax_A, ay_A = _udot(model, res, "u_xA"), _udot(model, res, "u_yA")
    ax_B, ay_B = _udot(model, res, "u_xB"), _udot(model, res, "u_yB")
    # the slot forces are internal: the pivots carry the weights and m a_G
    np.testing.assert_allclose(res["R_Ay"] + res["R_By"],
                               (m_A + m_B) * g + m_A * ay_A + m_B * ay_B, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res["R_Ax"] + res["R_Bx"], m_A * ax_A + m_B * ax_B,
                               rtol=0, atol=1e-9)
    # the crank about its pivot O_B: (I_B + m_B e^2/4) theta_B'' = tau - c w_B
    # + N_slot ((P - O_B) x A.y).z - m_B g (e/2) cos theta_B
    e, thB, thA, wB = c["e"], res["theta_B"], res["theta_A"], res["w_B"]
    lever_arm = e * np.cos(thB - thA)     # (e B.x) x A.y, along N.z
    moment = (c["tau"] - c["c"] * wB + res["N_slot"] * lever_arm
              - m_B * g * e / 2 * np.cos(thB))
    np.testing.assert_allclose((c["I_B"] + m_B * e ** 2 / 4) * _udot(model, res, "w_B"),
                               moment, rtol=0, atol=1e-9)
    _newton_euler_ok(res)


def test_pin_slot_slot_as_plain_velocity_constraint_leaves_residuals(built):
    definition, _, _ = built["pin-slot"]
    s = definition.symbols
    N, A, P, G_A = s["N"], s["A"], s["P"], s["G_A"]
    v_bar = G_A.vel(N) + A.ang_vel_in(N).cross(P.pos_from(G_A))
    args = dict(definition.kane_args)
    args.update(velocity_constraints=[(P.vel(N) - v_bar).dot(A.y)],
                constraints=[c for c in args["constraints"] if c.names != ("N_slot",)])
    eom = kd.kane(**args)
    assert "N_slot" not in eom.identified_forces
    model = definition.numeric(eom)
    res = kd.simulate(model, (0, 0.3), model.state(definition.initial(model)),
                      t_eval=np.linspace(0, 0.3, 7), **TIGHT)
    for multipliers in (None, "fit"):
        per_body = kd.check_newton_euler(res, multipliers=multipliers).per_body()
        assert per_body["lever"][1] > 1e-2 and per_body["crank"][1] > 1e-3  # N m


# ---------------------------------------------------------------- knife-edge
def test_knife_edge_closed_form(built):
    definition, eom, _ = built["knife-edge"]
    s = definition.symbols
    (p, vec, body), = _directions(eom, "F_lat")
    assert p == "P" and body is None and _same_vector(vec, s["B"].y, s["N"])
    m, a, I_C, u0, w0 = 1.3, 0.25, 0.07, -0.8, 1.5
    model = definition.numeric(eom, constants={"m": m, "a": a, "I_C": I_C})
    t = np.linspace(0, 8, 81)
    res = kd.simulate(model, (0, 8), model.state({"x": 0, "y": 0, "theta": 0.3, "u": u0,
                                                  "w": w0}),
                      t_eval=t, constraint_forces=True, **TIGHT)
    J = I_C + m * a ** 2
    U = np.sqrt(u0 ** 2 + J / m * w0 ** 2)
    u_exact = U * np.tanh(a * m * U / J * t + np.arctanh(u0 / U))
    w_exact = np.sqrt(m / J * (U ** 2 - u_exact ** 2))  # w keeps the sign of w0 > 0
    np.testing.assert_allclose(res["u"], u_exact, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res["w"], w_exact, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res["v"], 0.0, atol=1e-12)
    np.testing.assert_allclose(res["F_lat"], m * u_exact * w_exact * I_C / J, rtol=0,
                               atol=1e-8)
    # and by hand from the accelerations: m a_G . B.y = m (a w' + u w)
    np.testing.assert_allclose(res["F_lat"], m * (a * _udot(model, res, "w")
                                                  + res["u"] * res["w"]), atol=1e-12)
    _newton_euler_ok(res)


# ------------------------------------------------------- rolling-disk-contact
def test_rolling_disk_contact_directions(built):
    definition, eom, _ = built["rolling-disk-contact"]
    N = definition.symbols["N"]
    for name, axis in (("F_x", N.x), ("F_y", N.y), ("F_n", N.z)):
        (p, vec, body), = _directions(eom, name)
        assert (p, body) == ("C", "disk") and _same_vector(vec, axis, N)


def test_rolling_disk_contact_upright(built):
    """Upright straight rolling: F_n = m g and no friction, along the motion."""
    definition, _, model = built["rolling-disk-contact"]
    m, g, r = (definition.constants[definition.symbols[k]] for k in ("m", "g", "r"))
    v = 2.4
    y0 = model.state({"q3": 0.4, "q4": 0.0, "q5": 0.0, "x": 0.0, "y": 0.0,
                      "u1": 0.0, "u2": -v / r, "u3": 0.0})
    assert np.hypot(y0[model.index("u_x")], y0[model.index("u_y")]) == pytest.approx(v)
    res = kd.simulate(model, (0, 1), y0, t_eval=np.linspace(0, 1, 11),
                      constraint_forces=True, **TIGHT)
    np.testing.assert_allclose(res["F_n"], m * g, rtol=1e-12)
    np.testing.assert_allclose(res["F_x"], 0.0, atol=1e-10)
    np.testing.assert_allclose(res["F_y"], 0.0, atol=1e-10)
    _newton_euler_ok(res)


def test_rolling_disk_contact_steady_turn(built):
    """Steady turn (hand-derived balance): F_n = m g, friction = m v_G^2 / R_G."""
    definition, _, model = built["rolling-disk-contact"]
    m, g, r = (definition.constants[definition.symbols[k]] for k in ("m", "g", "r"))
    theta, yaw_rate = 0.3, 2.0
    spin = ((r / 4) * yaw_rate ** 2 * np.sin(theta) * np.cos(theta)
            - g * np.sin(theta)) / (1.5 * r * yaw_rate * np.cos(theta))
    y0 = model.state({"q3": 0.0, "q4": theta, "q5": 0.0, "x": 0.0, "y": 0.0,
                      "u1": 0.0, "u2": spin, "u3": yaw_rate * np.cos(theta)})
    res = kd.simulate(model, (0, 1), y0, t_eval=np.linspace(0, 1, 11),
                      constraint_forces=True, **TIGHT)
    np.testing.assert_allclose(res["q4"], theta, atol=1e-8)
    np.testing.assert_allclose(res["F_n"], m * g, rtol=1e-9)
    speed = np.hypot(res["u_x"], res["u_y"])  # the centre moves on a circle
    np.testing.assert_allclose(np.hypot(res["F_x"], res["F_y"]), m * speed * yaw_rate,
                               rtol=1e-8)
    _newton_euler_ok(res)


def test_rolling_disk_contact_matches_minimal_model(built):
    """Same angles and rates as the minimal-coordinate ``rolling-disk``; its
    normal force (auxiliary speed) equals the identified F_n."""
    definition, _, model = built["rolling-disk-contact"]
    ref_def = kd.models.build("rolling-disk", normal_force=True)
    ref = ref_def.numeric()
    r = definition.constants[definition.symbols["r"]]
    start = {"q3": 0.2, "q4": 0.35, "q5": 0.1, "u1": 0.6, "u2": -5.0, "u3": 1.2}
    y0 = model.state(dict(start, x=0.0, y=0.0))
    # the contact point below the centre: C = G - r L.z
    y_ref = ref.state(dict(start, q1=-r * np.sin(0.35) * np.sin(0.2),
                           q2=r * np.sin(0.35) * np.cos(0.2)))
    t = np.linspace(0, 1, 21)
    a = kd.simulate(model, (0, 1), y0, t_eval=t, constraint_forces=True, **TIGHT)
    b = kd.simulate(ref, (0, 1), y_ref, t_eval=t, constraint_forces=True, **TIGHT)
    for name in start:
        np.testing.assert_allclose(a[name], b[name], rtol=0, atol=1e-7)
    np.testing.assert_allclose(a["F_n"], b["N_c"], rtol=1e-7)
    # the centre stays above the contact point: G = C + r L.z
    psi, phi = a["q3"], a["q4"]
    np.testing.assert_allclose(a["x"], b["q1"] + r * np.sin(phi) * np.sin(psi), atol=1e-7)
    np.testing.assert_allclose(a["y"], b["q2"] - r * np.sin(phi) * np.cos(psi), atol=1e-7)
    assert np.ptp(a.energy) < 1e-8
    _newton_euler_ok(a)


# --------------------------------------------------------------- block-wedge
def test_block_wedge_closed_form(built):
    definition, eom, model = built["block-wedge"]
    s = definition.symbols
    N = s["N"]
    (p, vec, body), = _directions(eom, "N_floor")
    assert (p, body) == ("W", "wedge") and _same_vector(vec, N.y, N)
    incline = _directions(eom, "N_incline")
    assert [(p, b) for p, _, b in incline] == [("P", "block"), ("P", "wedge")]
    assert _same_vector(incline[0][1], s["n_hat"], N)
    assert _same_vector(incline[1][1], -s["n_hat"], N)

    M, m, g, th = (definition.constants[s[k]] for k in ("M", "m", "g", "theta"))
    D = M + m * np.sin(th) ** 2
    normal = m * M * g * np.cos(th) / D
    A = m * g * np.sin(th) * np.cos(th) / D
    sdd = -(M + m) * g * np.sin(th) / D
    floor = M * (M + m) * g / D
    t = np.linspace(0, 0.8, 17)
    X0, s0, V0, w0 = 0.1, 2.0, 0.3, 0.5
    res = kd.simulate(model, (0, 0.8), model.state({"X": X0, "s": s0, "u_X": V0,
                                                    "u_s": w0}),
                      t_eval=t, constraint_forces=True, **TIGHT)
    np.testing.assert_allclose(res["N_incline"], normal, rtol=1e-12)
    np.testing.assert_allclose(res["N_floor"], floor, rtol=1e-12)
    np.testing.assert_allclose(_udot(model, res, "u_X"), A, rtol=1e-12)
    np.testing.assert_allclose(res["X"], X0 + V0 * t + A * t ** 2 / 2, atol=1e-9)
    np.testing.assert_allclose(res["s"], s0 + w0 * t + sdd * t ** 2 / 2, atol=1e-9)
    # vertically the floor carries the weights less m times the block's fall
    block_ay = normal * np.cos(th) / m - g
    assert floor == pytest.approx((M + m) * g + m * block_ay, rel=1e-14)
    assert np.ptp(res.energy) < 1e-9
    _newton_euler_ok(res)


# ------------------------------------------------------------------------ CLI
def test_cli_run_prints_identified_forces_and_residual(tmp_path, capsys):
    assert main(["run", "block-wedge", "--t-end", "0.2", "--points", "11",
                 "--out", str(tmp_path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "identified constraint forces at t = 0.2 s: N_floor = 36.2215, " \
           "N_incline = 7.84219" in out
    residual = float(re.search(r"max Newton-Euler residual: (\S+)", out).group(1))
    assert residual < 1e-10
    header = (tmp_path / "block-wedge.csv").read_text().splitlines()[0].split(",")
    assert {"N_floor", "N_incline"} <= set(header)


# ------------------------------------------------------------------ bad input
def _particle():
    x, z, ux, uz = me.dynamicsymbols("x z u_x u_z")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + z * N.z)
    P.set_vel(N, ux * N.x + uz * N.z)
    args = dict(frame=N, q_ind=[x, z], u_ind=[ux], u_dep=[uz],
                kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[me.Particle("p", P, 1)])
    return N, O, P, args


def test_point_velocity_bad_arguments_name_the_point():
    N, O, P, _ = _particle()
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(Q\): point must be a sympy "
                                            "Point"):
        kd.PointVelocity("Q", N.x)
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(P\): relative_to must be"):
        kd.PointVelocity(P, N.x, relative_to=N)
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(P\): relative_to must be"):
        kd.PointVelocity(P, N.x, relative_to=(O, N))
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(P\): 2 direction\(s\) but "
                                            r"1 name\(s\)"):
        kd.PointVelocity(P, [N.x, N.z], names=["F"])
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(P\): directions must be"):
        kd.PointVelocity(P, [1, 0, 0])
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(P\): body must be"):
        kd.PointVelocity(P, N.x, body=N)


def test_constraint_errors_at_derivation_name_the_constraint():
    N, O, P, args = _particle()
    with pytest.raises(kd.ModelError, match="constraint-force names must be unique; "
                                            "repeated: F"):
        kd.kane(**args, constraints=[kd.PointVelocity(P, N.z, names="F"),
                                     kd.PointVelocity(P, N.x, names="F")])
    with pytest.raises(kd.ModelError, match=r"1 dependent speeds.*2 velocity constraints"
                                            r".*<PointVelocity P: F_x, F_z> gives 2"):
        kd.kane(**args, constraints=[kd.PointVelocity(P, [N.x, N.z], names=["F_x", "F_z"])])
    A = me.ReferenceFrame("A")
    A.orient_axis(N, N.y, 0.3)
    elsewhere = me.Point("E")  # not located relative to P
    with pytest.raises(kd.ModelError, match=r"PointVelocity\(P\): the position of P "
                                            "relative to E is not defined"):
        kd.kane(**args, constraints=[kd.PointVelocity(P, A.z, relative_to=(A, elsewhere))])
