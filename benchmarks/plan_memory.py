"""Memory of building a plan, per run, near the default run limit (max_runs).

For each plan: the closed-form run count (``run_count``, no arrays), the peak of
traced allocations while ``plan(...)`` builds it (tracemalloc: NumPy reports its
buffers), what the built plan keeps (sample table, level-usage table, level
indices, corner indices) and the build time. Bytes per run at these sizes
extrapolate to the limit: the build is a fixed number of passes over the
generated points.

Usage::

    python benchmarks/plan_memory.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
import tracemalloc

import numpy as np

from fuzzymbs.fuzzy.numbers import Trapezoidal, Triangular
from fuzzymbs.fuzzy.transform import DEFAULT_MAX_RUNS, plan, run_count


def _parameters(count: int, trapezoids: int = 0) -> dict:
    numbers = {f"p{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(count - trapezoids)}
    numbers.update({f"t{i}": Trapezoidal(i, i + 0.2, i + 0.6, i + 1.0) for i in range(trapezoids)})
    return numbers


CASES = [
    # (label, parameters, method, levels, options)
    ("reduced n=17 m=7", 17, 0, "reduced", 7, {}),
    ("reduced n=12 m=4", 12, 0, "reduced", 4, {}),
    ("extended n=14 m=6, 2 non-monotonic", 14, 0, "extended", 6, {"nonmonotonic": ["p0", "p1"]}),
    ("general n=8 m=4", 8, 0, "general", 4, {}),
    ("grid n=6 m=4", 6, 0, "grid", 4, {}),
    ("sparse n=30 level 3", 30, 0, "sparse", 4, {"sparse_level": 3}),
]
QUICK = [
    ("reduced n=12 m=4", 12, 0, "reduced", 4, {}),
    ("general n=5 m=4", 5, 0, "general", 4, {}),
]


def _kept_bytes(built) -> int:
    kept = built.samples.nbytes + built.level_usage.nbytes
    kept += sum(built.level_indices(j).nbytes for j in range(len(built.levels)))
    if built.method in ("reduced", "extended", "grid"):
        kept += built.corner_index.nbytes
    return kept


def measure(label, count, trapezoids, method, levels, options) -> dict:
    parameters = _parameters(count, trapezoids)
    start = time.perf_counter()
    runs = run_count(parameters, method, levels, **options)
    count_time = time.perf_counter() - start
    tracemalloc.start()
    start = time.perf_counter()
    built = plan(parameters, method, levels, max_runs=None, **options)
    build_time = time.perf_counter() - start
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert len(built) <= runs
    kept = _kept_bytes(built)
    return {
        "plan": label,
        "runs": len(built),
        "run_count": runs,
        "count_ms": 1e3 * count_time,
        "build_s": build_time,
        "peak_MB": peak / 2**20,
        "peak_bytes_per_run": peak / len(built),
        "kept_bytes_per_run": kept / len(built),
        "peak_MB_at_limit": peak / len(built) * DEFAULT_MAX_RUNS / 2**20,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small plans only")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args()
    rows = [measure(*case) for case in (QUICK if args.quick else CASES)]
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(
        f"{'plan':38s} {'runs':>9s} {'count ms':>8s} {'build s':>7s} {'peak MB':>8s} "
        f"{'peak B/run':>10s} {'kept B/run':>10s} {'MB at 1e6':>9s}"
    )
    for row in rows:
        print(
            f"{row['plan']:38s} {row['runs']:9d} {row['count_ms']:8.2f} {row['build_s']:7.2f} "
            f"{row['peak_MB']:8.1f} {row['peak_bytes_per_run']:10.0f} "
            f"{row['kept_bytes_per_run']:10.0f} {row['peak_MB_at_limit']:9.0f}"
        )
    print(f"(numpy {np.__version__}; peak = traced allocations while plan() builds)")


if __name__ == "__main__":
    main()
