"""Flexible members: finite elements, component mode synthesis, the reduced member.

``_reduced``  ``ReducedMember``: what a flexible body needs of its FE model
"""

from ._reduced import ReducedMember

__all__ = ["ReducedMember"]
