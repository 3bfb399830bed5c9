"""ROS34PW2 against RK4 on the nominal disc brake: error and cost (issue #14, in progress).

    python benchmarks/ros_accuracy.py [--quick]

Prints one JSON line: for the nominal brake over 10 ms (``--quick``: 1 ms),
recorded every 10 us, the largest deviation of y_lpad / y_upad from RK4 at
dt = 1 us / 64 (15.6 ns, the converged reference of docs/brake.md) relative to
the reference's peak, with wall time and steps, for RK4 at 1 us and
ROS34PW2 (:mod:`fuzzymbs.mbs.kernels.rosenbrock`) at rtol 1e-2 ... 1e-4 (atol
1e-4 rtol, in metres and metres per second). One sample (a padded block).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels.rosenbrock import ros34pw2
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake

OUTPUTS = {"y_lpad": Coordinate("lower_pad", 0), "y_upad": Coordinate("upper_pad", 0)}
RECORD = 1e-5  # s


def rosenbrock(compiled, t_end: float, rtol: float) -> tuple[np.ndarray, list[int]]:
    """(n_out, T) outputs of one nominal sample and [accepted, rejected] steps."""
    out_w = np.array([compiled.output_functional(spec) for spec in OUTPUTS.values()])
    n_rec = round(t_end / RECORD) + 1
    out = np.empty((1, out_w.shape[0], n_rec))
    status = np.zeros(1, dtype=np.int64)
    counts = np.zeros((1, 2), dtype=np.int64)
    ros34pw2(
        compiled.data,
        compiled.parameters.values({}),
        compiled.zero_state(1),
        (0.0, RECORD, n_rec, 1e-7),
        (out_w, np.full(out_w.shape[0], 1e-3), out, status, np.zeros(1)),
        (rtol, 1e-4 * rtol, 1e-14),
        4,
        counts,
    )
    if status[0] != 0:
        raise RuntimeError(f"ROS34PW2 failed at rtol {rtol} (status {status[0]})")
    return out[0], counts[0].tolist()


def table(t_end: float) -> dict:
    compiled = DiscBrake(t_end=t_end).compiled

    def rk4(dt: float) -> np.ndarray:
        run = simulate(compiled, {}, t_end=t_end, dt=dt, record_interval=RECORD, outputs=OUTPUTS)
        return np.array([run.outputs[name][0] for name in OUTPUTS])

    rosenbrock(compiled, 2e-5, 1e-3)  # compile
    rk4(1e-6)
    start = time.perf_counter()
    reference = rk4(1e-6 / 64)
    figures = {"t_end_s": t_end, "reference_seconds": round(time.perf_counter() - start, 2)}

    def error(y: np.ndarray) -> float:
        return float((np.abs(y - reference).max(axis=1) / np.abs(reference).max(axis=1)).max())

    start = time.perf_counter()
    coarse = rk4(1e-6)
    figures["rk4_1us"] = {
        "seconds": round(time.perf_counter() - start, 3),
        "steps": round(t_end / 1e-6),
        "error": error(coarse),
    }
    for rtol in (1e-2, 3e-3, 1e-3, 1e-4):
        start = time.perf_counter()
        y, steps = rosenbrock(compiled, t_end, rtol)
        figures[f"ros34pw2_rtol_{rtol:g}"] = {
            "seconds": round(time.perf_counter() - start, 3),
            "steps_accepted_rejected": steps,
            "error": error(y),
        }
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 ms instead of 10 ms")
    args = parser.parse_args()
    print(json.dumps(table(1e-3 if args.quick else 1e-2)))
