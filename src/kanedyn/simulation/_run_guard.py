"""What may end a run early, and how it ends without losing what was computed.

A run on SciPy's ``solve_ivp`` ends early when

* the right-hand side is not finite (a singular mass matrix, a ``nan``
  constant or input): the integrand records the state and returns ``nan``;
* a specified input's function raises (named by a ``ModelError``), or an event
  function raises: the guard records the state and the cause;
* Ctrl-C is pressed: while a run is under way a first SIGINT only raises a
  flag (a second one interrupts at once, as usual);
* the run's time limit (``simulate(..., timeout=...)``) has passed, checked at
  every step.

In each case the solver, wrapped by :func:`guarded_method`, reports a failed
step at its next step, so ``solve_ivp`` returns normally with everything it
had accepted up to then, instead of looping on ``nan`` step sizes or
discarding its work in an exception.
"""

from __future__ import annotations

import signal
import threading
import time
from contextlib import contextmanager

import numpy as np

from ..numerics import diagnose
from .._errors import INTERRUPTED, ModelError, OptionError

__all__ = ["RunGuard", "Integrand", "guarded_event", "guarded_method", "solver_class",
           "scipy_methods", "time_limit_message", "INTERRUPTED"]


def time_limit_message(timeout, t):
    """The message of a run stopped by its time limit (``timeout`` s) at ``t``."""
    where = f" at t={t:.6g} s" if np.isfinite(t) else ""
    return f"the time limit of {timeout:g} s of computing (timeout=) was reached{where}"


class RunGuard:
    """Reasons to stop a run: the first non-finite evaluation, Ctrl-C, or the
    time limit (``timeout`` s from the guard's making).

    Attributes
    ----------
    failure_state : (float, ndarray) or None
        Time and state of the first non-finite derivative.
    interrupted : bool
    on_step : callable or None
        Called after every accepted step with ``(t_old, y_old, f_old, t, y, f)``
        (``f``: the derivative there, ``None`` where the solver keeps none).
    """

    def __init__(self, model, timeout=None):
        self.model = model
        self.failure_state = None
        self.failure_text = None
        self.interrupted = False
        self.last_step = None  # (t, y) the solver accepted last
        self.on_step = None
        self.timeout = timeout
        self.deadline = None if timeout is None else time.monotonic() + timeout

    def fail(self, t, y, text=None):
        """Record the first failure at ``(t, y)`` (``text`` overrides the diagnosis)."""
        if self.failure_state is None:
            self.failure_state = (float(t), None if y is None else np.array(y, dtype=float))
            self.failure_text = text

    @property
    def failed(self):
        return self.failure_state is not None

    @property
    def stop_reason(self):
        """``"interrupted"``, the failure's message (a time limit that has passed
        is one), or ``None``."""
        if self.interrupted:
            return INTERRUPTED
        if not self.failed and self.deadline is not None \
                and time.monotonic() >= self.deadline:
            t, y = self.last_step or (np.nan, None)
            self.fail(t, y, time_limit_message(self.timeout, t))
        return self.failure_message() if self.failed else None

    def failure_message(self):
        """What went wrong, in the model's names (computed once, on demand)."""
        if self.failure_state is None:
            return None
        if self.failure_text is None:
            t, y = self.failure_state
            cause = diagnose(self.model, t, y)
            self.failure_text = (cause or "the state derivative is not finite at "
                                 f"t={t:.6g}")
        return self.failure_text

    @contextmanager
    def catching_interrupts(self):
        """Turn a first Ctrl-C into :attr:`interrupted` for the duration.

        Only in the main thread, and only when SIGINT has Python's default
        handler (a handler the user installed is left alone).
        """
        install = (threading.current_thread() is threading.main_thread()
                   and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
        if not install:
            yield self
            return

        def on_sigint(signum, frame):
            if self.interrupted:  # a second Ctrl-C: stop at once
                raise KeyboardInterrupt
            self.interrupted = True

        signal.signal(signal.SIGINT, on_sigint)
        try:
            yield self
        finally:
            signal.signal(signal.SIGINT, signal.default_int_handler)


class Integrand:
    """``rhs`` for ``solve_ivp``: counts, progress, non-finite results recorded."""

    def __init__(self, model, t_span, progress, guard):
        self.model = model
        self.guard = guard
        self.progress = progress
        self.t0, self.t1 = t_span
        self.n = model.n_states

    def __call__(self, t, y):
        try:
            out = self.model.rhs(t, y)
        except np.linalg.LinAlgError:
            self.guard.fail(t, y)
            return np.full(self.n, np.nan)
        except ModelError as exc:  # e.g. an input's function raised: its message
            self.guard.fail(t, y, str(exc))
            return np.full(self.n, np.nan)
        if not np.all(np.isfinite(out)):
            self.guard.fail(t, y)
        if self.progress.enabled and self.t1 != self.t0:
            self.progress.update("simulating", (t - self.t0) / (self.t1 - self.t0))
        return out


def guarded_event(event, k, guard=None):
    """``event`` as the integrators call it (``terminal`` and ``direction`` kept),
    naming it (the ``k``-th of the run's events) when it raises: with a ``guard``
    (``solve_ivp``), the guard records the state and the cause and the run ends at
    the next step; without (the compiled loop), a :class:`ModelError` with that
    cause ends the loop, which keeps what it has."""
    name = getattr(event, "__name__", None) or f"events[{k}]"

    def value(t, y):
        try:
            return event(t, y)
        except Exception as exc:
            cause = f"event {name} raised {type(exc).__name__} at t={t:g}: {exc}"
            if guard is None:
                raise ModelError(cause) from exc
            guard.fail(t, y, cause)
            return np.nan

    value.terminal = getattr(event, "terminal", False)
    value.direction = getattr(event, "direction", 0)
    return value


def scipy_methods():
    """``solve_ivp``'s methods, ``{name: OdeSolver class}`` (SciPy imported here,
    on first use)."""
    from scipy.integrate._ivp.ivp import METHODS
    return METHODS


def solver_class(method):
    """The ``OdeSolver`` class for a ``solve_ivp`` method name or class."""
    from scipy.integrate import OdeSolver
    methods = scipy_methods()
    if isinstance(method, str):
        try:
            return methods[method]
        except KeyError:
            raise OptionError(f"unknown method {method!r}; solve_ivp's methods are "
                              f"{', '.join(methods)} (and the compiled loop adds "
                              "'Rosenbrock23')") from None
    if isinstance(method, type) and issubclass(method, OdeSolver):
        return method
    raise OptionError(f"method must be a solve_ivp method name or an OdeSolver class, "
                      f"not {method!r}")


def guarded_method(method, guard):
    """An ``OdeSolver`` subclass of ``method`` that stops when ``guard`` says so.

    A step reports failure (message: the guard's reason) when the run was
    interrupted before it, or when a derivative evaluated during it was not
    finite; an implicit method's ``ValueError`` or ``LinAlgError`` on a
    non-finite Jacobian becomes the same failure.
    """
    base = solver_class(method)

    class Guarded(base):
        def _step_impl(self):
            if guard.stop_reason is not None:
                return False, guard.stop_reason
            before = (self.t, self.y.copy(), getattr(self, "f", None)) \
                if guard.on_step is not None else None
            try:
                success, message = super()._step_impl()
            except (ValueError, np.linalg.LinAlgError):
                if guard.failed:
                    return False, guard.stop_reason
                raise
            if guard.failed:
                return False, guard.stop_reason
            if success:
                guard.last_step = (self.t, self.y.copy())
                if guard.on_step is not None:
                    guard.on_step(*before, self.t, self.y, getattr(self, "f", None))
            return success, message

    Guarded.__name__ = Guarded.__qualname__ = base.__name__
    return Guarded
