r"""The power of each load, of prescribed motion and of flexible bodies' damping.

Along a motion the stored energy :math:`E = T + V` changes at the rate of the
power of everything :math:`E` does not hold.  Here that power is taken apart:

* each load :math:`l` of the equations (a force :math:`F_l` at a point, a
  torque :math:`M_l` on a frame): :math:`P_l = F_l\cdot v_l` or
  :math:`M_l\cdot\omega_l`, with the whole velocity, its explicitly
  time-dependent part (prescribed motion) included, and the constraint
  forces that auxiliary speeds expose given their values
  (:meth:`NumericModel.auxiliary`);
* the constraint forces that drive prescribed motion and that no auxiliary
  speed exposes: with
  :math:`v^t_k, \omega^t_k` the velocities at zero speeds (the explicitly
  time-dependent part, or the part that coordinates without speeds of their
  own give, such as a controller's pitch state turning a blade),

  .. math::

      P_\text{prescribed} = \sum_k \left[m_k a_k\cdot v^t_k
          + (I_k\alpha_k + \omega_k\times I_k\omega_k)\cdot\omega^t_k\right]
          + \sum_b w^t_b\cdot\left(M_b\dot w_b + \beta_b - F_b\right)
          - \sum_l F_l\cdot v^t_l,

  the power of all forces on the bodies along :math:`v^t` minus that of the
  loads (zero where no motion is prescribed, or where auxiliary speeds
  expose every force that drives it); a flexible body or inertial element
  :math:`b` contributes through its block (:mod:`kanedyn.formulations._flexible`:
  :math:`w^t_b` its body-frame velocities at zero speeds, :math:`M_b\dot w_b
  + \beta_b` its inertia forces, :math:`F_b` its gravity, elastic and
  damping forces);
* each flexible body's modal damping, :math:`-\dot\eta^T C\dot\eta`.

The gravity parts of the loads (:math:`F_l(g) - F_l(0)` at the gravity
symbol :math:`g`) are given apart: where the model declares a potential
energy, that is taken to be theirs (as :func:`power_balance` does).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..engine import dot, inertia_components, matvec, name_of
from ._inverse import _equations, _workspace
from ._jacobians import inputs_follow_state
from .backends._python import compile_python, generate_python

__all__ = ["LoadPowers", "load_powers"]


@dataclass(frozen=True)
class LoadPowers:
    r"""Powers at a set of states, W.

    Attributes
    ----------
    loads : numpy.ndarray, shape (n_loads, N)
        Each load's power without its gravity part, in the order of
        ``eom.loads``.
    gravity : numpy.ndarray, shape (n_loads, N)
        The power of each load's gravity part (zero without a gravity symbol).
    prescribed : numpy.ndarray or None, shape (N,)
        :math:`P_\text{prescribed}`; ``None`` where a flexible body whose
        motion is prescribed in part has no block with the equations (saved
        by an older kanedyn: its inertia forces are not taken apart here).
    damping : dict
        ``{flexible body name: ndarray (N,)}`` for the bodies with damping.
    moved_flexible : tuple of str
        The flexible bodies and inertial elements whose motion is prescribed
        in part.
    """

    loads: np.ndarray
    gravity: np.ndarray
    prescribed: np.ndarray | None
    damping: dict
    moved_flexible: tuple = ()


def _specification(model, gravity):
    """Arguments and outputs of the generated function; whether it gives the
    prescribed motion's power."""
    eom = _equations(model)
    prog, kin = _workspace(model)
    if eom.method != "kane" or kin is None:
        raise ModelError(f"the power of each load needs equations derived by kd.kane, not by "
                         f"{eom.method!r}")
    table = eom._table
    key = "auxiliary" if "auxiliary" in model._functions else "dynamics"
    args = dict(model._functions[key][0])
    udot = list(table.udot)
    args["r"] = list(args["r"]) + udot
    subs = model._substitutions
    aux_zero = {ua: 0 for ua in table.u_aux}
    at_rest = {**aux_zero, **{s: 0 for s in table.u}}

    def sub(e):
        e = prog.subs(e, aux_zero) if aux_zero else e
        return prog.subs(e, subs) if subs else e

    def velocity(loc):
        return (kin.angular_velocity(loc) if isinstance(loc, me.ReferenceFrame)
                else kin.velocity(loc))

    def prescribed_part(vector):
        return tuple(prog.subs(c, at_rest) for c in vector)

    g = None if gravity is None else table.internal(gravity, "gravity")
    rest_power, grav_power, along_t = [], [], []
    for loc, vec in eom._load_vectors:
        base = velocity(loc)
        rest = tuple(prog.subs(c, {g: 0}) for c in vec) if g is not None else vec
        grav = tuple(c - d for c, d in zip(vec, rest))
        rest_power.append(sub(dot(rest, base)))
        grav_power.append(sub(dot(grav, base)))
        along_t.append(dot(vec, prescribed_part(base)))
    def reference_motion(body):
        # a flexible body's frame and origin; an inertial element's rates (no frame)
        if hasattr(body, "origin"):
            return prescribed_part(velocity(body.frame)) + prescribed_part(velocity(body.origin))
        return tuple(prog.subs(c, at_rest) for c in body._rates(kin))

    moved = [b.name for b in eom.bodies if not isinstance(b, (me.RigidBody, me.Particle))
             and any(not sm.sympify(c).is_zero for c in reference_motion(b))]
    outputs = [((len(rest_power),), rest_power), ((len(grav_power),), grav_power)]
    blocks = {block.body.name: block for block in getattr(eom, "_flexible_blocks", ())}
    o = len(udot)
    if all(name in blocks for name in moved):
        inertia_power = [_block_power(blocks[name], udot, prescribed_part) for name in moved]
        for terms, (force, torque) in zip(eom._body_terms, eom._inertial):
            terms = terms.on(prog)
            body = terms.body
            V, W = terms.partial_velocities, terms.partial_angular_velocities
            m = kin.internal(body.mass, f"mass of {body.name}")
            ma = tuple(m * sm.Add(*[V[s][i] * udot[s] for s in range(o)]) + force[i]
                       for i in range(3))
            inertia_power.append(dot(ma, prescribed_part(kin.velocity(body.masscenter))))
            if isinstance(body, me.RigidBody):
                I_N = inertia_components(kin, body, f"body {body.name}")[1]
                alpha = tuple(sm.Add(*[W[s][i] * udot[s] for s in range(o)])
                              for i in range(3))
                H_rate = tuple(a + t for a, t in zip(matvec(I_N, alpha), torque))
                inertia_power.append(dot(H_rate, prescribed_part(kin.angular_velocity(
                    body.frame))))
        outputs.append(((), [sub(sm.Add(*inertia_power) - sm.Add(*along_t))]))
    return args, outputs, tuple(moved)


def _block_power(block, udot, prescribed_part):
    r""":math:`w^t\cdot(M_b\dot w + \beta - F_b)` of one flexible block."""
    size, o = block.size, len(udot)
    wdot = [block.rate[b] + sm.Add(*[block.partials[s][b] * udot[s] for s in range(o)
                                     if block.partials[s][b] != 0]) for b in range(size)]
    along = prescribed_part(block.w)
    return sm.Add(*[along[a] * (sm.Add(*[block.mass[a][b] * wdot[b] for b in range(size)
                                         if block.mass[a][b] != 0])
                                 + block.bias[a] - block.active[a])
                    for a in range(size) if along[a] != 0])


def _function(model, gravity):
    """The generated (vectorized NumPy) function, kept by the model per gravity symbol."""
    cache = model._data.setdefault("load_powers", {})
    if gravity not in cache:
        args, outputs, moved = _specification(model, gravity)
        source = generate_python(_workspace(model)[0], "load_powers", args, outputs,
                                 vectorized=True, cse=True)
        cache[gravity] = (source, moved)
    source, moved = cache[gravity]
    key = ("load_powers", gravity)
    if key not in model._fn:
        model._fn[key] = compile_python(source, "load_powers")
    return model._fn[key], moved


def load_powers(model, t, y, gravity=None):
    r"""The powers of the module's text at states ``y`` and times ``t``.

    Parameters
    ----------
    model : NumericModel
        Built by ``eom.numeric(...)`` from equations of :func:`kanedyn.kane`.
    t : array_like, shape (N,)
        Times, s.
    y : array_like, shape (n_states, N)
        States there (consistent with the constraints).
    gravity : sympy.Symbol, optional
        The gravity constant (e.g. ``g``); without it no load has a gravity part.

    Returns
    -------
    LoadPowers
    """
    fn, moved = _function(model, gravity)
    ts = np.atleast_1d(np.asarray(t, dtype=float))
    Y = np.asarray(y, dtype=float).reshape(model.n_states, ts.size)
    n, k = model.n_q, len(model.aux_names)
    # inputs that follow the state (a rotor's BEM, a catenary: solved per state, each
    # keeping its last state) are read once per row where the rhs reads them too,
    # rather than once more after all the rows' accelerations
    by_row = bool(k or inputs_follow_state(model))
    udot = _accelerations(model, ts, Y) if not by_row else None
    rows = []
    with _solved_together(model, ts, Y):
        for i in range(ts.size):
            if by_row and not k:
                rows.append(list(model._input_values(ts[i], Y[:, i]))
                            + list(model.rhs(ts[i], Y[:, i])[n:]))
                continue
            inputs = list(model._input_values(ts[i], Y[:, i])) if model._inputs else []
            if k:
                forces = list(model.auxiliary(ts[i], Y[:, i]).values())
                rows.append(inputs + forces + list(model.rhs(ts[i], Y[:, i])[n:]))
            else:
                rows.append(inputs + list(udot[i]))
    R = np.array(rows, dtype=float).T.reshape(-1, ts.size)
    out = fn(ts, Y, model._p, R)
    loads = np.broadcast_to(out[0], (len(out[0]), ts.size)).astype(float)
    grav = np.broadcast_to(out[1], (len(out[1]), ts.size)).astype(float)
    prescribed = np.broadcast_to(out[2], ts.shape).astype(float) if len(out) > 2 else None
    return LoadPowers(loads, grav, prescribed, _damping_powers(model, Y), moved)


@contextlib.contextmanager
def _solved_together(model, ts, Y):
    """The inputs that follow the state and whose shared function solves many
    states at once (``solved_at``: a rotor's BEM loads on its blades' nodes), each
    solved once for all the states ``Y`` (shape (n_states, N)) at the times ``ts``
    while the context holds, rather than state by state, each warm-started from
    the last (the same values, to the solver's tolerance)."""
    sources = {}
    for _, inp in model._inputs:
        source = getattr(inp.value, "input_source", None) if inp.arity == 2 else None
        if source is not None and hasattr(source, "solved_at"):
            sources[id(source)] = source
    with contextlib.ExitStack() as stack:
        for source in sources.values():
            stack.enter_context(source.solved_at(ts, Y))
        yield


def _accelerations(model, ts, Y):
    r""":math:`\dot u` at each state, shape (N, n_u): from one vectorized evaluation
    (:meth:`NumericModel.rhs_batch`), or state by state (:meth:`NumericModel.rhs`)
    where that gives a value that is not finite (a singular system: ``rhs`` raises
    there, as it did here before).  One row at a time in C (``lanes=False``, the
    same values): a run's few thousand rows take milliseconds so, where loading
    the lane-wise code would first compile the whole module again (seconds)."""
    udot = model.rhs_batch(ts, Y.T, lanes=False)[:, model.n_q:]
    if not np.all(np.isfinite(udot)):
        udot = np.array([model.rhs(ts[i], Y[:, i])[model.n_q:] for i in range(ts.size)])
    return udot.reshape(ts.size, -1)


def _damping_powers(model, Y):
    """``{flexible body name: -u^T C u}`` for the flexible bodies with damping."""
    out = {}
    for body in _equations(model).bodies:
        damping = getattr(body, "damping", None)
        if damping is None or not np.any(damping):
            continue
        rows = [model.state_names.index(name_of(u)) for u in body.u]
        speeds = Y[rows]
        out[body.name] = -np.einsum("in,ij,jn->n", speeds, np.asarray(damping, float),
                                    speeds)
    return out
