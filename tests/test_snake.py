"""The snake robot on passive wheels (``kanedyn.models.snake``).

Checked against things the equations of motion do not produce themselves:
Lagrange's equations with multipliers (a second formulation, in the
coordinates' rates), the Newton-Euler equations of every link (with the
joint forces, which the model's coordinates leave unidentified, fitted by
least squares), the wheel constraints and the energy evaluated with the
link geometry written out here in NumPy, and two closed-form motions.
"""

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main
from kanedyn.numerics import compiler_command

TOL = dict(rtol=1e-11, atol=1e-11)
#: The backend of the long runs at TOL (their subject is the motion, not the backend):
#: the compiled loop integrates the same equations with the same RK45.  The default
#: gait's 10 s took 11.5 s of CPU with the NumPy backend and 0.14 s compiled, the two
#: runs' states differing by 3.9e-14 at most; NumPy where there is no compiler.
BACKEND = "c" if compiler_command() is not None else "numpy"
L = 0.5  # the model's default link length, m


# --------------------------------------------------------------- geometry
def geometry(q, l=L):
    """Mass centres G (n, 2), joints J (n-1, 2), link axes e and lateral axes p
    (n, 2) of the configuration ``q = [x, y, theta_1..theta_n]``."""
    th = np.asarray(q[2:])
    e = np.column_stack([np.cos(th), np.sin(th)])
    p = np.column_stack([-np.sin(th), np.cos(th)])
    G = [np.asarray(q[:2], dtype=float)]
    J = []
    for i in range(len(th) - 1):
        J.append(G[i] + l / 2 * e[i])
        G.append(J[i] + l / 2 * e[i + 1])
    return np.array(G), np.array(J).reshape(-1, 2), e, p


def lateral_velocities(q, qdot, l=L):
    """Velocity of every G_i along its link's lateral axis, m/s, shape (n,)."""
    _, _, _, p = geometry(q, l)
    thd = np.asarray(qdot[2:])
    v = [np.asarray(qdot[:2], dtype=float)]
    for i in range(len(thd) - 1):
        v.append(v[i] + l / 2 * thd[i] * p[i] + l / 2 * thd[i + 1] * p[i + 1])
    return np.einsum("ij,ij->i", np.array(v), p)


def kinetic_energy(q, qdot, m=1.0, l=L):
    """Kinetic energy of the links from their mass-centre velocities and rates, J."""
    _, _, _, p = geometry(q, l)
    thd = np.asarray(qdot[2:])
    v = [np.asarray(qdot[:2], dtype=float)]
    for i in range(len(thd) - 1):
        v.append(v[i] + l / 2 * thd[i] * p[i] + l / 2 * thd[i + 1] * p[i + 1])
    v = np.array(v)
    return 0.5 * m * np.sum(v**2) + 0.5 * (m * l**2 / 12) * np.sum(thd**2)


def dependent_block(q, l=L):
    """Jacobian of the wheel constraints with respect to the dependent speeds
    ``u_l, w_2..w_n`` (rows: links), written out from the geometry."""
    th = np.asarray(q[2:])
    n = th.size
    B = np.zeros((n, n))
    for i in range(n):
        B[i, 0] = np.cos(th[0] - th[i])          # u_l along L_1.y
        for j in range(1, i):
            B[i, j] = l * np.cos(th[j] - th[i])  # a whole link j between
        if i:
            B[i, i] = l / 2
    return B


def q_and_qdot(model, t, y):
    n = model.n_q
    return y[:n], model.rhs(t, y)[:n]


def max_lateral_velocity(res):
    model, worst = res.model, 0.0
    for k in range(res.t.size):
        q, qd = q_and_qdot(model, res.t[k], res.y[:, k])
        worst = max(worst, float(np.max(np.abs(lateral_velocities(q, qd)))))
    return worst


def pin_force_fit(check, q, l=L):
    """Fit the joint forces to the Newton-Euler residuals of every link.

    ``q`` holds the coordinates, shape (n + 2, N); ``check`` holds, per
    link, m a_G - (applied + wheel forces) and the moment residual about G.
    What is left must be the forces the neighbours exert at the joints: P_i
    on link i at J_i and -P_i on link i+1.  Returns the
    largest residual component after the fit (3 n equations, 2 (n-1)
    unknowns per instant) and the fitted forces, N, shape (N, n-1, 2).
    """
    n = len(check.bodies)
    worst, forces = 0.0, []
    for k in range(check.t.size):
        G, J, _, _ = geometry(q[:, k], l)
        C = np.zeros((6 * n, 2 * (n - 1)))
        for i in range(n - 1):
            for a in range(2):
                unit = np.zeros(2)
                unit[a] = 1.0
                col = 2 * i + a
                for body, sign in ((i, 1.0), (i + 1, -1.0)):
                    r = J[i] - G[body]
                    C[6 * body + a, col] += sign
                    C[6 * body + 5, col] += sign * (r[0] * unit[1] - r[1] * unit[0])
        b = np.concatenate([check.force_residual[k], check.moment_residual[k]], axis=1)
        b = b.ravel()
        sol = np.linalg.lstsq(C, b, rcond=None)[0]
        worst = max(worst, float(np.max(np.abs(b - C @ sol))))
        forces.append(sol.reshape(n - 1, 2))
    return worst, np.array(forces)


def lagrange_start(kane_model, lag_model, y):
    """Lagrange state [q, q'] of the motion at Kane state ``y``."""
    n = kane_model.n_q
    qd = kane_model.rhs(0.0, y)[:n]
    out = np.zeros(lag_model.n_states)
    for name, q, rate in zip(kane_model.state_names[:n], y[:n], qd):
        out[lag_model.index(name)] = q
        out[lag_model.index(name + "_d")] = rate
    return lag_model.state(out)


# ------------------------------------------------------------------- tests
@pytest.mark.parametrize("n", [3, 5])
def test_kane_and_lagrange_give_the_same_motion(n):
    """Same coordinates, rates and wheel forces after 1 s of the driven gait."""
    d = kd.models.build("snake", n=n)
    km, lm = d.numeric(d.derive()), d.numeric(d.derive(method="lagrange"))
    yk = km.state(d.initial(km, {"u_f": 0.3, "w_1": 0.4}))
    yl = lagrange_start(km, lm, yk)
    rk = kd.simulate(km, (0, 1), yk, **TOL)
    rl = kd.simulate(lm, (0, 1), yl, **TOL)
    assert rk.success and rl.success
    q_names = km.state_names[:km.n_q]
    qk = np.array([rk[s][-1] for s in q_names])
    ql = np.array([rl[s][-1] for s in q_names])
    assert np.max(np.abs(qk - yk[:km.n_q])) > 0.05  # it did move
    np.testing.assert_allclose(ql, qk, rtol=0, atol=1e-8)
    qdk = km.rhs(1.0, rk.y[:, -1])[:km.n_q]
    qdl = np.array([rl[s + "_d"][-1] for s in q_names])
    np.testing.assert_allclose(qdl, qdk, rtol=0, atol=1e-8)
    fk, fl = km.multipliers(1.0, rk.y[:, -1]), lm.multipliers(1.0, rl.y[:, -1])
    for i in range(1, n + 1):
        assert abs(fk[f"F_{i}"] - fl[f"F_{i}"]) < 1e-7 * (1 + abs(fk[f"F_{i}"]))
    # the Lagrange run keeps the wheel constraints too (own kinematics)
    worst = max(np.max(np.abs(lateral_velocities(rl.y[:lm.n_q, k],
                                                 [rl[s + "_d"][k] for s in q_names])))
                for k in range(rl.t.size))
    assert worst < 1e-9


def test_augmented_lagrangean_derives_and_keeps_the_wheel_constraints():
    """The vakonomic model runs and rolls without side slip, but (as it should
    for nonholonomic constraints) is a different motion from Kane's."""
    d = kd.models.build("snake", n=3)
    km, am = d.numeric(d.derive()), d.numeric(d.derive(method="augmented"))
    yk = km.state(d.initial(km, {"u_f": 0.3, "w_1": 0.4}))
    qd = km.rhs(0.0, yk)[:km.n_q]
    ya = np.zeros(am.n_states)
    q_names = km.state_names[:km.n_q]
    for name, q, rate in zip(q_names, yk[:km.n_q], qd):
        ya[am.index(name)], ya[am.index(name + "_d")] = q, rate
    ra = kd.simulate(am, (0, 1), ya, **TOL)
    rk = kd.simulate(km, (0, 1), yk, **TOL)
    assert ra.success
    worst = max(np.max(np.abs(lateral_velocities(ra.y[:am.n_q, k],
                                                 [ra[s + "_d"][k] for s in q_names])))
                for k in range(ra.t.size))
    assert worst < 1e-8
    deviation = max(abs(ra[s][-1] - rk[s][-1]) for s in q_names)
    assert deviation > 1e-4


def test_newton_euler_with_fitted_joint_forces():
    """Every link obeys Newton-Euler with the wheel forces of the equations
    and joint forces found by least squares; wrong accelerations do not."""
    d = kd.models.build("snake", n=5)
    model = d.numeric(d.derive(), backend=BACKEND)
    y0 = model.state(d.initial(model, {"u_f": 0.2}))
    res = kd.simulate(model, (0, 3), y0, t_eval=np.linspace(0, 3, 31),
                      constraint_forces=True, **TOL)
    assert res.success
    check = kd.check_newton_euler(res)
    assert check.source == "equations"
    # the joint forces are not identified by the model: they are the residual
    assert check.max > 0.1
    worst, pins = pin_force_fit(check, res.y[:model.n_q])
    assert worst <= 1e-9 * check.inertia_scale
    assert np.max(np.abs(pins)) > 0.1
    # control: accelerations off by 1e-3 leave a residual the joints cannot explain
    rng = np.random.default_rng(5)
    k = 17
    y = res.y[:, k]
    udot = model.rhs(res.t[k], y)[model.n_q:] + 1e-3 * rng.standard_normal(model.n_u)
    bad = kd.check_newton_euler(model, res.t[k], y, udot=udot)
    bad_worst, _ = pin_force_fit(bad, y[:model.n_q, None])
    assert bad_worst > 1e-5


def test_energy_conserved_without_drive_and_damping():
    """A = c = 0: kinetic + joint-spring energy stays constant; no side slip."""
    d = kd.models.build("snake", n=5)
    model = d.numeric(d.derive(), constants={"A": 0.0, "c": 0.0}, backend=BACKEND)
    y0 = model.state(d.initial(model, {"u_f": 0.3, "w_1": 0.5}))
    res = kd.simulate(model, (0, 5), y0, t_eval=np.linspace(0, 5, 101), **TOL)
    assert res.success
    E = res.energy
    assert E is not None and E[0] > 0.05
    assert np.ptp(E) < 1e-8 * E[0]
    # the model's energy against the one computed here from the geometry
    k = d.constants[d.symbols["k"]]
    for j in (0, 50, 100):
        q, qd = q_and_qdot(model, res.t[j], res.y[:, j])
        V = 0.5 * k * np.sum(np.diff(q[2:]) ** 2)
        assert abs(kinetic_energy(q, qd) + V - E[j]) < 1e-12
    assert max_lateral_velocity(res) < 1e-9
    # the joints do move: energy passes between the springs and the links
    assert np.ptp(res.kinetic_energy) > 0.01


def test_default_gait_crawls_forward():
    """From rest the serpenoid torques drive the snake forward along +x with
    joint angles well below 90 degrees, pushing on its wheels sideways."""
    d = kd.models.build("snake")
    model = d.numeric(d.derive(), backend=BACKEND)
    y0 = model.state(d.initial(model))
    res = kd.simulate(model, (0, d.t_end), y0, t_eval=np.linspace(0, d.t_end, 201),
                      constraint_forces=True, **TOL)
    assert res.success
    n = 5
    x, y = res["x"], res["y"]
    assert x[-1] > 3.0                 # 4.19 m in 10 s
    assert abs(y[-1]) < 0.2 * x[-1]    # roughly straight on
    theta = np.array([res[f"theta_{i}"] for i in range(1, n + 1)])
    assert np.max(np.abs(np.diff(theta, axis=0))) < 0.5  # 0.38 rad at most
    forces = np.array([res[f"F_{i}"] for i in range(1, n + 1)])
    assert np.max(np.abs(forces)) > 0.5
    assert max_lateral_velocity(res) < 1e-9
    # the dependent speeds are solvable everywhere on the way: the block is
    # triangular with determinant (l/2)^(n-1) and stays well conditioned
    conds = []
    for k in range(res.t.size):
        B = dependent_block(res.y[:n + 2, k])
        assert abs(np.linalg.det(B) - (L / 2) ** (n - 1)) < 1e-12
        conds.append(np.linalg.cond(B))
    assert max(conds) < 60
    # without the drive the same snake barely moves (its springs only unbend it)
    still = model.with_constants({"A": 0.0})
    rest = kd.simulate(still, (0, d.t_end), y0, **TOL)
    assert abs(rest["x"][-1]) < 0.1 * x[-1]


def test_straight_snake_rolls_on_uniformly():
    """Closed form: aligned links, no drive: constant velocity, no wheel force."""
    d = kd.models.build("snake", n=4)
    model = d.numeric(d.derive(), constants={"A": 0.0})
    heading, speed = 0.3, 0.4
    values = {f"theta_{i}": heading for i in range(1, 5)}
    values.update(u_f=speed, w_1=0.0)
    y0 = model.state(d.initial(model, values))
    res = kd.simulate(model, (0, 3), y0, t_eval=np.linspace(0, 3, 7),
                      constraint_forces=True, **TOL)
    np.testing.assert_allclose(res["x"], speed * np.cos(heading) * res.t, atol=1e-12)
    np.testing.assert_allclose(res["y"], speed * np.sin(heading) * res.t, atol=1e-12)
    for i in range(1, 5):
        np.testing.assert_allclose(res[f"theta_{i}"], heading, atol=1e-12)
        np.testing.assert_allclose(res[f"F_{i}"], 0.0, atol=1e-12)


def test_bent_snake_turns_rigidly_on_a_circle():
    """Closed form: equal joint angles phi, no drive or springs: rigid rotation
    at Omega about the centre of the circle of radius l / (2 tan(phi/2)) that
    touches every link at its mass centre; wheel forces m R Omega^2 inwards."""
    n, phi, Omega, theta0 = 5, 0.3, 0.8, -0.4
    d = kd.models.build("snake", n=n)
    model = d.numeric(d.derive(), constants={"A": 0.0, "k": 0.0})
    R = L / (2 * np.tan(phi / 2))
    values = {f"theta_{i}": theta0 + (i - 1) * phi for i in range(1, n + 1)}
    values.update(x=0.1, y=-0.2, u_f=Omega * R, w_1=Omega)
    y0 = model.state(d.initial(model, values))
    # the completed dependent speeds are those of the rigid rotation
    assert abs(y0[model.index("u_l")]) < 1e-14
    for i in range(2, n + 1):
        assert abs(y0[model.index(f"w_{i}")] - Omega) < 1e-13
    t = np.linspace(0, 4, 9)
    res = kd.simulate(model, (0, 4), y0, t_eval=t, constraint_forces=True, **TOL)
    centre = np.array([0.1, -0.2]) + R * np.array([-np.sin(theta0), np.cos(theta0)])
    th1 = theta0 + Omega * t
    np.testing.assert_allclose(res["x"], centre[0] + R * np.sin(th1), atol=1e-9)
    np.testing.assert_allclose(res["y"], centre[1] - R * np.cos(th1), atol=1e-9)
    for i in range(1, n + 1):
        np.testing.assert_allclose(res[f"theta_{i}"], th1 + (i - 1) * phi, atol=1e-9)
        np.testing.assert_allclose(res[f"F_{i}"], 1.0 * R * Omega**2, rtol=1e-9)
    # every mass centre stays on the circle
    for k in range(t.size):
        G, _, _, _ = geometry(res.y[:n + 2, k])
        np.testing.assert_allclose(np.linalg.norm(G - centre, axis=1), R, rtol=1e-9)


@pytest.mark.parametrize("bad", [1, 0, -3, 2.5, "3", True])
def test_bad_number_of_links(bad):
    with pytest.raises(kd.ModelError, match=r"\bn\b"):
        kd.models.build("snake", n=bad)
    with pytest.raises(ValueError):
        kd.models.snake(n=bad)


def test_registry_and_symbols():
    d = kd.models.build("snake", n=2)
    assert "snake" in kd.models.REGISTRY and "snake" in kd.models.__all__
    assert len(d.symbols["q"]) == 4 and len(d.symbols["u"]) == 4
    assert [str(b) for b in d.symbols["bodies"]] == ["link_1", "link_2"]
    assert len(d.kane_args["u_dep"]) == 2 and len(d.kane_args["constraints"]) == 2


def test_cli_run(tmp_path, capsys):
    out = tmp_path / "snake"
    assert main(["run", "snake", "--t-end", "1", "--set", "n=3", "--set", "A=0.5",
                 "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "success: True" in text and "F_3 =" in text
    assert (out / "snake.csv").exists()
