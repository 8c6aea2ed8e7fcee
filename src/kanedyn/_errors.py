"""Exceptions raised by kanedyn.

Every error names the symbol, body, point or file at fault, so that a user can
find the offending line of their model without a debugger.
"""

__all__ = [
    "KanedynError",
    "ModelError",
    "KinematicsError",
    "ConstraintError",
    "MissingValueError",
]


class KanedynError(Exception):
    """Base class of all errors raised by kanedyn."""


class ModelError(KanedynError, ValueError):
    """The model description is inconsistent (coordinates, speeds, equations)."""


class KinematicsError(KanedynError, ValueError):
    """A velocity, angular velocity or orientation cannot be determined."""


class ConstraintError(KanedynError, ValueError):
    """Constraints cannot be satisfied or their Jacobian is singular."""


class MissingValueError(KanedynError, KeyError):
    """A numerical value (constant, specified input, initial value) is missing."""

    def __str__(self):  # KeyError quotes its message; keep it readable
        return str(self.args[0]) if self.args else ""
