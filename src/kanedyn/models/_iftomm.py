r"""Problems of the IFToMM library of computational benchmark problems for multibody codes.

Problem A02, the *N four-bar mechanism* (González, Dopico, Lugrís & Cuadrado
2006; the library of the IFToMM Technical Committee for Multibody Dynamics,
first hosted by the Laboratorio de Ingeniería Mecánica of the University of
A Coruña): :func:`n_four_bar`, and the exact motion of its physical branch,
:func:`n_four_bar_exact`, against which kanedyn's schemes are measured
(``docs/constraints.md``, "Singular configurations").
"""

from __future__ import annotations

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from .._errors import ModelError
from ._base import ModelDefinition

__all__ = ["n_four_bar", "n_four_bar_exact", "n_four_bar_singular_times"]


def n_four_bar(n=10):
    r"""IFToMM benchmark A02: ``n`` four-bar linkages in a row under gravity.

    Geometry (the benchmark's).  ``n + 1`` cranks of length ``L`` turn about
    ground pivots :math:`A_i = (iL, 0)`, ``i = 0 .. n``, on the ``N.x`` axis
    (``N.y`` up); coupler ``i`` (``i = 1 .. n``), also of length ``L``, joins
    the tips :math:`B_{i-1}` and :math:`B_i` of cranks ``i - 1`` and ``i``.
    All ``2n + 1`` links are uniform rods of mass ``m`` (central moment of
    inertia :math:`mL^2/12`); gravity ``g`` acts along :math:`-\hat n_y`.
    The benchmark's values: ``L = 1 m``, ``m = 1 kg``, ``g = 9.81 m/s²``,
    ``n = 40``.

    Coordinates, as the benchmark's reference formulation has them, one per
    link: the absolute angles ``theta0 .. theta{n}`` of the cranks and
    ``phi1 .. phi{n}`` of the couplers (rad, from ``N.x`` about ``N.z``);
    speeds ``dtheta0 ..``, ``dphi1 ..`` their rates (rad/s).  The loop
    closure of window ``i``, :math:`B_{i-1} + L\hat e(\phi_i) = B_i`, gives two
    configuration constraints

    .. math::

        L\cos\theta_{i-1} + L\cos\phi_i - L - L\cos\theta_i = 0,\qquad
        L\sin\theta_{i-1} + L\sin\phi_i - L\sin\theta_i = 0,

    so ``theta0`` is independent and the other ``2n`` coordinates dependent:
    one degree of freedom.

    Start (the benchmark's).  Cranks vertical (:math:`\theta_i = \pi/2`),
    couplers horizontal (:math:`\phi_i = 0`), and the point :math:`B_0`
    moving at 1 m/s along ``+N.x``: :math:`\dot\theta_0 = -1` rad/s.  The
    mechanism falls clockwise and, having kinetic energy left at the top,
    turns round and round; the benchmark asks for 20 s.

    Singular positions.  Whenever the cranks are horizontal (:math:`\theta
    = 0` or :math:`\pi`) all links lie on the ground line: the ``x`` rows of
    the constraint Jacobian vanish, its rank drops from ``2n`` to ``n`` and
    the mechanism has, instantaneously, ``n + 1`` degrees of freedom.  The
    physical motion stays on the parallelogram branch (all cranks parallel,
    couplers horizontal); see :func:`n_four_bar_exact`.

    Parameters
    ----------
    n : int
        Number of four-bar windows (``n >= 1``); the benchmark's is 40
        (``build("n-four-bar", n=40)``; the default, 10, derives and compiles
        in a fraction of the time).

    Returns
    -------
    ModelDefinition
        ``symbols`` holds ``theta`` and ``phi`` (lists of coordinates),
        ``B0`` (the point whose path is the benchmark's output), ``N``, and
        ``L, m, g``.
    """
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
        raise ModelError(f"n-four-bar: n must be a positive integer, got {n!r}")
    n = int(n)
    theta = list(me.dynamicsymbols(f"theta0:{n + 1}"))
    phi = list(me.dynamicsymbols(f"phi1:{n + 1}"))
    dtheta = list(me.dynamicsymbols(f"dtheta0:{n + 1}"))
    dphi = list(me.dynamicsymbols(f"dphi1:{n + 1}"))
    L, m, g = sm.symbols("L m g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    bodies, loads, heights = [], [], []

    def rod(name, q, w, start, height):
        """A uniform rod from ``start`` (at ``height``) at angle ``q``, rate ``w``; its tip.

        Velocities are set directly: the rod turns about ``N.z``, so a point
        at distance ``d`` along it moves at ``d w`` along ``F.y`` relative to
        ``start`` (cheaper than ``v2pt_theory`` for 81 rods).
        """
        F = me.ReferenceFrame(f"F_{name}")
        F.orient_axis(N, N.z, q)
        F.set_ang_vel(N, w * N.z)
        G = start.locatenew(f"G_{name}", L / 2 * F.x)
        G.set_vel(N, start.vel(N) + L / 2 * w * F.y)
        tip = start.locatenew(f"tip_{name}", L * F.x)
        tip.set_vel(N, start.vel(N) + L * w * F.y)
        inertia = me.inertia(F, 0, 0, m * L ** 2 / 12)
        bodies.append(me.RigidBody(name, G, F, m, (inertia, G)))
        loads.append((G, -m * g * N.y))
        heights.append(m * g * (height + L / 2 * sm.sin(q)))
        return tip

    tips = []
    for i in range(n + 1):
        A = O.locatenew(f"A{i}", i * L * N.x)
        A.set_vel(N, 0)
        tips.append(rod(f"crank{i}", theta[i], dtheta[i], A, 0))
    config, velocity = [], []
    for i in range(1, n + 1):
        a, b, c = theta[i - 1], phi[i - 1], theta[i]          # crank, coupler, crank
        wa, wb, wc = dtheta[i - 1], dphi[i - 1], dtheta[i]
        rod(f"coupler{i}", b, wb, tips[i - 1], L * sm.sin(a))
        # the coupler's far end minus the tip of crank i, along N.x and N.y
        config += [L * sm.cos(a) + L * sm.cos(b) - L - L * sm.cos(c),
                   L * sm.sin(a) + L * sm.sin(b) - L * sm.sin(c)]
        velocity += [-L * sm.sin(a) * wa - L * sm.sin(b) * wb + L * sm.sin(c) * wc,
                     L * sm.cos(a) * wa + L * sm.cos(b) * wb - L * sm.cos(c) * wc]
    q_dep = theta[1:] + phi
    u_dep = dtheta[1:] + dphi
    kd_eqs = [q.diff() - u for q, u in zip(theta + phi, dtheta + dphi)]
    initial = {theta[0]: sm.pi / 2, dtheta[0]: -1.0}
    initial.update({q: sm.pi / 2 for q in theta[1:]})
    initial.update({q: 0.0 for q in phi})
    initial.update({u: 0.0 for u in u_dep})
    return ModelDefinition(
        name="n-four-bar",
        title=f"IFToMM benchmark A02: {n} four-bar linkages in a row (singular positions; "
              "the benchmark's n is 40)",
        kane_args=dict(frame=N, q_ind=[theta[0]], u_ind=[dtheta[0]], kd_eqs=kd_eqs,
                       q_dep=q_dep, u_dep=u_dep, configuration_constraints=config,
                       velocity_constraints=velocity, bodies=bodies, loads=loads,
                       potential_energy=sm.Add(*heights)),
        constants={L: 1.0, m: 1.0, g: 9.81},
        initial_state=initial, t_end=20.0,
        symbols=dict(theta=theta, phi=phi, dtheta=dtheta, dphi=dphi, B0=tips[0], N=N,
                     L=L, m=m, g=g, n=n),
        description="The cranks pass the horizontal, where the loop-closure Jacobian "
                    "loses half its rank, twice a revolution; the benchmark's output "
                    "is the path of the tip B0 of the first crank over 20 s.")


def _branch_constants(n, L, m, g):
    """Inertia :math:`I` (kg m²) and gravity moment :math:`G` (N m) of the branch."""
    inertia = m * L ** 2 * ((n + 1) / 3.0 + n)
    moment = m * g * L * ((n + 1) / 2.0 + n)
    return inertia, moment


def n_four_bar_exact(t, n=40, L=1.0, m=1.0, g=9.81, theta0=np.pi / 2, rate0=-1.0,
                     rtol=1e-13, atol=1e-13):
    r"""The motion of the A02 mechanism on its parallelogram branch, integrated by hand.

    On the physical branch every crank has the same angle :math:`\theta` and
    every coupler translates with the crank tips, so the mechanism is a
    single degree of freedom with kinetic and potential energy

    .. math::

        T = \tfrac12 I\dot\theta^2,\quad I = mL^2\Big(\frac{n+1}{3} + n\Big),
        \qquad V = G\sin\theta,\quad G = mgL\Big(\frac{n+1}{2} + n\Big),

    (``n + 1`` cranks turning about their pivots, ``n`` couplers translating
    at the tip speed :math:`L\dot\theta`), hence :math:`I\ddot\theta = -G
    \cos\theta`.  This equation is integrated here with SciPy's DOP853 at
    tolerances of 1e-13, independently of kanedyn's formulations.

    Parameters
    ----------
    t : array_like, shape (k,)
        Output times, s (increasing, from 0).
    n : int
        Number of windows.
    L, m, g : float
        Link length (m), link mass (kg), gravity (m/s²).
    theta0, rate0 : float
        Initial crank angle (rad) and rate (rad/s); the benchmark's are
        :math:`\pi/2` and -1.
    rtol, atol : float
        Tolerances of the integration.

    Returns
    -------
    theta, rate : ndarray, shape (k,)
        Crank angle (rad) and rate (rad/s); :math:`B_0 = L(\cos\theta,
        \sin\theta)`.
    """
    from scipy.integrate import solve_ivp
    t = np.asarray(t, dtype=float)
    inertia, moment = _branch_constants(n, L, m, g)
    k = moment / inertia

    def rhs(_, y):
        return [y[1], -k * np.cos(y[0])]

    sol = solve_ivp(rhs, (0.0, float(t[-1])), [theta0, rate0], method="DOP853",
                    t_eval=t, rtol=rtol, atol=atol)
    return sol.y[0], sol.y[1]


def n_four_bar_singular_times(t_end, n=40, L=1.0, m=1.0, g=9.81, rate0=-1.0):
    r"""Times at which the A02 mechanism passes its singular (horizontal) positions.

    Started from the benchmark's position (:math:`\theta = \pi/2`, rate
    ``rate0 < 0``), the energy integral gives :math:`\dot\theta^2 =
    \dot\theta_0^2 + 2(G/I)(1 - \sin\theta)`, so the time to turn from
    :math:`\pi/2` to :math:`\theta` is a quadrature,

    .. math::

        t(\theta) = \int_\theta^{\pi/2}\frac{d\vartheta}{\sqrt{\dot\theta_0^2
        + 2(G/I)(1 - \sin\vartheta)}},

    evaluated with SciPy's ``quad``; the cranks are horizontal at
    :math:`\theta = 0, -\pi, -2\pi, \dots`.  The motion is periodic and
    symmetric about the top, so one quadrature over a half turn gives all
    crossings.

    Returns
    -------
    ndarray
        The crossing times in ``[0, t_end]``, s.
    """
    from scipy.integrate import quad
    if rate0 >= 0:
        raise ValueError("rate0 must be negative (the benchmark's start turns clockwise)")
    inertia, moment = _branch_constants(n, L, m, g)
    k = moment / inertia

    def dt(angle):
        return 1.0 / np.sqrt(rate0 ** 2 + 2.0 * k * (1.0 - np.sin(angle)))

    quarter = quad(dt, 0.0, np.pi / 2, epsabs=1e-14, epsrel=1e-14)[0]   # top -> horizontal
    half = quad(dt, -np.pi / 2, 0.0, epsabs=1e-14, epsrel=1e-14)[0]     # horizontal -> bottom
    period = 2.0 * (quarter + half)
    times = []
    start = 0.0
    while start + quarter <= t_end:
        times.append(start + quarter)                  # theta = 0 (going down)
        if start + quarter + 2.0 * half <= t_end:
            times.append(start + quarter + 2.0 * half)  # theta = -pi (coming up)
        start += period
    return np.asarray(times)
