"""ROS34PW2's Jacobian age on a brake study's shared steps: CPU and band error.

    python benchmarks/jacobian_age.py [--t-end 1e-2] [--rtol 1e-3] [--ages 5 7 10 15 20 30]

Prints one JSON line. The workload of brake study 1's plan: the modal sample's
logging run at ``--rtol`` (its steps become the shared sequence) and the 8 corners
of the study's support box (k and k_c +-10 %, F_n +-1 %) on that sequence, as
deviations from the modal sample on the same steps (what a study's bands are made
of; the reference that corrects every sample alike drops out, so it is not run).
The Jacobian age (accepted steps a Jacobian and f_t are used for,
:data:`fuzzymbs.mbs.kernels.rosenbrock_methods.JACOBIAN_AGE`) is a runtime coefficient of
the kernel, so every age runs in this process without compiling again.

Truth: the 9 samples on their own steps at rtol 1e-6, their deviations from the
modal one (cached in ``benchmarks/.cache/``). Error: the largest over the corners,
the outputs y_lpad, y_upad, y_cali and time of ``|dev - dev_truth|`` over the band
scale ``max(w, 0.1 max w)``, ``w`` the truth's corner spread (the cut-width scale
of docs/fuzzy.md). CPU: process time of the logging run and of the corners, the
smaller of two rounds (the ages alternate).
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np
from bench_common import BENCH_DIR, load_average

import fuzzymbs.mbs.integrate as integrate
from fuzzymbs.background import Background
from fuzzymbs.mbs.kernels import rosenbrock_methods
from fuzzymbs.mbs.shared_steps import share_steps
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

MODAL = {"pad_spring_stiffness": 200e3, "caliper_spring_stiffness": 1e3, "nodal_force": 16e3}
SPREADS = {"pad_spring_stiffness": 0.1, "caliper_spring_stiffness": 0.1, "nodal_force": 0.01}
OUTPUTS = ("y_lpad", "y_upad", "y_cali")
AGES = (5, 7, 10, 15, 20, 30)
CACHE = BENCH_DIR / ".cache"


def corners() -> dict[str, np.ndarray]:
    """The 8 corners of study 1's support box, one column per parameter."""
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=len(MODAL))))
    return {name: MODAL[name] * (1.0 + SPREADS[name] * signs[:, i]) for i, name in enumerate(MODAL)}


def truth(simulation, columns: dict, t_end: float, cache: Path) -> dict[str, np.ndarray]:
    """The corners' deviations from the modal sample, own steps at rtol 1e-6 (cached)."""
    path = cache / f"jacobian_age_truth_{t_end:g}.npz"
    if path.exists():
        return dict(np.load(path))
    samples = {name: np.concatenate(([MODAL[name]], columns[name])) for name in MODAL}
    runs = simulation.simulate(samples, tolerance=Tolerance(1e-6))
    if runs.failed.any():
        raise RuntimeError("a truth run failed")
    deviations = {name: runs.outputs[name][1:] - runs.outputs[name][0] for name in OUTPUTS}
    path.parent.mkdir(exist_ok=True)
    np.savez(path, **deviations)
    return deviations


def band_error(deviations: dict, exact: dict) -> float:
    """Largest ``|dev - exact|`` over the band scale of the exact corners' spread."""
    worst = 0.0
    for name in OUTPUTS:
        width = exact[name].max(axis=0) - exact[name].min(axis=0)
        scale = np.maximum(width, 0.1 * width.max())
        worst = max(worst, float(np.max(np.abs(deviations[name] - exact[name]) / scale)))
    return worst


def with_age(age: int) -> tuple:
    """ROS34PW2's kernel coefficients with the Jacobian renewed every ``age`` steps."""
    r = rosenbrock_methods
    return r.transformed(
        r.TABLEAU_A, r.TABLEAU_GAMMA, r.TABLEAU_B, r.TABLEAU_BHAT, age, embedded_order=2
    )


def measure(
    t_end: float, rtol: float, ages: tuple[int, ...], rounds: int = 2, cache: Path = CACHE
) -> dict:
    """Per age (a string key): logging and corners' CPU, the sequence's steps and the
    band error in per cent (the smallest CPU of ``rounds``)."""
    simulation = DiscBrake(t_end=t_end, record_interval=1e-5, rtol=rtol).simulation
    columns = corners()
    exact = truth(simulation, columns, t_end, cache)
    no_reference = Background(lambda: ({}, {}, {}))  # deviations need none
    default = integrate.METHODS["ros34pw2"]
    results: dict[int, dict] = {}
    try:
        for _ in range(rounds):
            for age in ages:
                integrate.METHODS["ros34pw2"] = with_age(age)
                start = time.process_time()
                shared = share_steps(simulation, MODAL, references=no_reference)
                logged = time.process_time()
                deviations = shared.deviations(columns)
                done = time.process_time()
                entry = {
                    "logging_cpu_s": round(logged - start, 3),
                    "corners_cpu_s": round(done - logged, 3),
                    "steps": len(shared.shared.sequence),
                    "band_error_percent": round(100 * band_error(deviations, exact), 4),
                }
                best = results.get(age)
                if best is None or done - start < best["logging_cpu_s"] + best["corners_cpu_s"]:
                    results[age] = entry
    finally:
        integrate.METHODS["ros34pw2"] = default
    return {str(age): results[age] for age in ages}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=1e-2)
    parser.add_argument("--rtol", type=float, default=1e-3)
    parser.add_argument("--ages", type=int, nargs="+", default=list(AGES))
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    start_load = load_average()
    ages = measure(args.t_end, args.rtol, tuple(args.ages), args.rounds)
    print(
        json.dumps(
            {
                "t_end_s": args.t_end,
                "rtol": args.rtol,
                "default_age": rosenbrock_methods.JACOBIAN_AGE,
                "ages": ages,
                "load_average": [start_load, load_average()],
            }
        )
    )


if __name__ == "__main__":
    main()
