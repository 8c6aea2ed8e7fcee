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

from ..._lazy import lazy_attributes as _lazy_attributes

#: public name -> the module (in this package) that defines it; imported on first use
#: (a model of rigid bodies is checked for flexible bodies: ``FlexibleBody`` alone,
#: without the finite elements and NumPy's polynomials they import)
_LAZY = {
    "ReducedMember": "._reduced",
    "BeamMember": "._member",
    "FEMember": "._member",
    "NodeMass": "._member",
    "BeamElement": "._beam",
    "beam_element_matrices": "._beam",
    "craig_bampton": "._reduction",
    "guyan": "._reduction",
    "free_free": "._reduction",
    "REDUCTIONS": "._reduction",
    "FlexibleBody": "._body",
    "InertiaInvariants": "._body",
}

__all__ = list(_LAZY)

__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__)
