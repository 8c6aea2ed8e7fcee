"""kanedyn's own interior-point NLP solver (``solve(solver="interior-point")``).

A primal-dual interior-point method of IPOPT's family (barrier, fraction to
the boundary, filter line search, inertia correction) on the collocation
NLP's sparse Jacobian and exact Hessian, its linear systems solved by a sparse
LDLᵀ factorization compiled in C that reports the inertia.

``kkt/``         the Newton step's linear system, factorized with its inertia
                 (the module list in ``kkt/__init__``): ``DenseKKT``, the
                 reference (LAPACK's dense LDLᵀ through SciPy); ``SparseKKT``,
                 a sparse LDLᵀ with 2 x 2 pivots on paired rows, compiled;
                 ``EnvelopeKKT`` (the default), the same LDLᵀ with L stored
                 by its envelope; ``LowRankKKT``, a limited-memory Hessian's
                 rank-2h part on any of them
``_solver``      ``InteriorPoint``: the algorithm, behind the interface of
                 ``optimization._solvers``; what it uses, in the data flow:
``_options``     the options (IPOPT's names and defaults), checked
``_reduced``     the NLP without fixed variables and unbounded rows, scaled
``_bounds``      the barrier, the bounds of the variables and slacks
``_start``       the starting point and the first multipliers
``_step``        the Newton step, regularized to the right inertia
``_filter``      the filter line search's acceptance test
``_restoration`` the feasibility restoration phase
``_optimality``  the optimality error, the bound multipliers' safeguard
``_status``      the return codes (IPOPT's numbers)
``_mapped``      NumPy's large arrays in mappings of their own during a solve
                 (resident memory that follows the arrays alive)

The factorizations take the same calls: ``KKT(n, m, hessian_structure,
jacobian_structure)``, ``factor(hessian_values, jacobian_values, diagonal_x,
diagonal_c, added_x=0.0) -> (n_positive, n_negative, n_zero)`` (each diagonal
an array or one number for every entry, ``diagonal_x`` also a
``kkt._diagonal.DiagonalEntries``; ``added_x``, the solver's
:math:`\\delta_w`, added to ``diagonal_x`` where not 0), ``solve(rhs,
overwrite=False)`` (with ``overwrite=True`` the solution may be written over
``rhs``, a writeable C-contiguous float64 vector, and returned, so the caller
uses only what is returned: ``SparseKKT`` and ``EnvelopeKKT`` do so,
``DenseKKT`` makes a new array; ``LowRankKKT`` passes it to its base),
``matvec(x)`` and ``release()`` (the factors dropped until the next
``factor``: the solver calls it at each new point).
"""

from ..._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
_LAZY = {
    "DenseKKT": ".kkt._dense",
    "SparseKKT": ".kkt._sparse",
    "EnvelopeKKT": ".kkt._envelope",
    "InteriorPoint": "._solver",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
