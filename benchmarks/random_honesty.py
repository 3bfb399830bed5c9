"""The adaptive method's certificate on random functions it was never tuned on.

The closed-form cases of docs/fuzzy.md (bump3, ringing3, valley4, the resonances) are
the cases the method's rules were found on; a certificate that holds only there would
not be one. This script draws smooth random models instead
(:func:`fuzzymbs.models.closed_form.random_models.random_case`: seeded
sums of anisotropic Gaussian bumps, a linear trend and an oblique ridge over the
support box, as a scalar or as a 21-point signal whose terms swing with their own
frequencies and phases), runs the adaptive method
(:class:`fuzzymbs.fuzzy.adaptive.AdaptiveTransformation`, 6 levels, tolerance 1 %,
budget 8,000) with and without their analytic gradients, and compares the cuts with the
truth (:func:`fuzzymbs.models.closed_form.resonance.polished_truth`: a dense grid of
every level's box, each bound then polished by a bounded local optimiser from the
best points of a coarser grid). Per case and path: runs, the true miss
(:func:`fuzzymbs.fuzzy.band_scale.band_miss`), the certified error, the status and
whether the result is honest (a miss within the tolerance + the truth's 0.1 %, or at
least half of it reported). Prints one line per run and a summary.

    python benchmarks/random_honesty.py [--seeds S] [--first-seed F]
        [--dimensions 2 3 4] [--elements 1 21] [--gradients both|true|false]
        [--tolerance T] [--certify bounds|global]
"""

from __future__ import annotations

import argparse
import sys
import time

import gradient_adaptive
from gradient_adaptive import LEVELS, judged, run

from fuzzymbs.fuzzy.adaptive import CERTIFICATES
from fuzzymbs.models.closed_form.random_models import random_case
from fuzzymbs.models.closed_form.resonance import polished_truth


def main(arguments: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--dimensions", type=int, nargs="+", default=[2, 3, 4])
    parser.add_argument("--elements", type=int, nargs="+", default=[1, 21])
    parser.add_argument("--gradients", choices=("both", "true", "false"), default="both")
    parser.add_argument("--tolerance", type=float, default=0.01)
    parser.add_argument("--certify", choices=CERTIFICATES, default="bounds")
    args = parser.parse_args(arguments)
    paths = {"both": (False, True), "true": (True,), "false": (False,)}[args.gradients]
    # the rounds and the judgment of gradient_adaptive.py (6 levels, budget 8,000,
    # 20,000 search points), at this tolerance
    gradient_adaptive.TOLERANCE = args.tolerance
    gradient_adaptive.CERTIFY = args.certify
    rows = []
    for dimension in args.dimensions:
        for elements in args.elements:
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                case = random_case(seed, dimension, elements)
                truth = polished_truth(case, LEVELS)
                for gradients in paths:
                    start = time.process_time()
                    outcome = run(case, gradients).outcome()
                    seconds = time.process_time() - start
                    miss, honest = judged(outcome, truth)
                    rows.append((case.name, gradients, outcome.runs, miss, outcome, honest))
                    print(
                        f"{case.name:12s} gradients {gradients!s:5s} {outcome.runs:5d} runs "
                        f"miss {100 * miss:6.2f} %  reported {100 * outcome.error:6.2f} %  "
                        f"{outcome.status:9s} honest {honest}  {seconds:6.1f} s",
                        flush=True,
                    )
    within = sum(1 for *_, miss, outcome, _ in rows if miss <= args.tolerance + 0.001)
    honest = sum(1 for *_, h in rows if h)
    converged = sum(1 for *_, outcome, _ in rows if outcome.converged)
    largest = max(miss for *_, miss, _, _ in rows)
    total = sum(runs for _, _, runs, *_ in rows)
    print(
        f"{len(rows)} runs of the method: {converged} converged, {within} within the "
        f"tolerance, {honest} honest, largest miss {100 * largest:.2f} %; {total:,} model "
        f"runs in all (certify {args.certify})"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
