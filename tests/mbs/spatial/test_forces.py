"""Spatial contact with friction and user force elements against closed forms and the
built-in spring."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.spatial import (
    Contact,
    Mechanism,
    Prismatic,
    RigidBody,
    Spherical,
    SpringDamper,
    UserForce,
    contacts,
    frame_with_z,
    ground,
    simulate,
)

from .user_forces import line_spring

# slow: the spatial kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow

GRAVITY = 9.81
CORNERS = [(sx * 0.1, sy * 0.05, -0.025) for sx in (-1, 1) for sy in (-1, 1)]


def block(position=(0.0, 0.0, 0.025), velocity=(0.0, 0.0, 0.0)):
    """A 2 kg block of 0.2 x 0.1 x 0.05 m, its frame at its centre of mass."""
    return RigidBody(
        "block",
        mass=2.0,
        inertia=2.0 / 12 * np.array([0.1**2 + 0.05**2, 0.2**2 + 0.05**2, 0.2**2 + 0.1**2]),
        position=position,
        velocity=velocity,
    )


def test_block_settles_on_four_corners_to_the_static_penetration():
    # four corners carry m g / 4 each: penetration m g / (4 k) (the penalty law's statics)
    body = block()
    law = dict(stiffness=1e6, damping=2e3)
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(
        body, *contacts([body.point(c) for c in CORNERS], ground.point(), **law)
    )
    result = simulate(mechanism, np.linspace(0.0, 1.0, 11))
    assert not result.failed.any()
    z = result.position("block")[0, -1, 2]
    assert 0.025 - z == pytest.approx(2.0 * GRAVITY / (4 * 1e6), rel=1e-4)
    # the penalty energy is counted: at rest, 4 x 1/2 k g^2
    elastic = result.energy()[0, -1, 2]
    assert elastic == pytest.approx(4 * 0.5 * 1e6 * (0.025 - z) ** 2, rel=1e-3)


def test_block_on_a_moving_plate_is_dragged_to_its_speed():
    # a heavy plate slides along x at 2 m/s (a prismatic guide, 1e6 kg); the block, at rest,
    # is accelerated by friction at mu g until it moves with the plate at t = v / (mu g)
    # (rigid-body Coulomb friction; the slip is measured against the plate's own surface)
    mu, speed = 0.4, 2.0
    plate = RigidBody("plate", mass=1e6, inertia=(1e6, 1e6, 1e6), velocity=(speed, 0.0, 0.0))
    start = 0.025 - 2.0 * GRAVITY / (4 * 1e6)
    body = block(position=(0.0, 0.0, start))
    law = dict(stiffness=1e6, damping=2e3, friction=mu, regularization=1e-4)
    along_x = frame_with_z((1.0, 0.0, 0.0))
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(
        plate,
        body,
        Prismatic(ground.point(axes=along_x), plate.point(axes=along_x)),
        *contacts([body.point(c) for c in CORNERS], plate.point(), **law),
    )
    times = np.linspace(0.0, 1.0, 101)
    result = simulate(mechanism, times)
    assert not result.failed.any()
    velocity = result.velocity("block")[0, :, 0]
    at = times == 0.3
    # measured 3.6e-9 m/s off mu g t at 0.3 s and 5e-10 off the plate's speed at the end
    assert abs(velocity[at][0] - mu * GRAVITY * 0.3) < 1e-6
    grip = speed / (mu * GRAVITY)
    assert abs(velocity[-1] - result.velocity("plate")[0, -1, 0]) < 1e-6
    assert velocity[times < grip - 0.05].max() < speed


def test_point_on_a_sphere_rests_at_the_penetration():
    # a 1 kg point-like body on top of a fixed sphere of radius 0.1 m: m g / k below its top
    ball = RigidBody("ball", mass=1.0, inertia=(1e-4, 1e-4, 1e-4), position=(0.0, 0.0, 0.1))
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(
        ball, Contact(ball.point(), ground.point(), stiffness=1e5, damping=500.0, radius=0.1)
    )
    result = simulate(mechanism, np.linspace(0.0, 1.0, 11))
    assert not result.failed.any()
    assert 0.1 - result.position("ball")[0, -1, 2] == pytest.approx(GRAVITY / 1e5, rel=1e-4)


def test_user_force_spring_matches_the_built_in_spring():
    # the same spring written by the user and built in: the same trajectory
    def hanging(spring):
        bob = RigidBody(
            "bob",
            mass=0.5,
            inertia=(1e-3, 1e-3, 1e-3),
            position=(0.1, 0.05, -0.4),
            velocity=(0.3, 0.0, 0.0),
        )
        return Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(bob, spring(bob))

    own = hanging(lambda bob: UserForce(bob.point(), ground.point(), line_spring, (200.0, 0.3)))
    built_in = hanging(
        lambda bob: SpringDamper(ground.point(), bob.point(), 200.0, free_length=0.3)
    )
    times = np.linspace(0.0, 1.0, 101)
    a = simulate(own, times, rtol=1e-10, atol=1e-12)
    b = simulate(built_in, times, rtol=1e-10, atol=1e-12)
    assert not (a.failed.any() or b.failed.any())
    assert np.ptp(a.position("bob")[0, :, 2]) > 0.01  # it bounces
    np.testing.assert_allclose(a.position("bob"), b.position("bob"), atol=1e-9)


def test_bad_contact_and_user_force_input_is_refused():
    ball = RigidBody("ball")
    with pytest.raises(InvalidParameterError, match="Contact stiffness must be finite and > 0"):
        Contact(ball.point(), ground.point(), stiffness=0.0)
    with pytest.raises(InvalidParameterError, match="Contact friction must be finite and >= 0"):
        Contact(ball.point(), ground.point(), stiffness=1.0, friction=-0.1)
    with pytest.raises(
        InvalidParameterError, match=r"compiled with fuzzymbs\.mbs\.spatial\.user_force"
    ):
        UserForce(ball.point(), None, lambda *args: None)


def test_contact_forces_are_outputs():
    # the settled block: each corner's contact pushes m g / 4 up, no friction
    body = block()
    law = dict(stiffness=1e6, damping=2e3, friction=0.3)
    corners = [
        Contact(body.point(c), ground.point(), name=f"corner{k}", **law)
        for k, c in enumerate(CORNERS)
    ]
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(body, *corners)
    result = simulate(mechanism, np.linspace(0.0, 1.0, 11))
    loads = np.array([result.element_force(f"corner{k}")[0, -1] for k in range(4)])
    np.testing.assert_allclose(loads[:, 2], 2.0 * GRAVITY / 4, rtol=1e-4)  # measured 1.1e-5
    np.testing.assert_allclose(loads[:, [0, 1, 3, 4, 5]], 0.0, atol=1e-6)
    with pytest.raises(InvalidParameterError, match="no force element named 'wheel'"):
        result.element_force("wheel")


def test_conical_pendulum_rod_force_is_the_joint_reaction():
    # steady conical motion of a point-like bob on a 1 m massless link (a ball joint at the
    # pivot): the joint pulls the bob towards the pivot with m g / cos(cone) (any text)
    length, cone, mass = 1.0, np.deg2rad(30), 1.5
    rate = np.sqrt(GRAVITY / (length * np.cos(cone)))
    at = np.array([length * np.sin(cone), 0.0, -length * np.cos(cone)])
    bob = RigidBody(
        "bob",
        mass=mass,
        inertia=(1e-6, 1e-6, 1e-6),
        position=at,
        velocity=np.cross([0.0, 0.0, rate], at),
        angular_velocity=(0.0, 0.0, rate),
    )
    mechanism = Mechanism(gravity=(0.0, 0.0, -GRAVITY)).add(
        bob, Spherical(ground.point(), bob.point(-at), name="pivot")
    )
    result = simulate(mechanism, np.linspace(0.0, 1.0, 11), rtol=1e-10, atol=1e-12)
    pull = result.reaction("pivot")[0]
    towards_pivot = -result.position("bob")[0] / length
    tension = mass * GRAVITY / np.cos(cone)
    # measured 9e-12 N and 6e-12 m/s^2
    np.testing.assert_allclose(pull, tension * towards_pivot, atol=1e-8)
    # the accelerations are the centripetal one: w^2 L sin(cone) towards the axis
    accelerations = result.solved()[0, :, :3]
    radial = -result.position("bob")[0] * np.array([1.0, 1.0, 0.0])
    np.testing.assert_allclose(accelerations, rate**2 * radial, atol=1e-8)
