"""The energy balance term by term (kd.analysis.energy_balance): each term set against
a second route to it, and the residual closing on the driven models."""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn import KanedynError
from kanedyn.analysis import energy_balance

TIGHT = dict(rtol=1e-10, atol=1e-10, dense_output=True)


def _run(name, t_end=None, points=401, backend="c", **options):
    definition = kd.models.build(name, **options)
    model = definition.numeric(backend=backend)
    t_end = t_end or definition.t_end
    res = kd.simulate(model, (0.0, t_end), definition.initial(model),
                      t_eval=np.linspace(0.0, t_end, points), **TIGHT)
    assert res.success, res.message
    return definition, res


def _trapezoid(values, t):
    return np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (values[1:] + values[:-1]))])


def test_flexible_robot_closes_and_the_motor_term_is_the_torque_times_the_rate():
    definition, res = _run("flexible-robot", hub_damping=0.02, points=3001)
    balance = energy_balance(res, load_names=definition.load_names)
    assert set(balance.terms) == {"motor torque", "hub damping"}
    assert balance.relative_residual < 1e-8
    # the motor's work from its torque expression and the hub rate, on the output points
    sy = definition.symbols
    torque = sm.lambdify(sm.Symbol("t"), definition.symbols["pulse"].subs(
        {sy["T_m"]: 1.0, sy["theta_f"]: np.pi / 2, **{s: v for s, v in
                                                      definition.constants.items()}}
    ).subs(me.dynamicsymbols._t, sm.Symbol("t")))
    omega = res["omega"]
    motor = _trapezoid(np.array([float(torque(t)) for t in res.t]) * omega, res.t)
    np.testing.assert_allclose(balance.terms["motor torque"], motor, atol=1e-5 * balance.scale)
    damping = _trapezoid(-0.02 * omega ** 2, res.t)
    np.testing.assert_allclose(balance.terms["hub damping"], damping, atol=1e-5 * balance.scale)
    # the damper took out most of what the motor put in
    assert balance.terms["hub damping"][-1] < -0.9 * balance.terms["motor torque"][-1]


def test_spin_up_beam_closes_on_the_work_of_the_drive_torque():
    definition, res = _run("spin-up-beam", t_end=16.0, n_modes=2, n_elements=4)
    balance = energy_balance(res, load_names=definition.load_names)
    assert balance.relative_residual < 1e-8
    work = balance.terms[definition.load_names[0]]
    # the exposed torque drives the whole prescribed motion: nothing is left to the
    # prescribed-motion term (round-off; it is no term at all before its extension to
    # flexible bodies)
    rest = balance.terms.pop("prescribed motion (the forces that drive it)", np.zeros(1))
    assert np.max(np.abs(rest)) < 1e-12 * balance.scale and len(balance.terms) == 1
    # tau from the auxiliary speed's equation at the output points, times the prescribed rate
    model = res.model
    tau = np.array([model.auxiliary(t, y)["tau"] for t, y in zip(res.t, res.y.T)])
    rate = sm.lambdify(me.dynamicsymbols._t, definition.symbols["theta_rate"])
    drive = _trapezoid(tau * np.array([float(rate(t)) for t in res.t]), res.t)
    np.testing.assert_allclose(work, drive, atol=1e-4 * balance.scale)
    assert work[-1] == pytest.approx(balance.energy_change[-1], rel=1e-8)


def test_a_flexible_body_in_prescribed_motion_takes_the_work_that_drives_it():
    """The spin-up beam without its auxiliary speed (the hub's rate prescribed, the
    torque not exposed): the prescribed-motion term, from the flexible body's inertia
    forces along the prescribed velocity, is the work of the exposed torque above."""
    definition = kd.models.build("spin-up-beam", n_modes=2, n_elements=4)
    s, a = definition.symbols, definition.kane_args
    s["B"].set_ang_vel(s["N"], s["theta"].diff(me.dynamicsymbols._t) * s["N"].z)
    eom = kd.kane(frame=a["frame"], q_ind=a["q_ind"], u_ind=a["u_ind"], kd_eqs=a["kd_eqs"],
                  bodies=a["bodies"])
    model = eom.numeric(constants={}, specified=definition.specified, backend="c")
    res = kd.simulate(model, (0.0, 16.0), np.zeros(model.n_states),
                      t_eval=np.linspace(0.0, 16.0, 401), **TIGHT)
    balance = energy_balance(res)
    [(name, work)] = balance.terms.items()
    assert name == "prescribed motion (the forces that drive it)"
    assert balance.relative_residual < 1e-8
    exposed = energy_balance(_run("spin-up-beam", t_end=16.0, n_modes=2, n_elements=4)[1])
    torque = next(w for n, w in exposed.terms.items() if "tau" in n)
    np.testing.assert_allclose(work, torque, atol=1e-9 * balance.scale)


def test_a_saved_flexible_body_keeps_the_work_that_drives_its_prescribed_motion(tmp_path):
    """The flexible bodies' blocks travel with saved equations: the loaded spin-up beam
    (hub rate prescribed, no torque exposed) has the same prescribed-motion term."""
    definition = kd.models.build("spin-up-beam", n_modes=2, n_elements=4)
    s, a = definition.symbols, definition.kane_args
    s["B"].set_ang_vel(s["N"], s["theta"].diff(me.dynamicsymbols._t) * s["N"].z)
    eom = kd.kane(frame=a["frame"], q_ind=a["q_ind"], u_ind=a["u_ind"], kd_eqs=a["kd_eqs"],
                  bodies=a["bodies"])
    eom.save(tmp_path / "beam.kd")
    terms = []
    for equations in (eom, kd.load(tmp_path / "beam.kd")):
        model = equations.numeric(constants={}, specified=definition.specified,
                                  backend="numpy")
        res = kd.simulate(model, (0.0, 4.0), np.zeros(model.n_states),
                          t_eval=np.linspace(0.0, 4.0, 41), **TIGHT)
        balance = energy_balance(res)
        assert balance.relative_residual < 1e-8
        terms.append(balance.terms["prescribed motion (the forces that drive it)"])
    assert np.max(np.abs(terms[0])) > 0.0
    np.testing.assert_allclose(terms[1], terms[0], rtol=0, atol=1e-12 * np.max(np.abs(terms[0])))


@pytest.fixture(scope="module")
def seatbelt_run():
    """The default sensor through the first 50 ms of its pulse (it reaches the
    housing's wall, the penalty limit's damper working, at about 25 ms)."""
    return _run("seatbelt-sensor", t_end=0.05, points=201)[1]


def test_seatbelt_prescribed_motion_term_is_the_pivot_forces_work(seatbelt_run):
    """The work of the forces that drive the housing's motion, taken from the
    inertia forces, equals the work of the pivot force exposed by auxiliary
    speeds in the same model (pivot_force=True): two routes to one term."""
    res = seatbelt_run
    balance = energy_balance(res)
    assert balance.relative_residual < 1e-8
    prescribed = balance.terms["prescribed motion (the forces that drive it)"]
    assert "force at G [g, m]" not in balance.terms  # gravity: held by the potential
    exposed = _run("seatbelt-sensor", t_end=0.05, points=201, pivot_force=True)[1]
    exposed_balance = energy_balance(exposed)
    assert exposed_balance.relative_residual < 1e-8
    [pivot] = [w for n, w in exposed_balance.terms.items() if n.startswith("constraint")]
    np.testing.assert_allclose(prescribed, pivot, atol=1e-8 * balance.scale)
    assert abs(prescribed[-1]) > 0.5 * balance.scale
    limit = [w for n, w in balance.terms.items() if "k_lim" in n]
    assert limit and limit[0][-1] < 0  # the wall's damper took energy out


@pytest.mark.slow
def test_a_missing_term_shows_in_the_residual(seatbelt_run):
    """Gravity counted twice (its load and the potential) leaves its work as residual."""
    res = seatbelt_run
    kept = energy_balance(res)
    counted_twice = energy_balance(res, gravity=None)
    assert kept.relative_residual < 1e-8 and counted_twice.relative_residual > 1e-4


def test_load_names_find_the_symbols_in_shared_subexpressions():
    """Loads that share a deep recurrence (a Chebyshev series, as a rotor's inflow
    gives): every load names the constant inside it, the shared part walked once."""
    from kanedyn.analysis._energy_balance import _term_names
    N, O = me.ReferenceFrame("N"), me.Point("O")
    O.set_vel(N, 0)
    x, u = me.dynamicsymbols("x u")
    c, k = sm.symbols("c k")
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, u * N.x)
    series = [sm.S.One, sm.sin(x) * c]
    for _ in range(40):    # 2^40 nodes as a tree
        series.append(2 * series[1] * series[-1] - series[-2])
    loads = [(P, -k * x * N.x), (P, series[-1] * N.x), (P, series[-1] ** 2 * N.y)]
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[u], kd_eqs=[x.diff() - u],
                  bodies=[me.Particle("p", P, 1.0)], loads=loads)
    model = eom.numeric(constants={c: 0.1, k: 1.0}, backend="numpy")
    assert _term_names(eom, model, None) == ["force at P [k]", "force at P [c] (2)",
                                             "force at P [c] (3)"]
    # a name given to two loads makes one term of both; None keeps the default name
    res = kd.simulate(model, (0.0, 1.0), [0.5, 0.0], t_eval=np.linspace(0.0, 1.0, 11),
                      **TIGHT)
    apart = energy_balance(res)
    joined = energy_balance(res, load_names=[None, "series", "series"])
    assert set(joined.terms) == {"force at P [k]", "series"}
    np.testing.assert_allclose(joined.terms["series"], apart.terms["force at P [c] (2)"]
                               + apart.terms["force at P [c] (3)"], rtol=1e-12, atol=1e-15)
    assert joined.relative_residual < 1e-8


def test_without_the_continuous_solution_it_says_what_to_do():
    definition = kd.models.build("flexible-robot", n_modes=1, n_elements=2)
    model = definition.numeric(backend="numpy")
    res = kd.simulate(model, (0.0, 0.1), definition.initial(model))
    with pytest.raises(KanedynError, match="dense_output=True"):
        energy_balance(res)
    res = kd.simulate(model, (0.0, 0.1), definition.initial(model), dense_output=True)
    with pytest.raises(KanedynError, match="2 load names for 1 loads"):
        energy_balance(res, load_names=("a", "b"))
    for bad in ([1], [-1], [True], ["0"]):
        with pytest.raises(KanedynError, match=r"potential_loads must be indices of the 1 "
                                               r"loads, got "):
            energy_balance(res, potential_loads=bad)


def _own_potential(definition, model, flexible):
    """The strain and gravitational energy of the flexible bodies (no load holds it), J,
    as a function of the state."""
    from kanedyn.engine import name_of
    from kanedyn.modeling.offshore import state_function
    s = definition.symbols
    symbols = {name_of(x): x for x in [*s["q"], *s["u"]]}
    states = [symbols.get(n, sm.Symbol("unused_" + n)) for n in model.state_names]
    return state_function([sum(body.gravitational_energy(s["O"]) + body.strain_energy
                               for body in flexible)], states, dict(definition.constants),
                          "flexible")


@pytest.mark.slow
def test_oc3_spar_spinning_rotor_with_controller_printed_balance_closes():
    """The balance that `kanedyn run oc3-spar` prints leaves out the loads whose work the
    declared potential holds (weights, the flexible shaft's spring, the hydrostatic and
    mooring springs' gradients: the definition's potential_loads) and closes; counted
    as work as well, they would make a residual of the potential's change.  A second
    route: every load counted as work, the kinetic energy plus the tower's own potential
    (bending, gravity: no load) closes too, and the two agree on the work of the loads
    not held."""
    d = kd.models.oc3_spar(rotor="spinning", controller="on", wind_speed=18.0,
                           drivetrain="flexible")
    m = d.numeric(backend="c")
    r = kd.simulate(m, (0, 10), d.initial(m), t_eval=np.linspace(0, 10, 101), rtol=1e-9,
                    atol=1e-9, dense_output=True)
    printed = energy_balance(r, load_names=d.load_names, potential_loads=d.potential_loads)
    assert printed.relative_residual < 1e-7                    # measured 2e-10
    assert abs(printed.terms["generator torque"][-1]) > 1e7        # the generator's work
    assert printed.terms["low-speed shaft damping"][-1] < 0.0
    assert printed.terms["mooring beyond its potential (the published matrix's asymmetry, "
                         "second-order part)"][-1] != 0.0
    assert any("held by the potential energy" in note for note in printed.notes)
    twice = energy_balance(r, load_names=d.load_names)
    T, V = np.array([m.energies(t, y) for t, y in zip(r.t, r.y.T)]).T
    own = _own_potential(d, m, [d.symbols["tower"]])
    Vt = np.array([float(own(c)[0]) for c in r.y.T])
    # counted twice: the residual is the held loads' potential change
    assert twice.relative_residual > 1e-3
    assert twice.residual == pytest.approx(V - V[0] - (Vt - Vt[0]), abs=1e-7 * twice.scale)
    W = sum(twice.terms.values())
    gap = T - T[0] + Vt - Vt[0] - W
    assert np.max(np.abs(gap)) < 1e-7 * np.max(np.abs(W))
    for name, work in printed.terms.items():
        np.testing.assert_allclose(work, twice.terms[name], rtol=0, atol=1e-12 * twice.scale)


@pytest.mark.slow
def test_oc3_spar_flexible_blades_bem_controller_energy_balance_closes():
    """The spinning, controlled, flexible system (three flexible blades pitched at their
    roots by the controller, BEM aerodynamics on their deflecting nodes, flexible tower,
    18 m/s): the change of the stored energy (kinetic, the declared potential) equals
    the aerodynamic work, the control work (generator torque, and the pitch drive's: the
    prescribed-motion term) and the dissipation (tower, blades, hydrodynamic damping),
    to 1e-6 of the energy exchanged (measured 8.6e-10 over these 2 s).  Second
    route: every load counted as work, the kinetic energy plus the flexible bodies' own
    potential."""
    d = kd.models.oc3_spar(rotor="spinning", controller="on", wind_speed=18.0,
                           blades="flexible", aero="bem")
    m = d.numeric(backend="c")
    r = kd.simulate(m, (0, 2), d.initial(m), t_eval=np.linspace(0, 2, 21), rtol=1e-9,
                    atol=1e-9, dense_output=True)
    assert r.success, r.message
    b = energy_balance(r, load_names=d.load_names, potential_loads=d.potential_loads)
    assert b.relative_residual < 1e-6
    aero = [b.terms[f"aerodynamic forces on blade{k}"] for k in (1, 2, 3)]
    assert all(w[-1] > 1e6 for w in aero)                      # the wind works on each
    assert b.terms["generator torque"][-1] < -1e6                   # the generator takes it
    pitching = b.terms["prescribed motion (the forces that drive it)"]
    assert np.max(np.abs(pitching)) > 1.0                     # the pitch drive's, J
    for body in ("tower", "blade1", "blade2", "blade3"):
        assert b.terms[f"damping of {body}"][-1] < 0.0
    assert b.terms["additional linear damping"][-1] < 0.0
    twice = energy_balance(r, load_names=d.load_names)
    T = np.array([m.energies(t, y)[0] for t, y in zip(r.t, r.y.T)])
    own = _own_potential(d, m, [d.symbols["tower"], *d.symbols["rotor"]["blades"]])
    V = np.array([float(own(c)[0]) for c in r.y.T])
    W = sum(twice.terms.values())
    assert np.max(np.abs(T - T[0] + V - V[0] - W)) < 1e-6 * twice.scale


@pytest.mark.parametrize("name, backend", [("four-bar", "numpy"), ("four-bar", "c"),
                                           ("n-link-pendulum-on-cart", "numpy")])
def test_load_powers_from_one_batch_equal_those_state_by_state(name, backend, monkeypatch):
    """The accelerations the load powers take from one ``rhs_batch`` (dependent
    speeds, a C module, an input's function) against ``rhs`` state by state, the
    way they were taken before: equal to 1e-12 of their scale, and so are the
    powers; where a state's system is singular, ``rhs``'s error as before."""
    from kanedyn.numerics import _load_powers
    definition = kd.models.build(name)
    specified = {s: np.sin for s in definition.specified}
    model = definition.numeric(definition.derive(), backend=backend, specified=specified)
    y0 = definition.initial(model)
    run = kd.simulate(model, (0.0, 1.0), y0, t_eval=np.linspace(0.0, 1.0, 41))
    ts, Y = run.t, run.y
    one_by_one = np.array([model.rhs(t, y)[model.n_q:] for t, y in zip(ts, Y.T)])
    batch = _load_powers._accelerations(model, ts, Y)
    scale = np.abs(one_by_one).max()
    assert np.abs(batch - one_by_one).max() <= 1e-12 * scale
    new = _load_powers.load_powers(model, ts, Y, gravity=sm.Symbol("g"))
    monkeypatch.setattr(_load_powers, "_accelerations", lambda model, ts, Y: one_by_one)
    old = _load_powers.load_powers(model, ts, Y, gravity=sm.Symbol("g"))
    for a, b in ((new.loads, old.loads), (new.gravity, old.gravity)):
        assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1.0)
    monkeypatch.undo()
    pendulum = kd.models.build("pendulum")
    massless = pendulum.numeric(backend="numpy").with_constants({"m": 0.0})
    y = np.array(pendulum.initial(massless), dtype=float)[:, None]
    with pytest.raises(np.linalg.LinAlgError):
        _load_powers._accelerations(massless, np.array([0.0]), y)
