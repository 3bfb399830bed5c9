"""Linearisation of spatial mechanisms against closed forms and the planar engine."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs import planar
from fuzzymbs.mbs.spatial import (
    FlexibleBody,
    Mechanism,
    Revolute,
    RigidBody,
    Spherical,
    ground,
    linearize,
)

# slow: the spatial kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow


def test_hanging_rod_on_a_ball_joint_swings_at_the_compound_pendulum_frequency():
    # w^2 = m g d / J_pivot in both horizontal directions (any dynamics text); the spin about
    # the rod's own axis is free (a zero eigenvalue)
    length, mass = 1.0, 1.0
    rod = RigidBody(
        "rod",
        mass=mass,
        inertia=(mass * length**2 / 12, mass * length**2 / 12, 1e-4),
        position=(0.0, 0.0, -length / 2),
    )
    mechanism = Mechanism(gravity=(0.0, 0.0, -9.81)).add(
        rod, Spherical(ground.point(), rod.point((0.0, 0.0, length / 2)))
    )
    lin = linearize(mechanism)
    expected = np.sqrt(mass * 9.81 * length / 2 / (mass * length**2 / 3))
    # central differences at the default step: measured 1e-9 relative
    np.testing.assert_allclose(lin.frequencies(), [expected, expected], rtol=1e-7)
    assert lin.basis.shape == (6, 3)
    assert np.abs(lin.eigenvalues.real).max() < 1e-6


def test_flexible_pendulum_frequencies_match_the_pinned_free_beam_and_the_planar_engine():
    # a strip on a hinge without gravity: its elastic frequencies are the pinned-free beam's,
    # beta L = 3.9266, 7.0686, 10.2102 (Blevins, Formulas for Natural Frequency and Mode
    # Shape, table 8-1); 8 clamped modes of a 16-element mesh
    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=2e-10 / 12 * 10
    )
    reduced = beam.reduce(8)
    body = FlexibleBody(
        "beam", reduced.modal_body(), orientation=Rotation.from_euler("z", -np.pi / 2).as_matrix()
    )
    lin = linearize(Mechanism().add(body, Revolute(ground.point(), body.node(0))))
    scale = np.sqrt(
        beam.youngs_modulus * beam.second_moment / (beam.mass_per_length * beam.length**4)
    )
    pinned_free = np.array([3.92660231, 7.06858275, 10.21017612]) ** 2 * scale
    # measured 2.6e-6, 3.0e-5, 1.4e-4: the mesh and the 8 modes, as in the planar engine
    np.testing.assert_allclose(lin.frequencies()[:3], pinned_free, rtol=3e-4)
    flat = planar.FlexibleBody("beam", beam=reduced, angle=-np.pi / 2)
    flat_lin = planar.linearize(
        planar.Mechanism().add(flat, planar.Revolute(planar.ground.point(), flat.node(0)))
    )
    # the two engines on the same modes: measured within 4.3e-6 (central differences)
    np.testing.assert_allclose(lin.frequencies()[:8], flat_lin.frequencies()[:8], rtol=2e-5)
