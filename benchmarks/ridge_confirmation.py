"""Runs, true misses and reported errors of the adaptive method on ridges and hard cases.

The resonance models of :mod:`fuzzymbs.models.closed_form.resonance` (single- and
two-degree-of-freedom forced oscillators across resonance, damping ratios 0.5, 2 and
5 %) and the hard cases of :mod:`fuzzymbs.models.closed_form.hard_cases`, 6 levels,
default tolerance (1 %) and budget: runs, true miss (``band_miss`` against the closed
form, or the dense grid polished by a local optimiser), the certified error and the
status. Prints the Markdown table of docs/fuzzy.md.

    python benchmarks/ridge_confirmation.py [case-name ...]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from fuzzymbs.fuzzy import plan
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import dense_truth, hard_cases
from fuzzymbs.models.closed_form.resonance import polished_truth, resonance_cases, sdof_truth

LEVELS = np.linspace(0.0, 1.0, 6)


def _truth(case):
    if case.name.startswith("sdof"):
        return sdof_truth(case, LEVELS)
    if case.name.startswith("2dof"):
        return polished_truth(case, LEVELS)
    return dense_truth(case, LEVELS)


def main(names: list[str]) -> None:
    rows = []
    for case in [*resonance_cases(), *hard_cases()]:
        if names and case.name not in names:
            continue
        truth = _truth(case)
        scheme = plan(triangular_numbers(case.triangles), method="adaptive", levels=LEVELS)
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cuts = scheme.retransform(scheme.evaluate(case.model))
            outcome = scheme.outcome()
        seconds = time.perf_counter() - start
        miss = max(band_miss(c.lower, c.upper, *truth[k]) for k, c in cuts.items())
        rows.append((case.name, outcome.runs, miss, outcome.error, outcome.status))
        print(
            f"{case.name:10s} {outcome.runs:5d} runs  miss {100 * miss:6.2f} %  reported "
            f"{100 * outcome.error:6.2f} %  {outcome.status}  {seconds:.1f} s",
            flush=True,
        )
    print()
    print("| case | runs | true miss | reported error | status |")
    print("|---|---:|---:|---:|---|")
    for name, runs, miss, error, status in rows:
        print(f"| {name} | {runs:,} | {100 * miss:.2f} % | {100 * error:.2f} % | {status} |")


if __name__ == "__main__":
    main(sys.argv[1:])
