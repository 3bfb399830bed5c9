"""The kernel corrections' block size: the adaptive method's rounds at the default against
the earlier 4,000,000 entries; prints readable lines to stderr and one JSON line.

    python benchmarks/correction_blocks.py [--repeats N] [--blocks VALUES HERMITE ...]

The adaptive method evaluates its kernel corrections
(:class:`fuzzymbs.fuzzy.residual_correction.KernelCorrection`,
:class:`fuzzymbs.fuzzy.hermite_correction.HermiteCorrection`) at every point of its box
searches, a block of points at a time: each block makes arrays of ``points x centres``
entries (distances, the kernel, the design matrix), so with a few outputs and many runs
the time goes into those passes over memory, not into arithmetic. A block that fits the
core's cache makes them cheaper. For cases whose model costs nothing, so that the time
is the method's (the oscillator and the two-mass chain at 0.5 % damping, 1,119 to 2,324
runs; ringing3; 6 levels, tolerance 1 %), each pair of block sizes (``_BLOCK_ENTRIES``
of the two modules) runs in this process in turn, ``--repeats`` rounds, the smallest
wall time of each; the runs and the certified error must agree (a block changes no
sum's order within a row, only which BLAS kernel computes it: round-off apart).

Also :func:`fuzzymbs.fuzzy.grids.nearest_distances` (extremal points against the runs)
at its default block against 2,000,000 entries, on random point sets of a brake study's
size (60,030 points, 76 runs, 3 parameters) and of the closed-form cases with many runs
(16,000 x 1,400 x 4 and 20,000 x 2,000 x 4): the smallest of ``--repeats`` calls, and
whether the two give the same numbers (they must: maxima and minima are exact).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import gradient_adaptive
import numpy as np
from bench_common import load_average

import fuzzymbs.fuzzy.grids as grids
import fuzzymbs.fuzzy.hermite_correction as hermite_correction
import fuzzymbs.fuzzy.residual_correction as residual_correction
from fuzzymbs.models.closed_form.hard_cases import hard_cases
from fuzzymbs.models.closed_form.resonance import resonance_cases

#: (case, with the model's gradients)
CASES = (("sdof-0.5%", False), ("2dof-0.5%", False), ("2dof-0.5%", True), ("ringing3", True))
#: the block sizes before (entries of the values' and the Hermite correction's blocks)
EARLIER = (4_000_000, 4_000_000)
#: nearest_distances' block before, and its point sets (points, runs, parameters)
EARLIER_DISTANCES = 2_000_000
DISTANCE_SETS = ((60_030, 76, 3), (16_000, 1_400, 4), (20_000, 2_000, 4))


def run(case, gradients: bool, blocks: tuple[int, int]) -> dict:
    """The adaptive method's rounds on ``case`` with the corrections' ``blocks``."""
    kept = residual_correction._BLOCK_ENTRIES, hermite_correction._BLOCK_ENTRIES
    residual_correction._BLOCK_ENTRIES, hermite_correction._BLOCK_ENTRIES = blocks
    try:
        start = time.perf_counter()
        engine = gradient_adaptive.run(case, gradients)
        seconds = time.perf_counter() - start
    finally:
        residual_correction._BLOCK_ENTRIES, hermite_correction._BLOCK_ENTRIES = kept
    outcome = engine.outcome()
    return {"seconds": seconds, "runs": outcome.runs, "error": outcome.error}


def nearest_distances_times(repeats: int, seed: int = 0) -> dict:
    """Per point set, the smallest time of nearest_distances at EARLIER_DISTANCES and at the
    default block, and whether both give the same numbers."""
    rng = np.random.default_rng(seed)
    default = grids._BLOCK_ENTRIES
    rows = {}
    for count, runs, dimension in DISTANCE_SETS:
        points = rng.uniform(-1.0, 1.0, (count, dimension))
        others = rng.uniform(-1.0, 1.0, (runs, dimension))
        times: dict[int, float] = {}
        found = {}
        for _ in range(repeats):
            for block in (EARLIER_DISTANCES, default):
                grids._BLOCK_ENTRIES = block
                try:
                    start = time.perf_counter()
                    found[block] = grids.nearest_distances(points, others)
                    seconds = time.perf_counter() - start
                finally:
                    grids._BLOCK_ENTRIES = default
                times[block] = min(times.get(block, np.inf), seconds)
        rows[f"{count}x{runs}x{dimension}"] = {
            "earlier_ms": 1e3 * times[EARLIER_DISTANCES],
            "default_ms": 1e3 * times[default],
            "ratio": times[default] / times[EARLIER_DISTANCES],
            "same_numbers": bool(np.array_equal(found[default], found[EARLIER_DISTANCES])),
        }
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument(
        "--blocks", type=int, nargs="+", help="pairs: values' and Hermite blocks (entries)"
    )
    args = parser.parse_args()
    if args.blocks and len(args.blocks) % 2:
        parser.error("--blocks takes pairs: the values' and the Hermite correction's entries")
    default = (residual_correction._BLOCK_ENTRIES, hermite_correction._BLOCK_ENTRIES)
    pairs = [EARLIER, default]
    if args.blocks:
        pairs += [tuple(args.blocks[i : i + 2]) for i in range(0, len(args.blocks), 2)]
    cases = {case.name: case for case in [*hard_cases(), *resonance_cases()]}
    report: dict = {"load_average_start": load_average(), "default": default, "rows": {}}
    for name, gradients in CASES:
        label = f"{name} {'gradients' if gradients else 'values'}"
        best: dict = {}
        for _ in range(args.repeats):
            for blocks in pairs:
                result = run(cases[name], gradients, blocks)
                key = f"{blocks[0]}/{blocks[1]}"
                if key not in best or result["seconds"] < best[key]["seconds"]:
                    best[key] = result
        first = f"{EARLIER[0]}/{EARLIER[1]}"
        for key in best:
            best[key]["ratio"] = best[key]["seconds"] / best[first]["seconds"]
        report["rows"][label] = best
        cells = "  ".join(
            f"{key}: {row['seconds']:.2f} s ({row['runs']} runs, {100 * row['error']:.3f} %,"
            f" x{row['ratio']:.2f})"
            for key, row in best.items()
        )
        print(f"{label:22s} {cells}", file=sys.stderr)
    report["nearest_distances"] = nearest_distances_times(max(3, args.repeats))
    for key, row in report["nearest_distances"].items():
        print(f"nearest_distances {key}: {row}", file=sys.stderr)
    report["load_average_end"] = load_average()
    print(json.dumps(report))


if __name__ == "__main__":
    main()
