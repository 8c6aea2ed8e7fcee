"""``kd.kane(..., kd_inputs=[...])``: first-order states driven by specified inputs.

A block of mass m on a line, pushed by a force ``a`` that integrates the input
``c(t) = 1`` (``a' = c``): ``a = t``, ``x = t^3 / (6 m)`` in closed form.
"""

from __future__ import annotations

import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd


def block(kd_inputs):
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    x, a = me.dynamicsymbols("x a")
    v, c = me.dynamicsymbols("v c")
    m = sm.Symbol("m")
    P = O.locatenew("P", x * N.x)
    P.set_vel(N, v * N.x)
    args = dict(frame=N, q_ind=[x, a], u_ind=[v], kd_eqs=[x.diff() - v, a.diff() - c],
                bodies=[me.Particle("block", P, m)], loads=[(P, a * N.x)])
    if kd_inputs is not None:
        args["kd_inputs"] = kd_inputs(c, v)
    return args, m, c


def test_a_state_driven_by_an_input_follows_its_closed_form():
    args, m, c = block(lambda c, v: [c])
    model = kd.kane(**args).numeric(constants={m: 2.0}, specified={c: 1.0})
    res = kd.simulate(model, (0, 1.5), [0.0, 0.0, 0.0], rtol=1e-11, atol=1e-13)
    assert res.success, res.message
    assert res["a"][-1] == pytest.approx(1.5, rel=1e-10)
    assert res["x"][-1] == pytest.approx(1.5 ** 3 / 12, rel=1e-8)


def test_an_undeclared_symbol_is_still_refused_as_a_forgotten_speed():
    args = block(None)[0]
    with pytest.raises(kd.ModelError, match=r"kinematic differential equation 1 .* contains "
                                             r"c, .* add the missing speed"):
        kd.kane(**args)


def test_kd_inputs_must_not_name_a_speed():
    args = block(lambda c, v: [c, v])[0]
    with pytest.raises(kd.ModelError, match=r"kd_inputs holds v, a generalized coordinate "
                                             "or speed"):
        kd.kane(**args)
