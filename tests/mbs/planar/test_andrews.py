"""Andrews' squeezing mechanism (seven bodies, closed loops) against the Test Set for IVP
Solvers' reference solution.

Source: Hairer & Wanner, Solving Ordinary Differential Equations II, sec. VII.7, and
the Test Set for IVP Solvers (Mazzia & Magherini, Univ. Bari; problem "andrews"): its
data, its consistent initial angles, and the angles at t = 0.03 s computed by PSIDE at
rtol = atol = 1e-14. The test set writes the problem in seven relative angles; here each
link is a rigid body in absolute coordinates with revolute joints, so the geometry below
is read off the test set's constraint equations and mass matrix (the body frames and
points are named after them).
"""

import numpy as np
import pytest

from fuzzymbs.mbs.planar import (
    MarkerLoad,
    Mechanism,
    Revolute,
    RigidBody,
    SpringDamper,
    ground,
    simulate,
)

# slow: the planar kernels take about 25 s to compile, which the README's pytest (5 min on a
# fresh clone of 2 cores) cannot spare in every test process; CI runs these with -m slow
pytestmark = pytest.mark.slow

# the test set's data (SI)
m1, m2, m3, m4, m5, m6, m7 = 0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498
xa, ya, xb, yb, xc, yc = -0.06934, -0.00227, -0.03635, 0.03273, 0.014, 0.072
c0 = 4530.0
i1, i2, i3, i4, i5, i6, i7 = 2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5
d, da, e, ea, rr, ra, l0 = 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5, 7785e-5
ss, sa, sb, sc, sd, ta, tb = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2, 2308e-5, 916e-5
u, ua, ub, zf, zt, fa, mom = 4e-2, 1228e-5, 449e-5, 2e-2, 4e-2, 1421e-5, 33e-3

# consistent initial angles (beta, Theta, gamma, Phi, delta, Omega, epsilon), at rest
START = (
    -0.0617138900142764496358948458001,
    0.0,
    0.455279819163070380255912382449,
    0.222668390165885884674473185609,
    0.487364979543842550225598953530,
    -0.222668390165885884674473185609,
    1.23054744454982119249735015568,
)
# PSIDE at rtol = atol = 1e-14 (the test set's subroutine andsoln)
AT_30_MS = (
    0.1581077119629904e2,
    -0.1575637105984298e2,
    0.4082224013073101e-1,
    -0.5347301163226948,
    0.5244099658805304,
    0.5347301163226948,
    0.1048080741042263e1,
)


def unit(angle):
    return np.array([np.cos(angle), np.sin(angle)])


def across(angle):
    return np.array([-np.sin(angle), np.cos(angle)])


def squeezer() -> Mechanism:
    beta, theta, gamma, phi, delta, omega, epsilon = START
    a, b, c = np.array([xa, ya]), np.array([xb, yb]), np.array([xc, yc])
    f = rr * unit(beta)
    g = a + zt * unit(delta)
    h = a - u * across(epsilon)
    # each body's frame: a joint point, turned by its absolute angle; the centre of mass of
    # bodies turning about a fixed pivot (3, 5, 7) only needs its distance from the pivot
    k1 = RigidBody("K1", mass=m1, inertia=i1, center=(ra, 0.0), angle=beta)
    k2 = RigidBody("K2", mass=m2, inertia=i2, center=(-da, 0.0), position=f, angle=beta + theta)
    k3 = RigidBody("K3", mass=m3, inertia=i3, center=(sa, sb), position=b, angle=gamma)
    k4 = RigidBody(
        "K4", mass=m4, inertia=i4, center=(0.0, -(e - ea)), position=g, angle=phi + delta
    )
    k5 = RigidBody("K5", mass=m5, inertia=i5, center=(ta, tb), position=a, angle=delta)
    k6 = RigidBody(
        "K6", mass=m6, inertia=i6, center=(zf - fa, 0.0), position=h, angle=omega + epsilon
    )
    k7 = RigidBody("K7", mass=m7, inertia=i7, center=(ua, ub), position=a, angle=epsilon)
    mechanism = Mechanism()
    mechanism.add(
        k1,
        k2,
        k3,
        k4,
        k5,
        k6,
        k7,
        Revolute(ground.point(), k1.point()),
        Revolute(k1.point(rr, 0.0), k2.point()),
        Revolute(k2.point(-d, 0.0), k3.point(0.0, -ss)),  # E
        Revolute(k2.point(-d, 0.0), k4.point(0.0, -e)),  # E
        Revolute(k2.point(-d, 0.0), k6.point(zf, 0.0)),  # E
        Revolute(ground.point(*b), k3.point()),  # B
        Revolute(ground.point(*a), k5.point()),  # A
        Revolute(k5.point(zt, 0.0), k4.point()),  # G
        Revolute(ground.point(*a), k7.point()),  # A
        Revolute(k7.point(0.0, -u), k6.point()),  # H
        SpringDamper(ground.point(*c), k3.point(sd, -sc), stiffness=c0, free_length=l0),
        MarkerLoad(k1.point(), torque=mom),
    )
    return mechanism


def test_andrews_squeezer_matches_the_test_set_at_30_ms():
    result = simulate(squeezer(), [0.0, 0.03], rtol=1e-10, atol=1e-12)
    assert not result.failed.any()
    angle = {
        name: result.coordinates(name)[0, -1, 2]
        for name in ("K1", "K2", "K3", "K4", "K5", "K6", "K7")
    }
    relative = (
        angle["K1"],
        angle["K2"] - angle["K1"],
        angle["K3"],
        angle["K4"] - angle["K5"],
        angle["K5"],
        angle["K6"] - angle["K7"],
        angle["K7"],
    )
    # 1e-7 rad: the reference is good to 1e-14, the run at rtol 1e-10 measured 1.3e-9
    np.testing.assert_allclose(relative, AT_30_MS, atol=1e-7)
    assert result.joint_residual[0] < 1e-10


def test_andrews_squeezer_at_the_default_tolerances():
    # the defaults (rtol 1e-6) on the same run, the crank turned 2.5 times: measured 2.4e-6 rad
    result = simulate(squeezer(), [0.0, 0.03])
    assert result.coordinates("K1")[0, -1, 2] == pytest.approx(AT_30_MS[0], abs=1e-5)
