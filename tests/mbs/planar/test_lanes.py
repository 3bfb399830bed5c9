"""LANES samples per kernel call, one per SIMD lane: a sample's run must not depend on its
block, its lane or its lane mates.

``simulate(kernel="lanes")`` (the default) packs samples L k .. L k + L - 1 into block k;
``kernel="samples"`` runs one sample per call. Each lane keeps its own clock (step size,
acceptance, output times, projection, failure), and every lane does the one-sample
kernel's arithmetic in its order, so the two kernels agree bit for bit, and so do runs of
the same sample in other batches and lanes.
"""

import numpy as np
import pytest

from fuzzymbs.mbs.planar import (
    ConstantRate,
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    SpringDamper,
    ground,
    integrator,
    simulate,
)
from fuzzymbs.mbs.planar.kernels import FINISHED
from fuzzymbs.models.mechanisms.slider_crank import build

# slow: the planar kernels take 25 to 35 s to compile (both kernels here); CI runs these
# with -m slow
pytestmark = pytest.mark.slow


def rigid_slider_crank(crank: float, rod: float, speed: float, stiffness: float) -> Mechanism:
    """A rigid slider-crank turning at ``speed`` [rad/s], its slider on a spring to ground
    (a force element: evaluated lane by lane); it locks where ``crank`` [m] > ``rod`` [m]."""
    crank_body = RigidBody(
        "crank", mass=0.2, inertia=0.01, center=(crank / 2, 0), angular_velocity=speed
    )
    rod_body = RigidBody(
        "rod",
        mass=0.1,
        inertia=1e-3,
        center=(rod / 2, 0),
        position=(crank, 0.0),
        velocity=(0.0, crank * speed),
        angular_velocity=-crank * speed / rod,
    )
    slider = RigidBody("slider", mass=0.1, inertia=1e-5, position=(crank + rod, 0.0))
    return Mechanism().add(
        crank_body,
        rod_body,
        slider,
        Revolute(ground.point(), crank_body.point(), drive=ConstantRate(speed)),
        Revolute(crank_body.point(crank, 0), rod_body.point()),
        Revolute(rod_body.point(rod, 0), slider.point()),
        Prismatic(ground.point(), slider.point()),
        SpringDamper(
            ground.point(crank + rod + 0.1, 0.0), slider.point(), stiffness=stiffness, damping=0.5
        ),
    )


#: seven samples: every lane's numbers differ, and sample 2 locks (crank longer than rod)
RIGID = [
    (0.10, 0.30, 10.0, 50.0),
    (0.12, 0.25, 14.0, 200.0),
    (0.30, 0.15, 10.0, 100.0),
    (0.08, 0.35, 8.0, 20.0),
    (0.11, 0.28, 20.0, 500.0),
    (0.09, 0.31, 12.0, 0.0),
    (0.13, 0.29, 16.0, 80.0),
]
#: few outputs and a tight tolerance: the samples' own step sizes set their steps
TIMES = np.linspace(0.0, 0.2, 11)


def assert_same_runs(a, b):
    """The two results' samples are the same bit for bit (states NaN where both failed)."""
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_array_equal(a.accepted, b.accepted)
    np.testing.assert_array_equal(a.rejected, b.rejected)
    np.testing.assert_array_equal(a.joint_residual, b.joint_residual)


def assert_solved_as_one_sample_kernel(result):
    """The accelerations and multipliers solved four lanes at a time (``solved()``) are
    those of the one-sample solve, bit for bit (NaN after a failure)."""
    n, c = (int(size) for size in result.batch.layout.sizes)
    reference = np.empty((*result.states.shape[:2], n + c))
    batch = result.batch
    integrator.solve_range(
        0,
        len(reference),
        result.times,
        result.states,
        batch.layout.arrays(),
        batch.data,
        batch.user_force,
        reference,
    )
    np.testing.assert_array_equal(result.solved(), reference)


def run(samples, **options):
    mechanisms = [rigid_slider_crank(*p) for p in samples]
    return simulate(mechanisms, TIMES, rtol=1e-9, atol=1e-12, **options)


def test_rigid_lanes_equal_the_one_sample_kernel_in_any_batch_and_lane():
    lanes = run(RIGID)
    # premise: the lanes step apart (their own step sizes and rejections), one fails
    assert len(set(lanes.accepted)) > 3 and lanes.rejected.max() > 0
    assert list(lanes.status != FINISHED) == [False, False, True, False, False, False, False]
    assert_same_runs(lanes, run(RIGID, kernel="samples"))
    assert_solved_as_one_sample_kernel(lanes)
    # reversed: every sample in another block and lane, with other lane mates
    reverse = run(RIGID[::-1])
    for i in range(len(RIGID)):
        np.testing.assert_array_equal(reverse.states[-1 - i], lanes.states[i])
        assert reverse.accepted[-1 - i] == lanes.accepted[i]
        assert reverse.rejected[-1 - i] == lanes.rejected[i]
    # alone (a block of one, its other lanes padded)
    for i in (0, 2, 6):
        alone = run([RIGID[i]])
        np.testing.assert_array_equal(alone.states[0], lanes.states[i])
        assert alone.status[0] == lanes.status[i]
        assert alone.joint_residual[0] == lanes.joint_residual[i]


def test_a_failing_lane_leaves_its_lane_mates_alone():
    # the locking sample in every lane of a block of healthy ones: it fails alone, at the
    # same time and with the same report; its mates finish as they do without it
    healthy = [RIGID[0], RIGID[1], RIGID[3]]
    alone = run(healthy)
    locked = run([RIGID[2]])
    assert locked.failed[0] and not alone.failed.any()
    for lane in range(4):
        block = [*healthy[:lane], RIGID[2], *healthy[lane:]]
        result = run(block)
        assert list(result.failed) == [i == lane for i in range(4)]
        np.testing.assert_array_equal(result.states[lane], locked.states[0])
        assert result.failure(lane) == locked.failure(0)
        assert result.accepted[lane] == locked.accepted[0]
        others = [i for i in range(4) if i != lane]
        np.testing.assert_array_equal(result.states[others], alone.states)
        np.testing.assert_array_equal(result.accepted[others], alone.accepted)


def test_flexible_lanes_equal_the_one_sample_kernel():
    # the flexible slider-crank (DOP853, a stiffened beam's terms in vectors), five samples
    # that differ in every parameter the model's study varies: one block and a short one
    rng = np.random.default_rng(7)
    parameters = [
        {
            "crank_speed": 150.0,
            "spin_up_time": 0.02,
            "youngs_modulus": 2.0e11 * rng.uniform(0.95, 1.05),
            "rod_width": 0.01,
            "rod_height": 0.006 * rng.uniform(0.98, 1.02),
            "slider_mass": 0.1 * rng.uniform(0.9, 1.1),
        }
        for _ in range(5)
    ]
    times = np.linspace(0.0, 0.004, 21)
    mechanisms = [build(p) for p in parameters]
    lanes = simulate(mechanisms, times, rtol=1e-5, atol=1e-7)
    assert not lanes.failed.any()
    assert_same_runs(lanes, simulate(mechanisms, times, rtol=1e-5, atol=1e-7, kernel="samples"))
    assert_solved_as_one_sample_kernel(lanes)
    shifted = simulate(mechanisms[1:] + mechanisms[:1], times, rtol=1e-5, atol=1e-7)
    np.testing.assert_array_equal(shifted.states, np.roll(lanes.states, -1, axis=0))
