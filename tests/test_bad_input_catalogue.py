"""The catalogue of bad input: each kind gets its exception type and a message
that names the culprit (body, symbol, option, file).  Runs in seconds."""

import re

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn.cli import main


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
    "derive with a value": (["derive", "pendulum", "--set", "m=2"],
                            "derive takes only model options"),
    "unknown formulation": (["compare", "pendulum", "--methods", "kane,hamilton"],
                            "unknown formulation.*hamilton"),
}


@pytest.mark.parametrize("case", sorted(CLI_CASES))
def test_bad_command_line(case, capsys, tmp_path):
    argv, pattern = CLI_CASES[case]
    extra = {"run": ["--out", str(tmp_path), "--quiet"], "derive": ["--quiet"]}
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
