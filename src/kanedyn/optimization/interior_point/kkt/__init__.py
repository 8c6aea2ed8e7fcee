"""The interior point's Newton system, factorized with its inertia.

``_dense``     ``DenseKKT``: the reference (LAPACK's dense LDLᵀ through
               SciPy), for tests and small problems
``_sparse``    ``SparseKKT``: a sparse LDLᵀ with 2 x 2 pivots on paired rows,
               its analysis and the inertia
``_envelope``  ``EnvelopeKKT`` (the solver's default): the same LDLᵀ, order
               and pivots with L stored by its envelope, values only
``_ordering``  the elimination order of both (the pairs, the band)
``_analyses``  their symbolic analyses, kept for the next solve
``_periodic``  index arrays held as periodic runs (the collocation's patterns
               without their index arrays), which the kernel walks
``_diagonal``  ``DiagonalEntries``: a diagonal zero but at some entries (the
               barrier's, nonzero where a variable is bounded)
``_kernel``    their compiled C kernel
``_low_rank``  ``LowRankKKT``: a limited-memory Hessian's low-rank part on
               any of them (Sherman–Morrison–Woodbury, Haynsworth's inertia)

All take the calls that ``interior_point``'s docstring lists; the public
classes are exported there.
"""

__all__ = []
