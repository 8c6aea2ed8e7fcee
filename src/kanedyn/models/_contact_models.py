"""Models with contacts: friction that follows the normal force, stick-slip, impacts."""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from ..modeling import Contact, Ellipsoid, Plane, Sphere
from .._errors import ModelError
from ._base import ModelDefinition

__all__ = ["sphere_slug", "block_on_incline", "bead_in_tube", "bouncing_ball", "ladder",
           "falling_rod", "slug_ellipsoid"]

T = me.dynamicsymbols._t


def _free_particle(N, O, name="P", coords="x y z", speeds="u_x u_y u_z"):
    """A point with Cartesian coordinates in N and their rates as speeds."""
    q = me.dynamicsymbols(coords)
    u = me.dynamicsymbols(speeds)
    P = O.locatenew(name, q[0] * N.x + q[1] * N.y + q[2] * N.z)
    P.set_vel(N, u[0] * N.x + u[1] * N.y + u[2] * N.z)
    return q, u, P


def sphere_slug():
    """A particle sliding on the inside of a fixed sphere, zero gravity, Coulomb friction.

    Closed form (see REFERENCES): the path is a great circle, the normal force
    is :math:`N = m v^2/R` and :math:`v(t) = v_0/(1 + \\mu v_0 t/R)`: the
    simplest case of friction that follows the computed normal force.
    """
    m, R, mu = sm.symbols("m R mu", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    q, u, P = _free_particle(N, O)
    contact = Contact(P, Sphere(N, O, R, inside=True, name="wall"), mu_k=mu, name="wall")
    init = dict(zip(q, (1.0, 0.0, 0.0)))
    init.update(dict(zip(u, (0.0, 3.0, 1.0))))
    return ModelDefinition(
        name="sphere-slug", title="particle sliding inside a sphere with friction, zero g",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u),
                       kd_eqs=[a.diff() - b for a, b in zip(q, u)],
                       bodies=[me.Particle("slug", P, m)], contacts=[contact]),
        constants={m: 1.0, R: 1.0, mu: 0.2}, initial_state=init, t_end=5.0,
        symbols=dict(q=q, u=u, m=m, R=R, mu=mu, N=N, O=O, P=P),
        description="v(t) = v0 / (1 + mu v0 t / R), N = m v^2 / R, on a great circle.")


def block_on_incline():
    """A block (particle) on a plane whose inclination is held, then increased.

    The plane turns about the horizontal ``N.x`` axis through ``O``; its
    inclination is ``theta0`` until ``t1``, then grows at rate ``omega``.
    Coordinates of the block in the plane frame: ``s`` up the slope, ``h``
    along the plane normal.  Started sliding down, it stops (kinetic friction
    ``mu_k``), sticks (static ``mu_s``), and slips again once the inclination
    and the centrifugal force of the turning plane exceed what static friction
    holds.
    """
    s, h = me.dynamicsymbols("s h")
    us, uh = me.dynamicsymbols("u_s u_h")
    m, g, mu_k, mu_s = sm.symbols("m g mu_k mu_s", positive=True)
    theta0, omega, t1 = sm.symbols("theta_0 omega t_1", positive=True)
    theta = sm.Piecewise((theta0, T < t1), (theta0 + omega * (T - t1), True))
    N = me.ReferenceFrame("N")
    E = me.ReferenceFrame("E")  # the plane
    E.orient_axis(N, N.x, theta)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", s * E.y + h * E.z)
    block = me.Particle("block", P, m)
    block.potential_energy = m * g * P.pos_from(O).dot(N.z)
    contact = Contact(P, Plane(E, O, E.z, name="incline"), mu_k=mu_k, mu_s=mu_s,
                      name="incline")
    return ModelDefinition(
        name="block-on-incline",
        title="block on a plane whose inclination increases: stick-slip",
        kane_args=dict(frame=N, q_ind=[s, h], u_ind=[us, uh],
                       kd_eqs=[s.diff() - us, h.diff() - uh], bodies=[block],
                       loads=[(P, -m * g * N.z)], contacts=[contact]),
        constants={m: 1.0, g: 9.81, mu_k: 0.4, mu_s: 0.5, theta0: 0.2, omega: 0.5,
                   t1: 1.0},
        initial_state={s: 1.0, h: 0.0, us: -1.0, uh: 0.0}, t_end=3.0,
        symbols=dict(s=s, h=h, us=us, uh=uh, m=m, g=g, mu_k=mu_k, mu_s=mu_s,
                     theta0=theta0, omega=omega, t1=t1, N=N, E=E),
        description="Slides down and stops at t = v0/(g(mu_k cos th0 - sin th0)); "
                    "slips again when sin th - mu_s cos th = omega^2 d / g.")


def bead_in_tube(omega=1.0):
    r"""A bead in a square tube spinning about the vertical: two rough contacts at once.

    The tube (frame ``E``) turns at the constant rate ``omega`` (rad/s, an
    option: the initial state follows it) about the vertical ``N.z`` through
    ``O``; its axis is ``E.x``.  The bead (a particle, mass ``m``) has
    inertial coordinates ``x, y, z`` and their rates as speeds; it rests on
    the floor ``z = 0`` and against the side wall ``y_E = b`` (the wall's free
    side is ``y_E < b``), both with friction ``mu``.  Started at ``x_E = 1`` m
    moving towards the axis at 1 m/s relative to the tube, it is pressed
    against the wall by the Coriolis force and by the part of the centrifugal
    force across the tube, and slides on both; while it slides inwards
    (relative speed :math:`\dot x_E < 0`)

    .. math::

        \ddot x_E + 2\mu\Omega\dot x_E - \Omega^2 x_E = \mu (g + \Omega^2 b),
        \qquad N_{floor} = m g,\qquad N_{wall} = m(\Omega^2 b - 2\Omega\dot x_E).

    It stops where :math:`\dot x_E = 0` and sticks if
    :math:`\Omega^2 x_E \le \mu_s (g + \Omega^2 b)`; sticking, the floor
    carries the weight, the wall normal the centripetal force across the tube
    (:math:`m\Omega^2 b`, no jump at the stop) and the frictions together the
    one along it (:math:`m\Omega^2 x_E`, inwards).  Faster (``omega=2.5``)
    the slip reverses and the bead slides out, leaving the wall where
    :math:`\dot x_E = \Omega b / 2`.  The wall does work on the bead: the
    energy balance counts it.
    """
    m, g, mu, b = sm.symbols("m g mu b", positive=True)
    omega = float(omega)
    N = me.ReferenceFrame("N")
    E = me.ReferenceFrame("E")  # the tube
    E.orient_axis(N, N.z, omega * T)
    O = me.Point("O")
    O.set_vel(N, 0)
    q, u, P = _free_particle(N, O)
    bead = me.Particle("bead", P, m)
    bead.potential_energy = m * g * q[2]
    contacts = [Contact(P, Plane(E, O, E.z, name="floor"), mu_k=mu, name="floor"),
                Contact(P, Plane(E, O.locatenew("W", b * E.y), -E.y, name="wall"), mu_k=mu,
                        name="wall")]
    values = {m: 1.0, g: 9.81, mu: 0.3, b: 0.05}
    # at t = 0 the tube frame is N: x_E = 1, y_E = b, relative velocity -1 m/s along E.x
    init = dict(zip(q, (1.0, values[b], 0.0)))
    init.update(dict(zip(u, (-1.0 - omega * values[b], omega * 1.0, 0.0))))
    return ModelDefinition(
        name="bead-in-tube",
        title="bead in a spinning square tube: floor and wall friction, slip then stick",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u),
                       kd_eqs=[a.diff() - v for a, v in zip(q, u)], bodies=[bead],
                       loads=[(P, -m * g * N.z)], contacts=contacts),
        constants=values, initial_state=init, t_end=1.0,
        symbols=dict(q=q, u=u, m=m, g=g, mu=mu, b=b, omega=omega, N=N, E=E, P=P),
        description="Slides towards the axis on floor and wall, stops and sticks: the "
                    "wall normal force m (Omega^2 b - 2 Omega x_E') falls to m Omega^2 b "
                    "without a jump; omega=2.5: reverses and leaves the wall.")


def bouncing_ball(restitution=0.8):
    """A ball (particle, radius ``r``) dropped on a floor; Newton/Poisson restitution."""
    _check_fraction("bouncing-ball", "restitution", restitution)
    x, z = me.dynamicsymbols("x z")
    ux, uz = me.dynamicsymbols("u_x u_z")
    m, g, r, e, mu = sm.symbols("m g r e mu", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x + z * N.z)
    C.set_vel(N, ux * N.x + uz * N.z)
    ball = me.Particle("ball", C, m)
    ball.potential_energy = m * g * z
    bottom = C.locatenew("B", -r * N.z)  # the lowest point of the ball
    contact = Contact(bottom, Plane(N, O, N.z, name="floor"), mu_k=mu, restitution=e,
                      name="floor")
    return ModelDefinition(
        name="bouncing-ball", title="ball bouncing on a floor with restitution",
        kane_args=dict(frame=N, q_ind=[x, z], u_ind=[ux, uz],
                       kd_eqs=[x.diff() - ux, z.diff() - uz], bodies=[ball],
                       loads=[(C, -m * g * N.z)], contacts=[contact]),
        constants={m: 0.1, g: 9.81, r: 0.05, e: restitution, mu: 0.0},
        initial_state={x: 0.0, z: 1.05, ux: 0.5, uz: 0.0}, t_end=4.0,
        symbols=dict(x=x, z=z, ux=ux, uz=uz, m=m, g=g, r=r, e=e, N=N),
        description="Apex heights above the floor fall by e^2 per bounce.",
        shape_specs=(("Sphere", ball, {"radius": r}),))


def _rod(N, O, length, mass, name="rod"):
    """A planar rod in the x-z plane: centre (x, z), angle theta from N.x."""
    x, z, th = me.dynamicsymbols("x z theta")
    ux, uz, w = me.dynamicsymbols("u_x u_z omega")
    B = me.ReferenceFrame("B")
    B.orient_axis(N, N.y, -th)  # theta measured from N.x towards N.z
    B.set_ang_vel(N, -w * N.y)
    G = O.locatenew("G", x * N.x + z * N.z)
    G.set_vel(N, ux * N.x + uz * N.z)
    inertia = me.inertia(B, 0, mass * length ** 2 / 12, mass * length ** 2 / 12)
    rod = me.RigidBody(name, G, B, mass, (inertia, G))
    return (x, z, th), (ux, uz, w), B, G, rod


def ladder(frictionless=False, angle=0.9):
    """A ladder (uniform rod) sliding against a rough wall and a rough floor.

    The foot ``A`` touches the floor ``z = 0``, the top ``C`` the wall
    ``x = 0``; the ladder starts at rest at ``angle`` (rad) from the floor,
    so ``theta = -angle``.  It slides if ``tan(angle) < (1 - mu_f mu_w) /
    (2 mu_f)`` (below 1.00 rad with the default coefficients), else it stays
    (both ends stick).  Without friction the top leaves the wall when its
    height is 2/3 of the initial one.  The ladder then falls and its top
    lands on the floor (a third contact, plastic impact).
    """
    L, m, g, mu_f, mu_w = sm.symbols("L m g mu_f mu_w", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    q, u, B, G, rod = _rod(N, O, L, m, "ladder")
    rod.potential_energy = m * g * q[1]
    foot = G.locatenew("A", L / 2 * B.x)    # towards +x, on the floor
    top = G.locatenew("C", -L / 2 * B.x)    # towards the wall
    foot.v2pt_theory(G, N, B)
    top.v2pt_theory(G, N, B)
    mus = (0, 0) if frictionless else (mu_f, mu_w)
    floor = Plane(N, O, N.z, name="floor")
    contacts = [Contact(foot, floor, mu_k=mus[0], name="floor"),
                Contact(top, Plane(N, O, N.x, name="wall"), mu_k=mus[1], name="wall"),
                Contact(top, floor, mu_k=mus[0], name="top-floor")]
    length = 2.0
    init = {q[0]: length / 2 * math.cos(angle), q[1]: length / 2 * math.sin(angle),
            q[2]: -angle, u[0]: 0.0, u[1]: 0.0, u[2]: 0.0}
    constants = {L: length, m: 10.0, g: 9.81}
    if not frictionless:
        constants.update({mu_f: 0.3, mu_w: 0.2})
    return ModelDefinition(
        name="ladder", title="ladder sliding against a rough wall and floor",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u),
                       kd_eqs=[a.diff() - b for a, b in zip(q, u)], bodies=[rod],
                       loads=[(G, -m * g * N.z)], contacts=contacts),
        constants=constants, initial_state=init, t_end=2.0,
        symbols=dict(q=q, u=u, L=L, m=m, g=g, N=N, B=B, G=G),
        description="Without friction the top leaves the wall at 2/3 of its initial "
                    "height.")


def falling_rod(angle=0.6, restitution=0.5, mu=0.4, law="poisson"):
    """A rod falling tilted onto a rough floor: impacts with friction at its ends.

    ``law``: the restitution law, ``"poisson"`` or ``"newton"``.
    """
    _check_fraction("falling-rod", "restitution", restitution)
    if not mu >= 0:
        raise ModelError(f"falling-rod: mu (the friction coefficient) must be >= 0, got {mu}")
    L, m, g, e, mu_s = sm.symbols("L m g e mu", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    q, u, B, G, rod = _rod(N, O, L, m, "rod")
    rod.potential_energy = m * g * q[1]
    ends = [G.locatenew("A", L / 2 * B.x), G.locatenew("C", -L / 2 * B.x)]
    for end in ends:
        end.v2pt_theory(G, N, B)
    contacts = [Contact(end, Plane(N, O, N.z, name="floor"), mu_k=mu_s, restitution=e,
                        restitution_law=law, name=f"floor-{end.name}") for end in ends]
    height = 0.5 + 0.5 * math.sin(angle)
    return ModelDefinition(
        name="falling-rod", title="rod falling on a rough floor: impacts with friction",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u),
                       kd_eqs=[a.diff() - b for a, b in zip(q, u)], bodies=[rod],
                       loads=[(G, -m * g * N.z)], contacts=contacts),
        constants={L: 1.0, m: 1.0, g: 9.81, e: restitution, mu_s: mu},
        initial_state={q[0]: 0.0, q[1]: height, q[2]: -angle, u[0]: 1.0, u[1]: 0.0,
                       u[2]: 0.0},
        t_end=2.0, symbols=dict(q=q, u=u, L=L, m=m, g=g, N=N, B=B, G=G),
        description="Impacts with friction: sticking, sliding and slip reversal during "
                    "the impulse; energy never increases.")


def slug_ellipsoid():
    """The seed example: a slug on the wall of a moving ellipsoidal tank, zero g.

    The tank (semi-axes ``a, b, c``) spins up about its ``z`` axis,
    ``psi(t) = Omega (t + tau (exp(-t/tau) - 1))``, while its centre moves as
    ``X(t) = A (1 - cos(w t))`` along ``N.x`` (propellant in a tank, or a
    docking spacecraft).  The slug (a particle) starts at rest on the wall
    the tank accelerates into, above the equator; it is dragged along by
    Coulomb friction, separates when the wall falls back, flies, hits the
    wall again (restitution ``e``, friction during the impact) and slides.
    """
    m, a, b, c = sm.symbols("m a b c", positive=True)
    mu, e, Omega, tau, A, w = sm.symbols("mu e Omega tau A w", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    Tank = me.ReferenceFrame("T")
    psi = Omega * (T + tau * (sm.exp(-T / tau) - 1))
    Tank.orient_axis(N, N.z, psi)
    centre = O.locatenew("Oc", A * (1 - sm.cos(w * T)) * N.x)
    centre.set_vel(N, A * w * sm.sin(w * T) * N.x)
    q, u, P = _free_particle(N, O)
    wall = Contact(P, Ellipsoid(Tank, centre, a, b, c, inside=True, name="tank"),
                   mu_k=mu, restitution=e, name="tank")
    values = {a: 0.8, b: 0.6, c: 0.5}
    z0 = 0.2  # on the wall, above the equator near the end of the long axis
    x0 = -values[a] * math.sqrt(1 - (z0 / values[c]) ** 2)
    init = dict(zip(q, (x0, 0.0, z0)))
    init.update(dict(zip(u, (0.0, 0.0, 0.0))))
    return ModelDefinition(
        name="slug-ellipsoid",
        title="slug on the wall of a spinning, translating ellipsoidal tank (zero g)",
        kane_args=dict(frame=N, q_ind=list(q), u_ind=list(u),
                       kd_eqs=[p.diff() - v for p, v in zip(q, u)],
                       bodies=[me.Particle("slug", P, m)], contacts=[wall]),
        constants={m: 1.0, **values, mu: 0.3, e: 0.5, Omega: 2.0, tau: 1.0, A: 0.3,
                   w: 3.0},
        initial_state=init, t_end=8.0,
        symbols=dict(q=q, u=u, m=m, N=N, T=Tank, centre=centre, P=P),
        description="Banerjee & Lemak's example: friction that follows the computed "
                    "normal force, separation, flight and impacts.")


def _check_fraction(model, option, value):
    """Refuse a coefficient outside [0, 1], naming the model and option."""
    if not 0.0 <= value <= 1.0:
        raise ModelError(f"{model}: {option} must lie in [0, 1], got {value}")
