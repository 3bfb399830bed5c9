"""The spatial bushing against closed forms: statics, the six frequencies, energy."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.spatial import Bushing, Mechanism, RigidBody, ground, linearize, simulate

# slow: the spatial kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow

GRAVITY = 9.81
MASS = 2.0
INERTIA = np.array([0.02, 0.03, 0.05])
STIFFNESS = (4e4, 2e4, 1e4, 300.0, 200.0, 100.0)


def test_block_sags_by_its_weight_over_the_bushing_stiffness():
    # the bushing's axes turned: the sag is A K^-1 A^T of the weight (statics); damped, the
    # block settles there without turning (its centre of mass is at the bushing)
    axes = Rotation.from_rotvec([0.3, -0.5, 0.2]).as_matrix()
    block = RigidBody("block", mass=MASS, inertia=INERTIA)
    mount = Bushing(
        ground.point(axes=axes),
        block.point(),
        STIFFNESS,
        (400.0, 300.0, 200.0, 3.0, 3.0, 3.0),
        name="mount",
    )
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(block, mount)
    result = simulate(mechanism, np.linspace(0.0, 2.0, 21))
    weight = np.array([0.0, 0.0, -MASS * GRAVITY])
    sag = axes @ ((axes.T @ weight) / np.array(STIFFNESS[:3]))
    np.testing.assert_allclose(result.position("block")[0, -1], sag, rtol=1e-5, atol=1e-10)
    np.testing.assert_allclose(result.euler_parameters("block")[0, -1], [1, 0, 0, 0], atol=1e-8)
    load = result.element_force("mount")[0, -1]
    np.testing.assert_allclose(load[:3], weight, atol=1e-5)  # measured 1.2e-6 N (settling)


def test_frequencies_are_those_of_the_springs():
    # about the rest state without gravity: sqrt(k / m) along each axis and
    # sqrt(k_angle / J) about each (the bushing's axes are the body's principal axes)
    block = RigidBody("block", mass=MASS, inertia=INERTIA)
    mechanism = Mechanism().add(block, Bushing(ground.point(), block.point(), STIFFNESS))
    expected = np.sort(
        np.concatenate(
            [np.sqrt(np.array(STIFFNESS[:3]) / MASS), np.sqrt(np.array(STIFFNESS[3:]) / INERTIA)]
        )
    )
    # central differences: measured within 4e-13
    np.testing.assert_allclose(linearize(mechanism).frequencies(), expected, rtol=1e-6)


def test_an_offset_bushing_keeps_the_energy():
    # the block hangs 0.2 m beside its turned mount and vibrates in all six directions with
    # small rotations: without damping the energy stays (kinetic, gravity, the bushing's)
    block = RigidBody(
        "block",
        mass=MASS,
        inertia=INERTIA,
        velocity=(0.05, -0.03, 0.04),
        angular_velocity=(0.2, -0.1, 0.3),
    )
    mount = Bushing(
        ground.point((-0.2, 0.0, 0.0), Rotation.from_rotvec([0.1, 0.2, -0.3]).as_matrix()),
        block.point(),
        STIFFNESS,
    )
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(block, mount)
    result = simulate(mechanism, np.linspace(0.0, 1.0, 101), rtol=1e-10, atol=1e-12)
    assert not result.failed.any()
    energy = result.energy()[0]
    assert energy[:, 2].max() > 1e-3  # the bushing works
    # the torques are the energy's own (J^T): measured 6.6e-11 J of 0.08 J
    assert np.ptp(energy.sum(axis=1)) < 1e-8 * np.abs(energy).max()


def test_bad_bushing_is_refused():
    block = RigidBody("block")
    with pytest.raises(InvalidParameterError, match="Bushing stiffness must be six"):
        Bushing(ground.point(), block.point(), (1.0, 2.0, 3.0))


def test_two_free_bodies_on_a_bushing_keep_their_momenta():
    # action and reaction: two free blocks joined by an offset bushing (markers 0.1 m
    # apart, turned axes) exchange force and torque so that the total linear and angular
    # momentum stay (Newton's third law with the pair's moment) and so does the energy
    first = RigidBody(
        "first",
        mass=MASS,
        inertia=INERTIA,
        velocity=(0.1, 0.0, -0.05),
        angular_velocity=(0.5, 0.2, -0.3),
    )
    second = RigidBody(
        "second",
        mass=3.0,
        inertia=(0.04, 0.02, 0.03),
        position=(0.3, 0.05, 0.0),
        velocity=(-0.2, 0.1, 0.0),
        angular_velocity=(-0.1, 0.4, 0.2),
    )
    axes = Rotation.from_rotvec([0.2, -0.1, 0.4]).as_matrix()
    mount = Bushing(first.point((0.1, 0.0, 0.0), axes), second.point((-0.1, -0.05, 0.0)), STIFFNESS)
    result = simulate(
        Mechanism().add(first, second, mount), np.linspace(0.0, 1.0, 51), rtol=1e-10, atol=1e-12
    )
    assert not result.failed.any()
    momentum = np.zeros((51, 3))
    angular = np.zeros((51, 3))
    for body in (first, second):
        r = result.position(body.name)[0]
        v = result.velocity(body.name)[0]
        w = result.angular_velocity(body.name)[0]
        turn = Rotation.from_quat(result.euler_parameters(body.name)[0][:, [1, 2, 3, 0]])
        momentum += body.mass * v
        angular += body.mass * np.cross(r, v) + turn.apply(w @ np.asarray(body.inertia).T)
    assert np.ptp(result.energy()[0, :, 2]) > 1e-4  # the bushing works
    # measured 1.2e-15 kg m/s, 1.7e-13 kg m^2/s and 5e-9 of the energy (rtol 1e-10)
    assert np.abs(momentum - momentum[0]).max() < 1e-10
    assert np.abs(angular - angular[0]).max() < 1e-8 * np.abs(angular).max()
    energy = result.energy()[0].sum(axis=1)
    assert np.ptp(energy) < 2e-8 * energy.max()
