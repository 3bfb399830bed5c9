"""Pendulums on the planar engine against closed forms."""

import numpy as np
import pytest
from scipy.special import ellipk

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.planar import (
    FlexibleBody,
    Mechanism,
    Revolute,
    RigidBody,
    ground,
    linearize,
    simulate,
)

GRAVITY = 9.81

# slow: the planar kernels take 25 to 35 s to compile, which the README's pytest (5 min on a
# fresh clone of 2 cores) cannot spare; CI runs these with -m slow
pytestmark = pytest.mark.slow


def rod_pendulum(angle_from_vertical: float, length: float = 1.0, mass: float = 1.0) -> Mechanism:
    rod = RigidBody(
        "rod",
        mass=mass,
        inertia=mass * length**2 / 12,
        center=(length / 2, 0.0),
        angle=-np.pi / 2 + angle_from_vertical,
    )
    mechanism = Mechanism(gravity=(0.0, -GRAVITY))
    mechanism.add(rod, Revolute(ground.point(), rod.point(), name="pivot"))
    return mechanism


def zero_crossings(t, signal):
    index = np.flatnonzero(np.diff(np.sign(signal)) != 0)
    return t[index] - signal[index] * (t[index + 1] - t[index]) / (
        signal[index + 1] - signal[index]
    )


def test_rigid_pendulum_period_matches_the_elliptic_integral():
    # compound pendulum: T = 4 / w0 K(sin^2(theta0 / 2)), w0^2 = m g d / J_pivot
    # (any dynamics text, e.g. Meriam & Kraige); the run's tolerance gives 1e-6
    amplitude = np.deg2rad(60)
    t = np.linspace(0.0, 6.0, 1201)
    result = simulate(rod_pendulum(amplitude), t)
    assert not result.failed.any()
    angle = result.coordinates("rod")[0, :, 2] + np.pi / 2
    period = 2 * np.mean(np.diff(zero_crossings(t, angle)))
    w0 = np.sqrt(GRAVITY * 0.5 / (1.0 / 3.0))
    assert period == pytest.approx(4 / w0 * ellipk(np.sin(amplitude / 2) ** 2), rel=1e-6)
    assert result.joint_residual[0] < 1e-10


def test_pivot_reaction_at_release_matches_newton_euler():
    # released from rest at theta0: alpha = -m g d sin(theta0) / J_pivot, and the pivot force
    # F = m a_c - m g with a_c = alpha x r_c (no centripetal part at rest)
    theta0 = np.deg2rad(40)
    result = simulate(rod_pendulum(theta0), [0.0, 1e-3])
    force = result.reaction("pivot")[0, 0]
    d = 0.5
    alpha = -GRAVITY * d * np.sin(theta0) / (1.0 / 3.0)
    r_c = d * np.array([np.sin(theta0), -np.cos(theta0)])
    a_c = alpha * np.array([-r_c[1], r_c[0]])
    np.testing.assert_allclose(force, a_c - np.array([0.0, -GRAVITY]), atol=1e-9)


def test_rigid_pendulum_small_oscillation_eigenvalue():
    # w0 = sqrt(m g d / J_pivot) for the linearised compound pendulum
    lin = linearize(rod_pendulum(0.0))
    assert lin.frequencies()[0] == pytest.approx(np.sqrt(GRAVITY * 0.5 * 3.0), rel=1e-7)


def test_energy_is_conserved_by_a_swinging_pendulum():
    # no damping: kinetic + potential energy constant; drift bounded by the step control
    t = np.linspace(0.0, 10.0, 501)
    result = simulate(rod_pendulum(np.deg2rad(120)), t)
    angle = result.coordinates("rod")[0, :, 2]
    rate = result.rates("rod")[0, :, 2]
    energy = 0.5 * (1.0 / 3.0) * rate**2 + GRAVITY * 0.5 * np.sin(angle)
    assert np.ptp(energy) < 1e-6 * np.abs(energy).max()


def test_flexible_pendulum_first_elastic_frequency_is_the_pinned_free_beam():
    # Euler-Bernoulli pinned-free beam: beta L = 3.9266, 7.0686 (Blevins, table 8-1); the
    # free frame rotation plus clamped modes of the frame at the pin give these, so the
    # floating-frame coupling terms (b, C1, a) are right. 8 clamped modes on 16 elements:
    # 3e-6 and 3e-5 off (4 modes: 1e-5 and 5e-4; docs/mechanisms.md)
    beam = PlanarBeam(
        length=1.0,
        youngs_modulus=2.1e11,
        density=7850.0,
        area=1e-4,
        second_moment=2e-10 / 12 * 10,
        elements=16,
    )
    body = FlexibleBody("beam", beam=beam.reduce(8), angle=-np.pi / 2)
    lin = linearize(Mechanism().add(body, Revolute(ground.point(), body.node(0))))
    ref = np.sqrt(
        beam.youngs_modulus * beam.second_moment / (beam.mass_per_length * beam.length**4)
    )
    np.testing.assert_allclose(
        lin.frequencies()[:2], np.array([3.92660231, 7.06858275]) ** 2 * ref, rtol=5e-5
    )


def test_flexible_pendulum_conserves_its_energy():
    # no damping, no drive: kinetic + gravity + elastic energy constant (the floating-frame
    # terms and the foreshortening that stiffens the beam are one Lagrangian; measured 1.3e-11 J
    # at rtol 1e-9 over 2 s from 60 degrees, 3 modes)
    beam = PlanarBeam(
        length=1.0,
        youngs_modulus=2.1e11,
        density=7850.0,
        area=9e-5,
        second_moment=0.03 * 0.003**3 / 12,
    )
    body = FlexibleBody("beam", beam=beam.reduce(3), angle=-np.pi / 2 + np.pi / 3)
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(body, Revolute(ground.point(), body.node(0)))
    result = simulate(mechanism, np.linspace(0.0, 2.0, 101), rtol=1e-9, atol=1e-11)
    energy = result.energy()[0].sum(axis=1)
    assert np.ptp(energy) < 1e-9
    assert np.abs(result.coordinates("beam")[0, :, 3:]).max() > 1e-4  # the beam did bend
