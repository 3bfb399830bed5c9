"""Spatial rigid-body mechanisms against closed forms.

Slow: the spatial kernels compile in about 25 s, which the README's pytest (5 min on a fresh
clone) cannot spare; CI runs them with ``pytest -m slow``.
"""

import numpy as np
import pytest
from scipy.special import ellipk

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar import ConstantRate
from fuzzymbs.mbs.spatial import (
    Cylindrical,
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    Spherical,
    Universal,
    frame_with_z,
    ground,
    simulate,
)

GRAVITY = 9.81

pytestmark = pytest.mark.slow


def test_conical_pendulum_keeps_its_cone():
    # steady conical motion of a spherical pendulum: w^2 = g / (L cos theta) (any dynamics text)
    length, theta = 1.0, np.deg2rad(30)
    rate = np.sqrt(GRAVITY / (length * np.cos(theta)))
    bob_at = np.array([length * np.sin(theta), 0.0, -length * np.cos(theta)])
    bob = RigidBody(
        "bob",
        mass=1.0,
        inertia=(1e-6, 1e-6, 1e-6),
        position=bob_at,
        velocity=np.cross([0, 0, rate], bob_at),
        angular_velocity=(0, 0, rate),
    )
    mechanism = Mechanism(gravity=(0, 0, -GRAVITY)).add(
        bob, Spherical(ground.point(), bob.point(-bob_at))
    )
    result = simulate(mechanism, np.linspace(0.0, 2.0, 201))
    position = result.position("bob")[0]
    np.testing.assert_allclose(position[:, 2], bob_at[2], atol=1e-9)
    turned = np.unwrap(np.arctan2(position[:, 1], position[:, 0]))
    np.testing.assert_allclose(turned, rate * result.times, atol=1e-8)
    assert result.joint_residual[0] < 1e-10


def test_torque_free_symmetric_body_precesses_at_eulers_rate():
    # Euler's equations for I1 = I2: the body-frame angular velocity turns about the symmetry
    # axis at lambda = (I3 - I1) / I1 w3, its magnitude and w3 constant (Goldstein, sec. 5.6)
    inertia = (2.0, 2.0, 3.0)
    w0 = np.array([0.5, 0.0, 4.0])
    body = RigidBody("top", mass=1.0, inertia=inertia, angular_velocity=w0)
    t = np.linspace(0.0, 3.0, 301)
    result = simulate(Mechanism().add(body), t, rtol=1e-9, atol=1e-11)
    w = result.angular_velocity("top")[0]
    rate = (inertia[2] - inertia[0]) / inertia[0] * w0[2]
    np.testing.assert_allclose(w[:, 0], 0.5 * np.cos(rate * t), atol=1e-7)
    np.testing.assert_allclose(w[:, 1], 0.5 * np.sin(rate * t), atol=1e-7)
    np.testing.assert_allclose(w[:, 2], 4.0, atol=1e-9)


def test_hinged_rod_swings_at_the_elliptic_period():
    # a rod on a revolute joint about the global y axis: the compound pendulum of the planar
    # tests, T = 4 / w0 K(sin^2(theta0 / 2)), w0^2 = m g d / J_pivot
    theta0 = np.deg2rad(50)
    direction = np.array([np.sin(theta0), 0.0, -np.cos(theta0)])
    rod = RigidBody(
        "rod",
        mass=1.0,
        inertia=(1 / 12, 1 / 12, 1e-4),
        position=0.5 * direction,
        orientation=frame_with_z(direction),
    )
    hinge = frame_with_z([0.0, 1.0, 0.0])
    rod_hinge = rod.orientation.T @ hinge
    mechanism = Mechanism(gravity=(0, 0, -GRAVITY)).add(
        rod, Revolute(ground.point(axes=hinge), rod.point((0, 0, -0.5), axes=rod_hinge))
    )
    t = np.linspace(0.0, 5.0, 1001)
    result = simulate(mechanism, t, rtol=1e-10, atol=1e-12)
    x = result.position("rod")[0, :, 0]
    index = np.flatnonzero(np.diff(np.sign(x)) != 0)
    crossings = t[index] - x[index] * (t[index + 1] - t[index]) / (x[index + 1] - x[index])
    w0 = np.sqrt(GRAVITY * 0.5 / (1 / 3))
    assert 2 * np.mean(np.diff(crossings)) == pytest.approx(
        4 / w0 * ellipk(np.sin(theta0 / 2) ** 2), rel=1e-7
    )
    assert np.abs(result.position("rod")[0, :, 1]).max() < 1e-9  # stays in its plane


def test_spatial_slider_crank_matches_its_kinematics():
    # crank (driven revolute about z), rod (spherical at the crank pin, universal at the slider),
    # slider (prismatic along x): x = r cos(phi) + sqrt(l^2 - r^2 sin^2 phi) (any mechanism text)
    r, length, w = 0.1, 0.3, 20.0
    crank = RigidBody(
        "crank",
        mass=0.5,
        inertia=(1e-3, 1e-3, 1e-3),
        position=(r / 2, 0, 0),
        angular_velocity=(0, 0, w),
        velocity=(0, r * w / 2, 0),
    )
    rod_axes = frame_with_z([1.0, 0.0, 0.0])
    rod = RigidBody(
        "rod",
        mass=0.3,
        inertia=(3e-3, 3e-3, 1e-5),
        position=(r + length / 2, 0, 0),
        orientation=rod_axes,
        velocity=(0, r * w / 2, 0),
        angular_velocity=(0, 0, -r * w / length),
    )
    slider = RigidBody("slider", mass=0.2, inertia=(1e-4, 1e-4, 1e-4), position=(r + length, 0, 0))
    slide_axes = frame_with_z([1.0, 0.0, 0.0])
    mechanism = Mechanism().add(
        crank,
        rod,
        slider,
        Revolute(ground.point(), crank.point((-r / 2, 0, 0)), drive=ConstantRate(w)),
        Spherical(crank.point((r / 2, 0, 0)), rod.point((0, 0, -length / 2))),
        # the cross: one arm across the rod in the plane of motion (the rod's body y, global y),
        # the other along the slider's z (global z, the axis the rod swings about)
        Universal(
            rod.point((0, 0, length / 2), axes=frame_with_z([0.0, 1.0, 0.0])),
            slider.point(axes=np.eye(3)),
        ),
        Prismatic(ground.point(axes=slide_axes), slider.point(axes=slide_axes)),
    )
    t = np.linspace(0.0, 0.6, 121)
    result = simulate(mechanism, t, rtol=1e-9, atol=1e-11)
    assert not result.failed.any()
    phi = w * t
    exact = r * np.cos(phi) + np.sqrt(length**2 - (r * np.sin(phi)) ** 2)
    np.testing.assert_allclose(result.position("slider")[0, :, 0], exact, atol=1e-8)


def test_block_slides_down_an_inclined_prismatic_and_cylindrical_guide():
    # frictionless guide inclined by alpha: s = g sin(alpha) t^2 / 2 along it (both joints)
    alpha = np.deg2rad(25)
    axis = np.array([np.cos(alpha), 0.0, -np.sin(alpha)])
    axes = frame_with_z(axis)
    t = np.linspace(0.0, 1.0, 11)
    for joint in (Prismatic, Cylindrical):
        block = RigidBody("block", mass=1.0, inertia=(0.01, 0.02, 0.03), orientation=axes)
        mechanism = Mechanism(gravity=(0, 0, -GRAVITY)).add(
            block, joint(ground.point(axes=axes), block.point(axes=np.eye(3)))
        )
        position = simulate(mechanism, t).position("block")[0]
        np.testing.assert_allclose(position @ axis, GRAVITY * np.sin(alpha) * t**2 / 2, atol=1e-8)


def test_bad_bodies_and_joints_are_refused_by_name():
    with pytest.raises(InvalidParameterError, match="inertia is singular or not physical"):
        RigidBody("plate", inertia=(1.0, 1.0, 3.0))
    with pytest.raises(InvalidParameterError, match="mass must be finite and > 0"):
        RigidBody("void", mass=0.0)
    bob = RigidBody("bob", position=(1.0, 0.0, 0.0))
    mechanism = Mechanism().add(bob, Spherical(ground.point(), bob.point(), name="ball"))
    with pytest.raises(InvalidParameterError, match="joint ball is violated at the start by 1"):
        mechanism.check()
    with pytest.raises(InvalidParameterError, match="Spherical cannot be driven"):
        Spherical(ground.point(), bob.point(), drive=ConstantRate(1.0))
