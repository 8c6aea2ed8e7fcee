"""Formulations: Kane's method and its siblings, one signature, one frozen result.

``_registry``               ``formulate(model, method=...)``, ``kane``, the registry
``_eom``                    ``EquationsOfMotion``, the frozen result of every sibling
``_kane``                   Kane's method (the reference)
``_lagrange``               Lagrange's equations with multipliers; the augmented
                            (vakonomic) Lagrangean
``_orthogonal_complement``  the natural orthogonal complement (per-body blocks)
``_latex``                  the equations as LaTeX

A formulation names its constraint scheme; the scheme itself is numerics
(:mod:`kanedyn.numerics.schemes`).
"""

from ._eom import EquationsOfMotion
from ._registry import FORMULATIONS, formulate, kane, register_formulation

__all__ = ["EquationsOfMotion", "FORMULATIONS", "formulate", "kane", "register_formulation"]
