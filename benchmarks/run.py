"""Run every fuzzymbs benchmark; the last output line is one JSON object with all figures.

Usage::

    python benchmarks/run.py [--quick] [--json] [--no-exudyn] [--out FILE]

``--quick`` (under a minute on 2 cores) integrates shorter end times and runs
smaller subsets of the baselines, scaling the figures as each script's
docstring says; ``--json`` prints only the JSON line. Progress goes to stderr.
See docs/benchmarks.md for what each figure means and the measured table.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

# kernels parallelise over samples; BLAS stays single-threaded (the matmul bound
# is measured in subprocesses with its own thread settings)
for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(1, str(Path(__file__).resolve().parent.parent / "src"))

from bench_common import load_average, log, machine  # noqa: E402

#: (JSON key, comparison, target) of the performance targets on the 2-core machine.
TARGETS = (
    ("brake_study_seconds", "<=", 5.0),
    ("brake_speedup_vs_numpy_loop", ">=", 50.0),
    ("brake_speedup_vs_solve_ivp", ">=", 100.0),
    ("brake_speedup_vs_exudyn", ">=", 20.0),
    ("gear_study_seconds", "<=", 1.0),
    ("gear_speedup_vs_python_loop", ">=", 30.0),
    ("brake_fraction_of_flop_bound", ">=", 0.40),
)


def targets(figures: dict[str, Any]) -> dict[str, Any]:
    """Each target with the measured value, whether it is met, and the factor to go."""
    rows = {}
    for key, op, goal in TARGETS:
        value = figures.get(key)
        if value is None:
            rows[key] = {"target": f"{op} {goal}", "value": None, "met": None}
            continue
        met = value <= goal if op == "<=" else value >= goal
        short = value / goal if op == "<=" else goal / value  # > 1: how far off
        rows[key] = {"target": f"{op} {goal}", "value": value, "met": bool(met)}
        rows[key]["factor_missing"] = None if met else short
    return rows


def table(figures: dict[str, Any]) -> str:
    """Human-readable summary of the headline figures."""
    lines = [f"{'figure':40s} {'value':>14s}  target", "-" * 70]
    for key, row in figures["targets"].items():
        value = row["value"]
        text = "n/a" if value is None else f"{value:14.4g}"
        mark = "" if row["met"] is None else ("met" if row["met"] else "MISSED")
        lines.append(f"{key:40s} {text:>14s}  {row['target']} {mark}")
    lines.append("-" * 70)
    for key in (
        "brake_seconds_per_sample_step",
        "brake_flops_per_sample_step",
        "matmul_gflops_1_thread",
        "matmul_gflops_2_threads",
        "brake_study_gflops",
    ):
        if figures.get(key) is not None:
            lines.append(f"{key:40s} {figures[key]:14.4g}")
    for row in figures.get("scaling_batches", []):
        lines.append(
            f"  batch {row['batch']:5d}: {row['seconds_per_sample_step'] * 1e6:8.2f} us/sample-step"
            f"  {row['gflops']:6.2f} GFLOP/s  {100 * row['fraction_of_flop_bound']:5.1f} % of bound"
            f"  ({row['gflops_per_core']:5.2f} GFLOP/s per CPU-second)"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (under a minute)")
    parser.add_argument("--json", action="store_true", help="print only the JSON line")
    parser.add_argument("--no-exudyn", action="store_true", help="skip the Exudyn comparison")
    parser.add_argument("--out", type=Path, help="also write the JSON to this file")
    args = parser.parse_args(argv)
    quick = args.quick

    import brake_bench
    import brake_flops
    import gear_bench
    import profile_brake
    import scaling
    import startup
    from matmul_rate import matmul_gflops

    from fuzzymbs.fuzzy import NonMonotonicWarning

    # the brake study's monotonicity guard warns on every run; timing is the point here
    warnings.simplefilter("ignore", NonMonotonicWarning)
    began = time.perf_counter()
    figures: dict[str, Any] = {"quick": quick, "machine": machine()}

    size = 1500 if quick else 3000
    log(f"matmul rate ({size} x {size} float64)")
    one, two = matmul_gflops(1, size, 3), matmul_gflops(2, size, 3)
    figures["matmul_gflops_1_thread"] = one["gflops"]
    figures["matmul_gflops_2_threads"] = two["gflops"]
    # the kernels run on 2 threads; when other load makes the 2-thread product slower
    # than the 1-thread one, the larger rate is the (conservative) bound
    bound = max(one["gflops"], two["gflops"])
    figures["flop_bound_gflops"] = bound

    figures.update(gear_bench.run(quick))
    figures.update(brake_bench.run(quick))

    model = brake_bench.brake_model(20 * brake_bench.DT)
    count = brake_flops.step_flops(model.compiled.data, figures["brake_contact_active_fraction"])
    flops = count["flops_per_sample_step"]
    figures["brake_flops_per_sample_step"] = flops
    figures["brake_flop_count"] = count
    figures["brake_study_gflops"] = flops / figures["brake_seconds_per_sample_step"] / 1e9
    figures["brake_study_fraction_of_flop_bound"] = figures["brake_study_gflops"] / bound
    # the ideal 2-core product rate (twice the 1-thread rate) as a stricter bound
    figures["brake_study_fraction_of_ideal_two_core_bound"] = figures["brake_study_gflops"] / (
        2.0 * one["gflops"]
    )

    if args.no_exudyn:
        figures["brake_exudyn"] = None
    else:
        try:
            import brake_exudyn

            exu = brake_exudyn.run(steps=100 if quick else 1000, batch=33)
            figures["brake_exudyn"] = exu
            figures["brake_speedup_vs_exudyn"] = exu["speedup"]
        except ImportError as exc:
            log(f"exudyn comparison skipped: {exc}")
            figures["brake_exudyn"] = None

    steps = 10 if quick else 50
    figures["scaling_batches"] = scaling.batch_scaling(steps, flops, bound)
    large = [r for r in figures["scaling_batches"] if r["batch"] >= 343]
    figures["brake_fraction_of_flop_bound"] = min(r["fraction_of_flop_bound"] for r in large)
    # per core, from CPU time: robust when other jobs share the machine
    figures["brake_fraction_of_core_bound_cpu"] = min(
        r["gflops_per_core"] / one["gflops"] for r in large
    )
    figures["brake_profile"] = profile_brake.profile(
        batch=33 if quick else 343,
        steps=20 if quick else 200,
        active_fraction=figures["brake_contact_active_fraction"],
    )
    figures["scaling_parameters"] = scaling.parameter_scaling(6)
    figures["scaling_dask"] = scaling.dask_vs_inline(100 if quick else 1000)
    figures["startup"] = startup.startup(quick)
    figures["peak_rss_mb"] = figures["startup"]["cached"].get("peak_rss_mb")

    figures["targets"] = targets(figures)
    figures["load_average_at_end"] = load_average()
    figures["benchmark_wall_seconds"] = time.perf_counter() - began
    text = json.dumps(figures, allow_nan=False)
    if args.out:
        args.out.write_text(text + "\n")
    if not args.json:
        print(table(figures))
    print(text)
    return figures


if __name__ == "__main__":
    main()
