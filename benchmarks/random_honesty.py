"""The adaptive method's certificate on random functions it was never tuned on.

The closed-form cases of docs/fuzzy.md (bump3, ringing3, valley4, the resonances) are
the cases the method's rules were found on; a certificate that holds only there would
not be one. This script draws smooth random models instead (``random_case``: seeded
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

    python benchmarks/random_honesty.py [--seeds S] [--dimensions 2 3 4]
        [--elements 1 21] [--gradients both|true|false] [--tolerance T]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.adaptive import AdaptiveTransformation
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import HardCase
from fuzzymbs.models.closed_form.resonance import polished_truth

LEVELS = np.linspace(0.0, 1.0, 6)
BUDGET = 8000
SEARCH_POINTS = 20_000
#: Gaussian bumps per model and the range of their widths per coordinate (unit cube
#: [-1, 1]^n: 0.25 is an eighth of the box)
BUMPS, WIDTHS = 3, (0.25, 0.8)
#: points per axis of the dense truth grid by dimension (then polished)
TRUTH_GRID = {1: 2001, 2: 201, 3: 61, 4: 25}
#: the signal's time points in [0, 1]
SIGNAL_TIME = np.linspace(0.0, 1.0, 21)


def random_case(seed: int, dimension: int, elements: int) -> HardCase:
    """A seeded smooth random model over ``dimension`` fuzzy parameters, ``elements``
    outputs (1: a scalar ``z``; more: a signal ``y`` over :data:`SIGNAL_TIME`), with its
    analytic gradient.

    In unit coordinates ``u_i = (x_i - m_i) / h_i`` of the support box (parameter i is
    ``TFN(m_i - h_i, m_i, m_i + h_i)``, ``m_i = i + 1``, ``h_i = 0.1 m_i``)::

        f_e(u) = sum_k a_ke exp(-sum_i ((u_i - c_ki) / s_ki)^2 / 2) + b_e . u
                 + r_e sin(w . u + p_e)

    with centres ``c`` in [-1.3, 1.3] (some outside the box: slopes without a peak),
    widths ``s`` in :data:`WIDTHS`, amplitudes ``a`` of order one (for a signal
    ``alpha_k cos(nu_k t_e + psi_k)``), a trend ``b`` and a ridge of amplitude 0.3 whose
    oblique wave vector ``w`` has about 1.5 radians per unit along each axis.
    """
    rng = np.random.default_rng([seed, dimension, elements])
    centres = rng.uniform(-1.3, 1.3, (BUMPS, dimension))
    widths = rng.uniform(*WIDTHS, (BUMPS, dimension))
    if elements == 1:
        amplitudes = rng.normal(0.0, 1.0, (BUMPS, 1))
        trend = rng.normal(0.0, 0.3, (1, dimension))
        ridge = np.full(1, 0.3)
        phase = rng.uniform(0.0, 2.0 * np.pi, 1)
    else:
        t = SIGNAL_TIME[:elements]
        swing = rng.uniform(2.0, 12.0, BUMPS)
        shift = rng.uniform(0.0, 2.0 * np.pi, BUMPS)
        amplitudes = rng.normal(0.0, 1.0, BUMPS)[:, None] * np.cos(
            swing[:, None] * t[None, :] + shift[:, None]
        )
        trend = rng.normal(0.0, 0.3, dimension)[None, :] * np.cos(3.0 * t)[:, None]
        ridge = 0.3 * np.ones(elements)
        phase = rng.uniform(0.0, 2.0 * np.pi) + 4.0 * t
    wave = rng.normal(0.0, 1.5, dimension)
    modal = np.arange(1.0, dimension + 1.0)
    half = 0.1 * modal
    names = [f"x{i + 1}" for i in range(dimension)]

    def evaluate(samples: Mapping[str, NDArray[np.float64]], gradient: bool):
        u = np.stack(
            [
                (np.asarray(samples[n], dtype=float) - m) / h
                for n, m, h in zip(names, modal, half, strict=True)
            ],
            axis=1,
        )  # (B, n)
        offset = (u[:, None, :] - centres[None, :, :]) / widths[None, :, :]  # (B, K, n)
        bump = np.exp(-0.5 * np.sum(offset**2, axis=2))  # (B, K)
        angle = (u @ wave)[:, None] + phase[None, :]  # (B, E)
        value = bump @ amplitudes + u @ trend.T + ridge[None, :] * np.sin(angle)
        key = "z" if elements == 1 else "y"
        if not gradient:
            return {key: value[:, 0] if elements == 1 else value}
        # d/du_i, then d/dx_i = d/du_i / h_i
        slope_bump = -(offset / widths[None, :, :]) * bump[:, :, None]  # (B, K, n)
        slope = np.einsum("bkn,ke->ben", slope_bump, amplitudes)
        slope = slope + trend[None, :, :] + (ridge[None, :] * np.cos(angle))[:, :, None] * wave
        slope = slope / half
        if elements == 1:
            return {key: value[:, 0]}, {key: slope[:, 0, :]}
        return {key: value}, {key: slope}

    triangles = {n: (m - h, m, m + h) for n, m, h in zip(names, modal, half, strict=True)}
    grid = (TRUTH_GRID[dimension],) * dimension
    name = f"random{dimension}{'s' if elements == 1 else 'y'}-{seed}"
    return HardCase(
        name,
        lambda samples: evaluate(samples, False),
        triangles,
        grid,
        lambda samples: evaluate(samples, True),
    )


def run(case: HardCase, gradients: bool, tolerance: float):
    """The adaptive method's rounds on the case, with or without its gradients."""
    engine = AdaptiveTransformation(
        triangular_numbers(case.triangles), LEVELS, tolerance, BUDGET, SEARCH_POINTS
    )
    while not engine.done:
        points = engine.next_batch()
        if len(points) == 0:
            break
        samples = dict(zip(engine.names, points.T, strict=True))
        if gradients:
            assert case.gradient is not None
            engine.add(points, *case.gradient(samples))
        else:
            engine.add(points, case.model(samples))
    return engine.outcome()


def judged(outcome, truth: dict, tolerance: float) -> tuple[float, bool]:
    """The true miss (largest over the outputs, cut-width scale) and whether the result is
    honest (a miss within the tolerance + the truth's 0.1 %, or half of it reported)."""
    miss = max(band_miss(outcome.lower[k], outcome.upper[k], *truth[k]) for k in outcome.lower)
    return miss, miss <= tolerance + 0.001 or outcome.error >= 0.5 * miss


def main(arguments: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--dimensions", type=int, nargs="+", default=[2, 3, 4])
    parser.add_argument("--elements", type=int, nargs="+", default=[1, 21])
    parser.add_argument("--gradients", choices=("both", "true", "false"), default="both")
    parser.add_argument("--tolerance", type=float, default=0.01)
    args = parser.parse_args(arguments)
    paths = {"both": (False, True), "true": (True,), "false": (False,)}[args.gradients]
    rows = []
    for dimension in args.dimensions:
        for elements in args.elements:
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                case = random_case(seed, dimension, elements)
                truth = polished_truth(case, LEVELS)
                for gradients in paths:
                    start = time.process_time()
                    outcome = run(case, gradients, args.tolerance)
                    seconds = time.process_time() - start
                    miss, honest = judged(outcome, truth, args.tolerance)
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
    print(
        f"{len(rows)} runs of the method: {converged} converged, {within} within the "
        f"tolerance, {honest} honest, largest miss {100 * largest:.2f} %"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
