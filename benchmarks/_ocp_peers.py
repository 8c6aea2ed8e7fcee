"""Optimal control problems posed twice: with kanedyn and with opty, the same
discrete problem (same collocation, same objective sum, same bounds, same
initial guess), for same-run comparisons (``bench_optimal_control.py``) and
the tests (``tests/test_optimal_control.py``).

opty's equations are written independently of kanedyn: the pendulum's by hand
(as opty's gallery writes it), the cart-pole's by SymPy's ``KanesMethod``.
Decision vectors: kanedyn's are node by node ``[y_0, ..., y_{N-1}, r_0, ...]``,
opty's state by state ``[x_1(t_0..t_{N-1}), x_2(...), ..., r(...)]``;
:func:`to_opty` and :func:`from_opty` convert.
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

#: kanedyn's method names -> opty's
OPTY_METHODS = {"backward-euler": "backward euler", "midpoint": "midpoint"}

#: the same IPOPT options for both (opty sets no Hessian: cyipopt then uses the
#: limited-memory approximation, as kanedyn does)
IPOPT_OPTIONS = {"tol": 1e-10, "max_iter": 3000, "print_level": 0,
                 "hessian_approximation": "limited-memory", "linear_solver": "mumps"}


def to_opty(z, N, ns, nr):
    """kanedyn's decision vector (node by node) -> opty's (state by state)."""
    Y = z[:N * ns].reshape(N, ns)
    R = z[N * ns:N * (ns + nr)].reshape(N, nr)
    return np.concatenate([Y.T.ravel(), R.T.ravel(), z[N * (ns + nr):]])


def from_opty(w, N, ns, nr):
    Y = w[:N * ns].reshape(ns, N)
    R = w[N * ns:N * (ns + nr)].reshape(nr, N)
    return np.concatenate([Y.T.ravel(), R.T.ravel(), w[N * (ns + nr):]])


# ------------------------------------------------------------ pendulum swing-up
#: opty's gallery: swing a pendulum (I = m d^2 = 1, g = 9.81) from hanging to
#: upright in 10 s with |torque| <= 2 N m, minimizing the integral of torque^2
PENDULUM = {"duration": 10.0, "torque": 2.0, "m": 1.0, "l": 1.0, "g": 9.81}


def pendulum_kanedyn(nodes, method="backward-euler", backend="c"):
    """``(problem, model)`` of the swing-up with kanedyn's built-in pendulum."""
    import kanedyn as kd
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend=backend, constants={
        definition.symbols[k]: PENDULUM[k] for k in ("m", "l", "g")})
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    limit = PENDULUM["torque"]
    problem = kd.OptimalControlProblem(
        model, nodes=nodes, duration=PENDULUM["duration"], lagrange=tau ** 2,
        bounds={tau: (-limit, limit)}, initial={q: 0.0, u: 0.0},
        final={q: np.pi, u: 0.0}, method=method)
    return problem, model


def pendulum_opty(nodes, method="backward-euler", backend="cython"):
    """opty's ``Problem`` of the same swing-up (equations written by hand);
    ``backend``: opty's, ``"cython"`` (compiled, as timed) or ``"numpy"``
    (the same expressions evaluated by NumPy, nothing to compile)."""
    from opty import Problem, create_objective_function
    I, m, g, d, t = sm.symbols("I, m, g, d, t")
    theta, omega, T = sm.symbols("theta, omega, T", cls=sm.Function)
    states, inputs = (theta(t), omega(t)), (T(t),)
    eom = sm.Matrix([theta(t).diff() - omega(t),
                     I * omega(t).diff() + m * g * d * sm.sin(theta(t)) - T(t)])
    p = PENDULUM
    duration = p["duration"]
    h = duration / (nodes - 1)
    obj, obj_grad = create_objective_function(
        sm.Integral(T(t) ** 2, t), states, inputs, (), nodes, h, time_symbol=t,
        integration_method=OPTY_METHODS[method])
    problem = Problem(
        obj, obj_grad, eom, states, nodes, h,
        known_parameter_map={I: p["m"] * p["l"] ** 2, m: p["m"], g: p["g"], d: p["l"]},
        instance_constraints=(theta(0.0), theta(duration) - np.pi, omega(0.0),
                              omega(duration)),
        bounds={T(t): (-p["torque"], p["torque"])}, time_symbol=t,
        integration_method=OPTY_METHODS[method], backend=backend)
    return problem


def pendulum_guess(nodes):
    """The initial guess of both: the angle on a line from 0 to pi, the rate
    of that line, a torque of 0.1 sin(2 pi t / 10)."""
    t = np.linspace(0.0, PENDULUM["duration"], nodes)
    theta = np.pi * t / PENDULUM["duration"]
    omega = np.full(nodes, np.pi / PENDULUM["duration"])
    torque = 0.1 * np.sin(2 * np.pi * t / PENDULUM["duration"])
    return np.concatenate([np.stack([theta, omega], axis=1).ravel(), torque])


#: the node count of the swing-up whose optimum seeds the memory scan's guesses
GALLERY_NODES = 501


def pendulum_gallery_optimum():
    """kanedyn's optimum of the swing-up at :data:`GALLERY_NODES` nodes (IPOPT
    from a random guess, seed 0): the decision vector."""
    problem, _ = pendulum_kanedyn(GALLERY_NODES)
    return problem.solve(np.random.default_rng(0).normal(size=3 * GALLERY_NODES),
                         options=IPOPT_OPTIONS).x


def pendulum_interpolated(coarse, nodes):
    """The guess at ``nodes`` nodes interpolated from ``coarse``, a decision
    vector at :data:`GALLERY_NODES` nodes (angle, rate, torque linearly in
    time)."""
    s_old, s_new = np.linspace(0, 1, GALLERY_NODES), np.linspace(0, 1, nodes)
    Y = coarse[:2 * GALLERY_NODES].reshape(GALLERY_NODES, 2)
    return np.concatenate([
        np.stack([np.interp(s_new, s_old, Y[:, j]) for j in range(2)], axis=1).ravel(),
        np.interp(s_new, s_old, coarse[2 * GALLERY_NODES:3 * GALLERY_NODES])])


# ------------------------------------------------------------ cart-pole swing-up
#: kanedyn's n-link-pendulum-on-cart with n = 1 (cart 2 kg, bob 0.5 kg on 0.6 m):
#: from hanging at rest to upright at rest with the cart back at 0 in 3 s,
#: |F| <= 20 N, |cart| <= 1.5 m, minimizing the integral of F^2
CART_POLE = {"duration": 3.0, "force": 20.0, "track": 1.5,
             "m_c": 2.0, "m": 0.5, "l": 0.6, "g": 9.81}


def cart_pole_kanedyn(nodes, method="backward-euler", backend="c"):
    import kanedyn as kd
    definition = kd.models.build("n-link-pendulum-on-cart", n=1)
    s = definition.symbols
    model = definition.numeric(backend=backend, constants={
        s[k]: CART_POLE[k] for k in ("m_c", "m", "l", "g")})
    (x, theta), (v, omega), F = s["q"], s["u"], s["F"]
    c = CART_POLE
    problem = kd.OptimalControlProblem(
        model, nodes=nodes, duration=c["duration"], lagrange=F ** 2,
        bounds={F: (-c["force"], c["force"]), x: (-c["track"], c["track"])},
        initial={x: 0.0, theta: 0.0, v: 0.0, omega: 0.0},
        final={x: 0.0, theta: np.pi, v: 0.0, omega: 0.0}, method=method)
    return problem, model


def cart_pole_opty(nodes, method="backward-euler", backend="cython"):
    """opty's ``Problem`` of the cart-pole, its equations by SymPy's KanesMethod
    (``backend`` as for :func:`pendulum_opty`)."""
    from opty import Problem, create_objective_function
    t = me.dynamicsymbols._t
    x, th, v, w, F = me.dynamicsymbols("x theta v omega F")
    mc, m, l, g = sm.symbols("m_c m l g")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (th, N.z))
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x)
    C.set_vel(N, v * N.x)
    P = C.locatenew("P", -l * A.y)
    A.set_ang_vel(N, w * N.z)
    P.v2pt_theory(C, N, A)
    kane = me.KanesMethod(N, q_ind=[x, th], u_ind=[v, w], kd_eqs=[x.diff() - v, th.diff() - w])
    kane.kanes_equations([me.Particle("cart", C, mc), me.Particle("bob", P, m)],
                         [(C, F * N.x - mc * g * N.y), (P, -m * g * N.y)])
    states = (x, th, v, w)
    eom = kane.mass_matrix_full * sm.Matrix([s.diff() for s in states]) - kane.forcing_full
    c = CART_POLE
    duration = c["duration"]
    h = duration / (nodes - 1)
    obj, obj_grad = create_objective_function(
        sm.Integral(F ** 2, t), states, (F,), (), nodes, h, time_symbol=t,
        integration_method=OPTY_METHODS[method])
    end = duration
    problem = Problem(
        obj, obj_grad, eom, states, nodes, h,
        known_parameter_map={mc: c["m_c"], m: c["m"], l: c["l"], g: c["g"]},
        instance_constraints=(x.func(0.0), th.func(0.0), v.func(0.0), w.func(0.0),
                              x.func(end), th.func(end) - np.pi, v.func(end), w.func(end)),
        bounds={F: (-c["force"], c["force"]), x: (-c["track"], c["track"])},
        time_symbol=t, integration_method=OPTY_METHODS[method], backend=backend)
    return problem


def cart_pole_guess(nodes):
    """Both start from: the cart still, the angle on a line to pi, no force."""
    t = np.linspace(0.0, CART_POLE["duration"], nodes)
    theta = np.pi * t / CART_POLE["duration"]
    Y = np.stack([np.zeros(nodes), theta, np.zeros(nodes),
                  np.full(nodes, np.pi / CART_POLE["duration"])], axis=1)
    return np.concatenate([Y.ravel(), np.zeros(nodes)])


def solve_opty(problem, guess_kanedyn, ns, nr, options=IPOPT_OPTIONS):
    """``(solution in kanedyn's layout, info, iterations)``."""
    for key, value in options.items():
        problem.add_option(key, value)
    N = problem.collocator.num_collocation_nodes
    w, info = problem.solve(to_opty(guess_kanedyn, N, ns, nr))
    return from_opty(np.asarray(w), N, ns, nr), info, len(problem.obj_value) - 1


# ------------------------------------------- opty's gallery: upright a double pendulum
#: opty's gallery problem "Upright a Double Pendulum"
#: (examples-gallery/02-intermediate/plot_two_link_pendulum_on_a_cart.py): a cart
#: (1 kg) on a track |x| <= 5 m carries two rods (1 kg, 2 m, 2 kg m^2 about their
#: ends, the masses at the ends), both from hanging (-pi/2) to upright (pi/2) at
#: rest, |F| <= 150 N, in the least time: opty minimizes the node interval h in
#: (0, 1] s on 300 nodes, backward Euler; 6 states
DOUBLE_PENDULUM_CART = {"lx": 2.0, "m1": 1.0, "m2": 1.0, "m3": 1.0, "g": 9.81,
                        "iZZ1": 2.0, "iZZ2": 2.0, "force": 150.0, "track": 5.0,
                        "h_max": 1.0, "nodes": 300}


def _double_pendulum_cart():
    """The gallery's model, as it writes it: ``(N, q, u, F, constants, bodies, loads,
    kd_eqs)``."""
    N, A1, A2 = sm.symbols("N A1, A2", cls=me.ReferenceFrame)
    O, P1, P2, P3 = sm.symbols("O P1 P2 P3", cls=me.Point)
    O.set_vel(N, 0)
    q1, q2, q3, u1, u2, u3, F = me.dynamicsymbols("q1 q2 q3 u1 u2 u3 F")
    lx, m1, m2, m3, g, iZZ1, iZZ2 = sm.symbols("lx, m1, m2, m3 g, iZZ1, iZZ2")
    A1.orient_axis(N, q2, N.z)
    A1.set_ang_vel(N, u2 * N.z)
    A2.orient_axis(N, q3, N.z)
    A2.set_ang_vel(N, u3 * N.z)
    P1.set_pos(O, q1 * N.x)
    P2.set_pos(P1, lx * A1.x)
    P2.v2pt_theory(P1, N, A1)
    P3.set_pos(P2, lx * A2.x)
    P3.v2pt_theory(P2, N, A2)
    bodies = [me.Particle("P1a", P1, m1),
              me.RigidBody("P2a", P2, A1, m2, (me.inertia(A1, 0, 0, iZZ1), P2)),
              me.RigidBody("P3a", P3, A2, m3, (me.inertia(A2, 0, 0, iZZ2), P3))]
    loads = [(P1, F * N.x - m1 * g * N.y), (P2, -m2 * g * N.y), (P3, -m3 * g * N.y)]
    kd_eqs = [q1.diff() - u1, q2.diff() - u2, q3.diff() - u3]
    constants = dict(zip((lx, m1, m2, m3, g, iZZ1, iZZ2),
                         (DOUBLE_PENDULUM_CART[k] for k in
                          ("lx", "m1", "m2", "m3", "g", "iZZ1", "iZZ2"))))
    return N, (q1, q2, q3), (u1, u2, u3), F, constants, bodies, loads, kd_eqs


def double_pendulum_cart_kanedyn(nodes, method="backward-euler", backend="c"):
    """``(problem, model)``: the gallery's problem with kanedyn (``kd.kane`` on the
    gallery's objects); the objective is T / (N - 1), opty's h."""
    import kanedyn as kd
    N, q, u, F, constants, bodies, loads, kd_eqs = _double_pendulum_cart()
    eom = kd.kane(frame=N, q_ind=list(q), u_ind=list(u), kd_eqs=kd_eqs, bodies=bodies,
                  loads=loads)
    model = eom.numeric(constants=constants, specified={F: 0.0}, backend=backend)
    c = DOUBLE_PENDULUM_CART
    T = sm.Symbol("T", positive=True)
    # kanedyn needs a positive lower bound of the duration; opty's h > 0 is open
    problem = kd.OptimalControlProblem(
        model, nodes=nodes, duration=T, mayer=T / (nodes - 1),
        bounds={F: (-c["force"], c["force"]), q[0]: (-c["track"], c["track"]),
                T: (1e-9 * (nodes - 1), c["h_max"] * (nodes - 1))},
        initial={q[0]: 0.0, q[1]: -np.pi / 2, q[2]: -np.pi / 2, u[0]: 0.0, u[1]: 0.0,
                 u[2]: 0.0},
        final={q[1]: np.pi / 2, q[2]: np.pi / 2, u[0]: 0.0, u[1]: 0.0, u[2]: 0.0},
        method=method)
    return problem, model


def double_pendulum_cart_opty(nodes, method="backward-euler"):
    """opty's ``Problem``, as the gallery writes it (its equations by SymPy's
    KanesMethod)."""
    from opty import Problem
    N, q, u, F, constants, bodies, loads, kd_eqs = _double_pendulum_cart()
    t = me.dynamicsymbols._t
    KM = me.KanesMethod(N, q_ind=list(q), u_ind=list(u), kd_eqs=sm.Matrix(kd_eqs))
    fr, frstar = KM.kanes_equations(bodies, loads=loads)
    eom = sm.Matrix(kd_eqs).col_join(fr + frstar)
    h = sm.symbols("h")
    duration = (nodes - 1) * h
    c = DOUBLE_PENDULUM_CART

    def obj(free):
        return free[-1]

    def obj_grad(free):
        grad = np.zeros_like(free)
        grad[-1] = 1.0
        return grad
    initial = {q[0]: 0.0, q[1]: -np.pi / 2, q[2]: -np.pi / 2, u[0]: 0.0, u[1]: 0.0,
               u[2]: 0.0}
    final = {q[1]: np.pi / 2, q[2]: np.pi / 2, u[0]: 0.0, u[1]: 0.0, u[2]: 0.0}
    instance = (tuple(x.subs({t: 0}) - v for x, v in initial.items())
                + tuple(x.subs({t: duration}) - v for x, v in final.items()))
    return Problem(obj, obj_grad, eom, (*q, *u), nodes, h, known_parameter_map=constants,
                   instance_constraints=instance, time_symbol=t,
                   bounds={F: (-c["force"], c["force"]), q[0]: (-c["track"], c["track"]),
                           h: (0.0, c["h_max"])},
                   integration_method=OPTY_METHODS[method])


def double_pendulum_cart_guess(nodes):
    """The gallery's own initial guess (kanedyn's layout): both angles on a line
    from -pi/2 to pi/2, F = 50 N, h = 0.01 s, the rest zero."""
    Y = np.zeros((nodes, 6))
    Y[:, 1] = Y[:, 2] = np.linspace(-np.pi / 2, np.pi / 2, nodes)
    return np.concatenate([Y.ravel(), np.full(nodes, 50.0), [0.01 * (nodes - 1)]])


def duration_to_opty(z, N, ns, nr):
    """kanedyn's vector with T last -> opty's with h = T / (N - 1) last."""
    w = to_opty(z, N, ns, nr)
    w[-1] = z[-1] / (N - 1)
    return w


def duration_from_opty(w, N, ns, nr):
    z = from_opty(w, N, ns, nr)
    z[-1] = w[-1] * (N - 1)
    return z
