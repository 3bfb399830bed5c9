"""The brake on the general engine, over the first 30 us of the press-on: its System
written as a spatial Mechanism (absolute coordinates, Lagrange multipliers for the disc's
driven hinge and the pads' and caliper's slides, SurfaceContact, Bushing and MarkerLoad
elements; Dormand-Prince) against the brake's minimal-coordinate kernels (ROS34PW2, the
SIMD contact passes). Two formulations and two codes from one set of bodies and joints:
they must agree to the integration tolerance over the press-on transient (contact closing
at 73 points per pad, friction at 0.7).
"""

import numpy as np
import pytest

from fuzzymbs.mbs.integrate import simulate as simulate_minimal
from fuzzymbs.mbs.spatial import simulate as simulate_absolute
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import brake_system, build_bodies
from fuzzymbs.models.brake.geometry import BrakeDesign
from fuzzymbs.tolerance import Tolerance

# slow: both engines compile (about a minute); the general engine runs for 11 s
pytestmark = pytest.mark.slow

T_END = 3e-5  # s: the pads close on the disc (their frames move 0.1 mm)


def test_the_brake_on_the_general_engine_agrees_with_its_kernels():
    bodies = build_bodies(BrakeDesign())
    system = brake_system(bodies)
    compiled = system.compile()
    outputs = {
        f"{name}{i}": Coordinate(name, i)
        for name, dofs in compiled.body_dofs.items()
        for i in range(dofs.stop - dofs.start)
    }
    minimal = simulate_minimal(
        compiled,
        t_end=T_END,
        dt=1e-7,
        record_interval=T_END / 20,
        outputs=outputs,
        integrator="ros34pw2",
        tolerance=Tolerance(1e-8, 1e-15),
    )
    absolute = simulate_absolute(system.as_mechanism(), minimal.time, rtol=1e-8, atol=1e-13)
    assert not minimal.failed.any() and not absolute.failed.any()
    for pad in ("lower_pad", "upper_pad"):
        mine = minimal.outputs[f"{pad}0"][0]
        assert np.abs(mine).max() > 5e-5  # the press-on moves the pads by 0.1 mm
        # measured: 3.3e-13 m of 1.04e-4 m
        np.testing.assert_allclose(absolute.position(pad)[0][:, 1], mine, atol=1e-10)
    for name, first in (("disc", 0), ("lower_pad", 1), ("caliper", 1)):
        dofs = compiled.body_dofs[name]
        mine = np.stack(
            [minimal.outputs[f"{name}{i}"][0] for i in range(first, dofs.stop - dofs.start)], -1
        )
        theirs = absolute.modal_coordinates(name)[0]
        scale = np.abs(mine).max()
        assert scale > 0
        # measured: 3.2e-9 (disc), 1.6e-8 (pads), 3.7e-11 (caliper) of the largest value,
        # both engines at rtol 1e-8 (at 1e-9 over 0.1 ms: 7.6e-9, 1.8e-8, 1.6e-9; the slides
        # 3.7e-13 m)
        np.testing.assert_allclose(theirs, mine, atol=1e-6 * scale)
