"""Complex-eigenvalue (flutter) stability of the linearised brake, sample by sample.

For every sample the brake is linearised about its steady sliding state
(:func:`fuzzymbs.mbs.linearize.eigenanalysis`: Newton equilibrium with the disc
turning under the pads, central-difference Jacobian, ``eig``). Eigenvalues
``lambda = sigma + i omega_d`` with ``sigma > 0`` are friction-induced
(mode-coupling) instabilities. Of each conjugate pair the member with
``omega_d >= 0`` is kept and the pairs are ranked by real part, so
``real_parts[:, 0]`` is the least stable mode of every sample.

The ranked real parts and frequencies are plain batched outputs: a study
retransforms them with the same plan as the time signals, giving fuzzy real
parts and frequencies of the least stable modes. Ranking (instead of tracking a
mode by its shape) is what the fuzzy bounds need: "the largest real part" is a
well-defined function of the parameters even when two modes swap places.

Linear analysis describes small perturbations of steady sliding. The time
integration of the study starts from rest with a 400 kN step load: a large
transient in which the friction direction at the contact points swings, so a
mode that grows from an infinitesimal perturbation may not grow from there.
:func:`growth_rate` measures the growth of a simulated signal for the comparison
(docs/brake.md shows both).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.linearize import eigenanalysis
from fuzzymbs.mbs.step_stability import rk4_step_limit
from fuzzymbs.mbs.system import CompiledSystem
from fuzzymbs.models.brake.geometry import BrakeDesign, build_bodies
from fuzzymbs.models.brake.model import brake_system, check_samples

__all__ = ["BrakeStability", "StabilityResult", "growth_rate", "stability_analysis"]


@dataclass
class StabilityResult:
    """Least stable modes of a batch of samples.

    Attributes
    ----------
    real_parts : (B, k) [1/s]
        Real parts sigma of the k least stable eigenvalue pairs, descending.
    frequencies : (B, k) [Hz]
        Their damped frequencies ``omega_d / (2 pi)``.
    damping_ratios : (B, k) [-]
        ``-sigma / |lambda|``.
    unstable_count : (B,) int
        Number of eigenvalue pairs with ``sigma > tolerance |lambda|``.
    converged : (B,) bool
        Whether the Newton steady state converged (False: the sample's results are NaN).
    pad_real_part, pad_frequency : (B,) [1/s], [Hz]
        Real part and frequency of the least stable mode *the pads take part in*:
        the larger pad-translation component of its eigenvector is at least
        ``pad_participation`` (coordinate part scaled to max-norm 1). Below the
        onset of instability the least stable mode overall is a nearly undamped
        caliper or disc mode that the pad signals hardly show.
    rk4_max_step : (B,) [s]
        Largest classic-RK4 step that integrates every decaying or undamped mode
        stably (:func:`fuzzymbs.mbs.step_stability.rk4_step_limit`): the time
        integration's step should stay below it.
    """

    real_parts: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    damping_ratios: NDArray[np.float64]
    unstable_count: NDArray[np.int64]
    converged: NDArray[np.bool_]
    pad_real_part: NDArray[np.float64]
    pad_frequency: NDArray[np.float64]
    rk4_max_step: NDArray[np.float64]

    @property
    def max_real_part(self) -> NDArray[np.float64]:
        """(B,) real part of the least stable mode [1/s]."""
        return self.real_parts[:, 0]


def stability_analysis(
    compiled: CompiledSystem,
    samples: Mapping[str, Any] | None = None,
    *,
    n_modes: int = 6,
    tolerance: float = 1e-6,
    pad_participation: float = 0.1,
) -> StabilityResult:
    """Complex eigenvalues of the brake linearised about steady sliding, for a batch.

    Parameters
    ----------
    compiled : CompiledSystem
        The brake (``DiscBrake(...).compiled``).
    samples : {name: (B,)}, optional
        Brake parameters (missing ones take their defaults).
    n_modes : int
        Number k of least stable eigenvalue pairs returned.
    tolerance : float
        A pair is unstable when ``sigma > tolerance |lambda|`` (round-off guard).
    pad_participation : float
        Threshold in (0, 1] of the pad-translation share that makes a mode a "pad
        mode" (see :class:`StabilityResult`).
    """
    if int(n_modes) != n_modes or n_modes < 1:
        raise InvalidParameterError(f"n_modes must be an integer >= 1, got {n_modes!r}")
    if not 0 < pad_participation <= 1:
        raise InvalidParameterError(
            f"pad_participation must lie in (0, 1], got {pad_participation!r}"
        )
    columns = check_samples(samples or {})
    analysis = eigenanalysis(compiled, columns, tolerance=tolerance)
    lam = analysis.eigenvalues
    batch = lam.shape[0]
    k = int(n_modes)
    # one member of each conjugate pair (real eigenvalues count once too)
    upper = np.where(lam.imag >= 0, lam.real, -np.inf)
    order = np.argsort(-upper, axis=1, kind="stable")[:, :k]
    chosen = np.take_along_axis(lam, order, axis=1)
    mag = np.abs(chosen)
    real = chosen.real
    freq = np.abs(chosen.imag) / (2 * np.pi)
    zeta = np.where(mag > 0, -real / np.where(mag > 0, mag, 1.0), 0.0)
    unstable = ((lam.real > tolerance * np.abs(lam)) & (lam.imag >= 0)).sum(axis=1)
    converged = analysis.steady_state.converged.copy()
    pads = [compiled.body_dofs[name].start for name in ("lower_pad", "upper_pad")]
    share = np.abs(analysis.mode_shapes[:, pads, :]).max(axis=1)  # (B, 2n)
    candidates = np.where((lam.imag >= 0) & (share >= pad_participation), lam.real, -np.inf)
    best = candidates.argmax(axis=1)[:, None]
    pad_lam = np.take_along_axis(lam, best, axis=1)[:, 0]
    found = np.isfinite(np.take_along_axis(candidates, best, axis=1)[:, 0]) & converged
    pad_real = np.where(found, pad_lam.real, np.nan)
    pad_freq = np.where(found, np.abs(pad_lam.imag) / (2 * np.pi), np.nan)
    for arr in (real, freq, zeta):
        arr[~converged] = np.nan
    if real.shape[1] < k:  # fewer pairs than requested: pad with NaN
        pad = np.full((batch, k - real.shape[1]), np.nan)
        real, freq, zeta = (np.hstack([a, pad]) for a in (real, freq, zeta))
    rk4_max_step, _ = rk4_step_limit(lam, tolerance)
    return StabilityResult(
        real, freq, zeta, unstable.astype(np.int64), converged, pad_real, pad_freq, rk4_max_step
    )


def growth_rate(
    signal: NDArray[np.float64], time: NDArray[np.float64], windows: int = 8
) -> NDArray[np.float64] | float:
    """Exponential growth rate [1/s] of the oscillation in simulated signals.

    The signal is cut into ``windows`` equal windows; the standard deviation in
    each (the oscillation amplitude about the window mean) is fitted with
    ``log(std) = a + rate * t`` by least squares. Positive: growing; negative: decaying.

    Parameters
    ----------
    signal : (B, T) or (T,)
        Simulated outputs (e.g. ``y_lpad``).
    time : (T,)
        Their times [s].
    windows : int
        Number of windows (>= 2).

    Returns
    -------
    ndarray (B,) or float
        Growth rates [1/s] (NaN where a window has zero amplitude).
    """
    y = np.atleast_2d(np.asarray(signal, dtype=float))
    t = np.asarray(time, dtype=float)
    if y.shape[1] != t.size or windows < 2 or t.size < 2 * windows:
        raise InvalidParameterError(
            f"growth_rate needs signals of {t.size} samples and 2 <= windows <= {t.size // 2}"
        )
    width = t.size // windows
    cut = y[:, : width * windows].reshape(y.shape[0], windows, width)
    amp = cut.std(axis=2)
    centres = t[: width * windows].reshape(windows, width).mean(axis=1)
    with np.errstate(divide="ignore"):
        logs = np.log(amp)
    rates = np.full(y.shape[0], np.nan)
    ok = np.isfinite(logs).all(axis=1)
    if ok.any():
        rates[ok] = np.polyfit(centres, logs[ok].T, 1)[0]
    return rates if np.ndim(signal) > 1 else float(rates[0])


class BrakeStability:
    """Batched model: least stable modes of the linearised brake per sample.

    Outputs ``max_real_part`` (B,) [1/s], ``least_stable_frequency`` (B,) [Hz],
    ``pad_max_real_part`` (B,) [1/s] and ``pad_mode_frequency`` (B,) [Hz] (least
    stable mode with pad participation, see :class:`StabilityResult`),
    ``real_parts`` and ``frequencies`` (B, k) over ``coords["mode_rank"]``,
    ``unstable_modes`` (B,), ``rk4_max_step`` (B,) [s] (largest stable RK4 step,
    see :class:`StabilityResult`) and the ``failed`` / ``failure_reason`` flags
    (Newton steady state not converged). Same parameters as :class:`DiscBrake`.

    Parameters
    ----------
    design : BrakeDesign, optional
    contact, regularization_velocity, modal_damping_ratio
        As for :class:`~fuzzymbs.models.brake.model.DiscBrake`.
    n_modes : int
        Number k of least stable pairs reported.
    pad_participation : float
        Threshold of the pad outputs ``pad_max_real_part`` / ``pad_mode_frequency``.
    """

    def __init__(
        self,
        design: BrakeDesign | None = None,
        *,
        contact: str = "two-pass",
        regularization_velocity: float = 1e-3,
        modal_damping_ratio: float = 0.0,
        n_modes: int = 6,
        pad_participation: float = 0.1,
    ) -> None:
        self.design = design or BrakeDesign()
        self.pad_participation = float(pad_participation)
        bodies = build_bodies(self.design)
        system = brake_system(bodies, contact, regularization_velocity, modal_damping_ratio)
        self.compiled = system.compile()
        self.n_modes = int(n_modes)
        self.coords = {"mode_rank": np.arange(self.n_modes)}
        self.output_dims = {
            "max_real_part": (),
            "least_stable_frequency": (),
            "unstable_modes": (),
            "pad_max_real_part": (),
            "pad_mode_frequency": (),
            "rk4_max_step": (),
            "real_parts": ("mode_rank",),
            "frequencies": ("mode_rank",),
            "failed": (),
            "failure_reason": (),
        }

    def __call__(self, samples: Mapping[str, Any]) -> dict[str, NDArray]:
        result = stability_analysis(
            self.compiled, samples, n_modes=self.n_modes, pad_participation=self.pad_participation
        )
        failed = ~result.converged
        reason = np.where(failed, "steady sliding state (Newton) did not converge", "")
        return {
            "max_real_part": result.real_parts[:, 0].copy(),
            "least_stable_frequency": result.frequencies[:, 0].copy(),
            "unstable_modes": result.unstable_count.astype(float),
            "pad_max_real_part": result.pad_real_part,
            "pad_mode_frequency": result.pad_frequency,
            "rk4_max_step": result.rk4_max_step,
            "real_parts": result.real_parts,
            "frequencies": result.frequencies,
            "failed": failed,
            "failure_reason": reason.astype(str),
        }
