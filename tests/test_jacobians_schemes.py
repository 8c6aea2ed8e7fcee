"""Exact derivatives for the constraint schemes that stabilize (issue 34).

Baumgarte, penalty, augmented Lagrangian (and Udwadia-Kalaba with gains, the
index-3 augmented Lagrangian through ``rhs``): ``model.jacobians`` against
fourth-order central differences of ``model.rhs`` (state), of
``model.jacobians(r=...).f`` (inputs), of ``model.with_constants(...).rhs``
(constants) and of ``model.multipliers``, at random states *off* the constraint
manifold, where the stabilization's :math:`P^+h` has a derivative of its own.

Tolerance: 1e-8 relative to the largest entry, as in ``test_jacobians.py``.
The differences' truncation error is about :math:`h^4` (1e-16 at the step
1e-4) and their round-off about :math:`\\epsilon\\kappa/h`, with
:math:`\\kappa` the condition number of the solve that gives the
accelerations: for the index-1 systems the measured worst was 4e-11.  The
penalty's solve has :math:`\\kappa` of about its factor, so the penalty is
checked at ``factor=10`` to 1e-8, and at its default 1e7 with the step 1e-2
(truncation about 1e-8) to 1e-6.
"""

from dataclasses import dataclass
from functools import cache
from typing import ClassVar

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from test_jacobians import differences, needs_compiler, relative

import kanedyn as kd

S = kd.schemes


@cache
def equations(name):
    definition = kd.models.build(name)
    return definition, definition.derive()


def off_the_manifold(definition, model, seed=0, scale=0.1):
    """The model's initial state moved at random in every entry: all constraints
    violated (the initial state itself satisfies them)."""
    y = np.asarray(definition.initial(model), dtype=float)
    y = y + scale * np.random.default_rng(seed).standard_normal(y.size)
    assert np.max(np.abs(model.constraint_residuals(0.0, y))) > 1e-3
    return y


def check_against_differences(model, definition, y, tol=1e-8, step=1e-4):
    """Worst relative differences of state, constants and multipliers."""
    J = model.jacobians(0.0, y, parameters=True)
    np.testing.assert_allclose(J.f, model.rhs(0.0, y), rtol=1e-12, atol=1e-12)
    worst = {"state": relative(J.state, differences(lambda z: model.rhs(0.0, z), y, step))}
    names = list(model.constants)
    p0 = np.array([model.constants[k] for k in names])
    fp = differences(lambda p: model.with_constants(dict(zip(names, p))).rhs(0.0, y), p0,
                     step, scaled=True)
    worst["parameters"] = relative(J.parameters, fp)
    worst["multipliers"] = relative(J.multipliers, differences(
        lambda z: list(model.multipliers(0.0, z).values()), y, step))
    for field, value in worst.items():
        assert value < tol, (field, value)
    return worst


STABILIZED = [S.Baumgarte(), S.Penalty(factor=10.0), S.AugmentedLagrangian()]


@pytest.mark.parametrize("scheme", STABILIZED + [S.AugmentedLagrangianIndex3(),
                                                 S.UdwadiaKalaba(alpha=5.0, beta=5.0)],
                         ids=lambda s: s.name)
@pytest.mark.parametrize("seed", [0, 1])
def test_a_closed_loop_off_its_constraints(scheme, seed):
    """The four-bar: two configuration constraints, P square."""
    definition, eom = equations("four-bar")
    model = definition.numeric(eom, backend="numpy", scheme=scheme)
    check_against_differences(model, definition, off_the_manifold(definition, model, seed))


@pytest.mark.parametrize("scheme", STABILIZED, ids=lambda s: s.name)
def test_a_nonholonomic_model_off_its_constraints(scheme):
    """The rolling disk: velocity constraints only (s = g_v c)."""
    definition, eom = equations("rolling-disk")
    model = definition.numeric(eom, backend="numpy", scheme=scheme)
    check_against_differences(model, definition, off_the_manifold(definition, model))


@pytest.mark.slow
@pytest.mark.parametrize("scheme", STABILIZED, ids=lambda s: s.name)
def test_the_bicycle_off_its_constraints(scheme):
    """The Whipple bicycle: one configuration and five velocity constraints (P
    wide, its least-squares solution the minimum-norm one), speeds that are
    not the coordinates' rates."""
    definition, eom = equations("whipple-bicycle")
    model = definition.numeric(eom, backend="numpy", scheme=scheme)
    check_against_differences(model, definition, off_the_manifold(definition, model,
                                                                  scale=0.05))


def test_the_penalty_at_its_default_factor():
    definition, eom = equations("four-bar")
    model = definition.numeric(eom, backend="numpy", scheme="penalty")
    check_against_differences(model, definition, off_the_manifold(definition, model),
                              tol=1e-6, step=1e-2)


def driven_four_bar():
    """The four-bar with a torque T(t) on the crank and the distance of its
    ground pivots an input d(t) of the configuration constraints."""
    definition = kd.models.build("four-bar")
    args = dict(definition.kane_args)
    T, d = me.dynamicsymbols("T d")
    l_d = next(s for s in definition.constants if str(s) == "l_d")
    args["loads"] = list(args["loads"]) + [(args["bodies"][0].frame, T * args["frame"].z)]
    args["configuration_constraints"] = [c.subs(l_d, d)
                                         for c in args["configuration_constraints"]]
    constants = {k: v for k, v in definition.constants.items() if k != l_d}
    return kd.kane(**args), constants, {T: lambda t: 0.5, d: lambda t: 0.9}


@pytest.mark.parametrize("scheme", STABILIZED, ids=lambda s: s.name)
def test_inputs_in_the_loads_and_in_the_constraints(scheme):
    """With r given, the stabilization is evaluated at r too (not at the
    inputs' providers), so f and its derivatives agree."""
    eom, constants, specified = driven_four_bar()
    model = eom.numeric(constants=constants, specified=specified, backend="numpy",
                        scheme=scheme)
    assert model.input_names == ("T(t)", "d(t)")
    y = np.array([1.2, 0.3, 1.6, 2.0, 0.1, -0.2])
    y = y + 0.1 * np.random.default_rng(4).standard_normal(y.size)
    r0 = np.array([0.7, 0.95])
    J = model.jacobians(0.0, y, r=r0)
    assert relative(J.inputs, differences(lambda r: model.jacobians(0.0, y, r=r).f, r0)) < 1e-8
    at_providers = model.jacobians(0.0, y)  # what rhs uses: r = (0.5, 0.9)
    assert relative(at_providers.state, differences(lambda z: model.rhs(0.0, z), y)) < 1e-8
    assert np.all(J.inputs[model.n_q:, 1] != 0.0)  # d moves the accelerations


@pytest.mark.parametrize("scheme", STABILIZED, ids=lambda s: s.name)
def test_many_states_at_once(scheme):
    definition, eom = equations("four-bar")
    model = definition.numeric(eom, backend="numpy", scheme=scheme)
    Y = np.array([off_the_manifold(definition, model, seed) for seed in range(3)])
    batch = model.jacobians([0.0, 0.1, 0.2], Y, parameters=True)
    assert batch.state.shape == (3, 6, 6) and batch.multipliers_parameters.shape == (3, 2, 8)
    for k in range(3):
        one = model.jacobians(0.1 * k, Y[k], parameters=True)
        for field in ("f", "state", "parameters", "multipliers", "multipliers_parameters"):
            assert relative(getattr(batch, field)[k], getattr(one, field)) < 1e-12, field


# The built-in stabilized schemes are not built on C (the C backend refuses them);
# these run in Python on the C backend's terms, as the index-3 scheme does, so the
# generated C derivatives of the stabilization's parts are those used.
@dataclass(frozen=True)
class BaumgarteOnC(S.Baumgarte):
    c_terms: ClassVar[bool] = True


@dataclass(frozen=True)
class PenaltyOnC(S.Penalty):
    c_terms: ClassVar[bool] = True


@needs_compiler
@pytest.mark.parametrize("scheme", [BaumgarteOnC(), PenaltyOnC(factor=10.0),
                                    S.AugmentedLagrangianIndex3()], ids=lambda s: s.name)
def test_the_c_backend(scheme):
    definition, eom = equations("four-bar")
    fast = definition.numeric(eom, backend="c", scheme=scheme)
    slow = definition.numeric(eom, backend="numpy", scheme=scheme)
    assert fast.backend == "c"
    Y = np.array([off_the_manifold(definition, slow, seed) for seed in range(3)])
    a, b = fast.jacobians(0.0, Y, parameters=True), slow.jacobians(0.0, Y, parameters=True)
    for field in ("f", "state", "parameters", "multipliers", "multipliers_parameters"):
        assert relative(getattr(a, field), getattr(b, field)) < 1e-11, field
    one = fast.jacobians(0.0, Y[1], parameters=True)
    assert relative(one.state, a.state[1]) < 1e-12
    assert relative(one.state, differences(lambda z: fast.rhs(0.0, z), Y[1])) < 1e-8


# ------------------------------------------------------------------ users
def test_radau_gets_the_exact_jacobian(monkeypatch):
    """As for the index-1 schemes: no differences of the right-hand side."""
    definition, eom = equations("four-bar")
    model = definition.numeric(eom, backend="numpy", scheme="baumgarte")
    y0 = definition.initial(model)
    calls = {"rhs": 0}
    rhs = model.rhs

    def counting(t, y):
        calls["rhs"] += 1
        return rhs(t, y)
    monkeypatch.setattr(model, "rhs", counting)
    exact = kd.simulate(model, (0.0, 1.0), y0, method="Radau")
    with_exact, calls["rhs"] = calls["rhs"], 0
    differenced = kd.simulate(model, (0.0, 1.0), y0, method="Radau", jac="differences")
    assert exact.success and differenced.success and exact.njev >= 1
    assert calls["rhs"] - with_exact >= model.n_states * differenced.njev
    np.testing.assert_allclose(exact.y[:, -1], differenced.y[:, -1], atol=1e-6)


@pytest.mark.parametrize("scheme", ["baumgarte", "augmented-lagrangian"])
def test_equilibrium_and_linearization_are_those_of_the_index1_equations(scheme):
    """On the constraints the stabilization vanishes, and so do its variations
    along them: the rest state, eigenvalues and linearization are Kane's."""
    from kanedyn.numerics._linearize import linearize_compiled
    definition, eom = equations("four-bar")
    kane = definition.numeric(eom, backend="numpy")
    model = definition.numeric(eom, backend="numpy", scheme=scheme)
    y0 = definition.initial(model)
    reference, found = kd.equilibrium(kane, y0), kd.equilibrium(model, y0)
    assert found.converged
    assert relative(found.y, reference.y) < 1e-12
    np.testing.assert_allclose(found.eigenvalues, reference.eigenvalues, rtol=1e-10)
    y = model.consistent_state(0.0, np.asarray(y0) + 0.05)
    assert linearize_compiled(model, y) is not None  # through the derivatives
    A, _, _ = model.linearize(y)
    assert relative(A, kane.linearize(y)[0]) < 1e-12


def test_the_penalty_linearization_is_its_own():
    """The penalty's accelerations differ from the index-1 ones by O(1/alpha),
    and so does its linearization (now of its own equations)."""
    definition, eom = equations("four-bar")
    kane = definition.numeric(eom, backend="numpy")
    y = kane.consistent_state(0.0, np.asarray(definition.initial(kane)) + 0.05)
    A = {factor: definition.numeric(eom, backend="numpy",
                                    scheme=S.Penalty(factor=factor)).linearize(y)[0]
         for factor in (1e3, 1e5)}
    reference = kane.linearize(y)[0]
    ratio = relative(A[1e3], reference) / relative(A[1e5], reference)
    assert 80.0 < ratio < 120.0  # 100 times the factor: a hundredth of the difference


# --------------------------------------------------------------- refused
def test_a_penalty_on_acceleration_constraints_of_ones_own_is_refused():
    """K given apart from B: the penalty's multipliers are not those of B."""
    definition = kd.models.build("four-bar")
    args = dict(definition.kane_args)
    t = me.dynamicsymbols._t
    rates = {q.diff(t): u for q, u in zip(definition.symbols["q"], definition.symbols["u"])}
    args["acceleration_constraints"] = [sm.sympify(c).diff(t).xreplace(rates)
                                        for c in args["velocity_constraints"]]
    eom = kd.kane(**args)
    model = definition.numeric(eom, backend="numpy", scheme="penalty")
    y = off_the_manifold(definition, model)
    with pytest.raises(kd.ModelError, match="'penalty' penalizes the acceleration "
                                            "constraints, which were given apart"):
        model.jacobians(0.0, y)
    baumgarte = definition.numeric(eom, backend="numpy", scheme="baumgarte")
    J = baumgarte.jacobians(0.0, y)
    assert relative(J.state, differences(lambda z: baumgarte.rhs(0.0, z), y)) < 1e-8
