"""Multiphase optimal control (``kd.MultiphaseProblem``, ``kd.Linkage``),
checked against what shares none of its code:

- the single-phase problem split at an interior time: the same discrete
  problem, so the same optimum (every method);
- a cart that releases a payload part way (its mass halves at the
  junction), the phases different models: least effort against its closed
  form (a weighted least-squares problem solved by hand), written once with
  the same states on both sides and once with other names joined by
  linkage equations; least time against its closed form (bang-bang, the
  release where the cart has travelled half way);
- the NLP's Jacobian and gradient against central differences (free
  durations, start times that are variables, time-dependent models and
  objectives, linkage equations in the junction time); the exact Hessian of
  its Lagrangian against central differences of that gradient, and its
  solve against the limited-memory one.

IPOPT through cyipopt is needed; without it every test here is skipped.
"""

import re

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from test_optimal_control import check_against_differences, hessian_and_differences

import kanedyn as kd

pytest.importorskip("cyipopt", reason="optimal control needs cyipopt (pip install "
                    "'kanedyn[optimal]', part of the test extra)")

TIGHT = {"tol": 1e-12, "max_iter": 500}
t = me.dynamicsymbols._t


def _cart(masses, names=("x", "v"), time_force=False):
    """A cart on a line pushed by F(t), carrying particles of ``masses`` (kg)
    at the same point (a payload is one more particle); with ``time_force``
    also pushed by sin(3 t)."""
    x, v = me.dynamicsymbols(" ".join(names))
    F = me.dynamicsymbols("F")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    points = []
    for k, _ in enumerate(masses):
        P = O.locatenew(f"P{k}", x * N.x)
        P.set_vel(N, v * N.x)
        points.append(P)
    symbols = sm.symbols(f"m0:{len(masses)}")
    push = F + (sm.sin(3 * t) if time_force else 0)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
                  bodies=[me.Particle(f"body{k}", P, m) for k, (P, m)
                          in enumerate(zip(points, symbols))],
                  loads=[(points[0], push * N.x)])
    model = eom.numeric(constants=dict(zip(symbols, masses)), specified={F: 0.0})
    return model, (x, v, F)


def _least_effort(pieces):
    r"""Least :math:`\int_0^1 F^2 dt` moving a cart from rest at 0 to rest
    at 1 when its mass is :math:`M_p` on each piece ``(a, b, M_p)``.  With
    the acceleration :math:`a = F/M`: minimize :math:`\int M^2 a^2` subject
    to :math:`\int a = 0`, :math:`\int (1 - t) a = 1`; stationarity gives
    :math:`a = (\mu_1 + \mu_2 s)/(2M^2)`, :math:`s = 1 - t`, and the
    objective is :math:`\mu_2/2`.  Returns (objective, x(t), F(t))."""
    def moment(k):
        return sum(((1 - a) ** (k + 1) - (1 - b) ** (k + 1)) / (k + 1) / (2 * M ** 2)
                   for a, b, M in pieces)
    mu = np.linalg.solve([[moment(0), moment(1)], [moment(1), moment(2)]], [0.0, 1.0])

    def mass(time):
        return next(M for a, b, M in pieces if a <= time <= b)

    def position(time):
        # x(t) = int_0^t (t - s) a(s) ds, piece by piece in closed form
        total = 0.0
        for a, b, M in pieces:
            hi = min(b, time)
            if hi <= a:
                continue

            def primitive(s):  # of (time - s)(mu1 + mu2 (1 - s)), in s
                c0, c1 = mu[0] + mu[1], -mu[1]
                return (time * c0 * s + (time * c1 - c0) * s ** 2 / 2 - c1 * s ** 3 / 3)
            total += (primitive(hi) - primitive(a)) / (2 * M ** 2)
        return total

    def force(time, side=0):
        M = mass(time) if side == 0 else side
        return (mu[0] + mu[1] * (1 - time)) / (2 * M)
    return mu[1] / 2, position, force


# ------------------------------------------------------------- split problems
@pytest.mark.parametrize("method, degree, continuous", [
    ("trapezoid", None, "xvF"), ("hermite-simpson", None, "xvF"), ("lgr", 3, "xv"),
    ("backward-euler", None, "xv")])
def test_split_in_two_is_the_single_phase_problem(method, degree, continuous):
    """The least-effort move of a 1 kg cart over 1 s, split at t = 0.5 into
    two phases of 11 nodes: the same discrete problem as one phase of 21
    nodes (the trapezoid's and Hermite-Simpson's input at the junction made
    continuous, which they share between intervals; LGR's and backward
    Euler's input at an interval's start is not collocated), so the same
    optimum and nodes."""
    model, (x, v, F) = _cart([1.0])
    options = dict(method=method, degree=degree, lagrange=F ** 2)
    single = kd.OptimalControlProblem(model, nodes=21, duration=1.0, initial={x: 0, v: 0},
                                      final={x: 1, v: 0}, **options)
    whole = single.solve(single.guess_line(inputs={F: 0.0}), options=TIGHT)
    first = kd.OptimalControlProblem(model, nodes=11, duration=0.5, initial={x: 0, v: 0},
                                     **options)
    second = kd.OptimalControlProblem(model, nodes=11, duration=0.5, final={x: 1, v: 0},
                                      start_time=0.5, **options)
    names = {"x": x, "v": v, "F": F}
    problem = kd.MultiphaseProblem(
        [first, second], linkages=kd.Linkage(continuous=[names[c] for c in continuous]))
    guess = [first.guess_line(end={x: 0.5, v: 1.0}, inputs={F: 0.0}),
             second.guess_line(start={x: 0.5, v: 1.0}, inputs={F: 0.0})]
    split = problem.solve(guess, options=TIGHT)
    assert whole.success and split.success, (whole.message, split.message)
    assert abs(split.objective - whole.objective) < 1e-9 * whole.objective
    joined = np.concatenate([split.phases[0].y[:, :-1], split.phases[1].y], axis=1)
    assert np.max(np.abs(joined - whole.y)) < 1e-8
    assert split.junction_times == (0.5,) and split.t.size == 22
    if continuous == "xvF" and method == "trapezoid":  # the input free to jump: less effort
        free = kd.MultiphaseProblem([first, second]).solve(guess, options=TIGHT)
        assert free.success and free.objective < whole.objective - 1e-4


# ------------------------------------------------------- the payload released
@pytest.mark.parametrize("method, degree", [("hermite-simpson", None), ("lgr", 3)])
@pytest.mark.parametrize("renamed", [False, True])
def test_payload_released_least_effort_closed_form(method, degree, renamed):
    """A 1 kg cart carries a 1 kg payload until t = 0.4 s and moves on alone,
    from rest at 0 to rest at 1 m in 1 s, with the least integral of F^2:
    the closed form (objective, position, the force doubling at the release)
    is piecewise cubic in the position, which both methods represent
    exactly.  The phases are two models (two particles, then one); the
    second names its states y, w in the renamed case, joined by linkage
    equations instead of continuity."""
    release = 0.4
    loaded, (x, v, F) = _cart([1.0, 1.0])
    names = ("y", "w") if renamed else ("x", "v")
    alone, (x2, v2, F2) = _cart([1.0], names)
    first = kd.OptimalControlProblem(loaded, nodes=5, duration=release, lagrange=F ** 2,
                                     initial={x: 0, v: 0}, method=method, degree=degree)
    second = kd.OptimalControlProblem(alone, nodes=7, duration=1 - release,
                                      lagrange=F2 ** 2, final={x2: 1, v2: 0}, method=method,
                                      degree=degree)
    L = kd.Linkage
    linkage = (L(continuous=[], equations=[x2.subs(t, L.after) - x.subs(t, L.before),
                                           v2.subs(t, L.after) - v.subs(t, L.before)])
               if renamed else None)
    problem = kd.MultiphaseProblem([first, second], linkages=linkage)
    mid = {x2: 0.3, v2: 1.0}
    result = problem.solve([first.guess_line(end={x: 0.3, v: 1.0}, inputs={F: 0.0}),
                            second.guess_line(start=mid, inputs={F2: 0.0})], options=TIGHT)
    assert result.success, result.message
    objective, position, force = _least_effort([(0.0, release, 2.0), (release, 1.0, 1.0)])
    assert abs(result.objective - objective) < 1e-9 * objective
    for phase in result.phases:
        state = phase.state_names[0]
        assert np.max(np.abs(phase[state] - [position(s) for s in phase.t])) < 1e-10
    before, after = result.phases[0]["F"][-1], result.phases[1]["F"][0]
    assert before == pytest.approx(force(release, 2.0), rel=1e-7)
    if method == "hermite-simpson":  # LGR's first input is extrapolated, also exact here
        assert after == pytest.approx(force(release, 1.0), rel=1e-7)
    assert after == pytest.approx(2 * before, rel=1e-7)


def test_payload_released_minimum_time_closed_form():
    """|F| <= 1 N; the 2 kg cart with its payload, from rest at 0, releases
    it on reaching 0.5 m and stops at 1 m alone (1 kg): the least total time
    is sqrt(2) (full push, loaded) + 2 sqrt(3/4) - sqrt(1/2) (push and brake
    alone) = 2.4391576 s.  Both durations are free, so the second phase's
    start is a variable; each phase's Mayer term is its duration.
    Hermite-Simpson with 21 and 41 nodes a phase: 3.1e-5 and 4.2e-6 below it
    (the switch from push to brake falls between nodes); the loaded phase,
    at its bound throughout, exact."""
    loaded, (x, v, F) = _cart([1.0, 1.0])
    alone, _ = _cart([1.0])
    T1, T2 = sm.symbols("T1 T2")
    exact = np.sqrt(2) + 2 * np.sqrt(0.75) - np.sqrt(0.5)
    found = []
    for nodes in (21, 41):
        first = kd.OptimalControlProblem(
            loaded, nodes=nodes, duration=T1, mayer=T1, bounds={F: (-1, 1), T1: (0.5, 3)},
            initial={x: 0, v: 0}, final={x: 0.5}, method="hermite-simpson")
        second = kd.OptimalControlProblem(
            alone, nodes=nodes, duration=T2, mayer=T2, bounds={F: (-1, 1), T2: (0.5, 3)},
            final={x: 1, v: 0}, method="hermite-simpson")
        problem = kd.MultiphaseProblem([first, second])
        assert problem.n_variables == first.n_variables + second.n_variables + 1
        result = problem.solve(
            [first.guess_line(end={v: 0.7}, inputs={F: 1.0}, duration=1.5),
             second.guess_line(start={x: 0.5, v: 0.7}, inputs={F: 0.0}, duration=1.0)],
            options={"tol": 1e-10, "max_iter": 1000})
        assert result.success, result.message
        one, two = result.phases
        assert abs(one.duration - np.sqrt(2)) < 1e-6
        assert two.t[0] == pytest.approx(one.t[-1], abs=1e-12)
        assert abs(one["v"][-1] - np.sqrt(0.5)) < 1e-6
        found.append(result.objective)
    assert abs(found[-1] - exact) < 2e-5, found
    assert abs(found[-1] - exact) <= abs(found[0] - exact)


# ---------------------------------------------------------------- derivatives
@pytest.mark.parametrize("method, degree", [("lgr", 2), ("hermite-simpson", None),
                                            ("midpoint", None), ("trapezoid", None)])
def test_multiphase_derivatives_against_differences(method, degree):
    """Three phases: a free duration (trapezoid), then a time-dependent model
    on a start that is a variable (``method``; its objective, Mayer term and
    path constraint in t), then a free duration on a variable start
    (Hermite-Simpson); linkages by continuity and by equations in both
    sides and the junction time.  The Jacobian and gradient against central
    differences."""
    from kanedyn.optimization._multiphase import MultiphaseNLP
    nlp = MultiphaseNLP(_three_phases(method, degree, time_force=True))
    assert [sub.layout.free_start_time for sub in nlp.phase_nlps] == [False, True, True]
    z = _random_point(nlp)
    check_against_differences(nlp, z, 1e-6)


def _three_phases(method, degree, time_force=False):
    """The three phases of the derivatives' check (see below)."""
    cart, (x, v, F) = _cart([1.5])
    forced, (x2, v2, F2) = _cart([0.7], time_force=time_force)
    T1, T3 = sm.symbols("T1 T3")
    L = kd.Linkage
    first = kd.OptimalControlProblem(
        cart, nodes=4, duration=T1, lagrange=F ** 2 + x * v, mayer=x ** 2,
        bounds={T1: (0.1, 3)}, initial={x: 0}, method="trapezoid",
        path_constraints=[(v ** 2 + F, -4, 4)])
    second = kd.OptimalControlProblem(
        forced, nodes=3, duration=0.7, lagrange=F2 ** 2 + sm.sin(t) * x2 + t * v2 ** 2,
        mayer=t * x2, method=method, degree=degree, path_constraints=[(x2 * t + F2, -9, 9)])
    third = kd.OptimalControlProblem(
        cart, nodes=4, duration=T3, lagrange=F ** 2, mayer=T3 + v ** 2,
        bounds={T3: (0.1, 3)}, method="hermite-simpson")
    return kd.MultiphaseProblem([first, second, third], linkages=[
        L(continuous=[], equations=[
            x2.subs(t, L.after) - x.subs(t, L.before) ** 2 - L.before * 0.1,
            v2.subs(t, L.after) * F.subs(t, L.before) - sm.cos(L.after)]),
        L(continuous=[x], equations=[v.subs(t, L.after) - 2 * v2.subs(t, L.before)])])


def _random_point(nlp, seed=1):
    z = np.random.default_rng(seed).normal(size=nlp.n)
    for sub, offset in zip(nlp.phase_nlps, nlp.offsets):
        L_ = sub.layout
        if L_.free_duration:
            z[offset + L_.duration_index] = 0.8
        if L_.free_start_time:
            z[offset + L_.start_index] = 1.3
    return z


@pytest.mark.parametrize("method, degree", [("lgr", 2), ("hermite-simpson", None),
                                            ("midpoint", None), ("trapezoid", None)])
def test_multiphase_exact_hessian_against_differences(method, degree):
    """The three phases below (the second's model autonomous here, its
    objective and path constraint in t; start times that are variables;
    linkage equations in both sides and the junction time) with the exact
    Hessian: within 1e-7 of its largest entry of the central differences of
    the exact gradient of the Lagrangian, at a random point with random
    multipliers."""
    from kanedyn.optimization._multiphase import MultiphaseNLP
    nlp = MultiphaseNLP(_three_phases(method, degree), hessian="exact")
    z = _random_point(nlp)
    rng = np.random.default_rng(2)
    multipliers, sigma = rng.normal(size=nlp.m), 0.7
    H, H_fd = hessian_and_differences(nlp, z, multipliers, sigma)
    assert np.max(np.abs(H)) > 1.0
    assert np.max(np.abs(H - H_fd)) < 1e-7 * np.max(np.abs(H))


def test_multiphase_exact_hessian_reaches_the_limited_memory_optimum():
    """The payload released part way in least time (both durations free,
    the second start a variable), Hermite-Simpson, 21 nodes a phase: the
    exact Hessian's optimum is the limited-memory solve's, in no more
    iterations."""
    loaded, (x, v, F) = _cart([1.0, 1.0])
    alone, _ = _cart([1.0])
    T1, T2 = sm.symbols("T1 T2")
    first = kd.OptimalControlProblem(
        loaded, nodes=21, duration=T1, mayer=T1 + 1e-2 * v ** 2, lagrange=1e-2 * F ** 2,
        bounds={F: (-1, 1), T1: (0.5, 3)}, initial={x: 0, v: 0}, final={x: 0.5},
        method="hermite-simpson")
    second = kd.OptimalControlProblem(
        alone, nodes=21, duration=T2, mayer=T2, lagrange=1e-2 * F ** 2,
        bounds={F: (-1, 1), T2: (0.5, 3)}, final={x: 1, v: 0}, method="hermite-simpson")
    problem = kd.MultiphaseProblem([first, second])
    guess = [first.guess_line(end={v: 0.7}, inputs={F: 1.0}, duration=1.5),
             second.guess_line(start={x: 0.5, v: 0.7}, inputs={F: 0.0}, duration=1.0)]
    approximate = problem.solve(guess, options=TIGHT)
    exact = problem.solve(guess, options=TIGHT, hessian="exact")
    assert approximate.success and exact.success, (approximate.message, exact.message)
    assert abs(exact.objective - approximate.objective) < 1e-8 * abs(approximate.objective)
    assert exact.iterations <= approximate.iterations


# ----------------------------------------------------------------- the result
def test_result_joined_table_plot_guesses_and_warm_start(tmp_path):
    """The joined views (times with the junction twice, a state of one
    phase only as nan in the other, the table and its CSV, the plot), the
    phases' re-simulations, a warm start from the result, and a phase's
    result seeding a single-phase problem."""
    model, (x, v, F) = _cart([1.0])
    other, (y, w, _) = _cart([1.0], ("y", "w"))
    first = kd.OptimalControlProblem(model, nodes=6, duration=0.5, lagrange=F ** 2,
                                     initial={x: 0, v: 0}, method="lgr", degree=2)
    second = kd.OptimalControlProblem(model, nodes=6, duration=0.5, lagrange=F ** 2,
                                      final={x: 1, v: 0}, method="hermite-simpson")
    problem = kd.MultiphaseProblem([first, second])
    guess = [first.guess_line(end={x: 0.5, v: 1}, inputs={F: 0.0}),
             second.guess_line(start={x: 0.5, v: 1}, inputs={F: 0.0})]
    result = problem.solve(guess, options=TIGHT)
    assert isinstance(result, kd.MultiphaseResult) and result.success, result.message
    assert result.t.size == 12 and result.t[5] == result.t[6] == 0.5
    np.testing.assert_array_equal(result["x"][:6], result.phases[0]["x"])
    assert result.objective == pytest.approx(sum(p.objective for p in result.phases))
    columns, rows = result.table()
    assert columns == ("t", "phase", "point", "x", "v", "F")
    assert len(rows) == 6 + 5 + 6 + 5  # nodes, LGR's interior points, nodes, midpoints
    assert {row[1] for row in rows} == {1, 2}
    written = result.to_csv(tmp_path / "phases.csv")
    assert written.read_text().splitlines()[0] == "t,phase,point,x,v,F"
    result.plot(path=tmp_path / "phases.png")
    assert (tmp_path / "phases.png").stat().st_size > 0
    checks = result.resimulate()
    assert len(checks) == 2 and all(c.max_defect < 1e-6 for c in checks)
    again = problem.solve(result, warm_start=True, options=TIGHT)
    assert again.success and again.iterations <= result.iterations
    alone = kd.OptimalControlProblem(model, nodes=11, duration=0.5, lagrange=F ** 2,
                                     initial={x: 0, v: 0}, final={x: 0.5})
    assert alone.solve(result.phases[0], options=TIGHT).success
    with pytest.raises(kd.ModelError, match="warm start"):
        alone.solve(result.phases[0], warm_start=True)
    # a state of one phase only
    mixed = kd.MultiphaseProblem([first, kd.OptimalControlProblem(
        other, nodes=4, duration=0.5, lagrange=F ** 2, final={y: 1, w: 0})], linkages=[
        kd.Linkage(equations=[y.subs(t, kd.Linkage.after) - x.subs(t, kd.Linkage.before),
                              w.subs(t, kd.Linkage.after) - v.subs(t, kd.Linkage.before)])])
    joined = mixed.solve([guess[0], mixed.phases[1].guess_line(start={y: 0.5, w: 1},
                                                               inputs={F: 0.0})],
                         options=TIGHT)
    assert joined.success, joined.message
    assert np.all(np.isnan(joined["y"][:6])) and not np.any(np.isnan(joined["y"][6:]))
    assert joined.table()[0] == ("t", "phase", "point", "x", "v", "y", "w", "F")
    with pytest.raises(kd.ModelError, match="different states"):
        joined.plot()
    with pytest.raises(KeyError, match="no phase"):
        joined["z"]


def test_unsolved_message_names_the_phase_row_or_the_junction_violated_most():
    """An infeasible multiphase problem's message names what is violated
    most in the problem's terms: a phase's defect with its phase and times
    (|F| <= 0.1 N cannot move 1 kg by 1 m in 1 s: 0.025 m at most), or a
    linkage's equation (x jumps by 5 m at the junction, but x is bounded to
    [0, 1] m on both sides: 4 m at least)."""
    model, (x, v, F) = _cart([1.0])
    L = kd.Linkage

    def phases(**kwargs):
        first = kd.OptimalControlProblem(model, nodes=11, duration=0.5, lagrange=F ** 2,
                                         initial={x: 0, v: 0}, **kwargs)
        second = kd.OptimalControlProblem(model, nodes=11, duration=0.5, lagrange=F ** 2,
                                          final={x: 1, v: 0}, **kwargs)
        guess = [first.guess_line(end={x: 0.5, v: 0}, inputs={F: 0.0}),
                 second.guess_line(start={x: 0.5, v: 0}, inputs={F: 0.0})]
        return first, second, guess

    first, second, guess = phases(bounds={F: (-0.1, 0.1)})
    weak = kd.MultiphaseProblem([first, second]).solve(guess, solver="interior-point")
    assert weak.status == 2 and not weak.success
    assert re.search(r"largest constraint violation [0-9.e+-]+, of phase [12]: the dynamics "
                     r"of [xv] between nodes \d+ and \d+ \(t = [0-9.]+ to [0-9.]+ s\)$",
                     weak.message), weak.message
    first, second, guess = phases(bounds={x: (0, 1)})
    jump = kd.MultiphaseProblem([first, second], linkages=[L(
        continuous=[v], equations=[x.subs(t, L.after) - x.subs(t, L.before) - 5])])
    apart = jump.solve(guess, solver="interior-point")
    assert apart.status == 2 and apart.constraint_violation >= 4.0 - 1e-6
    assert apart.message.endswith(", of linkage 1 (phases 1 and 2), equation 0 "
                                  "(x(t_j^+) - x(t_j^-) - 5)"), apart.message
