"""The direct impact solvers and the compiled contact path against the general ones.

* simultaneous impacts: the state enumeration satisfies the complementarity
  conditions (Newton restitution, Coulomb's law on the slip after the
  impact) checked here one by one; without friction it gives the unique
  solution projected Gauss-Seidel converges to;
* a spinning ball hitting a rough floor while sliding throughout: the
  closed-form sliding phase against the impulses written out by hand;
* falling-rod, slug-ellipsoid and a 3D ball with friction: a ``backend="c"``
  model run with ``simulate(backend="c")`` and a numpy model give the same
  mode histories and impacts (event times to the integration tolerance).
"""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.simulation import _impact

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from _contact_cases import CASES, build  # noqa: E402


def _random_impact(rng, k=2, o=8):
    """Contact-space inverse inertia of a random system, normals, approach."""
    J = rng.normal(size=(3 * k, o))
    A = rng.normal(size=(o, o))
    W = J @ np.linalg.solve(A @ A.T + o * np.eye(o), J.T)
    normals = [v / np.linalg.norm(v) for v in rng.normal(size=(k, 3))]
    v0 = rng.normal(size=3 * k)
    for c, n in enumerate(normals):  # every contact approaches at 0.5 m/s or more
        vn = n @ v0[3 * c:3 * c + 3]
        v0[3 * c:3 * c + 3] -= (max(vn, 0.0) + 0.5) * n
    return W, v0, normals, rng.uniform(0, 1, k), rng.uniform(0, 1, k)


def test_enumerated_simultaneous_impacts_satisfy_complementarity_and_match_pgs():
    rng = np.random.default_rng(11)
    solved = 0
    for _ in range(40):
        W, v0, normals, mu, e = _random_impact(rng)
        k = len(normals)
        F = _impact._local_frames(normals)
        L, w0 = F.T @ W @ F, F.T @ v0
        targets = np.where(w0[0::3] < 0, -e * w0[0::3], 0.0)
        x = _impact._enumerated(L, w0, targets, mu)
        if x is None:  # no start found the root: projected Gauss-Seidel resolves it
            continue
        solved += 1
        w = w0 + L @ x
        scale = np.max(np.abs(w0))
        for c in range(k):
            pn, pt, vn, vt = x[3 * c], x[3 * c + 1:3 * c + 3], w[3 * c], w[3 * c + 1:3 * c + 3]
            assert pn >= -1e-12 and vn >= targets[c] - 1e-9 * scale
            assert abs(pn * (vn - targets[c])) <= 1e-9 * scale * max(1.0, pn)
            assert np.linalg.norm(pt) <= mu[c] * pn * (1 + 1e-9) + 1e-12
            if np.linalg.norm(vt) > 1e-9 * scale:  # sliding: on the cone, against the slip
                assert np.linalg.norm(pt) == pytest.approx(mu[c] * pn, rel=1e-9, abs=1e-12)
                assert pt @ vt == pytest.approx(-np.linalg.norm(pt) * np.linalg.norm(vt),
                                                rel=1e-7, abs=1e-12)
    assert solved >= 36


def test_enumerated_frictionless_impacts_match_projected_gauss_seidel():
    """Without friction the impact is a linear complementarity problem with a
    unique solution, which projected Gauss-Seidel converges to."""
    rng = np.random.default_rng(5)
    for k in (2, 3):
        for _ in range(15):
            W, v0, normals, _, e = _random_impact(rng, k=k, o=3 * k + 2)
            mu = np.zeros(k)
            F = _impact._local_frames(normals)
            L, w0 = F.T @ W @ F, F.T @ v0
            targets = np.where(w0[0::3] < 0, -e[:k] * w0[0::3], 0.0)
            x = _impact._enumerated(L, w0, targets, mu)
            X = F.T @ _impact._gauss_seidel(L, w0, targets, mu, F, 50000, 1e-15).ravel()
            assert np.allclose(x, X, rtol=1e-8, atol=1e-10 * np.max(np.abs(X)))


def test_ball_sliding_through_its_impact_gets_the_closed_form_impulse():
    """Sphere (m, r, I = 2 m r^2 / 5), fast slip: P_n = (1 + e) m |v_n| (Poisson),
    P_t = -mu P_n along the slip; the slip slows by mu P_n (1/m + r^2 / I)."""
    m, r, mu, e = 0.5, 0.1, 0.3, 0.6
    inertia = 0.4 * m * r * r
    n = np.array([0.0, 0.0, 1.0])
    W = np.eye(3) / m + r * r / inertia * (np.eye(3) - np.outer(n, n))
    v0 = np.array([3.0, -4.0, -2.0])  # slip speed 5 m/s
    P = _impact._single(W, v0, n, mu, mu, e, "poisson")
    pn = (1 + e) * m * 2.0
    slip = v0[:2] / 5.0
    assert P[2] == pytest.approx(pn, rel=1e-12)
    assert np.allclose(P[:2], -mu * pn * slip, rtol=1e-12)
    v1 = v0 + W @ P
    assert np.allclose(v1[:2], v0[:2] - mu * pn * (1 / m + r * r / inertia) * slip,
                       rtol=1e-12)


def _signature(res):
    return ([(c.contact, c.old, c.new, c.reason) for c in res.mode_history],
            [i.contacts for i in res.impacts])


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None,
                    reason="no C compiler")
@pytest.mark.parametrize("name", CASES)
def test_compiled_and_python_contact_paths_give_the_same_modes_and_impacts(name):
    model, y0, t_end = build(name, "numpy")
    model_c, y0_c, _ = build(name, "c")
    if getattr(model_c, "_c", None) is None:
        pytest.skip("the C backend is not available")
    res = kd.simulate(model, (0, t_end), y0)
    res_c = kd.simulate(model_c, (0, t_end), y0_c, backend="c")
    assert res.success and res_c.success
    assert _signature(res) == _signature(res_c)
    assert len(res.impacts) > 5
    for a, b in zip(res.mode_history, res_c.mode_history):
        assert abs(a.t - b.t) <= 1e-8 * max(1.0, abs(a.t))
    for a, b in zip(res.impacts, res_c.impacts):
        assert abs(a.t - b.t) <= 1e-8 * max(1.0, abs(a.t))
        assert np.allclose(a.impulses, b.impulses, rtol=1e-5, atol=1e-7)
    assert np.allclose(res.y[:, -1], res_c.y[:, -1], rtol=1e-6, atol=1e-6)
    assert not math.isnan(res_c.y[0, -1])


def test_backend_c_for_contacts_needs_a_compiled_model():
    model, y0, _ = build("falling-rod", "numpy")
    with pytest.raises(kd.OptionError if hasattr(kd, "OptionError") else Exception,
                       match="backend='c'"):
        kd.simulate(model, (0, 0.1), y0, backend="c")


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None,
                    reason="no C compiler")
@pytest.mark.parametrize("name", CASES)
def test_compiled_contact_segments_match_the_python_segments(name, monkeypatch):
    """The same ``backend="c"`` model: its segments in the compiled contact
    loop (``contact_segment``) against ``solve_ivp`` on ``solve_modes``
    (``backend="scipy"``): same mode histories and impacts, event times to
    the integration tolerance; most segments run compiled."""
    from kanedyn.simulation import _hybrid
    model, y0, t_end = build(name, "c")
    if getattr(getattr(model, "_module", None), "contact_segment", None) is None:
        pytest.skip("the C backend is not available")
    compiled = []
    original = _hybrid._compiled_segment

    def counting(*args):
        out = original(*args)
        compiled.append(out is not None)
        return out
    monkeypatch.setattr(_hybrid, "_compiled_segment", counting)
    res_py = kd.simulate(model, (0, t_end), y0, backend="scipy")
    assert not compiled  # the reference path never calls the compiled loop
    res_c = kd.simulate(model, (0, t_end), y0, backend="c")
    assert res_py.success and res_c.success
    assert sum(compiled) >= 0.8 * len(compiled) and sum(compiled) > 5
    assert _signature(res_py) == _signature(res_c)
    for a, b in zip(res_py.mode_history, res_c.mode_history):
        assert abs(a.t - b.t) <= 1e-8 * max(1.0, abs(a.t))
    for a, b in zip(res_py.impacts, res_c.impacts):
        assert abs(a.t - b.t) <= 1e-8 * max(1.0, abs(a.t))
        assert np.allclose(a.impulses, b.impulses, rtol=1e-6, atol=1e-8)
    assert np.allclose(res_py.y[:, -1], res_c.y[:, -1], rtol=1e-6, atol=1e-6)
    assert np.allclose(res_py.dissipated_work[-1], res_c.dissipated_work[-1], rtol=1e-6,
                       atol=1e-8)
    assert np.allclose(res_py.contact_work[-1], res_c.contact_work[-1], rtol=1e-6, atol=1e-8)
