"""Inverse dynamics of numerical models: ``model.inverse_dynamics(t, q, u, udot)``.

Checked against the forward equations (``mass_matrix`` and ``forcing`` in
SymPy's reduced convention, open and closed chains), against Pinocchio's
recursive Newton-Euler algorithm (``rnea``) on the 3D chain and on a random
tree read from a URDF file, and by a round trip through the forward
right-hand side driven by the computed torques.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me

import kanedyn as kd

BACKENDS = ["numpy", "c"]


def reduced_reference(model, y, udot_ind):
    """``tau = M_red[:p] u' - f_red[:p]``, with the dependent u' from the
    acceleration-constraint rows of the reduced mass matrix."""
    p = model.n_u_ind
    M, f = model.mass_matrix(0.0, y), model.forcing(0.0, y)
    U = np.zeros(model.n_u)
    U[:p] = udot_ind
    if model.n_u_dep:
        U[p:] = np.linalg.solve(M[p:, p:], f[p:] - M[p:, :p] @ U[:p])
    return M[:p] @ U - f[:p], M, f


def random_points(model, definition, rng, count, spread=0.3):
    """All coordinates (dependent ones as guesses) near the model's initial
    state, independent speeds and rates."""
    y0 = model.state(definition.initial_state)
    q = y0[:model.n_q, None] + spread * rng.uniform(-1, 1, (model.n_q, count))
    u = rng.uniform(-2, 2, (model.n_u_ind, count))
    udot = rng.uniform(-3, 3, (model.n_u_ind, count))
    return q, u, udot


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name, options", [("chain3d", {"n": 3}), ("four-bar", {}),
                                           ("n-link-pendulum-on-cart", {})])
def test_equals_forward_mass_matrix_and_forcing(name, options, backend):
    definition = kd.models.build(name, **options)
    model = definition.numeric(backend=backend)
    rng = np.random.default_rng(7)
    q, u, udot = random_points(model, definition, rng, 6)
    tau = model.inverse_dynamics(0.0, q, u, udot)
    assert tau.shape == (model.n_u_ind, 6)
    for i in range(q.shape[1]):
        y = model.state(np.concatenate([q[:, i], u[:, i], np.zeros(model.n_u_dep)]))
        ref, M, f = reduced_reference(model, y, udot[:, i])
        scale = 1.0 + np.max(np.abs(ref))
        np.testing.assert_allclose(tau[:, i], ref, rtol=0, atol=1e-12 * scale)
        # the same point alone (1-D arrays) gives the same column
        single = model.inverse_dynamics(0.0, q[:, i], u[:, i], udot[:, i])
        assert single.shape == (model.n_u_ind,)
        np.testing.assert_allclose(single, tau[:, i], rtol=0, atol=1e-13 * scale)
        # round trip through the reduced forward equations: the forces added to
        # the independent rows give back the rates asked for
        p = model.n_u_ind
        extra = np.zeros(model.n_u)
        extra[:p] = tau[:, i]
        back = np.linalg.solve(M, f + extra)
        np.testing.assert_allclose(back[:p], udot[:, i], rtol=0, atol=1e-9)


@pytest.mark.parametrize("backend", BACKENDS)
def test_chain3d_against_pinocchio_rnea(backend):
    pin = pytest.importorskip("pinocchio")
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from _peers import DEFAULTS, pinocchio_chain

    n = 5
    definition = kd.models.build("chain3d", n=n)
    model = definition.numeric(constants=DEFAULTS, backend=backend)
    assert model.state_names == tuple(f"q{k}" for k in range(1, n + 1)) + tuple(
        f"u{k}" for k in range(1, n + 1))
    pmodel, pdata = pinocchio_chain(n)
    rng = np.random.default_rng(3)
    count = 20
    q = rng.uniform(-np.pi, np.pi, (n, count))
    u = rng.uniform(-2, 2, (n, count))
    udot = rng.uniform(-5, 5, (n, count))
    tau = model.inverse_dynamics(np.linspace(0, 1, count), q, u, udot)
    for i in range(count):
        ref = pin.rnea(pmodel, pdata, q[:, i].copy(), u[:, i].copy(), udot[:, i].copy())
        np.testing.assert_allclose(tau[:, i], ref, rtol=0, atol=1e-10)


def torqued_double_pendulum():
    """Planar double pendulum (relative angles) with joint torques T1, T2."""
    q1, q2, u1, u2 = me.dynamicsymbols("q1 q2 u1 u2")
    T1, T2 = me.dynamicsymbols("T1 T2")
    m1, m2, l1, l2, g = sm.symbols("m1 m2 l1 l2 g")
    N = me.ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (q1, N.z))
    B = A.orientnew("B", "Axis", (q2, A.z))
    A.set_ang_vel(N, u1 * N.z)
    B.set_ang_vel(A, u2 * A.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", l1 * A.x)
    Q = P.locatenew("Q", l2 * B.x)
    P.v2pt_theory(O, N, A)
    Q.v2pt_theory(P, N, B)
    I = sm.Rational(1, 12)
    bodyA = me.RigidBody("bA", O.locatenew("GA", l1 / 2 * A.x), A, m1,
                         (me.inertia(A, 0, I * m1 * l1**2, I * m1 * l1**2), O))
    bodyA.masscenter.v2pt_theory(O, N, A)
    bodyA.inertia = (me.inertia(A, 0, I * m1 * l1**2, I * m1 * l1**2), bodyA.masscenter)
    bodyB = me.Particle("pB", Q, m2)
    loads = [(bodyA.masscenter, -m1 * g * N.y), (Q, -m2 * g * N.y),
             (A, (T1 - T2) * N.z), (B, T2 * N.z)]
    eom = kd.kane(frame=N, q_ind=[q1, q2], u_ind=[u1, u2],
                  kd_eqs=[q1.diff() - u1, q2.diff() - u2],
                  bodies=[bodyA, bodyB], loads=loads)
    constants = {m1: 1.3, m2: 0.7, l1: 0.9, l2: 0.6, g: 9.81}
    return eom, constants, (T1, T2)


@pytest.mark.parametrize("backend", BACKENDS)
def test_round_trip_through_the_forward_rhs(backend):
    eom, constants, (T1, T2) = torqued_double_pendulum()
    free = eom.numeric(constants=constants, specified={T1: 0.0, T2: 0.0}, backend=backend)
    rng = np.random.default_rng(11)
    q, u, udot = (rng.uniform(-2, 2, (2, 8)) for _ in range(3))
    tau = free.inverse_dynamics(0.0, q, u, udot)
    for i in range(8):
        driven = eom.numeric(constants=constants, backend="numpy",
                             specified={T1: float(tau[0, i]), T2: float(tau[1, i])})
        ydot = driven.rhs(0.0, np.concatenate([q[:, i], u[:, i]]))
        np.testing.assert_allclose(ydot[2:], udot[:, i], rtol=0, atol=1e-10)
        np.testing.assert_allclose(ydot[:2], u[:, i], rtol=0, atol=1e-14)


def test_symbolic_form_matches_numeric():
    eom, constants, (T1, T2) = torqued_double_pendulum()
    tau_sym = eom.inverse_dynamics()
    assert tau_sym.shape == (2, 1)
    model = eom.numeric(constants=constants, specified={T1: 0.0, T2: 0.0})
    q, u, udot = [0.3, -0.8], [1.1, 0.4], [-2.0, 0.5]
    values = {**constants, T1: 0, T2: 0}
    for s, v in zip(eom.q, q):
        values[s] = v
    for s, v in zip(eom.u, u):
        values[s] = v
    for s, v in zip(eom.u, udot):
        values[s.diff(me.dynamicsymbols._t)] = v
    expected = np.array(tau_sym.xreplace({k: v for k, v in values.items()
                                          if isinstance(k, sm.Derivative)})
                        .xreplace(values), dtype=float).ravel()
    np.testing.assert_allclose(model.inverse_dynamics(0.0, q, u, udot), expected,
                               rtol=1e-12, atol=1e-12)


def test_bad_shapes_name_the_argument():
    model = kd.models.build("chain3d", n=2).numeric()
    with pytest.raises(ValueError, match="udot"):
        model.inverse_dynamics(0.0, np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="u must"):
        model.inverse_dynamics(0.0, np.zeros((2, 3)), np.zeros((2, 4)), np.zeros((2, 4)))


def test_trees_use_the_recursive_pass_and_loops_the_mass_matrix():
    """The tests above cover both paths: chain3d and the cart take the engine's
    recursive pass, the four-bar (a loop) the mass-matrix product."""
    from kanedyn.numerics._inverse import _recursive_inertia_forces
    for name, options, tree in [("chain3d", {"n": 3}, True),
                                ("n-link-pendulum-on-cart", {}, True),
                                ("four-bar", {}, False)]:
        eom = kd.models.build(name, **options).derive()
        rows = _recursive_inertia_forces(eom, len(eom.u), list(eom._table.udot), {})
        assert (rows is not None) == tree, name


@pytest.mark.parametrize("backend", BACKENDS)
def test_equations_stay_as_derived(backend):
    """The inverse function is built on an extension of the equations'
    program: ``eom`` keeps its size and fingerprint, and a model built after
    the inverse call computes the same as one built before."""
    from kanedyn.numerics.backends._c import fingerprint
    definition = kd.models.build("chain3d", n=3)
    eom = definition.derive()
    first = definition.numeric(eom, backend=backend)
    size = len(eom._program)
    key = fingerprint(eom._program, first._functions, first._sizes, first._cse)
    listing = list(eom._program._order)
    rng = np.random.default_rng(5)
    q, u, udot = random_points(first, definition, rng, 4)
    tau = first.inverse_dynamics(0.0, q, u, udot)
    assert len(eom._program) == size
    assert list(eom._program._order) == listing
    assert fingerprint(eom._program, first._functions, first._sizes, first._cse) == key
    second = definition.numeric(eom, backend=backend)
    assert fingerprint(eom._program, second._functions, second._sizes, second._cse) == key
    for i in range(q.shape[1]):
        y = np.concatenate([q[:, i], u[:, i]])
        np.testing.assert_array_equal(second.rhs(0.0, y), first.rhs(0.0, y))
    np.testing.assert_array_equal(second.inverse_dynamics(0.0, q, u, udot), tau)


def random_tree_urdf(links, seed):
    """A URDF text: ``links`` moving links on a random tree of revolute and
    prismatic joints (random parents, origins, axes, masses, inertias and
    inertial offsets) under a fixed base."""
    rng = np.random.default_rng(seed)

    def triple(scale):
        return " ".join(f"{v:.6f}" for v in rng.uniform(-scale, scale, 3))

    parts = ['<?xml version="1.0"?>', '<robot name="random_tree">',
             '  <link name="base"/>']
    for k in range(links):
        a, b, c = rng.uniform(0.01, 0.05, 3)  # a valid inertia: principal values
        ixy, ixz, iyz = rng.uniform(-0.002, 0.002, 3)  # + small products
        parts.append(
            f'  <link name="l{k}"><inertial><origin xyz="{triple(0.2)}" '
            f'rpy="{triple(1.0)}"/><mass value="{rng.uniform(0.5, 3.0):.6f}"/>'
            f'<inertia ixx="{b + c:.6f}" ixy="{ixy:.6f}" ixz="{ixz:.6f}" '
            f'iyy="{a + c:.6f}" iyz="{iyz:.6f}" izz="{a + b:.6f}"/></inertial></link>')
    for k in range(links):
        parent = "base" if k == 0 else f"l{rng.integers(0, k)}"
        kind = "prismatic" if rng.uniform() < 0.3 else "revolute"
        parts.append(
            f'  <joint name="j{k}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="l{k}"/><origin xyz="{triple(0.5)}" rpy="{triple(1.5)}"/>'
            f'<axis xyz="{triple(1.0)}"/>'
            '<limit lower="-3" upper="3" effort="100" velocity="10"/></joint>')
    parts.append("</robot>")
    return "\n".join(parts)


@pytest.fixture(scope="module")
def random_tree(tmp_path_factory):
    pin = pytest.importorskip("pinocchio")
    path = tmp_path_factory.mktemp("tree") / "random_tree.urdf"
    path.write_text(random_tree_urdf(6, seed=2))
    definition = kd.models.from_urdf(path)
    return definition, definition.derive(), pin.buildModelFromUrdf(str(path))


@pytest.mark.slow
@pytest.mark.parametrize("backend", BACKENDS)
def test_random_tree_against_pinocchio_rnea(random_tree, backend):
    """A random tree (branches, revolute and prismatic joints, skewed axes,
    offset and rotated inertias) read from one URDF file by kanedyn and by
    Pinocchio: the inverse dynamics equals ``rnea`` to 1e-10, one point at a
    time and a trajectory in one call."""
    import pinocchio as pin
    from test_urdf import pinocchio_state

    definition, eom, pmodel = random_tree
    parents = {pmodel.parents[i] for i in range(2, pmodel.njoints)}
    assert len(parents) < pmodel.njoints - 1  # some link carries two children: a tree
    pdata = pmodel.createData()
    efforts = {j.effort_input: 0.0 for j in definition.joints}
    model = definition.numeric(eom, specified=efforts, backend=backend)
    assert model.n_u_dep == 0 and model.n_u == pmodel.nv
    rng = np.random.default_rng(4)
    count = 10
    q, u, udot = rng.uniform(-1.5, 1.5, (3, model.n_q, count))
    tau = model.inverse_dynamics(0.0, q, u, udot)
    for i in range(count):
        qp, vp, _, index = pinocchio_state(pmodel, definition, q[:, i], u[:, i])
        ap = np.zeros(pmodel.nv)
        ap[index] = udot[:, i]
        ref = pin.rnea(pmodel, pdata, qp, vp, ap)[index]
        np.testing.assert_allclose(tau[:, i], ref, rtol=0, atol=1e-10)
        one = model.inverse_dynamics(0.0, q[:, i], u[:, i], udot[:, i])
        np.testing.assert_allclose(one, ref, rtol=0, atol=1e-10)


@pytest.mark.parametrize("backend", BACKENDS)
def test_one_point_inputs_checked_like_trajectories(backend):
    """The direct one-point call gives the trajectory call's column for lists,
    integers and NumPy scalars, and refuses what the general way refuses."""
    model = kd.models.build("chain3d", n=2).numeric(backend=backend)
    q, u, udot = np.array([0.3, -0.2]), np.array([1.0, 2.0]), np.array([-1.0, 0.5])
    ref = model.inverse_dynamics(np.array([0.0]), q[:, None], u[:, None], udot[:, None])
    np.testing.assert_array_equal(model.inverse_dynamics(np.float64(0.0), q, u, udot),
                                  ref[:, 0])
    np.testing.assert_array_equal(model.inverse_dynamics(0, [0, 0], [0, 0], [0, 0]),
                                  model.inverse_dynamics(0.0, np.zeros(2), np.zeros(2),
                                                         np.zeros(2)))
    for bad, name in [((np.nan, 0.0), "q"), ((0.0, np.inf), "q")]:
        with pytest.raises(ValueError, match=f"{name} has entries that are not finite"):
            model.inverse_dynamics(0.0, bad, u, udot)
    with pytest.raises(ValueError, match="udot has entries that are not finite"):
        model.inverse_dynamics(0.0, q, u, [0.0, np.nan])
    with pytest.raises(ValueError, match="u must"):
        model.inverse_dynamics(0.0, q, [1.0, 2.0, 3.0], udot)
    # float64 arrays (the C model's inverse_point): non-finite entries, wrong sizes,
    # other dtypes and a bool time go the general way
    with pytest.raises(ValueError, match="u has entries that are not finite"):
        model.inverse_dynamics(0.0, q, np.array([np.nan, 1.0]), udot)
    with pytest.raises(ValueError, match="udot must"):
        model.inverse_dynamics(0.0, q, u, np.zeros(3))
    np.testing.assert_array_equal(
        model.inverse_dynamics(0.0, q.astype(np.float32), u, udot),
        model.inverse_dynamics(0.0, q.astype(np.float32).astype(float), u, udot))
    np.testing.assert_array_equal(  # big-endian: converted, not read as native
        model.inverse_dynamics(0.0, q.astype(">f8"), u.astype(">f8"), udot.astype(">f8")),
        model.inverse_dynamics(0.0, q, u, udot))
    assert (model._fn.get("inverse_point") is not None) == (backend == "c")
    # a trajectory (C: every point in one call, inverse_rows) gives the one-point values
    rng = np.random.default_rng(2)
    Q, U, A = (rng.uniform(-1, 1, (2, 7)) for _ in range(3))
    np.testing.assert_array_equal(
        model.inverse_dynamics(np.linspace(0, 1, 7), Q, U, A),
        np.column_stack([model.inverse_dynamics(float(t), Q[:, i].copy(), U[:, i].copy(),
                                                A[:, i].copy())
                         for i, t in enumerate(np.linspace(0, 1, 7))]))


def test_closed_chain_trajectory_in_compiled_calls():
    """A C model of a closed chain completes a trajectory from the constraint
    terms of every point in one call (``constraints_rows``) and evaluates it in
    one more (``inverse_rows``): the same forces as point by point and as the
    numpy backend (the 3-RRR along a pose trajectory from its inverse kinematics)."""
    from kanedyn.models import planar_3rrr_ik, quintic_pose
    definition = kd.models.build("3rrr")
    eom = definition.derive()
    fast, slow = definition.numeric(eom, backend="c"), definition.numeric(eom)
    t = np.linspace(0.0, 2.0, 41)
    q, u, udot = planar_3rrr_ik(*quintic_pose(t, [0.0, 0.0, 0.0], [0.08, -0.05, 0.3], 2.0))
    p = fast.n_u_ind
    loop = []  # the terms point by point: not even in the first call
    fast._constraint_terms = lambda *args: loop.append(1) or type(fast)._constraint_terms(
        fast, *args)
    tau = fast.inverse_dynamics(t, q.T, u[:, :p].T, udot[:, :p].T)
    assert loop == []
    del fast._constraint_terms
    calls = []
    every = fast._fn["constraint_rows"]
    fast._fn["constraint_rows"] = lambda *args: calls.append(1) or every(*args)
    np.testing.assert_array_equal(fast.inverse_dynamics(t, q.T, u[:, :p].T, udot[:, :p].T),
                                  tau)
    assert calls == [1]
    np.testing.assert_allclose(tau, slow.inverse_dynamics(t, q.T, u[:, :p].T, udot[:, :p].T),
                               rtol=1e-10, atol=1e-10)
    fast._fn["constraint_rows"] = None  # point by point
    np.testing.assert_allclose(tau, fast.inverse_dynamics(t, q.T, u[:, :p].T,
                                                          udot[:, :p].T),
                               rtol=1e-12, atol=1e-12)
