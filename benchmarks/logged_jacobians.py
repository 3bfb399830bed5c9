"""Samples on shared steps with the logging run's Jacobians or their own; prints one JSON line.

    python benchmarks/logged_jacobians.py [--studies 1 2] [--quick]

A study's samples on the modal sample's step sequence renew their Jacobian where the
logging run did. They can take the logging run's (``simulate(logged_jacobians=...)``,
the default of :mod:`fuzzymbs.mbs.shared_steps`) or evaluate their own at their own
state (before). For the 33 samples of the brake's reduced plan (study 1 at rtol 1e-3,
study 2 at 1e-4: the tolerances their pilots choose, 10 ms, levels 0, 0.25, 0.5,
0.75, 1), both ways in one process, alternating, the smaller CPU time of two calls:
CPU seconds, accepted and rejected steps, Jacobians evaluated, the outputs' largest
difference over the samples' spread, and each way's band error against the same plan at
rtol 1e-6 on each sample's own steps (cached in benchmarks/.cache by brake_bands.py),
the modal sample's reference added to both. Also the log's rows and size.

``--quick``: 0.3 ms (brake_bands' ``QUICK_T_END``), study 1 only (the smoke test's mode).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from bench_common import load_average
from brake_bands import OUTPUTS, QUICK_T_END, reduced_plan, reference_bands, shared_step_deviation

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.models.brake import DiscBrake

#: the tolerance each study's pilot chooses (docs/benchmarks.md, "The runs that judge a
#: brake study")
STUDY_RTOL = {1: 1e-3, 2: 1e-4}


def measure(study: int, t_end: float, reference: dict, rounds: int = 2) -> dict:
    """Both ways of one study's plan on its modal sample's sequence (module docstring)."""
    plan, samples, modal = reduced_plan(study)
    model = DiscBrake(t_end=t_end, rtol=STUDY_RTOL[study])
    shared = model.share_steps(modal).simulation
    steps = shared.shared
    sim = model.simulation
    common = {
        "outputs": sim.outputs,
        "initial_state": sim.initial_state,
        "step_sequence": steps.sequence,
        "jacobian_renewals": steps.renewals,
        **sim.settings,
    }
    found: dict = {"rtol": STUDY_RTOL[study], "sequence_steps": int(steps.sequence.size)}
    rows = steps.jacobians[0]
    found["log_rows"] = int(rows.shape[0])
    found["log_mb"] = round(rows.nbytes / 1e6, 1)
    results, cpu = {}, {"own": [], "logged": []}
    for _ in range(rounds):
        for way, jacobians in (("own", None), ("logged", steps.jacobians)):
            start = time.process_time()
            results[way] = simulate(sim.compiled, samples, logged_jacobians=jacobians, **common)
            cpu[way].append(time.process_time() - start)
    for way, result in results.items():
        if result.failed.any():
            raise RuntimeError(f"study {study}, {way}: samples failed")
        deviation = shared_step_deviation(plan, result, steps, reference)
        found[way] = {
            "cpu_s": round(min(cpu[way]), 2),
            "accepted": int(result.step_counts[:, 0].sum()),
            "rejected": int(result.step_counts[:, 1].sum()),
            "jacobians": int(result.work_counts[:, 1].sum()),
            "band_error": {k: max(v) for k, v in deviation.items()},
        }
    found["cpu_ratio_logged_over_own"] = round(found["logged"]["cpu_s"] / found["own"]["cpu_s"], 3)
    found["difference_of_spread"] = max(
        float(np.abs(results["logged"].outputs[k] - results["own"].outputs[k]).max())
        / float(np.ptp(results["own"].outputs[k], axis=0).max())
        for k in OUTPUTS
    )
    return found


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    t_end = QUICK_T_END if args.quick else 1e-2
    studies = (1,) if args.quick else tuple(args.studies)
    figures: dict = {"load_average_start": load_average(), "t_end_s": t_end}
    for study in studies:
        reference = reference_bands(study, t_end)
        figures[f"study{study}"] = measure(study, t_end, reference, rounds=1 if args.quick else 2)
    figures["load_average_end"] = load_average()
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
