"""Marker accelerations against the central differences of the marker velocities."""

import numpy as np
import pytest

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.planar import FlexibleBody, Mechanism, Revolute, ground, simulate

# slow: the planar kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow


def test_tip_acceleration_of_a_flexible_pendulum_is_the_rate_of_its_velocity():
    # the tip node of a swinging steel strip (3 modes, foreshortening on): its reported
    # acceleration against the fourth-order central difference of its velocity on a 0.1 ms
    # grid (an independent route; the second-order difference's gap fell as h^2: 2.0e-3,
    # 5.0e-4, 1.3e-4 m/s^2 at h = 1e-4, 5e-5, 2.5e-5 s)
    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=6.75e-11
    ).reduce(3)
    body = FlexibleBody("strip", beam=beam, angle=-np.pi / 2 + np.pi / 3)
    mechanism = Mechanism(gravity=(0.0, -9.81)).add(body, Revolute(ground.point(), body.node(0)))
    mechanism.mark("tip", body.tip())
    times = np.linspace(0.0, 0.5, 5001)
    result = simulate(mechanism, times, rtol=1e-11, atol=1e-13)
    assert not result.failed.any()
    velocity = result.marker("tip")[0, :, 3:]
    acceleration = result.marker_acceleration("tip")[0]
    step = times[1] - times[0]
    difference = (velocity[:-4] - 8 * velocity[1:-3] + 8 * velocity[3:-1] - velocity[4:]) / (
        12 * step
    )
    scale = np.abs(acceleration).max(axis=0)
    assert scale[2] > 1.0  # the tip's own rotation accelerates (the strip bends)
    # measured 1.0e-7 to 2.8e-7 of each column's largest value (the h^4 truncation)
    gap = np.abs(acceleration[2:-2] - difference).max(axis=0) / scale
    assert (gap < 2e-6).all(), gap
