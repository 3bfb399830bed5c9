"""The adaptive method's box search: the compiled climb against the array climb it replaced.

    python benchmarks/box_search.py [--repeats N]

Prints readable lines to stderr and one JSON line to stdout.

:func:`fuzzymbs.fuzzy.box_search.climb` polishes every (box, element, bound) of the
surrogate from its best search-grid point. It runs in a compiled kernel
(:mod:`fuzzymbs.fuzzy.climb_kernel`, each start on its own); before, it ran with arrays
over every start still moving (:func:`array_climb` below, the baseline, the code it
replaced). Both in the same process, alternating, the smallest of ``--repeats``:

* **one box search of a brake-sized surrogate**: three parameters, a series of 25 terms
  (total degree 4), 6,003 output elements (three signals of 2,001 points), six nested
  cut boxes, a cubic correction through 64 runs; the series' coefficients fall with
  the degree and each element's mix of linear and curved terms varies, so that most
  starts sit in a corner and some climb (:func:`brake_sized`);
* **the residual correction on a search grid's block** (:meth:`KernelCorrection.values
  <fuzzymbs.fuzzy.residual_correction.KernelCorrection.values>`, one matrix product of
  the kernel, constant and linear terms) against the three terms added
  (:func:`three_term_values`, the code it replaced): brake study 1's sizes, 1,332 grid
  points, 76 runs, 3,003 output elements;
* **the adaptive method on closed-form cases** (ringing3, a 201-point signal, with and
  without the model's gradients; bump3, the oscillators at 2 %; 6 levels, tolerance 1 %),
  whose model costs nothing, so the time is the method's: the wall time of the rounds,
  the runs, and the certified error, which must agree between the two climbs (they sum
  the same terms in another order: round-off apart).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import gradient_adaptive
import numpy as np
from bench_common import load_average

from fuzzymbs.fuzzy import box_search
from fuzzymbs.fuzzy.chebyshev_grid import basis_gradient, basis_matrix
from fuzzymbs.fuzzy.residual_correction import KernelCorrection, cubic_kernel
from fuzzymbs.models.closed_form.hard_cases import hard_cases
from fuzzymbs.models.closed_form.resonance import resonance_cases

CASES = ("ringing3", "bump3", "sdof-2%")


def array_climb(degrees, coefficients, starts, element, sign, low, high, correction=None):
    """The array climb the kernel replaced: every start still moving, one step at a time."""
    x = starts.copy()
    width = high - low
    step = 0.05 * np.maximum(width.max(axis=1), 1e-300)
    column = coefficients[:, element]

    def value_at(points, rows):
        own = np.einsum("kd,dk->k", basis_matrix(degrees, points), column[:, rows])
        return own if correction is None else own + correction.at(points, element[rows])

    value = value_at(x, np.arange(len(x)))
    active = np.arange(len(x))
    for _ in range(box_search._STEPS):
        if not len(active):
            break
        here, box_low, box_high = x[active], low[active], high[active]
        _, gradient = basis_gradient(degrees, here)
        slope = np.einsum("ikd,dk->ki", gradient, column[:, active])
        if correction is not None:
            slope = slope + correction.gradient_at(here, element[active])
        slope = np.where(width[active] > 0.0, slope * sign[active, None], 0.0)
        inward = ((slope > 0.0) & (here < box_high)) | ((slope < 0.0) & (here > box_low))
        norm = np.linalg.norm(slope, axis=1)
        moving = norm > 0.0
        direction = np.where(moving[:, None], slope / np.where(moving, norm, 1.0)[:, None], 0.0)
        trial = np.clip(here + step[active, None] * direction, box_low, box_high)
        trial_value = value_at(trial, active)
        better = sign[active] * trial_value > sign[active] * value[active]
        x[active[better]], value[active[better]] = trial[better], trial_value[better]
        step[active] = np.where(better, 1.5 * step[active], 0.5 * step[active])
        active = active[inward.any(axis=1)]
    return x, value


def three_term_values(correction: KernelCorrection, points: np.ndarray) -> np.ndarray:
    """The correction at ``points`` as it was computed before: the kernel's product, the
    constant and the linear term added, each a (Q, E) array."""
    part = np.atleast_2d(points)[:, correction.moving]
    kernel = cubic_kernel(part, correction.centres)
    return kernel @ correction.weights + correction.tail[0] + part @ correction.tail[1:]


def correction_values(repeats: int, seed: int = 5) -> dict:
    """Best-of-``repeats`` times of :meth:`KernelCorrection.values` and
    :func:`three_term_values` on one block of brake study 1's size, and their largest
    difference relative to the values' largest magnitude."""
    rng = np.random.default_rng(seed)
    centres, elements, points, dimension = 76, 3003, 1332, 3
    correction = KernelCorrection(
        rng.uniform(-1.0, 1.0, (centres, dimension)),
        rng.normal(size=(centres, elements)),
        np.ones(dimension, dtype=bool),
    )
    grid = rng.uniform(-1.0, 1.0, (points, dimension))
    variants = {"three_terms": three_term_values, "one_product": KernelCorrection.values}
    times: dict[str, list[float]] = {name: [] for name in variants}
    values = {}
    for _ in range(repeats):
        for name, function in variants.items():
            start = time.perf_counter()
            for _ in range(10):
                values[name] = function(correction, grid)
            times[name].append((time.perf_counter() - start) / 10)
    difference = np.abs(values["one_product"] - values["three_terms"]).max()
    return {
        "three_terms_ms": 1e3 * min(times["three_terms"]),
        "one_product_ms": 1e3 * min(times["one_product"]),
        "speedup": min(times["three_terms"]) / min(times["one_product"]),
        "largest_difference_relative": float(difference / np.abs(values["three_terms"]).max()),
    }


def brake_sized(seed: int = 11) -> dict:
    """A surrogate of the brake study's size (see the module docstring)."""
    rng = np.random.default_rng(seed)
    degrees = np.array(
        [(a, b, c) for a in range(5) for b in range(5) for c in range(5) if a + b + c <= 4],
        dtype=np.int64,
    )[:25]
    elements = 6003
    total = degrees.sum(axis=1)
    coefficients = rng.normal(size=(len(degrees), elements)) * 0.3 ** total[:, None]
    coefficients[1:4] += rng.uniform(0.5, 2.0, size=(3, elements))  # mostly monotonic
    centres = rng.uniform(-1.0, 1.0, size=(64, 3))
    correction = KernelCorrection(
        centres, 0.01 * rng.normal(size=(64, elements)), np.ones(3, dtype=bool)
    )
    spans = np.linspace(1.0, 0.0, 6)
    low, high = -spans[:, None] * np.ones(3), spans[:, None] * np.ones(3)
    return {"degrees": degrees, "coefficients": coefficients, "low": low, "high": high,
            "correction": correction}  # fmt: skip


def time_box_search(climb, surrogate: dict) -> tuple[float, tuple]:
    box_search.climb = climb
    start = time.perf_counter()
    found = box_search.box_extremes(
        surrogate["degrees"], surrogate["coefficients"], surrogate["low"], surrogate["high"],
        correction=surrogate["correction"],
    )  # fmt: skip
    return time.perf_counter() - start, found


def run_case(climb, case, gradients: bool) -> dict:
    """The adaptive method's rounds on a closed-form case with ``climb`` in the box search
    and the extremum confirmation."""
    import fuzzymbs.fuzzy.extremum_confirmation as confirmation

    box_search.climb = climb
    confirmation.climb = climb
    start = time.perf_counter()
    engine = gradient_adaptive.run(case, gradients)  # 6 levels, 1 %, budget 8,000
    seconds = time.perf_counter() - start
    outcome = engine.outcome()
    return {"seconds": seconds, "runs": outcome.runs, "error": outcome.error}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    compiled = box_search.climb
    climbs = {"array": array_climb, "compiled": compiled}
    report: dict = {"load_average_start": load_average()}
    surrogate = brake_sized()
    time_box_search(compiled, surrogate)  # compile (or load the cache)
    times: dict[str, list[float]] = {name: [] for name in climbs}
    results = {}
    for _ in range(args.repeats):
        for name, climb in climbs.items():
            seconds, results[name] = time_box_search(climb, surrogate)
            times[name].append(seconds)
    spread = np.ptp(results["array"][1] - results["array"][0])
    report["brake_sized_box_search"] = {
        "array_s": min(times["array"]),
        "compiled_s": min(times["compiled"]),
        "speedup": min(times["array"]) / min(times["compiled"]),
        "bounds_largest_difference_over_widest_cut": float(
            max(np.abs(results["array"][k] - results["compiled"][k]).max() for k in (0, 1)) / spread
        ),
    }
    print(f"brake-sized box search: {report['brake_sized_box_search']}", file=sys.stderr)
    report["correction_values"] = correction_values(args.repeats)
    print(f"correction on a grid block: {report['correction_values']}", file=sys.stderr)
    cases = {case.name: case for case in [*hard_cases(), *resonance_cases()]}
    rows = {}
    for name in CASES:
        for gradients in (False, True):
            label = f"{name} {'gradients' if gradients else 'values'}"
            row = {}
            for climb_name, climb in climbs.items():
                best = None
                for _ in range(args.repeats):
                    result = run_case(climb, cases[name], gradients)
                    if best is None or result["seconds"] < best["seconds"]:
                        best = result
                row[climb_name] = best
            row["speedup"] = row["array"]["seconds"] / row["compiled"]["seconds"]
            rows[label] = row
            cells = [
                f"{key} {row[key]['seconds']:.2f} s ({row[key]['runs']} runs, "
                f"{100 * row[key]['error']:.3f} %)"
                for key in climbs
            ]
            print(f"{label:22s} " + "  ".join(cells) + f"  x{row['speedup']:.2f}", file=sys.stderr)
    box_search.climb = compiled
    report["adaptive_cases"] = rows
    report["load_average_end"] = load_average()
    print(json.dumps(report))


if __name__ == "__main__":
    main()
