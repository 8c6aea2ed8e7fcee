r"""Numerical models generated from :class:`EquationsOfMotion`.

A :class:`NumericModel` evaluates, for a state ``y = [q, u]`` (independent
before dependent, in the order of ``eom.q`` and ``eom.u``):

* ``rhs(t, y)``: :math:`[\dot q; \dot u]`, with :math:`\dot u` from the
  numerically assembled and solved system

  .. math::

      \begin{bmatrix} M_{ind} + A_r^T M_{dep} \\ K_a \end{bmatrix}\dot u =
      \begin{bmatrix} f_{ind} + A_r^T f_{dep} \\ -f_a \end{bmatrix},\qquad
      A_r = -B_{dep}^{-1} B_{ind},

  where :math:`M, f` are Kane's unreduced mass matrix and forcing, :math:`B`
  the velocity-constraint matrix and :math:`K_a\dot u + f_a = 0` the
  acceleration constraints;
* mass matrix and forcing in SymPy's convention, constraint residuals,
  constraint forces (auxiliary speeds), kinetic and potential energy.

Models are picklable: they carry their generated source and recompile it.
"""

from __future__ import annotations

import functools
import inspect
import numbers
import pickle
import sys
import threading
import warnings
import weakref
from collections.abc import Mapping

import numpy as np

from .._errors import ConstraintError, MissingValueError, ModelError
from .._fork import after_fork_in_child
from .._output_files import replacing
from .backends._c_quick import QUICK_STATS, when_cached, when_optimized

__all__ = ["NumericModel", "StateLayout", "build_numeric_model", "BACKENDS"]

BACKENDS = ("numpy", "c")


# ------------------------------------------------------------------ inputs
def _match_key(key, candidates, what):
    """Find the candidate a user key refers to (symbol, dynamic symbol or name).

    A string is matched against the candidates' names only (never parsed);
    any other key must be one of the candidates itself.  Returns ``None``
    when nothing matches.
    """
    import sympy as sm
    from ..engine import name_of
    if isinstance(key, str):
        found = [c for c in candidates if name_of(c) == key or str(c) == key]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            raise ModelError(f"the {what} name {key!r} is ambiguous: {found}")
        return None
    if not isinstance(key, sm.Basic):
        raise ModelError(f"{what} keys must be SymPy symbols or names (str), "
                         f"got {key!r} of type {type(key).__name__}")
    return key if key in candidates else None


def _unknown_key(key, candidates, what, listing):
    """The error for a key that names none of ``candidates``: closest names."""
    from ..engine import name_of
    import difflib
    name = key if isinstance(key, str) else name_of(key)
    names = sorted({name_of(c) for c in candidates})
    if not isinstance(key, str) and name in names:
        hint = (f"; the model's {name} is another symbol (other assumptions?): pass "
                f"that symbol or the name {name!r}.")
    else:
        close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
        hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else "."
    return ModelError(f"{key} is not {what} of this model{hint} Its {listing} are "
                      f"{', '.join(names) or '(none)'}.")


def _resolve_constants(candidates, constants, needed, parameters=()):
    """Values of the constants given; keys must be among ``candidates`` or
    ``parameters``.

    ``candidates`` are the symbols the numerical model may take as constants
    (those of the equations, of exact input expressions, of auxiliary
    equations); ``parameters`` the other symbols of the model description,
    whose values are accepted and dropped (the equations do not need them).
    Every symbol in ``needed`` must have a value.  Returns ``(values,
    unused)``: ``{symbol: float}`` for the given candidates and for the given
    other parameters (checked like the others, e.g. a body's mass, but not
    passed to the generated code).
    """
    values, unused = {}, {}
    candidates = sorted(candidates, key=str)
    known = set(candidates)
    accepted = sorted(known | set(parameters), key=str)
    for key, value in constants.items():
        sym = _match_key(key, accepted, "constant")
        if sym is None:
            raise _unknown_key(key, accepted, "a parameter", "parameters")
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"the value of constant {sym} must be a number, "
                             f"got {value!r}") from None
        (values if sym in known else unused)[sym] = number
    missing = [s for s in needed if s in known and s not in values]
    if missing:
        raise MissingValueError(
            "missing value(s) for constant(s) " + ", ".join(map(str, missing))
            + "; pass them in constants={...}")
    return values, unused


def _check_mapping(values, role, expected):
    """``constants=`` and ``specified=`` are mappings ``{symbol or name: value}``."""
    if not isinstance(values, Mapping):
        names = ", ".join(map(str, expected)) or "(none)"
        raise ModelError(f"{role} must be a dict {{symbol or name: value}}, not a "
                         f"{type(values).__name__}; this model's {role}: {names}")


def _check_finite(values):
    bad = [f"{s} = {v}" for s, v in values.items() if not np.isfinite(v)]
    if bad:
        raise ModelError(f"constant(s) {', '.join(bad)} not finite; give finite values")


def _callable_arity(func, name):
    """1 for ``f(t)``, 2 for ``f(t, y)``; a function that takes no position
    argument at all is refused, naming the input."""
    try:
        signature = inspect.signature(func)
    except (TypeError, ValueError):
        return 1
    positional = [p for p in signature.parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    if not positional and not any(p.kind == p.VAR_POSITIONAL
                                  for p in signature.parameters.values()):
        raise ModelError(f"specified input {name}: its function {func!r} takes no "
                         f"argument; give f(t) or f(t, y)")
    required = [p for p in positional if p.default is p.empty]
    return 2 if len(required) >= 2 else 1


class _Input:
    """Provider of one specified input: constant, f(t) or f(t, y)."""

    __slots__ = ("name", "value", "arity")

    def __init__(self, name, value):
        self.name = name
        if isinstance(value, numbers.Number):
            self.value, self.arity = float(value), 0
        elif callable(value):
            self.value, self.arity = value, _callable_arity(value, name)
        else:
            raise ModelError(f"specified input {name}: give a number, a SymPy "
                             f"expression in t, or a callable, not {value!r}")

    def __call__(self, t, y):
        if self.arity == 0:
            return self.value
        try:
            value = self.value(t) if self.arity == 1 else self.value(t, y)
        except Exception as exc:  # named here; a run ends on it keeping what it has
            raise ModelError(f"specified input {self.name}: its function raised "
                             f"{type(exc).__name__} at t={t:g}: {exc}") from exc
        if isinstance(value, float):
            return value
        if np.ndim(value) != 0 or not isinstance(value, (numbers.Real, np.ndarray)):
            raise ModelError(f"specified input {self.name}: its function returned "
                             f"{type(value).__name__} {np.shape(value)} at t={t:g}; it must "
                             "return one real number (give one input per component)")
        return float(value)

    def __getstate__(self):
        if self.arity and not _by_value_pickler_active():
            try:
                pickle.dumps(self.value)
            except Exception as exc:
                raise pickle.PicklingError(
                    f"specified input {self.name}: its function {self.value!r} cannot be "
                    f"pickled or saved ({exc}); define it at module level (importable by "
                    "name), or give the input as a number or a SymPy expression in t"
                ) from None
        return (self.name, self.value, self.arity)

    def __setstate__(self, state):
        self.name, self.value, self.arity = state


def _input_reader(inputs):
    """``read(t, y)``: the values of ``inputs`` (``[(internal, _Input)]``), a list
    in their order, as ``[inp(t, y) for _, inp in inputs]`` gives them.

    Inputs whose functions are entries of one shared array (a wave field's
    kinematics at all strips, a rotor's loads at all nodes) say so by two
    attributes: ``input_source``, the shared function (of ``t``, or of
    ``(t, y)`` as the entry itself), and ``input_index``, the entry's index (a
    tuple) in that function's array.  Each shared function is then called once
    per read and its entries taken together, instead of one Python call per
    entry; the values are the same floats.
    """
    if not inputs:
        return lambda t, y: ()
    groups, singles = {}, []
    for k, (_, inp) in enumerate(inputs):
        source = getattr(inp.value, "input_source", None) if inp.arity else None
        if source is None:
            singles.append((k, inp))
        else:
            groups.setdefault((source, inp.arity), []).append((k, inp))
    if not groups:
        providers = [inp for _, inp in inputs]
        return lambda t, y: [inp(t, y) for inp in providers]
    plans = [(source, arity, np.array([k for k, _ in members]),
              tuple(np.array(column) for column in zip(*(tuple(inp.value.input_index)
                                                         for _, inp in members))),
              members[0][1].name)
             for (source, arity), members in groups.items()]
    size = len(inputs)

    def read(t, y):
        out = np.empty(size)
        for k, inp in singles:
            out[k] = inp(t, y)
        for source, arity, rows, index, name in plans:
            try:
                values = source(t) if arity == 1 else source(t, y)
                out[rows] = np.asarray(values, dtype=float)[index]
            except Exception as exc:  # named as _Input names it
                raise ModelError(f"specified input {name}: its function raised "
                                 f"{type(exc).__name__} at t={t:g}: {exc}") from exc
        return out.tolist()
    return read


def _input_table(inputs):
    """``(table, names)`` for a compiled module when every input of ``inputs``
    (``[(internal, _Input)]``) is a piecewise polynomial or a number (each
    number a piece of degree 0, extrapolated), so that the module evaluates
    them itself (:mod:`~kanedyn.numerics.backends._c_inputs`); else None."""
    from ..modeling import PiecewisePolynomial
    parts, names = [], []
    for _, inp in inputs:
        value = inp.value
        if inp.arity == 0:
            value = PiecewisePolynomial([0.0, 1.0], [[value]], str(value), extrapolate=True)
        elif not isinstance(value, PiecewisePolynomial):
            return None
        parts.append(value.packed())
        names.append(f"specified input {inp.name}: {value.name}")
    return np.concatenate(parts), tuple(names)


def _by_value_pickler_active():
    """True inside cloudpickle (used by Dask), which pickles lambdas by value."""
    frame = sys._getframe(2)
    while frame is not None:
        if frame.f_globals.get("__name__", "").startswith("cloudpickle"):
            return True
        frame = frame.f_back
    return False


def _resolve_specified(eom, specified):
    """Split user inputs into exact substitutions and runtime providers.

    Returns ``(substitutions, providers)``: ``{internal: expression}`` and
    ``{internal: _Input}`` for every input given; the inputs the equations of
    motion need must be among them.
    """
    import sympy as sm
    table = eom._table
    t = table.t
    needed = list(eom.specified)
    substitutions = {}  # internal symbol -> expression (internal)
    providers = {}  # external -> value
    known = list(table.specified)
    given = {_match_key(key, known, "specified input") for key in specified}
    for key, value in specified.items():
        found = _match_key(key, known, "specified input")
        if found is None:
            raise _unknown_key(key, needed or known, "a specified input", "inputs")
        key = found
        number = isinstance(value, (numbers.Number, sm.Number))
        derivatives_needed = any(isinstance(e, sm.Derivative) and e.expr == key
                                 and e not in given for e in needed)
        if isinstance(value, sm.Basic) and not number or number and derivatives_needed:
            # an expression in t (a number, when the input's rates are needed too:
            # they are then exactly zero)
            expr = sm.sympify(value, strict=True)
            if isinstance(key, sm.Derivative):
                raise ModelError(f"give the SymPy expression for {key.expr}, not for "
                                 f"its derivative {key}")
            for ext, int_ in table.specified.items():
                base = ext.expr if isinstance(ext, sm.Derivative) else ext
                if base == key:
                    order = len(ext.variables) if isinstance(ext, sm.Derivative) else 0
                    substitutions[int_] = table.internal(
                        expr.diff(t, order) if order else expr, f"input {key}")
        else:
            providers[table.specified[key]] = _Input(str(key), value)
    for ext in needed:
        int_ = table.specified[ext]
        if int_ not in substitutions and int_ not in providers:
            base = ext.expr if isinstance(ext, sm.Derivative) else ext
            rates = any(isinstance(e, sm.Derivative) and e.expr == base for e in needed)
            hint = (f"; if {base} is a coordinate, list it in q_ind or q_dep with its "
                    "kinematic equation (a function of time that is neither is an input)"
                    if rates else "")
            raise MissingValueError(
                f"missing value for the specified input {ext}; pass it in "
                "specified={...} (a number, a SymPy expression in t, or a callable "
                f"of t or of (t, y)){hint}")
    return substitutions, providers


def _batched_solve(A, B):
    """Solve stacked systems; stacks whose matrix is singular give ``nan``."""
    try:
        return np.linalg.solve(A, B)
    except np.linalg.LinAlgError:
        out = np.full(np.broadcast_shapes(A.shape[:-2], B.shape[:-2]) + B.shape[-2:], np.nan)
        for i in range(A.shape[0]):
            try:
                out[i] = np.linalg.solve(A[i], B[i])
            except np.linalg.LinAlgError:
                pass
        return out


def _singular(block, full, rtol=1e-12):
    """True when ``block`` is singular relative to the scale of ``full``."""
    if block.size == 0:
        return False
    scale = max(np.max(np.abs(full)), 1e-300)
    return np.linalg.svd(block, compute_uv=False)[-1] <= rtol * scale * max(block.shape)


# ------------------------------------------------------------------- model
class StateLayout:
    """State bookkeeping shared by numerical models.

    Needs ``n_q``, ``n_u``, ``n_q_dep``, ``n_u_dep`` and ``state_names``.
    """

    @property
    def n_states(self):
        return self.n_q + self.n_u

    @property
    def n_q_ind(self):
        return self.n_q - self.n_q_dep

    @property
    def n_u_ind(self):
        return self.n_u - self.n_u_dep

    def index(self, name):
        """Position of a state (by name or dynamic symbol) in ``y``."""
        if isinstance(name, str):
            key = name
        else:
            from ..engine import name_of
            key = name_of(name)
        try:
            return self.state_names.index(key)
        except ValueError:
            raise KeyError(f"{name} is not a state of this model; states are "
                           f"{', '.join(self.state_names)}") from None

    def _check_y(self, y):
        y = np.array(y, dtype=float)
        if y.shape != (self.n_states,):
            raise ValueError(f"the state must have {self.n_states} entries "
                             f"({', '.join(self.state_names)}), got shape {y.shape}")
        return y


class _CompiledFunctions(dict):
    """The functions of a C model's module, ``{name: function}``.

    A module built without ``"dynamics"`` (see
    :func:`~kanedyn.numerics.backends._c.eager_functions`) gets it from the
    module with every function, compiled (or found in the cache) when first
    asked for.
    """

    _NAMES = ("dynamics", "constraints", "energy", "auxiliary", "contacts")

    def __init__(self, model, module):
        super().__init__((name, getattr(module, name)) for name in self._NAMES
                         if hasattr(module, name))
        self._model = model

    def __missing__(self, name):
        model = self.__dict__.pop("_model", None) if name == "dynamics" else None
        if model is None:
            raise KeyError(name)
        module = _full_module(model)
        for key in self._NAMES:
            if key not in self and hasattr(module, key):
                self[key] = getattr(module, key)
        return self[name]


#: held while a model binds a module: the build thread's move onto an optimized
#: module (:func:`_move_onto`) against the model's own binds
_BINDING = threading.RLock()


def _binding_anew():
    """A forked child: the binding lock made anew (a build thread of the parent,
    which the child does not have, may have held it)."""
    global _BINDING
    _BINDING = threading.RLock()


after_fork_in_child(_binding_anew)


def _move_onto(model_ref, quick, optimized):
    """Bind the model (a weak reference) to the ``optimized`` module where it
    still uses the ``quick`` one (not after it moved on to the module with
    every function)."""
    model = model_ref()
    with _BINDING:
        if model is not None and model._module is quick:
            model._bind(optimized)
            QUICK_STATS["swaps"] += 1


def _full_module(model):
    """The C module with every function of ``model`` (its first one left M out);
    from the quick compiler first where it is not cached, as the first one
    (its optimized build starts when its use pays for it)."""
    from .backends._c import fingerprint, generate_c_units
    from .backends._c_build import load_module
    try:
        eom = model._eom
        functions, sizes, cse = model._functions, model._sizes, model._cse
    except AttributeError:
        raise ModelError("this C model was compiled without its mass matrix (its "
                         "right-hand side needs none) and its equations are not "
                         "available here (a model restored from a file): build the model "
                         "in this process for the mass matrix or linearization") from None
    prog, table = eom._program, eom._table
    return load_module(fingerprint(prog, functions, sizes, cse), lambda: generate_c_units(
        prog, functions, sizes, describe=lambda e: str(table.external(e)), cse=cse),
        quick=True)


def _share_generated(model, clone):
    """Give ``clone`` (the same equations, other constants or inputs) the code
    ``model`` generated on first use: the linearization's Jacobians and the
    exact derivatives take the constants and inputs as arguments (not the
    derivative module's integration loop, ``_exact_loop``: it holds the
    model's constants and inputs); the second derivatives' NumPy functions
    (and their patterns) or C modules (:mod:`._hessians`) likewise."""
    for attr in ("_linearization_fn", "_jacobians", "_jacobians_p", "_jacobians_module",
                 "_jacobians_p_module", "_weighted_hessians", "_weighted_hessian_patterns"):
        if attr in model.__dict__:
            clone.__dict__[attr] = model.__dict__[attr]


class NumericModel(StateLayout):
    """Compiled numerical functions of a set of equations of motion.

    Attributes
    ----------
    state_names : tuple of str
        Names of the entries of ``y``: coordinates then speeds.
    n_q, n_u : int
        Numbers of coordinates and speeds (including dependent ones).
    constants : dict
        ``{name: value}`` of the constants used.
    name, title : str or None
        The model's name and description, when its equations carry them.
    """

    def __init__(self, data, module=None, functions=None):
        self._data = data
        self._compile(module, functions)

    #: attributes that need the symbolic equations; a model from the derivation
    #: cache (``_rederive`` set) derives them again when one is first asked for
    _DERIVED = ("_eom", "_substitutions", "_functions", "_sizes", "_cse")

    def __getattr__(self, name):
        if name in NumericModel._DERIVED:
            rederive = self.__dict__.pop("_rederive", None)
            if rederive is not None:
                fresh = rederive()
                for attr in NumericModel._DERIVED:
                    setattr(self, attr, getattr(fresh, attr))
                return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def _bind(self, module):
        """Use the compiled ``module``: its Model object and entry points (a
        module from the quick compiler until its optimized build is loaded)."""
        with _BINDING:
            self._bind_now(module)
        when_optimized(module, functools.partial(_move_onto, weakref.ref(self), module))

    def _bind_now(self, module):
        """:meth:`_bind` under the binding lock."""
        self._module = module
        self._fn = _CompiledFunctions(self, module)
        self._c = self._c_model(module)
        if getattr(self._data["scheme"], "c_backend", True):  # else: Python rhs, C terms
            self.rhs = self._c.rhs  # the compiled entry points, called directly
            self.rhs_batch = (self._rhs_batch_first if self._data.get("c_lanes_later")
                              else self._c.rhs_batch)

    def _c_model(self, module):
        """The compiled ``module``'s Model of this model's constants and inputs;
        inputs that are all piecewise polynomials (or numbers) go to it as data
        and are evaluated in C, others through :meth:`_input_values`."""
        if not self._inputs:
            return module.Model(self._p, None)
        table = _input_table(self._inputs)
        if table is None:
            return module.Model(self._p, self._input_values)
        return module.Model(self._p, None, *table)

    def _when_cached(self, callback):
        """Call ``callback()`` once this model's compiled module is in the cache:
        at once, or (a module from the quick compiler) when its optimized build
        is, never if that fails; at once for the numpy backend."""
        when_cached(getattr(self, "_module", None), lambda _: callback())

    #: rows from which ``rhs_batch`` builds (or loads) the module with lane-wise code
    LANES_FROM_ROWS = 64

    def _rhs_batch_first(self, t, Y, P=None, threads=None, lanes=None):
        """``rhs_batch`` of a C model whose lane-wise code is not loaded yet: a
        batch of :attr:`LANES_FROM_ROWS` rows or more (or ``lanes=True``)
        loads the module with every function, compiled on first use."""
        if lanes or (lanes is None and np.ndim(Y) == 2
                     and np.shape(Y)[0] >= self.LANES_FROM_ROWS):
            full = _full_module(self)
            with _BINDING:
                self._data = dict(self._data, c_lanes_later=False)
                self._bind(full)
        return self._c.rhs_batch(t, Y, P, threads=threads, lanes=lanes)

    # state and pickling
    def _body_parameters(self):
        """:func:`~kanedyn.modeling.body_parameters` of the model's bodies (SymPy);
        a model read from the derivation cache reads them when first needed
        (``data["body_parameters"]`` is then a function that returns them)."""
        parameters = self._data.get("body_parameters", ())
        if callable(parameters):
            parameters = parameters()
            self._data = dict(self._data, body_parameters=parameters)
        return parameters

    def __getstate__(self):
        self._body_parameters()  # read, not a function, in the pickle
        data = self._data
        if data["backend"] == "c" and data["c_source"] is None:
            rederive = self.__dict__.get("_rederive")
            if getattr(rederive, "portable", False):
                # a built-in model read from the derivation cache and not derived
                # here: how to derive it (its name and options) instead of its source
                data = dict(data, rederive=rederive)
            else:
                # the C source, so that another machine can build the module
                data = dict(data, c_source=self._module_source())
        return data

    def __setstate__(self, data):
        rederive = data.pop("rederive", None)
        self._data = data
        if rederive is None:
            self._compile()
            return
        from .backends._c_build import cached_module
        module = cached_module(data["c_key"])
        if module is None:  # not in this machine's cache: derived and built here
            fresh = rederive()
            if fresh._data["c_key"] != data["c_key"]:
                raise ModelError(
                    f"a pickled model of {rederive.origin[0]!r}: derived here it computes "
                    "something else than where it was pickled (another version of "
                    "kanedyn or of its models?); pickle it with the same version")
            for attr in NumericModel._DERIVED:
                setattr(self, attr, getattr(fresh, attr))
            module = fresh._module
        else:
            self._rederive = rederive
        self._compile(module)

    def _module_source(self):
        from .backends._c import eager_functions, generate_c
        eom = getattr(self, "_eom", None)
        if eom is None:
            raise ValueError("cannot pickle: the model's equations are not available")
        return generate_c(eom._program, eager_functions(self._functions, self._sizes),
                          self._sizes, cse=self._cse, lanes=False)

    def _compile(self, module=None, functions=None):
        """Load the C module (``module``: already loaded) or compile the NumPy
        sources (``functions``: already compiled, e.g. by the model copied)."""
        d = self._data
        self._p = np.asarray(d["p"], dtype=float)
        self._inputs = d["inputs"]
        self._read_inputs = _input_reader(self._inputs)
        if d["backend"] == "c":
            if module is None:
                from .backends._c_build import load_module
                source = d["c_source"]
                module = load_module(d["c_key"], lambda: source, quick=True)
            self._bind(module)
        elif functions is not None:
            self._fn = dict(functions)
        else:
            from .backends._python import compile_python
            self._fn = {name: compile_python(src, name) for name, src in d["sources"].items()}
        for key in ("n_q", "n_u", "n_q_dep", "n_u_dep", "state_names", "constants",
                    "aux_names", "input_names", "has_potential", "has_loads", "contacts",
                    "multiplier_names", "identified_names", "multiplier_form",
                    "scheme", "rates_are_speeds"):
            setattr(self, key, d[key])

    @property
    def name(self):
        return self._data.get("name")

    @property
    def title(self):
        return self._data.get("title")

    @property
    def state_units(self):
        """``{state name: unit or None}`` (see :attr:`EquationsOfMotion.state_units`);
        found on first use from the equations (all ``None`` without them)."""
        self._fill_units()
        return self._data["state_units"]

    @property
    def constraint_units(self):
        """Units of the configuration and velocity constraints, ``(list, list)``."""
        self._fill_units()
        return self._data["constraint_units"]

    def _fill_units(self):
        if "state_units" in self._data:
            return
        eom = getattr(self, "_eom", None)
        if eom is None:
            units = dict.fromkeys(self.state_names)
            config, velocity = [None] * self.n_q_dep, [None] * self.n_u_dep
        else:
            units = {n: eom.state_units.get(n) for n in self.state_names}
            config, velocity = eom.constraint_units
            if len(config) != self.n_q_dep:
                config = [None] * self.n_q_dep
            if len(velocity) != self.n_u_dep:  # constraints in vector form among them
                velocity = [None] * self.n_u_dep
        self._data["state_units"] = units
        self._data["constraint_units"] = (list(config), list(velocity))

    @property
    def backend(self):
        """``"numpy"`` or ``"c"``: what evaluates the model."""
        return self._data["backend"]

    def __repr__(self):
        return (f"<NumericModel: {self.n_q} coordinates, {self.n_u} speeds, "
                f"backend={self._data['backend']!r}>")

    def _repr_html_(self):
        """Notebook display: sizes, backend, scheme, constants and their values."""
        from .._html import box, names, number, table
        rows = [("backend", self._data["backend"]),
                ("scheme", getattr(self.scheme, "name", str(self.scheme))),
                ("coordinates q", f"{self.n_q} ({self.n_q_dep} dependent)"),
                ("speeds u", f"{self.n_u} ({self.n_u_dep} dependent)"),
                ("constraints", f"{self.n_q_dep} configuration, {self.n_u_dep} velocity"),
                ("states", names(self.state_names)),
                ("specified inputs", names(n.removesuffix("(t)") for n in self.input_names)),
                ("constraint forces", names(self.identified_names))]
        if self.contacts:
            rows.append(("contacts", len(self.contacts)))
        eom = getattr(self, "_eom", None)
        if eom is not None:
            rows.append(("intermediates", len(eom._program)))
        constants = [(name, number(value)) for name, value in self.constants.items()]
        return box(table(rows, caption="numerical model"),
                   table(constants, caption="constants") if constants else "",
                   title=f"NumericModel: {self.n_states} states, "
                         f"backend {self._data['backend']!r}")

    # ------------------------------------------------------------ basics
    def state(self, values, t=0.0, what="initial value"):
        """A consistent state array from an array or ``{symbol or name: value}``.

        A dict must give every independent coordinate and speed; dependent
        entries (given or zero) are starting guesses, completed from the
        constraints as in :meth:`consistent_state`.

        Raises
        ------
        MissingValueError
            When independent values are missing (``what`` names them in the
            message, e.g. "initial value").
        """
        names = self.state_names
        if isinstance(values, dict):
            y = np.zeros(self.n_states)
            given = set()
            for key, value in values.items():
                idx = self.index(key)
                try:
                    y[idx] = float(value)
                except (TypeError, ValueError):
                    raise ValueError(f"{what} of {names[idx]} must be a number, got "
                                     f"{value!r}") from None
                given.add(idx)
            n, l, o, m = self.n_q, self.n_q_dep, self.n_u, self.n_u_dep
            independent = list(range(n - l)) + list(range(n, n + o - m))
            missing = [names[i] for i in independent if i not in given]
            if missing:
                raise MissingValueError(f"missing {what}(s) for " + ", ".join(missing))
        else:
            y = self._check_y(values)
        bad = [names[i] for i in np.flatnonzero(~np.isfinite(y))]
        if bad:
            raise ValueError(f"{what}s are not finite for " + ", ".join(bad))
        if self.n_q_dep or self.n_u_dep:
            y = self.consistent_state(t, y)
        return y

    def _r(self, t, y):
        return self._read_inputs(t, y)

    _input_values = _r  # the same values (an older name some callers use)

    def input_values(self, t, y):
        """The specified inputs' values at ``(t, y)``, in the order of
        :attr:`input_names`: ndarray, shape (n_r,)."""
        return np.array(self._r(t, self._check_y(y)), dtype=float).reshape(-1)

    # ---------------------------------------------------------- dynamics
    def _dynamics(self, t, y):
        if len(y) != self.n_states:
            self._check_y(y)  # raises, naming the states
        return self._fn["dynamics"](t, y, self._p, self._r(t, y))

    def _assemble(self, mass, force, vel_B, acc_K, acc_f):
        """Reduced o x o system in SymPy's convention."""
        m = self.n_u_dep
        if m == 0:
            return mass, force
        p = self.n_u - m
        Ar = -np.linalg.solve(vel_B[:, p:], vel_B[:, :p])
        M = np.vstack([mass[:p] + Ar.T @ mass[p:], acc_K])
        f = np.concatenate([force[:p] + Ar.T @ force[p:], -acc_f])
        return M, f

    def rhs(self, t, y):
        """State derivative :math:`[\\dot q, \\dot u]` (a new array each call)."""
        terms = self._dynamics(t, y)
        return np.concatenate([terms[0], self.scheme.accelerations(self, t, y, terms)])

    __call__ = rhs

    def rhs_batch(self, t, Y, P=None, threads=None, lanes=None):
        """State derivatives of many states (and parameter sets) at once.

        Parameters
        ----------
        t : float or array_like, shape (k,)
        Y : array_like, shape (k, n_states)
            One state per row.
        P : array_like, shape (k, n_constants), optional
            One set of constants per row (in the order of :attr:`constants`);
            default: the model's constants for every row.
        threads : int, optional
            Number of threads of the C backend, which evaluates the rows in C
            in contiguous blocks (the GIL released; at least 32 rows per
            thread). Default ``None``: one per CPU this process may use (its
            affinity mask). The numpy backend evaluates vectorized in one
            thread and only checks the value.
        lanes : bool, optional
            C backend: evaluate four rows at once, one per SIMD lane (AVX2), with
            results equal to one row at a time. Default ``None``: where the
            module has the lane-wise code (not for dependent speeds) and the CPU
            its instructions; ``True`` raises ``ValueError`` where it cannot;
            ``False``: one row at a time. The numpy backend ignores it.

        Returns
        -------
        ndarray, shape (k, n_states)
            Rows whose system is singular are ``nan``.
        """
        from .schemes import Elimination
        if threads is not None and (isinstance(threads, bool)
                                    or not isinstance(threads, (int, np.integer))
                                    or threads < 1):
            raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
        Y = np.asarray(Y, dtype=float)
        if Y.ndim != 2 or Y.shape[1] != self.n_states:
            raise ValueError(f"Y must have shape (k, {self.n_states})")
        k = Y.shape[0]
        t = np.asarray(t, dtype=float)
        p = self._p if P is None else np.asarray(P, dtype=float).T
        if P is not None and p.shape != (len(self._p), k):
            raise ValueError(f"P must have shape (k, {len(self._p)})")
        batch = (self._batch_function() if type(self.scheme) is Elimination
                 and not self.multiplier_form else None)
        if batch is None:  # one state at a time
            ts = np.broadcast_to(t, (k,))
            models = [self] if P is None else [self.with_constants(row) for row in P]
            return np.array([models[i % len(models)].rhs(ts[i], Y[i]) for i in range(k)])
        r = ()
        if self._inputs:
            ts = np.broadcast_to(t, (k,))
            r = np.array([self._input_values(ts[i], Y[i]) for i in range(k)]).T
        qd, mass, force, vel_B, acc_K, acc_f = batch(t, Y.T, p, r)
        mass = np.moveaxis(mass, -1, 0)
        force = force.T
        m = self.n_u_dep
        if m:
            vel_B, acc_K = np.moveaxis(vel_B, -1, 0), np.moveaxis(acc_K, -1, 0)
            pi = self.n_u - m
            X = _batched_solve(vel_B[:, :, pi:], vel_B[:, :, :pi])
            XT = np.swapaxes(X, 1, 2)
            mass = np.concatenate([mass[:, :pi] - XT @ mass[:, pi:], acc_K], axis=1)
            force = np.concatenate([force[:, :pi] - (XT @ force[:, pi:, None])[..., 0],
                                    -acc_f.T], axis=1)
        ud = _batched_solve(mass, force[..., None])[..., 0]
        return np.concatenate([qd.T, ud], axis=1)

    def _batch_function(self):
        """The vectorized dynamics, generated (with CSE) on first use."""
        from .backends._python import compile_python, generate_python
        fn = self._fn.get("dynamics_batch")
        if fn is not None:
            return fn
        sources = self._data["sources"]
        if "dynamics_batch" not in sources:
            eom = getattr(self, "_eom", None)
            if eom is None:
                return None
            args, outputs = self._functions["dynamics"]
            sources["dynamics_batch"] = generate_python(
                eom._program, "dynamics_batch", args, outputs, vectorized=True, cse=True)
        fn = self._fn["dynamics_batch"] = compile_python(sources["dynamics_batch"],
                                                         "dynamics_batch")
        return fn

    def with_constants(self, values):
        """A copy of this model with other constants.

        Parameters
        ----------
        values : sequence of float or dict
            In the order of :attr:`constants`, or ``{name: value}`` for some.
        """
        from ..modeling import body_values
        current = dict(self.constants)
        if isinstance(values, dict):
            unknown = set(values) - set(current)
            if unknown:
                raise KeyError(f"{sorted(unknown)} are not constants of this model; its "
                               f"constants are {', '.join(current)}")
            current.update({k: float(v) for k, v in values.items()})
        else:
            values = [float(v) for v in values]
            if len(values) != len(current):
                raise ValueError(f"expected {len(current)} constants "
                                 f"({', '.join(current)}), got {len(values)}")
            current = dict(zip(current, values))
        bad = [f"{k} = {v}" for k, v in current.items() if not np.isfinite(v)]
        if bad:
            raise ModelError(f"constant(s) {', '.join(bad)} not finite; give finite values")
        parameters = self._body_parameters()
        symbols = {s: current[str(s)] for _, _, mass, inertia in parameters
                   for s in (mass.free_symbols | (inertia.free_symbols if inertia is not None
                                                  else set())) if str(s) in current}
        data = dict(self._data, p=list(current.values()), constants=current,
                    bodies=body_values(parameters, symbols))
        if self._data.get("contact_coefficients"):
            data["contacts"] = _contact_values(self._data["contact_coefficients"], current)
        # the same code: the loaded C module or the compiled NumPy functions are reused
        clone = NumericModel(data, module=getattr(self, "_module", None),
                             functions=None if data["backend"] == "c" else self._fn)
        if "_rederive" in self.__dict__:  # from the derivation cache: derived when needed
            clone._rederive = self._rederive
        else:
            for attr in NumericModel._DERIVED:
                if hasattr(self, attr):
                    setattr(clone, attr, getattr(self, attr))
        _share_generated(self, clone)
        return clone

    def with_inputs(self, specified):
        """A copy of this model whose specified inputs have other providers.

        The same code (the loaded C module or the compiled NumPy functions,
        and the derivatives once built): only the values of the inputs change.
        Optimal control uses it to simulate optimal inputs.

        Parameters
        ----------
        specified : dict
            ``{input symbol or name: number, f(t) or f(t, y)}`` for some of
            :attr:`input_names` (the others keep theirs).

        Raises
        ------
        KeyError
            Naming an input the model does not have.
        """
        names = [name.removesuffix("(t)") for name in self.input_names]
        inputs = list(self._inputs)
        for key, value in specified.items():
            if isinstance(key, str):
                name = key.removesuffix("(t)")
            else:
                from ..engine import name_of
                name = name_of(key)
            if name not in names:
                raise KeyError(f"{key} is not a specified input of this model; its inputs "
                               f"are {', '.join(names) or 'none'}")
            k = names.index(name)
            inputs[k] = (inputs[k][0], _Input(self._inputs[k][1].name, value))
        data = dict(self._data, inputs=inputs)
        clone = NumericModel(data, module=getattr(self, "_module", None),
                             functions=None if data["backend"] == "c" else self._fn)
        if "_rederive" in self.__dict__:
            clone._rederive = self._rederive
        else:
            for attr in NumericModel._DERIVED:
                if hasattr(self, attr):
                    setattr(clone, attr, getattr(self, attr))
        _share_generated(self, clone)
        return clone

    def mass_matrix(self, t, y):
        """SymPy-convention ``mass_matrix`` (o x o) at a state."""
        qd, mass, force, vel_B, acc_K, acc_f = self._dynamics(t, y)
        return self._assemble(mass, force, vel_B, acc_K, acc_f)[0]

    def forcing(self, t, y):
        """SymPy-convention ``forcing`` (o) at a state."""
        qd, mass, force, vel_B, acc_K, acc_f = self._dynamics(t, y)
        return self._assemble(mass, force, vel_B, acc_K, acc_f)[1]

    def mass_matrix_full(self, t, y):
        """``[[I, 0], [0, mass_matrix]]`` (explicit kinematic equations)."""
        n = self.n_q
        out = np.zeros((self.n_states, self.n_states))
        out[:n, :n] = np.eye(n)
        out[n:, n:] = self.mass_matrix(t, y)
        return out

    def forcing_full(self, t, y):
        """``[q', forcing]``."""
        qd, mass, force, vel_B, acc_K, acc_f = self._dynamics(t, y)
        return np.concatenate([qd, self._assemble(mass, force, vel_B, acc_K, acc_f)[1]])

    def inverse_dynamics(self, t, q, u, udot):
        r"""Generalized forces on the independent speeds that produce ``udot``.

        :math:`\tau = (M\dot u - f)_{ind} + A_r^T (M\dot u - f)_{dep}`: the
        forces to add to the independent speeds' generalized active forces
        so that the model moves with the accelerations ``udot`` at ``(q, u)``
        (:math:`M\dot u - f` for an open chain).  Dependent coordinates,
        speeds and rates are completed from the constraints; specified
        inputs keep their given values.  Generated code taking ``udot`` as
        inputs (see :mod:`kanedyn.numerics._inverse`).

        Parameters
        ----------
        t : float or array_like, shape (N,)
            Times, s.
        q : array_like, shape (n_q_ind, N) or (n_q, N), or 1-D
            Coordinates, one column per point (as ``res.y``).
        u : array_like, shape (n_u_ind, N) or (n_u, N), or 1-D
            Speeds.
        udot : array_like, shape (n_u_ind, N) or (n_u, N), or 1-D
            Rates of the independent speeds.

        Returns
        -------
        ndarray, shape (n_u_ind, N), or (n_u_ind,) for 1-D inputs
            In N for translation rates in m/s, N m for angular rates in rad/s.

        Examples
        --------
        >>> import numpy as np, kanedyn as kd
        >>> model = kd.models.build("pendulum").numeric(
        ...     constants={"m": 1.0, "l": 1.0, "g": 9.81})
        >>> tau = model.inverse_dynamics(0.0, [0.0], [0.0], [0.0])  # hold it still
        """
        one = self.__dict__.get("_inverse_one")  # the direct call for one point
        if one is None:
            from ._inverse import one_point
            one = self.__dict__["_inverse_one"] = one_point(self)
        tau = one(t, q, u, udot) if one else None
        if tau is None:  # a trajectory, or what the direct call leaves to the general way
            from ._inverse import inverse_dynamics as _inverse_dynamics
            tau = _inverse_dynamics(self, t, q, u, udot)
        return tau

    def jacobians(self, t, y, r=None, parameters=False, modes=None, directions=None,
                  stabilization=10.0):
        r"""Exact derivatives of :meth:`rhs`: :math:`\partial f/\partial y`,
        :math:`\partial f/\partial r` and, on request, :math:`\partial f/\partial p`.

        For a model with contacts, those of :meth:`contact_dynamics` within the
        given contact ``modes`` (and of the contact forces); see
        :mod:`kanedyn.numerics._contact_derivatives`.

        Generated code of the derivatives of the equations' program (both
        backends; made on first use), then one linear solve with the mass
        matrix (and the constraint Jacobians: dependent speeds and coordinates
        are differentiated through their elimination).  See
        :mod:`kanedyn.numerics._jacobians`.

        Parameters
        ----------
        t : float or array_like, shape (N,)
            Time, s.
        y : array_like, shape (n_states,) or (N, n_states)
            State, or one state per row.
        r : array_like, shape (n_inputs,), optional
            Values of the specified inputs (``input_names``); by default their
            providers are evaluated at ``(t, y)``.  The derivatives hold them
            fixed: an input that is a function of the state contributes
            nothing to ``state``.
        parameters : bool
            Also the derivatives with respect to the named constants
            (:attr:`constants`), for sensitivities and identification.
        modes, directions, stabilization
            For a model with contacts (required there, refused elsewhere): as
            :meth:`contact_dynamics`.

        Returns
        -------
        Jacobians
            ``f``, ``state`` (n_states, n_states), ``inputs``, ``parameters``,
            and the derivatives of the multipliers where the model has
            dependent speeds; with a first axis of length N for many states.

        Raises
        ------
        ModelError
            For a model with contacts without ``modes`` (or in statically
            indeterminate modes), a constraint scheme that does not state
            its equations (``acceleration_system()``; the built-in ones all do,
            the stabilized ones included), the penalty scheme on acceleration
            constraints given apart from the velocity constraints, or a model
            restored from a file, naming which.

        Examples
        --------
        >>> import kanedyn as kd
        >>> model = kd.models.build("pendulum").numeric(
        ...     constants={"m": 1.0, "l": 1.0, "g": 9.81})
        >>> J = model.jacobians(0.0, [0.1, 0.0])
        >>> J.state.shape
        (2, 2)
        """
        if modes is None:  # one state on C: one call, without the checks
            if r is None:
                point = self.__dict__.get("_jacobian_point_p" if parameters
                                          else "_jacobian_point")
                found = point(t, y) if point is not None else None
            else:
                point = self.__dict__.get("_jacobian_point_p_given_r" if parameters
                                          else "_jacobian_point_given_r")
                found = point(r, t, y) if point is not None else None
            if found is not None:
                return found
        from ._jacobians import jacobians
        return jacobians(self, t, y, r=r, parameters=parameters, modes=modes,
                         directions=directions, stabilization=stabilization)

    def inverse_parts(self, t, q, u, udot, groups=None, gravity=None):
        """The inverse-dynamics forces by cause and by body group.

        See :func:`kanedyn.numerics._inverse_parts.inverse_parts` (arguments
        as :meth:`inverse_dynamics`, plus ``groups = {name: [body names]}``
        and the ``gravity`` symbol); returns an ``InverseParts``.
        """
        from ._inverse_parts import inverse_parts
        return inverse_parts(self, t, q, u, udot, groups=groups, gravity=gravity)

    # -------------------------------------------------------- constraints
    def _constraint_terms(self, t, y):
        return self._fn["constraints"](t, y, self._p, self._r(t, y))

    def constraint_residuals(self, t, y):
        """Configuration then velocity constraint residuals (zero when satisfied).

        The velocity residuals are the constraint expressions themselves, so
        constraints nonlinear in the speeds are measured correctly.
        """
        h, _, _, vel_c = self._constraint_terms(t, y)
        return np.concatenate([h, vel_c])

    def constraint_conditioning(self, t, y):
        r"""How far a state is from a singular configuration: :math:`\sigma_{\min}/\sigma_{\max}`.

        The ratio of the smallest to the largest singular value of the
        velocity-constraint matrix :math:`B = \partial c/\partial u`, which
        holds the holonomic constraints as the time derivatives of the
        configuration constraints: 0 where the constraints lose rank, the
        inverse of their condition number elsewhere.  :func:`kanedyn.simulate` reports
        the times at which a run passes below ``singular_threshold``.

        Parameters
        ----------
        t : float
        y : array_like, shape (n_states,)

        Returns
        -------
        float
        """
        from ._singular import conditioning
        return conditioning(self, t, self._check_y(y))

    def consistent_state(self, t, y, tol=1e-12, max_iterations=50):
        """State with dependent coordinates and speeds satisfying the constraints.

        Dependent coordinates are found by Newton's method with the independent
        ones fixed; dependent speeds by solving the velocity constraints.

        Raises
        ------
        ConstraintError
            When the constraint Jacobian with respect to the dependent
            variables is singular, or Newton's method does not converge.
        """
        y = self._check_y(y)
        n, l, m = self.n_q, self.n_q_dep, self.n_u_dep
        names = self.state_names
        if l:
            dep = slice(n - l, n)
            for _ in range(max_iterations + 1):
                h, J, _, _ = self._constraint_terms(t, y)
                if _singular(J[:, dep], J):
                    raise ConstraintError(
                        "the configuration constraints cannot be solved for the "
                        f"dependent coordinates {', '.join(names[n - l:n])}: their "
                        f"Jacobian is singular at {self._describe(y[:n], names[:n])}; "
                        "give starting values of the dependent coordinates closer to "
                        "a consistent configuration, or choose other dependent "
                        "coordinates")
                if np.max(np.abs(h)) <= tol or not np.all(np.isfinite(h)):
                    break
                y[dep] -= np.linalg.solve(J[:, dep], h)
            if not np.max(np.abs(h)) <= max(tol, 1e-9):
                raise ConstraintError(
                    "could not satisfy the configuration constraints (residual "
                    f"{np.max(np.abs(h)):.3g}) by adjusting "
                    f"{', '.join(names[n - l:n])}; give initial values closer to a "
                    "consistent configuration")
        if m:  # Newton's method (one step when linear in the speeds)
            # dependent speeds, or, in the multiplier form, the smallest change
            # of all speeds
            free = slice(n, None) if self.multiplier_form else slice(n + self.n_u - m, None)
            for _ in range(max_iterations + 1):
                _, _, B, c = self._constraint_terms(t, y)
                Bf = B[:, free.start - n:]
                if not self.multiplier_form and _singular(Bf, B):
                    raise ConstraintError(
                        "the velocity constraints cannot be solved for the dependent "
                        f"speeds {', '.join(names[free])}: the constraint Jacobian "
                        f"with respect to them is singular at "
                        f"{self._describe(y[:n], names[:n])}")
                scale = 1.0 + np.max(np.abs(y[n:]))
                if np.max(np.abs(c)) <= tol * scale or not np.all(np.isfinite(c)):
                    break
                y[free] -= np.linalg.lstsq(Bf, c, rcond=None)[0]
            if not np.max(np.abs(c)) <= max(tol, 1e-9) * scale:
                raise ConstraintError(
                    "could not satisfy the velocity constraints (residual "
                    f"{np.max(np.abs(c)):.3g}) by adjusting {', '.join(names[free])}; "
                    "give initial speeds closer to a consistent motion")
        return y

    @staticmethod
    def _describe(values, names):
        return "(" + ", ".join(f"{k}={v:.6g}" for k, v in zip(names, values)) + ")"

    # ---------------------------------------------------------- energies
    def kinetic_energy(self, t, y):
        return float(self._fn["energy"](t, y, self._p, self._r(t, y))[0])

    def potential_energy(self, t, y):
        """Potential energy, or ``nan`` when the model declares none."""
        return float(self._fn["energy"](t, y, self._p, self._r(t, y))[1])

    def total_energy(self, t, y):
        ke, pe = self._fn["energy"](t, y, self._p, self._r(t, y))
        return float(ke + pe)

    def energies(self, t, y):
        """``(kinetic, potential)`` energy; potential ``nan`` when undeclared."""
        ke, pe = self._fn["energy"](t, y, self._p, self._r(t, y))
        return float(ke), float(pe)

    # -------------------------------------------------- constraint forces
    def auxiliary(self, t, y):
        """Constraint forces exposed by auxiliary speeds, ``{name: value}``.

        The auxiliary equations are linear in the unknown force symbols (those
        without a given value); they are solved with :math:`\\dot u` from
        :meth:`rhs`.
        """
        if "auxiliary" not in self._fn:
            raise ValueError("this model has no auxiliary speeds, hence no "
                             "constraint-force outputs")
        k = len(self.aux_names)
        ud = self.rhs(t, y)[self.n_q:]
        r = list(self._r(t, y))
        fn = self._fn["auxiliary"]
        K, f0 = fn(t, y, self._p, r + [0.0] * k)
        base = K @ ud + f0
        if k == 0:
            return {}
        G = np.empty((len(base), k))
        for j in range(k):
            lam = [0.0] * k
            lam[j] = 1.0
            G[:, j] = fn(t, y, self._p, r + lam)[1] - f0
        try:
            sol = np.linalg.solve(G, -base)
        except np.linalg.LinAlgError:  # a state where the forces are not determined
            sol = np.full(k, np.nan)
        return dict(zip(self.aux_names, sol))

    def multipliers(self, t, y, udot=None):
        r"""Multipliers :math:`\lambda` of the velocity constraints.

        Kane's unreduced equations hold with the constraint forces added,
        :math:`M\dot u = f + B^T\lambda` (``B`` the Jacobian of the velocity
        constraints with respect to the speeds); :math:`\lambda` is found by
        least squares (exact: ``B`` has full row rank).  For constraints given
        in vector form (:class:`kanedyn.PointVelocity`, ...) each multiplier
        is the magnitude of the identified force or torque along its
        direction, in N or N m.

        Parameters
        ----------
        t : float
        y : array_like, shape (n_states,)
        udot : array_like, shape (n_u,), optional
            Accelerations; default: those of :meth:`rhs`.

        Returns
        -------
        dict
            ``{name: value}`` in the order of the velocity constraints.
        """
        y = self._check_y(y)
        qd, mass, force, vel_B, acc_K, acc_f = self._dynamics(t, y)
        if udot is None:
            udot = self.scheme.accelerations(self, t, y, (qd, mass, force, vel_B, acc_K,
                                                           acc_f))
        names = self.multiplier_names
        if not names:
            return {}
        lam = np.linalg.lstsq(vel_B.reshape(len(names), -1).T, mass @ udot - force,
                              rcond=None)[0]
        return dict(zip(names, lam))

    @property
    def constraint_force_names(self):
        """Names of :meth:`constraint_forces`: auxiliary, then identified forces."""
        return tuple(self.aux_names) + tuple(self.identified_names)

    def constraint_forces(self, t, y):
        """Constraint forces at a state, ``{name: value}``.

        Those exposed by auxiliary speeds (:meth:`auxiliary`) and the
        magnitudes of the forces identified by vector constraints
        (:meth:`multipliers`).
        """
        out = self.auxiliary(t, y) if self.aux_names else {}
        if self.identified_names:
            lam = self.multipliers(t, y)
            out.update((name, lam[name]) for name in self.identified_names)
        return out

    # ------------------------------------------------------------ contacts
    def contact_dynamics(self, t, y, modes, directions=None, stabilization=10.0):
        """Accelerations and contact forces with the contacts in given modes.

        Parameters
        ----------
        t : float
        y : array_like
        modes : sequence of {"separated", "slip", "stick"}
            One per contact, in the order of ``eom.contacts``.
        directions : sequence, optional
            Slip directions for sliding contacts that have no slip velocity.
        stabilization : float
            Baumgarte frequency for the contact constraints, rad/s.

        Returns
        -------
        ContactSolution
            ``udot``, ``normal_force``, ``friction``, ``force``, ``dissipation``.
        """
        from ._contact_dynamics import solve_modes
        if not self.contacts:
            raise ValueError("this model has no contacts")
        if len(modes) != len(self.contacts):
            raise ValueError(f"give one mode per contact ({len(self.contacts)})")
        return solve_modes(self, t, self._check_y(y), modes, directions, stabilization)

    # ------------------------------------------------------------ C export
    def c_source(self, standalone=True, module_name="kanedyn_model", title=None,
                 jacobians=False, parameters=False):
        """C source of this model's numerical functions.

        Parameters
        ----------
        standalone : bool
            ``True``: a C99 file without Python (:func:`kanedyn_rhs`,
            ``kanedyn_constraints``, ``kanedyn_energy``; the header comment
            documents the signatures, the order of states, parameters and
            inputs, and the return codes), compiling with
            ``cc -c -std=c99 -Wall -Werror``.  ``False``: the source of the
            Python extension module the C backend builds (needs the Python
            and NumPy headers), with the module name ``module_name``.
        module_name : str
            Name of the extension module (``standalone=False`` only).
        title : str, optional
            First line of the standalone file's header comment.
        jacobians : bool
            The standalone file also holds ``kanedyn_jacobians``, the exact
            derivatives of :meth:`jacobians` (of the state derivative and of the
            multipliers, by the state and the inputs; the constraint rows by
            the state), generated and solved as the compiled derivative module
            does.  Its functions are then that module's: ``kanedyn_rhs`` gives
            the state derivative ``jacobians`` gives (equal to :meth:`rhs` to
            rounding).
        parameters : bool
            With ``jacobians``: also the columns of the named constants.

        Returns
        -------
        str

        Raises
        ------
        ModelError
            When the equations are not available (a model restored by
            unpickling), or the model's constraint scheme or formulation is
            not what the generated right-hand side computes; with
            ``jacobians``, where the model has no exact derivatives solved in
            C (see :meth:`jacobians`).
        ValueError
            ``jacobians`` with ``standalone=False``, or ``parameters`` without
            ``jacobians``.
        """
        if not standalone and jacobians:
            raise ValueError("jacobians: only in the standalone file (standalone=True); "
                             "the extension module's derivatives are model.jacobians")
        if parameters and not jacobians:
            raise ValueError("parameters: the constants' columns of the exact derivatives, "
                             "which need jacobians=True")
        if standalone and self.contacts:
            names = ", ".join(c["name"] for c in self.contacts)
            raise ModelError(f"cannot export standalone C of a model with contacts "
                             f"({names}): the file would hold the right-hand side without "
                             "them (their modes, events and impacts are followed by "
                             "kd.simulate); export the model without its contacts")
        return self._c_text(standalone, module_name, title, jacobians=jacobians,
                            parameters=parameters)

    def _c_text(self, standalone=True, module_name="kanedyn_model", title=None,
                contacts=False, jacobians=False, parameters=False):
        """:meth:`c_source` without its refusal of contacts; ``contacts=True``: the
        standalone file with the contact kinematics and the contact loop
        (:mod:`kanedyn.numerics.backends._c_hybrid`), what an FMU of a model with
        contacts compiles; ``jacobians``, ``parameters``: as for :meth:`c_source`."""
        from .backends._c import NAME_TOKEN, generate_c
        from .backends._c_export import standalone_c
        eom = getattr(self, "_eom", None)
        if eom is None:
            raise ModelError("cannot export C: this model's equations are not available "
                             "(a model restored from a file); export the model built by "
                             "eom.numeric(...)")
        if self.multiplier_form or not getattr(self.scheme, "c_backend", True):
            raise ModelError(f"cannot export C: the right-hand side of the "
                             f"{self.scheme.name!r} scheme ({eom.method} formulation) is "
                             "not the generated C one; use the default scheme")
        table = eom._table
        cse = self._cse  # None: the default choice (see build_numeric_model)
        if not standalone:
            if not module_name.isidentifier():
                raise ModelError(f"module_name {module_name!r} is not a valid identifier")
            source = generate_c(eom._program, self._functions, self._sizes,
                                describe=lambda e: str(table.external(e)), cse=cse,
                                units=False)
            return source.replace(NAME_TOKEN, module_name)
        derivatives = None
        if jacobians:
            from ._jacobians import standalone_derivatives
            derivatives = standalone_derivatives(self, parameters)
        return standalone_c(eom._program, self._functions, self._sizes, self.state_names,
                            dict(zip(self.constants, map(float, self._p))),
                            input_names=self.input_names,
                            title=title or f"{self!r}", cse=cse is not False,
                            describe=lambda e: str(table.external(e)),
                            contacts=self._contact_c() if contacts else None,
                            derivatives=derivatives)

    def _contact_c(self):
        """Per contact: its name, law and the C expressions (of ``p[i]``) of its
        coefficients (for :func:`~kanedyn.numerics.backends._c_export.standalone_c`)."""
        import sympy as sm
        index = {name: i for i, name in enumerate(self.constants)}
        unused = dict(self._data.get("unused_constants") or {})
        out = []
        for entry, exprs in self._data.get("contact_coefficients") or ():
            item = {"name": entry["name"], "newton": entry["law"] == "newton"}
            for key in ("mu_k", "mu_s", "viscous", "restitution"):
                expr = sm.sympify(exprs.get(key, 0), strict=True)
                values = {}
                for symbol in expr.free_symbols:
                    if str(symbol) in index:
                        values[symbol] = sm.Symbol(f"p[{index[str(symbol)]}]")
                    elif str(symbol) in unused:
                        values[symbol] = sm.Float(unused[str(symbol)])
                    else:
                        raise ModelError(f"contact {entry['name']}: its {key} depends on "
                                         f"{symbol}, which is not a constant of the model")
                item[key] = sm.ccode(sm.Float(expr) if expr.is_number
                                     else expr.xreplace(values))
            out.append(item)
        return out

    def export_c(self, path, standalone=True, module_name="kanedyn_model", title=None,
                 jacobians=False, parameters=False):
        """Write :meth:`c_source` to ``path`` (arguments as there); returns the
        path (a ``Path``).

        Raises :class:`~kanedyn.OutputFileError` when it cannot be written (nothing
        is left behind, an earlier file is as it was).
        """
        from pathlib import Path
        path = Path(path)
        source = self.c_source(standalone=standalone, module_name=module_name, title=title,
                               jacobians=jacobians, parameters=parameters)
        with replacing(path) as handle:
            handle.write(source)
        return path

    def export_fmu(self, path, y0, **options):
        """Write this model as an FMI 2.0 or 3.0 FMU (model exchange and
        co-simulation) compiled from :meth:`c_source`; returns the path.

        See :func:`kanedyn.io.export_fmu` for ``y0`` (the start state) and the
        options (``t_end``, ``rtol``, ``atol``, ``projection_tol``,
        ``constant_units``, ``identifier``, ``title``, ``fmi_version``,
        ``nominals``).  Models with contacts are refused.
        """
        from ..io import export_fmu
        return export_fmu(self, path, y0, **options)

    # --------------------------------------------------------- linearize
    def linearize(self, y, t=0.0, r=None):
        r"""Linearize about the state ``y``, :math:`\delta\dot x_i = A\,\delta x_i + B\,\delta r`.

        Parameters
        ----------
        y : array_like, shape (n_q + n_u,)
            Operating point ``[q, u]`` (SI units); its dependent entries must
            satisfy the constraints (:meth:`consistent_state` makes them).  It
            need not be an equilibrium: the accelerations and constraint forces
            at ``y`` enter the result.
        t : float
            Time of the operating point, s.
        r : array_like, optional
            Values of the specified inputs (the columns of ``B``) at the
            operating point; by default their providers are evaluated at
            ``(t, y)``.

        Returns
        -------
        A : ndarray, shape (n, n)
            With :math:`x_i = [q_{ind}; u_{ind}]` and
            ``n = n_q - n_q_dep + n_u - n_u_dep``: dependent coordinates and
            speeds are eliminated numerically.
        B : ndarray, shape (n, n_r)
        r : list of str
            Names of the inputs, in the order of the columns of ``B``.

        See Also
        --------
        kanedyn.EquationsOfMotion.linearize : symbolic, or SymPy's forms.

        Notes
        -----
        Computed from :meth:`jacobians` (the model's backend, C where it has
        one) where the model has exact derivatives and no input that is a
        derivative; otherwise from the linearization's own generated
        Jacobians (NumPy).  Both are exact; they agree to round-off.
        """
        from ._linearize import linearize_compiled, linearize_numeric
        found = linearize_compiled(self, y, t=t, r=r)
        return found if found is not None else linearize_numeric(self, y, t=t, r=r)


def _contact_outputs(terms, o, sub):
    """Outputs of the generated ``contacts`` function (see ContactTerms)."""
    if not terms:
        return []
    k = len(terms)
    jac = [sub(t.jacobian[r][i]) for t in terms for i in range(3) for r in range(o)]
    return [((k,), [sub(t.gap) for t in terms]),
            ((k,), [sub(t.grad_norm) for t in terms]),
            ((k, 3), [sub(c) for t in terms for c in t.normal]),
            ((k, 3), [sub(c) for t in terms for c in t.velocity]),
            ((3 * k, o), jac),
            ((k, 3), [sub(c) for t in terms for c in t.acceleration]),
            ((k,), [sub(t.normal_rate) for t in terms])]


def _contact_coefficients(contacts, values):
    """Numbers for each contact's friction and restitution coefficients."""
    from ..modeling import coefficient_value
    out = []
    for c in contacts:
        entry = {"name": c.name, "kind": c.kind, "law": c.restitution_law}
        for key, value in c.coefficients.items():
            entry[key] = coefficient_value(value, values, f"contact {c.name}: {key}")
        if entry["mu_k"] < 0 or entry["mu_s"] < 0 or entry["viscous"] < 0:
            raise ModelError(f"contact {c.name}: friction coefficients must not be "
                             f"negative (mu_k={entry['mu_k']}, mu_s={entry['mu_s']}, "
                             f"viscous={entry['viscous']})")
        if "restitution" in entry and not 0.0 <= entry["restitution"] <= 1.0:
            raise ModelError(f"contact {c.name}: the restitution coefficient must be in "
                             f"[0, 1], got {entry['restitution']}")
        out.append(entry)
    return out


def _contact_values(coefficients, current):
    """The contacts' numbers again, for the constants ``current`` (``{name: value}``)."""
    import sympy as sm
    out = []
    for entry, exprs in coefficients:
        entry = dict(entry)
        for key, expr in exprs.items():
            expr = sm.sympify(expr, strict=True)
            if not expr.is_number:
                expr = expr.xreplace({s: current[str(s)] for s in expr.free_symbols
                                      if str(s) in current})
            entry[key] = float(expr)
        out.append(entry)
    return out


def _speed_tree_found(eom, force, sub, values, unused):
    """The outputs of the C backend's articulated-body pass, or ``None``.

    The pass reads every body's whole spatial inertia, also components the
    equations do not contain (a product of inertia about a fixed axis): their
    values move from ``unused`` to ``values`` (they become inputs of the
    generated code); without a value for one of them, ``None`` (M is formed).
    """
    from .backends._c import speed_tree_outputs
    found = speed_tree_outputs(getattr(eom, "_speed_tree", None), eom._qdot, force, sub)
    if found is None:
        return None
    prog, table = eom._program, eom._table
    extra = set()
    for _, exprs in found[0][2:]:
        for e in exprs:
            extra |= prog.deps(e)
    extra = {s for s in extra if not table.is_dynamic(s) and s != table.t
             and s not in values}
    if not extra <= set(unused):
        return None
    values.update((s, unused.pop(s)) for s in extra)
    return found


def build_numeric_model(eom, constants, specified, backend="numpy", cse=None, scheme=None):
    """Generate and compile the numerical functions of ``eom``.

    ``scheme`` (default: the formulation's, :attr:`EquationsOfMotion.scheme`)
    is the constraint scheme of :mod:`kanedyn.schemes` that turns the
    evaluated terms into accelerations.

    ``cse`` (default: on for ``"c"``, whose build is cached, except in the
    articulated-body pass, where it gains nothing; off for ``"numpy"``, so
    that models are quick to create) eliminates common subexpressions of the
    generated code jointly.
    """
    import sympy as sm

    from ..engine import name_of
    from ..modeling import body_parameters, body_values
    from .backends._python import generate_python
    from .schemes import as_scheme
    if backend not in BACKENDS:
        raise ModelError(f"unknown backend {backend!r}; available: "
                         f"{', '.join(repr(b) for b in BACKENDS)}")
    _check_mapping(constants, "constants", eom.constants)
    _check_mapping(specified, "specified", eom.specified)
    prog = eom._program
    table = eom._table
    substitutions, providers = _resolve_specified(eom, specified)

    def sub(e):
        return prog.subs(e, substitutions) if substitutions else e

    def flat(rows):
        return [sub(e) for row in rows for e in row]

    n, o = len(eom.q), len(eom.u)
    m, l = len(eom.u_dep), len(eom.q_dep)
    force = [a - b for a, b in zip(eom._active, eom._remainder)]
    dynamics = [((n,), [sub(e) for e in eom._qdot]),
                ((o, o), flat(eom._mass)),
                ((o,), [sub(e) for e in force]),
                ((m, o), flat(eom._vel_B)),
                ((m, o), flat(eom._acc_K)),
                ((m,), [sub(e) for e in eom._acc_f])]
    hol_jac = [prog.diff(h, q) for h in eom._config for q in table.q]
    constraint_outputs = [((l,), [sub(e) for e in eom._config]),
                          ((l, n), [sub(e) for e in hol_jac]),
                          ((m, o), flat(eom._vel_B)),
                          ((m,), [sub(e) for e in eom._vel_c])]
    potential = eom._potential if eom._potential is not None else sm.nan
    energy = [((), [sub(eom._kinetic)]), ((), [sub(potential)])]
    contact_outputs = _contact_outputs(eom._contact_terms, o, sub)
    energy_leaves = set()
    for _, exprs in energy:
        for e in exprs:
            energy_leaves |= prog.deps(e)
    unknown_inputs = {s for s in energy_leaves
                      if s in table.specified.values() and s not in providers}
    if unknown_inputs:  # energy needs inputs the dynamics do not: report nan
        energy = [((), [sm.nan]), ((), [sm.nan])]

    main = [e for _, exprs in dynamics + constraint_outputs + energy + contact_outputs
            for e in exprs]
    leaves = set()
    for e in main:
        leaves |= prog.deps(e)
    runtime = [(s, inp) for s, inp in providers.items() if s in leaves]
    aux_exprs = flat(eom._aux_K) + [sub(e) for e in eom._aux_f]
    aux_leaves = set()
    for e in aux_exprs:
        aux_leaves |= prog.deps(e)
    # constants: the equations' own, those of exact input expressions and of
    # the auxiliary equations (those left without a value there are unknowns)
    candidates = set(eom.constants)
    for value in substitutions.values():
        candidates |= {s for s in value.free_symbols
                       if not table.is_dynamic(s) and s != table.t}
    candidates |= {s for s in aux_leaves if not table.is_dynamic(s) and s != table.t
                   and s not in table.udot}
    for contact in eom.contacts:  # friction coefficients may be symbols: required
        for value in contact.coefficients.values():
            symbols = sm.sympify(value, strict=True).free_symbols
            candidates |= symbols
            leaves |= symbols
    needed_consts = sorted((s for s in candidates if s in leaves), key=str)
    values, unused = _resolve_constants(candidates, constants, needed_consts,
                                        parameters=getattr(eom, "parameters", ()))
    _check_finite({**values, **unused})
    tree_found = _speed_tree_found(eom, force, sub, values, unused) \
        if backend == "c" and m == 0 and l == 0 else None
    body_parameters_ = body_parameters(eom.bodies)
    bodies = body_values(body_parameters_, {**values, **unused})
    const_syms = sorted(values, key=str)

    y_syms = list(table.q) + list(table.u)
    r_syms = [s for s, _ in runtime]
    args = {"y": y_syms, "p": const_syms, "r": r_syms}
    functions = {"dynamics": (args, dynamics), "constraints": (args, constraint_outputs),
                 "energy": (args, energy)}
    if contact_outputs:
        functions["contacts"] = (args, contact_outputs)

    aux_names = ()
    if eom.u_aux:
        unknowns = [s for s in aux_leaves
                    if s not in values and s not in r_syms and s not in y_syms
                    and s != table.t and s not in table.u_aux
                    and s not in set(table.udot)]
        unknowns.sort(key=lambda s: name_of(table.external(s)))
        aux_names = tuple(name_of(table.external(s)) for s in unknowns)
        s_aux = len(eom.u_aux)
        if len(unknowns) != s_aux:
            raise ModelError(
                f"the {s_aux} auxiliary equation(s) contain {len(unknowns)} symbol(s) "
                f"without a value ({', '.join(aux_names) or 'none'}); there must be "
                "exactly one unknown constraint-force magnitude per auxiliary speed, "
                "so give values for the others in constants={...}")
        aux_args = {"y": y_syms, "p": const_syms, "r": r_syms + unknowns}
        functions["auxiliary"] = (aux_args, [((s_aux, o), flat(eom._aux_K)),
                                             ((s_aux,), [sub(e) for e in eom._aux_f])])

    multiplier_form = bool(getattr(eom, "_multiplier_form", False)) and m > 0
    if multiplier_form and backend == "c":
        raise ModelError(f"the {eom.method!r} formulation solves for its accelerations "
                         "and multipliers together, which the C backend does not do yet; "
                         "use backend='numpy'")
    scheme = as_scheme(eom.scheme if scheme is None else scheme)
    if backend == "c" and not (scheme.c_backend or scheme.c_terms):
        raise ModelError(f"the C backend does not implement the {scheme.name!r} constraint "
                         "scheme; use backend='numpy'")
    sizes = {"n_q": n, "n_u": o, "n_q_dep": l, "n_u_dep": m, "n_p": len(const_syms),
             "n_r": len(r_syms)}
    sources = c_key = c_module = None
    lanes_later = False
    if backend == "c":
        from .backends._c import (compiler_command, eager_functions, fingerprint,
                                  generate_c_units, lanes_wanted, load_module,
                                  missing_compiler_text)
        if compiler_command() is None:
            warnings.warn(f"{missing_compiler_text()}; using the numpy backend instead",
                          RuntimeWarning, stacklevel=3)
            backend = "numpy"
        else:
            if tree_found is not None:  # u' by an articulated-body pass (KD_SOLVE 3)
                functions["tree"] = (args, tree_found[0])
                sizes["speed_tree"] = tree_found[1]
            eager = eager_functions(functions, sizes)  # M and lanes later, if asked for
            c_key = fingerprint(prog, eager, sizes, cse, lanes=False)
            # generated only when the module is not in the cache
            c_module = load_module(c_key, lambda: generate_c_units(
                prog, eager, sizes, describe=lambda e: str(table.external(e)), cse=cse,
                lanes=False), quick=True)
            lanes_later = lanes_wanted(functions, sizes)
    if backend == "numpy":
        cse = False if cse is None else cse
        sources = {name: generate_python(prog, name, a, outs, cse=cse)
                   for name, (a, outs) in functions.items()}
        # the vectorized dynamics for rhs_batch are generated on first use

    data = {
        "backend": backend,
        "sources": sources,
        "c_key": c_key,
        "c_lanes_later": lanes_later,  # rhs_batch: lanes in the module with everything
        "c_source": None,  # filled in when pickled (see __getstate__)
        "p": [values[s] for s in const_syms],
        "constants": {str(s): values[s] for s in const_syms},
        # given, but the equations do not use them (not constants of this model;
        # the viewer's shapes may be placed by them)
        "unused_constants": {str(s): unused[s] for s in sorted(unused, key=str)},
        "inputs": runtime,
        "input_names": tuple(inp.name for _, inp in runtime),
        "n_q": n, "n_u": o, "n_q_dep": l, "n_u_dep": m,
        "state_names": eom.state_names,
        "aux_names": aux_names,
        "has_potential": eom._potential is not None,
        "has_loads": bool(eom.loads),
        "contacts": _contact_coefficients(eom.contacts, values),
        "contact_coefficients": [({"name": c.name, "kind": c.kind, "law": c.restitution_law},
                                  dict(c.coefficients)) for c in eom.contacts],
        "multiplier_names": eom._multiplier_names,
        "multiplier_form": multiplier_form,
        "scheme": scheme,
        "rates_are_speeds": tuple(eom._qdot) == tuple(table.u),
        "identified_names": tuple(name for name, _ in eom._identified
                                  if name in eom._multiplier_names),
        "body_parameters": body_parameters_,
        "bodies": bodies,
        "name": getattr(eom, "name", None),
        "title": getattr(eom, "title", None),
    }
    model = NumericModel(data, module=c_module)
    # not pickled: the equations and exact input substitutions, for linearization
    # (and the function specifications, to regenerate C source when pickling)
    model._eom = eom
    model._substitutions = substitutions
    model._functions, model._sizes, model._cse = functions, sizes, cse
    scheme.prepare(model)
    return model
