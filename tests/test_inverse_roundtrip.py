"""Both directions agree: the forward equations driven by the inverse-dynamics forces
follow the prescribed platform motion (issue 15, item 6)."""

import numpy as np
import pytest

import kanedyn as kd


@pytest.mark.parametrize("gravity", [False, True])
def test_3rrr_round_trip(gravity):
    study = kd.inverse_study(kd.models.build("3rrr", gravity=gravity), t_end=1.0, points=21)
    check = study.forward_check(method="DOP853", rtol=1e-11, atol=1e-11)
    assert check.success
    assert np.max(np.abs(study.forces)) > 0.01  # a real load, not a trivial motion
    # the platform moved 5 cm / 10 degrees; the forward model follows to 1e-7
    assert np.ptp(check.prescribed, axis=1).min() > 0.04
    assert check.max_error < 1e-7, check.max_error


def test_force_function_matches_study():
    """The exact-time force callable gives the study's forces at its points."""
    study = kd.inverse_study(kd.models.build("3rrr", gravity=True), t_end=1.0, points=11)
    f = study.force_function()
    got = np.column_stack([f(t) for t in study.t])
    np.testing.assert_allclose(got, study.forces, rtol=1e-10, atol=1e-12)


@pytest.mark.slow
def test_stewart_round_trip():
    """Stewart platform under gravity, quintic manoeuvre of 1 s.

    The leg-force-driven platform is open-loop unstable (a pose error roughly
    doubles every 0.1 s), so the manoeuvre is kept at 1 s: over 2 s the
    integration error at rtol = 1e-11 grows to about 1.5e-7.
    """
    study = kd.inverse_study(kd.models.build("stewart-platform"), t_end=1.0, points=11)
    check = study.forward_check(method="DOP853", rtol=1e-11, atol=1e-11)
    assert check.success
    assert np.max(np.abs(study.forces)) > 10.0
    assert check.max_error < 1e-7, check.max_error
