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
    "OptionError",
    "SimulationInterrupted",
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


class OptionError(KanedynError, ValueError):
    """An argument or option has a value that cannot be honoured (names the option)."""


class SimulationInterrupted(KeyboardInterrupt):
    """Ctrl-C during a simulation; carries what was computed up to then.

    Attributes
    ----------
    result : SimulationResult
        The partial result (``success=False``, ``message="interrupted"``).

    Examples
    --------
    >>> try:                                   # doctest: +SKIP
    ...     res = kd.simulate(model, (0, 1000), y0)
    ... except kd.SimulationInterrupted as stop:
    ...     res = stop.result                  # everything up to the interruption
    """

    def __init__(self, result):
        super().__init__("interrupted")
        self.result = result
