"""Flexible bodies in every formulation: Kane ≡ orthogonal complement ≡ Lagrange.

Three derivations that share only the body's inertia invariants: Kane's
method projects the quasi-coordinate Newton–Euler equations of each flexible
body with its partial velocities; the natural orthogonal complement assembles
:math:`T_b^TM_bT_b` from per-body blocks numerically; Lagrange's equations
differentiate the kinetic energy :math:`\\tfrac12 w^TM_b(\\eta)w` in the
coordinates' rates.  On small models (a flexible beam on a driven hub, a rigid
link carrying a flexible link, a flexible link carrying a rigid payload at
its tip node; with and without gravity, damping and geometric stiffening)
the mass matrices and state derivatives agree to 1e-10 at random states.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd
from kanedyn._errors import ModelError
from kanedyn.engine._symbols import name_of

NOC = "orthogonal-complement"
TOL = 1e-10


def _member(n_modes=2):
    beam = kd.flexible.BeamMember.uniform("arm", 2.0, mass_per_length=3.0, EA=1e6, GJ=2e3,
                                          EI_y=4e3, EI_z=2e3, polar_inertia=1e-3, n_elements=3)
    return beam.craig_bampton(n_modes=n_modes)


def _flexible(name, frame, origin, options, gravity):
    return kd.FlexibleBody(name, frame, origin, _member(options.get("n_modes", 2)),
                           stiffening=options.get("stiffening", True),
                           rayleigh=options.get("rayleigh"),
                           modal_damping=options.get("modal_damping"),
                           gravity=gravity if options.get("gravity") else None)


def hub_model(**options):
    """(a) A cantilever on a hub driven by a torque about N.z; hub angle free."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    theta, omega = me.dynamicsymbols("theta omega")
    tau, I_h, g = sm.symbols("tau I_h g")
    H = N.orientnew("H", "Axis", [theta, N.z])
    H.set_ang_vel(N, omega * N.z)
    hub = me.RigidBody("hub", O, H, 0, (me.inertia(H, I_h / 2, I_h / 2, I_h), O))
    beam = _flexible("beam", H, O, options, -g * N.y)
    model = dict(frame=N, q_ind=[theta, *beam.q], u_ind=[omega, *beam.u],
                 kd_eqs=[theta.diff() - omega, *beam.kd_eqs], bodies=[hub, beam],
                 loads=[(H, tau * N.z)])
    return model, {tau: 0.7, I_h: 1.3, g: 9.81}


def link_model(**options):
    """(b) A rigid link turning about N.z carrying, at its tip, a flexible link
    hinged about the rigid link's y axis (its frame oriented from the link's)."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    m1, L1, I1, tau1, tau2, k2, g = sm.symbols("m1 L1 I1 tau1 tau2 k2 g")
    A = N.orientnew("A", "Axis", [q1, N.z])
    A.set_ang_vel(N, u1 * N.z)
    B = A.orientnew("B", "Axis", [q2, A.y])
    B.set_ang_vel(A, u2 * A.y)
    G = O.locatenew("G", L1 / 2 * A.x)
    G.v2pt_theory(O, N, A)
    P = O.locatenew("P", L1 * A.x)
    P.v2pt_theory(O, N, A)
    link = me.RigidBody("link", G, A, m1, (me.inertia(A, I1 / 10, I1, I1), G))
    beam = _flexible("beam", B, P, options, -g * N.z)
    loads = [(A, tau1 * N.z - tau2 * A.y), (B, (tau2 - k2 * q2) * A.y)]
    if options.get("gravity"):
        loads.append((G, -m1 * g * N.z))
    model = dict(frame=N, q_ind=[q1, q2, *beam.q], u_ind=[u1, u2, *beam.u],
                 kd_eqs=[q1.diff() - u1, q2.diff() - u2, *beam.kd_eqs],
                 bodies=[link, beam], loads=loads)
    return model, {m1: 2.0, L1: 1.2, I1: 0.3, tau1: 0.4, tau2: -0.3, k2: 5.0, g: 9.81}


def payload_model(**options):
    """(c) A flexible link on a two-axis gimbal carrying a rigid payload at its tip
    node (the payload turns with the node's frame)."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    mp, d, Ip, tau, g = sm.symbols("m_p d I_p tau g")
    B = me.ReferenceFrame("B")
    B.orient_body_fixed(N, (q1, q2, 0), "zyx")
    beam = _flexible("beam", B, O, options, -g * N.z)
    tip = beam.member.n_nodes - 1
    F = beam.node_frame(tip)
    Pc = beam.node_point(tip).locatenew("Pc", d * F.x + d / 3 * F.y)
    payload = me.RigidBody("payload", Pc, F, mp, (me.inertia(F, Ip, 2 * Ip, 3 * Ip), Pc))
    loads = [(B, tau * N.z + tau / 2 * B.y)]
    if options.get("gravity"):
        loads.append((Pc, -mp * g * N.z))
    # strain energy and gravity's (beam and payload) relative to O
    energy = beam.strain_energy
    if options.get("gravity"):
        energy += beam.gravitational_energy(O) + mp * g * Pc.pos_from(O).dot(N.z)
    model = dict(frame=N, q_ind=[q1, q2, *beam.q], u_ind=[u1, u2, *beam.u],
                 kd_eqs=[q1.diff() - u1, q2.diff() - u2, *beam.kd_eqs],
                 bodies=[beam, payload], loads=loads, potential_energy=energy)
    return model, {mp: 1.5, d: 0.2, Ip: 0.02, tau: 0.5, g: 9.81}


BUILDERS = {"hub": hub_model, "link": link_model, "payload": payload_model}

CASES = [
    ("hub", {}),
    ("hub", {"stiffening": False, "gravity": True, "rayleigh": (0.2, 1e-3)}),
    ("link", {"gravity": True, "rayleigh": (0.1, 2e-3)}),
    ("link", {"stiffening": False, "n_modes": 3}),
    ("payload", {"gravity": True, "rayleigh": (0.3, 1e-3)}),
    ("payload", {"stiffening": False, "gravity": True, "modal_damping": (0.02, 0.05)}),
]


def _id(case):
    name, options = case
    return name + "".join(f"-{k}" for k in sorted(options))


@pytest.fixture(scope="module")
def models():
    """{case id: (Kane, NOC, Lagrange numerical models, Kane -> Lagrange permutation)}."""
    cache = {}

    def get(case):
        key = _id(case)
        if key not in cache:
            name, options = case
            model, constants = BUILDERS[name](**options)
            kane = kd.formulate(method="kane", **model)
            numeric = [_numeric(kd.formulate(method=m, **model), constants)
                       for m in ("kane", NOC, "lagrange")]
            names = _rate_names(kane)
            lag = numeric[2]
            perm = [lag.index(names[s]) for s in numeric[0].state_names]
            cache[key] = (*numeric, perm)
        return cache[key]
    return get


def _numeric(eom, constants):
    """The numpy model, given the values of the constants the model uses."""
    return eom.numeric(constants={s: v for s, v in constants.items() if s in eom.parameters})


def _rate_names(eom):
    """``{Kane state name: Lagrange state name}`` (kd_eqs ``q' - u``)."""
    out = {}
    for eq in eom.kd_eqs:
        (qd,) = eq.atoms(sm.Derivative)
        u = sm.expand(qd - eq)
        out[name_of(qd.expr)] = name_of(qd.expr)
        out[name_of(u)] = name_of(qd.expr) + "_d"
    return out


def _states(model, count, seed):
    """Random states: angles within +-0.6 rad, modal coordinates within +-0.05
    (tip deflections of a few cm on the 2 m beam), speeds within +-1."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        y = np.empty(model.n_states)
        for i, name in enumerate(model.state_names):
            if i < model.n_q:
                y[i] = rng.uniform(-0.05, 0.05) if name.startswith("eta") else \
                    rng.uniform(-0.6, 0.6)
            else:
                y[i] = rng.uniform(-1.0, 1.0)
        yield y


def _close(a, b):
    return np.max(np.abs(a - b)) <= TOL * np.max(np.abs(a))


@pytest.mark.parametrize("case", CASES, ids=_id)
def test_kane_orthogonal_complement_lagrange_agree(models, case):
    kane, noc, lag, perm = models(case)
    assert noc.state_names == kane.state_names
    for k, y in enumerate(_states(kane, 4, seed=11)):
        t = 0.3 * k
        yl = np.empty(lag.n_states)
        yl[perm] = y
        M = kane.mass_matrix(t, y)
        assert np.all(np.linalg.eigvalsh(M) > 0)
        assert _close(M, noc.mass_matrix(t, y)), case
        n = kane.n_q
        ul = np.array(perm[n:]) - n  # Lagrange speed of each Kane speed
        assert _close(M, lag.mass_matrix(t, yl)[np.ix_(ul, ul)]), case
        f = kane.rhs(t, y)
        assert _close(f, noc.rhs(t, y)), case
        assert _close(f, lag.rhs(t, yl)[perm]), case
        assert np.isclose(kane.kinetic_energy(t, y), lag.kinetic_energy(t, yl), rtol=TOL)
        assert np.isclose(kane.kinetic_energy(t, y), noc.kinetic_energy(t, y), rtol=TOL)


@pytest.mark.parametrize("case", [c for c in CASES if c[0] == "payload"], ids=_id)
def test_energy_balance(models, case):
    """Without the applied torque, d/dt (T + V) equals the damping power
    -zeta^T D zeta (V the strain energy and, where on, gravity's potential
    ``FlexibleBody.gravitational_energy`` plus the payload's, formed apart from
    the equations' forces; T the kinetic energy of beam and payload)."""
    model, _ = payload_model(**case[1])
    (beam,) = [b for b in model["bodies"] if isinstance(b, kd.FlexibleBody)]
    for numeric in models(case)[:2]:  # Kane, orthogonal complement
        free = numeric.with_constants({"tau": 0.0})
        zeta = [free.index(name_of(s)) for s in beam.u]
        for y in _states(free, 3, seed=7):
            ydot = free.rhs(0.0, y)

            def rate(energy, y=y, ydot=ydot, h=1e-4):
                def central(h):
                    return (energy(0.0, y + h * ydot) - energy(0.0, y - h * ydot)) / (2 * h)
                return (4 * central(h / 2) - central(h)) / 3  # Richardson: error O(h^4)

            dT, dV = rate(free.kinetic_energy), rate(free.potential_energy)
            power = -y[zeta] @ beam.damping @ y[zeta]
            scale = max(abs(dT), abs(dV))  # the two cancel but for the damping power
            assert abs(dT + dV - power) <= 1e-9 * scale, (dT, dV, power)
            assert abs(power) > 1e-3 * scale  # the damping does work


@pytest.mark.parametrize("method", ["kane", NOC, "lagrange"])
def test_gravity_only_accelerates_a_translating_body(method):
    """A beam whose frame translates freely (tilted, not turning): uniform
    gravity adds g to the origin's acceleration and changes nothing else, at
    any deformation (the equivalence of gravity and an accelerated frame)."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    x = me.dynamicsymbols("x1:4")
    v = me.dynamicsymbols("v1:4")
    g = sm.symbols("g")
    B = N.orientnew("B", "Body", [0.3, -0.5, 0.2], "zyx")
    P = O.locatenew("P", x[0] * N.x + x[1] * N.y + x[2] * N.z)
    P.set_vel(N, v[0] * N.x + v[1] * N.y + v[2] * N.z)
    beam = _flexible("beam", B, P, {"gravity": True, "rayleigh": (0.2, 1e-3)},
                     g * (0.2 * N.x - 0.3 * N.y - N.z))
    eom = kd.formulate(method=method, frame=N, q_ind=[*x, *beam.q], u_ind=[*v, *beam.u],
                       kd_eqs=[*(a.diff() - b for a, b in zip(x, v)), *beam.kd_eqs],
                       bodies=[beam])
    heavy, light = eom.numeric(constants={g: 9.81}), eom.numeric(constants={g: 0.0})
    shift = np.zeros(heavy.n_states)
    shift[heavy.n_q:heavy.n_q + 3] = 9.81 * np.array([0.2, -0.3, -1.0])
    for y in _states(heavy, 3, seed=2):
        a, b = heavy.rhs(0.0, y), light.rhs(0.0, y) + shift
        assert np.max(np.abs(a - b)) <= TOL * np.max(np.abs(a)), (method, a - b)


def test_auxiliary_force_at_the_hub():
    """The pivot force of the hub, exposed by an auxiliary speed, is the same by
    Kane's method and the orthogonal complement (its magnitude does no work on
    the real motion: the hub's real partial velocities vanish)."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    theta, omega, u_a = me.dynamicsymbols("theta omega u_a")
    tau, I_h, R = sm.symbols("tau I_h R")
    O.set_vel(N, u_a * N.x)
    H = N.orientnew("H", "Axis", [theta, N.z])
    H.set_ang_vel(N, omega * N.z)
    hub = me.RigidBody("hub", O, H, 1.0, (me.inertia(H, I_h / 2, I_h / 2, I_h), O))
    beam = _flexible("beam", H, O, {}, None)
    model = dict(frame=N, q_ind=[theta, *beam.q], u_ind=[omega, *beam.u], u_auxiliary=[u_a],
                 kd_eqs=[theta.diff() - omega, *beam.kd_eqs], bodies=[hub, beam],
                 loads=[(H, tau * N.z), (O, R * N.x)])
    kane, noc = (kd.formulate(method=m, **model).numeric(constants={tau: 0.7, I_h: 1.3})
                 for m in ("kane", NOC))
    for y in _states(kane, 3, seed=4):
        assert _close(kane.rhs(0.0, y), noc.rhs(0.0, y))
        fk, fn = kane.auxiliary(0.0, y)["R"], noc.auxiliary(0.0, y)["R"]
        assert abs(fk) > 0.1 and abs(fk - fn) <= TOL * abs(fk)


@pytest.mark.parametrize("method", sorted(kd.FORMULATIONS))
def test_every_formulation_takes_or_refuses_flexible_bodies(models, method):
    """Every registered formulation either gives Kane's state derivative on a
    model with a flexible body or refuses it naming the body and itself."""
    case = ("link", {"gravity": True, "rayleigh": (0.1, 2e-3)})
    model, constants = link_model(**case[1])
    kane, _, _, perm = models(case)
    try:
        eom = kd.formulate(method=method, **model)
    except ModelError as error:
        assert "beam" in str(error) and method in str(error)
        return
    numeric = _numeric(eom, constants)
    for y in _states(kane, 2, seed=5):
        f = kane.rhs(0.1, y)
        if numeric.state_names == kane.state_names:
            g = numeric.rhs(0.1, y)
        else:
            yl = np.empty(numeric.n_states)
            yl[perm] = y
            g = numeric.rhs(0.1, yl)[perm]
        assert _close(f, g), method


def test_formulation_without_flexible_bodies_refused():
    """A formulation registered as rigid-only refuses a flexible body by name."""
    from kanedyn.formulations import _registry

    model, _ = hub_model()
    _registry.register_formulation("rigid-only-kane", _registry.FORMULATIONS["kane"],
                                   flexible_bodies=False)
    try:
        with pytest.raises(ModelError, match=r"'rigid-only-kane'.*flexible body 'beam'"):
            kd.formulate(method="rigid-only-kane", **model)
    finally:
        _registry.FORMULATIONS.pop("rigid-only-kane")
