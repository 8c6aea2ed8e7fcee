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
    c_file = tmp_path / f"{name}.c"
    c_file.write_text(source)
    subprocess.run([CC, "-c", *STRICT, str(c_file), "-o", str(tmp_path / f"{name}.o")],
                   check=True, capture_output=True, text=True)
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
