"""Every script in examples/ runs, saves its plot, and prints numbers that are right.

Each example is loaded with ``runpy`` (its ``if __name__ == "__main__"``
block does not run) and its ``main(argv)`` is called in a temporary
directory with ``--plot``; the dictionary it returns is checked against
references computed here, independently of the example: closed forms
derived by hand, a minimal-coordinate model integrated with SciPy, SymPy's
``KanesMethod``, an energy quadrature.  ``test_every_example_is_tested``
fails when a file in ``examples/`` has no test below.
"""

import re
import runpy
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import quad, solve_ivp

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def run_example(name, argv, tmp_path, monkeypatch):
    """``(main(argv + ["--plot", FILE]), module namespace)`` of ``examples/<name>.py``."""
    monkeypatch.chdir(tmp_path)
    namespace = runpy.run_path(str(EXAMPLES / f"{name}.py"), run_name=f"example_{name}")
    plot = tmp_path / f"{name}.png"
    out = namespace["main"](list(argv) + ["--plot", str(plot)])
    assert plot.stat().st_size > 10_000, f"{name}: no plot saved"
    return out, namespace


def test_every_example_is_tested():
    files = {path.stem for path in EXAMPLES.glob("*.py")}
    tested = set(re.findall(r'run_example\(\s*"(\w+)"', Path(__file__).read_text()))
    assert files, "no examples found"
    assert files <= tested, f"examples without a test: {sorted(files - tested)}"
    assert tested <= files, f"tests of missing examples: {sorted(tested - files)}"


def test_every_example_has_a_docstring_and_main():
    for path in EXAMPLES.glob("*.py"):
        text = path.read_text()
        assert text.startswith('"""'), f"{path.name}: no module docstring"
        assert f"python examples/{path.name}" in text, f"{path.name}: no 'how to run'"
        assert "def main(argv=None):" in text, f"{path.name}: no main(argv=None)"


# ----------------------------------------------------------- double pendulum
def test_double_pendulum(tmp_path, monkeypatch):
    """Small oscillations of two uniform rods (mass m, length l) hanging from
    a pivot, absolute angles: T = 1/2 q'^T M q', V = 1/2 q^T K q with

        M = m l^2 [[1/3 + 1, 1/2], [1/2, 1/4 + 1/12]],   K = m g l [[3/2, 0], [0, 1/2]]

    (rod A about the pivot; rod B: its centre moves at l q1' + l/2 q2', plus
    its own rotation), so omega^2 are the eigenvalues of K v = omega^2 M v:
    (3 -+ 6/sqrt(7)) g/l."""
    out, ns = run_example("double_pendulum", ["--t-end", "3"], tmp_path, monkeypatch)
    m, l, g = (ns["CONSTANTS"][k] for k in ("m", "l", "g"))
    M = m * l ** 2 * np.array([[4 / 3, 1 / 2], [1 / 2, 1 / 3]])
    K = m * g * l * np.array([[3 / 2, 0.0], [0.0, 1 / 2]])
    omega = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))
    np.testing.assert_allclose(out["omega"], omega, rtol=1e-10)
    np.testing.assert_allclose(omega ** 2, np.array([3 - 6 / 7 ** 0.5, 3 + 6 / 7 ** 0.5])
                               * g / l, rtol=1e-12)
    assert out["success"]
    assert out["energy_drift"] < 1e-8


# ---------------------------------------------------------------- four-bar
def four_bar_minimal(constants):
    """The four-bar in its crank angle alone, by Lagrange's equation.

    Position analysis in closed form (the coupler's far end is where the
    circles about the crank tip and the rocker pivot meet, on the branch of
    the examples' start), kinetic energy T = J(q) q'^2 / 2 and potential
    V(q) from it, so J q'' + J'(q) q'^2 / 2 + V'(q) = 0.  Returns
    ``rhs(t, y)`` for ``y = [q1, q1']``.
    """
    c = constants
    la, lb, lc, ld = c["l_a"], c["l_b"], c["l_c"], c["l_d"]
    q = sm.Symbol("q")
    tip = sm.Matrix([la * sm.cos(q), la * sm.sin(q)])
    to_pivot = sm.Matrix([ld, 0]) - tip
    d = sm.sqrt(to_pivot.dot(to_pivot))
    along = (lb ** 2 - lc ** 2 + d ** 2) / (2 * d)
    across = sm.sqrt(lb ** 2 - along ** 2)
    end = tip + along * to_pivot / d + across * sm.Matrix([-to_pivot[1], to_pivot[0]]) / d
    q2 = sm.atan2(end[1] - tip[1], end[0] - tip[0])
    q3 = sm.atan2(end[1], end[0] - ld)
    coupler_centre = (tip + end) / 2
    v = coupler_centre.diff(q)
    J = (c["m_a"] * la ** 2 / 3 + c["m_b"] * v.dot(v) + c["m_b"] * lb ** 2 / 12
         * q2.diff(q) ** 2 + c["m_c"] * lc ** 2 / 3 * q3.diff(q) ** 2)
    V = c["g"] * (c["m_a"] * la / 2 * sm.sin(q) + c["m_b"] * coupler_centre[1]
                  + c["m_c"] * lc / 2 * sm.sin(q3))
    terms = sm.lambdify(q, [J, J.diff(q), V.diff(q)], cse=True)

    def rhs(t, y):
        J, dJ, dV = terms(y[0])
        return [y[1], -(0.5 * dJ * y[1] ** 2 + dV) / J]
    return rhs


def test_closed_loop_residual_energy_and_built_in(tmp_path, monkeypatch):
    out, _ = run_example("closed_loop", [], tmp_path, monkeypatch)
    assert out["success"]
    assert out["projection_tol"] == 1e-6
    assert out["projections"] >= 1                 # the residual reached the tolerance
    assert 0.5 * out["projection_tol"] < out["max_constraint_residual"]
    assert out["max_constraint_residual"] < 1.5 * out["projection_tol"]
    assert out["energy_drift"] < 1e-5
    assert out["crank_vs_built_in"] < 1e-9


@pytest.mark.slow
def test_closed_loop_against_minimal_coordinates(tmp_path, monkeypatch):
    """Over 3 s (more than a crank revolution) at rtol = atol = 1e-10 the crank
    angle agrees to 6e-8 rad and its rate to 5e-7 rad/s."""
    out, ns = run_example("closed_loop", ["--tol", "1e-10", "--t-end", "3"], tmp_path,
                          monkeypatch)
    start = ns["START"]
    sol = solve_ivp(four_bar_minimal(ns["CONSTANTS"]), (0.0, 3.0), [start["q1"], start["u1"]],
                    method="DOP853", rtol=1e-13, atol=1e-13, t_eval=out["t"])
    assert np.ptp(sol.y[0]) > 2 * np.pi
    assert np.max(np.abs(np.array(out["q1"]) - sol.y[0])) < 1e-6
    assert np.max(np.abs(np.array(out["u1"]) - sol.y[1])) < 5e-6


# ------------------------------------------------------------- rolling disk
def test_rolling_disk(tmp_path, monkeypatch):
    """The lean of a disk rolling upright at spin Omega obeys
    (I + m r^2) theta'' + [(J/I)(J + m r^2) Omega^2 - m g r] theta = 0 (I about a
    diameter, J about the axle); for a thin disk, I = m r^2/4 and J = m r^2/2:
    theta'' = -(12 Omega^2 - 4 g/r)/5 theta, so the lean eigenvalues are
    lambda^2 = (4 g/r - 12 Omega^2)/5, stable iff Omega^2 > g/(3r)."""
    out, ns = run_example("rolling_disk", ["--t-end", "2"], tmp_path, monkeypatch)
    r, g = ns["CONSTANTS"]["r"], ns["CONSTANTS"]["g"]
    for case, spin in out["spin"].items():
        expected = np.sqrt(complex((4 * g / r - 12 * spin ** 2) / 5))
        pair = sorted(out["lean_eigenvalues"][case], key=lambda z: (z.imag, z.real))
        np.testing.assert_allclose(pair, sorted([-expected, expected],
                                                key=lambda z: (z.imag, z.real)),
                                   rtol=1e-9, atol=1e-9)
    assert out["spin"]["below"] ** 2 < g / (3 * r) < out["spin"]["above"] ** 2
    assert out["largest_real_part"]["below"] > 1.0
    assert abs(out["largest_real_part"]["above"]) < 1e-9
    assert out["fell_below"] and out["success"]
    assert out["max_lean_above"] < 0.15


# ------------------------------------------------------ friction and impacts
def test_friction_and_impacts(tmp_path, monkeypatch):
    """A particle thrown horizontally at v0 from height h onto a floor with
    restitution e and friction mu: approach speeds V_k = e^(k-1) sqrt(2 g h),
    flights of 2 e V_k / g, each impact takes mu (1 + e) V_k off the
    horizontal speed; the bounces end after a finite time, then the block
    slides at mu g to rest."""
    out, ns = run_example("friction_and_impacts", [], tmp_path, monkeypatch)
    c, s = ns["CONSTANTS"], ns["START"]
    m, g, mu, e = c["m"], c["g"], c["mu"], c["e"]
    h, v0 = s["z"], s["u_x"]
    V1 = np.sqrt(2 * g * h)
    k = np.arange(6)
    approach = V1 * e ** k
    times = np.sqrt(2 * h / g) + np.concatenate([[0.0], np.cumsum(2 * e * approach[:-1] / g)])
    np.testing.assert_allclose(out["approach_speeds"][:6], approach, rtol=1e-8)
    np.testing.assert_allclose(out["impact_times"][:6], times, rtol=1e-9)
    np.testing.assert_allclose(out["friction_impulses"][:6], -mu * m * (1 + e) * approach,
                               rtol=1e-8)
    lost = mu * (1 + e) * V1 / (1 - e)                  # speed taken off by all bounces
    sliding = v0 - lost
    bounce_end = np.sqrt(2 * h / g) + 2 * e * V1 / (g * (1 - e))
    x_bounces = v0 * np.sqrt(2 * h / g) + 2 * V1 / g * (sliding * e / (1 - e)
                                                         + lost * e ** 2 / (1 - e ** 2))
    assert out["stop_time"] == pytest.approx(bounce_end + sliding / (mu * g), abs=1e-5)
    assert out["final_x"] == pytest.approx(x_bounces + sliding ** 2 / (2 * mu * g), abs=1e-5)
    assert out["energy_lost"] == pytest.approx(m * g * h + m * v0 ** 2 / 2, rel=1e-10)
    assert -out["friction_work"] == pytest.approx(m * sliding ** 2 / 2, rel=1e-5)
    assert out["impact_loss"] - out["friction_work"] == pytest.approx(out["energy_lost"],
                                                                      abs=1e-9)
    assert out["energy_balance"] < 1e-9
    assert [(old, new) for _, old, new in out["modes"]] == [("separated", "slip"),
                                                            ("slip", "stick")]
    assert out["success"]


# --------------------------------------------------------- constraint forces
def test_constraint_forces(tmp_path, monkeypatch):
    """Energy integral: theta'^2 = theta0'^2 + 2 g/L (cos theta - cos theta0), so
    T = m g (3 cos theta - 2 cos theta0) + m L theta0'^2 along the motion."""
    out, ns = run_example("constraint_forces", [], tmp_path, monkeypatch)
    m, L, g = (ns["CONSTANTS"][k] for k in ("m", "L", "g"))
    theta0, rate0 = ns["THETA0"], ns["RATE0"]
    theta = np.array(out["theta"])
    expected = m * g * (3 * np.cos(theta) - 2 * np.cos(theta0)) + m * L * rate0 ** 2
    assert np.ptp(theta) > 3.0                          # a large swing
    np.testing.assert_allclose(out["tension"], expected, atol=1e-7)
    assert out["error_auxiliary"] < 1e-10 and out["error_vector"] < 1e-10
    assert out["difference"] < 1e-6
    assert out["newton_euler_residual"] < 1e-10


# ------------------------------------------------------------ formulations
def sympy_accelerations(keywords, constants, y):
    """u' of the slider-crank from SymPy's KanesMethod at the state ``y``."""
    kane = me.KanesMethod(keywords["frame"], q_ind=keywords["q_ind"],
                          u_ind=keywords["u_ind"], kd_eqs=keywords["kd_eqs"],
                          q_dependent=keywords["q_dep"],
                          configuration_constraints=keywords["configuration_constraints"],
                          u_dependent=keywords["u_dep"],
                          velocity_constraints=keywords["velocity_constraints"])
    kane.kanes_equations(keywords["bodies"], keywords["loads"])
    states = list(keywords["q_ind"]) + list(keywords["q_dep"]) + list(keywords["u_ind"]) \
        + list(keywords["u_dep"])
    values = dict(zip(states, y))
    values.update(constants)
    M = np.array(me.msubs(kane.mass_matrix_full, values), dtype=float)
    f = np.array(me.msubs(kane.forcing_full, values), dtype=float).ravel()
    return np.linalg.solve(M, f)[len(keywords["kd_eqs"]):]


@pytest.mark.slow
def test_formulations_compared(tmp_path, monkeypatch):
    out, ns = run_example("formulations_compared", ["--t-end", "1"], tmp_path, monkeypatch)
    keywords, symbols = ns["slider_crank"]()
    constants = {symbols[k]: v for k, v in ns["CONSTANTS"].items()}
    reference = sympy_accelerations(keywords, constants, out["state"])
    assert set(out["accelerations"]) == set(ns["METHODS"])
    for method, accelerations in out["accelerations"].items():
        tolerance = 1e-6 if method == "penalty" else 1e-10   # penalty: exact as 1/factor -> 0
        np.testing.assert_allclose(accelerations, reference, rtol=tolerance,
                                   atol=tolerance * np.max(np.abs(reference)),
                                   err_msg=method)
    assert 1e-10 < out["acceleration_deviation"]["penalty"] < 1e-6
    runs = out["runs"]
    assert all(row["success"] for row in runs.values())
    for method in ("lagrange", "partitioning", "orthogonal-complement"):
        assert runs[method]["crank_deviation"] < 1e-9     # projected like Kane: same motion
    for row in runs.values():
        assert row["crank_deviation"] < 1e-4 and row["energy_error"] < 1e-4
    assert out["operations"]["kane"] < out["operations"]["lagrange"]


# ------------------------------------------------------- singular positions
def branch_singular_times(n, count, L=1.0, m=1.0, g=9.81, rate0=-1.0):
    """Times the A02 cranks are horizontal, from the energy integral of the
    parallelogram branch: n + 1 cranks about their pivots, n couplers
    translating, I = m L^2 ((n+1)/3 + n), V = m g L ((n+1)/2 + n) sin theta."""
    k = (m * g * L * ((n + 1) / 2 + n)) / (m * L ** 2 * ((n + 1) / 3 + n))

    def dt(theta):
        return 1.0 / np.sqrt(rate0 ** 2 + 2 * k * (1 - np.sin(theta)))
    down = quad(dt, 0.0, np.pi / 2, epsabs=1e-13, epsrel=1e-13)[0]       # top -> right
    through = 2 * quad(dt, -np.pi / 2, 0.0, epsabs=1e-13, epsrel=1e-13)[0]  # right -> left
    return np.array([down, down + through])[:count]


@pytest.mark.slow
def test_singular_positions(tmp_path, monkeypatch):
    n, t_end = 2, 1.5
    out, _ = run_example("singular_positions", ["--n", str(n), "--t-end", str(t_end)],
                         tmp_path, monkeypatch)
    times = branch_singular_times(n, 2)
    np.testing.assert_allclose(out["singular_times"], times, atol=1e-9)
    np.testing.assert_allclose(out["kane_warned_at"][:2], times, atol=1e-6)
    np.testing.assert_allclose(out["index3_warned_at"][:2], times, atol=1e-5)
    assert "passed near a singular configuration" in out["kane_message"]
    # Kane's elimination leaves the branch at the left horizontal (or stops there)
    assert out["kane_t_end"] < t_end or out["kane_branch_error"] > 0.1
    assert out["index3_success"]
    assert out["index3_branch_error"] < 1e-4
    assert out["index3_crank_spread"] < 1e-10


# -------------------------------------------------------------- shuttle arm
@pytest.mark.slow
def test_shuttle_arm(tmp_path, monkeypatch):
    """The natural orthogonal complement integrated with BDF against Kane's
    equations integrated with DOP853 (explicit) and with BDF."""
    out, _ = run_example("shuttle_arm", ["--t-end", "5"], tmp_path, monkeypatch)
    assert out["success"]
    assert out["noc_vs_kane_dop853_angles"] < 1e-8
    assert out["noc_vs_kane_dop853_rates"] < 1e-7
    assert out["noc_vs_kane_bdf"] < 1e-8
    assert out["tracking_error_max"] < 0.01


# ---------------------------------------------------------- flexible bodies
@pytest.mark.slow
def test_campbell_rotor(tmp_path, monkeypatch):
    """On the rigid hub: collective at w, whirl at w +- Omega with
    w^2 = k/(m l^2) + Omega^2 e/l (closed form); on springs the collective, which the
    hub does not feel, is the same, and at rest the coupled pairs are degenerate."""
    out, _ = run_example("campbell_rotor", [], tmp_path, monkeypatch)
    speeds, split, coupled = out["speeds"], out["split"], out["coupled"]
    w = np.sqrt(640.0 / 40.0 + 0.25 * speeds ** 2)
    rad = split.frequencies * 2 * np.pi
    np.testing.assert_allclose(rad[:, split.mode("zeta_1 collective")], w, rtol=1e-9)
    np.testing.assert_allclose(rad[:, split.mode("zeta_1 forward")], w + speeds, rtol=1e-7)
    np.testing.assert_allclose(rad[:, split.mode("zeta_1 backward")], w - speeds, rtol=1e-7)
    collective = coupled.frequencies[:, coupled.mode("zeta_1 collective")] * 2 * np.pi
    np.testing.assert_allclose(collective, w, rtol=1e-9)
    assert coupled.converged.all() and np.all(coupled.periodicity < 1e-12)


def test_spin_up_beam(tmp_path, monkeypatch):
    """Kane, Ryan & Banerjee (1987), REFERENCES.md: bounded and well under 1 m with
    geometric stiffening, nearly zero after the spin-up; tens of metres by 10 s
    without.  At constant speed the beam, nearly straight, holds the kinetic energy
    of a uniform rod turning about its end: rho A L^3 Omega_s^2 / 6 = 7200 J."""
    out, _ = run_example("spin_up_beam", [], tmp_path, monkeypatch)
    assert out["success"]
    t, tip = out["t"], out["tip_stiffened"]
    assert np.max(np.abs(tip)) < 1.0 and np.max(np.abs(tip[t > 15])) < 0.02
    assert abs(out["tip_conventional"][np.searchsorted(t, 10.0)]) > 10.0
    assert out["energy"][-1] == pytest.approx(1.2 * 10.0 ** 3 * 6.0 ** 2 / 6, rel=2e-3)
    work = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (
        (out["tau"] * out["hub_rate"])[1:] + (out["tau"] * out["hub_rate"])[:-1]))])
    change = out["energy"] - out["energy"][0]
    assert np.max(np.abs(change - work)) < 1e-5 * np.max(change)   # trapezoid's error
    assert out["energy_balance"] < 1e-6


@pytest.mark.slow
def test_flexible_robot(tmp_path, monkeypatch):
    """The torque pulse turns a rigid robot by 90 degrees and stops it; the flexible
    robot ends close to that, vibrating; the motor's work (a trapezoid quadrature
    here) equals the change of kinetic plus strain energy."""
    out, _ = run_example("flexible_robot", ["--modes", "3"], tmp_path, monkeypatch)
    assert out["success"]
    assert np.degrees(out["theta"][-1]) == pytest.approx(90.0, abs=2.0)
    assert abs(out["omega"][-1]) < 0.3            # rad/s: the residual vibration only
    assert 5e-3 < np.max(np.abs(out["tip"])) < 0.1
    t, power = out["t"], out["tau"] * out["omega"]
    work = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (power[1:] + power[:-1]))])
    change = out["energy"] - out["energy"][0]
    assert np.max(np.abs(change - work)) < 1e-4 * np.max(change)
    assert out["energy_balance"] < 1e-6


@pytest.mark.slow
def test_identify_flexible_robot(tmp_path, monkeypatch):
    """Study (a) of issue 35: the hub damping and the payload recovered from the
    noisy record (seed 0): the truth inside both 95 % intervals, which are
    narrow (under 1 % of the value); the noise levels estimated from the
    residuals are those added (within 10 %); the fitted model's hub angle and
    bending coordinate follow a noise-free run of the true robot closer than
    a fifth of the noise.  Two bending modes (``--modes 2``; the example's
    default is three): the same fit of the same two constants and the same
    checks (measured: intervals 0.59 % and 0.17 % of the value wide, noise
    levels within 4 %), in 40 % less CPU time for the fit, whose explicit
    steps the highest mode sets."""
    out, ns = run_example("identify_flexible_robot", ["--seed", "0", "--modes", "2"],
                          tmp_path, monkeypatch)
    assert out["success"] and out["level"] == 0.95
    for name, value in out["truth"].items():
        lo, hi = out["intervals"][name]
        assert lo <= value <= hi, (name, out["estimates"][name], lo, hi)
        assert hi - lo < 0.01 * value
    for name, sigma in out["true_sigma"].items():
        assert out["sigma"][name] == pytest.approx(sigma, rel=0.1)
    import kanedyn as kd
    definition = kd.models.build("flexible-robot", n_modes=2, hub_damping=0.03,
                                 pulse_payload=0.1)
    model = definition.numeric(backend="c").with_constants({"m_p": 0.15})
    truth = kd.simulate(model, (0.0, 3.0), definition.initial(model), t_eval=out["t"],
                        rtol=1e-11, atol=1e-12)
    for name, sigma in out["true_sigma"].items():
        assert np.max(np.abs(out["fitted"][name] - truth[name])) < 0.2 * sigma, name


# ------------------------------------------------------------- URDF robot
@pytest.mark.slow
def test_urdf_robot(tmp_path, monkeypatch):
    """The UR5 falling from rest: the joint angles after 1 s equal those of
    Pinocchio's articulated-body algorithm (same URDF file, its default gravity
    (0, 0, -9.81)) integrated by SciPy."""
    pin = pytest.importorskip("pinocchio", reason="the check integrates Pinocchio's ABA")
    pytest.importorskip("matplotlib")
    out, _ = run_example("urdf_robot", [], tmp_path, monkeypatch)
    assert out["success"]
    pmodel = pin.buildModelFromUrdf(out["urdf"])
    pdata = pmodel.createData()
    assert pmodel.nq == pmodel.nv == len(out["final"])

    def rhs(t, y):
        q, v = y[:pmodel.nq], y[pmodel.nq:]
        return np.concatenate([v, pin.aba(pmodel, pdata, q, v, np.zeros(pmodel.nv))])

    sol = solve_ivp(rhs, (0.0, out["t_end"]), np.zeros(2 * pmodel.nq), method="DOP853",
                    rtol=1e-11, atol=1e-11)
    expected = {pmodel.names[pmodel.getJointId(name)]: sol.y[pmodel.joints[
        pmodel.getJointId(name)].idx_q, -1] for name in out["final"]}
    for name, angle in out["final"].items():
        assert angle == pytest.approx(expected[name], abs=1e-6), name


# ------------------------------------------------------------- MJCF model
def test_mjcf_model(tmp_path, monkeypatch):
    """dm_control's acrobot falling from upright for 3 s: its joint angles equal
    those of MuJoCo's own dynamics (``mj_forward``'s ``qacc``, contacts off, the
    same file) integrated by SciPy."""
    mujoco = pytest.importorskip("mujoco", reason="the check integrates MuJoCo's dynamics")
    pytest.importorskip("dm_control", reason="the example reads dm_control's acrobot")
    pytest.importorskip("matplotlib")
    out, _ = run_example("mjcf_model", [], tmp_path, monkeypatch)
    assert out["success"]
    mj = mujoco.MjModel.from_xml_path(out["mjcf"])
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data = mujoco.MjData(mj)

    def rhs(t, y):
        data.qpos[:], data.qvel[:] = y[:mj.nq], y[mj.nq:]
        mujoco.mj_forward(mj, data)
        return np.concatenate([data.qvel, data.qacc])

    y0 = np.concatenate([out["qpos"][0], np.zeros(mj.nv)])
    assert out["qpos"][0] == pytest.approx([0.05, 0.0])
    sol = solve_ivp(rhs, (0.0, out["times"][-1]), y0, method="DOP853", rtol=1e-12,
                    atol=1e-12, t_eval=out["times"])
    assert np.max(np.abs(sol.y[:mj.nq].T - out["qpos"])) < 1e-7
    assert out["mujoco_difference"] < 1e-7


# --------------------------------------------------------------- animation
def test_animate_pendulum(tmp_path, monkeypatch):
    """The page holds the scene; the tip's trace at every frame is the closed form
    (l sin q, -l cos q) of a rod of length l = 0.8 m turned by q from the downward
    vertical, and the declared shapes replace the default one."""
    import json
    out, _ = run_example("animate_pendulum", ["--out", "swing.html"], tmp_path, monkeypatch)
    html = out["page"].read_text()
    start = html.index('type="application/json">') + len('type="application/json">')
    scene = json.loads(html[start:html.index("</script>", start)])
    (rod,) = scene["bodies"]
    assert [s["kind"] for s in rod["shapes"]] == ["cylinder", "sphere"]
    q = out["result"]["q"]
    trace = np.array(scene["traces"][0]["points"]).reshape(-1, 3)
    np.testing.assert_allclose(trace[:, :2], 0.8 * np.column_stack([np.sin(q), -np.cos(q)]),
                               atol=2e-6)
    assert out["q_end"] == pytest.approx(q[-1])


# ------------------------------------------------------------ bicycle stability
def test_bicycle_stability(tmp_path, monkeypatch):
    """Against Meijaard, Papadopoulos, Ruina and Schwab (2007): the weave and
    capsize speeds and the four eigenvalues at 5 m/s (the values in
    ../shared/REFERENCES.md); the steady motion found from a leaning guess is
    upright."""
    out, _ = run_example("bicycle_stability", [], tmp_path, monkeypatch)
    assert abs(out["weave"] - 4.29238253634111) < 1e-8
    assert abs(out["capsize"] - 6.02426201538837) < 1e-8
    published = np.array([-14.07838969279820, -0.77534188219585 - 4.46486771378823j,
                          -0.77534188219585 + 4.46486771378823j, -0.32286642900409])
    assert np.max(np.abs(out["at_5"] - published)) < 1e-9
    first = out["first"]
    assert first.converged and first.stable
    assert np.max(np.abs(first.y[[3, 5]])) < 1e-12  # lean q4 and steer q7
    assert out["eigenvalues"].shape == (101, 4)


@pytest.mark.slow
@pytest.mark.slow
def test_flexible_robot_rest_to_rest(tmp_path, monkeypatch):
    """Against references computed here: the rigid arm's inertia about the
    hub from the model's documented numbers (hub 0.05 kg m^2, link 0.675 kg/m
    by 1 m at radius 0.05 m, payload 0.1 kg at the tip) gives the pulse's
    effort tau_0^2 T / 2 (tau_0 = 2 pi theta J0 / T^2, the simulated pulse's
    torque integrated) and the rigid arm's least effort 12 J0^2 theta^2 /
    T^3, which the elastic optimum must approach from above (0.4 % here);
    the Radau run of the optimal torque ends at 90 deg and leaves over 100x
    less tip vibration than the pulse's, and its torque integrates to the
    objective."""
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")
    out, ns = run_example("flexible_robot_rest_to_rest", [], tmp_path, monkeypatch)
    assert out["success"]
    J0 = 0.05 + 0.675 * (1 / 3 + 0.05 + 0.05 ** 2) + 0.1 * 1.05 ** 2
    theta, T = np.pi / 2, 1.0
    tau_0 = 2 * np.pi * theta * J0 / T ** 2
    assert abs(out["pulse_effort"] - tau_0 ** 2 * T / 2) < 1e-6 * tau_0 ** 2
    rigid = 12 * J0 ** 2 * theta ** 2 / T ** 3
    assert 1.0 < out["objective"] / rigid < 1.01
    assert abs(out["final_angle"] - theta) < 2e-4
    assert out["residual"] < out["pulse_residual"] / 100
    assert out["pulse_residual"] > 1e-3
    during = out["t"] <= T
    effort = np.trapezoid(out["torque"][during] ** 2, out["t"][during])
    assert abs(effort - out["objective"]) < 1e-4 * out["objective"]


@pytest.mark.slow
def test_shuttle_arm_flexible_booms(tmp_path, monkeypatch):
    """Checked by hand (21 nodes): the torques start and end at zero and stay
    within the documented limits (the quintic's peaks, 265.7 ... 26.58 N m);
    in microgravity, rest to rest, their net work along the collocated path
    is zero (Simpson over the nodes and midpoints, to 5e-3 of the work done
    both ways: measured 1.9e-3, the coarse mesh against the end ramps);
    simulated on the
    flexible booms they leave under a tenth of the end-effector deflection
    the rigid optimum's torques leave, for more effort than the rigid
    optimum's, and bring the joints to the documented end pose (-20, 35,
    -50, 5, 10, 30 deg) to 1e-2 rad."""
    from scipy.integrate import simpson
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")
    out, _ = run_example("shuttle_arm_flexible_booms", ["--nodes", "21"], tmp_path,
                         monkeypatch)
    study = out["study"]
    assert out["success"], study.result.message
    t, y, tau = study.result.points()
    assert np.max(np.abs(tau[:, [0, -1]])) < 1e-6
    limits = np.array([265.7, 61.22, 32.12, 9.786, 58.88, 26.58])
    assert np.all(np.abs(tau) <= limits[:, None] * (1 + 1e-3))
    power = np.sum(tau * y[6:12], axis=0)
    assert abs(simpson(power, x=t)) < 5e-3 * simpson(np.abs(power), x=t)
    d = study.data
    assert d["ramped_deflection_end"] < d["rigid_torques_deflection_end"] / 10
    assert study.result.objective > study.rigid.result.objective
    # the torques simulated on the flexible booms bring the joints to the
    # documented end pose (the coarse mesh's error: measured 3.2e-3 rad)
    end = np.radians([-20.0, 35.0, -50.0, 5.0, 10.0, 30.0])
    assert np.max(np.abs(study.replay.sol(150.0)[:6] - end)) < 1e-2


@pytest.mark.slow
def test_shuttle_arm_minimum_energy(tmp_path, monkeypatch):
    """Checked by hand: the end angles are the documented pose (-20, 35, -50,
    5, 10, 30 deg), every joint stays within the documented start-to-end
    range +- 10 deg and every torque within its limit at every node and
    midpoint, the effort is below the quintic's; in microgravity, rest to
    rest, the torques' net work (Simpson over the collocated points of
    sum tau_i u_i) is zero, the kinetic energy being zero at both ends (to
    1e-4 of the work done both ways); the PD-tracked replay stays closer to
    the path than the open-loop one."""
    from scipy.integrate import simpson
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")
    out, _ = run_example("shuttle_arm_minimum_energy", ["--nodes", "51"], tmp_path,
                         monkeypatch)
    r = out["result"]
    assert out["success"], r.message
    start = np.radians([0.0, 15.0, -30.0, 15.0, 0.0, 0.0])
    end = np.radians([-20.0, 35.0, -50.0, 5.0, 10.0, 30.0])
    t, y, tau = r.points()
    np.testing.assert_allclose(y[:6, -1], end, atol=1e-9)
    margin = np.radians(10.0)
    assert np.all(y[:6] >= np.minimum(start, end)[:, None] - margin - 1e-6)
    assert np.all(y[:6] <= np.maximum(start, end)[:, None] + margin + 1e-6)
    assert np.all(np.abs(tau) <= out["limit"][:, None] * (1 + 1e-6))
    assert r.objective < 0.65 * out["effort_quintic"]
    power = np.sum(tau * y[6:12], axis=0)
    assert abs(simpson(power, x=t)) < 1e-4 * simpson(np.abs(power), x=t)
    assert out["drift_tracked"] < out["drift_open_loop"] / 5 and out["drift_open_loop"] < 1e-3


@pytest.mark.slow
def test_out_parallel_least_peak_force(tmp_path, monkeypatch):
    """Checked by hand: from rest to rest the carriage forces' net work
    (Simpson of sum F_j ds_j over the collocated points) is the rise of the
    potential energy, computed here from the documented masses (platform
    20 kg, struts 2 kg at mid-length, carriages 5 kg, g = 9.81) and the
    closed-form inverse kinematics of the two poses (the drive trains'
    kinetic energy is zero at both ends), to 1e-5; the peak is the holding force,
    below the quintic's, and the inverse dynamics of the optimal path gives
    the collocated forces back to 1 N."""
    from scipy.integrate import simpson
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")
    out, _ = run_example("out_parallel_least_peak_force", ["--nodes", "21"], tmp_path,
                         monkeypatch)
    r = out["result"]
    assert out["success"], r.message
    t, y, F = r.points()
    names = list(r.state_names)
    ds = y[[names.index(f"ds{j}") for j in range(1, 7)]]
    work = simpson(np.sum(F * ds, axis=0), x=t)
    from kanedyn.models import out_parallel_anchors, out_parallel_ik
    _, _, c = out_parallel_anchors()

    def potential(pose):
        q, _, _ = out_parallel_ik(pose)
        a, b, gamma = pose[3:]
        Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
        Rz = np.array([[np.cos(gamma), -np.sin(gamma), 0], [np.sin(gamma), np.cos(gamma), 0],
                       [0, 0, 1]])
        anchors = pose[2] + (Rx @ Ry @ Rz @ c.T)[2]
        s = q[6:12]
        return 9.81 * (20.0 * pose[2] + 5.0 * np.sum(s) + 2.0 * np.sum((s + anchors) / 2))
    rise = potential(out["quintic"].pose[-1]) - potential(out["quintic"].pose[0])
    assert abs(work - rise) < 1e-5 * rise, (work, rise)  # measured 1.1e-6
    assert abs(out["peak"] - out["held"]) < 1e-5 * out["held"]
    assert out["peak"] < 0.95 * np.max(np.abs(out["quintic"].forces))
    assert np.max(np.abs(F)) <= out["peak"] * (1 + 1e-6)
    assert out["difference"] < 1.0


def test_pendulum_swing_up(tmp_path, monkeypatch):
    """The optimum meets its own conditions, checked here by hand: the end
    states, the torque limit, the objective as the trapezoid of tau^2, and the
    optimal torque (linear between the nodes, as the trapezoid assumes) driving
    the pendulum written here (m l^2 q'' = tau - m g l sin q, m = l = 1 kg, m,
    g = 9.81) through SciPy: the same motion while it swings (first 5 s)."""
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (the test extra)")
    out, _ = run_example("pendulum_swing_up", ["--nodes", "201"], tmp_path, monkeypatch)
    t, q, u, tau = out["t"], out["q"], out["u"], out["tau"]
    assert out["success"]
    np.testing.assert_allclose([q[0], u[0], q[-1], u[-1]], [0.0, 0.0, np.pi, 0.0],
                               atol=1e-6)
    assert np.max(np.abs(tau)) <= 2.0 + 1e-6 and np.max(np.abs(tau)) > 1.99  # at its limit
    assert abs(out["objective"] - np.trapezoid(tau ** 2, t)) < 1e-6 * out["objective"]

    def pendulum(time, x):
        return [x[1], np.interp(time, t, tau) - 9.81 * np.sin(x[0])]
    early = t <= 5.0
    run = solve_ivp(pendulum, (0.0, 5.0), [0.0, 0.0], t_eval=t[early], rtol=1e-10,
                    atol=1e-12, max_step=t[1] - t[0])
    # the trapezoid's error, O(h^2) at h = 0.05 s: under 1 % of each state's range
    assert np.max(np.abs(run.y[0] - q[early])) < 1e-2 * np.ptp(q[early])
    assert np.max(np.abs(run.y[1] - u[early])) < 1e-2 * np.ptp(u[early])


# ------------------------------------------------------------- oc3 controller
def test_oc3_controller(tmp_path, monkeypatch):
    """Turbulent 18 m/s (10 %): over the second half the baseline controller holds the
    rotor at the published rated 12.1 rpm and the electrical power at 5 MW (within 2 %,
    integral action on the speed; constant torque makes power follow speed), the mean
    pitch near the steady pitch of the mean wind, the spar leaning downwind."""
    out, _ = run_example("oc3_controller", [], tmp_path, monkeypatch)
    assert out["success"]
    assert out["mean_rotor_rpm"] == pytest.approx(12.1, rel=0.02)
    assert out["mean_power"] == pytest.approx(5.0e6, rel=0.02)
    from kanedyn.models import oc3_operating_point
    steady = oc3_operating_point(out["mean_wind"])
    assert out["mean_pitch_deg"] == pytest.approx(np.degrees(steady.pitch), abs=1.0)
    assert out["mean_platform_pitch_deg"] > 1.0
    assert out["rotor_rpm"].min() > 8.0 and out["rotor_rpm"].max() < 17.0


# ----------------------------------------------------------- seat-belt sensor
def test_seatbelt_sensor(tmp_path, monkeypatch):
    """The 20 g pulse tilts the pendulum past the lock angle and onto the wall; the
    energy balance closes to 1e-8 of the energy exchanged, the wall's damper taking
    energy out and the housing's prescribed motion putting it in."""
    out, _ = run_example("seatbelt_sensor", [], tmp_path, monkeypatch)
    assert out["success"] and out["lock_time"] is not None and 0.005 < out["lock_time"] < 0.03
    assert 29.0 < np.max(out["tilt"]) < 32.0  # the wall at 30 deg, a stiff penalty
    balance = out["balance"]
    assert balance.relative_residual < 1e-8
    wall = [w for name, w in balance.terms.items() if "k_lim" in name]
    assert wall and wall[0][-1] < 0
    assert balance.terms["prescribed motion (the forces that drive it)"][-1] > 0


# ----------------------------------------------------- parallel inverse dynamics
def test_parallel_inverse_dynamics(tmp_path, monkeypatch):
    """The 3-RRR's motor torques: zero at rest at both ends (a horizontal robot, no
    gravity), and their power equal to the rate of the kinetic energy differentiated
    from its own expression, to round-off."""
    out, _ = run_example("parallel_inverse_dynamics", [], tmp_path, monkeypatch)
    study = out["study"]
    assert study.forces.shape == (3, 201) and np.all(np.isfinite(study.forces))
    np.testing.assert_allclose(study.forces[:, [0, -1]], 0.0, atol=1e-12)
    assert np.max(np.abs(study.forces)) > 1e-2
    assert out["power_residual"] < 1e-10


# ------------------------------------------------------- a large chain, two ways
def test_large_chain(tmp_path, monkeypatch):
    """The chain written from positions and with ``v2pt_theory`` gives one state
    derivative, and at n = 3 that of SymPy's ``KanesMethod`` on the v2pt-written
    chain (mass_matrix_full, forcing_full, solved numerically)."""
    out, ns = run_example("large_chain", ["--sizes", "3", "6"], tmp_path, monkeypatch)
    assert [r["n"] for r in out["rows"]] == [3, 6]
    assert all(r["difference"] < 1e-10 for r in out["rows"]), out["rows"]
    kane_args, s = ns["chain"](3, v2pt=True)
    kane = me.KanesMethod(kane_args["frame"], q_ind=kane_args["q_ind"],
                          u_ind=kane_args["u_ind"], kd_eqs=kane_args["kd_eqs"])
    kane.kanes_equations(kane_args["bodies"], kane_args["loads"])
    y = out["states"][3]
    values = dict(zip(kane_args["q_ind"] + kane_args["u_ind"], y))
    values.update({s[k]: v for k, v in ns["CONSTANTS"].items()})
    M = np.array(kane.mass_matrix_full.subs(values), dtype=float)
    F = np.array(kane.forcing_full.subs(values), dtype=float).ravel()
    expected = np.linalg.solve(M, F)
    assert np.max(np.abs(np.array(out["rhs"]["3 positions"]) - expected)) < 1e-10
