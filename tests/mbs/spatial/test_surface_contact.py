"""Node-to-surface contact on the spatial engine (SurfaceContact): the brake's contact on
bodies in any frame motion.

* The second method is the brake's own engine: a flexible pad pressed on a turning flexible
  disc patch, built once from the same FlexibleBody and joint objects, runs in minimal
  coordinates (System: PenaltyContact, the SIMD contact kernel) and in absolute
  coordinates (Mechanism: SurfaceContact). Two codes, two formulations; they must agree
  to the integration tolerance.
* A floating block (no joint) dropped on a flexible plate settles with its weight carried
  by the contacts (statics: the forces sum to m g), which the minimal form cannot express.
"""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.contact import PenaltyContact, PolarChart
from fuzzymbs.mbs.forces import NodalForce
from fuzzymbs.mbs.integrate import simulate_reference
from fuzzymbs.mbs.lumped import lumped_modal_body
from fuzzymbs.mbs.spatial import (
    ConstantRate,
    Fixed,
    FlexibleBody,
    MarkerLoad,
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    SurfaceContact,
    frame_with_z,
    ground,
    simulate,
    surface_contacts,
)
from fuzzymbs.mbs.system import Coordinate, System

# slow: the spatial kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow

Y = frame_with_z((0.0, 1.0, 0.0))
SPEED = 2.0  # rad/s: the pad slides at 0.2 m/s
PRESS = 50.0  # N on each of the pad's four contact nodes
LAW = {"penalty": 1e5, "friction": 0.3, "regularization_velocity": 1e-3}


def bars(positions, pairs, stiffness):
    """Stiffness matrix of axial springs between nodes (rows (node, x/y/z))."""
    k = np.zeros((3 * len(positions), 3 * len(positions)))
    for i, j in pairs:
        n = positions[j] - positions[i]
        block = stiffness * np.outer(n, n) / (n @ n)
        for a, b, sign in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            k[3 * a : 3 * a + 3, 3 * b : 3 * b + 3] += sign * block
    return k


def disc_patch():
    """A sector of an annulus in y = 0 (3 radii x 8 angles) on bars, its inner ring held by
    the frame, springs to the frame across (y): a flexible master surface."""
    radii = [0.08, 0.1, 0.12]
    angles = np.linspace(-0.4, 0.4, 8)
    positions = np.array([[r * np.cos(a), 0.0, -r * np.sin(a)] for r in radii for a in angles])
    pairs = []
    for i in range(3):
        for j in range(8):
            n = 8 * i + j
            if j < 7:
                pairs.append((n, n + 1))
            if i < 2:
                pairs.append((n, n + 8))
                if j < 7:
                    pairs += [(n, n + 9), (n + 1, n + 8)]
    k = bars(positions, pairs, 4e5)
    k[1::3, 1::3] += np.eye(24) * 2e4  # out of plane: an elastic foundation
    return lumped_modal_body(
        "disc",
        positions,
        np.full(24, 0.01),
        k,
        free_dofs=np.arange(24, 72),
        node_sets={"patch": np.arange(24)},
    )


def pad():
    """Four contact nodes on the patch (y = 0) under a top node held by the frame."""
    positions = np.array(
        [[0.095 * np.cos(a), 0.0, -0.095 * np.sin(a)] for a in (-0.05, 0.05)]
        + [[0.105 * np.cos(a), 0.0, -0.105 * np.sin(a)] for a in (-0.05, 0.05)]
        + [[0.1, 0.01, 0.0]]
    )
    pairs = [(i, j) for i in range(5) for j in range(i + 1, 5)]
    return lumped_modal_body(
        "pad",
        positions,
        np.array([0.01, 0.01, 0.01, 0.01, 0.02]),
        bars(positions, pairs, 2e5),
        free_dofs=np.arange(12),
        node_sets={"contact": [0, 1, 2, 3]},
    )


def brake_like_bodies():
    disc = FlexibleBody("disc", disc_patch(), damping_ratio=0.02)
    shoe = FlexibleBody("pad", pad(), damping_ratio=0.02)
    joints = [
        Revolute(ground.point(axes=Y), disc.point(axes=Y), ConstantRate(SPEED)),
        Prismatic(ground.point(axes=Y), shoe.point(axes=Y)),
    ]
    return disc, shoe, joints


def test_pad_on_a_turning_disc_agrees_with_the_brake_engine():
    disc, shoe, joints = brake_like_bodies()
    chart = PolarChart("y", "x")
    times = np.linspace(0.0, 0.05, 101)

    system = System()
    for body in (disc, shoe):
        system.add_body(body)
    for joint in joints:
        system.add_joint(joint)
    system.add(NodalForce("press", "pad", "contact", "-y", PRESS))
    system.add(
        PenaltyContact("pad->disc", "pad", "contact", "disc", "patch", chart, **LAW, normal="y")
    )
    compiled = system.compile()
    outputs = {
        f"{b}{i}": Coordinate(b, i)
        for b, dofs in compiled.body_dofs.items()
        for i in range(dofs.stop - dofs.start)
    }
    minimal = simulate_reference(compiled, t_end=times[-1], outputs=outputs, times=times)

    mechanism = Mechanism().add(disc, shoe, *joints)
    mechanism.add(*[MarkerLoad(shoe.node(k), force=(0.0, -PRESS, 0.0)) for k in range(4)])
    mechanism.add(
        *surface_contacts(
            shoe,
            "contact",
            disc.point(),
            "patch",
            chart,
            stiffness=LAW["penalty"],
            friction=LAW["friction"],
            regularization=LAW["regularization_velocity"],
            normal="y",
        )
    )
    absolute = simulate(mechanism, times, rtol=1e-10, atol=1e-13)
    assert not absolute.failed.any()

    slide = absolute.position("pad")[0][:, 1]
    # the pad sinks 6.7 mm: the patch's soft foundation gives under 200 N
    assert slide.min() < -5e-3
    # measured: 3e-13 m; the modes 3.6e-11 (disc) and 9.8e-10 (pad) of their largest value
    np.testing.assert_allclose(slide, minimal["pad0"], atol=1e-11)
    for body, first in (("disc", 0), ("pad", 1)):
        mine = np.stack([minimal[f"{body}{first + m}"] for m in range(body_modes(body))], -1)
        theirs = absolute.modal_coordinates(body)[0]
        scale = np.abs(mine).max()
        assert scale > 1e-5  # the contact moves every body's modes
        np.testing.assert_allclose(theirs, mine, atol=1e-8 * scale)


def body_modes(name):
    return (disc_patch() if name == "disc" else pad()).n_modes


def test_a_floating_block_settles_on_a_flexible_plate():
    plate_modal = disc_patch()
    plate = FlexibleBody("plate", plate_modal, damping_ratio=0.2)
    mass = 0.4
    corners = [(0.095, -0.05), (0.095, 0.05), (0.105, -0.05), (0.105, 0.05)]
    centre = np.array([0.1, 0.005, 0.0])  # above the middle of the four corners
    block_nodes = [np.array([r * np.cos(a), 0.0, -r * np.sin(a)]) - centre for r, a in corners]
    block = RigidBody("block", mass=mass, inertia=(1e-4, 1e-4, 1e-4), position=centre)
    markers = [block.point(p) for p in block_nodes]
    mechanism = Mechanism(gravity=(0.0, -9.81, 0.0)).add(
        plate, block, Fixed(ground.point(), plate.point())
    )
    law = {"stiffness": 2e5, "damping": 40.0, "friction": 0.0}
    elements = [
        SurfaceContact(
            m,
            plate.point(),
            nodes="patch",
            chart=PolarChart("y", "x"),
            name=f"c{k}",
            normal="y",
            **law,
        )
        for k, m in enumerate(markers)
    ]
    mechanism.add(*elements)
    times = np.linspace(0.0, 0.6, 61)
    result = simulate(mechanism, times)
    assert not result.failed.any()
    total = sum(result.element_force(f"c{k}")[0, -1, 1] for k in range(4))
    # statics: the contacts carry the block's weight once it settles (measured 6e-6 off at
    # 0.6 s; 5e-5 at 0.5 s, 1.6e-3 at 0.3 s)
    assert total == pytest.approx(mass * 9.81, rel=1e-4)
    assert result.energy()[0, -1].sum() < result.energy()[0, 0].sum()  # damped, not gained


def test_surface_contact_refuses_what_it_cannot_hold():
    plate = FlexibleBody("plate", disc_patch())
    block = RigidBody("block", mass=1.0)
    chart = PolarChart("y", "x")
    with pytest.raises(InvalidParameterError, match=r"needs a flexible body's nodes.*ground"):
        SurfaceContact(block.point(), ground.point(), nodes="patch", chart=chart, stiffness=1.0)
    with pytest.raises(InvalidParameterError, match="rigid body 'block'"):
        SurfaceContact(plate.node(0), block.point(), nodes="patch", chart=chart, stiffness=1.0)
    with pytest.raises(InvalidParameterError, match="chart must be"):
        SurfaceContact(block.point(), plate.point(), nodes="patch", chart="y", stiffness=1.0)
    bad = SurfaceContact(block.point(), plate.point(), nodes="rim", chart=chart, stiffness=1.0)
    with pytest.raises(InvalidParameterError, match="unknown node set 'rim'"):
        Mechanism().add(plate, block, Fixed(ground.point(), plate.point()), bad).pack()
