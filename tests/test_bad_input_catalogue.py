"""The catalogue of bad input: each kind gets its exception type and a message
that names the culprit (body, symbol, option, file).  Runs in seconds."""

import errno
import hashlib
import json
import os
import re
import struct
import warnings


import zipfile
from dataclasses import replace

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.cli import main
from kanedyn.numerics.backends import CompilerError


from kanedyn.io import load_data


def _spring():
    """A particle on a spring along N.x: q, u; constants m, k; input F."""
    q, u, F = me.dynamicsymbols("q u F")
    m, k = sm.symbols("m k")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x)
    P.set_vel(N, u * N.x)
    args = dict(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                bodies=[me.Particle("bob", P, m)], loads=[(P, (F - k * q) * N.x)])
    return args, (q, u, F, m, k, N, O, P)


def test_model_values_given_as_text_are_never_run(tmp_path):
    """Every value of a model that SymPy would parse (and so run as Python) when
    given as text is refused, naming it: the potential energy, a contact's
    coefficients, a surface's size; the engine converts strictly as well."""
    marker = tmp_path / "ran"
    payload = f"__import__('pathlib').Path({str(marker)!r}).touch() or 1"
    model, (_q, _u, _F, _m, _k, N, O, P) = _spring()
    with pytest.raises(kd.ModelError, match="^potential_energy is the text"):
        kd.kane(**model, potential_energy=payload)
    with pytest.raises(kd.ModelError, match="^potential_energy must be a number or a SymPy "
                                            "expression, got Vector"):
        kd.kane(**model, potential_energy=N.x)
    floor = kd.Plane(N, O, N.z)
    for option in ("mu_k", "mu_s", "viscous", "restitution"):
        with pytest.raises(kd.ModelError, match=f": {option} is the text"):
            kd.Contact(P, floor, **{option: payload})
    with pytest.raises(kd.ModelError, match="surface sphere: radius is the text"):
        kd.Sphere(N, O, payload)
    with pytest.raises(kd.ModelError, match=r"surface sphere: radius must be > 0.0, got -1"):
        kd.Sphere(N, O, -1.0)
    from kanedyn.engine import Program
    with pytest.raises(sm.SympifyError):
        Program(sm.Symbol("t")).declare(sm.Symbol("x"), payload)
    assert not marker.exists()


@pytest.fixture(scope="module")
def spring():
    args, symbols = _spring()
    eom = kd.kane(**args)
    F = symbols[2]
    model = eom.numeric(constants={"m": 1.0, "k": 4.0}, specified={F: 0.0})
    return eom, model, symbols


def _rigid(inertia_of, mass=1, twice=False, rename=False, axis=(0, 0, 1)):
    q, u = me.dynamicsymbols("q u")
    N = me.ReferenceFrame("N")
    direction = (axis[0] * N.x + axis[1] * N.y + axis[2] * N.z).normalize()
    A = N.orientnew("A", "Axis", [q, direction])
    A.set_ang_vel(N, u * direction)
    O = me.Point("O")
    O.set_vel(N, 0)
    body = me.RigidBody("plate", O, A, mass, (inertia_of(A), O))
    bodies = [body, body] if twice else [body]
    if rename:
        other = me.RigidBody("plate", O, A, 1, (me.inertia(A, 1, 1, 1), O))
        bodies = [body, other]
    return dict(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u], bodies=bodies)


def _particle(mass):
    args, _ = _spring()
    P = args["bodies"][0].point
    return dict(args, bodies=[me.Particle("bob", P, mass)], loads=[])


# ------------------------------------------------- models: physically impossible
MODEL_CASES = {
    "negative particle mass": (lambda: _particle(-2), "'bob' has a negative mass"),
    "zero particle mass": (lambda: _particle(0), "particle 'bob' is declared with zero mass"),
    "negative body mass": (lambda: _rigid(lambda A: me.inertia(A, 1, 1, 1), mass=-1),
                           "'plate' has a negative mass"),
    "indefinite inertia": (lambda: _rigid(lambda A: me.inertia(A, 1, -2, 1)),
                           "'plate'.*not positive semidefinite"),
    "triangle inequality": (lambda: _rigid(lambda A: me.inertia(A, 1, 1, 5)),
                            "'plate'.*triangle inequality"),
    "non-symmetric inertia": (lambda: _rigid(lambda A: me.inertia(A, 1, 1, 1)
                                             + me.outer(A.x, A.y)),
                              "'plate'.*not symmetric"),
    "body listed twice": (lambda: _rigid(lambda A: me.inertia(A, 1, 1, 1), twice=True),
                          "'plate' is listed twice"),
    "two bodies one name": (lambda: _rigid(lambda A: me.inertia(A, 1, 1, 1), rename=True),
                            "two bodies are named 'plate'"),
    "kd_eqs as text": (lambda: dict(_spring()[0], kd_eqs=["q' - u"]),
                       r"kd_eqs\[0\] is the text"),
    "kd_eqs as inequality": (lambda: dict(_spring()[0], kd_eqs=[
        sm.Gt(me.dynamicsymbols("q").diff(), 0)]), r"kd_eqs\[0\] is .*Eq\(a, b\)"),
}


@pytest.mark.parametrize("case", sorted(MODEL_CASES))
def test_impossible_model_refused(case):
    make, pattern = MODEL_CASES[case]
    with pytest.raises(kd.ModelError, match=pattern):
        kd.kane(**make())


def test_planar_inertia_shorthand_is_accepted():
    """inertia(A, 0, 0, Izz), as planar models write it, is not refused."""
    eom = kd.kane(**_rigid(lambda A: me.inertia(A, 0, 0, 2)))
    assert eom.mass_matrix == sm.Matrix([[2]])


def test_kinematic_equations_as_equations():
    """Eq(q', u) means q' - u = 0, as an expression would."""
    args, (q, u, *_rest) = _spring()
    as_eq = kd.kane(**dict(args, kd_eqs=[sm.Eq(q.diff(), u)]))
    plain = kd.kane(**args)
    assert as_eq.mass_matrix_full == plain.mass_matrix_full
    assert sm.simplify(as_eq.forcing_full - plain.forcing_full) == sm.zeros(2, 1)


# ----------------------------------------------------- values for numeric()
def test_impossible_values_refused(spring):
    eom, _, (q, u, F, m, k, *_r) = spring
    with pytest.raises(kd.ModelError, match=r"'bob' has a negative mass, -1 kg \(with m = -1\)"):
        eom.numeric(constants={"m": -1.0, "k": 1.0}, specified={F: 0.0})


def test_impossible_inertia_value_refused():
    Ixx, Izz = sm.symbols("Ixx Izz")
    eom = kd.kane(**_rigid(lambda A: me.inertia(A, Ixx, Ixx, Izz), axis=(1, 0, 1)))
    assert set(eom.constants) == {Ixx, Izz}
    eom.numeric(constants={"Izz": 2.0, "Ixx": 1.0})  # a thin disc: I1 + I2 = I3
    with pytest.raises(kd.ModelError, match="'plate'.*triangle inequality.*Izz = 5"):
        eom.numeric(constants={"Izz": 5.0, "Ixx": 1.0})


VALUE_CASES = {
    "constants as a list": (dict(constants=[1.0, 4.0]), kd.ModelError,
                            "constants must be a dict .* not a list.*k, m"),
    "infinite constant": (dict(constants={"m": 1.0, "k": np.inf}), kd.ModelError,
                          "k = inf not finite"),
    "nan constant": (dict(constants={"m": np.nan, "k": 1.0}), kd.ModelError,
                     "m = nan not finite"),
    "unknown backend": (dict(constants={"m": 1.0, "k": 1.0}, backend="fortran"),
                        kd.ModelError, "unknown backend 'fortran'"),
}


@pytest.mark.parametrize("case", sorted(VALUE_CASES))
def test_bad_numeric_values(spring, case):
    eom, _, (q, u, F, *_r) = spring
    kwargs, error, pattern = VALUE_CASES[case]
    kwargs = dict(kwargs)
    kwargs.setdefault("specified", {F: 0.0})
    with pytest.raises(error, match=pattern):
        eom.numeric(**kwargs)


def test_input_returning_an_array(spring):
    eom, _, (q, u, F, *_r) = spring
    model = eom.numeric(constants={"m": 1.0, "k": 1.0},
                        specified={F: lambda t: np.array([1.0, 2.0])})
    with pytest.raises(kd.ModelError, match=r"specified input F\(t\).* must return one real"):
        model.rhs(0.0, np.zeros(2))


def test_state_of_wrong_length(spring):
    _, model, _ = spring
    with pytest.raises(ValueError, match=r"2 entries \(q, u\), got shape \(3,\)"):
        model.rhs(0.0, np.zeros(3))


def test_input_function_without_argument_and_equations_instead_of_a_model(spring):
    eom, _, (q, u, F, *_r) = spring
    with pytest.raises(kd.ModelError, match=r"specified input F\(t\): its function .* takes "
                                            r"no argument; give f\(t\) or f\(t, y\)"):
        eom.numeric(constants={"m": 1.0, "k": 4.0}, specified={F: lambda: 1.0})
    with pytest.raises(TypeError, match=r"simulate needs a numerical model, got "
                                        r"EquationsOfMotion: make one with \.numeric"):
        kd.simulate(eom, (0.0, 1.0), [1.0, 0.0])


def test_coordinate_left_out_of_q_ind_is_pointed_at():
    """A function of time in the kinematics that is neither a coordinate nor
    given is an input; when its rates appear, the message says it may be a
    coordinate left out of q_ind."""
    q1, q2, u1 = me.dynamicsymbols("q1 q2 u1")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q1, N.z])
    B = A.orientnew("B", "Axis", [q2, A.z])
    A.set_ang_vel(N, u1 * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    eom = kd.kane(frame=N, q_ind=[q1], u_ind=[u1], kd_eqs=[q1.diff() - u1],
                  bodies=[me.Particle("p", O.locatenew("P", A.x + B.x), 1)])
    with pytest.raises(kd.MissingValueError, match=r"missing value for the specified input "
                       r"q2\(t\); .*; if q2\(t\) is a coordinate, list it in q_ind"):
        eom.numeric()


@pytest.mark.parametrize("given", ["list", "dict"])
def test_initial_state_not_finite(spring, given):
    """A ``nan`` initial value is refused naming the state, whether the state
    is given as a list or by name."""
    _, model, _ = spring
    y0 = [np.nan, 0.0] if given == "list" else {"q": np.nan, "u": 0.0}
    with pytest.raises(ValueError, match="^initial values are not finite for q$"):
        kd.simulate(model, (0.0, 1.0), y0)


def test_state_value_that_is_not_a_number(spring):
    eom, model, _ = spring
    with pytest.raises(ValueError, match="^initial value of q must be a number, got 'abc'$"):
        kd.simulate(model, (0.0, 1.0), {"q": "abc", "u": 0.0})
    with pytest.raises(ValueError, match="^operating-point value of q must be a number"):
        eom.linearize(op_point={"q": "abc", "u": 0.0}, constants={"m": 1.0, "k": 4.0},
                      specified={"F": 0.0})


# ------------------------------------------------------ simulate() options
def _event(t, y):
    return y[0]


def _vector_event(t, y):
    return y


def _event_of_y(y):
    return y[0]


SIMULATE_CASES = {
    "zero rtol": (dict(rtol=0.0), "rtol must be a positive number"),
    "negative rtol": (dict(rtol=-1e-6), "rtol must be a positive number"),
    "negative atol": (dict(atol=-1e-6), "atol must be positive"),
    "zero atol": (dict(atol=0.0), "atol must be positive"),
    "atol of wrong length": (dict(atol=[1e-8, 1e-8, 1e-8]), r"atol .* one per state \(2\)"),
    "nan end time": (dict(t_span=(0.0, np.nan)), r"t_span must be finite, got \(0.0, nan\)"),
    "infinite end time": (dict(t_span=(0.0, np.inf)), "t_span must be finite"),
    "text end time": (dict(t_span=(0.0, "1; rm -rf")), "t_span must be two numbers"),
    "negative max_step": (dict(max_step=-0.1), "max_step must be positive"),
    "zero max_step": (dict(max_step=0.0), "max_step must be positive"),
    "first_step beyond span": (dict(first_step=5.0), "first_step 5.0 is longer"),
    "t_eval outside span": (dict(t_eval=[0.0, 0.5, 1.5]), r"1 of the 3 t_eval points lie "
                            r"outside t_span \(0, 1\), e.g. 1.5"),
    "t_eval unsorted": (dict(t_eval=[0.0, 0.7, 0.5]), "t_eval must be strictly increasing"),
    "t_eval forward on a backward run": (dict(t_span=(1.0, 0.0), t_eval=[0.0, 1.0]),
                                         "strictly decreasing"),
    "unknown method": (dict(method="Euler"), "unknown method 'Euler'"),
    "vector-valued event": (dict(events=[_event, _vector_event]),
                            r"event _vector_event returned an array of shape \(2,\)"),
    "event with wrong signature": (dict(events=_event_of_y),
                                   r"event _event_of_y must take \(t, y\)"),
    "event not callable": (dict(events=[3.0]), r"events\[0\] is not callable"),
    "misspelt tolerance": (dict(rtoll=1e-3), "unknown option 'rtoll' of simulate; did you "
                           "mean 'rtol'"),
    "misspelt dense output": (dict(dense_ouput=True), "did you mean 'dense_output'"),
    "contact option without contacts": (dict(modes=["stick"]), "option 'modes' applies to "
                                        "models with contacts only"),
}


@pytest.mark.parametrize("backend", ["numpy", "c"])
@pytest.mark.parametrize("case", sorted(SIMULATE_CASES))
def test_bad_simulate_options(spring, case, backend):
    eom, model, (q, u, F, *_r) = spring
    if backend == "c":
        model = _c_spring(eom, F)
    kwargs = dict(SIMULATE_CASES[case][0])
    t_span = kwargs.pop("t_span", (0.0, 1.0))
    with pytest.raises(kd.OptionError, match=SIMULATE_CASES[case][1]):
        kd.simulate(model, t_span, [1.0, 0.0], **kwargs)


_C_MODELS = {}


def _c_spring(eom, F):
    if "c" not in _C_MODELS:
        _C_MODELS["c"] = eom.numeric(constants={"m": 1.0, "k": 4.0}, specified={F: 0.0},
                                     backend="c")
    return _C_MODELS["c"]


# ----------------------------------------------------------------- the CLI
CLI_CASES = {
    "code in a parameter value": (["run", "pendulum", "--set", "m=__import__('os').getpid()"],
                                  "--set m: .* is not a number"),
    "text that is not a number": (["run", "pendulum", "--set", "m=heavy"],
                                  "--set m: 'heavy' is not a number"),
    "infinite parameter": (["run", "pendulum", "--set", "m=1e999"],
                           "--set m: '1e999' is not a finite number"),
    "negative mass": (["run", "pendulum", "--set", "m=-1"], "'bob' has a negative mass"),
    "unknown name": (["run", "pendulum", "--set", "mass=2"],
                     "--set mass: not an option, parameter or state of pendulum"),
    "option of the wrong type": (["run", "chain3d", "--set", "n=two"],
                                 "option n of chain3d is a whole number, got 'two'"),
    "float option as code": (["run", "ladder", "--set", "angle=().__class__"],
                             "option angle of ladder: .* is not a number"),
    "missing equals sign": (["run", "pendulum", "--set", "m"], "--set expects name=value"),
    "oc3-operating wind list not numbers": (
        ["study", "oc3-operating", "--set", "wind_speeds=rated"],
        "oc3-operating: wind_speeds must be numbers in m/s"),
    "oc3-operating wind out of the operating range": (
        ["study", "oc3-operating", "--set", "wind_speeds=11.4,30"],
        "oc3-operating: wind_speeds must be one or more operating winds"),
    "oc3-campbell one speed": (["study", "oc3-campbell", "--set", "n_speeds=1"],
                               "oc3-campbell: n_speeds must be at least 2"),
    "derive with a value": (["derive", "pendulum", "--set", "m=2"],
                            "derive takes only model options"),
    "unknown formulation": (["compare", "pendulum", "--methods", "kane,hamilton"],
                            "unknown formulation.*hamilton"),
    "damping ratio given in per cent": (["run", "oc3-spar", "--set", "tower_damping=1"],
                                        r"option tower_damping is the tower's structural "
                                        r"damping ratio, a fraction of critical in \[0, 1\) "
                                        r"\(0.01 is the published 1 %\), got 1.0"),
    "negative damping ratio": (["run", "oc3-spar", "--set", "tower_damping=-0.01"],
                               "option tower_damping .* got -0.01"),
    "unknown damping reference": (["run", "oc3-spar", "--set",
                                   "tower_damping_reference=loaded"],
                                  "option tower_damping_reference must be one of isolated, "
                                  "with_rna, got 'loaded'"),
    "FMU nominal of a state the model lacks": (["export", "bouncing-ball", "--fmu", "ball.fmu",
                                                "--nominal", "q9=1"],
                                               "--nominal q9: not a state of bouncing-ball; "
                                               "its states: x, z, u_x, u_z"),
    "FMU file name without .fmu": (["export", "pendulum", "--fmu", "pendulum.zip"],
                                   r"--fmu .*pendulum\.zip: the file name must end in \.fmu"),
    "FMU with an unknown --set name": (["export", "pendulum", "--fmu", "p.fmu", "--set",
                                        "mass=2"],
                                       "--set mass: not an option, parameter or state of "
                                       "pendulum"),
    "controller without a spinning rotor": (["run", "oc3-spar", "--set", "controller=on"],
                                            "option controller=on needs rotor=spinning"),
    "unknown rotor": (["run", "oc3-spar", "--set", "rotor=flexible"],
                      "option rotor must be one of rigid, spinning, got 'flexible'"),
    "wind past cut-out for the spinning rotor": (
        ["run", "oc3-spar", "--set", "rotor=spinning", "--set", "wind_speed=30"],
        "with rotor=spinning, option wind_speed must be 0 .* or from cut-in 3 to cut-out "
        "25 m/s, got 30.0"),
    "negative hub damping": (["run", "flexible-robot", "--set", "hub_damping=-1"],
                             r"flexible-robot: hub_damping must be a finite number >= 0 "
                             r"\(N m s/rad\), got -1"),
    "negative beam stiffness": (["run", "spin-up-beam", "--set", "EI=-1"],
                                r"spin-up-beam: EI must be a finite number > 0 \(N m\^2\), "
                                r"got -1"),
    "zero link length": (["run", "flexible-robot", "--set", "length=0"],
                         r"flexible-robot: length must be a finite number > 0 \(m\), got 0"),
    "a word in a platform wrench": (
        ["inverse", "out-parallel-6dof", "--quiet", "--wrench", "1,2,x,0,0,0"],
        "--wrench 1,2,x,0,0,0: Fz = 'x' is not a finite number"),
    "a platform wrench of five numbers": (
        ["inverse", "out-parallel-6dof", "--quiet", "--wrench", "1,2,3,4,5"],
        r"--wrench 1,2,3,4,5: give six numbers Fx,Fy,Fz,Mx,My,Mz \[N, N m\] or a .csv file"),
    "a pose file that is not there": (
        ["inverse", "out-parallel-6dof", "--quiet", "--poses", "no-such-poses.csv"],
        r"--poses: pose file no-such-poses.csv: cannot read it \(No such file"),
    "a pose file with a named trajectory": (
        ["inverse", "out-parallel-6dof", "--quiet", "--poses", "p.csv", "--trajectory",
         "sinusoid"],
        r"--poses p.csv: the pose file sets the trajectory and its times; drop --trajectory"),
    "an actuator limit that is not a quantity": (
        ["inverse", "out-parallel-6dof", "--quiet", "--limit", "forse=100"],
        r"--limit forse=100: 'forse=100' is not QUANTITY=VALUE with QUANTITY one of force, "),
    "a negative actuator limit": (
        ["inverse", "out-parallel-6dof", "--quiet", "--limit", "force=-1"],
        r"--limit force=-1: force = '-1' is not a finite number > 0"),
    "a machine file for another model": (
        ["inverse", "stewart-platform", "--quiet", "--machine", "m.toml"],
        r"--machine m.toml: machine files describe out-parallel-6dof, not stewart-platform"),
    "a machine file that is not there": (
        ["inverse", "out-parallel-6dof", "--quiet", "--machine", "no-such-machine.toml"],
        r"--machine: machine file no-such-machine.toml: cannot read it"),
}


def _flexible_bar():
    member = kd.flexible.BeamMember.uniform("bar", 2.0, mass_per_length=1.0, EA=1e6, GJ=1e3,
                                            EI_y=1e3, EI_z=1e3, polar_inertia=1e-3,
                                            n_elements=2)
    return member.craig_bampton(n_modes=2)


#: structural damping of a flexible member: the value refused, the option named
DAMPING_CASES = {
    "ratio not a number": (lambda m, N, O: kd.FlexibleBody("arm", N, O, m,
                                                           modal_damping=float("nan")),
                           "flexible body 'arm': modal_damping must be finite and not "
                           "negative"),
    "ratio in per cent": (lambda m, N, O: kd.FlexibleBody("arm", N, O, m, modal_damping=2),
                          r"flexible body 'arm': modal_damping are fractions of critical "
                          r"\(0.01 is 1 %\), got 2"),
    "negative Rayleigh beta": (lambda m, N, O: kd.FlexibleBody("arm", N, O, m,
                                                               rayleigh=(0.0, -1e-3)),
                               "flexible body 'arm': rayleigh coefficients must be finite "
                               "and not negative"),
    "member damping not symmetric": (lambda m, N, O: replace(m, damping=[[1.0, 2.0],
                                                                         [0.0, 1.0]]),
                                     "member 'bar': damping must be symmetric"),
    "member damping that feeds energy": (lambda m, N, O: replace(m, damping=-np.eye(2)),
                                         "member 'bar': damping must be positive "
                                         "semidefinite"),
    "damping given twice": (lambda m, N, O: kd.FlexibleBody(
        "arm", N, O, m.with_damping(ratios=0.01), modal_damping=0.01),
        "flexible body 'arm': member 'bar' carries its own damping"),
    "OC3 tower damping in per cent": (lambda m, N, O: kd.models.oc3_tower(4, 2, damping=1),
                                      r"oc3 tower: damping must be a fraction of critical "
                                      r"in \[0, 1\)"),
}


@pytest.mark.parametrize("case", sorted(DAMPING_CASES))
def test_bad_structural_damping(case):
    make, pattern = DAMPING_CASES[case]
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    with pytest.raises(kd.ModelError, match=pattern):
        make(_flexible_bar(), N, O)


@pytest.mark.parametrize("case", sorted(CLI_CASES))
def test_bad_command_line(case, capsys, tmp_path):
    argv, pattern = CLI_CASES[case]
    extra = {"run": ["--out", str(tmp_path), "--quiet"], "derive": ["--quiet"],
             "export": ["--quiet"]}
    if argv[0] == "export":  # the FMU's file beside the test's
        argv = [str(tmp_path / a) if a.endswith((".fmu", ".zip")) else a for a in argv]
    assert main(argv + extra.get(argv[0], [])) == 2
    err = capsys.readouterr().err
    assert err.startswith("kanedyn: error: ")
    assert re.search(pattern, err), err


@pytest.mark.parametrize("t_end", ["-3", "0", "nan"])
def test_demo_ride_length_refused_before_any_work(t_end, capsys, tmp_path):
    """``kanedyn demo --t-end`` is checked as ``run``'s is, before the derivation."""
    assert main(["demo", "--t-end", t_end, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"argument --t-end: must be a finite number > 0, got '{t_end}'" in err
    assert not (tmp_path / "out").exists()


# ---- issue 33, item 7: Disk full and bad files
# (pulse records, URDF files, output paths, kinematics, the viewer page)
_GOOD_PULSE = "t [s],ax [g],ay [g],az [g]\n" + "".join(
    f"{i * 1e-3},{-5 * np.sin(i / 3)},0,0\n" for i in range(10))


def _pulse_file(tmp_path, text=_GOOD_PULSE, encoding="utf-8"):
    path = tmp_path / "pulse.csv"
    path.write_text(text, encoding=encoding)
    return path


_UNIT_INERTIA = 'ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"'


def _robot_file(tmp_path, inertia=_UNIT_INERTIA, mass="1", mesh=None):
    """A URDF robot of one moving link 'arm' (its <inertia> on line 4, a mesh on 5)."""
    visual = (f'<visual><geometry><mesh filename="{mesh}"/></geometry></visual>'
              if mesh else "")
    path = tmp_path / "robot" / "robot.urdf"
    path.parent.mkdir(exist_ok=True)
    path.write_text(f"""<robot name="r">
  <link name="base"><inertial><mass value="9"/><inertia {_UNIT_INERTIA}/></inertial></link>
  <link name="arm">
    <inertial><mass value="{mass}"/><inertia {inertia}/></inertial>
    {visual}
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/></joint>
</robot>
""")
    return path


def _load_robot(**file_options):
    """The action of loading :func:`_robot_file` with ``file_options``."""
    return lambda tmp_path: kd.models.from_urdf(_robot_file(tmp_path, **file_options))


def _mesh_outside(tmp_path, name):
    """``mesh_file()`` of a visual that names ``secret.obj`` beside the URDF's folder."""
    secret = tmp_path / "secret.obj"
    secret.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    filename = {"..": "../secret.obj", "absolute": str(secret),
                "file://": f"file://{secret}"}[name]
    (visual,) = kd.models.from_urdf(_robot_file(tmp_path, mesh=filename)).visuals
    return visual.mesh_file()


def _mjcf(text):
    """The action of loading an MJCF file ``model.xml`` of ``text`` (in a folder
    ``model`` beside a file ``secret.xml``)."""
    def load(tmp_path):
        (tmp_path / "secret.xml").write_text("<mujoco><worldbody/></mujoco>")
        path = tmp_path / "model" / "model.xml"
        path.parent.mkdir(exist_ok=True)
        path.write_text(text)
        return kd.models.from_mjcf(path)
    return load


_MJCF_LAUGHS = ('<?xml version="1.0"?>\n<!DOCTYPE mujoco [\n<!ENTITY a "aaaaaaaaaa">\n'
                '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">\n'
                '<!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">\n]>\n<mujoco>&c;</mujoco>\n')
_MJCF_EXTERNAL = ('<?xml version="1.0"?>\n<!DOCTYPE mujoco [\n'
                  '<!ENTITY s SYSTEM "../secret.xml">\n]>\n<mujoco>&s;</mujoco>\n')
_MJCF_ARM = ("<mujoco>\n<default>\n<joint damping='{damping}'/>\n</default>\n<worldbody>\n"
             "<body name='arm'>\n<joint name='j' axis='{axis}'/>\n"
             "<geom type='capsule' size='0.02' fromto='0 0 0 0.3 0 0'/>\n"
             "</body>\n</worldbody>\n{tail}</mujoco>\n")


def _arm(damping="0.1", axis="0 1 0", tail=""):
    return _MJCF_ARM.format(damping=damping, axis=axis, tail=tail)


def _origin_without_velocity():
    q, u = me.dynamicsymbols("q u")
    N = me.ReferenceFrame("N")
    O = me.Point("O")  # its velocity is never set
    P = O.locatenew("P", q * N.x)
    return kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                   bodies=[me.Particle("bob", P, 1.0)])


def _iso_mme_test(tmp_path, sample="1.5E-1"):
    """An ISO-MME test of one vehicle channel whose fifth sample (line 15) is ``sample``."""
    values = [0.0, -0.5, -1.0, -1.5, 0.15, -2.0]
    mme = kd.vehicle.write_iso_mme(tmp_path / "T9", "T9", np.arange(6) * 1e-4,
                                   [("10VEHC0000CGACXP", "vehicle x", "g", values)])
    path = tmp_path / "T9" / "Channel" / "T9.001"
    path.write_text(path.read_text().replace("0.15\n", f"{sample}\n"))
    return mme


BAD_FILE_CASES = {
    "ISO-MME sample that is text": (
        lambda tmp: kd.vehicle.read_iso_mme(_iso_mme_test(tmp, "0,15")), kd.ModelError,
        r"T9\.001: channel 10VEHC0000CGACXP \(ax\), line 15: sample '0,15' is not a "
        r"finite number"),
    "NHTSA CSV cell that is text": (
        lambda tmp: kd.vehicle.read_nhtsa_csv(_pulse_file(tmp, "Time (s),X ACC (G)\n0,1\n"
                                                               "0.001,x\n"), {"ax": "X ACC"}),
        kd.ModelError, r"pulse\.csv: column 'X ACC \(G\)', line 3: 'x' is not a finite"),
    "pulse cell over 128 KB": (
        lambda tmp: kd.vehicle.read_pulse_csv(_pulse_file(tmp, _GOOD_PULSE.replace(
            "\n0.002,", '\n"' + "9" * 140_000 + '",', 1))),
        kd.ModelError, r"pulse\.csv: line 4: a cell longer than 131072 characters"),
    "URDF inertia of 1e308": (
        _load_robot(inertia='ixx="1e308" ixy="1e308" ixz="0" iyy="1e308" iyz="0" izz="1"'),
        kd.models.URDFError, r"robot\.urdf:4: <link name='arm'>: inertia beyond the range "
                             r"of floating point \(principal moments 0, 1, inf kg m\^2\)"),
    "URDF number 1e999": (
        _load_robot(mass="1e999"),
        kd.models.URDFError, r"robot\.urdf:4: <link name='arm'>: <mass value='1e999'>: "
                             "'1e999' is beyond the range of floating point"),
    "URDF triangle inequality": (
        _load_robot(inertia='ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="5"'),
        kd.models.URDFError, r"robot\.urdf:4: <link name='arm'>: the central inertia of its "
                             r"body violates the triangle inequality I1 \+ I2 >= I3 by 3 kg"),
    "URDF inertia indefinite beyond round-off": (
        _load_robot(inertia='ixx="1" ixy="1.001" ixz="0" iyy="1" iyz="0" izz="1"'),
        kd.models.URDFError, r"robot\.urdf:4: <link name='arm'>: inertia is not positive "
                             r"semi-definite by 0\.001 kg m\^2 .*: more than round-off"),
    "URDF mesh named by ../": (
        lambda tmp: _mesh_outside(tmp, ".."), kd.models.URDFError,
        r"robot\.urdf:5: mesh '\.\./secret\.obj' of link 'arm' is not read: .*secret\.obj is "
        r"outside the folders meshes are read from"),
    "URDF mesh named by an absolute path": (
        lambda tmp: _mesh_outside(tmp, "absolute"), kd.models.URDFError,
        r"robot\.urdf:5: mesh '/.*secret\.obj' of link 'arm' is not read: .*give mesh_dirs="),
    "URDF mesh named by file://": (
        lambda tmp: _mesh_outside(tmp, "file://"), kd.models.URDFError,
        r"robot\.urdf:5: mesh 'file:///.*secret\.obj' of link 'arm' is not read"),
    "MJCF billion laughs": (
        _mjcf(_MJCF_LAUGHS), kd.models.MJCFError,
        r"model\.xml:3: entity declarations are not accepted in an MJCF file"),
    "MJCF external entity": (
        _mjcf(_MJCF_EXTERNAL), kd.models.MJCFError,
        r"model\.xml:3: entity declarations are not accepted in an MJCF file"),
    "MJCF include outside its folder": (
        _mjcf(_arm(tail="<include file='../secret.xml'/>\n")), kd.models.MJCFError,
        r"model\.xml:11: <include>: file '\.\./secret\.xml' is outside the folder of the "
        r"main file"),
    "MJCF malformed number": (
        _mjcf(_arm(axis="0 1.0.2 0")), kd.models.MJCFError,
        r"model\.xml:7: <joint name='j'>: axis='0 1\.0\.2 0': '1\.0\.2' is not a number"),
    "MJCF number of a default class": (
        _mjcf(_arm(damping="1e999")), kd.models.MJCFError,
        r"model\.xml:3: <joint> \(a default\): damping='1e999': '1e999' is beyond the "
        "range of floating point"),
    "MJCF unsupported element": (
        _mjcf(_arm(tail="<actuator>\n<muscle name='m' joint='j'/>\n</actuator>\n")),
        kd.models.MJCFError, r"model\.xml:12: <muscle name='m'>: <muscle> actuators are not "
        "supported"),
    "inertia entries of 1e308": (
        lambda tmp: kd.kane(**_rigid(lambda A: me.inertia(A, 1e308, 1e308, 1e308, 1e308))),
        kd.ModelError, r"rigid body 'plate': its principal moments of inertia are beyond "
                       r"the range of floating point \(entries up to 1e\+308 kg m\^2\)"),
    "origin without a velocity": (
        lambda tmp: _origin_without_velocity(), kd.KinematicsError,
        r"velocity of point P in N cannot be found: .* likely the chain's origin O: "
        r"O\.set_vel\(N, 0\)"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILE_CASES))
def test_bad_files_and_paths(case, tmp_path):
    action, error, pattern = BAD_FILE_CASES[case]
    with pytest.raises(error, match=pattern):
        action(tmp_path)


@pytest.mark.parametrize("argv, pattern", [
    (["demo", "--out", "{file}"], r"--out .*given\.txt: .*given\.txt is a file, not a folder"),
    (["derive", "pendulum", "--c", "{folder}", "--quiet"],
     r"--c .*: is a folder; give the name of a file"),
], ids=["demo --out an existing file", "derive --c a folder"])
def test_output_paths_that_cannot_be_written(argv, pattern, capsys, tmp_path):
    (tmp_path / "given.txt").write_text("kept")
    argv = [a.format(file=tmp_path / "given.txt", folder=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("kanedyn: error: ") and err.count("\n") == 1, err
    assert re.search(pattern, err), err
    assert (tmp_path / "given.txt").read_text() == "kept"


def test_accepted_or_warned_of(tmp_path):
    """Inputs that are read correctly, or read with a warning naming the file."""
    # a byte-order mark, as spreadsheet programs write: read as without one
    plain = kd.vehicle.read_pulse_csv(_pulse_file(tmp_path))
    marked = kd.vehicle.read_pulse_csv(_pulse_file(tmp_path, encoding="utf-8-sig"))
    np.testing.assert_array_equal(marked.acceleration, plain.acceleration)
    # a 49 ms half-sine of 20 g (6.1 m/s) with its times in ms labelled [s]
    in_ms = "t [s],ax [g],ay [g],az [g]\n" + "".join(
        f"{i},{-20 * np.sin(np.pi * i / 49)},0,0\n" for i in range(50))
    with pytest.warns(UserWarning, match=r"pulse\.csv: the accelerations imply a speed change "
                      r"of 6116 m/s .* above 100 m/s; if the times are in milliseconds"):
        kd.vehicle.read_pulse_csv(_pulse_file(tmp_path, in_ms))
    # an inertia that is zero to round-off (iCub's head): accepted, named
    with pytest.warns(UserWarning, match=r"robot\.urdf:4: <link name='arm'>: inertia is not "
                      r"positive semi-definite by 2\.41e-35 kg m\^2"):
        kd.models.from_urdf(_robot_file(tmp_path, 'ixx="0" ixy="0" ixz="2.40741e-35" '
                                                  'iyy="0" iyz="0" izz="0"'))
    # a body named '<!--<script>': the page's scene data cannot end its <script>
    from kanedyn.io import page_html
    html = page_html({"title": "t", "bodies": [{"name": "<!--<script>"}]})
    assert '"name":"\\u003c!--\\u003cscript\\u003e"' in html and "<!--<script>" not in html


# ---- issue 33, item 2: a cache no one else can plant code in
# (and from item 7, a cache build on a full disk).  Each case makes the bad cache
# in tmp_path and returns a call; the call warns (the cache or the entry is not
# used) or raises, naming the path with its owner and mode.  The behaviour with a
# second user and a real full disk: tests/test_cache_safety.py.
_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0
_NOBODY = 65534


def _cache_at(path, monkeypatch, mode=0o700):
    path.mkdir(parents=True, exist_ok=True)
    path.chmod(mode)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(path))
    return path


def _module_entry(cache, mode=0o600, owner=None, what="so", acl=False):
    """A module and manifest (of the right checksum) in ``cache``; ``what``
    (``so`` or ``json``) gets ``mode`` and ``owner`` (and with ``acl``, an ACL
    entry that lets nobody write it)."""
    from kanedyn.numerics.backends import _c_build
    so_path, manifest = _c_build._entry(cache, "_kd_planted")
    so_path.write_bytes(b"\x7fELF not a module")
    manifest.write_text(json.dumps({"sha256": hashlib.sha256(so_path.read_bytes()).hexdigest()}))
    bad = so_path if what == "so" else manifest
    bad.chmod(mode)
    if owner is not None:
        os.chown(bad, owner, owner)
    if acl:
        _with_acl(bad)
    return lambda: _c_build._try_cached("_kd_planted", so_path, manifest), bad


def _with_acl(path, default=False):
    """``setfacl -m u:nobody:rw[x]`` (``-d``: the default ACL), written as the
    kernel stores it (no setfacl needed); skips where there are no ACLs."""
    perm = 7 if path.is_dir() else 6
    entries = [(0x01, perm, 0xFFFFFFFF), (0x02, perm, _NOBODY), (0x04, 0, 0xFFFFFFFF),
               (0x10, perm, 0xFFFFFFFF), (0x20, 0, 0xFFFFFFFF)]
    try:
        os.setxattr(path, f"system.posix_acl_{'default' if default else 'access'}",
                    struct.pack("<I", 2) + b"".join(struct.pack("<HHI", *e) for e in entries))
    except (AttributeError, OSError) as exc:
        pytest.skip(f"no POSIX ACLs here ({exc})")
    return path


def _linked_cache(tmp, monkeypatch):
    """KANEDYN_CACHE_DIR names a link of nobody's to a folder of this user's."""
    mine = tmp / "mine"
    mine.mkdir(mode=0o700)
    (tmp / "link").symlink_to(mine)
    os.chown(tmp / "link", _NOBODY, _NOBODY, follow_symlinks=False)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp / "link"))


def _homeless(monkeypatch):
    """No KANEDYN_CACHE_DIR, XDG_CACHE_HOME or HOME, and no entry in the user
    database (a container's ``--user 12345``)."""
    import pwd
    for name in ("KANEDYN_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(pwd, "getpwuid", {}.__getitem__)
    return _trusted()


def _loose_tmp(cache, tmp, monkeypatch):
    """The cache refused, and $TMPDIR a folder all can write (no sticky bit)."""
    import tempfile
    (tmp / "tmp").mkdir()
    (tmp / "tmp").chmod(0o777)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp / "tmp"))
    return _trusted()


def _symlinked_entry(cache):
    call, so_path = _module_entry(cache)
    target = cache.parent / "elsewhere.so"
    so_path.rename(target)
    so_path.symlink_to(target)
    return call, so_path


def _object(cache, folder_mode=0o700, mode=0o600, owner=None, folder_owner=None):
    from kanedyn.numerics.backends import _c_build
    (cache / "objects").mkdir(mode=folder_mode)
    (cache / "objects").chmod(folder_mode)
    cached = cache / "objects" / "planted.o"
    cached.write_bytes(b"object")
    cached.chmod(mode)
    if owner is not None:
        os.chown(cached, owner, owner)
    if folder_owner is not None:
        os.chown(cache / "objects", folder_owner, folder_owner)
    return lambda: _c_build._usable(cached)


def _derived(cache, mode=0o600, owner=None, folder_mode=0o700):
    from kanedyn.models._base import _load_entry
    folder = cache / "derived"
    folder.mkdir(mode=folder_mode)
    folder.chmod(folder_mode)
    entry = folder / "planted.kdnum"
    entry.write_bytes(b"PK")
    entry.chmod(mode)
    if owner is not None:
        os.chown(entry, owner, owner)
    return lambda: _load_entry(entry)


def _no_room(tmp_path, monkeypatch, private_too):
    """A build that meets ENOSPC writing the shared cache (injected at the
    write; tests/test_cache_safety.py fills a real tmpfs)."""
    from kanedyn.numerics.backends import _c_build
    cache = _cache_at(tmp_path / "cache", monkeypatch)

    def work(directory):
        if directory == cache or private_too:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(directory / "unit0.c"))
        return "built"
    return lambda: _c_build._with_room(cache, work)


_WORLD = r"can be written by every user \(owner \w+ \(uid \d+\), mode d?[-rwxt]+\)"
#: name -> (needs root, make(tmp_path, monkeypatch) -> call, exception or warning, pattern)
CACHE_CASES = {
    "cache directory all can write": (
        False, lambda tmp, mp: (_cache_at(tmp / "c", mp, 0o777), _trusted())[1],
        RuntimeWarning, r"the cache directory \S+/c \(\$KANEDYN_CACHE_DIR\) could be changed "
                        r"by another user, who could make this process run their code: \S+/c "
                        + _WORLD + r"; fix: `chmod o-w \S+/c`, or set KANEDYN_CACHE_DIR"),
    "cache directory its group can write": (
        True, lambda tmp, mp: (_chgrp(_cache_at(tmp / "c", mp, 0o770), _NOBODY), _trusted())[1],
        RuntimeWarning, r"\S+/c can be written by the users of group nogroup \(gid 65534\) "
                        r"\(owner root \(uid 0\), mode drwxrwx---\); fix: `chmod g-w \S+/c`"),
    "cache directory of another user": (
        True, lambda tmp, mp: (_chown(_cache_at(tmp / "c", mp), _NOBODY), _trusted())[1],
        RuntimeWarning, r"\S+/c is owned by another user \(owner nobody \(uid 65534\), mode "
                        r"drwx------\); set KANEDYN_CACHE_DIR to a directory of your own; "
                        r"nothing is loaded from it"),
    "cache directory group root can write": (
        True, lambda tmp, mp: (_chgrp(_cache_at(tmp / "c", mp, 0o770), 0), _trusted())[1],
        RuntimeWarning, r"\S+/c can be written by the users of group root \(gid 0\) \(owner "
                        r"root \(uid 0\), mode drwxrwx---\); fix: `chmod g-w \S+/c`"),
    "cache directory another user can write through an ACL": (
        False, lambda tmp, mp: (_with_acl(_cache_at(tmp / "c", mp)), _trusted())[1],
        RuntimeWarning, r"\S+/c can be written by nobody \(uid 65534\) through an access "
                        r"control list entry \(owner \w+ \(uid \d+\), mode drwxrwx---\+\); "
                        r"fix: `setfacl -x u:65534 \S+/c`"),
    "cache directory with a default ACL": (
        False, lambda tmp, mp: (_with_acl(_cache_at(tmp / "c", mp), default=True),
                                _trusted())[1],
        RuntimeWarning, r"\S+/c lets nobody \(uid 65534\) write what is created in it \(a "
                        r"default access control list\) .*; fix: `setfacl -k \S+/c`"),
    "cache directory named by another user's link": (
        True, lambda tmp, mp: (_linked_cache(tmp, mp), _trusted())[1],
        RuntimeWarning, r"\S+/link is a symbolic link of another user \(owner nobody \(uid "
                        r"65534\), mode lrwxrwxrwx\); set KANEDYN_CACHE_DIR to a directory of "
                        r"your own"),
    "no home directory and no cache directory set": (
        False, lambda tmp, mp: _homeless(mp),
        RuntimeWarning, r"there is no cache directory: KANEDYN_CACHE_DIR is not set, nor "
                        r"XDG_CACHE_HOME to an absolute path, and the home directory is unknown"),
    "a temporary directory all can write": (
        False, lambda tmp, mp: _loose_tmp(_cache_at(tmp / "c", mp, 0o777), tmp, mp),
        RuntimeWarning, r"temporary directory passed over: \S+/tmp " + _WORLD),
    "a folder above the cache all can write": (
        False, lambda tmp, mp: (_cache_at(tmp / "open", mp, 0o777),
                                _cache_at(tmp / "open" / "c", mp), _trusted())[2],
        RuntimeWarning, r"\S+/open " + _WORLD + r"; fix: `chmod o-w \S+/open`"),
    "a folder above the cache of another user": (
        True, lambda tmp, mp: (_chown(_cache_at(tmp / "theirs", mp, 0o755), _NOBODY),
                               _cache_at(tmp / "theirs" / "c", mp), _trusted())[2],
        RuntimeWarning, r"\S+/theirs is owned by another user \(owner nobody"),
    "module another user can write through an ACL": (
        False, lambda tmp, mp: _module_entry(_cache_at(tmp / "c", mp), acl=True)[0],
        RuntimeWarning, r"_kd_planted\S*\.so can be written by nobody \(uid 65534\) through "
                        r"an access control list entry \(owner \w+ \(uid \d+\), mode "
                        r"-rw-rw----\+\): not loaded"),
    "module all can write": (
        False, lambda tmp, mp: _module_entry(_cache_at(tmp / "c", mp), mode=0o666)[0],
        RuntimeWarning, r"\S+/c/_kd_planted\S*\.so can be written by every user \(owner "
                        r"\w+ \(uid \d+\), mode -rw-rw-rw-\): not loaded \(the cache loads "
                        r"only files of this user or root that no one else can write\); it "
                        r"is removed and built again"),
    "module of another user": (
        True, lambda tmp, mp: _module_entry(_cache_at(tmp / "c", mp), owner=_NOBODY)[0],
        RuntimeWarning, r"_kd_planted\S*\.so is owned by another user \(owner nobody \(uid "
                        r"65534\), mode -rw-------\): not loaded"),
    "manifest of another user": (
        True, lambda tmp, mp: _module_entry(_cache_at(tmp / "c", mp), owner=_NOBODY,
                                            what="json")[0],
        RuntimeWarning, r"_kd_planted\.json is owned by another user .*: not loaded"),
    "module that is a symbolic link": (
        False, lambda tmp, mp: _symlinked_entry(_cache_at(tmp / "c", mp))[0],
        RuntimeWarning, r"_kd_planted\S*\.so is a symbolic link: not loaded"),
    "cached object of another user": (
        True, lambda tmp, mp: _object(_cache_at(tmp / "c", mp), owner=_NOBODY),
        RuntimeWarning, r"objects/planted\.o is owned by another user .*: not loaded"),
    "cached object all can write": (
        False, lambda tmp, mp: _object(_cache_at(tmp / "c", mp), mode=0o646),
        RuntimeWarning, r"objects/planted\.o can be written by every user .*: not loaded"),
    "object folder all can write": (
        False, lambda tmp, mp: _object(_cache_at(tmp / "c", mp), folder_mode=0o777),
        RuntimeWarning, r"c/objects can be written by every user .*: not loaded"),
    "object folder of another user": (
        True, lambda tmp, mp: _object(_cache_at(tmp / "c", mp), folder_owner=_NOBODY),
        RuntimeWarning, r"c/objects is owned by another user .*: not loaded"),
    "derivation entry of another user": (
        True, lambda tmp, mp: _derived(_cache_at(tmp / "c", mp), owner=_NOBODY),
        kd.SavedFileError, r"derived/planted\.kdnum is owned by another user \(owner nobody "
                              r"\(uid 65534\), mode -rw-------\): not read \(the cache reads "
                              r"only files of this user or root"),
    "derivation entry all can write": (
        False, lambda tmp, mp: _derived(_cache_at(tmp / "c", mp), mode=0o666),
        kd.SavedFileError, r"derived/planted\.kdnum can be written by every user"),
    "derivation folder all can write": (
        False, lambda tmp, mp: _derived(_cache_at(tmp / "c", mp), folder_mode=0o777),
        kd.SavedFileError, r"c/derived can be written by every user .*: not read"),
    "lock file that is a symbolic link": (
        False, lambda tmp, mp: _linked_lock(tmp),
        OSError, r"Too many levels of symbolic links|symbolic link"),
    "full disk under the cache": (
        False, lambda tmp, mp: _no_room(tmp, mp, private_too=False),
        RuntimeWarning, r"the cache directory \S+/cache could not be written \(\S+/cache/"
                        r"unit0\.c: No space left on device\); compiled modules are built in "
                        r"\S+ for this process only \(free some space there to keep them\)"),
    "full disk everywhere": (
        False, lambda tmp, mp: _no_room(tmp, mp, private_too=True),
        CompilerError,
        r"a compiled module could not be built in \S+kanedyn-cache-\S+ \(\S+/unit0\.c: No space "
        r"left on device\); free some space there or set KANEDYN_CACHE_DIR"),
}


def _trusted():
    from kanedyn.numerics.backends import trusted_cache_dir
    return trusted_cache_dir


def _chown(path, uid):
    os.chown(path, uid, -1)
    return path


def _chgrp(path, gid):
    os.chown(path, -1, gid)
    return path


def _linked_lock(tmp):
    from kanedyn._fork import FileLock
    (tmp / "x.lock").symlink_to(tmp / "elsewhere")

    def take():
        with FileLock(tmp / "x.lock"):
            pass
    return take


@pytest.mark.parametrize("case", sorted(CACHE_CASES))
def test_cache_that_others_could_change(case, tmp_path, monkeypatch):
    from kanedyn.numerics.backends import _c_build
    root_only, make, fault, pattern = CACHE_CASES[case]
    if root_only and not _ROOT:
        pytest.skip("needs root: files of a second user (chown to uid 65534)")
    for name, fresh in (("_PRIVATE", []), ("_FULL", {}), ("_REFUSED", set())):
        monkeypatch.setattr(_c_build, name, fresh)
    call = make(tmp_path, monkeypatch)
    if issubclass(fault, Warning):
        with pytest.warns(fault, match=pattern):
            call()
    else:
        with pytest.raises(fault, match=pattern), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # the cache not used: a case above
            call()


# ---- issue 33, items 3-4 (and item 7's run --out on a full disk): interruptions, memory
def test_run_out_on_a_full_disk(tmp_path, monkeypatch, capsys):
    """The disk fills up while ``kanedyn run`` writes its CSV: one line naming the
    file and the cause, and no file cut short (the CSV is written under a
    temporary name and renamed when complete)."""
    import errno
    import os

    from kanedyn._output_files import replacing

    def fills_up(self, path):  # the writer as it is, and the disk full half way
        with replacing(path) as fh:
            fh.write("t,theta,omega\n0.0,")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(kd.SimulationResult, "to_csv", fills_up)
    argv = ["run", "pendulum", "--t-end", "0.1", "--backend", "numpy", "--out", str(tmp_path),
            "--quiet"]
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == (
        f"kanedyn: error: cannot write {tmp_path / 'pendulum.csv'}: No space left on device")
    assert not list(tmp_path.iterdir())


# ---- issue 33, item 1: kd.load runs no code and always ends
_PARTICLE = "sympy.physics.mechanics.particle.Particle"
_CODE = "__import__('os').system('false')"
SAVED_FILE_CASES = {
    # label: (nodes of the file, root 0; the message after "<file>: ")
    "a body's property setter (it sympifies text)": (
        [["object", _PARTICLE, [["mass", 1]]], ["str", _CODE]],
        "node 0: Particle has no attribute 'mass' that a saved file may hold"),
    "code as text in a body's mass": (
        [["object", _PARTICLE, [["_mass", 1]]], ["str", _CODE]],
        "node 0: Particle attribute '_mass' is a str, not a SymPy expression"),
    "an attribute no schema names": (
        [["object", "sympy.physics.vector.point.Point", [["evil", 1]]], ["none"]],
        "node 0: Point has no attribute 'evil' that a saved file may hold"),
    "text deep in a container of expressions": (
        [["object", "kanedyn.engine._program.Program", [["_defs", 1]]],
         ["dict", [[2, 3]]], ["symbol", "x", {}], ["str", _CODE]],
        "node 0: Program attribute '_defs' has a value that is a str, not a SymPy "
        "expression"),
    "an integer of 4000 digits": ([["expr", "Max", [1, 2]], ["integer", "9" * 4000],
                                   ["integer", "9"]],
                                  "node 1: .*an integer of at most 1000 digits"),
    "a condition that is a number": ([["expr", "And", [1, 1]], ["integer", "2"]],
                                     "node 0: argument 0 of And is an Integer, not a "
                                     "condition"),
    "a derivative by an expression": (
        [["expr", "Derivative", [1, 3]], ["symbol", "x", {}], ["integer", "1"],
         ["expr", "Tuple", [4, 2]], ["expr", "sin", [1]]],
        r"node 0: argument 1 of Derivative is a Tuple, not a \(variable, order\) pair"),
    "an assumption SymPy does not know": ([["symbol", "x", {"__class__": True}]],
                                          "node 0: .*'__class__' is not a SymPy "
                                          "assumption"),
    "a tuple of 2**70 items as a key": (
        [["dict", [[72, 1]]], ["int", "1"], ["tuple", [1]]]
        + [["tuple", [k, k]] for k in range(2, 72)],
        "node 0: a tuple of more than 64 items used as a key"),
    "a Vector as a dict key": (
        [["dict", [[1, 2]]], ["object", "sympy.physics.vector.vector.Vector", [["args", 2]]],
         ["list", []]], "node 0: a Vector used as a dict key or set member"),
    "objects nested 20000 deep": ([["list", [k + 1]] for k in range(20000)] + [["none"]],
                                  "node 4999: the objects are nested more than 5000 deep"),
    "a cycle through a tuple": ([["tuple", [0]]], "node 0: it refers back to node 0"),
    "an array of Python objects": ([["array", "object", [1], "AA=="]],
                                   "node 0: an array of type 'object'"),
    "a random state of the wrong size": ([["random", 3, ["1"], None]],
                                         "node 0: .*the state of a Mersenne Twister"),
    "a node that is not a list": ([{"kind": "list"}], "node 0: not a node but a dict"),
}


@pytest.mark.timeout(120)  # each is refused at once; a regression fails, not hangs
@pytest.mark.parametrize("case", sorted(SAVED_FILE_CASES))
def test_bad_saved_file(case, tmp_path, saved_archive):
    nodes, message = SAVED_FILE_CASES[case]
    path = saved_archive(tmp_path / "model.kdeom", nodes)
    with pytest.raises(kd.SavedFileError, match=r"model\.kdeom: " + message):
        load_data(path)


def _zip_bomb(path, size, compression=zipfile.ZIP_DEFLATED, members=()):
    with zipfile.ZipFile(path, "w", compression=compression) as archive:
        archive.writestr("manifest.json", "{}")
        with archive.open("nodes.json", "w", force_zip64=True) as member:
            for _ in range(size >> 20):
                member.write(b" " * (1 << 20))
        for name in members:
            archive.writestr(name, "")
    return path


def _sparse(path, size):
    with path.open("wb") as handle:
        handle.truncate(size)
    return path


SAVED_ARCHIVE_CASES = {
    "a zip bomb (64 MiB of spaces)": (lambda p: _zip_bomb(p, 64 << 20), {},
                                      "nodes.json is 67108864 bytes uncompressed, more "
                                      "than the 33554432"),
    "a member compressed by bzip2": (lambda p: _zip_bomb(p, 1 << 20, zipfile.ZIP_BZIP2), {},
                                     "manifest.json is compressed by a method kanedyn does "
                                     "not write"),
    "an archive of 40 members": (lambda p: _zip_bomb(p, 0, members=[f"m{i}" for i in
                                                                    range(38)]), {},
                                 r"not a kanedyn equations file \(it has 40 members\)"),
    "a file of 40 MiB": (lambda p: _sparse(p, 40 << 20), {},
                         "41943040 bytes, more than the 33554432 a saved file may have"),
    "a read over its time limit": (lambda p: kd.models.build("pendulum").derive().save(p),
                                   {"timeout": 0}, "reading took longer than its time limit"),
}


@pytest.mark.parametrize("case", sorted(SAVED_ARCHIVE_CASES))
def test_bad_saved_archive(case, tmp_path):
    make, options, message = SAVED_ARCHIVE_CASES[case]
    path = make(tmp_path / "model.kdeom")
    with pytest.raises(kd.SavedFileError, match=r"model\.kdeom: " + message):
        load_data(path, **options)


# ---- issue 33, items 5 and 6: no hangs (time limits, scheduler addresses); energy
# off by orders of magnitude is never a silent success
TIME_LIMIT_CASES = {
    "timeout of zero": 0, "negative timeout": -1.0, "nan timeout": float("nan"),
    "infinite timeout": float("inf"), "timeout as text": "10",
}


@pytest.mark.parametrize("backend", ["numpy", "c"])
@pytest.mark.parametrize("case", sorted(TIME_LIMIT_CASES))
def test_bad_time_limit(spring, case, backend):
    eom, model, (q, u, F, *_r) = spring
    model = _c_spring(eom, F) if backend == "c" else model
    with pytest.raises(kd.OptionError, match="timeout must be a positive number of seconds"):
        kd.simulate(model, (0.0, 1.0), [1.0, 0.0], timeout=TIME_LIMIT_CASES[case])


def _http_server():
    """An HTTP server on loopback (answers HTTP, never Dask); its tcp:// address."""
    import http.server
    import threading

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"tcp://127.0.0.1:{server.server_address[1]}"


SCHEDULER_CASES = {
    "no port": ("garbage", r"scheduler 'garbage' is not a Dask scheduler address \(missing "
                           r"port number"),
    "host without port": ("tcp://127.0.0.1", "is not a Dask scheduler address"),
    "unknown scheme": ("foo://x:1", "unknown scheme 'foo'"),
    "port that is not a number": ("tcp://host:port", "is not a Dask scheduler address"),
    "not text": (8786, "scheduler must be an address"),
    "an HTTP server": (None, "no Dask scheduler answered within 1 s .*accepted the "
                             "connection but did not answer"),
}


@pytest.mark.parametrize("case", sorted(SCHEDULER_CASES))
def test_bad_scheduler(spring, case, monkeypatch, capsys, tmp_path):
    """In kd.sweep and in ``kanedyn sweep --scheduler``: one line within seconds,
    before any run (an HTTP server kept both waiting over 180 s; ``garbage``
    gave a traceback)."""
    pytest.importorskip("distributed")
    pytest.importorskip("pandas")
    from kanedyn.simulation import _sweep
    monkeypatch.setattr(_sweep, "_CONNECT_SECONDS", 1.0)
    address, pattern = SCHEDULER_CASES[case]
    server = None
    if address is None:
        server, address = _http_server()
    try:
        _eom, model, _symbols = spring
        with pytest.raises(kd.OptionError, match=pattern):
            kd.sweep(model, {"k": [1.0]}, [1.0, 0.0], (0.0, 1.0), scheduler=address,
                     progress=False)
        if isinstance(address, str):
            assert main(["sweep", "pendulum", "--grid", "l=1", "--quiet", "--scheduler",
                         address, "--out", str(tmp_path / "o")]) == 2
            err = capsys.readouterr().err
            assert err.startswith("kanedyn: error: ") and len(err.splitlines()) == 1
            assert re.search(pattern, err), err
    finally:
        if server is not None:
            server.shutdown()
            server.server_close()


def test_run_timeout_refused_on_the_command_line(capsys, tmp_path):
    for value, why in (("0", "must be a finite number > 0"), ("-2", "must be a finite"),
                       ("nan", "must be a finite"), ("soon", "expected a number, got 'soon'")):
        assert main(["sweep", "pendulum", "--grid", "l=1", "--run-timeout", value,
                     "--out", str(tmp_path / "o")]) == 2
        assert f"argument --run-timeout: {why}" in capsys.readouterr().err


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_energy_off_by_orders_of_magnitude(backend):
    """The stiff spring of the issue (k = 1e8, rtol = atol = 1e-2, RK45 with
    first_step=0.5, max_step=10, two output times: silent before) grows its
    energy 3e24-fold: flagged, with the stiff methods suggested."""
    args, (q, u, F, m, k, *_r) = _spring()
    eom = kd.kane(**args, potential_energy=k * q ** 2 / 2)
    model = eom.numeric(constants={"m": 1.0, "k": 1e8}, specified={F: 0.0}, backend=backend)
    with pytest.warns(kd.TrustWarning, match="the energy balance fails.*method='Radau'"):
        res = kd.simulate(model, (0.0, 1.0), [1.0, 0.0], rtol=1e-2, atol=1e-2,
                          t_eval=[0.0, 1.0], first_step=0.5, max_step=10)
    assert res.success and "warning: the energy balance fails" in res.message


# ---- issue 33, review: outputs and signals
EMPTY_OUTPUT_CASES = {
    "run --out ''": ["run", "pendulum", "--quiet", "--out", ""],
    "demo --out ''": ["demo", "--quiet", "--out", ""],
    "sweep --out ''": ["sweep", "pendulum", "--grid", "m=1:2:2", "--quiet", "--out", ""],
    "compare --plot --out ''": ["compare", "pendulum", "--plot", "--quiet", "--out", ""],
    "inverse --out ''": ["inverse", "3rrr", "--quiet", "--out", ""],
    "study --out ''": ["study", "seatbelt-regulatory", "--quiet", "--out", ""],
    "derive --c ''": ["derive", "pendulum", "--quiet", "--c", ""],
}


@pytest.mark.parametrize("case", sorted(EMPTY_OUTPUT_CASES))
def test_an_empty_output_name_is_refused(case, capsys, tmp_path, monkeypatch):
    """``--out ""`` wrote into the current folder without a word."""
    monkeypatch.chdir(tmp_path)
    argv = EMPTY_OUTPUT_CASES[case]
    assert main(argv) == 2
    option = argv[-2]
    assert capsys.readouterr().err == (f"kanedyn: error: {option}: the name is empty; give a "
                                       "folder or file name (. for the current folder)\n")
    assert not list(tmp_path.iterdir())


def _result():
    d = kd.models.build("pendulum")
    model = d.numeric(backend="numpy")
    return kd.simulate(model, (0.0, 0.1), d.initial(model))


OUTPUT_FILE_CASES = {
    "a CSV into a folder that does not exist": (
        lambda tmp: _result().to_csv(tmp / "missing" / "run.csv"),
        "missing/run.csv: No such file or directory"),
    "a CSV named as an existing folder": (
        lambda tmp: _result().to_csv(tmp), ": Is a directory"),
    "a C file on a full device": (
        lambda tmp: _result().model.export_c("/dev/full"), "/dev/full: No space left on device"),
}


@pytest.mark.parametrize("case", sorted(OUTPUT_FILE_CASES))
def test_output_files_that_cannot_be_written(case, tmp_path):
    """A file the library cannot write: OutputFileError (an OSError) naming it and the
    cause, and nothing left behind (a plain OSError, or a file cut short)."""
    if "/dev/full" in case and not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    write, message = OUTPUT_FILE_CASES[case]
    before = sorted(tmp_path.iterdir())
    with pytest.raises(kd.OutputFileError, match="^cannot write .*" + re.escape(message)):
        write(tmp_path)
    assert sorted(tmp_path.iterdir()) == before


def test_derive_c_on_a_full_device(capsys):
    """derive --c /dev/full: a traceback before; written as a device (never replaced)."""
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    assert main(["derive", "pendulum", "--quiet", "--c", "/dev/full"]) == 2
    assert capsys.readouterr().err == ("kanedyn: error: cannot write /dev/full: No space "
                                       "left on device\n")


class _FullStream:
    """A stream on a full disk: every write fails."""

    def write(self, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def flush(self):
        pass


def test_standard_output_on_a_full_disk(monkeypatch, capsys):
    """kanedyn list > /dev/full: a traceback before."""
    monkeypatch.setattr("sys.stdout", _FullStream())
    assert main(["list"]) == 2
    assert capsys.readouterr().err == ("kanedyn: error: cannot write to standard output: "
                                       "No space left on device\n")


# ---- issue 33, review: files and formulations
# (pulse files that are no regular file or too large, URDF mesh names the file system
# refuses and numbers in other digits, a public name asked of the wrong module)
def _mesh_of(tmp_path, filename, before=lambda robot: None):
    """``mesh_file()`` of the mesh ``filename`` of :func:`_robot_file` (line 5);
    ``before(folder)`` prepares the robot's folder."""
    (tmp_path / "robot").mkdir()
    before(tmp_path / "robot")
    (visual,) = kd.models.from_urdf(_robot_file(tmp_path, mesh=filename)).visuals
    return visual.mesh_file()


def _named_pipe(tmp_path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no named pipes here")
    os.mkfifo(tmp_path / "pulse.csv")
    return tmp_path / "pulse.csv"


REVIEW_CASES = {
    "pulse file that is /dev/zero": (
        lambda tmp: kd.vehicle.read_pulse_csv("/dev/zero"), kd.ModelError,
        r"^/dev/zero: a character device, not a regular file; give a CSV file$"),
    "pulse file that is a named pipe": (
        lambda tmp: kd.vehicle.read_pulse_csv(_named_pipe(tmp)), kd.ModelError,
        r"pulse\.csv: a named pipe, not a regular file"),
    "pulse file that is a folder": (
        lambda tmp: kd.vehicle.read_pulse_csv(tmp), kd.ModelError,
        r": a folder, not a regular file"),
    "pulse file of 65 MiB": (
        lambda tmp: kd.vehicle.read_pulse_csv(_sparse(tmp / "pulse.csv", 65 << 20)),
        kd.ModelError, r"pulse\.csv: 68157440 bytes, more than the 67108864 a pulse record "
                       r"may have \(give read_pulse_csv\(\.\.\., max_bytes=\.\.\.\)"),
    "URDF mesh name of 5000 characters": (
        lambda tmp: _mesh_of(tmp, "a" * 5000 + ".obj"), kd.models.URDFError,
        r"robot\.urdf:5: mesh 'a{50}\.\.\.\(5004 characters\)' of link 'arm' is not read: "
        r"its name cannot be looked up: File name too long$"),
    "URDF mesh in 3000 nested folders": (
        lambda tmp: _mesh_of(tmp, "x/" * 3000 + "y.obj"), kd.models.URDFError,
        r"robot\.urdf:5: mesh '(x/){25}\.\.\.\(6005 characters\)' .*File name too long$"),
    "URDF mesh under a loop of symbolic links": (
        lambda tmp: _mesh_of(tmp, "loop/a.obj", lambda robot: (robot / "loop").symlink_to(
            robot / "loop")), kd.models.URDFError,
        r"robot\.urdf:5: mesh 'loop/a\.obj' of link 'arm' is not read: its name cannot be "
        r"looked up: Too many levels of symbolic links$"),
    "URDF mesh file: URI of another host": (
        lambda tmp: _mesh_of(tmp, "file://server/meshes/a.obj"), kd.models.URDFError,
        r"robot\.urdf:5: .* is not read: the file: URI names a file on the host 'server'; "
        r"only local files are read"),
    "URDF mass in Arabic-Indic digits": (
        _load_robot(mass="\u0661\u0660"), kd.models.URDFError,
        r"robot\.urdf:4: <link name='arm'>: <mass value='\u0661\u0660'>: is not a number$"),
    "URDF inertia in full-width digits": (
        _load_robot(inertia=_UNIT_INERTIA.replace('izz="1"', 'izz="\uff11"')),
        kd.models.URDFError, r"robot\.urdf:4: <link name='arm'>: <inertia izz='\uff11'>: "
                             r"is not a number$"),
    "a public name asked of the wrong module": (
        lambda tmp: kd.offshore.HalfSinePulse, AttributeError,
        r"^module 'kanedyn\.offshore' has no attribute 'HalfSinePulse'; it is "
        r"kanedyn\.vehicle\.HalfSinePulse$"),
}


@pytest.mark.timeout(60)  # a pipe or /dev/zero that is read would hang or fill memory
@pytest.mark.parametrize("case", sorted(REVIEW_CASES))
def test_review_files_and_formulations(case, tmp_path):
    action, error, pattern = REVIEW_CASES[case]
    with pytest.raises(error, match=pattern):
        action(tmp_path)


def test_review_mesh_uris_read(tmp_path):
    """Valid URIs that were "not found": file://localhost/... and percent-encoded
    paths, still read only inside the allowed folders."""
    def mesh(robot):
        (robot / "my mesh.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    folder = tmp_path / "robot"
    name = f"file://localhost{folder}/my%20mesh.obj"
    assert _mesh_of(tmp_path, name, mesh) == str(folder / "my mesh.obj")


def _ocp(**changes):
    """The spring's rest-to-rest problem of least effort, with ``changes``."""
    model, (q, u, F, m, k, *_) = _spring()
    numeric = kd.kane(**model).numeric(constants={m: 1.0, k: 1.0}, specified={F: 0.0})
    options = dict(nodes=11, duration=1.0, lagrange=F ** 2, initial={q: 0, u: 0},
                   final={q: 1, u: 0})
    options.update({key: value(q, u, F, m, k) if callable(value) else value
                    for key, value in changes.items()})
    return kd.OptimalControlProblem(numeric, **options)


#: optimal control: each a clear error naming the bound, symbol or option at fault
OCP_CASES = {
    "bounds with lower above upper": (
        lambda: _ocp(bounds=lambda q, u, F, m, k: {F: (2.0, -2.0)}), kd.ModelError,
        r"^bounds of F: the lower bound 2 is above the upper bound -2$"),
    "initial state outside its bounds": (
        lambda: _ocp(bounds=lambda q, u, F, m, k: {q: (0.5, 2.0)}), kd.ModelError,
        r"^initial value q = 0 lies outside its bounds \(0\.5, 2\)$"),
    "objective naming a symbol the model lacks": (
        lambda: _ocp(lagrange=lambda q, u, F, m, k: F ** 2 + sm.Symbol("c") * q),
        kd.ModelError, r"integrand \(lagrange\) names c, which is not a symbol of the model"),
    "objective naming a function the model lacks": (
        lambda: _ocp(lagrange=lambda q, u, F, m, k: me.dynamicsymbols("w") ** 2),
        kd.ModelError, r"^w\(\.\.\.\) is neither a state \(q, u\) nor an input \(F\)"),
    "objective given as text": (
        lambda: _ocp(lagrange="F(t)**2"), kd.ModelError,
        r"integrand \(lagrange\) is the text 'F\(t\)\*\*2'; give a number or a SymPy"),
    "bounds on a constant that is not free": (
        lambda: _ocp(bounds=lambda q, u, F, m, k: {m: (0.5, 2.0)}), kd.ModelError,
        r"^bounds name the constant m, which is not free; list it in parameters="),
    "free duration without bounds": (
        lambda: _ocp(duration=sm.Symbol("T")), kd.ModelError,
        r"^the free duration T needs bounds: bounds=\{T: \(lower, upper\)\}$"),
    "instance constraint between nodes": (
        lambda: _ocp(instance_constraints=lambda q, u, F, m, k: [
            q.func(0.37) - 0.5]), kd.ModelError,
        r"q\(0\.37\) - 0\.5\): the time 0\.37 s is not a node time \(nodes every 0\.1 s "
        r"from t0 = 0 s\)$"),
    "unknown collocation method": (
        lambda: _ocp(method="rk4"), kd.ModelError,
        r"^unknown collocation method 'rk4'; available: backward-euler, trapezoid, midpoint,"
        r" hermite-simpson, lgr$"),
    "guess of the wrong shape": (
        lambda: _ocp().solve(np.zeros(7)), kd.ModelError,
        r"^the guess must have shape \(33,\) \(states and inputs at 11 nodes, .*got \(7,\)"),
    "straight-line guess without the inputs": (
        lambda: _ocp().guess_line(), kd.ModelError,
        r"^the guess needs a value for every input: missing F \(inputs=\{\.\.\.\}\)$"),
    "no objective": (
        lambda: _ocp(lagrange=None), kd.ModelError, r"^give an objective: lagrange="),
}


@pytest.mark.parametrize("case", sorted(OCP_CASES))
def test_optimal_control_bad_input(case):
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt")
    make, kind, pattern = OCP_CASES[case]
    with pytest.raises(kind, match=pattern):
        make()


# ------------------------------------------------ parameter identification (issue 35)
_T = np.linspace(0.0, 1.0, 11)
_X = np.cos(2.0 * _T)          # the spring's q with m = 1, k = 4, released at rest from 1


def _fit(spring, data=None, parameters=("k",), **options):
    """``kd.identify`` on the spring's model with the record of ``_X``."""
    _eom, model, _symbols = spring
    options.setdefault("y0", [1.0, 0.0])
    return kd.identify(model, (_T, {"q": _X}) if data is None else data, list(parameters),
                       **options)


def _csv(tmp, text, name="record.csv"):
    path = tmp / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


_GOOD_RECORD = "t [s],q [m]\n" + "".join(f"{t!r},{x!r}\n" for t, x in zip(
    map(float, _T), map(float, _X)))

#: kd.identify and kd.MeasuredRecord: each a clear error naming the constant, channel,
#: sample, or the file with its line and column
IDENTIFY_CASES = {
    "constant the model lacks": (
        lambda s, tmp: _fit(s, parameters=["mass"]), kd.ModelError,
        r"^parameters: 'mass' is not a constant of the model; its constants: k, m$"),
    "constant named twice": (
        lambda s, tmp: _fit(s, parameters=["k", "k"]), kd.ModelError,
        r"^parameters names k twice$"),
    "initial value of a state the model lacks": (
        lambda s, tmp: _fit(s, initial=["v"]), kd.ModelError,
        r"^initial: 'v' is not a state of the model; its states: q, u$"),
    "channel naming no output": (
        lambda s, tmp: _fit(s, data=(_T, {"x": _X})), kd.ModelError,
        r"^record 0: channel 'x' is not an output of the model: measured channels are "
        r"states \(q, u\) or their rates"),
    "times going back": (
        lambda s, tmp: kd.MeasuredRecord(_T[::-1], {"q": _X}), kd.ModelError,
        r"^record, sample 1 \(t = 0\.9 s\): the time goes back \(0\.9 s after 1 s\)"),
    "a time repeated": (
        lambda s, tmp: kd.MeasuredRecord(np.r_[_T[:3], _T[2:]], {"q": np.r_[_X[:3], _X[2:]]}),
        kd.ModelError, r"^record, sample 3 \(t = 0\.2 s\): the time repeats"),
    "samples before the start": (
        lambda s, tmp: kd.MeasuredRecord(_T, {"q": _X}, start=0.5), kd.ModelError,
        r"^record: start = 0\.5 s must be finite and not after the first sample \(0 s\)$"),
    "NaN in the data": (
        lambda s, tmp: kd.MeasuredRecord(_T, {"q": np.where(_T > 0.55, np.nan, _X)}),
        kd.ModelError, r"^record, sample 6 \(t = 0\.6 s\), channel 'q': nan is not a finite "
                       r"number \(5 such values\); leave missing samples out"),
    "a channel shorter than the time": (
        lambda s, tmp: kd.MeasuredRecord(_T, {"q": _X[:5]}), kd.ModelError,
        r"^record, channel 'q': 5 values for 11 times"),
    "too few data for the unknowns": (
        lambda s, tmp: _fit(s, data=(_T[:2], {"q": _X[:2]}), parameters=["k", "m"]),
        kd.ModelError, r"^too few data: 2 measured values for 2 unknowns \(k, m\)"),
    "constants the data cannot separate": (
        lambda s, tmp: _fit(s, parameters=["k", "m"]), kd.ModelError,
        r"^identify: k, m cannot be identified from these data at the initial guess: the "
        r"Jacobian has rank 1 of 2: the outputs do not change along 0\.71 k \+ 0\.71 m"),
    "no initial state": (
        lambda s, tmp: _fit(s, y0=None), kd.ModelError,
        r"^record 0: no initial state: give y0="),
    "nothing to fit": (
        lambda s, tmp: _fit(s, parameters=[]), kd.ModelError, r"^nothing to fit"),
    "negative noise level": (
        lambda s, tmp: _fit(s, sigma={"q": -1.0}), kd.ModelError,
        r"^sigma of q: a positive finite number, got -1"),
    "noise level of a channel not measured": (
        lambda s, tmp: _fit(s, sigma={"u": 1.0}), kd.ModelError,
        r"^sigma names 'u', which no record measures \(q\)$"),
    "bounds upside down": (
        lambda s, tmp: _fit(s, bounds={"k": (5.0, 3.0)}), kd.ModelError,
        r"^bounds of k: \(5, 3\) is not an interval$"),
    "guess outside its bounds": (
        lambda s, tmp: _fit(s, bounds={"k": (5.0, 6.0)}), kd.ModelError,
        r"^the model's k = 4, the guess, lies outside its bounds \(5, 6\)$"),
    "level in per cent": (
        lambda s, tmp: _fit(s, level=95), kd.OptionError,
        r"^identify: level must be a number between 0 and 1 \(0\.95: 95 %\), got 95$"),
    "no segment": (
        lambda s, tmp: _fit(s, segments=0), kd.OptionError,
        r'^identify: segments must be an integer >= 1 or "auto", got 0$'),
    "data of no known kind": (
        lambda s, tmp: _fit(s, data=3.0), kd.ModelError,
        r"^data must be a MeasuredRecord, a CSV file, a pair \(t, \{channel: values\}\) or "
        r"a list of them, got float$"),
    "CSV cell that is code": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace(
            "0.1,", "0.1,__import__('os')#", 1))), kd.ModelError,
        r"record\.csv: line 3, column 'q \[m\]': \"__import__\('os'\)#.*\" is not a finite "
        r"number$"),
    "CSV empty cell": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace("\n0.2,", "\n0.2,\n#", 1))),
        kd.ModelError, r"record\.csv: line 4, column 'q \[m\]': an empty cell is not a "
                       r"finite number$"),
    "CSV without a time column": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace("t [s]", "s"))),
        kd.ModelError, r"record\.csv: line 1: no time column in the header \(s, q \[m\]\); "
                       r"name it t or time"),
    "CSV time in hours": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace("t [s]", "t [h]"))),
        kd.ModelError, r"record\.csv: column 't \[h\]': unknown time unit 'h'; use s or ms$"),
    "CSV column in another unit": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace("q [m]", "q [mm]"))),
        kd.ModelError, r"record\.csv: column 'q' is in 'mm'; the model's q is in 'm' "
                       r"\(convert the column\)$"),
    "CSV time going back": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace("\n0.2,", "\n0.05,", 1))),
        kd.ModelError, r"record\.csv, line 4: the time goes back \(0\.05 s after 0\.1 s\)"),
    "CSV row longer than the header": (
        lambda s, tmp: _fit(s, data=_csv(tmp, _GOOD_RECORD.replace("\n0.1,", "\n0.1,1,", 1))),
        kd.ModelError, r"record\.csv: line 3 has 3 cells; the header \(line 1\) names 2 "
                       r"columns$"),
    "CSV not UTF-8": (
        lambda s, tmp: _fit(s, data=_csv(tmp, b"t,q\n0,\xff\n")), kd.ModelError,
        r"record\.csv: not UTF-8 text \(byte 0xff at offset 6\)"),
    "CSV a folder": (
        lambda s, tmp: _fit(s, data=str(tmp)), kd.ModelError,
        r"a folder, not a regular file; give a CSV file$"),
}


@pytest.mark.parametrize("case", sorted(IDENTIFY_CASES))
def test_identification_bad_input(spring, case, tmp_path):
    make, kind, pattern = IDENTIFY_CASES[case]
    with pytest.raises(kind, match=pattern):
        make(spring, tmp_path)


# ---- issue 36, item 6: OpenFAST input files (kd.offshore.read_openfast_input)
_OPENFAST_FILE = """------- ElastoDyn-like test file -------
title line
---------------------- MASS ----------------------------------------------------
    7466330   PtfmMass    - Platform mass (kg)
"__import__('os').system('true')"   PtfmRIner   - text where a number belongs
True          PtfmSgDOF   - flag
        100   HubMass     - given once
        200   HubMass     - given twice
          0   AddCLin     - a matrix
          1
     0    x
---------------------- TABLE ---------------------------------------------------
          2   NJoints     - rows of the table below
JointID   Jointzi
  (-)       (m)
    1      -120
    2      depth
"""


def _openfast(tmp, text=_OPENFAST_FILE, name="ed.dat"):
    path = tmp / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return kd.offshore.read_openfast_input(path)


OPENFAST_CASES = {
    "missing file": (
        lambda tmp: kd.offshore.read_openfast_input(tmp / "none.dat"),
        r"cannot read OpenFAST file .*none\.dat: No such file"),
    "a folder": (
        lambda tmp: kd.offshore.read_openfast_input(tmp),
        r"a folder, not a regular file; give an OpenFAST text file$"),
    "not UTF-8": (
        lambda tmp: _openfast(tmp, b"header\n 1 X - x\n\xff\n"),
        r"ed\.dat, line 3: not UTF-8 text \(byte 0xff\)$"),
    "larger than allowed": (
        lambda tmp: kd.offshore.read_openfast_input(
            _openfast(tmp) and tmp / "ed.dat", max_bytes=10),
        r"ed\.dat: \d+ bytes, more than the 10 an OpenFAST file may have"),
    "name missing": (
        lambda tmp: _openfast(tmp).number("PtfmMas"),
        r"ed\.dat: no line gives PtfmMas$"),
    "name given twice": (
        lambda tmp: _openfast(tmp).number("HubMass"),
        r"ed\.dat: HubMass is given on lines 7, 8; which one is meant is not clear$"),
    "text (code) where a number belongs, never run": (
        lambda tmp: _openfast(tmp).number("PtfmRIner"),
        r"ed\.dat, line 5: PtfmRIner is \"__import__\('os'\)\.system\('true'\)\", not a "
        r"number$"),
    "number where a flag belongs": (
        lambda tmp: _openfast(tmp).flag("PtfmMass"),
        r"ed\.dat, line 4: PtfmMass is 7466330\.0, not a flag \(True or False\)$"),
    "flag where a number belongs": (
        lambda tmp: _openfast(tmp).integer("PtfmSgDOF"),
        r"ed\.dat, line 6: PtfmSgDOF is True, not a whole number$"),
    "matrix where one value belongs": (
        lambda tmp: _openfast(tmp).number("AddCLin"),
        r"ed\.dat, line 9: AddCLin holds 2 values, not one$"),
    "matrix row of another length": (
        lambda tmp: _openfast(tmp, _OPENFAST_FILE.replace("     0    x\n", "")
                              .replace("          1\n", "          1   2\n")).array("AddCLin"),
        r"ed\.dat, line 9: the rows of AddCLin differ in length$"),
    "no table with the column": (
        lambda tmp: _openfast(tmp).table("Jointxi"),
        r"ed\.dat: no table has a column 'Jointxi'$"),
    "table shorter than its count": (
        lambda tmp: _openfast(tmp, _OPENFAST_FILE.replace("2   NJoints", "3   NJoints"))
        .table("JointID", rows="NJoints"),
        r"ed\.dat, line 14: NJoints = 3 but the table has 2 rows$"),
    "text in a column of numbers": (
        lambda tmp: _openfast(tmp).table("JointID").column("Jointzi"),
        r"ed\.dat, line 17: column 'Jointzi' holds 'depth', not a number$"),
    "column the table lacks": (
        lambda tmp: _openfast(tmp).table("JointID").column("Jointxi"),
        r"ed\.dat, line 14: the table has no column 'Jointxi' \(columns: JointID, Jointzi\)$"),
}


@pytest.mark.parametrize("case", sorted(OPENFAST_CASES))
def test_openfast_input_bad_input(case, tmp_path):
    make, pattern = OPENFAST_CASES[case]
    with pytest.raises(kd.ModelError, match=pattern):
        make(tmp_path)


# ---- issue 36, item 3: flexible blades
BLADE_CLI_CASES = {
    "unknown blades": (["run", "oc3-spar", "--set", "rotor=spinning", "--set",
                        "blades=elastic"],
                       "option blades must be one of rigid, flexible, got 'elastic'"),
    "flexible blades without a spinning rotor": (
        ["run", "oc3-spar", "--set", "blades=flexible"],
        r"option blades=flexible needs rotor=spinning \(the rigid rotor has no rotor speed\)"),
}


@pytest.mark.parametrize("case", sorted(BLADE_CLI_CASES))
def test_flexible_blades_bad_command_line(case, capsys, tmp_path):
    argv, pattern = BLADE_CLI_CASES[case]
    assert main(argv + ["--out", str(tmp_path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("kanedyn: error: ") and re.search(pattern, err), err


def _blade_rotor(**changes):
    """A FlexibleBladeElementRotor of three NREL 5-MW blades on a bare hub."""
    from kanedyn.models._nrel5mw_blade import nrel5mw_bem
    from kanedyn.models._oc3_blades import blade_annulus_nodes, oc3_blade_member
    N, O = me.ReferenceFrame("N"), me.Point("O")
    O.set_vel(N, 0)
    member = oc3_blade_member()
    blades = [kd.FlexibleBody(f"b{k}", N, O, member) for k in range(3)]
    bem = nrel5mw_bem()
    args = dict(name="rotor", bem=bem, blades=blades, nodes=blade_annulus_nodes(member, bem),
                hub=O, shaft_frame=N, radial=[N.z, N.z, N.z], frame=N, pitch=0.0, wind=11.4)
    args.update(changes)
    return kd.offshore.FlexibleBladeElementRotor(**args)


def _blade_modes(**options):
    from kanedyn.models._nrel5mw_blade_structure import nrel5mw_blade_modes
    return nrel5mw_blade_modes(**options)


BLADE_API_CASES = {
    "two bodies for a three-bladed rotor": (
        lambda: _blade_rotor(blades=_blade_rotor().blades[:2]),
        r"the rotor has 3 blades; got 2 flexible bodies and 3 span directions"),
    "rigid bodies as blades": (
        lambda: _blade_rotor(blades=[me.Particle("p", me.Point("P"), 1.0)] * 3),
        "blades must be FlexibleBody objects"),
    "too few annulus nodes": (lambda: _blade_rotor(nodes=[1, 2, 3]),
                              "17 annuli need as many nodes, got 3"),
    "a node off its annulus": (
        lambda: _blade_rotor(nodes=[2] + list(range(2, 18))),
        r"node 2 of blade 'b0' is 5\.6 m from the shaft, annulus 0 at 2\.8667 m"),
    "no wind": (lambda: _blade_rotor(wind=0.0),
                r"wind must be a positive number \(m/s\) or a function of t, got 0\.0"),
    "blade damping of 1 or more": (
        lambda: _blade_modes(damping=1.0),
        r"nrel5mw blade: damping must be a fraction of critical in \[0, 1\), got 1\.0"),
}


@pytest.mark.parametrize("case", sorted(BLADE_API_CASES))
def test_flexible_blades_bad_input(case):
    make, pattern = BLADE_API_CASES[case]
    with pytest.raises(kd.ModelError, match=pattern):
        make()


# ---- issue 35, multiphase problems and Legendre-Gauss-Radau collocation
def _phases(first=None, second=None, **problem):
    """Two phases of the spring's problem (0.5 s each), the first from rest at
    0, the second to rest at 1, with ``first``/``second`` changes; then
    ``kd.MultiphaseProblem`` with ``problem`` (``phases=`` replaces them)."""
    a = _ocp(**{"duration": 0.5, "final": {}, **(first or {})})
    b = _ocp(**{"duration": 0.5, "initial": {}, **(second or {})})
    return kd.MultiphaseProblem(problem.pop("phases", [a, b]), **problem)


def _other_states():
    """A model whose states (z, w) and input (G) the spring lacks."""
    z, w, G = me.dynamicsymbols("z w G")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", z * N.x)
    P.set_vel(N, w * N.x)
    eom = kd.kane(frame=N, q_ind=[z], u_ind=[w], kd_eqs=[z.diff() - w],
                  bodies=[me.Particle("P", P, 1.0)], loads=[(P, G * N.x)])
    numeric = eom.numeric(specified={G: 0.0})
    return kd.OptimalControlProblem(numeric, nodes=5, duration=0.5, lagrange=G ** 2,
                                    final={z: 1, w: 0})


def _junction(*equations):
    q, u = me.dynamicsymbols("q u")
    return kd.Linkage(equations=[e(q, u, me.dynamicsymbols._t, kd.Linkage)
                                 for e in equations])


#: multiphase problems and LGR: each a clear error naming the phase, linkage,
#: state or option at fault
MULTIPHASE_CASES = {
    "LGR degree below 1": (
        lambda: _ocp(method="lgr", degree=0), kd.ModelError,
        r"^degree must be an integer of at least 1 \(the Radau points per interval of "
        r"method='lgr'\), got 0$"),
    "LGR degree not a whole number": (
        lambda: _ocp(method="lgr", degree=2.5), kd.ModelError,
        r"^degree must be an integer of at least 1 .*, got 2\.5$"),
    "degree for another method": (
        lambda: _ocp(degree=3), kd.ModelError,
        r"^degree= is for method='lgr' \(its Radau points per interval\); method "
        r"'trapezoid' has none$"),
    "one phase": (
        lambda: _phases(phases=[_ocp()]), kd.ModelError,
        r"^a multiphase problem needs at least two phases, got 1 \(a single phase is solved "
        r"by its own solve\(\)\)$"),
    "a phase that is not a problem": (
        lambda: _phases(phases=[_ocp(), "phase"]), kd.ModelError,
        r"^phase 2 must be an OptimalControlProblem, got str$"),
    "fewer linkages than junctions": (
        lambda: _phases(phases=[_ocp(), _ocp(), _ocp()], linkages=[kd.Linkage()]),
        kd.ModelError,
        r"^3 phases have 2 junctions, but linkages= gives 1 \(one Linkage per junction, or "
        r"one for all\)$"),
    "a linkage that is not a Linkage": (
        lambda: _phases(linkages=[{"q": "q"}]), kd.ModelError,
        r"^linkage 1 must be a kd\.Linkage, got dict$"),
    "continuous state a phase lacks": (
        lambda: _phases(linkages=kd.Linkage(continuous=["z"])), kd.ModelError,
        r"^linkage 1 \(phases 1 and 2\): continuous names z, which phase 1 lacks \(its "
        r"states: q, u; inputs: F\)$"),
    "linkage equation naming a state the next phase lacks": (
        lambda: _phases(second=None, phases=[_ocp(duration=0.5, final={}), _other_states()],
                        linkages=_junction(lambda q, u, t, L: q.subs(t, L.after) - 1)),
        kd.ModelError,
        r"^linkage 1 \(phases 1 and 2\), equation 0 \(q\(t_j\^\+\) - 1\) names q, which "
        r"phase 2 lacks \(its states: z, w; inputs: G\) \(at its start\)$"),
    "linkage equation at the running time": (
        lambda: _phases(linkages=_junction(lambda q, u, t, L: q - q.subs(t, L.after))),
        kd.ModelError,
        r"equation 0 \(.*\) contains q\(t\): at a junction a state or input is written "
        r"q\(Linkage\.before\) \(the end of phase 1\) or q\(Linkage\.after\)"),
    "linkage equation naming a constant": (
        lambda: _phases(linkages=_junction(
            lambda q, u, t, L: q.subs(t, L.after) - sm.Symbol("m") * q.subs(t, L.before))),
        kd.ModelError,
        r"names m: a linkage names only states and inputs at the junction and its time "
        r"\(write constants as numbers\)$"),
    "phases that share no state": (
        lambda: _phases(phases=[_ocp(duration=0.5, final={}), _other_states()]),
        kd.ModelError,
        r"^linkage 1 \(phases 1 and 2\): the phases share no independent state \(phase 1: "
        r"q, u; phase 2: z, w\), so the default linkage joins nothing; give "
        r"linkages=\[kd\.Linkage\(equations=\[\.\.\.\]\)\]$"),
    "a linkage that joins nothing": (
        lambda: _phases(linkages=kd.Linkage(continuous=[])), kd.ModelError,
        r"^linkage 1 \(phases 1 and 2\) joins nothing: give it continuous states or "
        r"equations"),
    "continuous state fixed to two values": (
        lambda: _phases(first={"final": {"q": 0.4}}, second={"initial": {"q": 0.6}}),
        kd.ModelError,
        r"^linkage 1 \(phases 1 and 2\): q is continuous, but phase 1 ends with q = 0\.4 "
        r"and phase 2 starts with q = 0\.6$"),
    "a start time that is not the junction's": (
        lambda: _phases(second={"start_time": 0.3}), kd.ModelError,
        r"^phase 2 starts where phase 1 ends, at 0\.5 s, but was given start_time=0\.3; "
        r"leave it out or give 0\.5$"),
    "a start time after a free duration": (
        lambda: _phases(first={"duration": sm.Symbol("T1"),
                               "bounds": {sm.Symbol("T1"): (0.1, 1)}},
                        second={"start_time": 0.5}), kd.ModelError,
        r"^phase 2 starts where phase 1 ends, which follows a free duration: leave its "
        r"start_time out \(it was given 0\.5 s\)$"),
    "one free-duration symbol in two phases": (
        lambda: _phases(first={"duration": sm.Symbol("T"), "bounds": {sm.Symbol("T"): (0.1, 1)}},
                        second={"duration": sm.Symbol("T"),
                                "bounds": {sm.Symbol("T"): (0.1, 1)}}), kd.ModelError,
        r"^phases 1 and 2 both have the free duration T; give each phase a symbol of its "
        r"own$"),
    "a guess per phase missing": (
        lambda: _phases().solve([np.zeros(33)]), kd.ModelError,
        r"^give one guess per phase: 2 phases, 1 guesses$"),
    "a phase's guess of the wrong shape": (
        lambda: _phases().solve([np.zeros(33), np.zeros(5)]), kd.ModelError,
        r"^phase 2: the guess must have shape \(33,\)"),
}


@pytest.mark.parametrize("case", sorted(MULTIPHASE_CASES))
def test_multiphase_and_lgr_bad_input(case):
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt")
    make, kind, pattern = MULTIPHASE_CASES[case]
    with pytest.raises(kind, match=pattern):
        make()


# ---- issue 35, item 4: the Shuttle arm and out-parallel studies
_S = sm.Symbol("s")

#: auxiliary variables of an optimal-control problem, and the two studies' options:
#: each a clear error naming the variable or option
STUDY_OCP_CASES = {
    "auxiliary variable that is a constant": (
        lambda: _ocp(auxiliary={sm.Symbol("m"): 1.0}), kd.ModelError,
        r"^auxiliary variable m is a constant of the model \(list it in parameters= to "
        r"optimize it\)$"),
    "auxiliary variable that is a state": (
        lambda: _ocp(auxiliary={sm.Symbol("q"): 1.0}), kd.ModelError,
        r"^auxiliary variable q is a state of the model$"),
    "auxiliary variable named by text": (
        lambda: _ocp(auxiliary={"s": 1.0}), kd.ModelError,
        r"^auxiliary variables are SymPy symbols, got 's'$"),
    "auxiliary variables as a list": (
        lambda: _ocp(auxiliary=[_S]), kd.ModelError,
        r"^auxiliary must be a dict \{symbol: starting value\}, got list$"),
    "auxiliary starting value as text": (
        lambda: _ocp(auxiliary={_S: "big"}), kd.ModelError,
        r"^starting value of the auxiliary variable s must be a finite number, got 'big'$"),
    "auxiliary starting value nan": (
        lambda: _ocp(auxiliary={_S: float("nan")}), kd.ModelError,
        r"^starting value of the auxiliary variable s must be a finite number, got nan$"),
    "objective naming an undeclared auxiliary": (
        lambda: _ocp(lagrange=None, mayer=_S), kd.ModelError,
        r"terminal cost \(mayer\) names s, which is not a symbol of the model"),
    "shuttle arm: negative joint-angle margin": (
        lambda: kd.studies.shuttle_arm_minimum_energy(margin=-5.0), kd.KanedynError,
        r"^margin must be a number of degrees >= 0 \(inf: no joint-angle limits\), got -5\.0$"),
    "shuttle arm: torque factor zero": (
        lambda: kd.studies.shuttle_arm_minimum_energy(torque_factor=0.0), kd.KanedynError,
        r"^torque_factor must be a positive number, got 0\.0$"),
    "shuttle arm: flexible booms as a model option": (
        lambda: kd.studies.shuttle_arm_minimum_energy(model_options={"flexible_booms": True}),
        kd.KanedynError, r"^the model option flexible_booms is set by the study's option booms "
                         r"\(booms='flexible', --set booms=flexible\), got flexible_booms=True$"),
    "shuttle arm: unknown booms": (
        lambda: kd.studies.shuttle_arm_minimum_energy(booms="elastic"),
        kd.KanedynError, r"^booms must be one of rigid, flexible, got 'elastic'$"),
    "out-parallel: force limit not positive": (
        lambda: kd.studies.out_parallel_least_peak_force(force_limit=-200.0), kd.KanedynError,
        r"^force_limit must be a positive number \(N\), got -200\.0$"),
    "out-parallel: negative regularization": (
        lambda: kd.studies.out_parallel_least_peak_force(regularization=-1e-5),
        kd.KanedynError, r"^regularization must be a number >= 0, got -1e-05$"),
}


@pytest.mark.parametrize("case", sorted(STUDY_OCP_CASES))
def test_study_optimal_control_bad_input(case):
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt")
    make, kind, pattern = STUDY_OCP_CASES[case]
    with pytest.raises(kind, match=pattern):
        make()


def test_study_option_from_the_command_line_is_one_line(capsys):
    """``kanedyn optimize shuttle-arm --set margin=-1``: exit 2, the option named."""
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt")
    assert main(["optimize", "shuttle-arm", "--set", "margin=-1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "margin must be a number of degrees >= 0" in err and len(err.splitlines()) == 1


def test_study_choice_from_the_command_line_names_the_option(capsys):
    """``kanedyn optimize shuttle-arm --set booms=elastic``: exit 2, the option
    and its choices named."""
    pytest.importorskip("cyipopt", reason="optimal control needs cyipopt")
    assert main(["optimize", "shuttle-arm", "--set", "booms=elastic", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "option booms must be one of rigid, flexible, got 'elastic'" in err


# ---- issue 39: events of simulate_many (kd.Event)
@pytest.fixture(scope="module")
def torqued_pendulum():
    if kd.numerics.backends.compiler_command() is None:
        pytest.skip("simulate_many runs in the C backend")
    return kd.models.build("pendulum", torque=True).numeric(backend="c")


def _many(model, events):
    return kd.simulate_many(model, [0.1, 0.0], (0.0, 0.5), inputs={"tau": 0.0},
                            events=events)


def _q_u():
    return me.dynamicsymbols("q u")


def _knee(t, y):
    return y[0]


EVENT_CASES = {
    "an event that is a Python function": (
        lambda m: _many(m, [_knee]), kd.OptionError,
        r"^simulate_many: event _knee is a Python function, which cannot run in the C "
        r"threads that integrate the runs; give it as a SymPy expression of t and the "
        r"model's states, inputs and constants, kd\.Event\(expression, terminal=\.\.\., "
        r"direction=\.\.\.\) \(kd\.simulate takes the same Event\)$"),
    "an event given as text": (
        lambda m: _many(m, ["q - 0.2"]), kd.OptionError,
        r"^simulate_many: events\[0\] is not a SymPy expression or a kd\.Event: 'q - 0\.2'$"),
    "an Event's expression given as text": (
        lambda m: kd.Event("__import__('os')"), kd.ModelError,
        r"^an event's expression is the text \"__import__\('os'\)\"; give a number or a "
        r"SymPy expression \(text is never run as code\)$"),
    "a condition for an event": (
        lambda m: kd.Event(_q_u()[0] > 0.2), kd.OptionError,
        r"^event q\(t\) > 0\.2 is a condition; an event is a value that crosses zero; give "
        r"q\(t\) - 0\.2$"),
    "a direction of 2": (
        lambda m: kd.Event(_q_u()[0], direction=2), kd.OptionError,
        r"^event q\(t\): direction must be -1, 0 or 1, got 2$"),
    "terminal given as text": (
        lambda m: kd.Event(_q_u()[0], terminal="yes"), kd.OptionError,
        r"^event q\(t\): terminal must be True or False, got 'yes'$"),
    "a symbol the model does not have": (
        lambda m: _many(m, kd.Event(_q_u()[0] - sm.Symbol("x0"), name="reach")),
        kd.ModelError,
        r"^event reach: x0 is not the time t or a state, input or constant of this model "
        r"\(states: q, u; constants: g, l, m; inputs: tau\); give numbers for other "
        r"values$"),
    "a symbol the model does not have, in kd.simulate": (
        lambda m: kd.simulate(m.with_inputs({"tau": 0.0}), (0.0, 0.5), [0.1, 0.0],
                              events=[_q_u()[0] - me.dynamicsymbols("w")]),
        kd.ModelError, r"^event q\(t\) - w\(t\): w is not the time t or a state"),
    "a rate in an event": (
        lambda m: _many(m, _q_u()[0].diff()), kd.ModelError,
        r"^event Derivative\(q\(t\), t\): it holds the derivative\(s\) "
        r"Derivative\(q\(t\), t\); an event is a function of the state: write the rates "
        r"of the coordinates with the speeds \(the kinematic equations\)$"),
}


@pytest.mark.parametrize("case", sorted(EVENT_CASES))
def test_ensemble_event_bad_input(torqued_pendulum, case):
    make, kind, pattern = EVENT_CASES[case]
    with pytest.raises(kind, match=pattern):
        make(torqued_pendulum)
