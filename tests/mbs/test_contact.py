"""Penalty contact and regularised Coulomb friction against closed-form statics."""

import numpy as np
import pytest

from fuzzymbs.mbs.bodies import FixedBody, RotatingBody, TranslatingBody
from fuzzymbs.mbs.contact import CartesianChart, PenaltyContact, PolarChart, symmetric_contact
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels import layout as K
from fuzzymbs.mbs.linearize import steady_state
from fuzzymbs.mbs.lumped import lumped_modal_body, rigid_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.system import Coordinate, NodeDisplacement, System

from .systems import annulus_nodes, ground_patch


def pressed_block(force, penalty, damping=0.0):
    system = System()
    system.add_body(ground_patch())
    system.add_body(TranslatingBody(rigid_body("block", 2.0, [(0.1, 0.0, 0.05)]), ["y"]))
    system.add(NodalForce("press", "block", [0], "y", -force))
    system.add(
        PenaltyContact(
            "c",
            "block",
            [0],
            "ground",
            np.arange(9),
            CartesianChart("x", "z"),
            penalty=Parameter("c_p", penalty),
            normal="y",
            normal_damping=damping,
        )
    )
    return system


def test_static_penetration_equals_load_over_penalty():
    # closed form: one slave node in contact, c_p g = -F
    system = pressed_block(100.0, 1e6)
    st = steady_state(system, {"c_p": np.array([1e6, 4e6])})
    assert st.converged.all()
    np.testing.assert_allclose(st.x[:, 0], [-100.0 / 1e6, -100.0 / 4e6], rtol=1e-9)


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_damped_settling_reaches_static_penetration(kernel):
    # contact damping d_n = 2 zeta sqrt(c_p m) with zeta = 0.5: settles within ~0.05 s
    system = pressed_block(100.0, 1e6, damping=2 * 0.5 * np.sqrt(1e6 * 2.0))
    res = simulate(
        system,
        t_end=0.2,
        dt=1e-5,
        record_interval=1e-3,
        outputs={"y": Coordinate("block")},
        kernel=kernel,
    )
    np.testing.assert_allclose(res.outputs["y"][0, -1], -1e-4, rtol=1e-6)


def block_on_spring_plate(
    nodes, block_at, k_m, force, penalty, mass=0.1, damping_ratio=0.0, normal_damping=0.0
):
    """A rigid block at ``block_at`` pressed with ``force`` in -y onto a fixed plate whose
    nodes are point masses ``mass`` on their own springs ``k_m`` in y (one mode per node)."""
    n = len(nodes)
    stiff = np.zeros((3 * n, 3 * n))
    for i in range(n):
        stiff[3 * i + 1, 3 * i + 1] = k_m
    plate = lumped_modal_body(
        "plate", nodes, np.full(n, mass), stiff, free_dofs=[3 * i + 1 for i in range(n)]
    )
    system = System()
    system.add_body(FixedBody(plate, damping_ratio=damping_ratio))
    system.add_body(TranslatingBody(rigid_body("block", 1.0, [block_at]), ["y"]))
    system.add(NodalForce("press", "block", [0], "y", -force))
    system.add(
        PenaltyContact(
            "c",
            "block",
            [0],
            "plate",
            np.arange(n),
            CartesianChart("x", "z"),
            penalty=penalty,
            normal="y",
            normal_damping=normal_damping,
        )
    )
    return system


def test_bilinear_load_sharing_on_elastic_master():
    # master: 2 x 2 nodes, each a point mass on its own spring k_m in y (modes = nodes);
    # slave pressed with F at (xi, eta) = (0.25, 0.5): node a carries N_a F (bilinear
    # shape functions), so its deflection is N_a F / k_m; penetration stays F / c_p.
    k_m, force, c_p = 1e5, 50.0, 1e6
    nodes = np.array([(0, 0, 0), (1, 0, 0), (0, 0, 1), (1, 0, 1)], dtype=float)
    system = block_on_spring_plate(nodes, (0.25, 0.0, 0.5), k_m, force, c_p)
    compiled = system.compile()
    st = steady_state(compiled)
    assert st.converged.all()
    weights = {0: 0.75 * 0.5, 1: 0.25 * 0.5, 2: 0.75 * 0.5, 3: 0.25 * 0.5}
    x = np.concatenate([st.x[0], np.zeros_like(st.x[0])])
    for node, w in weights.items():
        defl = compiled.output_functional(NodeDisplacement("plate", node, "y")) @ x
        assert defl == pytest.approx(-w * force / k_m, rel=1e-9)
    plate_y = sum(
        w * compiled.output_functional(NodeDisplacement("plate", n, "y")) @ x
        for n, w in weights.items()
    )
    block_y = compiled.output_functional(Coordinate("block")) @ x
    assert block_y - plate_y == pytest.approx(-force / c_p, rel=1e-9)


def rigid_pad(name: str, y: float):
    g = np.linspace(-0.02, 0.02, 3)
    xx, zz = np.meshgrid(g, g, indexing="ij")
    nodes = np.stack([xx, np.full(xx.shape, y), zz], -1).reshape(-1, 3)
    return rigid_body(name, 0.5, nodes)


@pytest.mark.parametrize("two_pass", [False, True])
def test_single_and_two_pass_penetration(two_pass):
    # 9 pad nodes on 9 aligned ground nodes, total load 9 F: single pass -> F / c_p;
    # two-pass adds the 9 ground nodes as slaves of the pad face -> F / (2 c_p).
    force, c_p = 1000.0, 1e8
    system = System()
    system.add_body(FixedBody(rigid_pad("ground", 0.0)))
    system.add_body(TranslatingBody(rigid_pad("pad", 0.0), ["y"]))
    system.add(NodalForce("press", "pad", np.arange(9), "y", -force))
    chart = CartesianChart("x", "z")
    if two_pass:
        system.add(
            *symmetric_contact(
                "c",
                "pad",
                np.arange(9),
                chart,
                "ground",
                np.arange(9),
                chart,
                penalty=c_p,
                normal_a="-y",
                normal_b="y",
            )
        )
    else:
        system.add(
            PenaltyContact(
                "c", "pad", np.arange(9), "ground", np.arange(9), chart, penalty=c_p, normal="y"
            )
        )
    st = steady_state(system)
    expected = -force / c_p / (2.0 if two_pass else 1.0)
    assert st.x[0, 0] == pytest.approx(expected, rel=1e-9)


def friction_block(mu=0.6, eps=1e-4, spring_damping=0.0):
    """A block pressed with F = 200 N on a disc face (radius 10 m, 0.01 rad/s: belt speed
    0.1 m/s in -z), held tangentially by a spring k_t in z."""
    system = System()
    disc = rigid_body("disc", 1.0, annulus_nodes(9.0, 11.0, 3, 48))
    system.add_body(RotatingBody(disc, "y", speed=0.01))
    system.add_body(TranslatingBody(rigid_body("block", 1.0), ["z", "y"], origin=(10.0, 0, 0)))
    system.add(NodalForce("press", "block", [0], "y", -200.0))
    system.add(Spring("hold", "block", [0], stiffness=1e4, damping=spring_damping, direction="z"))
    system.add(
        PenaltyContact(
            "c",
            "block",
            [0],
            "disc",
            np.arange(disc.n_nodes),
            PolarChart("y", "x"),
            penalty=1e7,
            friction=Parameter("mu", mu),
            regularization_velocity=eps,
            normal="y",
            normal_damping=2e3,
        )
    )
    return system


def test_friction_force_is_mu_times_normal_force_when_sliding():
    # regularised law at |v_t| = 0.1 m/s >> eps = 1e-4 m/s: mu N (1 - eps^2 / (2 v^2)), i.e.
    # mu N to 5e-7; the spring carries it: k_t z = -mu N (belt moves in -z). Exactly, the
    # disc velocity at the displaced block (R, 0, z) is Omega (z, 0, -R): its z share is
    # R / sqrt(R^2 + z^2) (a 2e-6 effect at mu = 1), and |v| = Omega sqrt(R^2 + z^2).
    mus = np.array([0.2, 0.6, 1.0])
    st = steady_state(friction_block(), {"mu": mus})
    assert st.converged.all()
    np.testing.assert_allclose(1e4 * st.x[:, 0], -mus * 200.0, rtol=3e-6)
    z = st.x[:, 0]
    speed = 0.01 * np.hypot(10.0, z)
    exact = -mus * 200.0 * 10.0 / np.hypot(10.0, z) * speed / np.hypot(speed, 1e-4)
    # 1e-7: the master velocity is the bilinear (r, theta) interpolation of the node
    # velocities, i.e. evaluated on the cell's chord, not on the arc (a (dtheta)^2 effect)
    np.testing.assert_allclose(1e4 * z, exact, rtol=1e-7)
    # normal direction unaffected: penetration N / c_p
    np.testing.assert_allclose(st.x[:, 1], -200.0 / 1e7, rtol=1e-6)


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_friction_time_integration_settles_to_mu_normal_force(kernel):
    # tangential dashpot: zeta = 0.2 on the 100 rad/s block mode, e^-20t decay
    system = friction_block(spring_damping=2 * 0.2 * np.sqrt(1e4 * 1.0))
    res = simulate(
        system,
        {"mu": np.array([0.3, 0.7])},
        kernel=kernel,
        t_end=1.0,
        dt=1e-4,
        record_interval=1e-2,
        outputs={"z": Coordinate("block", 0)},
    )
    np.testing.assert_allclose(1e4 * res.outputs["z"][:, -1], [-60.0, -140.0], rtol=3e-6)


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_bilinear_load_sharing_on_a_non_uniform_master_grid(kernel):
    # master: a 3 x 3 grid with unequal spacings (x: 0, 0.2, 1.0; z: 0, 0.5, 1.5), so the
    # cell look-up walks the grid instead of dividing by a uniform spacing; each node is
    # a point mass on its own spring k_m in y. A block pressed with F at (x, z) = (0.4,
    # 1.25) lies in cell (1, 1) at xi = (0.4 - 0.2) / 0.8 = 0.25, eta = (1.25 - 0.5) / 1.0
    # = 0.75; at rest node a carries N_a F (bilinear shape functions) and deflects by
    # N_a F / k_m, the other nodes not at all; the penetration is F / c_p. Damping in the
    # contact and the plate modes lets the dynamics settle onto that static state.
    k_m, force, c_p, mass = 1e5, 50.0, 1e6, 0.1
    xs, zs = (0.0, 0.2, 1.0), (0.0, 0.5, 1.5)
    nodes = np.array([(x, 0.0, z) for x in xs for z in zs])
    system = block_on_spring_plate(
        nodes,
        (0.4, 0.0, 1.25),
        k_m,
        force,
        c_p,
        mass=mass,
        damping_ratio=0.5,
        normal_damping=2 * 0.5 * np.sqrt(c_p * 1.0),
    )
    compiled = system.compile()
    # premise: both chart directions are flagged non-uniform, so the walk runs
    assert compiled.data[12][0, K.CF_UUNIFORM] == 0 and compiled.data[12][0, K.CF_VUNIFORM] == 0
    outputs = {f"n{i}": NodeDisplacement("plate", i, "y") for i in range(9)}
    outputs["block"] = Coordinate("block")
    res = simulate(
        compiled, t_end=0.4, dt=1e-5, record_interval=1e-2, outputs=outputs, kernel=kernel
    )
    xi, eta = 0.25, 0.75
    # node index = 3 * (x index) + (z index); the cell's corners are x 1..2, z 1..2
    weights = {4: (1 - xi) * (1 - eta), 7: xi * (1 - eta), 8: xi * eta, 5: (1 - xi) * eta}
    for i in range(9):
        expected = -weights.get(i, 0.0) * force / k_m
        # settled: the slowest mode (the block on the contact damper, overdamped) decays
        # at about 90 1/s, e^-36 over 0.4 s; the deflections are about 1e-4 m
        assert res.outputs[f"n{i}"][0, -1] == pytest.approx(expected, abs=1e-9)
    surface = sum(w * res.outputs[f"n{i}"][0, -1] for i, w in weights.items())
    assert res.outputs["block"][0, -1] - surface == pytest.approx(-force / c_p, rel=1e-6)
