"""The engine: straight-line programs and the kinematics written into them.

What the layers above use of it.  Nothing here knows about formulations,
numerics or simulation; see ``docs/architecture.md``.

``_program``     straight-line programs: named intermediates, forward time
                 derivatives, random-point identity tests, listings for codegen
``_cse``         the listings' common subexpressions: repeated subtrees named once
``_symbols``     the table between a model's SymPy symbols and internal ones
``_kinematics``  frames and points as intermediates: rotations, angular
                 velocities, velocities, partial velocities, inertias
``_composite``   composite-body sums for the mass matrix and forcing of trees
``_tree_derivatives``  derivatives of a tree's inertia forces in spatial terms,
                 and their entries formed from per-speed vectors
"""

from ._composite import composite_equations, composite_inertia_forces
from ._kinematics import (Kinematics, PartialVelocities, add, cross, dot, dyadic_matrix,
                          inertia_components, is_small, matvec)
from ._program import (SAMPLE_SEEDS, Program, difference, fast_eval, free_symbols_of,
                       kd_dpow, random_sampler, total_derivative)
from ._symbols import SymbolTable, name_of, time_derivative
from ._tree_derivatives import FACTOR_PARTS, tree_inertia_derivatives, tree_jacobian_values

__all__ = ["Program", "SAMPLE_SEEDS", "fast_eval", "random_sampler", "total_derivative", "kd_dpow",
           "SymbolTable", "name_of", "Kinematics", "PartialVelocities", "add", "cross", "dot",
           "matvec", "dyadic_matrix", "inertia_components", "is_small", "composite_equations",
           "composite_inertia_forces", "tree_inertia_derivatives", "tree_jacobian_values",
           "FACTOR_PARTS", "time_derivative", "free_symbols_of", "difference"]
