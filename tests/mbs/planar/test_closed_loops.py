"""Closed kinematic loops on the planar engine: a four-bar against its one-degree-of-freedom
equation, a rigid slider-crank against its closed-form kinematics."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fuzzymbs.mbs.planar import (
    ConstantRate,
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    ground,
    simulate,
)

# slow: the planar kernels take about 25 s to compile, which the README's pytest (5 min on a
# fresh clone of 2 cores) cannot spare in every test process; CI runs these with -m slow
pytestmark = pytest.mark.slow

GRAVITY = 9.81
# crank-rocker (Grashof: 0.4 + 1.0 < 1.0 + 0.8), uniform bars of 1 kg/m
CRANK, COUPLER, ROCKER, BASE = 0.4, 1.0, 0.8, 1.0


def unit(angle):
    return np.array([np.cos(angle), np.sin(angle)])


def closure(phi):
    """Coupler and rocker angles for crank angle phi (the branch with the coupler above)."""
    a = CRANK * unit(phi)
    o4 = np.array([BASE, 0.0])
    span = o4 - a
    dist = np.hypot(*span)
    along = (COUPLER**2 - ROCKER**2 + dist**2) / (2 * dist)
    across = np.sqrt(COUPLER**2 - along**2)
    b = a + along * span / dist + across * np.array([-span[1], span[0]]) / dist
    return np.arctan2(*(b - a)[::-1]), np.arctan2(*(b - o4)[::-1])


def rates(phi):
    """d theta3 / d phi, d theta4 / d phi from the velocity loop."""
    t3, t4 = closure(phi)
    perp = lambda t: np.array([-np.sin(t), np.cos(t)])  # noqa: E731
    matrix = np.column_stack([COUPLER * perp(t3), -ROCKER * perp(t4)])
    return np.linalg.solve(matrix, -CRANK * perp(phi))


def generalized_mass_and_potential(phi):
    t3, t4 = closure(phi)
    r3, r4 = rates(phi)
    perp = lambda t: np.array([-np.sin(t), np.cos(t)])  # noqa: E731
    masses = [CRANK, COUPLER, ROCKER]
    inertia = [
        m * length**2 / 12 for m, length in zip(masses, [CRANK, COUPLER, ROCKER], strict=True)
    ]
    v1 = CRANK / 2 * perp(phi)
    v2 = CRANK * perp(phi) + COUPLER / 2 * r3 * perp(t3)
    v3 = ROCKER / 2 * r4 * perp(t4)
    mu = (
        sum(m * v @ v for m, v in zip(masses, [v1, v2, v3], strict=True))
        + inertia[0]
        + inertia[1] * r3**2
        + inertia[2] * r4**2
    )
    y = [
        CRANK / 2 * np.sin(phi),
        CRANK * np.sin(phi) + COUPLER / 2 * np.sin(t3),
        ROCKER / 2 * np.sin(t4),
    ]
    return mu, GRAVITY * sum(m * yi for m, yi in zip(masses, y, strict=True))


def four_bar_reference(phi0, rate0, times):
    """Lagrange's equation in the crank angle: mu phi'' + mu'/2 phi'^2 + V' = 0 (mu', V' by
    central differences), integrated by DOP853 at rtol 1e-11: an independent second method."""
    h = 1e-6

    def rhs(t, y):
        phi, w = y
        mu, _ = generalized_mass_and_potential(phi)
        mu_p, v_p = generalized_mass_and_potential(phi + h)
        mu_m, v_m = generalized_mass_and_potential(phi - h)
        return [w, -(0.5 * (mu_p - mu_m) / (2 * h) * w**2 + (v_p - v_m) / (2 * h)) / mu]

    return solve_ivp(
        rhs,
        (times[0], times[-1]),
        [phi0, rate0],
        t_eval=times,
        method="DOP853",
        rtol=1e-11,
        atol=1e-12,
    ).y[0]


def four_bar(phi0, rate0):
    t3, t4 = closure(phi0)
    r3, r4 = rates(phi0) * rate0
    bars = []
    for name, length, angle, origin, rate in [
        ("crank", CRANK, phi0, np.zeros(2), rate0),
        ("coupler", COUPLER, t3, CRANK * unit(phi0), r3),
        ("rocker", ROCKER, t4, np.array([BASE, 0.0]), r4),
    ]:
        velocity = (
            rate0 * CRANK * np.array([-np.sin(phi0), np.cos(phi0)]) if name == "coupler" else (0, 0)
        )
        bars.append(
            RigidBody(
                name,
                mass=length,
                inertia=length**3 / 12,
                center=(length / 2, 0.0),
                position=origin,
                angle=angle,
                velocity=velocity,
                angular_velocity=rate,
            )
        )
    crank, coupler, rocker = bars
    mechanism = Mechanism(gravity=(0.0, -GRAVITY)).add(
        *bars,
        Revolute(ground.point(), crank.point()),
        Revolute(crank.point(CRANK, 0), coupler.point()),
        Revolute(coupler.point(COUPLER, 0), rocker.point(ROCKER, 0)),
        Revolute(ground.point(BASE, 0), rocker.point()),
    )
    return mechanism


def test_four_bar_follows_its_one_degree_of_freedom_equation():
    times = np.linspace(0.0, 3.0, 301)
    result = simulate(four_bar(np.pi / 3, 4.0), times, rtol=1e-9, atol=1e-11)
    assert not result.failed.any()
    crank = result.coordinates("crank")[0, :, 2]
    reference = four_bar_reference(np.pi / 3, 4.0, times)
    # second method at rtol 1e-11; the engine at rtol 1e-9 with the loop projected every step
    np.testing.assert_allclose(crank, reference, atol=2e-6)
    assert result.joint_residual[0] < 1e-10


def test_four_bar_conserves_energy_over_a_long_run():
    times = np.linspace(0.0, 20.0, 201)
    result = simulate(four_bar(np.pi / 3, 4.0), times)
    energy = []
    for i in range(times.size):
        phi = result.coordinates("crank")[0, i, 2]
        w = result.rates("crank")[0, i, 2]
        mu, potential = generalized_mass_and_potential(phi)
        energy.append(0.5 * mu * w**2 + potential)
    energy = np.array(energy)
    # the default tolerances (rtol 1e-6): the drift over 20 s, measured 2.7e-6 of the energy;
    # the bound leaves a factor 4
    assert np.ptp(energy) < 1e-5 * np.abs(energy).max()
    # the engine's own energy (kinetic from its mass matrix, gravity from its first moments)
    # is the one-degree-of-freedom equation's, up to the potential's zero. The stored states
    # meet the loop to the projection tolerance (1e-10 m), where the one-degree-of-freedom
    # form, which reads the crank alone, and the engine's, which reads every body, part by
    # the forces (about 10 N) times that: measured 1.4e-9 J at a 9.9e-11 m residual, of an
    # energy of 10.6 J whose terms a wrong formula would move by far more
    engine = result.energy()[0].sum(axis=1)
    assert result.joint_residual[0] <= 1e-10
    np.testing.assert_allclose(engine - engine[0], energy - energy[0], atol=5e-9)


def test_driven_rigid_slider_crank_matches_its_kinematics():
    # x = r cos(phi) + sqrt(l^2 - r^2 sin^2 phi), phi = w t (any mechanism text)
    r, length, w = 0.15, 0.3, 150.0
    crank = RigidBody(
        "crank", mass=0.2, inertia=0.2 * r**2 / 12, center=(r / 2, 0), angular_velocity=w
    )
    rod = RigidBody(
        "rod",
        mass=0.3,
        inertia=0.3 * length**2 / 12,
        center=(length / 2, 0),
        position=(r, 0.0),
        velocity=(0.0, r * w),
        angular_velocity=-r * w / length,
    )
    slider = RigidBody("slider", mass=0.1, inertia=1e-5, position=(r + length, 0.0))
    mechanism = Mechanism().add(
        crank,
        rod,
        slider,
        Revolute(ground.point(), crank.point(), drive=ConstantRate(w), name="drive"),
        Revolute(crank.point(r, 0), rod.point()),
        Revolute(rod.point(length, 0), slider.point(), name="pin"),
        Prismatic(ground.point(), slider.point()),
    )
    times = np.linspace(0.0, 0.1, 201)
    result = simulate(mechanism, times)
    phi = w * times
    x = r * np.cos(phi) + np.sqrt(length**2 - (r * np.sin(phi)) ** 2)
    np.testing.assert_allclose(result.coordinates("slider")[0, :, 0], x, atol=1e-9)
    # the pin's force on the slider along x is the slider's mass times its acceleration
    # (the slide is frictionless): x'' by differentiating x twice in closed form
    s, c = np.sin(phi), np.cos(phi)
    root = np.sqrt(length**2 - r**2 * s**2)
    xdd = (
        -r * w**2 * c - (r**2 * w**2 * (c**2 - s**2)) / root - (r**4 * w**2 * s**2 * c**2) / root**3
    )
    np.testing.assert_allclose(result.reaction("pin")[0, :, 0], 0.1 * xdd, rtol=1e-6, atol=1e-6)
    assert result.reaction("pin").shape == (1, times.size, 2)


def test_locked_mechanism_is_reported_failed_with_its_history():
    # a crank longer than the rod cannot turn: the slider-crank locks at sin(phi) = l / r and the
    # run fails there, keeping its states up to the failure
    r, length, w = 0.3, 0.15, 10.0
    crank = RigidBody("crank", mass=0.2, inertia=0.01, center=(r / 2, 0), angular_velocity=w)
    rod = RigidBody(
        "rod",
        mass=0.1,
        inertia=1e-3,
        center=(length / 2, 0),
        position=(r, 0.0),
        velocity=(0.0, r * w),
        angular_velocity=-r * w / length,
    )
    slider = RigidBody("slider", mass=0.1, inertia=1e-5, position=(r + length, 0.0))
    mechanism = Mechanism().add(
        crank,
        rod,
        slider,
        Revolute(ground.point(), crank.point(), drive=ConstantRate(w)),
        Revolute(crank.point(r, 0), rod.point()),
        Revolute(rod.point(length, 0), slider.point()),
        Prismatic(ground.point(), slider.point()),
    )
    times = np.linspace(0.0, 0.2, 41)
    result = simulate(mechanism, times)
    assert result.failed[0]
    lock = np.arcsin(length / r) / w
    good = np.isfinite(result.states[0, :, 0])
    assert good[times < lock - 0.01].all() and not good[-1]
    assert "after t =" in result.failure(0)
