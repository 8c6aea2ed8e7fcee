"""The interior-point method's KKT factorizations (``SparseKKT``, ``EnvelopeKKT``) on a
pendulum swing-up.

The NLP of the torque-driven pendulum swung to 2 rad and stopped in 3 s
(least effort, as in ``tests/test_optimal_control.py``), free duration, with
its exact Hessian at random multipliers, at 100, 1,000 and 10,000 nodes
(``--nodes``), trapezoid and Hermite-Simpson.  K = [[H + 1e-4 I, Jᵀ], [J, 0]].
For each:

- ``SparseKKT``'s and ``EnvelopeKKT``'s analysis time (ordering, pattern,
  maps, elimination tree; the envelope), nnz(L) (the envelope's entries)
  and the bytes per node of L (with D), of the maps (with K's pattern and
  values; the envelope's order and the Hessian's structure) and of the
  kernel's scratch arrays;
- their ``factor`` (the scatter of the values included) and ``solve`` (one
  right-hand side), timed interleaved in rounds (:func:`_timing.interleaved`,
  thread CPU time, minima), and the envelope's times over the sparse ones;
- SciPy's ``splu`` on the same matrix (a general sparse LU), for reference:
  SuperLU's default order (COLAMD) with threshold partial pivoting that
  prefers the diagonal (``diag_pivot_thresh=0.01``: with its default, 1.0,
  L + U had 317 thousand entries at 1,000 trapezoid nodes, 13.9 million at
  1,000 Hermite-Simpson nodes, against 52 and 146 thousand, and 10,000 nodes
  ran out of 8 GB; the minimum degree order on Aᵀ + A filled more at both
  thresholds); its factorization (ordering included: it cannot reuse one)
  and solve times as ratios ours / SciPy's, and nnz(L) + nnz(U);
- the fill of other orders, for the choice of ours (``--orders``): SuperLU's
  minimum degree on Aᵀ + A (``permc_spec="MMD_AT_PLUS_A"``, diagonal pivots,
  symmetric mode: nnz of its L below the diagonal is the fill of that
  order), and ``SparseKKT``'s ``ordering="rcm"`` (the rows themselves, no
  pairs) and ``ordering="pairs-mmd"`` (the pairs in that minimum degree
  order instead of RCM), and their ``factor`` times (in the same rounds)
  as ratios to ours.

No assertions; the residual of the solve is printed (relative, infinity norm).

Usage::

    python benchmarks/bench_kkt_factor.py [--nodes 100 1000 10000] [--rounds 5]
        [--orders]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import sympy as sm

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kanedyn as kd  # noqa: E402
from _timing import interleaved  # noqa: E402
from kanedyn.optimization._nlp import CollocationNLP  # noqa: E402
from kanedyn.optimization.interior_point import EnvelopeKKT, SparseKKT  # noqa: E402

#: the two storages of L, each analysed, factored and timed
STORAGES = {"sparse": SparseKKT, "envelope": EnvelopeKKT}


#: SuperLU's options for the reference LU (the module's docstring)
REFERENCE = {"diag_pivot_thresh": 0.01}


def pendulum_nlp(nodes, method):
    """The swing-up's NLP (free duration, exact Hessian)."""
    definition = kd.models.build("pendulum", torque=True)
    model = definition.numeric(backend="numpy")
    q, u, tau = (definition.symbols[k] for k in ("q", "u", "tau"))
    T = sm.Symbol("T")
    problem = kd.OptimalControlProblem(
        model, nodes=nodes, duration=T, lagrange=tau ** 2, initial={q: 0, u: 0},
        final={q: 2.0, u: 0}, method=method, bounds={T: (0.5, 10.0)})
    return CollocationNLP(problem, hessian="exact")


def kkt_values(nlp, seed=0):
    """``(hessian_values, jacobian_values, diagonal_x, diagonal_c)`` at a
    random point (duration 3 s) and random multipliers."""
    rng = np.random.default_rng(seed)
    z = rng.normal(size=nlp.n)
    z[nlp.layout.duration_index] = 3.0
    return (nlp.hessian(z, rng.normal(size=nlp.m), 1.0), nlp.jacobian(z),
            np.full(nlp.n, 1e-4), np.zeros(nlp.m))


def kkt_matrix(nlp, values):
    """K as a SciPy CSC matrix (both triangles)."""
    hv, jv, dx, dc = values
    n, m = nlp.n, nlp.m
    (hr, hc), (jr, jc) = nlp.hessian_structure(), nlp.jacobian_structure()
    H = sp.coo_matrix((hv, (hr, hc)), shape=(n, n)).tocsc()
    H = H + sp.tril(H, -1).T + sp.diags(dx)
    J = sp.coo_matrix((jv, (jr, jc)), shape=(m, n)).tocsc()
    return sp.bmat([[H, J.T], [J, -sp.diags(dc)]], format="csc")


def minimum_degree_fill(K):
    """nnz below the diagonal of L in SuperLU's minimum degree order on Aᵀ + A
    (no pivoting off the diagonal)."""
    lu = spla.splu(K, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True})
    return lu.L.nnz - K.shape[0]


def run(nodes, method, rounds, orders):
    nlp = pendulum_nlp(nodes, method)
    values = kkt_values(nlp)
    structures = (nlp.hessian_structure(), nlp.jacobian_structure())
    kkts, analysis_time = {}, {}
    for name, KKT in STORAGES.items():
        start = time.perf_counter()
        kkts[name] = KKT(nlp.n, nlp.m, *structures)
        analysis_time[name] = time.perf_counter() - start
    K = kkt_matrix(nlp, values)
    rhs = np.random.default_rng(1).normal(size=K.shape[0])
    inertia = {name: kkt.factor(*values) for name, kkt in kkts.items()}
    residual = {name: np.abs(K @ kkt.solve(rhs) - rhs).max() / np.abs(rhs).max()
                for name, kkt in kkts.items()}
    lu = spla.splu(K, **REFERENCE)
    contenders = {"splu": lambda: spla.splu(K, **REFERENCE), "splu solve": lambda: lu.solve(rhs)}
    for name, kkt in kkts.items():
        contenders[f"factor {name}"] = lambda k=kkt: k.factor(*values)
        contenders[f"solve {name}"] = lambda k=kkt: k.solve(rhs)
    others = {}
    if orders:
        others = {o: SparseKKT(nlp.n, nlp.m, *structures, ordering=o)
                  for o in ("rcm", "pairs-mmd")}
        contenders.update({f"factor {o}": (lambda k=k: k.factor(*values))
                           for o, k in others.items()})
    timings = interleaved(contenders, rounds=rounds, min_time=0.05)
    best = {name: t.best for name, t in timings.items()}
    for name, kkt in kkts.items():
        a = kkt.analysis
        print(f"{method:15s} {nodes:6d} {name:8s} n={a.n:6d} m={a.m:6d} dense={a.n_dense} "
              f"nnz(K)={a.nnz_matrix:7d} nnz(L)={a.nnz_factor:8d} "
              f"L {a.bytes_factor / nodes:6.0f} B/node, maps {a.bytes_maps / nodes:5.0f} "
              f"B/node, scratch {a.bytes_workspace / nodes:4.0f} B/node | analysis "
              f"{analysis_time[name] * 1e3:7.1f} ms, factor {best[f'factor {name}'] * 1e3:7.3f}"
              f" ms ({best[f'factor {name}'] / best['splu']:.3f} x splu), solve "
              f"{best[f'solve {name}'] * 1e3:6.3f} ms "
              f"({best[f'solve {name}'] / best['splu solve']:.2f} x splu's) | inertia "
              f"{inertia[name]} residual {residual[name]:.1e}")
    print(f"{'':22s} envelope / sparse: factor "
          f"{best['factor envelope'] / best['factor sparse']:.2f}, solve "
          f"{best['solve envelope'] / best['solve sparse']:.2f}; splu nnz(L+U) "
          f"{lu.L.nnz + lu.U.nnz}")
    if orders:
        a = kkts["sparse"].analysis
        rcm, mmd = (others[o].analysis.nnz_factor for o in ("rcm", "pairs-mmd"))
        print(f"{'':22s} fill: ours (pairs by RCM) {a.nnz_factor}, pairs by minimum "
              f"degree {mmd}, rows by RCM {rcm}, SuperLU's minimum degree on A'+A "
              f"{minimum_degree_fill(K)}; factor time / ours: pairs by minimum degree "
              f"{best['factor pairs-mmd'] / best['factor sparse']:.2f}, rows by RCM "
              f"{best['factor rcm'] / best['factor sparse']:.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="+", default=[100, 1000, 10000])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--orders", action="store_true",
                        help="also the fill of other orders")
    args = parser.parse_args()
    print(f"load {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}, "
          f"{os.cpu_count()} CPUs, NumPy {np.__version__}")
    for method in ("trapezoid", "hermite-simpson"):
        for nodes in args.nodes:
            run(nodes, method, args.rounds, args.orders)


if __name__ == "__main__":
    main()
