"""Samples in lockstep (four per SIMD vector): a sample's result must not depend on its
block mates.

``kernel="samples"`` gives every sample a block of its own (its lanes repeat
it); ``kernel="lanes"`` packs four different samples per block, so that lanes
differ in every parameter, in their master cells (the per-lane gather path of
the contact pass) and in failing or not. The physics itself is checked against
closed forms and a NumPy implementation of the right-hand side elsewhere
(tests/mbs, tests/test_benchmarks_smoke.py). A block decides which contact path
runs and whether friction is evaluated, but every path gives a lane the same
arithmetic, so the results are bit-identical.

The physics exists once, in the four-lane form (docs/embs.md, "The kernels"):
the per-sample reference is the same code run one sample per block.
"""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.integrate import samples_per_block, simulate
from fuzzymbs.mbs.kernels import simd
from fuzzymbs.mbs.kernels.layout import CF_VSCALE
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance


@pytest.fixture(scope="module")
def brake():
    return DiscBrake(t_end=4e-4, record_interval=1e-5).compiled


OUTPUTS = {
    "y_lpad": Coordinate("lower_pad", 0),
    "y_upad": Coordinate("upper_pad", 0),
    "v_lpad": Coordinate("lower_pad", 0, velocity=True),
}


def _brake_samples(n: int, seed: int = 1) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        "pad_spring_stiffness": 200e3 * rng.uniform(0.8, 1.2, n),
        "caliper_spring_stiffness": 1e3 * rng.uniform(0.8, 1.2, n),
        "nodal_force": 16e3 * rng.uniform(0.9, 1.1, n),
        "disc_speed": np.where(np.arange(n) % 2 == 0, 1.0, 400.0) * rng.uniform(1.0, 1.1, n),
        "penalty_stiffness": 1e8 * rng.uniform(0.8, 1.2, n),
        "friction_coefficient": np.where(np.arange(n) % 5 == 2, 0.0, rng.uniform(0.3, 0.9, n)),
    }


def test_brake_lanes_equal_samples_kernel(brake):
    # 11 samples: two whole blocks and a padded one; every parameter varies per lane,
    # one lane in five is frictionless inside a block with friction, and the disc
    # speeds (1 and 400 rad/s alternating) turn the lanes' discs apart by more than two
    # master cells, so the per-lane (gather) contact path runs as well as the shared-cell
    # path
    samples = _brake_samples(11)
    speeds = samples["disc_speed"]
    t_end = 4e-4
    # premise: the polar cells of the disc patch are 1 / v_scale rad wide
    v_scale = brake.data[12][0, CF_VSCALE]
    assert (speeds[1] - speeds[0]) * t_end * v_scale > 2
    runs = {
        kernel: simulate(brake, samples, t_end=t_end, dt=1e-6, outputs=OUTPUTS, kernel=kernel)
        for kernel in ("samples", "lanes")
    }
    assert not runs["samples"].failed.any() and not runs["lanes"].failed.any()
    for name in OUTPUTS:
        ref = runs["samples"].outputs[name]
        scale = np.abs(ref).max()
        assert scale > 0
        # every lane takes the same arithmetic whatever its block mates: bit-identical
        np.testing.assert_array_equal(runs["lanes"].outputs[name], ref)


def test_auto_kernel_equals_samples_kernel_per_sample(brake):
    samples = _brake_samples(7, seed=3)  # auto: one block of 4, three left over -> padded
    a = simulate(brake, samples, t_end=1e-4, dt=1e-6, outputs=OUTPUTS, kernel="auto")
    b = simulate(brake, samples, t_end=1e-4, dt=1e-6, outputs=OUTPUTS, kernel="samples")
    for name in OUTPUTS:
        np.testing.assert_array_equal(a.outputs[name], b.outputs[name])


def test_failed_lane_is_reported_and_leaves_its_block_mates_alone(brake):
    # lane 1's force is 100 times too large: it leaves the 1 mm displacement bound after
    # 4 us (both kernels); the other lanes of its block, integrated on for 96 steps with
    # the failed lane repeating a healthy one, must be those of the per-sample kernel
    # (measured 5e-15 apart)
    samples = _brake_samples(4, seed=5)
    samples["nodal_force"][1] = 1.6e6
    runs = {
        kernel: simulate(
            brake,
            samples,
            t_end=1e-4,
            dt=1e-6,
            outputs=OUTPUTS,
            displacement_bound=1e-3,
            kernel=kernel,
        )
        for kernel in ("samples", "lanes")
    }
    lanes, ref = runs["lanes"], runs["samples"]
    assert ref.failed.tolist() == [False, True, False, False]
    assert lanes.failed.tolist() == ref.failed.tolist()
    assert lanes.failure_reason.tolist() == ref.failure_reason.tolist()
    np.testing.assert_array_equal(lanes.failure_time, ref.failure_time)
    assert 0 < lanes.failure_time[1] < 1e-4
    assert np.isnan(lanes.outputs["y_lpad"][1]).all()
    healthy = [0, 2, 3]
    np.testing.assert_array_equal(lanes.outputs["y_lpad"][healthy], ref.outputs["y_lpad"][healthy])


@pytest.mark.parametrize(
    ("kernel", "expected"), [("auto", simd.LANES), ("lanes", simd.LANES), ("samples", 1)]
)
def test_samples_per_block(kernel, expected):
    assert samples_per_block(kernel) == expected


def test_unknown_kernel_is_named(brake):
    with pytest.raises(InvalidParameterError, match="kernel must be one of"):
        simulate(brake, t_end=1e-5, dt=1e-6, outputs=OUTPUTS, kernel="gpu")


def test_simd_primitives_against_numpy():
    import numba as nb

    @nb.njit
    def apply(a, b, out):
        for k in range(0, a.size, simd.LANES):
            x = simd.load(a, k)
            y = simd.load(b, k)
            r = simd.fma(x, y, simd.sqrt(simd.vabs(x))) / (y + 2.0) - simd.floor(x)
            r = simd.where_lt(x, y, r, -r)
            lane_factor = simd.splat(0.0)
            for lane in range(simd.LANES - 1):
                lane_factor = simd.insert(lane_factor, lane, lane + 1)
            lane_factor = simd.insert(lane_factor, simd.LANES - 1, simd.get(y, simd.LANES - 1))
            simd.store(out, k, r + simd.broadcast(a, 0) * lane_factor)

    @nb.njit
    def reductions(v):
        x = simd.load(v, 0)
        return simd.all_zero(x), simd.same_lanes(x)

    lanes = simd.LANES
    rng = np.random.default_rng(0)
    a = rng.normal(size=4 * lanes)
    b = rng.normal(size=4 * lanes)
    out = np.empty(4 * lanes)
    apply(a, b, out)
    r = (a * b + np.sqrt(np.abs(a))) / (b + 2.0) - np.floor(a)
    r = np.where(a < b, r, -r)
    lane_factor = np.arange(1.0, lanes + 1.0)[None, :].repeat(4, 0)
    lane_factor[:, -1] = b[lanes - 1 :: lanes]
    expected = r + a[0] * lane_factor.ravel()
    np.testing.assert_allclose(out, expected, rtol=1e-14, atol=1e-14)
    assert reductions(np.zeros(lanes)) == (True, True)
    for lane in range(lanes):
        one = np.zeros(lanes)
        one[lane] = np.nan if lane % 2 else -1.0
        assert reductions(one) == (False, False)
    assert reductions(np.full(lanes, 2.5)) == (False, True)
    assert reductions(np.full(lanes, np.nan)) == (False, False)


def test_brake_model_option_kernel():
    # the study-file option [model.options] kernel reaches the integrator
    from fuzzymbs.models.brake import brake_model

    assert brake_model(kernel="samples", t_end=1e-5).simulation.settings["kernel"] == "samples"
    with pytest.raises(InvalidParameterError, match="kernel must be one of"):
        brake_model(kernel="gpu", t_end=1e-5)


# ROS34PW2: each lane keeps its own clock (step, error control, Jacobian age), so a
# sample's outputs are bit for bit those of the sample alone, whatever shares its block
ROS = {"integrator": "ros34pw2", "tolerance": Tolerance(1e-3)}


def _ros_run(brake, samples, order, kernel="lanes", chunk_size=64):
    picked = {name: values[order] for name, values in samples.items()}
    return simulate(
        brake,
        picked,
        t_end=3e-4,
        dt=1e-6,
        outputs=OUTPUTS,
        kernel=kernel,
        chunk_size=chunk_size,
        **ROS,
    )


@pytest.mark.slow
def test_ros34pw2_sample_is_independent_of_its_block(brake):
    # 9 samples that differ in every parameter, with frictionless lanes and disc speeds
    # 1 and 400 rad/s side by side (the per-lane contact path); the reference is each
    # sample in a block of its own
    samples = _brake_samples(9, seed=7)
    order = np.arange(9)
    alone = _ros_run(brake, samples, order, kernel="samples")
    assert not alone.failed.any()
    permutation = np.random.default_rng(2).permutation(9)
    variants = {
        "lanes": (order, _ros_run(brake, samples, order)),
        "permuted": (permutation, _ros_run(brake, samples, permutation)),
        "chunks of 2": (order[::-1], _ros_run(brake, samples, order[::-1], chunk_size=2)),
    }
    for label, (rows, run) in variants.items():
        for name in OUTPUTS:
            np.testing.assert_array_equal(
                run.outputs[name], alone.outputs[name][rows], err_msg=f"{label}: {name}"
            )
        np.testing.assert_array_equal(run.step_counts, alone.step_counts[rows], err_msg=label)
    # premise: the samples take different step sequences (a shared step would hide them)
    assert len(set(alone.step_counts[:, 0].tolist())) > 3


@pytest.mark.slow  # compiles ROS34PW2's lane kernel (about 50 s on CI)
def test_ros34pw2_duplicates_in_one_block_are_identical(brake):
    # one parameter point four times, between other points: every copy equal
    samples = _brake_samples(6, seed=11)
    order = np.array([0, 3, 1, 3, 3, 2, 3, 5])
    run = _ros_run(brake, samples, order)
    copies = run.outputs["y_lpad"][order == 3]
    for copy in copies[1:]:
        np.testing.assert_array_equal(copy, copies[0])


@pytest.mark.slow  # compiles ROS34PW2's lane kernel (about 50 s on CI)
def test_ros34pw2_failed_lane_leaves_the_others_bit_identical(brake):
    samples = _brake_samples(4, seed=5)
    samples["nodal_force"][1] = 1.6e9  # pushes the pad beyond the 1 mm bound at once
    alone = _ros_run(brake, samples, np.arange(4), kernel="samples")
    lanes = _ros_run(brake, samples, np.arange(4))
    assert alone.failed.tolist() == [False, True, False, False]
    assert lanes.failed.tolist() == alone.failed.tolist()
    np.testing.assert_array_equal(lanes.failure_time, alone.failure_time)
    healthy = [0, 2, 3]
    np.testing.assert_array_equal(
        lanes.outputs["y_lpad"][healthy], alone.outputs["y_lpad"][healthy]
    )


@pytest.mark.slow  # the same compiled kernel as ROS34PW2 (the tableau is an argument)
def test_rodas4_sample_is_independent_of_its_block(brake):
    # RODAS4 in the same lane kernel: each of 5 samples (every parameter varied, the
    # per-lane contact path) bit for bit the same alone and in blocks with others
    samples = _brake_samples(5, seed=3)
    rodas = {"integrator": "rodas4", "tolerance": Tolerance(1e-3)}

    def go(order, kernel):
        picked = {name: values[order] for name, values in samples.items()}
        return simulate(brake, picked, t_end=1e-4, dt=1e-6, outputs=OUTPUTS, kernel=kernel, **rodas)

    alone = go(np.arange(5), "samples")
    assert not alone.failed.any()
    order = np.array([4, 2, 0, 3, 1])
    packed = go(order, "lanes")
    for name in OUTPUTS:
        np.testing.assert_array_equal(packed.outputs[name], alone.outputs[name][order])
    np.testing.assert_array_equal(packed.step_counts, alone.step_counts[order])
    assert len(set(alone.step_counts[:, 0].tolist())) > 2


def test_lane_count_is_four_unless_set(monkeypatch):
    # 4 lanes; FUZZYMBS_LANES=8 for AVX-512 (bit for bit the same results)
    monkeypatch.delenv("FUZZYMBS_LANES", raising=False)
    assert simd.choose_lanes() == 4
    for value in ("4", "8"):
        monkeypatch.setenv("FUZZYMBS_LANES", value)
        assert simd.choose_lanes() == int(value)
    monkeypatch.setenv("FUZZYMBS_LANES", "16")
    with pytest.raises(ValueError, match="FUZZYMBS_LANES must be 4 or 8"):
        simd.choose_lanes()
    simd.check_cache()  # this process's cached kernels are of its width
