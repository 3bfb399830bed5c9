"""Runs and true misses of every transformation method on the hard test models.

For bump3, ringing3 and valley4 (:mod:`fuzzymbs.models.closed_form.hard_cases`,
6 levels mu = 0, 0.2, ..., 1) each method's cuts are compared with the dense-grid
truth: the miss is :func:`fuzzymbs.fuzzy.band_scale.band_miss` (the part of the
true cut outside the computed one over max(true width, 0.1 x widest), largest
over levels and elements). The adaptive method also reports its own certified
error. Prints the Markdown table of docs/fuzzy.md.

    python benchmarks/method_misses.py
"""

from __future__ import annotations

import warnings

import numpy as np

from fuzzymbs.fuzzy import plan
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import dense_truth, hard_cases

LEVELS = np.linspace(0.0, 1.0, 6)
METHODS = ("reduced", "extended", "general", "grid", "sparse", "adaptive")


def _options(method: str, case) -> dict:
    if method == "extended":  # every parameter non-monotonic: what a screening names here
        return {"nonmonotonic": list(case.triangles)}
    if method == "sparse":
        return {"sparse_level": 4}
    return {}


def main() -> None:
    rows = []
    for case in hard_cases():
        truth = dense_truth(case, LEVELS)
        for method in METHODS:
            scheme = plan(
                triangular_numbers(case.triangles),
                method=method,
                levels=LEVELS,
                max_runs=None,
                **_options(method, case),
            )
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cuts = scheme.retransform(scheme.evaluate(case.model), check_monotonic=False)
            miss = max(band_miss(c.lower, c.upper, *truth[k]) for k, c in cuts.items())
            error = f"{100 * scheme.outcome().error:.2f} %" if method == "adaptive" else ""
            rows.append((case.name, method, len(scheme), miss, error))
            print(
                f"{case.name:9s} {method:9s} {len(scheme):6d} {100 * miss:8.2f} % {error}",
                flush=True,
            )
    print()
    print("| model | method | runs | true miss | reported error |")
    print("|---|---|---:|---:|---:|")
    for name, method, runs, miss, error in rows:
        print(f"| {name} | {method} | {runs:,} | {100 * miss:.2f} % | {error} |")


if __name__ == "__main__":
    main()
