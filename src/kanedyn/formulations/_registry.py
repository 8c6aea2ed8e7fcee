"""The formulation registry: ``formulate(model, method=...)``.

Every formulation takes the same model description (a
``sympy.physics.mechanics.System`` or KanesMethod keywords) and returns an
:class:`EquationsOfMotion`.  Kane's method is the reference; later formulations
register themselves here under their own names.
"""

from __future__ import annotations

from .._errors import ModelError
from .._progress import NO_PROGRESS, as_progress
from ..modeling import FlexibleBody, InertialElement, parse_model

__all__ = ["kane", "formulate", "FORMULATIONS", "register_formulation"]

#: name -> ``derive(spec, progress=..., **options) -> EquationsOfMotion`` of each
#: formulation; :func:`formulate` looks ``method`` up here.
FORMULATIONS = {}
_RIGID_ONLY = set()  # formulations that cannot take flexible bodies


def register_formulation(name, derive, flexible_bodies=True):
    """Register ``derive(spec, progress=..., **options) -> EquationsOfMotion``.

    Parameters
    ----------
    name : str
        The key of :data:`FORMULATIONS` (``formulate(..., method=name)``).
    derive : callable
    flexible_bodies : bool
        Whether ``derive`` takes :class:`kanedyn.FlexibleBody` objects; when
        not, :func:`formulate` refuses models with one, naming the body.
    """
    FORMULATIONS[name] = derive
    if flexible_bodies:
        _RIGID_ONLY.discard(name)
    else:
        _RIGID_ONLY.add(name)


def formulate(*args, method="kane", progress=False, scheme=None, **kwargs):
    r"""Equations of motion of a model by the named formulation.

    Parameters
    ----------
    *args, **kwargs
        A ``sympy.physics.mechanics.System``, or the keywords of
        :func:`kanedyn.kane`.
    method : str
        A key of :data:`FORMULATIONS`:

        ``"kane"``
            Kane's method (the reference).
        ``"lagrange"``
            Lagrange's equations with multipliers (speeds :math:`\dot q`),
            dependent rates eliminated with a fixed partition where one
            exists, drift projected.
        ``"lagrange-index1"``, ``"lagrange-baumgarte"``, ``"lagrange-projection"``
            The same equations as an index-1 DAE: plain, with Baumgarte
            stabilization, with projection onto the constraints.
        ``"penalty"``, ``"augmented-lagrangian"``
            Bayo's penalty and augmented-Lagrangian formulations.
        ``"udwadia-kalaba"``
            Udwadia–Kalaba's explicit equations.
        ``"partitioning"``
            Generalized coordinate partitioning (Wehage–Haug).
        ``"maggi"``
            Maggi's equations (null-space projection).
        ``"augmented-lagrangian-index3"``
            Bayo & Ledesma's index-3 augmented Lagrangian with mass-orthogonal
            projections, integrated by its own fixed-step trapezoidal rule
            (:class:`kanedyn.schemes.AugmentedLagrangianIndex3`): passes
            singular configurations; holonomic constraints only.
        ``"orthogonal-complement"``
            The natural orthogonal complement (Cyril, Angeles & Misra 1991):
            each body's Newton–Euler equations projected with its twist map
            T_b, M = Σ_b T_bᵀ M_b T_b assembled numerically and solved by
            Cholesky's factorization.
        ``"augmented"``
            The augmented (vakonomic) Lagrangean: a different motion for
            nonholonomic systems.

        The Lagrange-based variants share one derivation and differ in their
        constraint scheme (:mod:`kanedyn.schemes`).

        Every built-in formulation takes :class:`kanedyn.FlexibleBody`
        objects: Kane's method and the orthogonal complement through each
        body's quasi-coordinate Newton–Euler block (twist map
        :math:`\partial w/\partial u` of :math:`w = (v, \omega, \zeta)`,
        generalized mass :math:`M_b(\eta)`), the Lagrange family and
        ``"augmented"`` through its kinetic energy :math:`\tfrac12
        w^TM_b(\eta)w` and generalized forces; they agree to round-off.  A
        formulation registered with ``flexible_bodies=False`` refuses them
        with a :class:`ModelError` naming the body.
    progress : bool
        Print progress of long derivations to stderr.
    scheme : str or Scheme, optional
        Replace the formulation's constraint scheme (e.g.
        ``kd.schemes.Baumgarte(alpha=20.0, beta=20.0)``).

    Returns
    -------
    EquationsOfMotion
    """
    try:
        derive = FORMULATIONS[method]
    except KeyError:
        raise ModelError(f"unknown formulation {method!r}; available: "
                         f"{', '.join(sorted(FORMULATIONS))}") from None
    options = {k: kwargs.pop(k) for k in ("explicit_kinematics",) if k in kwargs}
    spec = parse_model(*args, **kwargs)
    if method in _RIGID_ONLY:
        flexible = [b for b in spec.bodies if isinstance(b, (FlexibleBody, InertialElement))]
        if flexible:
            takes = sorted(set(FORMULATIONS) - _RIGID_ONLY)
            what = ("flexible body" if isinstance(flexible[0], FlexibleBody)
                    else type(flexible[0]).__name__)
            raise ModelError(
                f"the {method!r} formulation does not take flexible bodies or inertial "
                f"elements ({what} {flexible[0].name!r}); use one of {', '.join(takes)}")
    eom = derive(spec, progress=as_progress(progress), **options)
    if scheme is not None:
        object.__setattr__(eom, "_scheme", scheme)
        eom.scheme  # noqa: B018  (resolves the scheme now: an unknown one is refused here)
    return eom


def _with_scheme(derive, method, scheme):
    """A formulation: ``derive``'s equations, solved with the scheme named ``scheme``.

    Schemes are numerics (:mod:`kanedyn.numerics.schemes`); formulations name
    them, and the numerical model resolves the name.
    """
    def derive_with_scheme(spec, progress=NO_PROGRESS, **options):
        eom = derive(spec, progress=progress, **options)
        # set once, before anyone sees the result
        object.__setattr__(eom, "_scheme", scheme)
        object.__setattr__(eom, "method", method)
        return eom
    derive_with_scheme.__doc__ = f"{derive.__name__} with the {scheme!r} constraint scheme."
    return derive_with_scheme


def kane(*args, progress=False, explicit_kinematics=True, **kwargs):
    r"""Kane's equations of motion, derived by kanedyn.

    Parameters
    ----------
    system : sympy.physics.mechanics.System, optional
        A complete model (joints, bodies, loads, constraints).  Alternatively
        give the keywords below, as for SymPy's ``KanesMethod``.
    frame : ReferenceFrame
        The inertial frame.
    q_ind, u_ind : sequence of dynamicsymbols
        Independent generalized coordinates and speeds.
    kd_eqs : sequence of expressions
        Kinematic differential equations ``f(q', u, q, t) = 0``, linear in q'
        and u.
    q_dep, u_dep : sequence of dynamicsymbols, optional
        Dependent coordinates and speeds (aliases ``q_dependent``,
        ``u_dependent``).
    configuration_constraints : sequence of expressions, optional
        Holonomic constraints ``f(q, t) = 0``, one per dependent coordinate.
    velocity_constraints : sequence of expressions, optional
        ``f(u, q, t) = 0``, one per dependent speed, including the time
        derivatives of the configuration constraints.  Derived from the
        configuration constraints when omitted.
    acceleration_constraints : sequence of expressions, optional
        Defaults to the time derivative of the velocity constraints.
    u_auxiliary : sequence of dynamicsymbols, optional
        Auxiliary speeds that expose constraint forces
        (:attr:`EquationsOfMotion.auxiliary_equations`).
    kd_inputs : sequence of dynamicsymbols, optional
        Specified inputs (functions of time) the kinematic differential
        equations may contain: the inputs of first-order states, such as an
        actuator's activation :math:`\dot a = c(t)` (an undeclared symbol there
        is refused as a forgotten speed).
    bodies : sequence of RigidBody or Particle
    loads : sequence of Force, Torque or (Point | ReferenceFrame, Vector)
        (alias ``forcelist``).
    constraints : sequence of VectorConstraint, optional
        Velocity constraints in vector form (:class:`kanedyn.PointVelocity`,
        :class:`kanedyn.AngularVelocity`, :class:`kanedyn.OrthogonalVelocities`),
        each with the constraint force it identifies; they follow the
        explicit ``velocity_constraints`` and count towards ``u_dep``.  Their
        magnitudes: :meth:`NumericModel.constraint_forces`; a check:
        :func:`kanedyn.check_newton_euler`.
    contacts : sequence of Contact, optional
        Points of bodies touching surfaces, with Coulomb friction: their
        normal and friction forces are found with the accelerations at
        evaluation time (see :func:`kanedyn.simulate`).
    potential_energy : expression, optional
        Used only to report total energy; defaults to the sum of the bodies'
        ``potential_energy`` attributes.
    explicit_kinematics : bool
        As in SymPy: ``mass_matrix_full`` has an identity kinematic block.
    progress : bool
        Print progress of long derivations to stderr.

    Returns
    -------
    EquationsOfMotion

    Examples
    --------
    >>> import sympy as sm, sympy.physics.mechanics as me, kanedyn as kd
    >>> q, u = me.dynamicsymbols('q u')
    >>> m, l, g = sm.symbols('m l g')
    >>> N, A = me.ReferenceFrame('N'), me.ReferenceFrame('A')
    >>> A.orient_axis(N, N.z, q)
    >>> A.set_ang_vel(N, u * N.z)
    >>> O = me.Point('O'); O.set_vel(N, 0)
    >>> P = O.locatenew('P', l * A.x); P.v2pt_theory(O, N, A)
    l*u(t)*A.y
    >>> bob = me.Particle('bob', P, m)
    >>> eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
    ...               bodies=[bob], loads=[(P, -m * g * N.y)])
    >>> eom.mass_matrix
    Matrix([[l**2*m]])
    """
    return formulate(*args, method="kane", progress=progress,
                     explicit_kinematics=explicit_kinematics, **kwargs)


def _register_builtin():
    from ._kane import derive_kane
    from ._lagrange import derive_augmented, derive_lagrange
    from ._orthogonal_complement import derive_orthogonal_complement
    register_formulation("kane", derive_kane)
    register_formulation("lagrange", derive_lagrange)
    register_formulation("augmented", derive_augmented)
    register_formulation("orthogonal-complement", derive_orthogonal_complement)
    for name, scheme in (("lagrange-index1", "index-1"),
                         ("lagrange-baumgarte", "baumgarte"),
                         ("lagrange-projection", "projection"),
                         ("penalty", "penalty"),
                         ("augmented-lagrangian", "augmented-lagrangian"),
                         ("udwadia-kalaba", "udwadia-kalaba"),
                         ("partitioning", "partitioning"),
                         ("maggi", "null-space"),
                         ("augmented-lagrangian-index3", "augmented-lagrangian-index3")):
        register_formulation(name, _with_scheme(derive_lagrange, name, scheme))


_register_builtin()
