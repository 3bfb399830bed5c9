"""Penalty contact with friction on the planar engine against closed forms."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar import (
    Contact,
    Mechanism,
    RigidBody,
    SpringDamper,
    contacts,
    ground,
    simulate,
)

# slow: the planar kernels take about 25 s to compile, which the README's pytest (5 min on a
# fresh clone of 2 cores) cannot spare in every test process; CI runs these with -m slow
pytestmark = pytest.mark.slow

GRAVITY = 9.81


def block(velocity=(0.0, 0.0), height=0.05, **law):
    body = RigidBody(
        "block",
        mass=2.0,
        inertia=2.0 * (0.2**2 + 0.1**2) / 12,
        position=(0.0, height),
        velocity=velocity,
    )
    corners = [body.point(-0.1, -0.05), body.point(0.1, -0.05)]
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(
        body, *contacts(corners, ground.point(), **law)
    )
    return mechanism


def test_block_settles_to_the_static_penetration():
    # two corners carry m g / 2 each: penetration m g / (2 k) (the penalty law's statics)
    law = dict(stiffness=1e6, damping=2e3)
    result = simulate(block(**law), np.linspace(0.0, 1.0, 11))
    assert not result.failed.any()
    y = result.coordinates("block")[0, -1, 1]
    assert 0.05 - y == pytest.approx(2.0 * GRAVITY / (2 * 1e6), rel=1e-4)


def test_sliding_block_stops_where_coulomb_says():
    # v0 = 1 m/s, mu = 0.3: it stops after v0^2 / (2 mu g) = 0.1699 m at t = v0 / (mu g) = 0.34 s
    # (rigid-body Coulomb friction); the regularisation (eps = 1e-4 m/s) lets it creep after
    law = dict(stiffness=1e6, damping=2e3, friction=0.3, regularization=1e-4)
    start = 0.05 - 2.0 * GRAVITY / (2 * 1e6)
    times = np.linspace(0.0, 0.6, 61)
    result = simulate(block(velocity=(1.0, 0.0), height=start, **law), times)
    assert not result.failed.any()
    x = result.coordinates("block")[0, :, 0]
    stop = 1.0**2 / (2 * 0.3 * GRAVITY)
    assert x[-1] == pytest.approx(stop, rel=2e-3)
    speed = result.rates("block")[0, :, 0]
    assert abs(speed[times == 0.2][0] - (1.0 - 0.3 * GRAVITY * 0.2)) < 2e-3


def test_point_on_a_cylinder_rests_at_the_penetration():
    # a 1 kg point-like body on a fixed circle of radius 0.1 m: m g / k below the top
    ball = RigidBody("ball", mass=1.0, inertia=1e-4, position=(0.0, 0.1))
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(
        ball, Contact(ball.point(), ground.point(), stiffness=1e5, damping=500.0, radius=0.1)
    )
    result = simulate(mechanism, np.linspace(0.0, 1.0, 11))
    assert 0.1 - result.coordinates("ball")[0, -1, 1] == pytest.approx(GRAVITY / 1e5, rel=1e-4)


def test_bad_contact_law_is_refused():
    with pytest.raises(InvalidParameterError, match="Contact stiffness"):
        Contact(ground.point(), ground.point(1, 0), stiffness=0.0)
    with pytest.raises(InvalidParameterError, match="Contact friction"):
        Contact(ground.point(), ground.point(1, 0), stiffness=1.0, friction=-0.1)


def test_contact_forces_are_outputs():
    # the settled block of the first test: each corner pushes m g / 2 up, nothing sideways
    body = RigidBody("block", mass=2.0, inertia=2.0 * (0.2**2 + 0.1**2) / 12, position=(0.0, 0.05))
    corners = [
        Contact(body.point(x, -0.05), ground.point(), 1e6, 2e3, 0.3, name=f"corner{k}")
        for k, x in enumerate((-0.1, 0.1))
    ]
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(body, *corners)
    result = simulate(mechanism, np.linspace(0.0, 1.0, 11))
    loads = np.array([result.element_force(f"corner{k}")[0, -1] for k in range(2)])
    np.testing.assert_allclose(loads[:, 1], 2.0 * GRAVITY / 2, rtol=1e-4)
    np.testing.assert_allclose(loads[:, [0, 2]], 0.0, atol=1e-6)
    # unnamed elements answer to their kind and markers
    assert mechanism.force("corner1") is corners[1]
    spring = SpringDamper(body.point(), ground.point(0.0, 1.0), 10.0)
    assert Mechanism().add(body, spring).force(spring.label()) is spring
