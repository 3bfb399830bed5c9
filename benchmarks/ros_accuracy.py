"""ROS34PW2 against RK4 on the disc brake: error and cost.

    python benchmarks/ros_accuracy.py [--quick] [--rtol 1e-2 3e-3 ...]

Prints one JSON line. For the nominal brake and the corner sample
(k -10 %, k_c +10 %, F_n +1 %) over 10 ms (``--quick``: 1 ms), recorded every
10 us: the largest deviation over time of y_lpad / y_upad from RK4 at
dt = 1 us / 64 (15.6 ns, the converged reference of docs/brake.md), relative to
the reference's peak, with wall time and steps, for RK4 at 1 us and ROS34PW2
(:mod:`fuzzymbs.mbs.kernels.rosenbrock`) at several rtol (atol 1e-5 rtol, in
metres and metres per second), each sample in its own block (kernel
"samples"), through :func:`fuzzymbs.mbs.integrate.simulate`.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.study.integration_check import peak_relative_deviation
from fuzzymbs.tolerance import Tolerance

OUTPUTS = {
    "y_lpad": Coordinate("lower_pad", 0),
    "y_upad": Coordinate("upper_pad", 0),
    "y_cali": Coordinate("caliper", 0),
}
PADS = 2  # the accuracy criterion: y_lpad and y_upad; y_cali reported apart
RECORD = 1e-5  # s
SAMPLES = {
    "nominal": {},
    "corner": {
        "pad_spring_stiffness": 180e3,
        "caliper_spring_stiffness": 1.1e3,
        "nodal_force": 16.16e3,
    },
}
RTOLS = (1e-2, 3e-3, 1e-3, 1e-4)


def peak_error(y: np.ndarray, reference: np.ndarray) -> float:
    """Largest deviation over time, relative to the reference's peak, over the outputs."""
    return max(peak_relative_deviation(row, ref) for row, ref in zip(y, reference, strict=True))


def table(t_end: float, rtols: tuple[float, ...] = RTOLS) -> dict:
    """Figures per sample: reference time, RK4 at 1 us and ROS34PW2 per rtol."""
    compiled = DiscBrake(t_end=t_end).compiled

    def run(sample: dict, **options) -> tuple[np.ndarray, float, object]:
        values = {name: np.array([value]) for name, value in sample.items()}
        start = time.perf_counter()
        result = simulate(
            compiled,
            values,
            t_end=t_end,
            record_interval=RECORD,
            outputs=OUTPUTS,
            kernel="samples",
            **options,
        )
        seconds = time.perf_counter() - start
        if result.failed.any():
            raise RuntimeError(f"{options} failed on {sample}")
        return np.array([result.outputs[name][0] for name in OUTPUTS]), seconds, result

    simulate(compiled, {}, t_end=2e-5, dt=1e-6, record_interval=1e-5, outputs=OUTPUTS)
    simulate(
        compiled,
        {},
        t_end=2e-5,
        dt=1e-7,
        record_interval=1e-5,
        outputs=OUTPUTS,
        integrator="ros34pw2",
    )  # compile
    figures: dict = {"t_end_s": t_end}
    for label, sample in SAMPLES.items():
        reference, seconds, _ = run(sample, dt=1e-6 / 64)
        entry: dict = {"reference_seconds": round(seconds, 2)}

        y, seconds, _ = run(sample, dt=1e-6)
        entry["rk4_1us"] = {
            "seconds": round(seconds, 3),
            "steps": round(t_end / 1e-6),
            "error": peak_error(y[:PADS], reference[:PADS]),
            "error_y_cali": peak_relative_deviation(y[PADS], reference[PADS]),
        }
        for rtol in rtols:
            y, seconds, result = run(
                sample, dt=1e-7, integrator="ros34pw2", tolerance=Tolerance(rtol)
            )
            entry[f"ros34pw2_rtol_{rtol:g}"] = {
                "seconds": round(seconds, 3),
                "steps_accepted_rejected": result.step_counts[0].tolist(),
                "error": peak_error(y[:PADS], reference[:PADS]),
                "error_y_cali": peak_relative_deviation(y[PADS], reference[PADS]),
            }
        figures[label] = entry
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 ms instead of 10 ms")
    parser.add_argument("--rtol", type=float, nargs="+", default=list(RTOLS))
    args = parser.parse_args()
    print(json.dumps(table(1e-3 if args.quick else 1e-2, tuple(args.rtol))))
