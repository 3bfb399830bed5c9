"""The planar bushing against closed forms: statics, frequencies, energy, moment balance."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar import Bushing, Mechanism, RigidBody, ground, linearize, simulate

# slow: the planar kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow

GRAVITY = 9.81
MASS, INERTIA = 2.0, 0.05
STIFFNESS = (4e4, 1e4, 300.0)  # kx, ky [N/m], k_angle [N m/rad]


def mounted(angle=0.0, **motion):
    """A block on a bushing to the ground, the bushing's axes turned by ``angle``."""
    block = RigidBody("block", mass=MASS, inertia=INERTIA, **motion)
    mount = Bushing(ground.point(angle=angle), block.point(), STIFFNESS, name="mount")
    return block, Mechanism(gravity=(0.0, -GRAVITY)).add(block, mount)


def test_block_sags_by_its_weight_over_the_bushing_stiffness():
    # bushing axes turned by 30 degrees: the sag is K^-1 of the weight in those axes (statics);
    # with damping (ratios about 0.7) it settles there
    angle = np.deg2rad(30)
    block = RigidBody("block", mass=MASS, inertia=INERTIA)
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(
        block,
        Bushing(ground.point(angle=angle), block.point(), STIFFNESS, (400.0, 200.0, 5.0), "mount"),
    )
    result = simulate(mechanism, np.linspace(0.0, 2.0, 21))
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    weight_local = turn.T @ np.array([0.0, -MASS * GRAVITY])
    sag = turn @ (weight_local / np.array(STIFFNESS[:2]))
    np.testing.assert_allclose(result.coordinates("block")[0, -1, :2], sag, rtol=1e-5, atol=1e-9)
    # the anisotropic mount twists the block too: its torque about the bushing is zero only
    # with the moment of the force, which a pair at coinciding markers does not have
    assert abs(result.coordinates("block")[0, -1, 2]) < 1e-8
    # the mount's force on the ground marker at rest is the weight (marker i: the ground)
    load = result.element_force("mount")[0, -1]
    np.testing.assert_allclose(load[:2], [0.0, -MASS * GRAVITY], atol=1e-6)  # measured 6e-8 N


def test_frequencies_are_those_of_the_springs():
    # sqrt(kx / m), sqrt(ky / m), sqrt(k_angle / J) about the rest state (any vibration text)
    _, mechanism = mounted()
    frequencies = linearize(mechanism).frequencies()
    expected = np.sort(np.sqrt([STIFFNESS[0] / MASS, STIFFNESS[1] / MASS, STIFFNESS[2] / INERTIA]))
    np.testing.assert_allclose(frequencies, expected, rtol=1e-6)


def test_an_offset_bushing_keeps_the_energy_and_the_pair_balanced():
    # the block hangs 0.3 m beside its mount, swings and spins: without damping the energy
    # (the bushing's 1/2 d^T K d and angular part, gravity, kinetic) stays (measured 2.4e-9 J
    # of 0.5 J); the force reported as the mount's is the one the run applied (Newton)
    block = RigidBody(
        "block", mass=MASS, inertia=INERTIA, velocity=(0.2, 0.5), angular_velocity=3.0
    )
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(
        block, Bushing(ground.point(-0.3, 0.0, angle=0.4), block.point(), STIFFNESS, name="mount")
    )
    times = np.linspace(0.0, 1.0, 101)
    result = simulate(mechanism, times, rtol=1e-10, atol=1e-12)
    assert not result.failed.any()
    energy = result.energy()[0].sum(axis=1)
    assert np.ptp(energy) < 2e-8 * np.abs(result.energy()[0]).max()
    # force on the block = -(load on the ground marker): m a = -load + m g
    load = result.element_force("mount")[0]
    accel = result.solved()[0, :, :2]
    np.testing.assert_allclose(MASS * accel, -load[:, :2] + [0.0, -MASS * GRAVITY], atol=1e-8)


def test_bad_bushing_is_refused():
    block = RigidBody("block", mass=1.0, inertia=0.1)
    with pytest.raises(InvalidParameterError, match="Bushing stiffness must be three"):
        Bushing(ground.point(), block.point(), (1.0, -2.0, 3.0))
    with pytest.raises(InvalidParameterError, match="Bushing damping must be three"):
        Bushing(ground.point(), block.point(), (1.0, 2.0, 3.0), (1.0, 2.0))


def test_two_free_bodies_on_a_bushing_keep_their_momenta():
    # action and reaction with the pair's moment: two free blocks joined by an offset,
    # turned bushing keep their total linear and angular momentum and their energy
    first = RigidBody(
        "first", mass=MASS, inertia=INERTIA, velocity=(0.1, -0.05), angular_velocity=0.5
    )
    second = RigidBody(
        "second",
        mass=3.0,
        inertia=0.03,
        position=(0.3, 0.05),
        velocity=(-0.2, 0.1),
        angular_velocity=-0.4,
    )
    mount = Bushing(first.point(0.1, 0.0, angle=0.4), second.point(-0.1, -0.05), STIFFNESS)
    times = np.linspace(0.0, 1.0, 51)
    result = simulate(Mechanism().add(first, second, mount), times, rtol=1e-10, atol=1e-12)
    assert not result.failed.any()
    momentum = np.zeros((51, 2))
    angular = np.zeros(51)
    for body in (first, second):
        x, y, _ = result.coordinates(body.name)[0].T
        vx, vy, w = result.rates(body.name)[0].T
        momentum += body.mass * np.column_stack([vx, vy])
        angular += body.mass * (x * vy - y * vx) + body.inertia * w
    assert np.ptp(result.energy()[0, :, 1]) > 1e-4  # the bushing works
    # measured 1.9e-15 kg m/s, 5e-14 kg m^2/s and 6.3e-9 of the energy (rtol 1e-10)
    assert np.abs(momentum - momentum[0]).max() < 1e-10
    assert np.ptp(angular) < 1e-9 * np.abs(angular).max()
    energy = result.energy()[0].sum(axis=1)
    assert np.ptp(energy) < 2e-8 * np.abs(result.energy()[0]).max()
