"""Shared steps with the error's first-order part removed too; prints one JSON line.

    python benchmarks/first_order_correction.py [--studies 1 2] [--rtol 1e-2 1e-3] [--quick]

On the modal sample's shared steps a study removes the modal sample's own error from
every sample (``c(t) = y_ref(p0, t) - y(p0, t)``, :mod:`fuzzymbs.mbs.shared_steps`);
what is left of the integration error is its variation across the cut, to first
order ``e'(p0) (p - p0)`` (docs/theory.md, "Shared steps"). This benchmark measures
whether removing that first-order part as well would let a study take a looser
tolerance. ``e'(p0)`` is the slope of the model's deviations (``deviations``: minus the
modal sample on the same steps) less the slope of the same deviations at a tenth of
the tolerance (on that model's own shared steps), estimated two ways:

* ``central``: central differences at ``p0 +- h e_i``, ``h`` the step fraction times
  the support's half-width (2 n runs at each tolerance);
* ``corners``: the main effects of the 2^n corners of the innermost cut (the runs a
  study's tolerance pilot already makes at both tolerances, so no extra run).

The 33 samples of the brake's reduced plan (study 1: k, k_c +-10 %, F_n +-1 %;
study 2: k, k_c, omega +-10 %; levels 0, 0.25, 0.5, 0.75, 1) on the shared steps at
each rtol, corrected by the constant alone (today's) and by the constant and either
first-order part; their bands against the same plan at rtol 1e-6 on each sample's
own steps (cached in benchmarks/.cache by brake_bands.py), per output and level, as a
fraction of max(local cut width, 0.1 x the level's widest cut). CPU seconds: the plan's
runs (with the modal sample's logging run and its reference pair), the tighter model's
logging run, and the runs each estimate of the slope adds.

``--quick``: 0.3 ms (brake_bands' ``QUICK_T_END``), study 1, rtol 1e-2 (the smoke test's mode).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from bench_common import load_average
from brake_bands import (
    LEVELS,
    OUTPUTS,
    QUICK_T_END,
    plan_deviation,
    reference_bands,
    study_parameters,
)

import fuzzymbs
from fuzzymbs.models.brake import DiscBrake


def slopes_central(coarse: dict, fine: dict, h: np.ndarray) -> dict[str, np.ndarray]:
    """output -> (T, n): slope of ``coarse - fine`` from rows ``+h e_i, -h e_i`` per i."""
    found = {}
    for name in OUTPUTS:
        diff = np.asarray(coarse[name]) - np.asarray(fine[name])  # (2 n, T)
        found[name] = np.stack(
            [(diff[2 * i] - diff[2 * i + 1]) / (2 * h[i]) for i in range(len(h))], axis=-1
        )
    return found


def slopes_corners(coarse: dict, fine: dict, signs: np.ndarray, h: np.ndarray) -> dict:
    """output -> (T, n): main effects of ``coarse - fine`` over the 2^n corners
    ``p0 + signs h`` (least squares of a two-level factorial: mean of sign x value / h)."""
    found = {}
    for name in OUTPUTS:
        diff = np.asarray(coarse[name]) - np.asarray(fine[name])  # (2^n, T)
        found[name] = (signs.T @ diff).T / (len(signs) * h)
    return found


def corrected(values: dict, rows: np.ndarray, p0: np.ndarray, slope: dict | None) -> dict:
    """output -> (k, T): ``values`` at ``rows`` (k, n) less ``slope (row - p0)``; as they are
    where ``slope`` is None (the modal part alone)."""
    if slope is None:
        return {name: np.asarray(values[name]) for name in OUTPUTS}
    return {name: np.asarray(values[name]) - (rows - p0) @ slope[name].T for name in OUTPUTS}


def measure(study: int, rtol: float, t_end: float, fraction: float, reference: dict) -> dict:
    """Band deviations of the constant and the two first-order corrections at ``rtol``."""
    parameters = study_parameters(study)
    names = list(parameters)
    plan = fuzzymbs.plan(parameters, method="reduced", levels=LEVELS)
    samples, p0 = plan.samples, plan.samples[plan.nominal_index]
    n = len(names)
    half = np.array([(parameters[k].support[1] - parameters[k].support[0]) / 2 for k in names])
    h = fraction * half
    central = np.repeat(p0[None, :], 2 * n, axis=0)
    for i in range(n):
        central[2 * i, i] += h[i]
        central[2 * i + 1, i] -= h[i]
    # the innermost cut of non-zero width (level 0.75), as a study's pilot takes it
    inner = plan.level_indices(len(LEVELS) - 2)
    corners = samples[inner]
    signs = np.sign(corners - p0)
    corner_h = np.abs(corners - p0).max(axis=0)

    def columns(rows: np.ndarray) -> dict[str, np.ndarray]:
        return {k: rows[:, i] for i, k in enumerate(names)}

    modal = {k: float(p0[i]) for i, k in enumerate(names)}
    model = DiscBrake(t_end=t_end, rtol=rtol)
    model(columns(p0[None, :]))  # compile / warm up
    cpu = time.process_time()
    coarse = model.share_steps(modal)
    plan_out = coarse.deviations(columns(samples))
    reference_modal = coarse.simulation.shared.reference
    plan_cpu = time.process_time() - cpu
    cpu = time.process_time()
    coarse_central = coarse.deviations(columns(central))
    cpu_central_coarse = time.process_time() - cpu
    cpu = time.process_time()
    fine = coarse.tightened(10.0)  # a study's tighter model (the same reference): logs
    fine_logging_cpu = time.process_time() - cpu
    cpu = time.process_time()
    fine_central = fine.deviations(columns(central))
    cpu_central_fine = time.process_time() - cpu
    cpu = time.process_time()
    fine_corners = fine.deviations(columns(corners))
    cpu_corners_fine = time.process_time() - cpu
    coarse_corners = {name: np.asarray(plan_out[name])[inner] for name in OUTPUTS}
    slopes = {
        "constant": None,
        "central": slopes_central(coarse_central, fine_central, h),
        "corners": slopes_corners(coarse_corners, fine_corners, signs, corner_h),
    }
    found: dict = {
        "plan_cpu_s": round(plan_cpu, 2),
        "fine_logging_cpu_s": round(fine_logging_cpu, 2),
        "slope_cpu_s": {
            "central": round(cpu_central_coarse + cpu_central_fine, 2),
            "corners": round(cpu_corners_fine, 2),
        },
    }
    before = slopes_central(coarse_central, fine_central, h)
    for label, slope in slopes.items():
        outputs = corrected(plan_out, samples, p0, slope)
        for name in OUTPUTS:
            outputs[name] = reference_modal[name][None, :] + outputs[name]
        found[label] = plan_deviation(plan, outputs, reference)
        if slope is not None:
            # what is left of the slope of (model - finer model) at the central points,
            # relative to it before, each slope times its step (a change in m): 0 to
            # round-off for "central" (the correction's sign and scale), the two
            # estimates' disagreement for "corners"
            after = slopes_central(corrected(coarse_central, central, p0, slope), fine_central, h)
            found[f"{label}_slope_left"] = max(
                float(np.abs(after[k] * h).max() / np.abs(before[k] * h).max()) for k in OUTPUTS
            )
    return found


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rtol", type=float, nargs="+", default=[1e-2, 3e-3, 1e-3])
    parser.add_argument(
        "--step-fraction",
        type=float,
        default=0.25,
        help="central differences' step over the support's half-width (0.25: the level "
        "0.75 cut's half-width of a triangular number)",
    )
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    t_end = QUICK_T_END if args.quick else 1e-2
    studies = (1,) if args.quick else tuple(args.studies)
    rtols = (1e-2,) if args.quick else tuple(args.rtol)
    figures: dict = {"load_average_start": load_average(), "t_end_s": t_end}
    for study in studies:
        reference = reference_bands(study, t_end)
        figures[f"study{study}"] = {
            f"rtol {r:g}": measure(study, r, t_end, args.step_fraction, reference) for r in rtols
        }
    figures["load_average_end"] = load_average()
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
