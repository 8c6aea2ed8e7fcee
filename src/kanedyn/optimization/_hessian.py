r"""The exact Hessian of the NLP's Lagrangian (``solve(hessian="exact")``).

IPOPT's Lagrangian is :math:`\sigma J(z) + \sum_j \lambda_j g_j(z)`.  With
the defect rows :math:`y_{k+1} - y_k - h \sum_s c_s f(t_s, y_s, r_s)` and the
objective's quadrature :math:`h \sum_k \sum_s c_s L(t_s, y_s, r_s)` (plus a
Mayer term at the last node), every stage point :math:`x_s = (y_s, r_s) =
\sum_o a_{s,o}\,(y_{k+o}, r_{k+o})` contributes the block

.. math::

    a_s a_s^T \otimes \Bigl(\frac{\partial^2 (\lambda_s^T f)}{\partial x^2}
    + \sigma h c_s L''\Bigr),\qquad \lambda_s = -h c_s\,\lambda_{k},

on the variables of its interval's nodes: block diagonal per node for
backward Euler and the trapezoid, two nodes wide for the midpoint rule.
The second derivatives of :math:`f` are generated
(:func:`kanedyn.numerics._hessians.weighted_hessians`), those of the
objective are SymPy's.  Entries repeat where blocks overlap (IPOPT adds
them); only the lower triangle is given.

For problems whose only constraints are the dynamics' defects and the bounds
(the initial and final states are bounds): path constraints, instance
constraints, free parameters, a free duration, a model with constraints, the
interval methods (Hermite-Simpson, LGR) and a phase that starts at a free
time are refused, naming the feature.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .._errors import ModelError
from ._transcription import INTERVAL_METHODS

__all__ = ["LagrangianHessian", "HESSIANS"]

#: the values of ``solve(hessian=...)``
HESSIANS = ("limited-memory", "exact")


class LagrangianHessian:
    """Pattern and values of the Lagrangian's Hessian of ``nlp`` (a
    :class:`._nlp.CollocationNLP`)."""

    def __init__(self, nlp):
        from ..numerics import hessians_unavailable
        pb, L = nlp.problem, nlp.layout
        refused = [what for what, present in (
            ("path constraints", bool(pb.path)),
            ("instance constraints", bool(pb.instances)),
            ("free parameters", bool(L.n_free)),
            ("a free duration", L.free_duration),
            ("a model with constraints", bool(pb.n_residuals)),
            (f"the {pb.method} method", pb.method in INTERVAL_METHODS),
            ("a phase of a multiphase problem", L.free_start_time)) if present]
        if refused:
            raise ModelError(f'hessian="exact" is not available for {", ".join(refused)} '
                             '(use hessian="limited-memory")')
        reason = hessians_unavailable(pb.model)
        if reason:
            raise ModelError(f'hessian="exact": {reason}')
        self.nlp = nlp
        N, ns, nr = L.nodes, L.n_states, L.n_inputs
        self.nx = nx = ns + nr
        k = np.arange(N)[:, None]
        node_vars = np.concatenate([k * ns + np.arange(ns),
                                    L.input_start + k * nr + np.arange(nr)], axis=1)
        self._blocks = []  # (variables (K, m), coefficients (m,), mask (K, m, m))
        rows, cols = [], []
        for s in nlp.defects.stages:
            offsets = [o for o in (0, 1) if s.a[o]]
            V = np.concatenate([node_vars[o:o + N - 1] for o in offsets], axis=1)
            a = np.repeat([s.a[o] for o in offsets], nx)
            self._add(V, a, rows, cols)
        if pb.mayer is not None:
            self._add(node_vars[-1:], np.ones(nx), rows, cols)
        self.structure = (np.concatenate(rows), np.concatenate(cols))

    def _add(self, V, a, rows, cols):
        r = np.broadcast_to(V[:, :, None], V.shape + V.shape[1:])
        c = np.broadcast_to(V[:, None, :], r.shape)
        mask = r >= c
        rows.append(r[mask])
        cols.append(c[mask])
        self._blocks.append((V, a, mask))

    def values(self, z, sigma, multipliers):
        """The Hessian's values in the order of :attr:`structure`."""
        from ..numerics import weighted_hessians
        nlp = self.nlp
        e = nlp._evaluate(z)
        pb, L = nlp.problem, nlp.layout
        N, ns, h = L.nodes, L.n_states, e["h"]
        defects = nlp.defects
        rows = defects.rows
        n_defects = (N - 1) * len(rows)
        lam = np.zeros((N - 1, ns))
        lam[:, rows] = np.asarray(multipliers[:n_defects]).reshape(N - 1, len(rows))
        stages = defects._stage_values(e["evaluated"])
        out = []
        for s, (f, A, B, _), (V, a, mask) in zip(defects.stages, stages, self._blocks):
            t = pb.start_time + h * (np.arange(N - 1) + s.position)
            Ys = s.a[0] * e["Y"][:-1] + s.a[1] * e["Y"][1:]
            Rs = s.a[0] * e["R"][:-1] + s.a[1] * e["R"][1:]
            H = weighted_hessians(e["model"], t, Ys, Rs, -h * s.c * lam,
                                  SimpleNamespace(f=f, state=A, inputs=B))
            if pb.lagrange is not None and sigma:
                H = H + sigma * h * s.c * pb.lagrange.second(t, Ys, Rs, e["P"], e["T"])
            out.append(self._spread(H, a, V, mask))
        if pb.mayer is not None:
            V, a, mask = self._blocks[-1]
            tf = np.array([pb.start_time + e["T"]])
            H = sigma * pb.mayer.second(tf, e["Y"][-1:], e["R"][-1:], e["P"], e["T"])
            out.append(self._spread(H, a, V, mask))
        return np.concatenate(out)

    def _spread(self, H, a, V, mask):
        reps = V.shape[1] // self.nx
        block = np.tile(H, (1, reps, reps)) * (a[:, None] * a[None, :])
        return block[mask]
