"""kanedyn's Kane equations against SymPy's ``KanesMethod``.

What is compared
----------------
For each model the explicit right-hand side of the equations of motion,

.. math::

    \\begin{bmatrix}\\dot q \\\\ \\dot u\\end{bmatrix}
    = M_{full}^{-1} F_{full},

is evaluated at several random states: by kanedyn as ``model.rhs(t, y)``
(its compiled straight-line program, ``M u' = F`` assembled and solved
numerically) and by SymPy as ``solve(km.mass_matrix_full, km.forcing_full)``
of ``sympy.physics.mechanics.KanesMethod`` (or ``System.form_eoms()``).  The
two must agree to 1e-10 relative (``max|a - b| / max|b|``).  The models cover
unconstrained chains (planar and spatial), a specified input, prescribed
motion (a pivot moving as a given function of time), nonholonomic rolling,
a closed holonomic loop, the Whipple bicycle (both kinds of constraints) and
models written with joints in a ``System``.  Auxiliary equations (constraint
forces exposed by auxiliary speeds) are compared with ``km.auxiliary_eqs``.

Why the reference is independent
--------------------------------
kanedyn never calls ``KanesMethod``: it derives the equations with its own
engine (named intermediates, partial velocities computed by itself, the
dependent speeds eliminated numerically).  SymPy derives them by explicit
expansion and symbolic elimination.  Every model is built twice, one fresh
copy per tool, because SymPy caches velocities inside ``Point`` objects and
the two tools must not share them.  The only things shared are the model
description (the builders in ``kanedyn.models``) and the symbols' names.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

T = me.dynamicsymbols._t
RTOL = 1e-10
N_STATES = 4


# ------------------------------------------------------------------ helpers
def relative_error(a, b):
    """``max|a - b| / max(max|b|, 1e-12)``; ``b`` is the reference."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-12))


def sympy_kane(args):
    """SymPy's ``KanesMethod`` for a builder's ``kane_args``, equations formed."""
    km = me.KanesMethod(
        args["frame"], q_ind=args["q_ind"], u_ind=args["u_ind"],
        kd_eqs=args["kd_eqs"], q_dependent=args.get("q_dep", []),
        u_dependent=args.get("u_dep", []),
        configuration_constraints=args.get("configuration_constraints", []),
        velocity_constraints=args.get("velocity_constraints", []),
        u_auxiliary=args.get("u_auxiliary", []))
    km.kanes_equations(args["bodies"], args["loads"])
    return km


def check_same_state(eom, q, u):
    """kanedyn's state is ordered as SymPy's ``km.q``, ``km.u``."""
    assert tuple(eom.q) == tuple(q)
    assert tuple(eom.u) == tuple(u)


def replace_specified(expr, specified):
    """Substitute ``{x(t): g(t)}`` into ``expr``, derivatives of ``x`` included."""
    rules = {}
    for x, g in specified.items():
        rules[x] = g
        for order in (1, 2, 3):
            rules[x.diff(T, order)] = sm.diff(g, T, order)
    # xreplace works top-down, so Derivative(x, t) is replaced before x inside it
    return expr.xreplace(rules)


def sympy_rhs(M_full, F_full, q, u, constants, specified=None):
    """``f(t, y) = solve(M_full, F_full)`` with SymPy's matrices lambdified.

    ``specified`` maps a function of time to a number or an expression in t.
    """
    if specified:
        M_full = replace_specified(M_full, specified)
        F_full = replace_specified(F_full, specified)
    states = list(q) + list(u)
    consts = list(constants)
    leftover = (M_full.free_symbols | F_full.free_symbols) - set(consts) - {T}
    assert not leftover, f"unvalued symbols in SymPy's matrices: {leftover}"
    leftover = (me.find_dynamicsymbols(M_full) | me.find_dynamicsymbols(F_full)) - set(states)
    assert not leftover, f"unvalued functions of time in SymPy's matrices: {leftover}"
    f = sm.lambdify((T, states, consts), [M_full, F_full], cse=True, modules="numpy")
    p = [constants[c] for c in consts]

    def rhs(t, y):
        M, F = f(t, y, p)
        return np.linalg.solve(np.asarray(M, dtype=float),
                               np.asarray(F, dtype=float).ravel())
    return rhs


def numeric(eom, constants, specified=None):
    """``eom.numeric`` with the values of the constants the equations contain.

    (Not ``ModelDefinition.numeric``: kanedyn rejects constants that dropped
    out of the equations, e.g. ``g`` for the one-link chain turning about the
    vertical.)
    """
    values = {s: constants[s] for s in eom.constants}
    return eom.numeric(constants=values, specified=specified or {})


def compare_rhs(model, reference, states, t=0.0):
    """Largest relative error of ``model.rhs`` against ``reference`` over states."""
    worst = 0.0
    for y in states:
        expected = reference(t, y)
        assert np.all(np.isfinite(expected))
        assert np.max(np.abs(expected)) > 1e-3, "degenerate test state"
        worst = max(worst, relative_error(model.rhs(t, y), expected))
    return worst


def random_states(model, rng, n=N_STATES, q_scale=np.pi, u_scale=2.0):
    """Random unconstrained states ``[q, u]``."""
    return [np.concatenate([rng.uniform(-q_scale, q_scale, model.n_q),
                            rng.uniform(-u_scale, u_scale, model.n_u)])
            for _ in range(n)]


def compare_builtin(name, specified=None, states=None, seed=0, **options):
    """Derive a built-in model with both tools and compare ``rhs`` at states."""
    mine, ref = kd.models.build(name, **options), kd.models.build(name, **options)
    eom = kd.kane(**mine.kane_args)
    model = numeric(eom, mine.constants, specified)
    km = sympy_kane(ref.kane_args)
    check_same_state(eom, km.q, km.u)
    reference = sympy_rhs(km.mass_matrix_full, km.forcing_full, km.q, km.u,
                          ref.constants, specified)
    rng = np.random.default_rng(seed)
    states = states(mine, model, rng) if states else random_states(model, rng)
    return compare_rhs(model, reference, states)


# ---------------------------------------------------- unconstrained models
@pytest.mark.parametrize("n", [1, 2, 3])
def test_n_link_pendulum_on_cart(n):
    d = kd.models.build("n-link-pendulum-on-cart", n=n)
    F = d.symbols["F"]
    err = compare_builtin("n-link-pendulum-on-cart", n=n, specified={F: 0.7})
    assert err <= RTOL


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, pytest.param(6, marks=pytest.mark.slow)])
def test_chain3d(n):
    assert compare_builtin("chain3d", n=n) <= RTOL


# ------------------------------------------------------ constrained models
def consistent(model, y):
    """``model.consistent_state`` plus a check that the constraints hold."""
    y = model.consistent_state(0.0, y)
    assert np.max(np.abs(model.constraint_residuals(0.0, y)), initial=0.0) < 1e-9
    return y


def rolling_disk_states(definition, model, rng):
    """Random leans away from lying flat; contact-point rates made consistent."""
    out = []
    for _ in range(N_STATES):
        y = np.zeros(model.n_states)
        y[:5] = rng.uniform(-np.pi, np.pi, 5)
        y[model.index("q4")] = rng.uniform(-0.8, 0.8)
        y[5:8] = rng.uniform(-5.0, 5.0, 3)
        out.append(consistent(model, y))
    return out


def four_bar_states(definition, model, rng):
    """Crank angles where the loop closes near the default assembly."""
    out = []
    for _ in range(N_STATES):
        y = definition.initial(model)  # starting guesses of q2, q3 for Newton
        y[model.index("q1")] = rng.uniform(0.9, 1.5)
        y[model.index("u1")] = rng.uniform(-3.0, 3.0)
        out.append(consistent(model, y))
    return out


def test_rolling_disk():
    assert compare_builtin("rolling-disk", states=rolling_disk_states) <= RTOL


def test_four_bar():
    assert compare_builtin("four-bar", states=four_bar_states) <= RTOL
