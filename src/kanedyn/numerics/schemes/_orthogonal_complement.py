r"""The natural orthogonal complement's numerical assembly (its constraint scheme).

The formulation (:mod:`kanedyn.formulations._orthogonal_complement`) leaves
per-body blocks on the equations; this scheme turns them into the mass matrix
and forcing at evaluation time and solves by Cholesky's factorization.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..._errors import ModelError
from ._base import AccelerationSystem, Scheme, complement_solve

__all__ = ["OrthogonalComplement"]

_ASSEMBLY = '''
def dynamics(t, y, p, r):
    qd, T, Tdu, Mb, w, Q, B, K, fa, TF, TduF, MbF, wF = _noc_blocks(t, y, p, r)
    # M_b T_b for every rigid body at once, then M = T^T blkdiag(M_b) T
    MT = numpy.matmul(Mb.reshape({nb}, 6, 6), T.reshape({nb}, 6, {o})).reshape({rows}, {o})
    bias = w - numpy.matmul(Mb.reshape({nb}, 6, 6), Tdu.reshape({nb}, 6, 1)).reshape({rows})
    M, f = T.T @ MT, T.T @ bias + Q
    # flexible bodies: one block of its own size each (row offset, size, offset in MbF)
    for start, size, at in {flexible}:
        Mk = MbF[at:at + size * size].reshape(size, size)
        Tk = TF[start:start + size]
        M = M + Tk.T @ (Mk @ Tk)
        f = f + Tk.T @ (wF[start:start + size] - Mk @ TduF[start:start + size])
    return qd, M, f, B, K, fa
'''


@dataclass(frozen=True)
class OrthogonalComplement(Scheme):
    r"""Numerical assembly of the natural orthogonal complement; Cholesky solve.

    :meth:`prepare` replaces the numerical model's generated ``dynamics``
    function by one that evaluates the per-body blocks :math:`T_b`,
    :math:`\dot T_b u`, :math:`M_b`, :math:`w_b` (and :math:`Q`) and assembles

    .. math::

        M = T^T\,\mathrm{blkdiag}(M_b)\,T,\qquad
        f = T^T\left(w - \mathrm{blkdiag}(M_b)\,\dot T u\right) + Q

    with NumPy (so ``model.mass_matrix``, ``model.multipliers`` and the
    Newton–Euler check see the assembled matrices); a flexible body's block
    has its own size, :math:`6 + m` (body-frame origin velocity, angular
    velocity and modal speeds).  :meth:`accelerations`
    eliminates the dependent speeds with the complement :math:`N = [1; X]`
    of the acceleration constraints and solves the symmetric positive
    definite :math:`N^TMN\,\dot u_i = N^T(f - M\dot u_p)` by Cholesky's
    factorization.  Constraint drift is projected as in Kane's elimination
    (dependent coordinates and speeds solved from the constraints).

    Only equations from ``formulate(..., method="orthogonal-complement")``
    carry the blocks; the compiled C backend does not implement the scheme.
    """

    name: ClassVar[str] = "orthogonal-complement"
    project: ClassVar[bool] = True
    c_backend: ClassVar[bool] = False

    def prepare(self, model):
        eom = model._eom
        blocks = getattr(eom, "_noc_blocks", None)
        if blocks is None:
            raise ModelError(
                f"the orthogonal-complement scheme needs the per-body blocks of "
                f"formulate(..., method='orthogonal-complement'); these equations come "
                f"from the {eom.method!r} formulation")
        prog = eom._program
        subs = model._substitutions

        def sub(e):
            return prog.subs(e, subs) if subs else e

        n, o, m = model.n_q, model.n_u, model.n_u_dep
        nb = blocks.n_bodies
        rows = 6 * nb
        sizes = getattr(blocks, "sizes", ())
        layout, start, at = [], 0, 0
        for size in sizes:
            layout.append((start, size, at))
            start, at = start + size, at + size * size
        outputs = [((n,), [sub(e) for e in eom._qdot]),
                   ((rows, o), [sub(e) for e in blocks.T]),
                   ((rows,), [sub(e) for e in blocks.Tdu]),
                   ((36 * nb,), [sub(e) for e in blocks.Mb]),
                   ((rows,), [sub(e) for e in blocks.w]),
                   ((o,), [sub(e) for e in blocks.Q]),
                   ((m, o), [sub(e) for row in eom._vel_B for e in row]),
                   ((m, o), [sub(e) for row in eom._acc_K for e in row]),
                   ((m,), [sub(e) for e in eom._acc_f]),
                   ((start, o), [sub(e) for e in blocks.TF]),
                   ((start,), [sub(e) for e in blocks.TduF]),
                   ((at,), [sub(e) for e in blocks.MbF]),
                   ((start,), [sub(e) for e in blocks.wF])]
        from ..backends._python import compile_python, generate_python
        args = model._functions["dynamics"][0]
        source = (generate_python(prog, "_noc_blocks", args, outputs, cse=model._cse is not False)
                  + _ASSEMBLY.format(nb=nb, o=o, rows=rows, flexible=tuple(layout)))
        # kept in the model's sources, so that copies and unpickled models
        # evaluate the same assembly
        model._data["sources"]["dynamics"] = source
        model._fn["dynamics"] = compile_python(source, "dynamics")

    def accelerations(self, model, t, y, terms):
        _, mass, force, _, acc_K, acc_f = terms
        m = model.n_u_dep
        if not m:
            return _cholesky_solve(mass, force, t)
        return complement_solve(mass, force, acc_K, acc_f, np.arange(model.n_u - m, model.n_u),
                                solve=lambda A, b: _cholesky_solve(A, b, t))

    def acceleration_system(self):
        return AccelerationSystem()


def _cholesky_solve(A, b, t):
    import scipy.linalg as sla  # imported when first needed
    try:
        return sla.cho_solve(sla.cho_factor(A), b)
    except np.linalg.LinAlgError:
        raise np.linalg.LinAlgError(
            f"the mass matrix of the natural orthogonal complement is not positive "
            f"definite at t = {t:g} (a speed that moves no mass or inertia, or a "
            "dependent-speed partition singular here)") from None
