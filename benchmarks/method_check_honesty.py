"""How honest is the method check? Reported ``method_error`` against the true miss.

For each hard test model of :mod:`fuzzymbs.models.closed_form.hard_cases` (bump3,
ringing3, valley4; 6 level steps) and each fixed transformation method (reduced,
extended with the first parameter non-monotonic, general, grid, sparse at its
default level), the method's cuts are compared with the dense-grid truth
(:func:`~fuzzymbs.models.closed_form.hard_cases.dense_truth`, resolved to about
0.1 % of the cut width) -- the true miss, :func:`fuzzymbs.fuzzy.band_scale.band_miss`
-- and with the study's default method check
(:func:`fuzzymbs.fuzzy.validation.check_plan`: the default count of validation
runs in four rounds) -- the reported ``method_error``. The target: the reported
error at least half the true miss wherever the true miss exceeds 1 %.

Usage::

    python benchmarks/method_check_honesty.py [--json]

About 20 s on one core (the dense truth of valley4's grid plan dominates).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

METHODS = ("reduced", "extended", "general", "grid", "sparse")
LEVELS = 6
TOLERANCE = 0.01


def measure() -> list[dict]:
    """One row per case and method."""
    from fuzzymbs.fuzzy import plan
    from fuzzymbs.fuzzy.band_scale import band_miss
    from fuzzymbs.fuzzy.numbers import triangular_numbers
    from fuzzymbs.fuzzy.validation import check_plan
    from fuzzymbs.models.closed_form.hard_cases import dense_truth, hard_cases

    rows = []
    for case in hard_cases():
        truth = None
        for method in METHODS:
            options = {"nonmonotonic": [next(iter(case.triangles))]} if method == "extended" else {}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the retransformation's own warnings
                scheme = plan(triangular_numbers(case.triangles), method, LEVELS, **options)
                outputs = scheme.evaluate(case.model)
                fuzzy = scheme.retransform(outputs)
            cuts = {name: (result.lower, result.upper) for name, result in fuzzy.items()}
            if truth is None:
                truth = dense_truth(case, scheme.levels)
            miss = max(band_miss(*cuts[name], *truth[name]) for name in cuts)
            started = time.perf_counter()
            check = check_plan(scheme, case.model, outputs, cuts)
            rows.append(
                {
                    "case": case.name,
                    "method": method,
                    "runs": len(scheme),
                    "validation_runs": len(check.points),
                    "rounds": check.rounds,
                    "true_miss": miss,
                    "method_error": check.error,
                    "honest": bool(miss <= TOLERANCE or check.error >= 0.5 * miss),
                    "check_s": round(time.perf_counter() - started, 3),
                }
            )
    return rows


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table."""
    lines = [
        "| case | method | runs | validation runs (per round) | true miss | method_error | "
        "reported / true |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        ratio = row["method_error"] / row["true_miss"] if row["true_miss"] > 1e-9 else float("nan")
        rounds = " + ".join(str(r) for r in row["rounds"])
        lines.append(
            f"| {row['case']} | {row['method']} | {row['runs']:,} | {row['validation_runs']} "
            f"({rounds}) | {100 * row['true_miss']:.1f} % | {100 * row['method_error']:.1f} % "
            f"| {ratio:.2f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    rows = measure()
    if args.json:
        print(json.dumps(rows))
    else:
        print(table(rows))
        dishonest = [f"{r['case']}/{r['method']}" for r in rows if not r["honest"]]
        print(f"below half the true miss: {', '.join(dishonest) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
