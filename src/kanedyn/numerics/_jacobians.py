r"""Exact derivatives of a :class:`NumericModel`'s right-hand side.

The state derivative is :math:`f = [\dot q;\ \dot u]` with :math:`\dot q =
g(q, u, r)` and the accelerations solving the index-1 system

.. math::

    M\dot u - f_u - B^T\lambda = 0,\qquad K\dot u + f_a = 0,

(:math:`B` the velocity-constraint matrix, :math:`K` the acceleration one,
:math:`\lambda` the multipliers of :meth:`NumericModel.multipliers`; without
dependent speeds only the first, with no :math:`\lambda`).  With the residuals
:math:`E(x; w, \mu) = \tau(q, u, w) - B^T\mu` (:math:`\tau = Mw - f_u`, the
inverse dynamics) and :math:`a(x; w) = Kw + f_a` differentiated with respect to
any variable :math:`x` (a coordinate, a speed, an input, a constant) at
:math:`w = \dot u`, :math:`\mu = \lambda`,

.. math::

    \begin{bmatrix} M & -B^T \\ K & 0 \end{bmatrix}
    \begin{bmatrix} \partial_x\dot u \\ \partial_x\lambda \end{bmatrix}
    = -\begin{bmatrix} \partial_x E \\ \partial_x a \end{bmatrix} .

The partial derivatives :math:`\partial_x g, \partial_x E, \partial_x a` are
generated code (both backends): forward differentiation of the equations'
straight-line program (:meth:`kanedyn.engine.Program.jacobian`), nothing
expanded.  For a tree derived by Kane's method :math:`\tau` is the engine's
recursive pass (:func:`kanedyn.engine.composite_inertia_forces`, :math:`O(n)`
for a chain), so its derivatives take :math:`O(n^2)` operations, as
articulated-body derivatives do; otherwise :math:`\tau` is the product with the
mass-matrix entries.  A tree whose coordinates' rates are its speeds takes
spatial formulas for the state columns of its inertia forces and constant loads
instead (:func:`kanedyn.engine.tree_inertia_derivatives`, fewer operations by
a factor 3.5 to 7 on ``chain3d`` at n = 7 to 30; :func:`_tree_state_rows`),
their :math:`n^2` entries formed when the code runs from
:data:`TREE_FACTOR_MIN_SPEEDS` speeds.
The linear solve is numerical, so dependent speeds (and coordinates) are
differentiated through their elimination exactly.  One state on the C backend
is then one call of the module, which also makes the :class:`Jacobians`
(:func:`_keep_point`).  In C the derivatives take the values the dynamics
computed for the accelerations (the kinematics, the sines and cosines:
:data:`PLAIN_DYNAMICS_MIN_SPEEDS`), and a tree of long paths solves for the
accelerations and the derivative columns by the articulated-body pass instead
of M's factors (:data:`TREE_SOLVE_MIN_DEPTH`).

This is the derivative of the accelerations every index-1 scheme computes
(elimination, index-1, projection, Udwadia-Kalaba, partitioning, null space,
orthogonal complement, and the index-3 augmented Lagrangian through ``rhs``:
on any state they give the same :math:`\dot u`).  Each scheme states the
equations its accelerations satisfy
(:meth:`~kanedyn.numerics.schemes.Scheme.acceleration_system`).  Those that
add stabilization terms :math:`s` to the acceleration constraints (Baumgarte,
the augmented Lagrangian, Udwadia-Kalaba with gains) or replace them by a
penalty (:math:`K\dot u + f_a + s + \mu/\alpha = 0`) add :math:`\partial s`
(and the penalty's :math:`I/\alpha` and :math:`\partial\alpha`) to the
second row, exactly, off the constraint manifold too: see
:mod:`kanedyn.numerics._stabilization_derivatives`.  A scheme whose system
is not known (a scheme of one's own without ``acceleration_system``), and the
penalty on acceleration constraints given apart from the velocity
constraints, are refused, naming the scheme.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass
from dataclasses import fields as dataclass_fields
from functools import partial

import numpy as np

from .._errors import ModelError

__all__ = ["Jacobians", "jacobians", "EXACT_SCHEMES", "derivatives_unavailable",
           "state_jacobian", "through_inputs", "derivatives_built", "exact_loop",
           "inputs_follow_state", "broadcast_rows"]

#: the constraint schemes whose accelerations are the exact index-1 ones (Udwadia-Kalaba
#: without its optional stabilization gains)
EXACT_SCHEMES = ("elimination", "index-1", "projection", "udwadia-kalaba", "partitioning",
                 "null-space", "orthogonal-complement")


@dataclass(frozen=True, slots=True)
class Jacobians:
    r"""Derivatives of the state derivative :math:`f(t, y)` at one state or many.

    For many states (``y`` of shape (N, n_states)) every array has a first
    axis of length N.

    Attributes
    ----------
    f : ndarray, shape (n_states,)
        The state derivative :math:`[\dot q, \dot u]` itself.
    state : ndarray, shape (n_states, n_states)
        :math:`\partial f/\partial y` (rows: the entries of ``f``; columns:
        ``state_names``), the specified inputs held at their values.
    inputs : ndarray, shape (n_states, n_inputs)
        :math:`\partial f/\partial r`, columns ``input_names``.
    parameters : ndarray, shape (n_states, n_constants), or None
        :math:`\partial f/\partial p`, columns ``parameter_names`` (asked for
        with ``parameters=True``).
    multipliers, multipliers_inputs, multipliers_parameters : ndarray or None
        The same derivatives of the multipliers :math:`\lambda`
        (:meth:`NumericModel.multipliers`), shapes (m, n_states), (m,
        n_inputs), (m, n_constants); ``None`` without dependent speeds (or
        parameters not asked for).
    constraints : ndarray, shape (n_q_dep + n_u_dep, n_states)
        :math:`\partial[h; c]/\partial y` of the constraint residuals
        (:meth:`NumericModel.constraint_residuals`: configuration, then
        velocity constraints).
    state_names, input_names, parameter_names, multiplier_names : tuple of str
    contact_forces : ndarray, shape (k, 3), or None
        For a model with contacts (derivatives within given modes): the total
        force of each contact (normal and friction, N, inertial components), as
        :attr:`ContactSolution.force`; ``None`` without contacts.
    contact_forces_state, contact_forces_inputs, contact_forces_parameters : ndarray or None
        Their derivatives, shapes (k, 3, n_states), (k, 3, n_inputs), (k, 3,
        n_constants) (the last with ``parameters=True``).
    contact_names : tuple of str
    """

    f: np.ndarray
    state: np.ndarray
    inputs: np.ndarray
    parameters: np.ndarray | None
    multipliers: np.ndarray | None
    multipliers_inputs: np.ndarray | None
    multipliers_parameters: np.ndarray | None
    constraints: np.ndarray
    state_names: tuple
    input_names: tuple
    parameter_names: tuple
    multiplier_names: tuple
    contact_forces: np.ndarray | None = None
    contact_forces_state: np.ndarray | None = None
    contact_forces_inputs: np.ndarray | None = None
    contact_forces_parameters: np.ndarray | None = None
    contact_names: tuple = ()

    @classmethod
    def _of(cls, **fields):
        """One made from all its fields without the checks of ``__init__`` (a
        Jacobian per step of an integrator: its construction counts)."""
        self = object.__new__(cls)
        for name, value in fields.items():
            object.__setattr__(self, name, value)
        return self


# ------------------------------------------------------------ generated code
def _specification(model, parameters):
    """``(program, arguments, outputs)`` of the generated ``jacobians`` function.

    Arguments ``(t, y, p, r)`` with ``r`` = the model's inputs, then ``w``
    (:math:`\\dot u`) and ``mu`` (:math:`\\lambda`); outputs
    ``g_y, E_y, a_y, g_r, E_r, a_r`` (and ``g_p, E_p, a_p``), then ``h_y, c_y``
    (the configuration and velocity constraints), then for a stabilized
    scheme the derivatives of its parts (:func:`_stabilization_derivatives.part_rows`),
    or for a model with contacts those of its contact kinematics, mass matrix
    and velocity-constraint matrix (:func:`_contact_derivatives.contact_rows`),
    one output per column group.  For a tree taking the spatial formulas
    (:func:`_tree_state_rows`) ``E_y`` lacks their part, and one last output
    holds the factors it is formed from; the tree of speeds is kept by the
    model (``_jacobian_tree``).
    """
    import sympy as sm

    from ._inverse import _recursive_inertia_forces, _workspace
    from ._stabilization_derivatives import part_rows
    eom = model._eom
    args, dynamics = model._functions["dynamics"]
    o, m = model.n_u, model.n_u_dep
    qdot, mass, force = dynamics[0][1], dynamics[1][1], dynamics[2][1]
    vel_B, acc_K, acc_f = dynamics[3][1], dynamics[4][1], dynamics[5][1]
    prog, kin = _workspace(model)
    w = list(eom._table.udot)
    mu = [sm.Dummy(f"mu{k}") for k in range(m)]
    columns = [args["y"], args["r"]] + ([args["p"]] if parameters else [])
    tree = _tree_state_rows(model, prog, kin, w, mass, args["y"], args["p"])
    model.__dict__["_jacobian_tree"] = None if tree is None else tree[2]
    factored = tree is not None and tree[1] is not None
    E = None  # formed where some column needs it (not a tree's state columns alone)
    if tree is None or any(len(variables) for variables in columns[1:]):
        inertia = _recursive_inertia_forces(eom, o, w, model._substitutions, kin)
        if inertia is None:
            inertia = [sm.Add(*[mass[r * o + s] * w[s] for s in range(o)]) for r in range(o)]
        E = [inertia[r] - force[r] - sm.Add(*[vel_B[c * o + r] * mu[c] for c in range(m)])
             for r in range(o)]
    a = [sm.Add(*[acc_K[c * o + s] * w[s] for s in range(o)]) + acc_f[c] for c in range(m)]
    outputs = []
    for variables in columns:
        for part, rows in enumerate((qdot, E, a)):
            if part == 1 and tree is not None and variables is args["y"]:
                outputs.append(((o, len(variables)), tree[0]))
                continue
            shape = (len(rows) if part != 1 else o, len(variables))
            jac = list(prog.jacobian(rows, variables, guarded=True)) if shape[1] else []
            outputs.append((shape, jac))
    _, constraints = model._functions["constraints"]
    for rows in (constraints[0][1], constraints[3][1]):  # h(q), c(q, u)
        jac = prog.jacobian(rows, args["y"], guarded=True)
        outputs.append(((len(rows), len(args["y"])), list(jac)))
    rows = part_rows(prog, _parts(model), list(args["y"]), dynamics, constraints)
    if model.contacts:
        from ._contact_derivatives import contact_rows
        rows = contact_rows(model)
    for variables in columns if rows else ():
        jac = prog.jacobian(rows, variables, guarded=True)
        outputs.append(((len(rows), len(variables)), list(jac)))
    if factored:  # last: the tree's factors (no constraint or contact rows)
        outputs.append(((len(tree[1]), o), [x for row in tree[1] for x in row]))
    return prog, dict(args, r=list(args["r"]) + w + mu), outputs


#: speeds from which a tree's derivatives are formed from its factors when the
#: code runs (below, the entries are expressions of the generated code): chain3d,
#: C, per state, the factors' time over the expressions' 1.1 at n = 7, 1.0 at
#: n = 12, 0.73 at n = 30
TREE_FACTOR_MIN_SPEEDS = 12


def _tree_state_rows(model, prog, kin, w, mass, y, constants):
    r"""``(rows, factors, parent)`` of :math:`\partial E/\partial y` of a tree
    without constraints or contacts, or ``None`` where the tree's formulas do
    not apply.

    Its inertia forces and the loads constant in inertial components at mass
    centres and on body frames (gravity) are differentiated in spatial terms
    (:func:`kanedyn.engine.tree_inertia_derivatives`), the other loads by the
    program: ``rows`` (row-major entries) holds the latter's part; from
    :data:`TREE_FACTOR_MIN_SPEEDS` speeds the former's is formed from the numbers
    of ``factors`` (45 rows of o expressions) and the tree ``parent`` when the
    code runs (:func:`kanedyn.engine.tree_jacobian_values`, or the C runtime's
    ``kd_tree_jacobian``), so the generated code grows with n, not n^2; below,
    ``rows`` holds both parts and ``factors`` and ``parent`` are ``None``."""
    from ..engine import tree_inertia_derivatives
    from ..engine import difference
    from ._inverse import _tree_bodies
    eom, o = model._eom, model.n_u
    if model.n_u_dep or model.n_q_dep or model.contacts or kin is None:
        return None
    found = _tree_bodies(eom, kin)
    if found is None:
        return None
    table = eom._table
    constant, other, active = _split_loads(model, prog, kin, found, set(constants))
    remainder = [_substituted(model, prog, e) for e in eom._remainder]
    # less the constant loads' generalized forces: those of all loads less the others'
    rest = [remainder[r] - (active[r] - other[r]) for r in range(o)]
    entries = o < TREE_FACTOR_MIN_SPEEDS
    spatial = tree_inertia_derivatives(kin, *found, table.q, table.u, w, o,
                                       (list(mass[:o * o]), rest),
                                       [(k, kind, vec) for k, kind, vec, _ in constant],
                                       factors=True, entries=entries)
    if spatial is None:
        return None
    dq, du, factors, parent = spatial
    moved = prog.jacobian(other, y, guarded=True)
    if entries:  # the entries as expressions (a - b, without SymPy's flatten where it can)
        return [difference(dq[r][c] if c < o else du[r][c - o], moved[r, c])
                for r in range(o) for c in range(len(y))], None, None
    return [-moved[r, c] for r in range(o) for c in range(len(y))], factors, parent


def _substituted(model, prog, expr):
    """``expr`` with the model's exact inputs substituted."""
    subs = model._substitutions
    return prog.subs(expr, subs) if subs else expr


def _split_loads(model, prog, kin, tree, constants):
    """``(constant, other, active)``: the loads constant in inertial components
    at a body's mass centre or on its frame, ``(k, "F" or "T", vector,
    partials)``; the generalized active forces of the other loads and those
    of all loads, as the equations have them (o expressions each).

    Where their sum differs from the equations' active forces at the sample
    points (:func:`_sum_agrees`), every load is taken as other (those forces)."""
    import sympy.physics.mechanics as me

    from ..engine import dot
    eom, o = model._eom, model.n_u
    bodies, terms = tree[0], tree[1]
    at_centre = {b.masscenter: k for k, b in enumerate(bodies)}
    on_frame = {b.frame: k for k, b in enumerate(bodies) if isinstance(b, me.RigidBody)}
    aux_zero = {ua: 0 for ua in eom._table.u_aux}
    constant, other = [], [0] * o
    for loc, vec in eom._load_vectors:
        frame = isinstance(loc, me.ReferenceFrame)
        k = (on_frame if frame else at_centre).get(loc)
        if k is not None and all(prog.deps(c) <= constants for c in vec):
            part = terms[k].partial_angular_velocities if frame else terms[k].partial_velocities
            constant.append((k, "T" if frame else "F", vec, part))
            continue
        base = kin.angular_velocity(loc) if frame else kin.velocity(loc)
        for r, speed in enumerate(eom._table.u):
            partial = tuple(prog.subs(prog.diff(c, speed), aux_zero) for c in base)
            other[r] += dot(vec, partial)
    other = [_substituted(model, prog, e) for e in other]
    active = [_substituted(model, prog, e) for e in eom._active]
    if not _sum_agrees(prog, constant, other, active, eom._table.u[:o]):
        return [], active, active
    return constant, other, active


def _sum_agrees(prog, constant, other, active, speeds):
    """Whether ``other`` plus the generalized forces of the ``constant`` loads
    equal ``active`` at the sample points.  The loads' partial velocities are
    taken by complex steps through their velocities in all speeds at once
    (:meth:`~kanedyn.engine.Program.shadow_jacobian`: numbers, no expression
    per load and speed), else (a point where those cannot be trusted) formed
    as expressions."""
    from ..engine import SAMPLE_SEEDS, dot
    o = len(active)
    formed = None
    vectors = [getattr(part, "vector", None) for _, _, _, part in constant]
    for seed in SAMPLE_SEEDS:
        theirs = np.array(prog.shadow(active, seed))
        partials = (prog.shadow_jacobian([c for v in vectors for c in v], speeds, seed)
                    if constant and None not in vectors else None)
        if partials is not None or not constant:
            loads = np.array(prog.shadow([c for _, _, vec, _ in constant for c in vec], seed))
            mine = np.array(prog.shadow(other, seed), dtype=complex)
            if constant:
                mine += np.einsum("lc,lcr->r", loads.reshape(-1, 3),
                                  partials.reshape(len(constant), 3, o))
        else:
            if formed is None:
                formed = [e + sum(dot(vec, part[r]) for _, _, vec, part in constant)
                          for r, e in enumerate(other)]
            mine = np.array(prog.shadow(formed, seed))
        scale = 1.0 + max((abs(x) for x in theirs), default=0.0)
        if any(not abs(x - z) <= 1e-10 * scale for x, z in zip(mine, theirs)):
            return False
    return True


def _system(model):
    """The scheme's :class:`AccelerationSystem` (``None``: not known)."""
    scheme = getattr(model, "scheme", None)
    method = getattr(scheme, "acceleration_system", None)
    return method() if method is not None else None


def _parts(model):
    """The stabilization parts whose derivatives are generated (``()``: none);
    kept by the model (its scheme does not change)."""
    found = model.__dict__.get("_jacobian_parts")
    if found is None:
        from ._stabilization_derivatives import parts
        # the contact modes' solve is index-1, without stabilization
        found = () if model.contacts or not model.n_u_dep else parts(_system(model),
                                                                      model.n_q_dep)
        model.__dict__["_jacobian_parts"] = found
    return found


#: changes when the generated derivatives change (part of the C cache key)
_GENERATION = "jacobians 5"


def _functions(model, parameters):
    """``(dynamics, jacobians)``: the generated functions, made on first use and
    kept by the model (one pair with, one without the parameter columns).

    The C module's cache key is that of the model's own functions and this
    generation: a module in the cache is loaded without differentiating
    anything (the derivatives of chain3d at n = 30 take 11 s to form)."""
    key = "jacobians_p" if parameters else "jacobians"
    found = model.__dict__.get("_" + key)
    if found is not None:
        return found
    if model._data["backend"] == "c":
        from .backends._c import generate_c_units, load_module
        text, functions, sizes = _c_key(model, parameters)
        table = model._eom._table

        def units():
            prog, args, outputs = _specification(model, parameters)
            tree = {"jacobian_tree": model.__dict__["_jacobian_tree"]}
            first = "tree" if "tree" in functions else "dynamics"
            return generate_c_units(prog, dict(functions, jacobians=(args, outputs)),
                                    dict(sizes, **tree),
                                    describe=lambda e: str(table.external(e)),
                                    cse=model._cse, lanes=False, plain=_plain(model),
                                    share=(first, "jacobians"))
        # first from the quick compiler where there is one: its functions move onto
        # the optimized code (built in the background) by themselves, and the model
        # onto the optimized module's entry points once it is loaded
        import weakref

        from .backends._c_quick import when_optimized
        module = load_module(text, units, quick=True)
        model.__dict__["_" + key + "_module"] = module
        found = _entry_points(module)
        model.__dict__["_" + key] = found
        when_optimized(module, partial(_move_onto, weakref.ref(model), key, module))
        return model.__dict__["_" + key]  # the optimized module's, if loaded already
    else:
        from .backends._python import compile_python, generate_python
        prog, args, outputs = _specification(model, parameters)
        source = generate_python(prog, key, args, outputs, cse=True)
        found = (model._fn["dynamics"], compile_python(source, key),
                 *_numpy_rows(model, key, (prog, args, outputs)), None, None)
    model.__dict__["_" + key] = found
    return found


def _numpy_rows(model, key, specification):
    """``(dynamics_rows, jacobians_rows)`` of a NumPy model: the dynamics and the
    generated derivatives of many states at once (``(T, Y, p, R)``, states in
    rows, every output with a first axis of length N, as the C module's), each
    vectorized function generated on its first call (:func:`_evaluate` takes
    them for more than one state: the derivatives of a collocation NLP's nodes
    in one call, not state by state).  They give ``None`` where a value is not
    finite: the vectorized code evaluates both sides of a conditional (the
    derivative of ``x**p`` by ``p`` where ``x`` is 0, say), where the code of one
    state evaluates the side it takes and raises on a value ``math`` does not
    take, so the states of such a call are evaluated one by one, as before."""
    from .backends._python import compile_python, generate_python
    made = {}

    def rows(fn, T, Y, p, R):
        with np.errstate(all="ignore"):
            values = fn(T, Y.T, p, R.T)
        if not all(np.isfinite(x).all() for x in values):
            return None
        return [np.moveaxis(x, -1, 0) for x in values]

    def dynamics_rows(T, Y, p, R):
        return rows(model._batch_function(), T, Y, p, R)

    def jacobians_rows(T, Y, p, R):
        fn = made.get(key)
        if fn is None:
            prog, args, outputs = specification
            source = generate_python(prog, key + "_rows", args, outputs, vectorized=True,
                                     cse=True)
            fn = made[key] = compile_python(source, key + "_rows")
        return rows(fn, T, Y, p, R)

    return dynamics_rows, jacobians_rows


def standalone_derivatives(model, parameters=False):
    """What the standalone C file needs for the exact derivatives
    (:meth:`NumericModel.c_source` with ``jacobians=True``): the functions and
    sizes of the model's derivative module, its program, and how it lists them
    (``program, functions, sizes, plain, share, cse``), for
    :func:`kanedyn.numerics.backends._c_export.standalone_c`.

    The standalone file takes models of the elimination scheme only (its
    right-hand side is the generated one), whose derivatives the module solves
    in C whole (no stabilization parts solved in NumPy).

    Raises
    ------
    ModelError
        Where the model has no exact derivatives, naming why.
    """
    _check_available(model)
    _, functions, sizes = _c_key(model, parameters)
    prog, args, outputs = _specification(model, parameters)
    first = "tree" if "tree" in functions else "dynamics"
    # the pass's fallback where a pivot is not positive: M (not in the module)
    functions = dict(functions, dynamics=model._functions["dynamics"], jacobians=(args, outputs))
    return dict(program=prog, functions=functions,
                sizes=dict(sizes, jacobian_tree=model.__dict__["_jacobian_tree"]),
                plain=_plain(model), share=(first, "jacobians"), cse=model._cse)


def _move_onto(model_ref, key, quick, optimized):
    """Give the model (a weak reference) the entry points of the ``optimized``
    derivative module where it still has those of the ``quick`` one: their
    evaluation moved onto the optimized code already, but the quick compiler's
    own code around it (the one-state call's arguments, arrays and result) cost
    about 0.5 µs more per call (chain3d n = 7, the Panda).  The one-state paths
    are made again on the next call (:func:`_keep_point`)."""
    model = model_ref()
    if model is None or model.__dict__.get("_" + key + "_module") is not quick:
        return
    model.__dict__["_" + key + "_module"] = optimized
    model.__dict__["_" + key] = _entry_points(optimized)
    point = "_jacobian_point_p" if key == "jacobians_p" else "_jacobian_point"
    for name in (point, point + "_given_r"):
        model.__dict__.pop(name, None)


#: the model's functions listed again in the derivative module without common
#: subexpressions (the same numbers) from :data:`PLAIN_DYNAMICS_MIN_SPEEDS` speeds:
#: ``dynamics``, M and the forcing, whose elimination over M's n^2 entries took
#: 1.0 s of CPU at chain3d n = 100 (0.055 s without) for 2.8 % fewer operations
#: (5 % at n = 30) in the derivative module's solve
_PLAIN = ("dynamics",)

#: speeds from which (this many or more) the derivative module lists the dynamics
#: plain (:data:`_PLAIN`), the derivatives taking the program's intermediates the
#: dynamics computed (``kanedyn.numerics.backends._c._shared_sources``); below
#: (at most 11 speeds) it lists M and the forcing together with the derivatives,
#: their common subexpressions eliminated jointly (the derivatives then take
#: every value the dynamics computed, not only the program's intermediates)
PLAIN_DYNAMICS_MIN_SPEEDS = 12


def _plain(model):
    """The functions the derivative module lists without common subexpressions."""
    return () if model.n_u < PLAIN_DYNAMICS_MIN_SPEEDS else _PLAIN


#: a tree whose right-hand side is solved by the articulated-body pass (the
#: model's ``tree`` function, from 12 speeds) has its derivatives solved by that
#: pass too where its speeds have on average this many speeds on their path to
#: the root (themselves included) or more: its derivative module evaluates the
#: pass instead of M and the forcing, and solves the derivative columns with the
#: pass's factors (``kd_tree_apply`` of the C runtime, about 24 multiply-adds per
#: speed and column, against two per speed on the path for M's factors).  On C,
#: per state, the time of the pass over that of M's factors (both modules built
#: in one process; two builds each): chain3d n = 12, 16, 20 (6.5, 8.5, 10.5 on
#: average) 0.93-1.00, 0.97-1.12, 0.94-1.03 (no consistent difference), n = 24,
#: 30 (12.5, 15.5) 0.81-0.95, 0.82-0.94, n = 100 0.38; Solo12 on a floating
#: base (6.5) 1.05-1.17, on a fixed one (4 legs of 3 speeds, 2) 1.3-1.45
TREE_SOLVE_MIN_DEPTH = 10


def _tree_solve(model):
    """Whether the derivative module of ``model`` is solved by the articulated-body
    pass (:data:`TREE_SOLVE_MIN_DEPTH`) instead of M's factors."""
    if "tree" not in model._functions or model.n_u_dep or model.contacts or _parts(model):
        return False
    parent = model._sizes["speed_tree"][0]
    path = 0  # the speeds on the paths to the roots
    for k in range(len(parent)):
        while k >= 0:
            path, k = path + 1, parent[k]
    return path >= TREE_SOLVE_MIN_DEPTH * len(parent)


def _c_key(model, parameters):
    """``(cache key text, functions, sizes)`` of a C model's derivative module:
    the model's own functions (M included; the tree pass instead where
    :func:`_tree_solve`) and this generation."""
    from .backends._c import fingerprint
    if _tree_solve(model):  # no M
        functions = {k: v for k, v in model._functions.items() if k != "dynamics"}
        sizes = dict(model._sizes)
    else:
        functions = {k: v for k, v in model._functions.items() if k != "tree"}  # M needed
        sizes = {k: v for k, v in model._sizes.items() if k != "speed_tree"}
    text = fingerprint(model._eom._program, functions, sizes, model._cse, lanes=False)
    parts = _parts(model)
    stabilized = f" stabilization={','.join(parts)}" if parts else ""
    stabilized += " contacts" if model.contacts else ""
    stabilized += " factors" if model.n_u >= TREE_FACTOR_MIN_SPEEDS else ""
    return f"{text}\n{_GENERATION} parameters={parameters}{stabilized}", functions, sizes


def _entry_points(module):
    """The C module's functions ``(dynamics, jacobians, dynamics_rows,
    jacobians_rows, solved_jacobians, solved_jacobian)`` (the last two: the whole
    evaluation in C, of many states and of one)."""
    return (getattr(module, "dynamics", None), module.jacobians,
            getattr(module, "dynamics_rows", None), module.jacobians_rows,
            module.solved_jacobians, module.solved_jacobian)


def _built(model):
    """The derivative functions ``model`` has made (in this process), or ``None``."""
    return model.__dict__.get("_jacobians") or model.__dict__.get("_jacobians_p")


def derivatives_built(model):
    """Whether ``model`` has its derivative functions at no cost of building them:
    made in this process, or (C) in the compile cache, then loaded."""
    if _built(model) is not None:
        return True
    if model._data["backend"] != "c" or derivatives_unavailable(model):
        return False
    from .backends._c_build import cached_module
    module = cached_module(_c_key(model, False)[0])
    if module is None:
        return False
    model.__dict__["_jacobians"] = _entry_points(module)
    model.__dict__["_jacobians_module"] = module
    return True


def exact_loop(model):
    """The compiled integration loop (a generated ``Model`` object) of a C
    ``model``'s derivative module: the same right-hand side, and the exact
    Jacobian in its Rosenbrock method (the inputs held at their values: not for
    inputs that are functions of the state).  Builds the derivatives if
    needed."""
    found = model.__dict__.get("_exact_loop")
    if found is None:
        if not derivatives_built(model):
            _functions(model, False)
        module = (model.__dict__.get("_jacobians_module")
                  or model.__dict__["_jacobians_p_module"])
        found = model._c_model(module)
        model.__dict__["_exact_loop"] = found
    return found


# ----------------------------------------------------------------- numbers
def derivatives_unavailable(model, modes_given=False):
    """Why ``model`` has no exact derivatives (text), or ``None``.

    A model with contacts has them within given contact modes only
    (``modes_given``: asked for so).  Found once, then kept by the model
    (what it asks of the model does not change)."""
    kept = getattr(model, "__dict__", {})
    key = "_jacobian_reason_modes" if modes_given else "_jacobian_reason"
    if key not in kept:
        kept[key] = _derivatives_unavailable(model, modes_given)
    return kept[key]


def _derivatives_unavailable(model, modes_given):
    if not hasattr(model, "jacobians"):
        return f"a {type(model).__name__} has no exact derivatives"
    name = getattr(getattr(model, "scheme", None), "name", None)
    system = _system(model)
    if model.n_u_dep and system is None:
        from .schemes import SCHEMES
        return (f"this model's constraint scheme {name!r} does not say what its "
                "accelerations satisfy (its acceleration_system() gives None), so their "
                "derivatives are not generated: build the model with a built-in scheme "
                f"({', '.join(SCHEMES)}), or give the scheme an acceleration_system()")
    if (model.n_u_dep and system.penalty_factor is not None
            and getattr(model, "_functions", None) is not None
            and not _constraint_rows_are_velocity_rows(model)):
        return (f"this model's scheme {name!r} penalizes the acceleration constraints, "
                "which were given apart from the velocity constraints "
                "(acceleration_constraints=...): the derivatives of its multipliers are "
                "generated only where the acceleration constraints are the velocity "
                "constraints differentiated; build the model with scheme='baumgarte', "
                "'augmented-lagrangian' or an index-1 scheme for its derivatives")
    if model.contacts and not modes_given:
        return ("a model with contacts has exact derivatives within given contact modes "
                "only (model.jacobians(t, y, modes=[...]), one mode per contact): its "
                "accelerations depend on the modes")
    if getattr(model, "_eom", None) is None or not hasattr(model, "_functions"):
        return ("the derivatives need the model's equations, which a model restored from "
                "a file does not carry; build the model with eom.numeric(...) in this "
                "process")
    return None


def _constraint_rows_are_velocity_rows(model):
    """Whether the acceleration-constraint matrix K is B, that of the velocity
    constraints (the same generated entries)."""
    dynamics = model._functions["dynamics"][1]
    return list(dynamics[3][1]) == list(dynamics[4][1])


def _check_available(model, modes_given=False):
    """Raise why ``model`` has no exact derivatives (:func:`derivatives_unavailable`)."""
    reason = derivatives_unavailable(model, modes_given)
    if reason:
        raise ModelError(reason)


def inputs_follow_state(model):
    """Names of the specified inputs given as functions of the state ``(t, y)``."""
    return [name for name, (_, inp) in zip(model.input_names, model._inputs)
            if inp.arity == 2]


def through_inputs(model, t, y, inputs):
    """The part of the total :math:`\\partial f/\\partial y` that comes through the
    inputs that are functions of the state: ``inputs`` (:math:`\\partial
    f/\\partial r`) times their own derivatives, by central differences (a
    user's function); zero where no input follows the state."""
    following = [k for k, (_, inp) in enumerate(model._inputs) if inp.arity == 2]
    if not following:
        return 0.0

    def values(state):   # every input at one state, then the next state: inputs that
        # share one solve (a rotor's loads) keep its last state's values, one solve each
        return np.array([model._inputs[k][1](t, state) for k in following], dtype=float)

    columns = []
    for j in range(y.size):
        h = 1e-7 * max(1.0, abs(y[j]))
        up, down = y.copy(), y.copy()
        up[j] += h
        down[j] -= h
        columns.append((values(up) - values(down)) / (2 * h))
    return inputs[:, following] @ np.array(columns).T


def state_jacobian(model):
    r"""``jac(t, y)``: the total :math:`\partial f/\partial y` of ``model.rhs``
    for an integrator, the inputs that are functions of the state included
    (:func:`through_inputs`)."""
    _check_available(model)
    fns = _built(model) or _functions(model, False)

    def jac(t, y):
        y = np.asarray(y, dtype=float)
        _, ((state, _), (inputs, _), *_), _ = _evaluate(model, fns, [t], y[None, :], None)
        return state[0] + through_inputs(model, t, y, inputs[0])

    return jac


def _evaluate(model, fns, T, Y, R):
    """``(f, groups, constraints)`` at the states ``Y`` (N, n_states), each array
    with a first axis of length N: ``groups`` holds ``(d f/d x, d lambda/d x)``
    per column group (state, inputs, constants).

    The accelerations are those of ``model.rhs`` (the scheme's), the
    multipliers those of :meth:`NumericModel.multipliers`; for many states,
    both from the index-1 system that every exact scheme solves, and every
    state in one call of each generated function (on C; with NumPy, vectorized
    over the states: :func:`_numpy_rows`).  A stabilized scheme's
    accelerations come from its :class:`AccelerationSystem`, with the inputs
    ``R`` (:func:`_stabilization_derivatives.accelerations`).  The derivatives
    then solve the stacked systems.
    """
    dynamics, derivatives, dynamics_rows, derivative_rows, solved, _ = fns
    N, n, o, m = len(Y), model.n_q, model.n_u, model.n_u_dep
    names = _parts(model)
    if R is None:
        R = (np.array([model._r(t, y) for t, y in zip(T, Y)], dtype=float).reshape(N, -1)
             if model._inputs else np.zeros((N, 0)))
    if solved is not None and not names:  # C: both solves and the derivatives in one call
        f, D, constraints = solved(np.ascontiguousarray(T, dtype=float),
                                   np.ascontiguousarray(Y, dtype=float), model._p,
                                   np.ascontiguousarray(R, dtype=float))
        x, k = model.n_states, model.n_states + R.shape[1]
        groups = [(D[:, :x, a:b], D[:, x:, a:b] if m else None)
                  for a, b in ((0, x), (x, k), (k, D.shape[2]))]
        return f, groups, constraints
    from . import _stabilization_derivatives as stab
    system, values = _system(model), {}
    stacked = None
    if dynamics_rows is not None and N > 1 and not names:
        T, Y = np.ascontiguousarray(T, dtype=float), np.ascontiguousarray(Y, dtype=float)
        stacked = _stacked(model, dynamics_rows, derivative_rows, T, Y, R)
    if stacked is not None:
        qd, udot, lam, S, outputs = stacked
    else:
        at = []
        for t, y, r in zip(T, Y, R):
            terms = dynamics(t, y, model._p, list(r))
            if names:
                udot, found = stab.accelerations(model, system, t, y, r, terms)
            else:
                udot, found = model.scheme.accelerations(model, t, y, terms), {}
            lam = (np.linalg.lstsq(terms[3].T, terms[1] @ udot - terms[2], rcond=None)[0]
                   if m else np.zeros(0))
            at.append((terms, udot, lam, found,
                       derivatives(t, y, model._p, list(r) + list(udot) + list(lam))))
        qd, mass, _, vel_B, acc_K, _ = (np.stack(part) for part in zip(*(a[0] for a in at)))
        udot, lam = np.stack([a[1] for a in at]), np.stack([a[2] for a in at])
        values = {key: np.stack([a[3][key] for a in at]) for key in at[0][3]}
        outputs = [np.stack(part) for part in zip(*(a[4] for a in at))]
        S = _index1_matrices(mass, vel_B, acc_K, values.get("alpha"))
    tree = model.__dict__.get("_jacobian_tree")
    if tree is not None:  # the part of the spatial formulas, from their factors
        from ..engine import tree_jacobian_values
        outputs[1] = outputs[1] + tree_jacobian_values(outputs.pop(), tree)
    count = (len(outputs) - 2) // (4 if names else 3)  # column groups
    blocks, (h_y, c_y) = outputs[:3 * count], outputs[3 * count:3 * count + 2]
    extra = outputs[3 * count + 2:]
    groups = []
    for k in range(count):
        g_x, E_x, a_x = blocks[3 * k:3 * k + 3]
        if names and E_x.shape[2]:
            a_x = a_x + stab.second_row(system, names, values, extra[k], lam,
                                        (model.n_q_dep, o))
        solved = (np.linalg.solve(S, -np.concatenate([E_x, a_x], axis=1)) if E_x.shape[2]
                  else np.zeros((N, o + m, 0)))
        groups.append((np.concatenate([g_x.reshape(N, n, -1), solved[:, :o]], axis=1),
                       solved[:, o:] if m else None))
    return np.hstack([qd, udot]), groups, np.concatenate([h_y, c_y], axis=1)


def _stacked(model, dynamics_rows, derivative_rows, T, Y, R):
    """``(qd, udot, lam, S, outputs)`` of the states ``Y`` from the functions of
    many states, the index-1 systems ``S`` solved stacked; ``None`` where a NumPy
    model's vectorized code met a value that is not finite (:func:`_numpy_rows`:
    the states are then evaluated one by one)."""
    terms = dynamics_rows(T, Y, model._p, R)
    if terms is None:
        return None
    qd, mass, force, vel_B, acc_K, acc_f = terms
    S = _index1_matrices(mass, vel_B, acc_K)
    solved = np.linalg.solve(S, np.concatenate([force, -acc_f], axis=1)[..., None])[..., 0]
    udot, lam = solved[:, :model.n_u], solved[:, model.n_u:]
    outputs = derivative_rows(T, Y, model._p, np.hstack([R, udot, lam]))
    return None if outputs is None else (qd, udot, lam, S, list(outputs))


def _index1_matrices(mass, vel_B, acc_K, alpha=None):
    """``[[M, -B^T], [K, 0]]`` of each state (stacked), or ``M`` without
    dependent speeds; with a penalty ``alpha`` (N,), ``I/alpha`` in the
    lower right block."""
    N, o = mass.shape[:2]
    m = vel_B.shape[1]
    if not m:
        return mass
    S = np.zeros((N, o + m, o + m))
    S[:, :o, :o], S[:, :o, o:], S[:, o:, :o] = mass, -np.swapaxes(vel_B, 1, 2), acc_K
    if alpha is not None:
        S[:, o:, o:] = np.eye(m) / alpha[:, None, None]
    return S


def broadcast_rows(values, shape):
    """``values`` (an ndarray) as an array of ``shape``: ``values`` itself when
    it has that shape, else ``np.broadcast_to``'s read-only view (which costs
    microseconds per call, a part of each evaluation of a collocation NLP's
    derivatives at 100 nodes; the callers only read it)."""
    return values if values.shape == shape else np.broadcast_to(values, shape)


def jacobians(model, t, y, r=None, parameters=False, modes=None, directions=None,
              stabilization=10.0):
    r"""Exact :math:`\partial f/\partial(y, r, p)` of ``model.rhs`` at ``y`` (of
    :meth:`NumericModel.contact_dynamics` in ``modes`` for a model with contacts).

    See :meth:`NumericModel.jacobians`.
    """
    if model.contacts or modes is not None:
        from ._contact_derivatives import check_modes
        if not model.contacts:
            raise ModelError("modes: this model has no contacts")
        modes = check_modes(model, modes, directions)
    _check_available(model, modes is not None)
    fns = _functions(model, parameters)
    Y = np.asarray(y, dtype=float)
    many = Y.ndim == 2
    rows = Y if many else Y[None, :]
    if rows.ndim != 2 or rows.shape[1] != model.n_states:
        model._check_y(Y if not many else Y[0])  # raises, naming the states
        raise ValueError(f"y must have shape (N, {model.n_states}) for many states, "
                         f"got {Y.shape}")
    T = np.full(len(rows), t, dtype=float) if isinstance(t, (int, float)) or \
        np.ndim(t) == 0 else broadcast_rows(np.asarray(t, dtype=float), (len(rows),))
    if r is not None:
        r = np.atleast_1d(np.asarray(r, dtype=float))
        if r.shape[-1] != len(model.input_names):
            raise ValueError(f"r must have {len(model.input_names)} entries "
                             f"({', '.join(model.input_names) or 'the model has no inputs'})")
        R = broadcast_rows(r, (len(rows), r.shape[-1]))
    contact = {}
    if modes is not None:
        f, groups, constraints, contact = _evaluate_in_modes(
            model, fns, T, rows, None if r is None else R, modes, directions, stabilization,
            parameters)
    else:
        f, groups, constraints = _evaluate(model, fns, T, rows, None if r is None else R)
    if not many:
        f, constraints = f[0], constraints[0]
        groups = [(d[0], None if dl is None else dl[0]) for d, dl in groups]
        contact = {key: value[0] for key, value in contact.items()}
    m = model.n_u_dep
    if not many and modes is None:
        _keep_point(model, fns, parameters)
    return Jacobians._of(
        f=f, state=groups[0][0], inputs=groups[1][0],
        parameters=groups[2][0] if parameters else None,
        multipliers=groups[0][1] if m else None,
        multipliers_inputs=groups[1][1] if m else None,
        multipliers_parameters=groups[2][1] if m and parameters else None,
        constraints=constraints,
        state_names=tuple(model.state_names), input_names=tuple(model.input_names),
        parameter_names=tuple(model.constants), multiplier_names=tuple(
            model.multiplier_names or ()),
        contact_forces=contact.get("forces"), contact_forces_state=contact.get("state"),
        contact_forces_inputs=contact.get("inputs"),
        contact_forces_parameters=contact.get("parameters"),
        contact_names=tuple(c["name"] for c in model.contacts))


#: the fields of :class:`Jacobians` the C module's ``solved_jacobian`` fills, in its order
_SOLVED = ("f", "constraints", "state", "inputs", "parameters", "multipliers",
           "multipliers_inputs", "multipliers_parameters")


def _keep_point(model, fns, parameters):
    """Keep with ``model`` the functions ``point(t, y)`` and ``given(r, t, y)``
    that give its :class:`Jacobians` at one state in one call of the C module
    (``solved_jacobian``), for the next calls with ``modes`` not given (and
    ``r`` not given, or given): a C model without contacts or a stabilized
    scheme (whose parts are solved in NumPy), with constants where they are
    asked for.  They return ``None`` for what they do not take as it comes
    (``y`` or ``r`` not an array of ``n_states`` or ``n_inputs`` floats, ``t``
    not a number), which :func:`jacobians` then checks and converts."""
    key = "_jacobian_point_p" if parameters else "_jacobian_point"
    one = fns[5]
    if key in model.__dict__ or one is None or model.contacts or _parts(model) \
            or (parameters and not len(model._p)):
        return
    fixed = dict.fromkeys(_SOLVED)
    fixed.update((f.name, None if f.default is MISSING else f.default)
                 for f in dataclass_fields(Jacobians) if f.name not in fixed)
    fixed.update(contact_forces=None, contact_forces_state=None, contact_forces_inputs=None,
                 contact_forces_parameters=None, state_names=tuple(model.state_names),
                 input_names=tuple(model.input_names), parameter_names=tuple(model.constants),
                 multiplier_names=tuple(model.multiplier_names or ()), contact_names=())
    # empty blocks: one read-only array each, not made anew per call
    x = model.n_states
    for name, shape in (("constraints", (model.n_q_dep + model.n_u_dep, x)),
                        ("inputs", (x, len(model.input_names)))):
        if not min(shape):
            fixed[name] = np.empty(shape)
            fixed[name].flags.writeable = False
    # the C function fills the slots of a new Jacobians: its member descriptors
    # (those of _SOLVED first) and the values of the fields it does not make
    members = tuple(getattr(Jacobians, name) for name in fixed)
    solved = partial(one, Jacobians, members, tuple(fixed.values()), model._p)
    model.__dict__[key + "_given_r"] = solved
    if not model._inputs:
        model.__dict__[key] = partial(solved, np.zeros(0))
        return
    shape = (model.n_states,)

    def point(t, y):
        if type(y) is not np.ndarray or y.shape != shape:
            return None
        return solved(np.array(model._r(t, y), dtype=float), t, y)

    model.__dict__[key] = point


def _evaluate_in_modes(model, fns, T, Y, R, modes, directions, stabilization, parameters):
    """:func:`_evaluate` for a model with contacts in ``modes``
    (:func:`_contact_derivatives.contact_evaluate` at each state), and the
    contact forces with their derivatives by column group."""
    from ._contact_derivatives import contact_evaluate
    if R is None:
        R = (np.array([model._r(t, y) for t, y in zip(T, Y)], dtype=float).reshape(len(Y), -1)
             if model._inputs else np.zeros((len(Y), 0)))
    at = [contact_evaluate(model, fns[1], t, y, r, modes, directions, stabilization,
                           parameters) for t, y, r in zip(T, Y, R)]
    groups = [(np.stack([a["groups"][g][0] for a in at]),
               np.stack([a["groups"][g][1] for a in at]) if model.n_u_dep else None)
              for g in range(len(at[0]["groups"]))]
    contact = {"forces": np.stack([a["forces"] for a in at])}
    for g, key in enumerate(("state", "inputs", "parameters")[:len(groups)]):
        contact[key] = np.stack([a["force_groups"][g] for a in at])
    return (np.stack([a["f"] for a in at]), groups,
            np.stack([a["constraints"] for a in at]), contact)
