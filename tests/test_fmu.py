"""FMU export (FMI 2.0): FMPy validates the FMUs and simulates them as model exchange
(CVODE) and co-simulation; the results are compared with ``kd.simulate``."""

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


def _exported(name, folder, **options):
    """(definition, model, y0, path of its FMU), built once per model and options."""
    key = (name, tuple(sorted(options.items())))
    if key not in _BUILT:
        definition = kd.models.build(name, **options)
        model = definition.numeric(backend="c")
        y0 = model.state(definition.initial(model))
        path = model.export_fmu(folder / f"{name}-{len(_BUILT)}.fmu", y0,
                                t_end=definition.t_end,
                                constant_units=definition.constant_units)
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


def _fmu_run(path, names, kind, t_end, dt, start_values=TIGHT, **options):
    if kind == "ModelExchange":
        options = {"relative_tolerance": 1e-12, **options}
    result = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=t_end, output_interval=dt,
                               output=list(names), record_events=False,
                               start_values=start_values, **options)
    return np.array([result[n] for n in names])


# (model, end time [s], output interval [s], model exchange's bound): the bound of
# model exchange is CVODE's accuracy at rtol = 1e-12 (measured 4e-10 pendulum,
# 1.2e-8 four-bar, 1.1e-10 bicycle, 3.0e-8 flexible robot); co-simulation, the
# FMU's own Dormand-Prince at 1e-12, is within 1e-9 (measured 9e-12, 3.6e-11,
# 8e-13, ...)
CASES = [("pendulum", 2.0, 0.1, 1e-9), ("four-bar", 2.0, 0.1, 5e-8),
         ("whipple-bicycle", 2.0, 0.1, 1e-9),
         pytest.param("flexible-robot", 1.0, 0.01, 1e-7, marks=pytest.mark.slow)]


@pytest.mark.parametrize("name, t_end, dt, me_bound", CASES)
def test_fmu_validates_and_equals_simulate(name, t_end, dt, me_bound, folder):
    _, model, y0, path = _exported(name, folder)
    assert validate_fmu(str(path)) == []
    expected = _reference(model, y0, t_end, dt)
    names = model.state_names
    cs = _fmu_run(path, names, "CoSimulation", t_end, dt)
    assert np.max(np.abs(cs - expected)) < 1e-9
    me = _fmu_run(path, names, "ModelExchange", t_end, dt)
    assert np.max(np.abs(me - expected)) < me_bound


def test_model_exchange_derivatives_are_model_rhs(folder):
    """The FMU's derivatives at states set through FMI are model.rhs's (round-off)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model
    _, model, y0, path = _exported("four-bar", folder)
    description = read_model_description(str(path))
    fmu = FMU2Model(guid=description.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=description.modelExchange.modelIdentifier,
                    instanceName="check")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.enterContinuousTimeMode()
    n = model.n_states
    rng = np.random.default_rng(3)
    for _ in range(4):
        y = model.consistent_state(0.0, y0 + rng.uniform(-0.2, 0.2, n))
        t = float(rng.uniform(0, 2))
        fmu.setTime(t)
        fmu.setContinuousStates((ctypes.c_double * n)(*y), n)
        out = (ctypes.c_double * n)()
        fmu.getDerivatives(out, n)
        expected = model.rhs(t, y)
        assert np.allclose(np.array(out), expected, rtol=1e-12, atol=1e-12)
    fmu.terminate()
    fmu.freeInstance()


def test_constrained_initial_state_is_made_consistent(folder):
    """A start value of a dependent coordinate is a guess: completed at initialization
    (as kd.simulate completes it)."""
    _, model, y0, path = _exported("four-bar", folder)
    guess = dict(zip(model.state_names, y0))
    guess.update({"q2": y0[1] + 0.05, "q1": 1.0})
    t_end, dt = 0.5, 0.1
    expected = _reference(model, model.state(dict(guess)), t_end, dt)
    got = _fmu_run(path, model.state_names, "CoSimulation", t_end, dt,
                   start_values={**TIGHT, "q1": 1.0, "q2": guess["q2"]})
    assert np.max(np.abs(got - expected)) < 1e-9


def test_parameters_change_the_result_as_constants_do(folder):
    _, model, y0, path = _exported("pendulum", folder)
    t_end, dt = 2.0, 0.1
    expected = _reference(model.with_constants({"l": 1.7}), y0, t_end, dt)
    default = _reference(model, y0, t_end, dt)
    assert np.max(np.abs(expected - default)) > 1e-2  # the parameter matters
    for kind in ("CoSimulation", "ModelExchange"):
        got = _fmu_run(path, model.state_names, kind, t_end, dt,
                       start_values={**TIGHT, "l": 1.7})
        assert np.max(np.abs(got - expected)) < 1e-9


def test_inputs_equal_simulate_with_the_same_input(folder):
    """A staircase torque signal: its steps are FMPy's input events (model exchange:
    event mode, then CVODE restarted; co-simulation: communication points), the value
    held between them; kd.simulate run piece by piece with each value."""
    _, model, y0, path = _exported("pendulum", folder, torque=True)
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


def test_contacts_are_refused_naming_them(folder):
    model = kd.models.build("bouncing-ball").numeric(backend="numpy")
    with pytest.raises(ModelError, match=r"contacts \(floor\)"):
        model.export_fmu(folder / "ball.fmu", np.zeros(model.n_states))


def test_a_file_name_without_fmu_is_refused(folder):
    definition = kd.models.build("pendulum")
    model = definition.numeric(backend="numpy")
    with pytest.raises(OptionError, match="must end in .fmu"):
        model.export_fmu(folder / "pendulum.zip", definition.initial(model))
    with pytest.raises(OptionError, match="atol"):
        model.export_fmu(folder / "pendulum.fmu", definition.initial(model), atol=-1.0)


def test_cli_export(tmp_path, capsys):
    out = tmp_path / "pendulum.fmu"
    assert main(["export", "pendulum", "--fmu", str(out), "--set", "l=2.5", "--set",
                 "q=0.4", "--quiet"]) == 0
    assert "wrote" in capsys.readouterr().out
    assert validate_fmu(str(out)) == []
    from fmpy import read_model_description
    variables = {v.name: v for v in read_model_description(str(out)).modelVariables}
    assert float(variables["l"].start) == 2.5 and float(variables["q"].start) == 0.4


@pytest.mark.parametrize("argv, message", [
    (["--fmu", "out.zip"], "--fmu out.zip: the file name must end in .fmu"),
    (["--fmu", "out.fmu", "--set", "nope=1"], "--set nope: not an option, parameter"),
])
def test_cli_export_bad_input(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["export", "pendulum", *argv, "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out.fmu").exists()


def test_cli_export_refuses_contacts(tmp_path, capsys):
    assert main(["export", "bouncing-ball", "--fmu", str(tmp_path / "b.fmu"),
                 "--quiet"]) == 2
    assert "contacts (floor)" in capsys.readouterr().err
    assert not (tmp_path / "b.fmu").exists()
