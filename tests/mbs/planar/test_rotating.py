"""Spinning flexible beams: geometric stiffening against published frequencies and a
geometrically nonlinear beam."""

import numpy as np
import pytest

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.planar import (
    ConstantRate,
    FlexibleBody,
    Mechanism,
    Revolute,
    ground,
    linearize,
)

# slow: the planar kernels take about 25 s to compile, which the README's pytest (5 min on a
# fresh clone of 2 cores) cannot spare in every test process; CI runs these with -m slow
pytestmark = pytest.mark.slow

KANE = dict(
    length=8.0, youngs_modulus=6.8952e10, density=2766.7, area=7.2968e-5, second_moment=8.2189e-9
)


def spinning(beam, speed, drive, stiffening=True):
    body = FlexibleBody("beam", beam=beam, angular_velocity=speed, geometric_stiffening=stiffening)
    mechanism = Mechanism().add(body, Revolute(ground.point(), body.node(0), drive=drive))
    mechanism.mark("tip", body.tip())
    return mechanism


# First flapwise frequency of a uniform rotating cantilever, hub radius 0, over the
# dimensionless speed gamma = Omega sqrt(rho A L^4 / EI): Wright, Smith, Thresher & Wang,
# J. Appl. Mech. 49 (1982) 197, table 1 (also Hodges & Rutkowski, AIAA J. 19 (1981) 1459).
# The in-plane (lead-lag) frequency of the same beam is sqrt(flap^2 - gamma^2).
FLAPWISE = {1: 3.6816, 2: 4.1373, 4: 5.5850, 6: 7.3604, 10: 11.2023, 12: 13.1702}


@pytest.mark.parametrize("gamma", sorted(FLAPWISE))
def test_in_plane_frequency_under_spin_matches_the_published_table(gamma):
    beam = PlanarBeam(**KANE, elements=24)
    ref = np.sqrt(
        beam.youngs_modulus * beam.second_moment / (beam.mass_per_length * beam.length**4)
    )
    speed = gamma * ref
    lin = linearize(spinning(beam.reduce(8), speed, ConstantRate(speed)), t=0.0)
    in_plane = lin.frequencies()[0] / ref
    # the table's 5 digits, and 24 elements with 8 modes: within 6e-5 up to gamma = 12
    assert np.sqrt(in_plane**2 + gamma**2) == pytest.approx(FLAPWISE[gamma], rel=1e-4)


def test_without_stiffening_the_spinning_beam_softens_to_instability():
    # without the geometric stiffness the in-plane stiffness is omega_0^2 - Omega^2 per mode:
    # above the first frequency (2.91 rad/s) the linearisation has a real positive eigenvalue
    beam = PlanarBeam(**KANE).reduce(4)
    lin = linearize(spinning(beam, 4.0, ConstantRate(4.0), stiffening=False))
    assert lin.eigenvalues.real.max() > 1.0
    lin = linearize(spinning(beam, 4.0, ConstantRate(4.0)))
    assert np.abs(lin.eigenvalues.real).max() < 1e-6 * np.abs(lin.eigenvalues).max()
