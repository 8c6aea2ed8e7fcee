"""What may end a run early, and how it ends without losing what was computed.

A run on SciPy's ``solve_ivp`` ends early when

* the right-hand side is not finite (a singular mass matrix, a ``nan``
  constant or input): the integrand records the state and returns ``nan``;
* a specified input's function raises (named by a ``ModelError``), or an event
  function raises: the guard records the state and the cause;
* Ctrl-C is pressed or SIGTERM arrives (:mod:`kanedyn._signals`): while a run
  is under way a first stop signal only raises a flag, and the run ends at the
  end of its step; a second makes every further evaluation of the equations
  return ``nan``, so that the run ends as soon as the evaluation under way
  returns; a third raises ``KeyboardInterrupt`` at once (what is under way is
  lost: the way out of an evaluation that never returns).  The compiled loops
  read the flag (:attr:`RunGuard.stop_flag`) where they check for signals,
  between their steps;
* the run's time limit (``simulate(..., timeout=...)``) has passed, checked at
  every step (the compiled loops every 16 steps, next to the stop flag, given
  :meth:`RunGuard.seconds_left`).

In these cases the solver, wrapped by :func:`guarded_method`, reports a failed
step at its next step, so ``solve_ivp`` returns normally with everything it
had accepted up to then, instead of looping on ``nan`` step sizes or
discarding its work in an exception.
"""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager

import numpy as np

from ..numerics import diagnose
from .._errors import INTERRUPTED, ModelError, OptionError
from .._signals import Stopped, holding

__all__ = ["RunGuard", "Integrand", "guarded_event", "guarded_method", "solver_class",
           "scipy_methods", "time_limit_message", "INTERRUPTED"]


def time_limit_message(timeout, t):
    """The message of a run stopped by its time limit (``timeout`` s) at ``t``."""
    where = f" at t={t:.6g} s" if np.isfinite(t) else ""
    return f"the time limit of {timeout:g} s of computing (timeout=) was reached{where}"


class RunGuard:
    """Reasons to stop a run: the first non-finite evaluation, a stop signal, or
    the time limit (``timeout`` s from the guard's making).

    Attributes
    ----------
    failure_state : (float, ndarray) or None
        Time and state of the first non-finite derivative.
    signum : int or None
        The first stop signal received during the run (SIGINT, SIGTERM).
    stops : int
        Stop signals received.
    stop_flag : ndarray of int32, shape (1,)
        1 once a stop signal came: what compiled loops read between their steps.
    deadline : float or None
        ``time.monotonic()`` at which the time limit passes.
    on_step : callable or None
        Called after every accepted step with ``(t_old, y_old, f_old, t, y, f)``
        (``f``: the derivative there, ``None`` where the solver keeps none).
    """

    def __init__(self, model, timeout=None):
        self.model = model
        self.failure_state = None
        self.failure_text = None
        self.signum = None
        self.stops = 0
        self.stop_flag = np.zeros(1, dtype=np.int32)
        self.skipped = False  # an evaluation returned nan unevaluated (hurried)
        self.last_step = None  # (t, y) the solver accepted last
        self.on_step = None
        self.timeout = timeout
        self.deadline = None if timeout is None else time.monotonic() + timeout

    def seconds_left(self):
        """Seconds before the time limit, for a compiled loop (0.0: no limit; one
        that has passed, the least time, 1e-9 s)."""
        if self.deadline is None:
            return 0.0
        return max(self.deadline - time.monotonic(), 1e-9)

    @property
    def interrupted(self):
        """A stop signal came: end the run at the end of the step."""
        return self.signum is not None

    @property
    def hurried(self):
        """A second one came: end it as soon as the evaluation under way returns."""
        return self.stops >= 2

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

    def _on_signal(self, signum):
        self.stops += 1
        if self.signum is None:
            self.signum = signum
            self.stop_flag[0] = 1
        if self.stops >= 3:
            raise Stopped(signum)

    @contextmanager
    def catching_interrupts(self):
        """Turn stop signals into :attr:`interrupted` for the duration (see the
        module's text; :mod:`kanedyn._signals` says which signals, when)."""
        with holding(self._on_signal):
            yield self


class Integrand:
    """``rhs`` for ``solve_ivp``: counts, progress, non-finite results recorded."""

    def __init__(self, model, t_span, progress, guard):
        self.model = model
        self.guard = guard
        self.progress = progress
        self.t0, self.t1 = t_span
        self.n = model.n_states
        # inputs that a compiled model evaluates itself: numbers and piecewise
        # polynomials (whose module is loaded if there are any); see columns()
        piecewise = sys.modules.get("kanedyn.modeling._piecewise")
        kind = getattr(piecewise, "PiecewisePolynomial", ())
        self._inputs_in_c = all(inp.arity == 0 or isinstance(inp.value, kind)
                                for _, inp in getattr(model, "_inputs", ()))

    def __call__(self, t, y):
        if self.guard.hurried:  # a second stop signal: no more evaluations
            self.guard.skipped = True
            return np.full(self.n, np.nan)
        try:
            out = self.model.rhs(t, y)
        except np.linalg.LinAlgError:
            self.guard.fail(t, y)
            return np.full(self.n, np.nan)
        except ModelError as exc:  # e.g. an input's function raised: its message
            self.guard.fail(t, y, str(exc))
            return np.full(self.n, np.nan)
        if not np.isfinite(out).all():  # the method: np.all's dispatch is most of its cost
            self.guard.fail(t, y)
        if self.progress.enabled and self.t1 != self.t0:
            self.progress.update("simulating", (t - self.t0) / (self.t1 - self.t0))
        return out

    def columns(self, t, Y, looped):
        """The derivatives at the states ``Y[:, j]`` (the columns of a difference
        Jacobian, all at ``t``), ``(n, k)``.

        A compiled model whose inputs it evaluates itself (none, numbers,
        piecewise polynomials) takes them in one call of its ``rhs_batch``, row
        by row with the code of ``rhs`` (one thread, no lanes: the same numbers
        to the bit), instead of ``k`` calls from Python (a 28-state Radau run
        spent 44 % of its evaluations there).  Everything else, and a batch
        with a column that is not finite or raises, goes to ``looped(t, Y)``:
        one call of this integrand per column, as ``solve_ivp`` makes them (the
        failure then recorded as it would have been).
        """
        c = getattr(self.model, "_c", None)
        if (self.guard.hurried or c is None or not self._inputs_in_c
                or getattr(self.model.rhs, "__self__", None) is not c):
            return looped(t, Y)
        try:
            out = c.rhs_batch(t, Y.T, None, 1, False)
        except Exception:  # noqa: BLE001 (an error of a column: the loop records it)
            return looped(t, Y)
        if not np.isfinite(out).all():
            return looped(t, Y)
        if self.progress.enabled and self.t1 != self.t0:
            self.progress.update("simulating", (t - self.t0) / (self.t1 - self.t0))
        return out.T


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
    finite or not evaluated (a second stop signal); an implicit method's
    ``ValueError`` or ``LinAlgError`` on a non-finite Jacobian becomes the same
    failure.
    """
    base = solver_class(method)

    class Guarded(base):
        def __init__(self, fun, *args, **kwargs):
            super().__init__(fun, *args, **kwargs)
            if getattr(self, "solve_lu", None) is not None \
                    and isinstance(getattr(self, "J", None), np.ndarray):  # dense: Radau, BDF
                self.lu, self.solve_lu = _direct_lu(self)
            columns = getattr(fun, "columns", None)
            if columns is not None and not self.vectorized:  # difference Jacobians' columns
                looped = self.fun_vectorized
                self.fun_vectorized = lambda t, Y: columns(t, Y, looped)

        def _step_impl(self):
            if guard.stop_reason is not None:
                return False, guard.stop_reason
            before = (self.t, self.y.copy(), getattr(self, "f", None)) \
                if guard.on_step is not None else None
            try:
                success, message = super()._step_impl()
            except (ValueError, np.linalg.LinAlgError):
                if guard.failed or guard.skipped:
                    return False, guard.stop_reason
                raise
            if guard.failed or guard.skipped:
                return False, guard.stop_reason
            if success:
                guard.last_step = (self.t, self.y.copy())
                if guard.on_step is not None:
                    guard.on_step(*before, self.t, self.y, getattr(self, "f", None))
            return success, message

    Guarded.__name__ = Guarded.__qualname__ = base.__name__
    return Guarded


def _direct_lu(solver):
    """``(lu, solve_lu)`` for a dense implicit method (Radau, BDF): SciPy's
    ``lu_factor(A, overwrite_a=True)`` and ``lu_solve(LU, b, overwrite_b=True)``
    as LAPACK's ``getrf`` and ``getrs`` called directly, the same calls with
    the same arguments (the same results to the bit) and the same checks
    (non-finite input: ``ValueError``; an exactly singular matrix: the
    warning), without the wrappers' per-call overhead (SciPy 1.17's batching:
    a quarter of a 28-state Radau run's time)."""
    import warnings

    from scipy.linalg import LinAlgWarning, get_lapack_funcs
    routines = {}

    def lapack(name, array):
        key = (name, array.dtype.char)
        found = routines.get(key)
        if found is None:
            found = routines[key] = get_lapack_funcs((name,), (array,))[0]
        return found

    def finite(a):
        a = np.asarray(a)
        if a.dtype.char in np.typecodes["AllFloat"] and not np.isfinite(a).all():
            raise ValueError("array must not contain infs or NaNs")
        return a

    def lu(A):
        solver.nlu += 1
        A = finite(A)
        if A.size == 0 or A.ndim != 2:
            from scipy.linalg import lu_factor
            return lu_factor(A, overwrite_a=True)
        factors, piv, info = lapack("getrf", A)(A, overwrite_a=True)
        if info < 0:
            raise ValueError(f"illegal value in {-info}th argument of internal getrf "
                             f"(lu_factor)")
        if info > 0:
            warnings.warn(f"Diagonal number {info} is exactly zero. Singular matrix.",
                          LinAlgWarning, stacklevel=2)
        return factors, piv

    def solve_lu(LU, b):
        factors, piv = LU
        b = finite(b)
        if b.size == 0 or b.ndim != 1 or factors.shape[0] != b.shape[0]:
            from scipy.linalg import lu_solve
            return lu_solve(LU, b, overwrite_b=True)
        x, info = lapack("getrs", np.empty(0, np.result_type(factors, b)))(
            factors, piv, b, trans=0, overwrite_b=True)
        if info:
            raise ValueError(f"illegal value in {-info}th argument of internal gesv|posv")
        return x
    return lu, solve_lu
