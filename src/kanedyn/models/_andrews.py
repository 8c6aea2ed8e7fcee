r"""Andrews' squeezing mechanism: seven planar bodies, six loop-closure constraints.

The seven-body mechanism that Hairer & Wanner (*Solving Ordinary Differential
Equations II*, section VII.7) and the IVP test set (problem "andrews") use to
test solvers of index-3 DAEs: a crank turned by a constant torque drives,
through three closed loops, arms held by a stiff spring.  Small inertias
(mass-matrix entries of 8e-7 to 7e-5 kg m²) against a spring of 4530 N/m:
within the test's 0.03 s the crank makes 2.5 turns and the accelerations
reach 5.7e5 rad/s².
"""

from __future__ import annotations

import sympy as sm
import sympy.physics.mechanics as me

from ._base import ModelDefinition

__all__ = ["andrews_squeezer", "ANDREWS_INITIAL"]

#: The test set's consistent initial coordinates (rad), at rest:
#: ``beta, Theta, gamma, Phi, delta, Omega, epsilon``.
ANDREWS_INITIAL = (-0.0617138900142764496358948458001, 0.0,
                   0.455279819163070380255912382449, 0.222668390165885884674473185609,
                   0.487364979543842550225598953530, -0.222668390165885884674473185609,
                   1.23054744454982119249735015568)

_NAMES = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")

_LENGTHS = dict(xa=-0.06934, ya=-0.00227, xb=-0.03635, yb=0.03273, xc=0.014, yc=0.072,
                d=28e-3, da=115e-4, e=2e-2, ea=1421e-5, rr=7e-3, ra=92e-5, l0=7785e-5,
                ss=35e-3, sa=1874e-5, sb=1043e-5, sc=18e-3, sd=2e-2, ta=2308e-5,
                tb=916e-5, u=4e-2, ua=1228e-5, ub=449e-5, zf=2e-2, zt=4e-2, fa=1421e-5)
_MASSES = (0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498)
_INERTIAS = (2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5)


def andrews_squeezer():
    r"""Andrews' squeezing mechanism (Hairer & Wanner II, VII.7; IVP test set "andrews").

    Geometry and data as in the test set (lengths in m, masses in kg, central
    moments of inertia ``i1 .. i7`` in kg m², no gravity).  Seven coordinates,
    the test set's, all absolute or relative angles about ``N.z`` (rad):

    * body 1, the crank, turns about the origin ``O`` (angle ``beta``; centre
      of mass at ``ra``); the drive torque ``mom`` acts on it;
    * body 2 is pinned to the crank at ``rr`` from ``O`` (angle ``Theta``
      relative to the crank); its far end ``F``, at ``d`` from the pin, is the
      point where the three loops close; centre of mass at ``da`` from the pin;
    * body 3 turns about ``B = (xb, yb)`` (angle ``gamma``) and reaches ``F``
      at ``ss``; the spring (stiffness ``c0``, free length ``l0``) joins its
      point ``D = B + sd e_x(gamma) - sc e_y(gamma)`` to ``C = (xc, yc)``;
    * body 5 turns about ``A = (xa, ya)`` (angle ``delta``); body 4 is pinned
      to it at ``zt`` from ``A`` (angle ``Phi`` relative to it) and reaches
      ``F`` at ``e``;
    * body 7 turns about ``A`` (angle ``epsilon``); body 6 is pinned to it at
      ``u`` from ``A`` (angle ``Omega`` relative to it) and reaches ``F`` at
      ``zf``.

    The six configuration constraints are the test set's ``g(q) = 0``, in its
    order and signs: the ``x`` and ``y`` differences of ``F`` reached through
    bodies 1-2 and through body 3, bodies 5-4 and bodies 7-6.  ``beta`` is the
    independent coordinate; speeds are the coordinates' rates (``dbeta``,
    ...), so the Lagrange-based formulations and the index-3 scheme apply.
    The model's multipliers are the test set's with the opposite sign (kanedyn
    writes :math:`M\dot u = f + B^T\lambda`, the test set :math:`M\ddot q = f
    - G^T\lambda`).

    Returns
    -------
    ModelDefinition
        ``symbols`` holds ``q`` and ``u`` (lists in the order above), ``N``,
        and ``F`` (the loop-closing point reached through bodies 1-2).
    """
    q = list(me.dynamicsymbols(_NAMES))
    w = list(me.dynamicsymbols(["d" + name for name in _NAMES]))
    beta, theta, gamma, phi, delta, omega, epsilon = q
    wbeta, wtheta, wgamma, wphi, wdelta, womega, wepsilon = w
    # lengths and coordinates of the fixed points, m (three of those are negative)
    L = {name: sm.Symbol(name, real=True) if name in ("xa", "ya", "xb")
         else sm.Symbol(name, positive=True) for name in _LENGTHS}
    masses = sm.symbols("m1:8", positive=True)
    inertias = sm.symbols("i1:8", positive=True)
    c0, mom = sm.symbols("c0 mom", real=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)

    def frame(name, angle, rate):
        F = me.ReferenceFrame(name)
        F.orient_axis(N, N.z, angle)
        F.set_ang_vel(N, rate * N.z)
        return F

    def fixed(name, x, y):
        P = O.locatenew(name, x * N.x + y * N.y)
        P.set_vel(N, 0)
        return P

    def on(name, base, frame_, offset):
        P = base.locatenew(name, offset)
        P.v2pt_theory(base, N, frame_)
        return P

    A = fixed("A", L["xa"], L["ya"])
    B = fixed("B", L["xb"], L["yb"])
    C = fixed("C", L["xc"], L["yc"])
    F1 = frame("F1", beta, wbeta)
    F2 = frame("F2", beta + theta, wbeta + wtheta)
    F3 = frame("F3", gamma, wgamma)
    F5 = frame("F5", delta, wdelta)
    F4 = frame("F4", phi + delta, wphi + wdelta)
    F7 = frame("F7", epsilon, wepsilon)
    F6 = frame("F6", omega + epsilon, womega + wepsilon)
    pin12 = on("P12", O, F1, L["rr"] * F1.x)
    pin54 = on("P54", A, F5, L["zt"] * F5.x)
    pin76 = on("P76", A, F7, -L["u"] * F7.y)
    closing = {"12": on("F", pin12, F2, -L["d"] * F2.x),
               "3": on("F3_end", B, F3, -L["ss"] * F3.y),
               "54": on("F4_end", pin54, F4, -L["e"] * F4.y),
               "76": on("F6_end", pin76, F6, L["zf"] * F6.x)}
    centres = [on("G1", O, F1, L["ra"] * F1.x),
               on("G2", pin12, F2, -L["da"] * F2.x),
               on("G3", B, F3, L["sa"] * F3.x + L["sb"] * F3.y),
               on("G4", pin54, F4, -(L["e"] - L["ea"]) * F4.y),
               on("G5", A, F5, L["ta"] * F5.x + L["tb"] * F5.y),
               on("G6", pin76, F6, (L["zf"] - L["fa"]) * F6.x),
               on("G7", A, F7, L["ua"] * F7.x + L["ub"] * F7.y)]
    frames = (F1, F2, F3, F4, F5, F6, F7)
    bodies = [me.RigidBody(f"body{k + 1}", G, Fk, masses[k],
                           (me.inertia(Fk, 0, 0, inertias[k]), G))
              for k, (G, Fk) in enumerate(zip(centres, frames))]
    D = on("D", B, F3, L["sd"] * F3.x - L["sc"] * F3.y)
    spring = D.pos_from(C)
    stretch = sm.sqrt(spring.dot(N.x) ** 2 + spring.dot(N.y) ** 2)
    loads = [(F1, mom * N.z), (D, -c0 * (stretch - L["l0"]) / stretch * spring)]
    config, velocity = [], []
    for other in ("3", "54", "76"):
        gap = closing["12"].pos_from(O) - closing[other].pos_from(O)
        rate = closing["12"].vel(N) - closing[other].vel(N)
        config += [gap.dot(N.x), gap.dot(N.y)]
        velocity += [rate.dot(N.x), rate.dot(N.y)]
    constants = {L[name]: value for name, value in _LENGTHS.items()}
    constants.update(zip(masses, _MASSES))
    constants.update(zip(inertias, _INERTIAS))
    constants.update({c0: 4530.0, mom: 0.033})
    units = {sym: "m" for sym in L.values()}
    units.update({m: "kg" for m in masses})
    units.update({i: "kg m^2" for i in inertias})
    units.update({c0: "N/m", mom: "N m"})
    initial = dict(zip(q, ANDREWS_INITIAL))
    initial.update({rate: 0.0 for rate in w})
    return ModelDefinition(
        name="andrews-squeezer",
        title="Andrews' squeezing mechanism: 7 bodies, 6 loop-closure constraints",
        kane_args=dict(frame=N, q_ind=[beta], u_ind=[wbeta],
                       kd_eqs=[qk.diff() - wk for qk, wk in zip(q, w)],
                       q_dep=q[1:], u_dep=w[1:], configuration_constraints=config,
                       velocity_constraints=velocity, bodies=bodies, loads=loads,
                       potential_energy=c0 / 2 * (stretch - L["l0"]) ** 2 - mom * beta),
        constants=constants, constant_units=units, initial_state=initial, t_end=0.03,
        symbols=dict(q=q, u=w, N=N, F=closing["12"]),
        description="The test set's start (at rest) and reference solution at t = 0.03 s; "
                    "the potential energy holds the spring and the work of the constant "
                    "drive torque (-mom beta).")
