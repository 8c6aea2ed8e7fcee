"""Standalone C export: compiles on its own and computes what model.rhs computes."""

import ctypes
import re
import shutil
import subprocess

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main

CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler (cc) installed")

STRICT = ["-std=c99", "-Wall", "-Werror", "-pedantic"]


def _compile_library(source, tmp_path, name="model"):
    """The file compiled under the strict flags at -O2 into a library, loaded.

    One compiler run: the warnings at -O2 include those at -O0 (the front end's
    are the same at every level; the ones that need the optimizer's analysis
    come on top), so the -c run at -O0 this made first checked nothing more,
    and was a third of the compiler's time (the Whipple bicycle's file: 0.7 s
    at -O0, 1.9 s at -O2)."""
    c_file = tmp_path / f"{name}.c"
    c_file.write_text(source)
    lib = tmp_path / f"lib{name}.so"
    subprocess.run([CC, "-shared", "-fPIC", "-O2", *STRICT, str(c_file), "-o", str(lib),
                    "-lm"], check=True, capture_output=True, text=True)
    return ctypes.CDLL(str(lib))


def _call(lib, function, t, y, p, r, n_out):
    vec = ctypes.POINTER(ctypes.c_double)
    out = np.zeros(n_out)

    def arr(a):
        a = np.ascontiguousarray(a, dtype=float)
        return a.ctypes.data_as(vec) if a.size else None
    fn = getattr(lib, function)
    fn.restype = ctypes.c_int
    fn.argtypes = [ctypes.c_double, vec, vec, vec, vec]
    code = fn(float(t), arr(y), arr(p), arr(r), out.ctypes.data_as(vec))
    return code, out


def _states(definition, model, rng, count=5):
    """Random states near the model's initial state, consistent with the constraints."""
    out = []
    for _ in range(count):
        y = definition.initial(model) + rng.uniform(-0.3, 0.3, model.n_states)
        if model.n_q_dep or model.n_u_dep:
            y = model.consistent_state(0.0, y)
        out.append(y)
    return out


CASES = [("pendulum", {}), ("four-bar", {}), ("rolling-disk", {}), ("chain3d", {"n": 3}),
         ("chaplygin-sleigh", {})]


@pytest.mark.parametrize("name, options", CASES, ids=[c[0] for c in CASES])
def test_standalone_rhs_matches_model_rhs(name, options, tmp_path):
    definition = kd.models.build(name, **options)
    model = definition.numeric(definition.derive())  # numpy backend: an independent path
    lib = _compile_library(model.c_source(), tmp_path)
    p = np.array(list(model.constants.values()))
    rng = np.random.default_rng(1)
    for k, y in enumerate(_states(definition, model, rng)):
        t = 0.1 * k
        code, ydot = _call(lib, "kanedyn_rhs", t, y, p, [], model.n_states)
        assert code == 0
        expected = model.rhs(t, y)
        np.testing.assert_allclose(ydot, expected, rtol=1e-13,
                                   atol=1e-13 * max(1.0, np.max(np.abs(expected))))
        code, residual = _call(lib, "kanedyn_constraints", t, y, p, [],
                               model.n_q_dep + model.n_u_dep)
        assert code == 0
        np.testing.assert_allclose(residual, model.constraint_residuals(t, y), atol=1e-13)
        code, energy = _call(lib, "kanedyn_energy", t, y, p, [], 2)
        assert energy[0] == pytest.approx(model.kinetic_energy(t, y), rel=1e-13, abs=1e-13)


def test_standalone_export_of_a_model_solved_by_the_tree_pass(tmp_path):
    """A C-backend model solved by the articulated-body pass exports a
    standalone file that solves by the same pass (the mass matrix only as the
    fallback where the pass meets a pivot that is not positive): it compiles
    under the strict flags and gives the NumPy model's rhs."""
    from kanedyn.numerics.backends._c import TREE_MIN_SPEEDS
    definition = kd.models.build("chain3d", n=TREE_MIN_SPEEDS, style="positions")
    eom = definition.derive()
    model = definition.numeric(eom, backend="c")
    source = model.c_source()
    assert "#define KD_SOLVE 3" in source and "kd_eval_tree(" in source
    lib = _compile_library(source, tmp_path)
    model = definition.numeric(eom)  # numpy backend: an independent path
    p = np.array(list(model.constants.values()))
    for y in _states(definition, model, np.random.default_rng(2), count=3):
        code, ydot = _call(lib, "kanedyn_rhs", 0.0, y, p, [], model.n_states)
        assert code == 0
        expected = model.rhs(0.0, y)
        np.testing.assert_allclose(ydot, expected, rtol=1e-11,
                                   atol=1e-11 * max(1.0, np.max(np.abs(expected))))


def test_parameters_and_inputs_are_passed(tmp_path):
    """Other parameter values and a specified input given at run time (r)."""
    definition = kd.models.build("n-link-pendulum-on-cart", n=2)
    eom = definition.derive()
    force = set(eom.specified)  # F(t), the push on the cart
    assert len(force) == 1

    def push(t, y):
        return 0.3 + np.sin(2.0 * t)
    model = definition.numeric(eom, constants={"m": 0.7}, specified={force.pop(): push})
    assert model.input_names == ("F(t)",)
    source = model.c_source(title="cart with two links")
    assert source.startswith("/*\n * cart with two links")
    assert " *   r[0] = F\n" in source
    lib = _compile_library(source, tmp_path)
    names = list(model.constants)
    p = np.array([model.constants[n] for n in names])
    p[names.index("l")] = 0.45
    other = model.with_constants({"l": 0.45})
    for t in (0.0, 0.4, 1.3):
        y = np.random.default_rng(int(10 * t)).uniform(-1, 1, model.n_states)
        code, ydot = _call(lib, "kanedyn_rhs", t, y, p, [push(t, y)], model.n_states)
        assert code == 0
        np.testing.assert_allclose(ydot, other.rhs(t, y), rtol=1e-13, atol=1e-13)


def test_header_documents_the_interface():
    definition = kd.models.build("four-bar")
    model = definition.numeric(definition.derive())
    source = model.c_source(title="four-bar")
    header = source[:source.index("*/")]
    assert "int kanedyn_rhs(double t, const double *y, const double *p," in header
    assert "Return codes: 0 success; 1 singular" in header
    for k, name in enumerate(model.state_names):
        assert f"y[{k}] = {name}\n" in header
    for k, (name, value) in enumerate(model.constants.items()):
        assert f"p[{k}] = {name} = {value!r}" in header
    assert re.search(r"^int kanedyn_rhs\(", source, re.M)


def test_driver_program_prints_the_rhs(tmp_path):
    """A C program of a user: links the exported file, prints ydot."""
    definition = kd.models.build("four-bar")
    model = definition.numeric(definition.derive())
    model.export_c(tmp_path / "fourbar.c", title="four-bar")
    y = model.consistent_state(0.0, definition.initial(model))
    driver = tmp_path / "main.c"
    driver.write_text(
        "#include <stdio.h>\n"
        "int kanedyn_rhs(double, const double *, const double *, const double *, double *);\n"
        "extern const double kanedyn_default_parameters[];\n"
        "int main(void) {\n"
        f"    const double y[{model.n_states}] = {{{', '.join(repr(float(v)) for v in y)}}};\n"
        f"    double ydot[{model.n_states}];\n"
        "    int code = kanedyn_rhs(0.0, y, kanedyn_default_parameters, NULL, ydot);\n"
        f"    for (int i = 0; i < {model.n_states}; ++i) printf(\"%.17g\\n\", ydot[i]);\n"
        "    return code;\n}\n")
    exe = tmp_path / "driver"
    subprocess.run([CC, *STRICT, str(driver), str(tmp_path / "fourbar.c"), "-o", str(exe),
                    "-lm"], check=True, capture_output=True, text=True)
    run = subprocess.run([str(exe)], check=True, capture_output=True, text=True)
    printed = np.array([float(v) for v in run.stdout.split()])
    np.testing.assert_allclose(printed, model.rhs(0.0, y), rtol=1e-13, atol=1e-13)


def test_singular_system_returns_1(tmp_path):
    definition = kd.models.build("pendulum")
    model = definition.numeric(definition.derive())
    lib = _compile_library(model.c_source(), tmp_path)
    p = np.array([0.0 if name == "m" else v for name, v in model.constants.items()])
    code, _ = _call(lib, "kanedyn_rhs", 0.0, [0.3, 0.0], p, [], 2)
    assert code == 1


def test_extension_module_source(tmp_path):
    """The one-file source of the extension module compiles into a module
    whose Model and functions give the compiled model's numbers."""
    import importlib.machinery
    import importlib.util
    import sysconfig

    definition = kd.models.build("pendulum")
    model = definition.numeric(definition.derive(), backend="c")
    source = model.c_source(standalone=False, module_name="my_pendulum")
    assert "#include <Python.h>" in source and "PyInit_my_pendulum" in source
    with pytest.raises(kd.ModelError, match="module_name"):
        model.c_source(standalone=False, module_name="not valid")
    c_file = tmp_path / "my_pendulum.c"
    c_file.write_text(source)
    library = tmp_path / f"my_pendulum{sysconfig.get_config_var('EXT_SUFFIX') or '.so'}"
    subprocess.run([CC, "-shared", "-fPIC", "-O1", "-std=gnu11",
                    f"-I{sysconfig.get_paths()['include']}", f"-I{np.get_include()}",
                    str(c_file), "-o", str(library), "-lm"], check=True)
    loader = importlib.machinery.ExtensionFileLoader("my_pendulum", str(library))
    module = importlib.util.module_from_spec(
        importlib.util.spec_from_file_location("my_pendulum", str(library), loader=loader))
    loader.exec_module(module)
    p = np.array([model.constants[name] for name in sorted(model.constants)])
    y = np.array([0.4, -0.3])
    np.testing.assert_array_equal(module.Model(p).rhs(0.0, y), model.rhs(0.0, y))
    kinetic, potential = module.energy(0.0, y, p, np.zeros(0))
    assert kinetic == pytest.approx(model.kinetic_energy(0.0, y), rel=1e-14)
    assert potential == pytest.approx(model.potential_energy(0.0, y), rel=1e-14)


def test_cli_derive_writes_c(tmp_path, capsys):
    out = tmp_path / "pendulum.c"
    assert main(["derive", "pendulum", "--quiet", "--c", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    subprocess.run([CC, "-c", *STRICT, str(out), "-o", str(tmp_path / "p.o")], check=True)
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["derive", "pendulum", "--quiet", "--c", str(blocker / "x.c")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--c" in err[0]


@pytest.mark.slow
def test_large_model_with_work_array(tmp_path):
    """The Whipple bicycle: dependent coordinates and speeds, the largest classic model."""
    definition = kd.models.build("whipple-bicycle")
    model = definition.numeric(definition.derive())
    lib = _compile_library(model.c_source(), tmp_path)
    p = np.array(list(model.constants.values()))
    y = model.consistent_state(0.0, definition.initial(model))
    code, ydot = _call(lib, "kanedyn_rhs", 0.0, y, p, [], model.n_states)
    assert code == 0
    expected = model.rhs(0.0, y)
    np.testing.assert_allclose(ydot, expected, rtol=1e-12,
                               atol=1e-13 * np.max(np.abs(expected)))


def test_split_program_uses_the_heap_work_array(tmp_path, monkeypatch):
    """Programs longer than CHUNK statements are split; values cross in a work array."""
    from kanedyn.numerics.backends import _c
    monkeypatch.setattr(_c, "CHUNK", 20)
    definition = kd.models.build("four-bar")
    model = definition.numeric(definition.derive())
    source = model.c_source()
    assert re.search(r"#define KD_NW [1-9]", source) and "kd_dynamics_part1" in source
    lib = _compile_library(source, tmp_path)
    p = np.array(list(model.constants.values()))
    for y in _states(definition, model, np.random.default_rng(3), count=3):
        code, ydot = _call(lib, "kanedyn_rhs", 0.0, y, p, [], model.n_states)
        assert code == 0
        np.testing.assert_allclose(ydot, model.rhs(0.0, y), rtol=1e-13, atol=1e-13)


def test_a_model_with_contacts_is_refused_not_exported_without_them(tmp_path):
    definition = kd.models.build("bouncing-ball")
    model = definition.numeric(backend="numpy")
    with pytest.raises(kd.ModelError, match=r"standalone C of a model with contacts "
                                            r"\(floor\)"):
        model.export_c(tmp_path / "ball.c")
    assert not (tmp_path / "ball.c").exists()


def _jacobians_call(lib, t, y, p, r, rows, columns, n_constraints):
    """``kanedyn_jacobians`` of a compiled file: (code, ydot, jacobian, constraint rows)."""
    vec = ctypes.POINTER(ctypes.c_double)
    ydot, jacobian = np.zeros(len(y)), np.zeros((rows, columns))
    constraint = np.zeros((n_constraints, len(y)))

    def arr(a):
        a = np.ascontiguousarray(a, dtype=float)
        return a.ctypes.data_as(vec) if a.size else None
    fn = lib.kanedyn_jacobians
    fn.restype = ctypes.c_int
    fn.argtypes = [ctypes.c_double, vec, vec, vec, vec, vec, vec]
    code = fn(float(t), arr(y), arr(p), arr(r), arr(ydot), arr(jacobian), arr(constraint))
    return code, ydot, jacobian, constraint


def _assert_jacobians_equal(lib, model, t, y, r, parameters, rtol):
    """The file's derivatives at (t, y, r) against ``model.jacobians``."""
    p = np.array(list(model.constants.values()))
    x, n_r = model.n_states, len(model.input_names)
    expected = model.jacobians(t, y, r=r if n_r else None, parameters=parameters)
    columns = x + n_r + (len(p) if parameters else 0)
    code, ydot, jacobian, constraint = _jacobians_call(
        lib, t, y, p, r, x + model.n_u_dep, columns, model.n_q_dep + model.n_u_dep)
    assert code == 0
    blocks = [(ydot, expected.f), (jacobian[:x, :x], expected.state),
              (jacobian[:x, x:x + n_r], expected.inputs), (constraint, expected.constraints)]
    if parameters:
        blocks.append((jacobian[:x, x + n_r:], expected.parameters))
    if model.n_u_dep:
        blocks.append((jacobian[x:, :x], expected.multipliers))
        blocks.append((jacobian[x:, x:x + n_r], expected.multipliers_inputs))
    scale = max(1.0, np.max(np.abs(expected.state)))
    for found, wanted in blocks:
        np.testing.assert_allclose(found, wanted, rtol=rtol, atol=rtol * scale)


JACOBIAN_CASES = [("four-bar", {}, True), ("n-link-pendulum-on-cart", {"n": 2}, False),
                  ("rolling-disk", {}, False)]


@pytest.mark.parametrize("name, options, parameters", JACOBIAN_CASES,
                         ids=[c[0] for c in JACOBIAN_CASES])
def test_standalone_jacobians_match_model_jacobians(name, options, parameters, tmp_path):
    """``c_source(jacobians=True)``: ``kanedyn_jacobians`` of the file, compiled
    under the strict flags, against the NumPy backend's generated derivatives
    (an independent path), at random consistent states and inputs: a loop with
    dependent coordinates and speeds (multipliers and constraint rows; the
    constants' columns too), a specified input, a nonholonomic disk.
    Measured: equal to 1.1e-14 of the largest entry or better."""
    definition = kd.models.build(name, **options)
    model = definition.numeric(definition.derive())
    source = model.c_source(jacobians=True, parameters=parameters)
    assert "int kanedyn_jacobians(double t," in source[:source.index("*/")]
    lib = _compile_library(source, tmp_path)
    rng = np.random.default_rng(4)
    for k, y in enumerate(_states(definition, model, rng, count=3)):
        r = rng.uniform(-1.0, 1.0, len(model.input_names))
        _assert_jacobians_equal(lib, model, 0.2 * k, y, r, parameters, rtol=1e-12)


def test_standalone_jacobians_of_a_tree_solved_by_the_pass(tmp_path, monkeypatch):
    """A chain whose derivative module solves by the articulated-body pass, its
    derivatives formed from the tree's factors at run time (taken here from 4
    speeds on, by default from 12 and paths of 10): the file solves the same
    way and gives the compiled module's derivatives (measured: equal to the
    bit), its kanedyn_rhs the module's rhs."""
    from kanedyn.numerics import _jacobians
    from kanedyn.numerics.backends import _c
    monkeypatch.setattr(_c, "TREE_MIN_SPEEDS", 4)
    monkeypatch.setattr(_jacobians, "TREE_FACTOR_MIN_SPEEDS", 4)
    monkeypatch.setattr(_jacobians, "TREE_SOLVE_MIN_DEPTH", 1)
    definition = kd.models.build("chain3d", n=4, style="positions")
    # the equations given: no derivation-cache entry, whose module gcc would build
    # at once (the settings above are not part of its key either); the module's
    # numbers are those of gcc's to the bit (tests/test_quick_compile.py)
    model = definition.numeric(definition.derive(), backend="c")
    source = model.c_source(jacobians=True)
    assert "#define KD_JAC_TREE_SOLVE 1" in source and "#define KD_TREE_JAC 1" in source
    lib = _compile_library(source, tmp_path)
    p = np.array(list(model.constants.values()))
    for y in np.random.default_rng(5).uniform(-1.5, 1.5, (2, model.n_states)):
        _assert_jacobians_equal(lib, model, 0.0, y, [], False, rtol=1e-13)
        code, ydot = _call(lib, "kanedyn_rhs", 0.0, y, p, [], model.n_states)
        assert code == 0
        np.testing.assert_allclose(ydot, model.rhs(0.0, y), rtol=1e-13, atol=1e-13)


def test_jacobians_options_refused_where_they_do_not_apply(tmp_path):
    definition = kd.models.build("pendulum")
    model = definition.numeric(definition.derive())
    with pytest.raises(ValueError, match="jacobians: only in the standalone file"):
        model.c_source(standalone=False, jacobians=True)
    with pytest.raises(ValueError, match="parameters: .* need jacobians=True"):
        model.c_source(parameters=True)
    with pytest.raises(kd.ModelError, match="'baumgarte' scheme"):
        kd.models.build("four-bar").numeric(scheme="baumgarte").c_source(jacobians=True)


def test_cli_derive_writes_the_jacobians(tmp_path, capsys):
    """``kanedyn derive MODEL --c FILE --jacobians``: a file whose
    kanedyn_jacobians gives model.jacobians; without --c, an error naming it."""
    path = tmp_path / "pendulum.c"
    assert main(["derive", "pendulum", "--c", str(path), "--jacobians", "--quiet"]) == 0
    lib = _compile_library(path.read_text(), tmp_path)
    definition = kd.models.build("pendulum")
    model = definition.numeric(definition.derive())
    _assert_jacobians_equal(lib, model, 0.0, np.array([0.4, -1.1]), [], False, rtol=1e-13)
    capsys.readouterr()
    assert main(["derive", "pendulum", "--jacobians"]) == 2
    assert "--jacobians" in capsys.readouterr().err
