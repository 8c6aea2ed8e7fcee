r"""``OptimalControlProblem``: what to optimize, checked when it is stated.

.. math::

    \min_{y(t),\, r(t),\, p,\, T}\quad \Phi(y(t_f), r(t_f), p, t_f)
        + \int_{t_0}^{t_f} L(t, y, r, p)\, dt
    \quad\text{s.t.}\quad \dot y = f(t, y, r, p),\;
    g_{lo} \le g(t, y, r, p) \le g_{hi},\; \text{bounds},\; \text{instances}

with :math:`t_f = t_0 + T`.  The model's right-hand side :math:`f` and its
exact derivatives are the numerical model's (``model.jacobians``); the
objective and constraints are SymPy expressions in the model's symbols
(:mod:`._terms`).
"""

from __future__ import annotations

import numbers

import numpy as np

from .._errors import ModelError
from ._terms import Symbols, compile_term, instance_atoms
from ._transcription import COLLOCATION_METHODS, Layout

__all__ = ["OptimalControlProblem"]


class _Path:
    """A path constraint ``lower <= g <= upper`` at every node."""

    def __init__(self, term, lower, upper, text):
        self.term, self.lower, self.upper, self.text = term, lower, upper, text


class _Instance:
    """One instance constraint: ``value(args) = 0`` with ``args`` the named
    values (``at``: ``(kind, index, node)`` each), the free parameters, T;
    ``hessian(args)`` its second derivatives in them, or ``None`` (linear)."""

    def __init__(self, at, value, gradient, text, hessian=None):
        self.at, self.value, self.gradient, self.text = at, value, gradient, text
        self.hessian = hessian
        self.lower = self.upper = 0.0


def _bound_pair(value, what):
    try:
        lower, upper = value
    except (TypeError, ValueError):
        raise ModelError(f"bounds of {what} must be a pair (lower, upper), got "
                         f"{value!r}") from None
    pair = []
    for v, side, inf in ((lower, "lower", -np.inf), (upper, "upper", np.inf)):
        if v is None:
            pair.append(inf)
            continue
        if isinstance(v, (str, bytes)) or not isinstance(v, (numbers.Real, np.number)):
            raise ModelError(f"{side} bound of {what} must be a number or None, got {v!r}")
        if np.isnan(v):
            raise ModelError(f"{side} bound of {what} is nan")
        pair.append(float(v))
    if pair[0] > pair[1]:
        raise ModelError(f"bounds of {what}: the lower bound {pair[0]:g} is above the upper "
                         f"bound {pair[1]:g}")
    return pair


def _name(key):
    """The model's name of a symbol, a dynamic symbol or a name."""
    if isinstance(key, str):
        return key.removesuffix("(t)")
    from sympy.core.function import AppliedUndef
    if isinstance(key, AppliedUndef):
        return str(key.func)
    return str(key)


class OptimalControlProblem:
    r"""An optimal control problem on a numerical model, solved by direct collocation.

    Parameters
    ----------
    model : NumericModel or EquationsOfMotion
        The dynamics :math:`\dot y = f(t, y, r, p)`.  The specified inputs of
        a numerical model (``model.input_names``) are the controls; the values
        it was built with are not used.  Equations of motion are made numerical
        here with ``constants`` and ``backend`` (their inputs become controls).
    nodes : int
        Number of collocation nodes N (at least 2), equally spaced.
    duration : float or sympy.Symbol
        :math:`T = t_f - t_0`, s; a symbol makes it free (give its bounds in
        ``bounds``).
    lagrange : sympy expression, optional
        Integrand :math:`L(t, y, r, p)` of the objective.
    mayer : sympy expression, optional
        Terminal cost :math:`\Phi` in the states and inputs (written as
        ``q(t)``, taken at :math:`t_f`), the free parameters and the duration
        symbol.  At least one of ``lagrange`` and ``mayer``.
    bounds : dict, optional
        ``{symbol or name: (lower, upper)}`` for states and inputs (at every
        node), free parameters and the duration symbol; ``None`` for no bound
        on a side.
    initial, final : dict, optional
        ``{state: value}`` at :math:`t_0` and :math:`t_f` (independent states
        only for a model with constraints).
    instance_constraints : sequence of sympy expressions, optional
        Expressions equal to zero at the solution, in states and inputs at
        node times (``q(0) - q(T)``; with a free duration the times must be
        fractions of its symbol, ``q(T/2)``).
    periodic : sequence of states, optional
        States equal at :math:`t_0` and :math:`t_f`.
    path_constraints : sequence of (expression, lower, upper), optional
        :math:`g(t, y, r, p)` kept within bounds at every node.
    parameters : sequence of constants, optional
        Constants of the model that are optimized too (their model values are
        the initial guess).
    auxiliary : dict, optional
        ``{sympy.Symbol: starting value}``: free scalars the model does not
        contain, which only the objective and the constraints name; bounds in
        ``bounds``.  The bound :math:`s` of an epigraph is one: minimizing
        ``mayer=s`` with the path constraints :math:`-s \le F_i(t) \le s`
        minimizes the peak of :math:`|F_i|`.  Their values are in the
        result's ``parameters``.
    method : {"trapezoid", "backward-euler", "midpoint", "hermite-simpson", "lgr"}
        The collocation (see :mod:`kanedyn.optimization._transcription`).
        ``"hermite-simpson"`` (order 4) adds the states and inputs at the
        midpoint of every interval as variables, ``"lgr"``
        (Legendre-Gauss-Radau, order 2 degree - 1) those at the degree - 1
        interior Radau points (:mod:`kanedyn.optimization._interval`);
        bounds and path constraints (and a model's constraints) hold there
        too.
    degree : int, optional
        Only with ``method="lgr"``: the Radau points per interval (at least
        1; default 3).
    start_time : float, optional
        :math:`t_0`, s (default 0).  In a :class:`MultiphaseProblem` a phase
        after the first starts where the one before ends: leave it out
        there, or give that time.
    constants : dict, optional
        Only with equations of motion: the constants' values.
    backend : str
        Only with equations of motion: ``"numpy"`` or ``"c"``.

    Raises
    ------
    ModelError
        For every inconsistency, naming the symbol, bound or option at fault.

    Notes
    -----
    A model with dependent coordinates or speeds (closed loops, nonholonomic
    constraints): only the independent states are collocated; the
    configuration and velocity constraints are imposed at every node, so the
    dependent states follow them exactly at the nodes, and the right-hand
    side eliminates the dependent speeds numerically as in a simulation.

    Examples
    --------
    >>> import sympy as sm, sympy.physics.mechanics as me
    >>> import kanedyn as kd
    >>> x, v, F = me.dynamicsymbols("x v F")
    >>> N = me.ReferenceFrame("N"); O = me.Point("O"); O.set_vel(N, 0)
    >>> P = O.locatenew("P", x * N.x); P.set_vel(N, v * N.x)
    >>> eom = kd.kane(frame=N, q_ind=[x], u_ind=[v], kd_eqs=[x.diff() - v],
    ...               bodies=[me.Particle("P", P, 1)], loads=[(P, F * N.x)])
    >>> ocp = kd.OptimalControlProblem(eom.numeric(specified={F: 0.0}), nodes=41,
    ...     duration=1.0, lagrange=F**2, initial={x: 0, v: 0}, final={x: 1, v: 0})
    >>> res = ocp.solve(ocp.guess_line(inputs={F: 0.0}))   # doctest: +SKIP
    """

    def __init__(self, model, *, nodes, duration, lagrange=None, mayer=None, bounds=None,
                 initial=None, final=None, instance_constraints=(), periodic=(),
                 path_constraints=(), parameters=(), auxiliary=None, method="trapezoid",
                 degree=None, start_time=None, constants=None, backend="numpy"):
        model = self._numeric(model, constants, backend)
        reason = _derivatives_unavailable(model)
        if reason:
            raise ModelError(f"optimal control needs the model's exact derivatives: {reason}")
        self.model = model
        if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or nodes < 2:
            raise ModelError(f"nodes must be an integer of at least 2, got {nodes!r}")
        self.nodes = int(nodes)
        if method not in COLLOCATION_METHODS:
            raise ModelError(f"unknown collocation method {method!r}; available: "
                             f"{', '.join(COLLOCATION_METHODS)}")
        self.method = method
        self.degree = _degree(degree, method)
        #: whether start_time was given (a later phase of a MultiphaseProblem
        #: starts where the one before ends)
        self.start_time_given = start_time is not None
        if start_time is None:
            start_time = 0.0
        if isinstance(start_time, bool) or not isinstance(start_time, numbers.Real) \
                or not np.isfinite(start_time):
            raise ModelError(f"start_time must be a finite number, got {start_time!r}")
        self.start_time = float(start_time)
        self._duration(duration)
        import sympy.physics.mechanics as me
        names = tuple(str(c) for c in model.constants)
        free = tuple(self._free_parameter(p, names) for p in parameters)
        if len(set(free)) != len(free):
            raise ModelError(f"parameters lists a constant twice: {', '.join(free)}")
        self.free_columns = [names.index(p) for p in free]
        self.auxiliary = self._auxiliary(auxiliary or {}, names)
        self.symbols = Symbols(
            t=me.dynamicsymbols._t, states=tuple(model.state_names),
            inputs=tuple(n.removesuffix("(t)") for n in model.input_names),
            constants=dict(model.constants), free=free + tuple(self.auxiliary),
            duration=self.duration if self.free_duration else None)
        self._constraint_layout()
        self._bounds(bounds or {})
        self.initial = self._end_values(initial or {}, "initial")
        self.final = self._end_values(final or {}, "final")
        if lagrange is None and mayer is None:
            raise ModelError("give an objective: lagrange= (an integrand) and/or mayer= "
                             "(a terminal cost)")
        self.lagrange = compile_term(lagrange, self.symbols, "the objective's integrand "
                                     "(lagrange)")
        self.mayer = compile_term(mayer, self.symbols, "the terminal cost (mayer)")
        self.path = [self._path(entry, k) for k, entry in enumerate(path_constraints)]
        self.instances = [self._instance(e, k) for k, e in enumerate(instance_constraints)]
        self.instances += [self._periodic(s) for s in periodic]

    # ------------------------------------------------------------ checks
    @staticmethod
    def _numeric(model, constants, backend):
        if hasattr(model, "jacobians") and hasattr(model, "state_names"):
            if constants is not None:
                raise ModelError("constants= is for equations of motion; a numerical "
                                 "model has its constants (model.with_constants(...))")
            return model
        if hasattr(model, "numeric") and hasattr(model, "specified"):
            if constants is None:
                raise ModelError("equations of motion need constants={symbol: value} to "
                                 "become a numerical model")
            specified = {s: 0.0 for s in model.specified
                         if not hasattr(s, "variables")}  # values unused: the controls
            return model.numeric(constants=constants, specified=specified, backend=backend)
        raise ModelError(f"model must be a NumericModel or EquationsOfMotion, got "
                         f"{type(model).__name__}")

    def _duration(self, duration):
        import sympy as sm
        if isinstance(duration, sm.Symbol):
            self.duration, self.free_duration, self.duration_value = duration, True, None
            return
        if isinstance(duration, bool) or not isinstance(duration, numbers.Real) \
                or not np.isfinite(duration) or duration <= 0:
            raise ModelError(f"duration must be a positive number (s) or a SymPy symbol "
                             f"(free duration), got {duration!r}")
        self.duration, self.free_duration = float(duration), False
        self.duration_value = float(duration)

    @staticmethod
    def _free_parameter(p, names):
        name = _name(p)
        if name not in names:
            raise ModelError(f"parameters: {p} is not a constant of the model (its "
                             f"constants: {', '.join(names)})")
        return name

    def _auxiliary(self, auxiliary, constants):
        """``{name: starting value}`` of the auxiliary variables, checked."""
        import sympy as sm
        if not isinstance(auxiliary, dict):
            raise ModelError(f"auxiliary must be a dict {{symbol: starting value}}, got "
                             f"{type(auxiliary).__name__}")
        m = self.model
        taken = {"t": "the time", **{n: "a constant of the model (list it in "
                                        "parameters= to optimize it)" for n in constants},
                 **{n: "a state of the model" for n in m.state_names},
                 **{n.removesuffix("(t)"): "an input of the model" for n in m.input_names}}
        if self.free_duration:
            taken[str(self.duration)] = "the free duration"
        out = {}
        for key, value in auxiliary.items():
            if not isinstance(key, sm.Symbol):
                raise ModelError(f"auxiliary variables are SymPy symbols, got {key!r}")
            name = str(key)
            if name in taken:
                raise ModelError(f"auxiliary variable {name} is {taken[name]}")
            if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.number)) \
                    or not np.isfinite(value):
                raise ModelError(f"starting value of the auxiliary variable {name} must be a "
                                 f"finite number, got {value!r}")
            out[name] = float(value)
        return out

    def parameter_start(self):
        """The free parameters' starting values: the model's constants, then
        the auxiliary variables' (ndarray, the layout's order)."""
        s = self.symbols
        return np.array([self.auxiliary[n] if n in self.auxiliary else s.constants[n]
                         for n in s.free], dtype=float)

    def _constraint_layout(self):
        m = self.model
        n, l, o, k = m.n_q, m.n_q_dep, m.n_u, m.n_u_dep
        self.collocated_rows = list(range(n - l)) + list(range(n, n + o - k))
        self.dependent = [m.state_names[i] for i in range(n - l, n)] + \
            [m.state_names[i] for i in range(n + o - k, n + o)]
        self.n_residuals = l + k

    def _bounds(self, bounds):
        s = self.symbols
        self.state_bounds = np.tile([-np.inf, np.inf], (len(s.states), 1))
        self.input_bounds = np.tile([-np.inf, np.inf], (len(s.inputs), 1))
        self.free_bounds = np.tile([-np.inf, np.inf], (len(s.free), 1))
        self.duration_bounds = None
        if not isinstance(bounds, dict):
            raise ModelError(f"bounds must be a dict {{symbol: (lower, upper)}}, got "
                             f"{type(bounds).__name__}")
        for key, value in bounds.items():
            name = _name(key)
            pair = _bound_pair(value, name)
            if self.free_duration and name == str(self.duration):
                self.duration_bounds = pair
            elif name in s.states:
                self.state_bounds[s.states.index(name)] = pair
            elif name in s.inputs:
                self.input_bounds[s.inputs.index(name)] = pair
            elif name in s.free:
                self.free_bounds[s.free.index(name)] = pair
            elif name in s.constants:
                raise ModelError(f"bounds name the constant {name}, which is not free; list "
                                 "it in parameters= to optimize it")
            else:
                raise ModelError(
                    f"bounds name {key}, which is neither a state ({', '.join(s.states)}), "
                    f"an input ({', '.join(s.inputs) or 'none'}), a free parameter "
                    f"({', '.join(s.free) or 'none'}) nor the free duration")
        if self.free_duration:
            if self.duration_bounds is None:
                raise ModelError(f"the free duration {self.duration} needs bounds: "
                                 f"bounds={{{self.duration}: (lower, upper)}}")
            if self.duration_bounds[0] <= 0:
                raise ModelError(f"the lower bound of the duration {self.duration} must be "
                                 f"positive, got {self.duration_bounds[0]:g}")

    def _end_values(self, values, which):
        s = self.symbols
        out = {}
        for key, value in values.items():
            name = _name(key)
            if name not in s.states:
                raise ModelError(f"{which} state names {key}, which is not a state of the "
                                 f"model ({', '.join(s.states)})")
            if name in self.dependent:
                raise ModelError(f"{which} value of {name}: a dependent state follows from "
                                 "the constraints; give the independent states only")
            if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.number)) \
                    or not np.isfinite(value):
                raise ModelError(f"{which} value of {name} must be a finite number, got "
                                 f"{value!r}")
            j = s.states.index(name)
            lo, hi = self.state_bounds[j]
            if not lo <= value <= hi:
                raise ModelError(f"{which} value {name} = {value:g} lies outside its bounds "
                                 f"({lo:g}, {hi:g})")
            out[j] = float(value)
        return out

    def _path(self, entry, k):
        try:
            expr, lower, upper = entry
        except (TypeError, ValueError):
            raise ModelError(f"path constraint {k} must be (expression, lower, upper), got "
                             f"{entry!r}") from None
        lower, upper = _bound_pair((lower, upper), f"path constraint {k} ({expr})")
        term = compile_term(expr, self.symbols, f"path constraint {k} ({expr})")
        return _Path(term, lower, upper, str(expr))

    def _node_of(self, time, what):
        """The node index at ``time`` (a number, or a multiple of the free
        duration's symbol)."""
        import sympy as sm
        N = self.nodes
        if self.free_duration:
            fraction = sm.nsimplify(sm.simplify((time - self.start_time) / self.duration))
            if not fraction.is_number:
                raise ModelError(f"{what}: the time {time} is not a fraction of the free "
                                 f"duration {self.duration} (write q({self.duration}/2))")
            position = float(fraction) * (N - 1)
        else:
            if not sm.sympify(time).is_number:
                raise ModelError(f"{what}: the time {time} is not a number")
            position = (float(time) - self.start_time) / self.duration * (N - 1)
        node = int(round(position))
        if abs(position - node) > 1e-9 * N or not 0 <= node < N:
            if self.free_duration:
                raise ModelError(f"{what}: the time {time} is not a node time (nodes at "
                                 f"t0 + k {self.duration}/{N - 1})")
            raise ModelError(f"{what}: the time {float(time):g} s is not a node time (nodes "
                             f"every {self.duration / (N - 1):g} s from t0 = "
                             f"{self.start_time:g} s)")
        return node

    def _instance(self, value, k):
        import sympy as sm
        what = f"instance constraint {k} ({value})"
        expr, atoms = instance_atoms(value, self.symbols, what)
        at, dummies, swap = [], [], {}
        for atom, (kind, j, time) in atoms.items():
            d = sm.Dummy()
            swap[atom] = d
            dummies.append(d)
            at.append((kind, j, self._node_of(time, what)))
        p = [sm.Dummy() for _ in self.symbols.free]
        for name, d in zip(self.symbols.free, p):
            swap.update({s: d for s in expr.free_symbols if str(s) == name})
        T = sm.Dummy("T")
        if self.free_duration:
            swap[self.duration] = T
        e = expr.xreplace(swap)
        variables = dummies + p + [T]
        fn = sm.lambdify(variables, [e] + [e.diff(v) for v in variables], modules="numpy")
        second = sm.lambdify(variables, [e.diff(a).diff(b) for a in variables
                                         for b in variables], modules="numpy")
        n = len(variables)
        return _Instance(at, lambda a: float(fn(*a)[0]),
                         lambda a: np.array(fn(*a)[1:], dtype=float), str(value),
                         lambda a: np.array(second(*a), dtype=float).reshape(n, n))

    def _periodic(self, state):
        s = self.symbols
        name = _name(state)
        if name not in s.states:
            raise ModelError(f"periodic names {state}, which is not a state of the model "
                             f"({', '.join(s.states)})")
        j = s.states.index(name)
        extra = len(s.free) + 1
        grad = np.concatenate([[1.0, -1.0], np.zeros(extra)])
        return _Instance([("state", j, self.nodes - 1), ("state", j, 0)],
                         lambda a: float(a[0] - a[1]), lambda a: grad,
                         f"{name}(tf) - {name}(t0)")

    # ----------------------------------------------------------- guesses
    @property
    def n_variables(self):
        """Length of the decision vector (states and inputs at every node, the
        free parameters, the duration when free; with Hermite-Simpson and LGR
        also the states and inputs at the interior points of the N - 1
        intervals)."""
        return Layout.of(self).n_variables

    def node_times(self, duration=None):
        """Times of the nodes, s (``duration`` for a free one)."""
        T = self.duration_value if duration is None else float(duration)
        if T is None:
            raise ModelError("the duration is free: give node_times(duration=...)")
        return self.start_time + T * np.linspace(0.0, 1.0, self.nodes)

    def guess_line(self, start=None, end=None, inputs=None, duration=None):
        """A decision vector: states on a straight line from ``start`` to ``end``.

        Parameters
        ----------
        start, end : dict, optional
            ``{state: value}``; entries not given are taken from ``initial`` and
            ``final`` of the problem; every state needs both ends.
        inputs : dict
            ``{input: value}``, constant over time, for every input.
        duration : float
            Only (and required) for a free duration.
        """
        from ._guess import line
        return line(self, start or {}, end or {}, inputs or {}, duration)

    def guess_from(self, result, inputs=None):
        """A decision vector from a ``SimulationResult`` (its states at the node
        times; ``inputs``: ``{input: number or f(t)}`` for every input) or an
        earlier :class:`OptimalControlResult` (states, inputs, parameters and
        duration, interpolated onto these nodes)."""
        from ._guess import from_result
        return from_result(self, result, inputs)

    # ------------------------------------------------------------ solve
    def solve(self, guess, *, solver="ipopt", options=None, warm_start=False,
              hessian="limited-memory"):
        """Solve the transcribed problem from ``guess``.

        Parameters
        ----------
        guess : ndarray, shape (n_variables,), or OptimalControlResult
            The decision vector (:meth:`guess_line`, :meth:`guess_from`), or a
            previous solution of a problem with the same layout.
        solver : str or object
            ``"ipopt"`` (IPOPT through cyipopt), ``"interior-point"``
            (kanedyn's own, :mod:`kanedyn.optimization.interior_point`, which
            takes IPOPT's names for the options it shares) or an object of the
            solver interface (:mod:`kanedyn.optimization._solvers`).
        options : dict, optional
            Passed to the solver (IPOPT's options: ``{"tol": 1e-10,
            "max_iter": 500}``); a name or value the solver refuses is a
            :class:`~kanedyn.OptionError`.
        warm_start : bool
            With a previous result as ``guess``: start from its multipliers too.
        hessian : {"limited-memory", "exact"}
            The Hessian of the Lagrangian the solver uses: its limited-memory
            quasi-Newton approximation, or the exact one (generated second
            derivatives of the model, :mod:`kanedyn.optimization._hessian`;
            every method, constraint, free parameter and free duration, but
            not models with constraints or contacts).

        Returns
        -------
        OptimalControlResult
            Also when the solver fails or is interrupted (Ctrl-C: the last
            iterate), with the solver's status in ``message``.
        """
        from ._guess import vector
        from ._nlp import CollocationNLP
        from ._result import build_result
        from ._hessian import HESSIANS
        from ._solvers import solve_nlp, solver_arrays, solver_named
        solver_named(solver)
        if hessian not in HESSIANS:
            raise ModelError(f"hessian={hessian!r}: give one of {', '.join(HESSIANS)}")
        from .interior_point._options import DEFAULTS
        tolerance = (options or {}).get("constr_viol_tol", DEFAULTS["constr_viol_tol"])
        with solver_arrays(solver, options):  # (the NLP's own arrays too)
            x0, warm = vector(self, guess, warm_start)
            nlp = CollocationNLP(self, hessian=hessian)
            solution, signal = solve_nlp(solver, nlp, x0, options, warm)
            return build_result(self, nlp, solution, signal, start=x0, tolerance=tolerance)

    def __repr__(self):
        free = " free duration," if self.free_duration else ""
        method = self.method if self.degree is None else f"{self.method} degree {self.degree}"
        return (f"<OptimalControlProblem {method}, {self.nodes} nodes,{free} "
                f"{len(self.symbols.states)} states, {len(self.symbols.inputs)} inputs, "
                f"{len(self.symbols.free)} free parameters>")


def _degree(degree, method):
    """The LGR degree (3 unless given); ``None`` for the other methods."""
    if method != "lgr":
        if degree is not None:
            raise ModelError(f"degree= is for method='lgr' (its Radau points per interval); "
                             f"method {method!r} has none")
        return None
    if degree is None:
        return 3
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
        raise ModelError(f"degree must be an integer of at least 1 (the Radau points per "
                         f"interval of method='lgr'), got {degree!r}")
    return int(degree)


def _derivatives_unavailable(model):
    from ..numerics import derivatives_unavailable
    return derivatives_unavailable(model)
