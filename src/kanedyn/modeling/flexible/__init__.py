"""Flexible members: finite elements, component mode synthesis, flexible bodies.

``_reduced``    ``ReducedMember``: what a flexible body needs of its FE model
``_beam``       3D beam elements (Euler–Bernoulli or Timoshenko): stiffness,
                consistent mass, geometric stiffness per unit axial force
``_stations``   station tables of section properties, interpolated along a member
``_matrices``   checks of mass and stiffness matrices from elsewhere, Matrix Market
``_member``     ``FEMember`` (from matrices), ``BeamMember`` (from stations),
                ``NodeMass``; assembly and natural modes of the full model
``_eigen``      lowest modes by SciPy's eigensolvers; rigid-body motion removed exactly
``_reduction``  component mode synthesis: Craig–Bampton, Guyan, free–free;
                mode names and scaling; second-order foreshortening G
``_body``       ``FlexibleBody``: floating frame plus modal coordinates, and its
                inertia invariants
"""

from ._beam import BeamElement, beam_element_matrices
from ._body import FlexibleBody, InertiaInvariants
from ._member import BeamMember, FEMember, NodeMass
from ._reduced import ReducedMember
from ._reduction import REDUCTIONS, craig_bampton, free_free, guyan

__all__ = ["ReducedMember", "BeamMember", "FEMember", "NodeMass", "BeamElement",
           "beam_element_matrices", "craig_bampton", "guyan", "free_free", "REDUCTIONS",
           "FlexibleBody", "InertiaInvariants"]
