"""RK4 against SciPy's adaptive DOP853 on the same right-hand side, and energy conservation.

References: solve_ivp(method="DOP853", rtol=1e-10) (Hairer, Norsett, Wanner,
Solving ODEs I, 8th-order Dormand-Prince) for the integrator; the mechanical
energy T + V written out independently below for conservation.
"""

import numpy as np
import pytest

from fuzzymbs.mbs.bodies import RotatingBody, TranslatingBody
from fuzzymbs.mbs.contact import CartesianChart, PenaltyContact, PolarChart, symmetric_contact
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import simulate, simulate_reference
from fuzzymbs.mbs.linearize import eigenanalysis, steady_state
from fuzzymbs.mbs.lumped import lumped_modal_body, rigid_body
from fuzzymbs.mbs.system import Coordinate, NodeDisplacement, System

from .systems import annulus_nodes, ground_patch


def elastic_disc():
    """12 point masses on a periodic polar grid (r = 0.08, 0.12; 6 angles) in y = 0, each on
    its own supports (k_n) plus out-of-plane springs to its ring and radial neighbours."""
    nodes = annulus_nodes(0.08, 0.12, 2, 6)
    n = nodes.shape[0]
    stiff = np.kron(np.eye(n), np.diag([2e4, 1e4, 2e4]))
    pairs = [(i, (i + 1) % 6) for i in range(6)] + [(6 + i, 6 + (i + 1) % 6) for i in range(6)]
    pairs += [(i, 6 + i) for i in range(6)]
    for a, b in pairs:
        for i, j, s in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
            stiff[3 * i + 1, 3 * j + 1] += s * 5e3
    return lumped_modal_body("disc", nodes, np.full(n, 0.1), stiff)


def rotating_contact_system():
    """Elastic disc spinning at 2 rad/s about y, a block at r = 0.1 m pressed on it with
    50 N, held by springs in y and z, Coulomb mu = 0.5 (eps = 1e-3 m/s, sliding ~0.2 m/s)."""
    system = System()
    system.add_body(RotatingBody(elastic_disc(), "y", speed=2.0, damping_ratio=0.01))
    system.add_body(TranslatingBody(rigid_body("block", 0.5), ["z", "y"], origin=(0.1, 0, 0)))
    system.add(NodalForce("press", "block", [0], "y", -50.0))
    system.add(Spring("hold", "block", [0], stiffness=2e3, damping=1.0, direction="z"))
    system.add(Spring("lift", "block", [0], stiffness=1e3, direction="y"))
    system.add(
        PenaltyContact(
            "c",
            "block",
            [0],
            "disc",
            np.arange(12),
            PolarChart("y", "x"),
            penalty=1e5,
            friction=0.5,
            normal="y",
        )
    )
    return system


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_rk4_matches_dop853_on_rotating_elastic_contact(kernel):
    system = rotating_contact_system().compile()
    outputs = {
        "block_y": Coordinate("block", 1),
        "block_z": Coordinate("block", 0),
        "disc_y": NodeDisplacement("disc", 0, "y"),
    }
    res = simulate(
        system, t_end=0.05, dt=2e-6, record_interval=1e-3, outputs=outputs, kernel=kernel
    )
    ref = simulate_reference(
        system, t_end=0.05, outputs=outputs, times=res.time, rtol=1e-10, atol=1e-15, max_step=1e-4
    )
    for name in outputs:
        scale = np.abs(ref[name]).max()
        assert scale > 0
        # RK4 at omega_max dt ~ 1e-3 (global error ~ (w dt)^4 w T ~ 1e-10 of the response,
        # the contact kinks add O(dt^2) local errors): measured 1.6e-11; bound 1e-9
        np.testing.assert_allclose(res.outputs[name][0], ref[name], atol=1e-9 * scale)


def energy_system():
    """An elastic body translating in x and y whose basis is clamped to its frame at node 0
    (so C_t != 0 and the full mass matrix matters), dropping onto a fixed ground patch."""
    stiff = np.zeros((6, 6))
    k = np.diag([1e4, 2e4, 1e4])
    stiff[:3, :3] = k
    stiff[3:, 3:] = k
    stiff[:3, 3:] = -k
    stiff[3:, :3] = -k
    body = lumped_modal_body(
        "body", [(0, 0, 0), (0, 0.05, 0)], [1.0, 0.5], stiff, free_dofs=[3, 4, 5]
    )
    system = System()
    system.add_body(ground_patch(y=-0.01))
    system.add_body(TranslatingBody(body, ["x", "y"]))
    system.add(Spring("side", "body", [1], stiffness=3e3, direction="x"))
    system.add(NodalForce("weight", "body", [1], "y", -20.0))
    system.add(
        PenaltyContact(
            "c",
            "body",
            [0],
            "ground",
            np.arange(9),
            CartesianChart("x", "z"),
            penalty=1e5,
            normal="y",
        )
    )
    return body, system.compile()


def energy(body, compiled, states):
    """T + V: T = 1/2 v^T M v with M = [[m P P^T, P C_t], [C_t^T P^T, I]];
    V = 1/2 sum w^2 q^2 + 1/2 k_side u_x^2 + 1/2 c_p min(g, 0)^2 - F u_y (node 1)."""
    axes = np.eye(3)[:2]
    coupling = axes @ body.translation_coupling
    mass = np.block([[body.mass * axes @ axes.T, coupling], [coupling.T, np.eye(body.n_modes)]])
    n = compiled.n_dofs
    x, v = states[:, :n], states[:, n:]
    kinetic = 0.5 * np.einsum("ti,ij,tj->t", v, mass, v)
    q = x[:, 2:]
    u1 = x[:, None, :2] @ axes[None] + (body.mode_shapes[1] @ q.T).T[:, None, :]
    u1 = u1[:, 0]
    gap = 0.01 + x[:, 1] + (body.mode_shapes[0] @ q.T).T[:, 1]
    potential = 0.5 * (body.frequencies**2 * q**2).sum(axis=1) + 0.5 * 3e3 * u1[:, 0] ** 2
    potential += 0.5 * 1e5 * np.minimum(gap, 0.0) ** 2 - (-20.0) * u1[:, 1]
    return kinetic + potential, gap, kinetic[0]


GUESS = np.array([0.0, -0.0102, 0.0, 0.0, 0.0])  # in contact: a start for Newton


def run_energy(dt, closed=False):
    body, compiled = energy_system()
    outputs = {f"x{i}": Coordinate("body", i) for i in range(5)}
    outputs.update({f"v{i}": Coordinate("body", i, velocity=True) for i in range(5)})
    x0 = compiled.zero_state()
    if closed:  # start at the static equilibrium in contact, gently shaken: never separates
        x0[0, :5] = steady_state(compiled, guess=GUESS).x[0]
        x0[0, 5] = 0.3  # vx (frictionless sliding)
        x0[0, 6] = -0.02  # vy: amplitude ~1e-4 m < static penetration 2e-4 m
    else:
        x0[0, 5] = 0.3  # vx
        x0[0, 6] = -1.0  # vy: hits the ground at t ~ 0.01 s and bounces off
    res = simulate(
        compiled, t_end=0.1, dt=dt, record_interval=1e-3, outputs=outputs, initial_state=x0
    )
    states = np.stack([res.outputs[k][0] for k in outputs], axis=1)
    return energy(body, compiled, states)


def highest_frequency():
    """omega_max of the linear system in contact (eigenvalues of the linearisation)."""
    _, compiled = energy_system()
    state = steady_state(compiled, guess=GUESS)
    return np.abs(eigenanalysis(compiled, state=state).eigenvalues.imag).max()


def test_energy_conserved_in_permanent_contact():
    # Smooth (always in contact, linear): RK4's amplification factor on an undamped mode
    # is |R(i w h)|^2 = 1 - (w h)^6 / 72 + ..., so the energy drifts by at most
    # (w h)^5 w T / 72 with w = omega_max; and it must fall ~2^5 when h halves.
    w = highest_frequency()
    drifts = []
    for dt in (2e-4, 1e-4):
        e, gap, scale = run_energy(dt, closed=True)
        assert gap.max() < 0  # never separated
        drift = np.abs(e - e[0]).max() / scale  # relative to the energy of the motion
        assert drift <= (w * dt) ** 5 * w * 0.1 / 72
        drifts.append(drift)
    assert drifts[1] < drifts[0] / 16


def test_energy_conserved_through_impact():
    # Away from contact the motion is smooth and energy is exact to round-off. A step
    # that crosses g = 0 integrates a right-hand side whose derivative jumps by c_p / m:
    # its local error is O(c_p v^2 h^2), i.e. a relative energy error of order
    # (omega_c h)^2 per crossing (omega_c: contact frequency), two crossings per bounce.
    e, gap, scale = run_energy(5e-5)
    assert gap.min() < -1e-3  # it really was in contact (penetration of mm)
    first_contact = np.flatnonzero(gap < 0)[0]
    assert np.abs(e[:first_contact] - e[0]).max() / scale < 1e-12
    w = highest_frequency()
    drift = np.abs(e - e[0]).max() / scale  # measured ~6e-7
    assert drift < 2 * (w * 5e-5) ** 2


def two_pass_system():
    """An elastic 3 x 3-node pad (point masses on y-springs to a translating backing plate) pressed
    with 3 N per node on the spinning elastic disc, symmetric (two-pass) contact with
    friction, the pad frame held by a y-spring: both passes, both bodies elastic."""
    g = np.linspace(-0.012, 0.012, 3)
    xx, zz = np.meshgrid(0.1 + g, g, indexing="ij")
    nodes = np.stack([xx, np.zeros(xx.shape), zz], -1).reshape(-1, 3)
    # node 9: the backing plate, rigid with the frame (its mass keeps the frame translation
    # independent of the nine face modes, else the mass matrix would be singular)
    nodes = np.vstack([nodes, [(0.1, 0.01, 0.0)]])
    stiff = np.zeros((30, 30))
    for i in range(9):
        stiff[3 * i + 1, 3 * i + 1] = 4e3
    masses = np.append(np.full(9, 0.02), 0.2)
    pad = lumped_modal_body("pad", nodes, masses, stiff, free_dofs=3 * np.arange(9) + 1)
    system = System()
    system.add_body(RotatingBody(elastic_disc(), "y", speed=2.0, damping_ratio=0.01))
    system.add_body(TranslatingBody(pad, ["y"], damping_ratio=0.01))
    system.add(NodalForce("press", "pad", np.arange(9), "y", -3.0))
    system.add(Spring("hold", "pad", [4], stiffness=500.0, damping=0.5, direction="y"))
    system.add(
        *symmetric_contact(
            "c",
            "pad",
            np.arange(9),
            CartesianChart("x", "z", origin=(0.1, 0.0, 0.0)),
            "disc",
            np.arange(12),
            PolarChart("y", "x"),
            penalty=2e4,
            friction=0.4,
            normal_a="-y",
            normal_b="y",
        )
    )
    return system


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_rk4_matches_dop853_two_pass_elastic_contact(kernel):
    system = two_pass_system().compile()
    outputs = {
        "pad_y": Coordinate("pad", 0),
        "pad_node": NodeDisplacement("pad", 0, "y"),
        "disc_y": NodeDisplacement("disc", 6, "y"),
    }
    res = simulate(
        system, t_end=0.03, dt=2e-6, record_interval=1e-3, outputs=outputs, kernel=kernel
    )
    ref = simulate_reference(
        system, t_end=0.03, outputs=outputs, times=res.time, rtol=1e-10, atol=1e-15, max_step=1e-4
    )
    for name in outputs:
        scale = np.abs(ref[name]).max()
        assert scale > 1e-6  # the pad really moved and pressed the disc
        # measured 5e-10 (pad node), more contact kinks than the single-pass case
        np.testing.assert_allclose(res.outputs[name][0], ref[name], atol=3e-9 * scale)
