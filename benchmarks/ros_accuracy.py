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

from bench_common import BRAKE_SAMPLES, brake_errors, brake_outputs, brake_run

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

RTOLS = (1e-2, 3e-3, 1e-3, 1e-4)


def table(t_end: float, rtols: tuple[float, ...] = RTOLS) -> dict:
    """Figures per sample: reference time, RK4 at 1 us and ROS34PW2 per rtol."""
    compiled = DiscBrake(t_end=t_end).compiled
    outputs = brake_outputs()
    simulate(compiled, {}, t_end=2e-5, dt=1e-6, record_interval=1e-5, outputs=outputs)
    simulate(
        compiled,
        {},
        t_end=2e-5,
        dt=1e-7,
        record_interval=1e-5,
        outputs=outputs,
        integrator="ros34pw2",
    )  # compile
    figures: dict = {"t_end_s": t_end}
    for label, sample in BRAKE_SAMPLES.items():
        reference, seconds, _ = brake_run(compiled, sample, t_end, dt=1e-6 / 64)
        entry: dict = {"reference_seconds": round(seconds, 2)}

        y, seconds, _ = brake_run(compiled, sample, t_end, dt=1e-6)
        entry["rk4_1us"] = {
            "seconds": round(seconds, 3),
            "steps": round(t_end / 1e-6),
            **brake_errors(y, reference),
        }
        for rtol in rtols:
            y, seconds, result = brake_run(
                compiled, sample, t_end, dt=1e-7, integrator="ros34pw2", tolerance=Tolerance(rtol)
            )
            entry[f"ros34pw2_rtol_{rtol:g}"] = {
                "seconds": round(seconds, 3),
                "steps_accepted_rejected": result.step_counts[0].tolist(),
                **brake_errors(y, reference),
            }
        figures[label] = entry
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 ms instead of 10 ms")
    parser.add_argument("--rtol", type=float, nargs="+", default=list(RTOLS))
    args = parser.parse_args()
    print(json.dumps(table(1e-3 if args.quick else 1e-2, tuple(args.rtol))))
