"""Which IPOPT for kanedyn's optimal control: cyipopt (Debian's libipopt) or
CasADi's bundled IPOPT, both driven by the same Python callbacks.

kanedyn supplies its own exact sparse constraint Jacobian from compiled code,
so what matters is what each interface adds around those callbacks:

1. the overhead of one round trip solver -> Python callback -> solver (a
   problem of 2 variables, where the callbacks cost nothing), per call;
2. a transcribed problem of realistic size (a double integrator, minimum
   effort, trapezoidal collocation at N nodes; every callback vectorized
   NumPy): wall time, iterations, time inside the callbacks, and what the
   interface and IPOPT take besides;
3. how a sparse Jacobian is handed over: cyipopt takes (rows, cols) once and
   the values each call; CasADi takes a ``casadi.Callback`` whose
   ``get_jacobian`` returns a second ``Callback`` declaring a
   ``casadi.Sparsity`` and returning a ``DM`` each call.

Both solve with the limited-memory Hessian, MUMPS, ``tol=1e-8``.  The IPOPT
versions differ (Debian 12's 3.11.9; CasADi's wheel bundles 3.14), so
iteration counts may differ a little; the callbacks are the same functions.

Usage::

    python benchmarks/bench_nlp_solvers.py [--nodes 1000 10000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np


class Counted:
    """The NLP's callbacks with call counters and the time spent inside."""

    def __init__(self, problem):
        self.p = problem
        self.calls = 0
        self.seconds = 0.0

    def wrap(self, fn):
        def inner(x, *args):
            start = time.perf_counter()
            out = fn(np.asarray(x, dtype=float).ravel(), *args)
            self.seconds += time.perf_counter() - start
            self.calls += 1
            return out
        return inner


def tiny():
    """min (x0 - 1)^2 + (x1 - 2)^2 subject to x0 + x1 = 1: the callbacks are free."""
    return dict(
        n=2, m=1,
        f=lambda x: (x[0] - 1) ** 2 + (x[1] - 2) ** 2,
        grad=lambda x: np.array([2 * (x[0] - 1), 2 * (x[1] - 2)]),
        g=lambda x: np.array([x[0] + x[1] - 1.0]),
        rows=np.array([0, 0]), cols=np.array([0, 1]),
        jac=lambda x: np.array([1.0, 1.0]),
        x0=np.zeros(2), lbx=np.full(2, -1e20), ubx=np.full(2, 1e20),
        lbg=np.zeros(1), ubg=np.zeros(1))


def double_integrator(N):
    """Rest-to-rest in 1 s over a distance 1, min integral of u^2, trapezoid.

    Variables [x (N), v (N), u (N)]; constraints: the 2 (N - 1) defects, then
    x0 = v0 = 0, x1 = 1, v1 = 0 as bounds.
    """
    h = 1.0 / (N - 1)
    k = np.arange(N - 1)
    n = 3 * N

    def split(z):
        return z[:N], z[N:2 * N], z[2 * N:]

    def f(z):
        u = split(z)[2]
        return h * (0.5 * u[0] ** 2 + np.sum(u[1:-1] ** 2) + 0.5 * u[-1] ** 2)

    def grad(z):
        u = split(z)[2]
        w = np.full(N, 2 * h)
        w[0] = w[-1] = h
        return np.concatenate([np.zeros(2 * N), w * u])

    def g(z):
        x, v, u = split(z)
        return np.concatenate([x[1:] - x[:-1] - 0.5 * h * (v[1:] + v[:-1]),
                               v[1:] - v[:-1] - 0.5 * h * (u[1:] + u[:-1])])

    r1 = np.repeat(k, 4)
    c1 = np.stack([k + 1, k, N + k + 1, N + k], axis=1).ravel()
    r2 = np.repeat(N - 1 + k, 4)
    c2 = np.stack([N + k + 1, N + k, 2 * N + k + 1, 2 * N + k], axis=1).ravel()
    vals = np.tile([1.0, -1.0, -0.5 * h, -0.5 * h], 2 * (N - 1))
    lbx, ubx = np.full(n, -1e20), np.full(n, 1e20)
    for idx, value in ((0, 0.0), (N, 0.0), (N - 1, 1.0), (2 * N - 1, 0.0)):
        lbx[idx] = ubx[idx] = value
    return dict(n=n, m=2 * (N - 1), f=f, grad=grad, g=g,
                rows=np.concatenate([r1, r2]), cols=np.concatenate([c1, c2]),
                jac=lambda z: vals.copy(), x0=np.zeros(n), lbx=lbx, ubx=ubx,
                lbg=np.zeros(2 * (N - 1)), ubg=np.zeros(2 * (N - 1)))


OPTIONS = {"hessian_approximation": "limited-memory", "tol": 1e-8, "print_level": 0,
           "max_iter": 3000, "linear_solver": "mumps"}


def run_cyipopt(p):
    import cyipopt
    c = Counted(p)

    class Problem:
        objective = staticmethod(c.wrap(p["f"]))
        gradient = staticmethod(c.wrap(p["grad"]))
        constraints = staticmethod(c.wrap(p["g"]))
        jacobian = staticmethod(c.wrap(p["jac"]))

        def jacobianstructure(self):
            return p["rows"], p["cols"]

    nlp = cyipopt.Problem(n=p["n"], m=p["m"], problem_obj=Problem(), lb=p["lbx"],
                          ub=p["ubx"], cl=p["lbg"], cu=p["ubg"])
    for key, value in OPTIONS.items():
        nlp.add_option(key, value)
    nlp.add_option("sb", "yes")
    start = time.perf_counter()
    x, info = nlp.solve(p["x0"])
    wall = time.perf_counter() - start
    # cyipopt 1.7 reports no iteration count in info: ask the intermediate callback
    return x, wall, c, info["status"], _iterations_cyipopt(p)


def _iterations_cyipopt(p):
    import cyipopt
    count = [0]

    class Problem:
        objective = staticmethod(p["f"])
        gradient = staticmethod(p["grad"])
        constraints = staticmethod(p["g"])
        jacobian = staticmethod(p["jac"])

        def jacobianstructure(self):
            return p["rows"], p["cols"]

        def intermediate(self, *args):
            count[0] = args[1]
            return True

    nlp = cyipopt.Problem(n=p["n"], m=p["m"], problem_obj=Problem(), lb=p["lbx"],
                          ub=p["ubx"], cl=p["lbg"], cu=p["ubg"])
    for key, value in OPTIONS.items():
        nlp.add_option(key, value)
    nlp.add_option("sb", "yes")
    nlp.solve(p["x0"])
    return count[0]


def run_casadi(p):
    import casadi as ca
    c = Counted(p)
    n, m = p["n"], p["m"]
    f, grad, g, jac = (c.wrap(p[k]) for k in ("f", "grad", "g", "jac"))
    sparsity = ca.Sparsity.triplet(m, n, list(map(int, p["rows"])), list(map(int, p["cols"])))
    # the triplet order is not CasADi's column-major order: a permutation
    order = np.lexsort((p["rows"], p["cols"]))

    class Jac(ca.Callback):
        def __init__(self, name, out_rows, fn, sp):
            ca.Callback.__init__(self)
            self.out_rows, self.fn, self.sp = out_rows, fn, sp
            self.construct(name, {})

        def get_n_in(self):
            return 2

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(n, 1) if i == 0 else ca.Sparsity.dense(self.out_rows, 1)

        def get_sparsity_out(self, i):
            return self.sp

        def eval(self, args):
            return [self.fn(np.array(args[0]))]

    def gradient_values(x):
        return ca.DM(ca.Sparsity.dense(1, n), grad(x))

    def jacobian_values(x):
        return ca.DM(sparsity, jac(x)[order])

    class Fun(ca.Callback):
        def __init__(self, name, rows, fn, jac_fn, sp):
            ca.Callback.__init__(self)
            self.rows, self.fn = rows, fn
            self.jac = Jac(name + "_jac", rows, jac_fn, sp)
            self.construct(name, {})

        def get_n_in(self):
            return 1

        def get_n_out(self):
            return 1

        def get_sparsity_in(self, i):
            return ca.Sparsity.dense(n, 1)

        def get_sparsity_out(self, i):
            return ca.Sparsity.dense(self.rows, 1)

        def eval(self, args):
            return [np.atleast_1d(self.fn(np.array(args[0])))]

        def has_jacobian(self):
            return True

        def get_jacobian(self, name, inames, onames, opts):
            return self.jac

    F = Fun("f", 1, f, gradient_values, ca.Sparsity.dense(1, n))
    G = Fun("g", m, g, jacobian_values, sparsity)
    x = ca.MX.sym("x", n)
    opts = {"ipopt." + k: v for k, v in OPTIONS.items()}
    opts.update({"print_time": False, "ipopt.sb": "yes"})
    solver = ca.nlpsol("s", "ipopt", {"x": x, "f": F(x), "g": G(x)}, opts)
    start = time.perf_counter()
    out = solver(x0=p["x0"], lbx=p["lbx"], ubx=p["ubx"], lbg=p["lbg"], ubg=p["ubg"])
    wall = time.perf_counter() - start
    stats = solver.stats()
    return (np.array(out["x"]).ravel(), wall, c, stats["return_status"],
            stats["iter_count"])


def report(label, problem, runner):
    x, wall, c, status, iterations = runner(problem)
    print(f"  {label:8s} wall {wall:8.4f} s  iterations {iterations:5d}  callbacks "
          f"{c.calls:6d} ({c.seconds:7.4f} s inside)  outside the callbacks "
          f"{1e6 * (wall - c.seconds) / max(c.calls, 1):8.1f} us per call  status {status}")
    return x, wall, c


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="*", default=[300, 1000, 10000])
    parser.add_argument("--casadi-up-to", type=int, default=1000,
                        help="largest N given to CasADi (its time grows as N^3: 194 s "
                             "at N = 1000 on the machine of docs/benchmarks.md)")
    args = parser.parse_args()
    import casadi
    import cyipopt
    print(f"cyipopt {cyipopt.__version__} (IPOPT {cyipopt.IPOPT_VERSION}), "
          f"casadi {casadi.__version__}")
    print("tiny problem (2 variables, callbacks free)")
    for label, runner in (("cyipopt", run_cyipopt), ("casadi", run_casadi)):
        report(label, tiny(), runner)
    for N in args.nodes:
        print(f"double integrator, trapezoid, N = {N} ({3 * N} variables)")
        runners = [("cyipopt", run_cyipopt)]
        if N <= args.casadi_up_to:
            runners.append(("casadi", run_casadi))
        xs = [report(label, double_integrator(N), runner)[0] for label, runner in runners]
        if len(xs) == 2:
            print(f"  largest difference between the solutions "
                  f"{np.max(np.abs(xs[0] - xs[1])):.2e}")


if __name__ == "__main__":
    main()
