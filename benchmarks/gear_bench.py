"""Gear STE study (49 runs, full alpha-bound grid) against per-sample Python loops.

fuzzymbs: ``Study("gear-pair", ..., method="grid", levels=3)`` -- the inputs of
the demo ``gear-ste/01-ste-adaptive.toml`` (z 20/40, 100 mesh positions, k_t
+-20 %, k_con +-30 %) on the full alpha-bound grid: one compiled, sample-parallel
call for all 49 samples, then the retransformation.

Baselines, one sample at a time:

* ``python_loop`` (the headline): the same MUBOCO-PR equations and Newton
  solver (the kernels' own source, Numba decorators removed, see
  :mod:`interpreted`) run by CPython, in a Python loop over the samples. This is
  what a user gets who writes the model in plain Python and loops.
* ``compiled_b1_loop``: the compiled model called with a batch of one sample in
  a Python loop -- what is left of the speed-up when the per-sample code is
  already compiled (only batching and the second core remain).

Both baselines count only model evaluations (no retransformation), which
favours them slightly.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from bench_common import best_time, log

from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.study.study import Study

MODAL_TOOTH_STIFFNESS = 14732.9  # N m/rad (demo gear-ste)
MODAL_CONTACT_STIFFNESS = 8.82418e8  # N/m
POSITIONS = 100


def gear_study(positions: int = POSITIONS) -> Study:
    """The 49-run STE study of the gear-ste demo (7 x 7 alpha-bound grid)."""
    kt, kc = MODAL_TOOTH_STIFFNESS, MODAL_CONTACT_STIFFNESS
    return Study(
        "gear-pair",
        {
            "tooth_stiffness": Triangular(0.8 * kt, kt, 1.2 * kt),
            "contact_stiffness": Triangular(0.7 * kc, kc, 1.3 * kc),
        },
        method="grid",
        levels=3,
        outputs=["ste"],
        model_options={"torque": 100.0, "positions": positions},
        name="gear-ste-bench",
    )


def _solver_args(model: Any, samples: dict[str, np.ndarray]) -> tuple:
    cols = model.stiffness_columns(samples)
    return (
        model.geometry,
        model.positions,
        model.pairs,
        cols["torque"],
        cols["contact_stiffness"],
        model.contact_exponent,
        cols["pinion_tooth_stiffness"],
        cols["wheel_tooth_stiffness"],
    )


def interpreted_ste(model: Any, samples: dict[str, np.ndarray], solver: Any) -> np.ndarray:
    """STE (B, P) [m] of each sample, one interpreted solver call per sample."""
    count = len(next(iter(samples.values())))
    rows = []
    for i in range(count):
        one = {name: values[i : i + 1] for name, values in samples.items()}
        rows.append(solver.solve_static_batch(*_solver_args(model, one))[0][0])
    return np.array(rows)


def run(quick: bool = False) -> dict[str, Any]:
    """Time the study and the baselines; return the figures (seconds, ratios, agreement)."""
    from interpreted import interpreted_gear_solver

    study = gear_study()
    runs = len(study.plan)
    samples = study.columns(0, runs)
    model = study.model
    log(f"gear: {runs} runs, {POSITIONS} positions; warm-up (compile or load cache)")
    first = study.run(progress=False)
    assert not first.failed.any(), "gear benchmark study has failed samples"

    repeats = 3 if quick else 5
    cpu_start = time.process_time()
    study_seconds = best_time(lambda: study.run(progress=False), repeat=repeats)
    study_cpu = (time.process_time() - cpu_start) / repeats  # all threads, per run
    model_seconds = best_time(lambda: model(samples), repeat=3 if quick else 5)
    batched = model(samples)["ste"]

    # compiled model, batch of one, Python loop over all samples
    def b1_loop() -> None:
        for i in range(runs):
            model({name: values[i : i + 1] for name, values in samples.items()})

    b1_seconds = best_time(b1_loop, repeat=2 if quick else 3)

    # interpreted solver, one sample at a time: a subset in quick mode (per-sample cost)
    solver = interpreted_gear_solver()
    subset = 2 if quick else runs
    picks = np.linspace(0, runs - 1, subset).round().astype(int)
    sub = {name: values[picks] for name, values in samples.items()}
    start = time.perf_counter()
    ste_python = interpreted_ste(model, sub, solver)
    python_per_sample = (time.perf_counter() - start) / subset
    agreement = float(np.max(np.abs(ste_python - batched[picks])))
    scale = float(np.max(np.abs(batched)))

    python_loop_seconds = python_per_sample * runs
    log(
        f"gear: study {study_seconds:.3f} s (model {model_seconds:.3f} s), "
        f"python loop {python_loop_seconds:.2f} s, compiled B=1 loop {b1_seconds:.3f} s"
    )
    return {
        "gear_runs": runs,
        "gear_positions": POSITIONS,
        "gear_study_seconds": study_seconds,
        "gear_model_seconds": model_seconds,
        "gear_study_cpu_seconds": study_cpu,
        "gear_python_loop_seconds": python_loop_seconds,
        "gear_python_loop_samples_timed": subset,
        "gear_python_loop_seconds_per_sample": python_per_sample,
        "gear_compiled_b1_loop_seconds": b1_seconds,
        "gear_speedup_vs_python_loop": python_loop_seconds / study_seconds,
        "gear_speedup_vs_compiled_b1_loop": b1_seconds / study_seconds,
        "gear_python_loop_max_abs_diff_m": agreement,
        "gear_ste_max_abs_m": scale,
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(quick=True)))
