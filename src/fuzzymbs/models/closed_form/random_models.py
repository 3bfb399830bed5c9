"""Seeded smooth random test models: what the adaptive method was never tuned on.

The closed-form cases of :mod:`~fuzzymbs.models.closed_form.hard_cases` and
:mod:`~fuzzymbs.models.closed_form.resonance` are the ones the adaptive method's
rules were found on. :func:`random_case` draws others: sums of anisotropic Gaussian
bumps, a linear trend and an oblique ridge over 1 to 4 triangular parameters, as a
scalar or as a signal, each with its analytic gradient and a truth grid for
:func:`~fuzzymbs.models.closed_form.resonance.polished_truth`
(``benchmarks/random_honesty.py``; docs/fuzzy.md, "Models it was never tuned on").
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.models.closed_form.hard_cases import HardCase

__all__ = ["SIGNAL_TIME", "random_case"]

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
    ridge = np.full(elements, 0.3)
    if elements == 1:
        amplitudes = rng.normal(0.0, 1.0, (BUMPS, 1))
        trend = rng.normal(0.0, 0.3, (1, dimension))
        phase = rng.uniform(0.0, 2.0 * np.pi, 1)
    else:
        t = SIGNAL_TIME[:elements]
        swing = rng.uniform(2.0, 12.0, BUMPS)
        shift = rng.uniform(0.0, 2.0 * np.pi, BUMPS)
        amplitudes = rng.normal(0.0, 1.0, BUMPS)[:, None] * np.cos(
            swing[:, None] * t[None, :] + shift[:, None]
        )
        trend = rng.normal(0.0, 0.3, dimension)[None, :] * np.cos(3.0 * t)[:, None]
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
        # a scalar model's outputs (B,) and gradients (B, n); a signal's (B, E), (B, E, n)
        key, element = ("z", 0) if elements == 1 else ("y", slice(None))
        if not gradient:
            return {key: value[:, element]}
        # d/du_i, then d/dx_i = d/du_i / h_i
        slope_bump = -(offset / widths[None, :, :]) * bump[:, :, None]  # (B, K, n)
        slope = np.einsum("bkn,ke->ben", slope_bump, amplitudes)
        slope = slope + trend[None, :, :] + (ridge[None, :] * np.cos(angle))[:, :, None] * wave
        slope = slope / half
        return {key: value[:, element]}, {key: slope[:, element]}

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
