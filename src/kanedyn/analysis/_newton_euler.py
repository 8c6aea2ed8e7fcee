r"""Newton–Euler check of a motion: do the forces explain each body's motion?

For every body :math:`k` with mass centre :math:`G_k`, at a state and its
accelerations,

.. math::

    R_k = m_k a_{G_k} - \sum F - \sum_i \lambda_i F_{ik}, \qquad
    H_k = I_k\alpha_k + \omega_k\times I_k\omega_k - \sum r\times F - \sum T
          - \sum_i \lambda_i M_{ik},

where the sums run over the applied loads on the body (moments about
:math:`G_k`) and :math:`F_{ik}, M_{ik}` is the force and moment on body
:math:`k` of the constraint force identified by vector constraint
:math:`i` (:mod:`kanedyn.modeling._vector_constraints`) per unit multiplier.  The
accelerations come from the equations of motion of whatever formulation
produced the model, but the residuals are built from the bodies' kinematics
alone (Newton's and Euler's laws), so they are an independent check: they
vanish only if the motion is one the identified constraint forces can
produce.

The multipliers are Kane's (the equations' own, :meth:`NumericModel.multipliers`)
when the model has them, else fitted by least squares to the residuals (then
a non-zero residual means no constraint forces along the identified
directions explain the motion).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from ..numerics import compile_python, generate_python
from .._errors import ModelError
from ..engine import SAMPLE_SEEDS, add, cross, inertia_components, matvec

__all__ = ["check_newton_euler", "NewtonEulerCheck"]


@dataclass(frozen=True)
class NewtonEulerCheck:
    """Newton–Euler residuals of a motion, body by body.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Times, s.
    bodies : tuple of str
        Body names, in the order of the residual arrays.
    force_residual : ndarray, shape (N, n_bodies, 3)
        :math:`m a_G - \\sum F` including the identified constraint forces,
        N, inertial components.
    moment_residual : ndarray, shape (N, n_bodies, 3)
        Moment residual about each mass centre, N m (zero for particles).
    multipliers : dict
        ``{name: ndarray (N,)}``: the identified constraint-force magnitudes
        used.
    source : str
        Where the multipliers came from: ``"equations"``, ``"fit"`` or
        ``"given"``.
    inertia_scale : float
        Largest component of :math:`m a_G` and of the moment of the inertia
        forces met (N, N m): a scale for the residuals.
    unidentified : tuple of str
        Multipliers of constraints given as scalar equations, whose forces no
        vector constraint identifies: the residuals hold those forces (they
        measure them, not an error of the motion).
    """

    t: np.ndarray
    bodies: tuple
    force_residual: np.ndarray
    moment_residual: np.ndarray
    multipliers: dict
    source: str
    inertia_scale: float
    unidentified: tuple = ()

    @property
    def max_force(self):
        """Largest force-residual component, N."""
        return float(np.max(np.abs(self.force_residual), initial=0.0))

    @property
    def max_moment(self):
        """Largest moment-residual component, N m."""
        return float(np.max(np.abs(self.moment_residual), initial=0.0))

    @property
    def force_history(self):
        """Largest force-residual component over the bodies at each time, shape (N,), N."""
        return np.max(np.abs(self.force_residual), axis=(1, 2), initial=0.0)

    @property
    def moment_history(self):
        """Largest moment-residual component over the bodies at each time, shape (N,), N m."""
        return np.max(np.abs(self.moment_residual), axis=(1, 2), initial=0.0)

    @property
    def max(self):
        """Largest residual component (force or moment)."""
        return max(self.max_force, self.max_moment)

    def per_body(self):
        """``{body: (max force residual, max moment residual)}``."""
        return {name: (float(np.max(np.abs(self.force_residual[:, k]), initial=0.0)),
                       float(np.max(np.abs(self.moment_residual[:, k]), initial=0.0)))
                for k, name in enumerate(self.bodies)}

    def table(self):
        """The per-body maxima as text."""
        lines = [f"Newton-Euler residuals (multipliers: {self.source}; "
                 f"inertia scale {self.inertia_scale:.3g})",
                 *([f"  they hold the forces of {', '.join(self.unidentified)}: constraints "
                    "given as scalar equations identify no force on a body"]
                   if self.unidentified else []),
                 f"  {'body':<16} {'force [N]':>12} {'moment [N m]':>14}"]
        for name, (f, m) in self.per_body().items():
            lines.append(f"  {name:<16} {f:12.3e} {m:14.3e}")
        return "\n".join(lines)


def _close(prog, a, b):
    """Whether two component tuples agree at random points."""
    for seed in SAMPLE_SEEDS[:2]:
        va, vb = prog.shadow(a, seed), prog.shadow(b, seed)
        scale = 1.0 + max(abs(x) for x in list(va) + list(vb))
        if any(not abs(x - y) <= 1e-9 * scale for x, y in zip(va, vb)):
            return False
    return True


class _Owners:
    """Which body a load's point or frame belongs to."""

    def __init__(self, eom, loads_on):
        self.eom = eom
        self.kin = eom._kinematics
        self.bodies = list(eom.bodies)
        self.given = {}
        for key, body in (loads_on or {}).items():
            if body is not None and body not in self.bodies:
                raise ModelError(f"loads_on: {body!r} is not a body of this model")
            self.given[key] = body

    def _index(self, body):
        return None if body is None else self.bodies.index(body)

    def point(self, point, what):
        if point in self.given:
            return self._index(self.given[point])
        for k, b in enumerate(self.bodies):
            if b.masscenter is point:
                return k
        kin, prog = self.kin, self.kin.prog
        v = kin.velocity(point)
        found = []
        for k, b in enumerate(self.bodies):
            if not isinstance(b, me.RigidBody):
                continue
            r = kin.position(point, b.masscenter)
            if r is None:
                continue
            rigid = add(kin.velocity(b.masscenter), cross(kin.angular_velocity(b.frame), r))
            if _close(prog, v, rigid):
                found.append(k)
        if len(found) == 1:
            return found[0]
        if not found and _close(prog, v, (sm.S.Zero,) * 3):
            return None  # a point fixed in the inertial frame: ground
        names = ", ".join(self.bodies[k].name for k in found)
        problem = (f"is fixed in several bodies ({names})" if found
                   else "moves with none of the bodies")
        raise ModelError(f"{what} acts at point {point.name}, which {problem}; say which "
                         f"body it acts on with loads_on={{{point.name}: body}}")

    def frame(self, frame, what):
        if frame in self.given:
            return self._index(self.given[frame])
        for k, b in enumerate(self.bodies):
            if isinstance(b, me.RigidBody) and b.frame is frame:
                return k
        if _close(self.kin.prog, self.kin.angular_velocity(frame), (sm.S.Zero,) * 3):
            return None  # a frame fixed in the inertial frame: ground
        raise ModelError(f"{what} acts on frame {frame}, which is no body's frame; say "
                         f"which body it acts on with loads_on={{{frame}: body}}")


def _wrench(kin, body, kind, location, vector):
    """Force and moment about the mass centre of ``body`` (6 components)."""
    if kind == "torque" or isinstance(location, me.ReferenceFrame):
        return (sm.S.Zero,) * 3 + tuple(vector)
    if isinstance(body, me.Particle):
        # a force on a particle acts at the particle (a reaction on a particle,
        # ``relative_to=particle``, is located at the constrained point)
        return tuple(vector) + (sm.S.Zero,) * 3
    r = kin.position(location, body.masscenter)
    if r is None:
        raise ModelError(f"the position of point {location.name} relative to the mass "
                         f"centre of {body.name} is not defined; locate it (set_pos)")
    return tuple(vector) + tuple(cross(r, vector))


def _build(model, loads_on):
    """Generate the function returning inertia, applied and unit constraint wrenches."""
    eom = getattr(model, "_eom", None)
    if eom is None:
        raise ModelError("the Newton-Euler check needs the model's equations, which an "
                         "unpickled NumericModel does not carry; rebuild it with "
                         "eom.numeric(...)")
    for body in eom.bodies:
        if not isinstance(body, (me.RigidBody, me.Particle)):
            raise ModelError(f"the Newton-Euler check covers rigid bodies and particles; "
                             f"body {body.name!r} is a {type(body).__name__}, whose elastic "
                             "motion it has no residual for")
    prog, table, kin = eom._program, eom._table, eom._kinematics
    owners = _Owners(eom, loads_on)
    bodies = list(eom.bodies)
    nb = len(bodies)
    zero6 = [(sm.S.Zero,) * 6 for _ in range(nb)]
    udot = table.udot
    inertia = []
    for body, terms, (force0, torque0) in zip(bodies, eom._body_terms, eom._inertial):
        m = kin.internal(body.mass, f"mass of {body.name}")
        accel = [sum((V[i] * ud for V, ud in zip(terms.partial_velocities, udot)), sm.S.Zero)
                 for i in range(3)]
        force = tuple(m * a + f for a, f in zip(accel, force0))
        if isinstance(body, me.RigidBody):
            _, I_N, _ = inertia_components(kin, body, f"body {body.name}")
            alpha = [sum((W[i] * ud for W, ud in zip(terms.partial_angular_velocities, udot)),
                         sm.S.Zero) for i in range(3)]
            moment = add(matvec(I_N, alpha), torque0)
        else:
            moment = (sm.S.Zero,) * 3
        inertia.append(force + tuple(moment))

    applied = [list(w) for w in zero6]
    for location, vec in eom._load_vectors:
        what = f"the load on {location}"
        if isinstance(location, me.ReferenceFrame):
            k = owners.frame(location, what)
        else:
            k = owners.point(location, what)
        if k is None:
            continue
        w = _wrench(kin, bodies[k], "torque" if isinstance(location, me.ReferenceFrame)
                    else "force", location, vec)
        applied[k] = [a + b for a, b in zip(applied[k], w)]

    names, units = [], []
    for name, actions in eom._identified:
        unit = [list(w) for w in zero6]
        for a in actions:
            if a.ground:
                continue
            if a.body is not None:
                k = bodies.index(a.body) if a.body in bodies else None
                if k is None:
                    raise ModelError(f"constraint {name}: {a.body.name} is not a body of "
                                     "this model")
            elif a.kind == "torque":
                k = owners.frame(a.location, f"constraint torque {name}")
            else:
                k = owners.point(a.location, f"constraint force {name}")
            if k is None:
                continue
            w = _wrench(kin, bodies[k], a.kind, a.location, a.vector)
            unit[k] = [x + y for x, y in zip(unit[k], w)]
        names.append(name)
        units.append(unit)

    subs = model._substitutions

    def sub(e):
        return prog.subs(sm.sympify(e, strict=True), subs) if subs else sm.sympify(e, strict=True)

    args = dict(model._functions["dynamics"][0])
    args["r"] = list(args["r"]) + list(udot)
    k = len(names)
    outputs = [((nb, 6), [sub(e) for w in inertia for e in w]),
               ((nb, 6), [sub(e) for w in applied for e in w]),
               ((k, nb * 6), [sub(e) for u in units for w in u for e in w])]
    source = generate_python(prog, "newton_euler", args, outputs)
    return compile_python(source, "newton_euler"), tuple(names)


def check_newton_euler(model, t=None, y=None, *, udot=None, multipliers=None,
                       loads_on=None):
    r"""Newton–Euler residuals of each body along a motion.

    Parameters
    ----------
    model : NumericModel or SimulationResult
        A model (then give ``t`` and ``y``) or a simulation (its times and
        states are used).
    t : float or array_like, shape (N,), optional
    y : array_like, shape (n_states,) or (n_states, N), optional
    udot : array_like, shape (n_u,) or (n_u, N), optional
        Accelerations; default: the model's equations of motion
        (``model.rhs``).
    multipliers : None, "fit" or dict
        ``None``: the equations' own multipliers when every identified force
        has one (Kane's method, Lagrange's), else fitted; ``"fit"``: least
        squares over all residual components; a dict ``{name: value or
        array (N,)}``: given.
    loads_on : dict, optional
        ``{Point or ReferenceFrame: body}`` for loads at points fixed in
        several bodies (e.g. joint points); ``None`` as body: ground.

    Returns
    -------
    NewtonEulerCheck

    Raises
    ------
    ModelError
        When a load cannot be assigned to a body (the message names the
        point), the model has a flexible body, or the model was unpickled
        without its equations.
    """
    from ..simulation import SimulationResult
    if isinstance(model, SimulationResult):
        if t is not None or y is not None:
            raise ValueError("give either a SimulationResult or a model with t and y")
        model, t, y = model.model, model.t, model.y
    if t is None or y is None:
        raise ValueError("give the times t and states y to check")
    ts = np.atleast_1d(np.asarray(t, dtype=float))
    Y = np.asarray(y, dtype=float)
    Y = Y.reshape(-1, 1) if Y.ndim == 1 else Y
    if Y.shape != (model.n_states, ts.size):
        raise ValueError(f"y must have shape ({model.n_states}, {ts.size})")
    cached = getattr(model, "_newton_euler", None)
    if cached is None or cached[0] != loads_on:
        fn, names = _build(model, loads_on)
        model._newton_euler = (loads_on, fn, names)
    _, fn, names = model._newton_euler
    if udot is not None:
        UD = np.asarray(udot, dtype=float)
        UD = UD.reshape(-1, 1) if UD.ndim == 1 else UD
        if UD.shape != (model.n_u, ts.size):
            raise ValueError(f"udot must have shape ({model.n_u}, {ts.size})")
    if isinstance(multipliers, dict):
        source = "given"
        missing = set(names) - set(multipliers)
        if missing:
            raise ValueError(f"multipliers missing for {', '.join(sorted(missing))}")
    elif multipliers == "fit" or not set(names) <= set(model.multiplier_names):
        source = "fit"
    elif multipliers is None:
        source = "equations"
    else:
        raise ValueError(f"multipliers must be None, 'fit' or a dict, not {multipliers!r}")

    n, nb = ts.size, len(model._eom.bodies)
    force_res = np.zeros((n, nb, 3))
    moment_res = np.zeros((n, nb, 3))
    lam_out = np.zeros((len(names), n))
    scale = 0.0
    for j in range(n):
        tj, yj = ts[j], Y[:, j]
        try:
            ud = UD[:, j] if udot is not None else model.rhs(tj, yj)[model.n_q:]
        except np.linalg.LinAlgError as exc:
            raise ModelError(f"no accelerations to check at t={tj:g}: the equations of "
                             f"motion are singular there ({exc})") from None
        r = list(model._r(tj, yj)) + list(ud)
        inertia, applied, units = fn(tj, yj, model._p, r)
        units = units.reshape(len(names), nb, 6)
        base = inertia - applied
        if not names:
            lam = np.zeros(0)
        elif source == "given":
            lam = np.array([np.broadcast_to(multipliers[nm], (n,))[j] for nm in names])
        elif source == "equations":
            values = model.multipliers(tj, yj, udot=ud)
            lam = np.array([values[nm] for nm in names])
        else:
            lam = np.linalg.lstsq(units.reshape(len(names), -1).T, base.ravel(),
                                  rcond=None)[0]
        res = base - np.tensordot(lam, units, axes=1) if names else base
        force_res[j], moment_res[j] = res[:, :3], res[:, 3:]
        lam_out[:, j] = lam
        scale = max(scale, float(np.max(np.abs(inertia), initial=0.0)))
    return NewtonEulerCheck(t=ts, bodies=tuple(b.name for b in model._eom.bodies),
                            force_residual=force_res, moment_residual=moment_res,
                            multipliers=dict(zip(names, lam_out)), source=source,
                            inertia_scale=scale,
                            unidentified=tuple(name for name in model._eom.multiplier_names
                                               if name not in names))
