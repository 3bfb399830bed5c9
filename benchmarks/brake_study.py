"""Benchmark of the disc-brake studies; prints one JSON line.

    python benchmarks/brake_study.py [--quick]

Measures, on this machine, after compilation (a warm-up study of 20 steps
compiles or loads the Numba kernels and imports what building a result needs):

* ``study1_default_warm_s``: wall time of the 33-run study 1 (reduced method, k,
  k_c +-10 %, F_n +-1 %, 10 ms) with the API's defaults: the integrator's tolerance
  chosen by a pilot for the cut widths, every sample on the modal sample's shared
  steps (docs/studies.md), all 33 samples in one call (9 blocks of four samples, the
  last one padded, round robin over the threads), the study's check of its time
  integration (the samples that bound the cuts re-run at a tenfold tighter
  tolerance), whose result is ``study1_default_time_integration_error`` (of the cut
  width), and its method check (the default validation runs); ``study1_rk4_1us_warm_s``:
  the same study with the paper's RK4 at dt = 1 us (its check: dt = 0.5 us), and
  ``study1_default_over_rk4_1us`` the ratio (4 while the default was rtol 1e-2 judged
  on the peak; 17.4 with the bands' accuracy, docs/benchmarks.md);
  ``study1_rk4_samples_kernel_warm_s``: the RK4 study with ``kernel="samples"``
  (a block per sample, its lanes repeating it). ``--quick``: 1 ms instead of
  10 ms (``study1_rk4_1us_warm_s_per_10ms`` extrapolates);
* ``us_per_sample_step``: wall time per sample and RK4 step of the RK4 study
  (4 right-hand-side evaluations; every step it took, its checks' runs included);
  ``cpu_us_per_sample_step`` the same in
  process CPU time (all threads), which other jobs on the machine do not
  inflate, and ``study1_idle_cores_s_per_10ms`` = CPU time / threads, the wall
  time on idle cores; ``us_per_lane_rhs`` CPU time of one right-hand side per
  lane (single thread, a block's right-hand side / 4), split into contact
  passes and node kinematics + force map; ``us_per_block_rhs`` that of a whole
  block, the cost of one sample run alone;
* ``large_*``: a streamed study of 9261 samples (grid method, 10 levels, the
  three study-1 parameters) in chunks of 256 through a chunk store, with a
  short end time (0.1 ms) so that it finishes here; peak resident memory of the
  process (``ru_maxrss``) and the output memory a 10 ms study of the same
  size would hold (N x 3 outputs x 2001 records x 8 bytes, plus the bounds).
  ``--quick``: 729 samples (grid, 4 levels);
* ``fullsize_stream_*``: the same sample table through the study runner with a
  cheap stand-in model whose outputs have the full 10 ms size (3 x 2001 records
  per sample): the runner's peak memory for a 10,000-sample study of 10 ms
  signals (the brake kernel holds one state per sample and does not add to it).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time

import numba
import numpy as np

from fuzzymbs.mbs.kernels import contact, kinematics, rhs
from fuzzymbs.mbs.kernels import layout as K
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.study.study import Study

STUDY1 = {
    "pad_spring_stiffness": {"type": "triangular", "modal": 200e3, "spread": 0.1},
    "caliper_spring_stiffness": {"type": "triangular", "modal": 1e3, "spread": 0.1},
    "nodal_force": {"type": "triangular", "modal": 16e3, "spread": 0.01},
}
LEVELS = [0.0, 0.25, 0.5, 0.75, 1.0]


@numba.njit
def _repeat_rhs(n, x, dx, p, data, work):
    t = np.full(LANES, 1e-4)  # a time per lane, as the package's integrators pass it
    for _ in range(n):
        rhs.rhs(t, x, dx, p, data, work)


@numba.njit
def _repeat_contact(n, x, p, data, work):
    for _ in range(n):
        for c in range(data[11].shape[0]):
            contact.contact_pass(c, x, p, data, work)


@numba.njit
def _repeat_kinematics(n, x, data, work):
    ndof, bi, bf, node_xbar, fpool = data[0], data[1], data[2], data[3], data[6]
    q_gen, node_x, node_v, node_f, rot, rot_a = work[:6]
    for _ in range(n):
        kinematics.node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
        kinematics.map_node_forces(bi, bf, fpool, rot_a, node_f, q_gen)


class FullSizeStandIn:
    """Cheap stand-in with the brake's parameters and full-size outputs (3 x 2001 records).

    Measures the study runner's memory when a 10,000-sample study of 10 ms signals
    streams through (the brake kernel itself holds one state per sample, so its
    memory does not grow with the study). Outputs: smooth functions of the samples.
    """

    def __init__(self) -> None:
        self.coords = {"time": np.arange(2001) * 5e-6}

    def __call__(self, samples: dict) -> dict:
        t = self.coords["time"]
        force = np.asarray(samples["nodal_force"])[:, None]
        k = np.asarray(samples["pad_spring_stiffness"])[:, None]
        y = force / 7.3e9 * (1.0 - np.exp(-400.0 * t)) + 1e-12 * k * t
        return {"y_lpad": y, "y_upad": -y, "y_cali": 1e-3 * (y - y.mean(axis=1, keepdims=True))}


def rhs_profile(model: DiscBrake, repeats: int = 20000) -> dict[str, float]:
    """Single-thread cost of one right-hand side at a loaded state (all points in contact)."""
    compiled = model.compiled
    p = compiled.parameters.values({})[0]
    x = np.zeros(compiled.n_state)
    x[compiled.body_dofs["lower_pad"].start] = 55e-6
    x[compiled.body_dofs["upper_pad"].start] = -55e-6
    out = {}
    # a block of four lanes at the same state: its cost is that of one sample run alone
    # (kernel="samples"); a quarter of it is the cost per sample in full blocks
    xl = np.ascontiguousarray(np.repeat(x, LANES))
    pl = np.ascontiguousarray(np.repeat(p, LANES))
    dxl = np.empty_like(xl)
    work = rhs.make_work(compiled.data)
    for name, func, args in (  # process CPU time: single thread, robust against load
        ("us_per_lane_rhs", _repeat_rhs, (xl, dxl, pl, compiled.data, work)),
        ("us_per_lane_contact_passes", _repeat_contact, (xl, pl, compiled.data, work)),
        (
            "us_per_lane_node_kinematics_and_force_map",
            _repeat_kinematics,
            (xl, compiled.data, work),
        ),
    ):
        func(1, *args)
        start = time.process_time()
        func(repeats, *args)
        out[name] = 1e6 * (time.process_time() - start) / (repeats * LANES)
    out["us_per_block_rhs"] = LANES * out["us_per_lane_rhs"]
    out["tracked_nodes"] = int(compiled.data[3].shape[0])
    out["contact_slave_nodes"] = int(compiled.data[11][:, K.C_NSLAVE].sum())
    out["coordinates"] = int(compiled.n_dofs)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description="disc-brake study benchmark")
    parser.add_argument("--quick", action="store_true", help="1 ms study 1, 1000-sample stream")
    args = parser.parse_args()
    t_end = 1e-3 if args.quick else 1e-2
    report: dict[str, object] = {
        "benchmark": "brake_study",
        "quick": args.quick,
        "threads": numba.get_num_threads(),
        "cpus": os.cpu_count(),
    }

    # warm-up: compiles or loads the kernels (33 = 8 blocks + 1 padded block) and imports
    # what building the result dataset needs (xarray's lazy imports, about 1 s)
    for integrator in ("ros34pw2", "rk4"):
        warm = DiscBrake(t_end=2e-5, integrator=integrator)
        Study(warm, STUDY1, method="reduced", levels=LEVELS).run(progress=False)

    def timed(model: DiscBrake) -> tuple[float, float, object]:
        study = Study(model, STUDY1, method="reduced", levels=LEVELS)
        start, cpu_start = time.perf_counter(), time.process_time()
        result = study.run(chunk_size=len(study.plan), progress=False)
        return time.perf_counter() - start, time.process_time() - cpu_start, result

    # the default study (ROS34PW2, rtol 1e-2) and the paper's RK4 at 1 us, same minutes
    model = DiscBrake(t_end=t_end)
    default_elapsed, _, default_result = timed(model)
    elapsed, cpu, result = timed(DiscBrake(t_end=t_end, integrator="rk4"))
    baseline_elapsed, _, _ = timed(DiscBrake(t_end=t_end, integrator="rk4", kernel="samples"))
    samples = int(result.dataset.sizes["sample"])
    n_steps = round(t_end / 1e-6)
    # every RK4 step the study took: its runs and validation runs at 1 us, and its
    # time-integration check's re-runs at 0.5 us (twice the steps)
    attrs = result.dataset.attrs
    sample_steps = n_steps * (
        samples + int(attrs.get("validation_runs", 0)) + 2 * int(attrs["time_integration_runs"])
    )
    failed = int(np.asarray(default_result.dataset["sample_failed"]).sum())
    report.update(
        {
            "study1_samples": samples,
            "study1_t_end_s": t_end,
            "study1_default_warm_s": round(default_elapsed, 3),
            "study1_default_time_integration_error": round(
                float(default_result.dataset.attrs["time_integration_error"]), 5
            ),
            "study1_default_over_rk4_1us": round(default_elapsed / elapsed, 2),
            "study1_failed": failed,
            "study1_rk4_1us_warm_s": round(elapsed, 3),
            "study1_rk4_1us_time_integration_error": round(
                float(result.dataset.attrs["time_integration_error"]), 5
            ),
            "study1_rk4_1us_warm_s_per_10ms": round(elapsed * 1e-2 / t_end, 3),
            "study1_rk4_samples_kernel_warm_s": round(baseline_elapsed, 3),
            "study1_rk4_lanes_speedup": round(baseline_elapsed / elapsed, 2),
            "us_per_sample_step": round(1e6 * elapsed / sample_steps, 2),
            # CPU time of all threads: robust against other jobs sharing the machine;
            # CPU time / threads is the wall time on otherwise idle cores
            "study1_rk4_cpu_s": round(cpu, 3),
            "cpu_us_per_sample_step": round(1e6 * cpu / sample_steps, 2),
            "study1_idle_cores_s_per_10ms": round(cpu / numba.get_num_threads() * 1e-2 / t_end, 2),
            "load_average_1min": round(os.getloadavg()[0], 2),
        }
    )
    report.update(
        {k: round(v, 3) if isinstance(v, float) else v for k, v in rhs_profile(model).items()}
    )

    levels = 4 if args.quick else 10  # grid: (2 m + 1)^3 samples: 729 or 9261
    short = DiscBrake(t_end=1e-4, integrator="rk4")
    big = Study(short, STUDY1, method="grid", levels=levels)
    with tempfile.TemporaryDirectory() as store:
        start = time.perf_counter()
        big.run(chunk_size=256, store=store, progress=False, keep_raw=False)
        big_elapsed = time.perf_counter() - start
    n_big = len(big.plan)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    records = 2001  # 10 ms at the default 5 us record interval
    levels_count = levels + 1
    raw_mb = n_big * 3 * records * 8 / 2**20
    bounds_mb = 2 * levels_count * 3 * records * 8 / 2**20
    report.update(
        {
            "large_samples": n_big,
            "large_t_end_s": 1e-4,
            "large_wall_s": round(big_elapsed, 2),
            "large_peak_rss_mb": round(peak_mb, 1),
            "large_10ms_raw_outputs_mb": round(raw_mb, 1),
            "large_10ms_bounds_mb": round(bounds_mb, 2),
            "large_10ms_idle_cores_hours": round(
                report["cpu_us_per_sample_step"] * n_big * 1e4 / numba.get_num_threads() / 3.6e9,
                2,
            ),
        }
    )
    stand_in = Study(FullSizeStandIn(), STUDY1, method="grid", levels=levels)
    with tempfile.TemporaryDirectory() as store:
        start = time.perf_counter()
        stand_in.run(chunk_size=256, store=store, progress=False, keep_raw=False)
        report["fullsize_stream_wall_s"] = round(time.perf_counter() - start, 2)
    report["fullsize_stream_peak_rss_mb"] = round(
        resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1
    )
    json.dump(report, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
