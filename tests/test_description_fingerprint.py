"""A user's model description in the derivation cache: the digest of the
description (``kanedyn.models._fingerprint``) is the same for the same
description built again and differs for every change; an unchanged model is
read from the cache, a changed one derived again."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.models._base import DERIVE_STATS
from kanedyn.models._fingerprint import description_fingerprint

#: a user's model, written with sympy.physics.mechanics: a double pendulum whose
#: ``variant`` changes one thing of its description (run here and, as text, in a
#: second interpreter)
BUILDER = '''
import sympy as sm
import sympy.physics.mechanics as me
from kanedyn.models import ModelDefinition


def double_pendulum(variant=None):
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    l, m, g = sm.symbols("l m g", positive=variant != "assumption")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (q1, N.z))
    B = A.orientnew("B", "Axis", (q2, A.y if variant == "axis" else A.z))
    A.set_ang_vel(N, u1 * N.z)
    B.set_ang_vel(A, u2 * (A.y if variant == "axis" else A.z))
    O = me.Point("O")
    O.set_vel(N, 0)
    P1 = O.locatenew("P1", l * A.x)
    P2 = P1.locatenew("P2", (2 * l if variant == "length" else l) * B.x)
    P1.v2pt_theory(O, N, A)
    P2.v2pt_theory(P1, N, B)
    bodies = [me.Particle("p1", P1, m), me.Particle("p2", P2, m)]
    sign = -1 if variant == "load" else 1
    loads = [(P1, sign * m * g * N.x), (P2, m * g * N.x)]
    kd_eqs = [q1.diff() - u1, q2.diff() - (2 * u2 if variant == "kinematics" else u2)]
    constants = {l: 1.0, m: 2.0 if variant == "constant" else 1.0, g: 9.81}
    return ModelDefinition(
        name="double pendulum", title="a user's double pendulum",
        kane_args=dict(frame=N, q_ind=[q1, q2], u_ind=[u1, u2], kd_eqs=kd_eqs,
                       bodies=bodies, loads=loads),
        constants=constants, initial_state={q1: 0.4, q2: -0.3, u1: 0.1, u2: 0.2},
        t_end=1.0, specified={sm.Symbol("unused"): 0.0} if variant == "specified" else {})
'''
_namespace = {}
exec(compile(BUILDER, "<double pendulum>", "exec"), _namespace)  # the test's own code
double_pendulum = _namespace["double_pendulum"]

VARIANTS = ("assumption", "axis", "length", "load", "kinematics", "constant", "specified")


def test_same_description_same_digest_in_another_process():
    """Fresh SymPy objects, the same description: the same digest, here and in a
    second interpreter (another hash seed)."""
    here = description_fingerprint(double_pendulum())
    assert here is not None and here == description_fingerprint(double_pendulum())
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = dict(os.environ, PYTHONPATH=src, PYTHONHASHSEED="12345")
    code = (BUILDER + "\nimport json\nfrom kanedyn.models._fingerprint import "
            "description_fingerprint\nprint(json.dumps(description_fingerprint("
            "double_pendulum())))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == here


@pytest.mark.parametrize("variant", VARIANTS)
def test_every_change_of_the_description_changes_the_digest(variant):
    assert description_fingerprint(double_pendulum(variant)) \
        != description_fingerprint(double_pendulum())


def test_a_description_holding_a_function_has_no_digest():
    """What the digest does not cover (here a specified input given as a
    function of time): no digest, so never read from the cache."""
    import sympy as sm
    definition = double_pendulum()
    definition.specified[sm.Symbol("F")] = lambda t: 0.0
    assert description_fingerprint(definition) is None


def test_unchanged_user_model_is_read_from_the_cache_a_changed_one_derived(
        tmp_path, monkeypatch):
    """The second numerical model of an unchanged description (new SymPy
    objects) is the cache's: not derived, the same accelerations as a fresh
    derivation with the numpy backend; a changed one is derived again and
    gives its own."""
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    tmp_path.chmod(0o700)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    y = np.array([0.4, -0.3, 0.1, 0.2])
    first = double_pendulum().numeric(backend="c")
    # the entry is written once its module is cached (its build started at once;
    # builds of earlier tests waiting for their use to pay are not started)
    kd.numerics.finish_compiling(start_waiting=False)
    before = DERIVE_STATS["derivations"]
    again = double_pendulum().numeric(backend="c", constants={"m": 1.5})
    assert DERIVE_STATS["derivations"] == before  # read, not derived
    fresh = double_pendulum()
    reference = fresh.numeric(fresh.derive(), constants={"m": 1.5})
    assert np.allclose(again.rhs(0.0, y), reference.rhs(0.0, y), rtol=1e-12, atol=1e-12)
    assert np.array_equal(first.rhs(0.0, y), double_pendulum().numeric(backend="c").rhs(0.0, y))
    changed = double_pendulum("length").numeric(backend="c")
    assert DERIVE_STATS["derivations"] == before + 2  # the reference, and the changed model
    other = double_pendulum("length")
    expected = other.numeric(other.derive())
    assert np.allclose(changed.rhs(0.0, y), expected.rhs(0.0, y), rtol=1e-12, atol=1e-12)
    assert not np.allclose(changed.rhs(0.0, y), first.rhs(0.0, y))


def test_a_description_changed_after_its_model_was_read_is_not_derived_for_it(
        tmp_path, monkeypatch):
    """The equations of a model read from the cache are derived from its
    definition when first asked for; a definition changed in between would
    give other equations: refused, naming the model."""
    import sympy.physics.mechanics as me
    from kanedyn.numerics import compiler_command
    if compiler_command() is None:
        pytest.skip("no C compiler")
    tmp_path.chmod(0o700)
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(tmp_path))
    double_pendulum().numeric(backend="c")
    kd.numerics.finish_compiling(start_waiting=False)
    definition = double_pendulum()
    model = definition.numeric(backend="c")
    N = definition.kane_args["frame"]
    definition.kane_args["bodies"][1].masscenter.set_vel(N, me.Vector(0))
    with pytest.raises(kd.ModelError, match="model double pendulum: its description changed"):
        model.linearize(0.0, np.zeros(4))
