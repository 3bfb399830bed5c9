"""How accurate the extrapolated reference of shared steps is, and what it costs; one JSON line.

    python benchmarks/reference_extrapolation.py [--t-end 0.01]

The modal sample of the brake's studies (the default parameters) integrated alone
at rtol 1e-4, 1e-5, 1e-6 and 1e-7, each on its own steps
(:mod:`fuzzymbs.mbs.shared_steps`). The reference a study takes is the runs at 1e-5
and 1e-4 extrapolated with the error law rtol^q (q = REFERENCE_ORDER = 0.88); the
earlier reference was the run at 1e-6. Against the run at 1e-7 (whose own error is
about a tenth of the 1e-6 run's), each is judged on the default studies' cut widths
(the bands that ``brake_bands.py --parts cost --cost-studies 1 2`` stores in
benchmarks/.cache; without them, on the peak) with the normalisation of
``time_integration_error``: the largest deviation over the pads' and the caliper's
elements divided by max(cut width, 0.1 x the widest cut of that level), per level.
Also: the extrapolation with the slopes 0.82 and 1.0 (how much rests on the law),
the reference's error estimate, the steps of each run and the wall time of the
reference block (the two runs as lanes of one SIMD block) against the run at 1e-6
alone, on one thread. Figures behind docs/brake.md ("The reference").
"""

from __future__ import annotations

import argparse
import json
import time
from types import SimpleNamespace

import numba
import numpy as np
from bench_common import load_average
from brake_bands import default_runs_file

from fuzzymbs.fuzzy.band_scale import width_relative
from fuzzymbs.mbs.shared_steps import REFERENCE_ORDER, REFERENCE_RTOL, _extrapolated
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

OUTPUTS = ("y_lpad", "y_upad", "y_cali")
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7)


def runs(t_end: float) -> tuple[dict, dict, dict]:
    """Outputs, steps and wall time of the modal sample at each of :data:`RTOLS`."""
    model = DiscBrake(t_end=t_end).simulation
    model.simulate({}, tolerance=Tolerance(1e-2))  # compiled
    outputs, steps, seconds = {}, {}, {}
    for rtol in RTOLS:
        start = time.perf_counter()
        result = model.simulate({}, tolerance=Tolerance(rtol))
        seconds[rtol] = time.perf_counter() - start
        outputs[rtol] = {name: result.outputs[name][0] for name in OUTPUTS}
        steps[rtol] = int(result.step_counts[0].sum())
    start = time.perf_counter()
    pair = model.simulate(
        {"nodal_force": np.full(2, 16e3)}, tolerance=Tolerance(np.array([1e-4, 1e-5]))
    )
    seconds["pair_block"] = time.perf_counter() - start
    assert all(np.array_equal(pair.outputs[n][1], outputs[1e-5][n]) for n in OUTPUTS), (
        "a lane of the pair differs from its run alone"
    )
    return outputs, steps, seconds


def extrapolated(outputs: dict, order: float = REFERENCE_ORDER) -> tuple[dict, dict]:
    """The reference a study takes (:func:`fuzzymbs.mbs.shared_steps._extrapolated`) from
    the runs at REFERENCE_RTOL and ten times it, with the error law's slope ``order``, and
    its error estimate."""
    tight, loose = outputs[REFERENCE_RTOL], outputs[10 * REFERENCE_RTOL]
    runs = SimpleNamespace(
        outputs={n: np.array([tight[n], loose[n]]) for n in OUTPUTS},
        failed=np.array([False, False]),
    )
    model = SimpleNamespace(outputs=dict.fromkeys(OUTPUTS))
    return _extrapolated(model, {}, runs, (0, 1), order)


def errors(candidate: dict, truth: dict, bands: dict | None) -> list[float]:
    """Largest deviation per level [% of the cut width] (or of the peak without bands)."""
    if bands is None:
        peak = max(
            float(np.max(np.abs(candidate[n] - truth[n]) / np.abs(truth[n]).max())) for n in OUTPUTS
        )
        return [float(f"{100 * peak:.3g}")]
    per_level = None
    for name in OUTPUTS:
        lower, upper = bands[name]
        deviation = np.broadcast_to(np.abs(candidate[name] - truth[name]), lower.shape)
        ratio = np.nanmax(width_relative(deviation, lower, upper), axis=1)
        per_level = ratio if per_level is None else np.fmax(per_level, ratio)
    return [float(f"{100 * float(r):.3g}") for r in per_level if np.isfinite(r)]


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=0.01)
    args = parser.parse_args(argv)
    numba.set_num_threads(1)
    figures: dict = {"load_average_start": load_average(), "t_end_s": args.t_end}
    outputs, steps, seconds = runs(args.t_end)
    truth = outputs[1e-7]
    reference, estimate = extrapolated(outputs)
    for study in (1, 2):
        path = default_runs_file(study, args.t_end)  # the cut widths, where saved
        bands = None
        if path.exists():
            data = np.load(path)
            bands = {n: (data[f"{n}_lower"], data[f"{n}_upper"]) for n in OUTPUTS}
        figures[f"study{study}"] = {
            "scale": "cut width" if bands is not None else "peak",
            "extrapolated": errors(reference, truth, bands),
            "run_1e-6": errors(outputs[1e-6], truth, bands),
            "run_1e-5": errors(outputs[1e-5], truth, bands),
            "extrapolated_slope_0.82": errors(extrapolated(outputs, 0.82)[0], truth, bands),
            "extrapolated_slope_1.0": errors(extrapolated(outputs, 1.0)[0], truth, bands),
            "estimate": errors(
                {n: truth[n] + estimate[n] for n in OUTPUTS}, truth, bands
            ),  # the estimated error, on the same scale
        }
    figures["order"] = REFERENCE_ORDER
    figures["steps"] = {f"{r:g}": steps[r] for r in RTOLS}
    figures["wall_s"] = {
        **{f"run_{r:g}": round(seconds[r], 2) for r in RTOLS},
        "pair_block_1e-4_1e-5": round(seconds["pair_block"], 2),
    }
    figures["load_average_end"] = load_average()
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
