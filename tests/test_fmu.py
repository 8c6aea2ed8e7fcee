"""FMU export (FMI 2.0 and 3.0): FMPy validates the FMUs and simulates them as model
exchange (CVODE) and co-simulation; the results are compared with ``kd.simulate``."""

import ctypes
import shutil

import numpy as np
import pytest

import kanedyn as kd
from kanedyn._errors import ModelError, OptionError
from kanedyn.cli import main

fmpy = pytest.importorskip("fmpy")
from fmpy.validation import validate_fmu  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler (cc) installed")

#: the co-simulation step's tolerances for the comparisons (FMU parameters), and the
#: residual that triggers a projection (kd.simulate's default at atol = 1e-12)
TIGHT = {"kanedyn.rtol": 1e-12, "kanedyn.atol": 1e-12, "kanedyn.projection_tol": 1e-10}

_BUILT = {}


def _exported(name, folder, fmi_version=2, **options):
    """(definition, model, y0, path of its FMU), built once per model, FMI version and
    options."""
    key = (name, fmi_version, tuple(sorted(options.items())))
    if key not in _BUILT:
        definition = kd.models.build(name, **options)
        model = definition.numeric(backend="c")
        y0 = model.state(definition.initial(model))
        path = model.export_fmu(folder / f"{name}-{len(_BUILT)}.fmu", y0,
                                t_end=definition.t_end,
                                constant_units=definition.constant_units,
                                fmi_version=fmi_version)
        _BUILT[key] = (definition, model, y0, path)
    return _BUILT[key]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("fmu")


def _reference(model, y0, t_end, dt):
    times = np.linspace(0.0, t_end, int(round(t_end / dt)) + 1)
    res = kd.simulate(model, (0.0, t_end), y0, rtol=1e-12, atol=1e-12, t_eval=times)
    assert res.success, res.message
    return res.y


#: FMPy's CVODE (model exchange) at rtol = 1e-13 (atol = rtol x nominal, the nominals
#: 1): at FMPy's default, 1e-12, its error on the four-bar and the flexible robot is
#: 1.2e-8 and 3.0e-8 (docs/fmu.md).  CVODE takes at most 500 steps per output
#: interval: at 1e-13 that needs outputs every 0.01 s.
ME_RTOL, ME_INTERVAL = 1e-13, 0.01


def _fmu_run(path, names, kind, t_end, dt, start_values=TIGHT, **options):
    """The states at the output times of FMPy's run; the tolerance (of the FMU's own
    integration in co-simulation: it replaces kanedyn.rtol, as the FMU's default
    experiment's would) 1e-12, CVODE's ME_RTOL."""
    tolerance = ME_RTOL if kind == "ModelExchange" else 1e-12
    options = {"relative_tolerance": tolerance, **options}
    result = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=t_end, output_interval=dt,
                               output=list(names), record_events=False,
                               start_values=start_values, **options)
    return np.array([result[n] for n in names])


# (model, end time [s], output interval [s]): co-simulation (the FMU's own
# Dormand-Prince at 1e-12) within 1e-9 (measured 9e-12 pendulum, 3.6e-11 four-bar,
# 8e-13 bicycle, 1e-11 flexible robot), model exchange within 1e-8 (measured 7e-11,
# 2.9e-9, 1.6e-11, 3.8e-9), the same for both FMI versions
CASES = [("pendulum", 2.0, 0.1), ("four-bar", 2.0, 0.1), ("whipple-bicycle", 2.0, 0.1),
         pytest.param("flexible-robot", 1.0, 0.01, marks=pytest.mark.slow)]
VERSIONS = [2, 3]


@pytest.mark.parametrize("fmi_version", VERSIONS)
@pytest.mark.parametrize("name, t_end, dt", CASES)
def test_fmu_validates_and_equals_simulate(name, t_end, dt, fmi_version, folder):
    _, model, y0, path = _exported(name, folder, fmi_version)
    assert validate_fmu(str(path)) == []
    names = model.state_names
    cs = _fmu_run(path, names, "CoSimulation", t_end, dt)
    assert np.max(np.abs(cs - _reference(model, y0, t_end, dt))) < 1e-9
    me = _fmu_run(path, names, "ModelExchange", t_end, ME_INTERVAL)
    assert np.max(np.abs(me - _reference(model, y0, t_end, ME_INTERVAL))) < 1e-8


@pytest.mark.slow
@pytest.mark.parametrize("fmi_version", VERSIONS)
def test_nominals_of_small_states_make_model_exchange_accurate(fmi_version, folder):
    """The flexible robot's elastic coordinates are of the order of a millimetre: with
    the nominal 1, CVODE's absolute tolerance (rtol x nominal = 1e-12 m) is loose on
    them and its error reaches 3e-8; declared as nominal 1e-3, within 1e-8 at the same
    rtol (measured 8e-10, the reference's own error at 1e-12 included)."""
    from fmpy import read_model_description
    definition, model, y0, plain = _exported("flexible-robot", folder, fmi_version)
    elastic = [n for n in model.state_names if n.startswith(("eta_", "zeta_"))]
    assert elastic
    path = model.export_fmu(folder / f"flexible-nominal-{fmi_version}.fmu", y0,
                            t_end=definition.t_end, fmi_version=fmi_version,
                            nominals={n: 1e-3 for n in elastic})
    assert validate_fmu(str(path)) == []
    nominal = {v.name: v.nominal for v in read_model_description(str(path)).modelVariables}
    assert float(nominal[elastic[0]]) == 1e-3 and nominal["theta"] is None
    t_end, dt = 1.0, 0.01
    expected = _reference(model, y0, t_end, dt)
    errors = [np.max(np.abs(_fmu_run(p, model.state_names, "ModelExchange", t_end, dt,
                                     relative_tolerance=1e-12) - expected))
              for p in (plain, path)]
    assert errors[0] > 1e-8 > errors[1]


def _model_exchange_instance(path, fmi_version):
    """An FMPy instance of the FMU's model exchange, initialized, in continuous time."""
    from fmpy import extract, read_model_description
    description = read_model_description(str(path))
    options = dict(guid=description.guid, unzipDirectory=extract(str(path)),
                   modelIdentifier=description.modelExchange.modelIdentifier,
                   instanceName="check")
    if fmi_version == 2:
        from fmpy.fmi2 import FMU2Model
        fmu = FMU2Model(**options)
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
    else:
        from fmpy.fmi3 import FMU3Model
        fmu = FMU3Model(**options)
        fmu.instantiate()
        fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    fmu.enterContinuousTimeMode()
    return fmu


@pytest.mark.parametrize("fmi_version", VERSIONS)
def test_model_exchange_derivatives_are_model_rhs(fmi_version, folder):
    """The FMU's derivatives at states set through FMI are model.rhs's (round-off)."""
    _, model, y0, path = _exported("four-bar", folder, fmi_version)
    fmu = _model_exchange_instance(path, fmi_version)
    derivatives = fmu.getDerivatives if fmi_version == 2 \
        else fmu.getContinuousStateDerivatives
    n = model.n_states
    rng = np.random.default_rng(3)
    for _ in range(4):
        y = model.consistent_state(0.0, y0 + rng.uniform(-0.2, 0.2, n))
        t = float(rng.uniform(0, 2))
        fmu.setTime(t)
        fmu.setContinuousStates((ctypes.c_double * n)(*y), n)
        out = (ctypes.c_double * n)()
        derivatives(out, n)
        expected = model.rhs(t, y)
        assert np.allclose(np.array(out), expected, rtol=1e-12, atol=1e-12)
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("fmi_version", VERSIONS)
def test_constrained_initial_state_is_made_consistent(fmi_version, folder):
    """A start value of a dependent coordinate is a guess: completed at initialization
    (as kd.simulate completes it)."""
    _, model, y0, path = _exported("four-bar", folder, fmi_version)
    guess = dict(zip(model.state_names, y0))
    guess.update({"q2": y0[1] + 0.05, "q1": 1.0})
    t_end, dt = 0.5, 0.1
    expected = _reference(model, model.state(dict(guess)), t_end, dt)
    got = _fmu_run(path, model.state_names, "CoSimulation", t_end, dt,
                   start_values={**TIGHT, "q1": 1.0, "q2": guess["q2"]})
    assert np.max(np.abs(got - expected)) < 1e-9


@pytest.mark.parametrize("fmi_version", VERSIONS)
def test_parameters_change_the_result_as_constants_do(fmi_version, folder):
    _, model, y0, path = _exported("pendulum", folder, fmi_version)
    t_end, dt = 2.0, 0.1
    expected = _reference(model.with_constants({"l": 1.7}), y0, t_end, dt)
    default = _reference(model, y0, t_end, dt)
    assert np.max(np.abs(expected - default)) > 1e-2  # the parameter matters
    for kind, bound in (("CoSimulation", 1e-9), ("ModelExchange", 1e-8)):
        got = _fmu_run(path, model.state_names, kind, t_end, dt,
                       start_values={**TIGHT, "l": 1.7})
        assert np.max(np.abs(got - expected)) < bound


@pytest.mark.parametrize("fmi_version", VERSIONS)
def test_inputs_equal_simulate_with_the_same_input(fmi_version, folder):
    """A staircase torque signal: its steps are FMPy's input events (model exchange:
    event mode, then CVODE restarted; co-simulation: communication points), the value
    held between them; kd.simulate run piece by piece with each value."""
    _, model, y0, path = _exported("pendulum", folder, fmi_version, torque=True)
    t_end, dt = 2.0, 0.1
    edges = np.arange(0.0, t_end + dt / 2, dt)
    levels = 0.8 * np.sin(3.0 * edges[:-1])
    rows = [(t, level) for a, b, level in zip(edges[:-1], edges[1:], levels) for t in (a, b)]
    staircase = np.array(rows, dtype=[("time", float), ("tau", float)])
    pieces, y = [y0], y0
    for a, b, level in zip(edges[:-1], edges[1:], levels):
        res = kd.simulate(model.with_inputs({"tau": float(level)}), (a, b), y, rtol=1e-12,
                          atol=1e-12)
        y = res.y[:, -1]
        pieces.append(y)
    expected = np.array(pieces).T
    assert np.max(np.abs(expected - _reference(model, y0, t_end, dt))) > 1e-2
    cs = _fmu_run(path, model.state_names, "CoSimulation", t_end, dt, input=staircase)
    assert np.max(np.abs(cs - expected)) < 1e-9
    me = _fmu_run(path, model.state_names, "ModelExchange", t_end, dt, input=staircase)
    assert np.max(np.abs(me - expected)) < 1e-8


def test_co_simulation_interpolates_inputs_with_their_derivatives(folder):
    """fmi2SetRealInputDerivatives: the input is r + (t - t0) r' within the step."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    _, model, y0, path = _exported("pendulum", folder, torque=True)
    description = read_model_description(str(path))
    tau = next(v.valueReference for v in description.modelVariables if v.name == "tau")
    states = [v.valueReference for v in description.modelVariables
              if v.name in model.state_names]
    fmu = FMU2Slave(guid=description.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=description.coSimulation.modelIdentifier,
                    instanceName="ramp")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.setReal([v.valueReference for v in description.modelVariables
                 if v.name in TIGHT], [TIGHT[v.name] for v in description.modelVariables
                                       if v.name in TIGHT])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.setReal([tau], [0.3])
    fmu.setRealInputDerivatives([tau], [1], [2.0])
    fmu.doStep(0.0, 0.5)
    got = np.array(fmu.getReal(states))
    fmu.terminate()
    fmu.freeInstance()
    res = kd.simulate(model.with_inputs({"tau": lambda t: 0.3 + 2.0 * t}), (0.0, 0.5), y0,
                      rtol=1e-12, atol=1e-12)
    held = kd.simulate(model.with_inputs({"tau": 0.3}), (0.0, 0.5), y0, rtol=1e-12,
                       atol=1e-12)
    assert np.max(np.abs(held.y[:, -1] - res.y[:, -1])) > 1e-3
    assert np.max(np.abs(got - res.y[:, -1])) < 1e-10


def test_units_and_variables_in_the_model_description(folder):
    from fmpy import read_model_description
    _, model, _, path = _exported("four-bar", folder)
    variables = {v.name: v for v in read_model_description(str(path)).modelVariables}
    assert variables["q1"].unit == "rad" and variables["u1"].unit == "rad/s"
    assert variables["der(u1)"].unit == "rad/s^2"
    assert variables["m_a"].causality == "parameter" and variables["m_a"].unit == "kg"
    assert float(variables["g"].start) == model.constants["g"]
    assert variables["kinetic_energy"].causality == "output"


def test_fmi3_model_description(folder):
    """FMI 3.0's form of the same variables: Float64 variables, the independent
    variable time, derivatives and the model structure by value reference, the
    sources in buildDescription.xml."""
    import zipfile

    from fmpy import read_model_description
    _, model, _, path = _exported("four-bar", folder, 3)
    description = read_model_description(str(path))
    assert description.fmiVersion == "3.0"
    variables = {v.name: v for v in description.modelVariables}
    assert variables["time"].causality == "independent" and variables["time"].unit == "s"
    assert {v.type for v in description.modelVariables} == {"Float64"}
    assert variables["q1"].unit == "rad" and variables["der(u1)"].unit == "rad/s^2"
    assert variables["der(u1)"].derivative is variables["u1"]
    assert variables["m_a"].causality == "parameter" and variables["m_a"].unit == "kg"
    states = [variables[n] for n in model.state_names]
    assert [d.variable.derivative for d in description.derivatives] == states
    assert [o.variable for o in description.outputs] == [
        *states, variables["kinetic_energy"], variables["potential_energy"]]
    assert description.modelExchange.needsCompletedIntegratorStep
    with zipfile.ZipFile(path) as archive:
        names = set(archive.namelist())
        build = archive.read("sources/buildDescription.xml").decode()
    assert {"sources/model.c", "sources/fmi3.c", "modelDescription.xml"} <= names
    assert any(n.startswith("binaries/") and "-" in n.split("/")[1] for n in names)
    assert '<SourceFile name="fmi3.c"' in build


# ------------------------------------------------------------ contacts (co-simulation)
#: the co-simulation step's tolerances and kd.simulate's for the contact comparisons
CONTACT_TOL = 1e-10


def _contact_run(path, names, t_end, dt, logger=None):
    """FMPy's co-simulation of a contact model at CONTACT_TOL: the output times and
    the states there."""
    result = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=t_end,
                               output_interval=dt, output=list(names),
                               relative_tolerance=CONTACT_TOL, logger=logger,
                               start_values={"kanedyn.atol": CONTACT_TOL})
    return result["time"], np.array([result[n] for n in names])


_REFERENCES = {}


def _contact_reference(model, y0, times):
    """kd.simulate's run of ``model`` from ``y0`` at CONTACT_TOL, its outputs at
    ``times``: made once per model, initial state and output times (the tests of
    one exported model by co-simulation and by model exchange compare with the
    same run where FMPy gives both the same output times)."""
    key = (id(model), np.asarray(y0, dtype=float).tobytes(),
           np.asarray(times, dtype=float).tobytes())
    found = _REFERENCES.get(key)
    if found is None or found[0] is not model:  # (the model kept: its id stays its own)
        res = kd.simulate(model, (0.0, times[-1]), y0, rtol=CONTACT_TOL, atol=CONTACT_TOL,
                          t_eval=times)
        assert res.success, res.message
        found = _REFERENCES[key] = (model, res)
    return found[1]


# (model, FMI version, end time [s], output interval [s]); measured at CONTACT_TOL:
# bouncing ball 2.7e-11 (19 impacts in 4 s; 6 s: 2.8e-10, at rest on the floor after
# 67 impacts at 4.06 s), block on incline 7.1e-10 (slip -> stick -> slip -> lift-off),
# slug in an ellipsoidal tank 5.1e-10 (3D: 44 impacts with friction, sliding on the wall)
CONTACT_CASES = [("bouncing-ball", 2, 6.0, 0.02), ("bouncing-ball", 3, 4.0, 0.02),
                 ("block-on-incline", 2, 3.0, 0.02),
                 pytest.param("slug-ellipsoid", 3, 8.0, 0.08, marks=pytest.mark.slow)]


@pytest.mark.parametrize("name, fmi_version, t_end, dt", CONTACT_CASES)
def test_contact_fmu_cosimulation_equals_simulate(name, fmi_version, t_end, dt, folder):
    definition, model, y0, path = _exported(name, folder, fmi_version)
    assert validate_fmu(str(path)) == []
    times, states = _contact_run(path, model.state_names, t_end, dt)
    ref = _contact_reference(model, y0, times)
    assert ref.mode_history or ref.impacts  # the events happen within the run
    assert np.max(np.abs(states - ref.y)) < 1e-8


def test_contact_fmu_coefficients_follow_their_parameters(folder):
    """The restitution and friction coefficients are expressions of the FMU's
    parameters: a ball given e = 0.5 and mu = 0.3 (friction at the impacts) in the
    FMU equals kd.simulate of the model with those constants."""
    _, model, y0, path = _exported("bouncing-ball", folder, 2)
    result = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=2.0,
                               output_interval=0.02, output=list(model.state_names),
                               relative_tolerance=CONTACT_TOL,
                               start_values={"kanedyn.atol": CONTACT_TOL, "e": 0.5,
                                             "mu": 0.3})
    changed = model.with_constants({"e": 0.5, "mu": 0.3})
    ref = _contact_reference(changed, y0, result["time"])
    states = np.array([result[n] for n in model.state_names])
    assert len(ref.impacts) > 3
    assert np.max(np.abs(states - ref.y)) < 1e-8
    default = _contact_reference(model, y0, result["time"])
    assert np.max(np.abs(states - default.y)) > 1e-2  # the parameters made a difference


def test_contact_fmu_ball_bounces_as_the_closed_form(folder):
    """Free flights between impacts with the floor: touchdown at t1 = sqrt(2 h / g),
    each bounce leaving at e times the speed it came with (Poisson, frictionless)."""
    definition, model, y0, path = _exported("bouncing-ball", folder, 2)
    g, e, r = (model.constants[k] for k in ("g", "e", "r"))
    times, states = _contact_run(path, ["z", "u_z"], 3.0, 0.01)
    h = y0[1] - r
    t_hit, v = np.sqrt(2 * h / g), np.sqrt(2 * g * h)
    starts, speeds = [0.0], [0.0]
    heights = [y0[1]]
    while t_hit < times[-1]:  # the flights: (start, upward speed, height)
        v *= e
        starts.append(t_hit)
        speeds.append(v)
        heights.append(r)
        t_hit += 2 * v / g
    k = np.searchsorted(starts, times, side="right") - 1
    tau = times - np.take(starts, k)
    z = np.take(heights, k) + np.take(speeds, k) * tau - 0.5 * g * tau ** 2
    assert np.max(np.abs(states[0] - z)) < 1e-8


def _contact_run_of(kind, path, names, t_end, rtol=1e-12, logger=None):
    """FMPy's run of a contact FMU, outputs every 0.01 s: co-simulation at CONTACT_TOL,
    model exchange with CVODE at ``rtol``; the output times and the states there."""
    cosim = kind == "CoSimulation"
    result = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=t_end, output_interval=0.01,
                               output=list(names), record_events=False, logger=logger,
                               relative_tolerance=CONTACT_TOL if cosim else rtol,
                               start_values={"kanedyn.atol": CONTACT_TOL} if cosim else {})
    return result["time"], np.array([result[n] for n in names])


@pytest.mark.parametrize("kind, fmi_version", [("CoSimulation", 2),
                                                ("ModelExchange", 3)])
def test_contact_fmu_frictionless_ladder(kind, fmi_version, folder):
    """Two frictionless contacts sliding at once (floor and wall): the top leaves the
    wall when the ladder's centre has fallen to 2/3 of its initial height (the
    closed form), then lands on the floor while the foot slides (an impact of two
    contacts at once, 0.59 s), and the FMU equals kd.simulate over the 2 s
    (measured 4.1e-11 co-simulation, 3.4e-10 model exchange)."""
    _, model, y0, path = _exported("ladder", folder, fmi_version, frictionless=True)
    times, states = _contact_run_of(kind, path, model.state_names, 2.0)
    ref = _contact_reference(model, y0, times)
    assert [i.contacts for i in ref.impacts] == [("floor", "top-floor")]
    assert np.max(np.abs(states - ref.y)) < 1e-8
    (lift_off,) = [c for c in ref.mode_history if c.contact == "wall"]
    at = kd.simulate(model, (0.0, lift_off.t), y0, rtol=CONTACT_TOL, atol=CONTACT_TOL)
    assert abs(at["z"][-1] / y0[1] - 2 / 3) < 1e-8


def _last_modes(model, ref):
    """The contacts' modes at the last output time of kd.simulate's result."""
    return tuple(ref.contact_forces[c["name"]]["mode"][-1] for c in model.contacts)


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_contact_fmu_rough_ladder(kind, folder):
    """Floor and wall with Coulomb friction at once: both ends slide, the top leaves
    the wall, then lands on the floor while the foot slides (an impact of two
    contacts with friction, both ends stick after it: redundant contacts, their
    forces by least friction).  Measured 3.8e-10 (co-simulation), 9.8e-10 (model
    exchange, CVODE at 1e-12) over 2 s."""
    _, model, y0, path = _exported("ladder", folder, 2)
    times, states = _contact_run_of(kind, path, model.state_names, 2.0)
    ref = _contact_reference(model, y0, times)
    assert [i.contacts for i in ref.impacts] == [("floor", "top-floor")]
    assert _last_modes(model, ref) == ("stick", "separated", "stick")
    assert np.max(np.abs(states - ref.y)) < 1e-8


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_contact_fmu_bead_in_tube(kind, folder):
    """A bead sliding on the floor and the wall of a spinning tube at once (friction
    on both, the slip directions free of the other contact's drift) until both
    slips stop together and it sticks in the corner.  Measured 1.2e-10
    (co-simulation), 1.5e-10 (model exchange, CVODE at 1e-12) over 1 s."""
    _, model, y0, path = _exported("bead-in-tube", folder, 3)
    times, states = _contact_run_of(kind, path, model.state_names, 1.0)
    ref = _contact_reference(model, y0, times)
    assert sorted((c.contact, c.old, c.new) for c in ref.mode_history) == [
        ("floor", "slip", "stick"), ("wall", "slip", "stick")]
    assert np.max(np.abs(states - ref.y)) < 1e-8


def test_contact_fmu_falling_rod_lands_with_both_ends(folder):
    """The falling rod bounces on one end, then on the other, then on one end while
    the other touches (impacts of both contacts at once, with friction) until it
    lies on the floor: the FMU equals kd.simulate over the 2 s (measured 4.2e-10)."""
    definition, model, y0, path = _exported("falling-rod", folder, 2)
    times, states = _contact_run_of("CoSimulation", path, model.state_names, 2.0)
    ref = _contact_reference(model, y0, times)
    assert sum(len(i.contacts) == 2 for i in ref.impacts) > 5
    assert _last_modes(model, ref) == ("stick", "stick")
    assert np.max(np.abs(states - ref.y)) < 1e-8


_IN_SPACE = {}


def _rod_in_space(folder, law):
    """A rod that can also move along N.y, its end A landing on a rough floor (mu 0.3,
    restitution 0.5 under ``law``) with a slip across the rod's plane: the slip
    turns during the impulse (kd.simulate integrates it over the normal impulse).
    (model, y0, path of its FMU), built once per law."""
    if law in _IN_SPACE:
        return _IN_SPACE[law]
    import sympy.physics.mechanics as me
    q = me.dynamicsymbols("x y z theta")
    u = me.dynamicsymbols("u_x u_y u_z omega")
    N, O, B = me.ReferenceFrame("N"), me.Point("O"), me.ReferenceFrame("B")
    O.set_vel(N, 0)
    B.orient_axis(N, N.y, -q[3])
    B.set_ang_vel(N, -u[3] * N.y)
    G = O.locatenew("G", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    G.set_vel(N, u[0] * N.x + u[1] * N.y + u[2] * N.z)
    rod = me.RigidBody("rod", G, B, 1.0, (me.inertia(B, 0, 1 / 12, 1 / 12), G))
    A = G.locatenew("A", 0.5 * B.x)
    A.v2pt_theory(G, N, B)
    floor = kd.Contact(A, kd.Plane(N, O, N.z, name="floor"), mu_k=0.3, restitution=0.5,
                       restitution_law=law, name="floor-A")
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=[a.diff() - b for a, b in zip(q, u)],
                  bodies=[rod], loads=[(G, -9.81 * N.z)], contacts=[floor])
    model = eom.numeric(backend="c")
    y0 = np.array([0.0, 0.0, 0.5 * np.sin(0.6) + 0.01, -0.6, 1.0, 1.0, -1.0, 0.0])
    _IN_SPACE[law] = (model, y0, model.export_fmu(folder / f"rod-in-space-{law}.fmu", y0))
    return _IN_SPACE[law]


@pytest.mark.parametrize("law", ["poisson", "newton"])
@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_contact_fmu_impact_whose_slip_turns(kind, law, folder):
    """Impacts whose slip turns during the impulse (the slip across the rod's plane
    meets an inverse inertia that differs along and across it), integrated over the
    normal impulse in the FMU as in kd.simulate; 20 impacts in 1 s, the bounces
    shrinking geometrically.  Measured 1.8e-9 / 1.4e-9 (co-simulation, Poisson /
    Newton), 2.2e-9 / 1.4e-9 (model exchange, CVODE at 1e-13; at 1e-12: 1.8e-7 /
    1.2e-3)."""
    model, y0, path = _rod_in_space(folder, law)
    times, states = _contact_run_of(kind, path, model.state_names, 1.0, rtol=1e-13)
    ref = _contact_reference(model, y0, times)
    # the friction impulse of the first impact is not opposite the slip it met (along
    # (1, 1) / sqrt(2)): the slip turned
    friction = ref.impacts[0].impulses[0][:2]
    slip = np.array([1.0, 1.0]) / np.sqrt(2.0)
    assert len(ref.impacts) > 10 and -friction @ slip < 0.999 * np.hypot(*friction)
    assert np.max(np.abs(states - ref.y)) < 1e-8


# (model, FMI version, end time [s], CVODE's rtol): FMPy's model exchange, the contact
# events located by CVODE on the event indicators; measured 1.3e-9, 3.9e-10, 3.1e-9,
# 3.2e-9 (the same for both versions).  The falling rod over 2 s (47 impacts, 36 of
# both ends at once) at CVODE's rtol 1e-12: 7.2e-4 from 0.88 s on, where its bounces
# shrink geometrically (1e-11: 3.4e-4)
CONTACT_ME_CASES = [("bouncing-ball", 2, 4.0, 1e-13), ("bouncing-ball", 3, 4.0, 1e-13),
                    ("block-on-incline", 3, 3.0, 1e-12), ("falling-rod", 2, 2.0, 1e-13),
                    pytest.param("slug-ellipsoid", 2, 8.0, 1e-12, marks=pytest.mark.slow)]


@pytest.mark.parametrize("name, fmi_version, t_end, rtol", CONTACT_ME_CASES)
def test_contact_fmu_model_exchange_equals_simulate(name, fmi_version, t_end, rtol, folder):
    definition, model, y0, path = _exported(name, folder, fmi_version)
    assert validate_fmu(str(path)) == []
    result = fmpy.simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=t_end,
                               output_interval=0.01, output=list(model.state_names),
                               relative_tolerance=rtol, record_events=False)
    times = result["time"]
    ref = _contact_reference(model, y0, times)
    assert ref.mode_history or ref.impacts
    states = np.array([result[n] for n in model.state_names])
    assert np.max(np.abs(states - ref.y)) < 1e-8


@pytest.mark.parametrize("name, t_end, rtol", [("bouncing-ball", 4.0, 1e-13),
                                                ("block-on-incline", 3.0, 1e-12)])
def test_contact_fmu_model_exchange_event_times(name, t_end, rtol, folder):
    """The times of the events FMPy's CVODE locates on the indicators (recorded twice
    in its result: before and after) are kd.simulate's impact and mode-change times
    (measured within 1.2e-10 on the ball's 19 impacts).  Where the block starts to
    slip, CVODE finds the new slip's stop indicator at rounding level 1.7e-14 s
    later (the slip speed -1.5e-14 m/s): an event that changes nothing (the slip
    stops, cannot stick, slides on), counted with the first."""
    definition, model, y0, path = _exported(name, folder, 2)
    result = fmpy.simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=t_end,
                               output_interval=0.01, output=list(model.state_names),
                               relative_tolerance=rtol, record_events=True)
    times = result["time"]
    events = np.unique(times[:-1][np.diff(times) == 0])
    events = events[np.r_[True, np.diff(events) > 1e-9]]
    ref = kd.simulate(model, (0.0, t_end), y0, rtol=CONTACT_TOL, atol=CONTACT_TOL)
    expected = np.unique([i.t for i in ref.impacts] + [c.t for c in ref.mode_history])
    assert len(expected) >= 3 and events.shape == expected.shape
    assert np.max(np.abs(events - expected)) < 1e-8


@pytest.mark.parametrize("fmi_version", VERSIONS)
@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_contact_fmu_mode_outputs(kind, fmi_version, folder):
    """The output ``incline.mode`` (0 separated, 1 sliding, 2 sticking) follows
    kd.simulate's modes at the output times: slip, stick, slip, lift-off."""
    _, model, y0, path = _exported("block-on-incline", folder, fmi_version)
    result = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=3.0, output_interval=0.1,
                               output=["incline.mode"], relative_tolerance=1e-12,
                               record_events=False)
    ref = _contact_reference(model, y0, result["time"])
    codes = {"separated": 0, "slip": 1, "stick": 2}
    expected = [codes[mode] for mode in ref.contact_forces["incline"]["mode"]]
    assert len(set(expected)) == 3
    assert list(result["incline.mode"]) == expected


def test_contact_fmu_event_indicators(folder):
    """Two event indicators per contact: FMI 2.0 counts them, FMI 3.0 declares them
    as variables."""
    from fmpy import read_model_description
    _, model, _, path = _exported("falling-rod", folder, 2)
    description = read_model_description(str(path))
    assert description.numberOfEventIndicators == 4
    assert description.modelExchange is not None and description.coSimulation is not None
    _, model, _, path = _exported("bouncing-ball", folder, 3)
    description = read_model_description(str(path))
    names = [v.variable.name for v in description.eventIndicators]
    assert names == ["floor.event_indicator_1", "floor.event_indicator_2"]


@pytest.mark.parametrize("fmi_version", VERSIONS)
def test_contact_fmu_sources_compile_strictly(fmi_version, folder, tmp_path):
    """The sources in the archive build on their own (C99, no warnings)."""
    import subprocess
    import zipfile
    _, _, _, path = _exported("falling-rod", folder, fmi_version)
    with zipfile.ZipFile(path) as archive:
        archive.extractall(tmp_path)
    cc = shutil.which("cc") or shutil.which("gcc")
    for name in ("model.c", f"fmi{fmi_version}.c"):
        done = subprocess.run([cc, "-c", "-std=c99", "-Wall", "-Werror", "-pedantic",
                               str(tmp_path / "sources" / name), "-o",
                               str(tmp_path / (name + ".o"))], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr


def test_bilateral_contacts_are_refused_naming_them(folder):
    import sympy.physics.mechanics as me
    q, u = me.dynamicsymbols("x y z"), me.dynamicsymbols("u_x u_y u_z")
    N, O = me.ReferenceFrame("N"), me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q[0] * N.x + q[1] * N.y + q[2] * N.z)
    P.set_vel(N, u[0] * N.x + u[1] * N.y + u[2] * N.z)
    shell = kd.Contact(P, kd.Sphere(N, O, 1.0, inside=False), kind="bilateral", name="shell")
    eom = kd.kane(frame=N, q_ind=q, u_ind=u, kd_eqs=[a.diff() - b for a, b in zip(q, u)],
                  bodies=[me.Particle("p", P, 1.0)], contacts=[shell])
    with pytest.raises(ModelError, match="contact shell: it is bilateral"):
        eom.numeric().export_fmu(folder / "shell.fmu", [1, 0, 0, 0, 1, 0])


def test_a_file_name_without_fmu_is_refused(folder):
    definition = kd.models.build("pendulum")
    model = definition.numeric(backend="numpy")
    with pytest.raises(OptionError, match="must end in .fmu"):
        model.export_fmu(folder / "pendulum.zip", definition.initial(model))
    with pytest.raises(OptionError, match="atol"):
        model.export_fmu(folder / "pendulum.fmu", definition.initial(model), atol=-1.0)
    with pytest.raises(OptionError, match="nominals names 'theta', which is not a state"):
        model.export_fmu(folder / "pendulum.fmu", definition.initial(model),
                         nominals={"theta": 0.1})
    with pytest.raises(OptionError, match="nominal value of q must be a finite number > 0"):
        model.export_fmu(folder / "pendulum.fmu", definition.initial(model),
                         nominals={"q": 0.0})
    with pytest.raises(OptionError, match="fmi_version must be 2 or 3.*'3.0'"):
        model.export_fmu(folder / "pendulum.fmu", definition.initial(model),
                         fmi_version="3.0")


def test_cli_export(tmp_path, capsys):
    out = tmp_path / "pendulum.fmu"
    assert main(["export", "pendulum", "--fmu", str(out), "--set", "l=2.5", "--set",
                 "q=0.4", "--quiet"]) == 0
    assert "wrote" in capsys.readouterr().out
    assert validate_fmu(str(out)) == []
    from fmpy import read_model_description
    variables = {v.name: v for v in read_model_description(str(out)).modelVariables}
    assert float(variables["l"].start) == 2.5 and float(variables["q"].start) == 0.4


def test_cli_export_fmi3(tmp_path, capsys):
    out = tmp_path / "pendulum.fmu"
    assert main(["export", "pendulum", "--fmu", str(out), "--fmi-version", "3",
                 "--set", "l=2.5", "--nominal", "q=0.5", "--quiet"]) == 0
    assert "FMI 3.0" in capsys.readouterr().out
    assert validate_fmu(str(out)) == []
    from fmpy import read_model_description
    description = read_model_description(str(out))
    assert description.fmiVersion == "3.0"
    variables = {v.name: v for v in description.modelVariables}
    assert float(variables["l"].start) == 2.5 and float(variables["q"].nominal) == 0.5


@pytest.mark.parametrize("argv, message", [
    (["--fmu", "out.zip"], "--fmu out.zip: the file name must end in .fmu"),
    (["--fmu", "out.fmu", "--set", "nope=1"], "--set nope: not an option, parameter"),
    (["--fmu", "out.fmu", "--fmi-version", "1"], "--fmi-version: invalid choice: 1"),
    (["--fmu", "out.fmu", "--nominal", "theta=0.1"], "--nominal theta: not a state of"),
    (["--fmu", "out.fmu", "--nominal", "q=-1"], "--nominal q: '-1' is not a positive"),
])
def test_cli_export_bad_input(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["export", "pendulum", *argv, "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out.fmu").exists()


def test_cli_export_contacts(tmp_path, capsys):
    assert main(["export", "bouncing-ball", "--fmu", str(tmp_path / "b.fmu"),
                 "--quiet"]) == 0
    assert "1 contacts" in capsys.readouterr().out
    assert validate_fmu(str(tmp_path / "b.fmu")) == []
