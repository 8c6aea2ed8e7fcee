"""Exceptions raised by kanedyn.

Every error names the symbol, body, point or file at fault, so that a user can
find the offending line of their model without a debugger.
"""

import os
import signal

__all__ = [
    "KanedynError",
    "ModelError",
    "KinematicsError",
    "ConstraintError",
    "MissingValueError",
    "OptionError",
    "OutputFileError",
    "SimulationInterrupted",
    "SingularConfigurationWarning",
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


class OutputFileError(KanedynError, OSError):
    """A file could not be written (a full disk, no permission, no such folder).

    An ``OSError`` (``errno``, ``strerror``; ``filename`` is the file that was to
    be written, not a temporary name); the message names both: ``cannot write
    out/run.csv: No space left on device``.  Nothing of the file is left behind,
    and an earlier file of that name is as it was.
    """

    def __init__(self, path, cause):
        super().__init__(getattr(cause, "errno", None), getattr(cause, "strerror", None)
                         or str(cause), os.fspath(path))

    def __str__(self):
        return f"cannot write {self.filename}: {self.strerror}"


#: the message of a run ended by Ctrl-C
INTERRUPTED = "interrupted"


class SimulationInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM) during a simulation; carries what was computed up to then.

    Attributes
    ----------
    result : SimulationResult
        The partial result (``success=False``, ``message="interrupted"``), or
        the complete one when the signal came after the last step.
    signum : int
        The signal (``signal.SIGINT`` for Ctrl-C, ``signal.SIGTERM``).

    Examples
    --------
    >>> try:                                   # doctest: +SKIP
    ...     res = kd.simulate(model, (0, 1000), y0)
    ... except kd.SimulationInterrupted as stop:
    ...     res = stop.result                  # everything up to the interruption
    """

    def __init__(self, result, signum=None):
        super().__init__(INTERRUPTED)
        self.result = result
        self.signum = signal.SIGINT if signum is None else signum


class SingularConfigurationWarning(RuntimeWarning):
    """A simulation passed near a configuration where the constraint Jacobian loses rank.

    Attributes
    ----------
    times : tuple of float
        Times of closest approach, s.
    ratios : tuple of float
        Smallest over largest singular value of the constraint Jacobian there.
    """

    def __init__(self, message, times=(), ratios=()):
        super().__init__(message)
        self.times = tuple(float(t) for t in times)
        self.ratios = tuple(float(r) for r in ratios)
