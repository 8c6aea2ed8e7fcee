"""Flexible members: finite elements, component mode synthesis, the reduced member.

``_reduced``  ``ReducedMember``: what a flexible body needs of its FE model
``_body``     ``FlexibleBody``: floating frame plus modal coordinates, and its
              inertia invariants
"""

from ._body import FlexibleBody, InertiaInvariants
from ._reduced import ReducedMember

__all__ = ["ReducedMember", "FlexibleBody", "InertiaInvariants"]
