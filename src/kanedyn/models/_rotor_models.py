r"""Rotors for Campbell diagrams: a spinning cantilever and a lag-hinged rotor on a support.

Both turn about ``N.z`` (no gravity) with the azimuth ``psi`` a coordinate and
its rate ``Omega`` a speed, so that :func:`kanedyn.campbell` holds the speed
and lets the azimuth move.
"""

from __future__ import annotations

import math

import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ..modeling import BeamMember, FlexibleBody
from ._base import ModelDefinition

__all__ = ["rotating_cantilever", "lag_rotor"]


def _hub(N, O):
    """A frame turning about ``N.z`` by the azimuth ``psi`` at the speed ``Omega``."""
    psi, Omega = me.dynamicsymbols("psi Omega")
    R = N.orientnew("R", "Axis", [psi, N.z])
    R.set_ang_vel(N, Omega * N.z)
    return R, psi, Omega


def rotating_cantilever(n_elements=20, n_modes=5):
    r"""Uniform cantilever on a hub of radius 0, bending out of the plane of rotation (flap).

    The data of Wright, Smith, Thresher & Wang (1982): L = 31.623 m, 100
    kg/m, EI = 1e8 N m² flapwise (so :math:`\sqrt{EI/(mL^4)} = 1` rad/s),
    reduced by Craig–Bampton to its first ``n_modes`` flap modes, with
    geometric stiffening; the hub (J = 1000 kg m²) turns freely.

    Parameters
    ----------
    n_elements : int
        Beam elements.
    n_modes : int
        Flap modes kept (at most 5 with the 8 modes reduced first).

    Returns
    -------
    ModelDefinition
        States ``psi``, ``eta_blade_1`` ..., ``Omega``, ``zeta_blade_1`` ...
    """
    if not 1 <= int(n_modes) <= 5:
        raise ModelError(f"rotating-cantilever: n_modes must be 1 to 5, got {n_modes!r}")
    member = BeamMember.uniform("blade", 31.623, mass_per_length=100.0, EA=1e12, GJ=1e5,
                                EI_y=1e8, EI_z=1e9, polar_inertia=1e-3, n_elements=n_elements)
    flap = member.craig_bampton(n_modes=8).keep_modes(
        [f"bending_xz_{j}" for j in range(1, int(n_modes) + 1)])
    N, O = me.ReferenceFrame("N"), me.Point("O")
    O.set_vel(N, 0)
    R, psi, Omega = _hub(N, O)
    hub = me.RigidBody("hub", O, R, 1.0, (me.inertia(R, 500.0, 500.0, 1000.0), O))
    blade = FlexibleBody("blade", R, O, flap)
    return ModelDefinition(
        name="rotating-cantilever",
        title="uniform cantilever spinning on a free hub, flap modes (Wright et al. 1982)",
        kane_args=dict(frame=N, q_ind=[psi, *blade.q], u_ind=[Omega, *blade.u],
                       kd_eqs=[psi.diff() - Omega, *blade.kd_eqs], bodies=[hub, blade]),
        constants={}, initial_state={}, t_end=10.0, specified={},
        symbols=dict(psi=psi, Omega=Omega, blade=blade, N=N, R=R),
        description="Flapwise frequencies against rotation speed: Wright, Smith, Thresher "
                    "& Wang (1982), tabulated by Bir (2009).")


def lag_rotor(n_blades=3):
    r"""Rigid blades on lag hinges with springs, on a hub that translates on springs.

    Blade :math:`b` is a point mass :math:`m` at distance :math:`l` from its
    hinge, which sits at radius :math:`e` and azimuth
    :math:`\psi + 2\pi(b-1)/N`; a torsional spring :math:`k_\zeta` holds the
    lag angle :math:`\zeta_b` (in the plane of rotation).  The hub (mass
    :math:`M`, axial inertia :math:`J`) moves in ``x`` and ``y`` on springs
    :math:`k_h`.  On a fixed hub the lag frequency in the rotating frame is

    .. math::

        \omega_\zeta^2 = \frac{k_\zeta}{m l^2} + \Omega^2\,\frac{e}{l}.

    Parameters
    ----------
    n_blades : int
        At least 3.

    Returns
    -------
    ModelDefinition
        Constants ``m``, ``l``, ``e``, ``k_zeta``, ``M``, ``J``, ``k_h``
        (defaults 10 kg, 2 m, 0.5 m, 640 N m/rad, 20 kg, 5 kg m², 1250 N/m:
        a lag frequency of 4 rad/s at rest, the hub on its springs at 5 rad/s
        with the blades' mass); states ``x``, ``y``, ``psi``,
        ``zeta_1`` ... ``zeta_N`` then their speeds ``u_x``, ``u_y``,
        ``Omega``, ``w_1`` ... ``w_N``.
    """
    n_blades = int(n_blades)
    if n_blades < 3:
        raise ModelError(f"lag-rotor: n_blades must be 3 or more, got {n_blades!r}")
    m, l, e, k_zeta, M, J, k_h = sm.symbols("m l e k_zeta M J k_h")
    N, O = me.ReferenceFrame("N"), me.Point("O")
    O.set_vel(N, 0)
    x, y, u_x, u_y = me.dynamicsymbols("x y u_x u_y")
    H = O.locatenew("H", x * N.x + y * N.y)
    H.set_vel(N, u_x * N.x + u_y * N.y)
    R, psi, Omega = _hub(N, O)
    zeta = me.dynamicsymbols(f"zeta_1:{n_blades + 1}")
    w = me.dynamicsymbols(f"w_1:{n_blades + 1}")
    bodies = [me.RigidBody("hub", H, R, M, (me.inertia(R, J / 2, J / 2, J), H))]
    loads = [(H, -k_h * (x * N.x + y * N.y))]
    for b in range(n_blades):
        phi = 2 * math.pi * b / n_blades
        hinge = H.locatenew(f"hinge_{b + 1}", e * (math.cos(phi) * R.x + math.sin(phi) * R.y))
        hinge.v2pt_theory(H, N, R)
        A = R.orientnew(f"A_{b + 1}", "Axis", [phi + zeta[b], R.z])
        A.set_ang_vel(R, w[b] * R.z)
        tip = hinge.locatenew(f"mass_{b + 1}", l * A.x)
        tip.v2pt_theory(hinge, N, A)
        bodies.append(me.Particle(f"blade_{b + 1}", tip, m))
        loads += [(A, -k_zeta * zeta[b] * N.z), (R, k_zeta * zeta[b] * N.z)]
    return ModelDefinition(
        name="lag-rotor",
        title=f"{n_blades} lag-hinged rigid blades on a hub on lateral springs",
        kane_args=dict(frame=N, q_ind=[x, y, psi, *zeta], u_ind=[u_x, u_y, Omega, *w],
                       kd_eqs=[x.diff() - u_x, y.diff() - u_y, psi.diff() - Omega,
                               *(z.diff() - s for z, s in zip(zeta, w))],
                       bodies=bodies, loads=loads),
        constants={m: 10.0, l: 2.0, e: 0.5, k_zeta: 640.0, M: 20.0, J: 5.0, k_h: 1250.0},
        initial_state={}, t_end=10.0, specified={},
        symbols=dict(m=m, l=l, e=e, k_zeta=k_zeta, M=M, J=J, k_h=k_h, psi=psi, Omega=Omega,
                     zeta=list(zeta), N=N, R=R),
        description="The classic rotor of ground resonance: in multiblade coordinates "
                    "the lag modes split into collective and forward and backward whirl.")
