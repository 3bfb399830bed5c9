"""Is a fixed RK4 step stable for the linearised system? The step limit from its eigenvalues.

Classic RK4 applied to ``x' = lambda x`` multiplies x per step by the
polynomial ``R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24``, ``z = lambda dt``. A
decaying or undamped mode is integrated stably only while ``|R(z)| <= 1``: on
the negative real axis for ``dt |lambda| <= 2.7853``, on the imaginary axis for
``dt |lambda| <= 2 sqrt(2) = 2.8284`` (Hairer & Wanner, *Solving Ordinary
Differential Equations II*, Sec. IV.2; Butcher, *Numerical Methods for
Ordinary Differential Equations*, Sec. 238). Outside, the explicit step
amplifies the mode: a linear system blows up, and a nonlinear one may instead
settle in a bounded numerical chatter (the disc brake at the paper's step,
``docs/brake.md``, "Accuracy of the time integration").

:func:`rk4_step_limit` gives the largest step for which every decaying or
undamped eigenvalue stays in the region; :func:`rk4_step_stability` does so
for a system linearised about its steady sliding state
(:func:`fuzzymbs.mbs.linearize.eigenanalysis`), sample by sample, and checks
a given step. Eigenvalues of growing modes (``Re lambda > tolerance
|lambda|``, a physical instability) have no step limit and are reported
apart. Stability is necessary, not sufficient: a step inside the region can
still be inaccurate.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.linearize import Eigenanalysis, eigenanalysis
from fuzzymbs.mbs.system import CompiledSystem, System

__all__ = ["StepStability", "rk4_amplification", "rk4_step_limit", "rk4_step_stability"]

# |R(t e^{i phi})| is scanned on t in (0, _T_SCAN] (the region lies inside |z| < 2.9)
_T_SCAN = 3.0
_SCAN_POINTS = 3001


def rk4_amplification(z: ArrayLike) -> NDArray[np.float64]:
    """``|R(z)|``, RK4's amplification of the mode ``x' = lambda x`` per step, ``z = lambda dt``."""
    z = np.asarray(z, dtype=complex)
    return np.abs(1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0))))


def _ray_limit(direction: complex) -> float:
    """Smallest t > 0 with ``|R(t direction)| = 1`` leaving the region (``|direction| = 1``).

    Scans for the first point outside, then refines the crossing with Brent's method.
    """
    t = np.linspace(0.0, _T_SCAN, _SCAN_POINTS)[1:]
    excess = rk4_amplification(t * direction) - 1.0
    outside = np.flatnonzero(excess > 1e-13)
    if outside.size == 0:
        return np.inf
    first = outside[0]
    if first == 0:  # leaves at once: a growing direction (handled by the caller)
        return 0.0
    return scipy.optimize.brentq(
        lambda s: rk4_amplification(s * direction) - 1.0, t[first - 1], t[first], xtol=1e-15
    )


def rk4_step_limit(
    eigenvalues: ArrayLike, tolerance: float = 1e-6
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """Largest RK4 step [s] for which no decaying or undamped mode is amplified.

    Parameters
    ----------
    eigenvalues : array_like, complex, (..., m)
        Eigenvalues [1/s] of the linearised system (last axis: the modes).
    tolerance : float
        ``Re lambda > tolerance |lambda|``: a growing mode, excluded (no step
        stabilises it); ``|Re lambda| <= tolerance |lambda|``: undamped, taken
        on the imaginary axis (round-off of the eigensolver is no damping).

    Returns
    -------
    max_dt : ndarray (...)
        The step limit per sample (inf if no mode limits it; NaN if an
        eigenvalue is NaN, e.g. a failed linearisation).
    limiting : ndarray (...), complex
        The eigenvalue that sets the limit (NaN where none does).
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    if lam.ndim == 0:
        raise InvalidParameterError("eigenvalues must have at least one axis (the modes)")
    magnitude = np.abs(lam)
    undamped = np.abs(lam.real) <= tolerance * magnitude
    limits = np.full(lam.shape, np.inf)
    considered = (magnitude > 0) & ~(lam.real > tolerance * magnitude) & np.isfinite(lam)
    directions = np.where(
        undamped, 1j * np.sign(lam.imag), lam / np.where(magnitude > 0, magnitude, 1)
    )
    cache: dict[complex, float] = {}
    for index in zip(*np.nonzero(considered), strict=True):
        direction = complex(directions[index])
        key = complex(round(direction.real, 14), round(direction.imag, 14))
        if key not in cache:
            cache[key] = _ray_limit(direction)
        limits[index] = cache[key] / magnitude[index]
    which = np.argmin(limits, axis=-1)
    max_dt = np.take_along_axis(limits, which[..., None], axis=-1)[..., 0]
    limiting = np.take_along_axis(lam, which[..., None], axis=-1)[..., 0]
    limiting = np.where(np.isfinite(max_dt), limiting, np.nan + 0j)
    failed = ~np.isfinite(lam).all(axis=-1)
    max_dt = np.where(failed, np.nan, max_dt)
    limiting = np.where(failed, np.nan + 0j, limiting)
    return max_dt, limiting


@dataclass
class StepStability:
    """RK4 step check of a linearised system, per sample.

    Attributes
    ----------
    dt : float
        The step checked [s].
    max_stable_dt : (B,) largest stable RK4 step [s] (NaN: linearisation failed).
    limiting_eigenvalue : (B,) complex, the eigenvalue [1/s] that sets it.
    amplification : (B, 2n) ``|R(lambda dt)|`` of every eigenvalue.
    amplified : (B, 2n) bool, decaying or undamped modes with ``|R(lambda dt)| > 1``:
        the modes the step integrates unstably.
    growing : (B, 2n) bool, physically growing modes (no step limit; see
        :attr:`fuzzymbs.mbs.linearize.Eigenanalysis.unstable`).
    analysis : the underlying :class:`~fuzzymbs.mbs.linearize.Eigenanalysis`.
    """

    dt: float
    max_stable_dt: NDArray[np.float64]
    limiting_eigenvalue: NDArray[np.complex128]
    amplification: NDArray[np.float64]
    amplified: NDArray[np.bool_]
    growing: NDArray[np.bool_]
    analysis: Eigenanalysis

    @property
    def stable(self) -> NDArray[np.bool_]:
        """(B,) True when ``dt`` is within the step limit (False for failed samples)."""
        with np.errstate(invalid="ignore"):
            return self.dt <= self.max_stable_dt


def rk4_step_stability(
    system: System | CompiledSystem,
    samples: Mapping[str, NDArray[np.float64]] | None = None,
    *,
    dt: float,
    analysis: Eigenanalysis | None = None,
    tolerance: float = 1e-6,
) -> StepStability:
    """Check a fixed RK4 step against the eigenvalues of the system linearised at steady sliding.

    Parameters
    ----------
    system : System or CompiledSystem
    samples : {name: (B,)}, optional
        Parameter values (missing names take their defaults).
    dt : float
        The RK4 step to check [s].
    analysis : Eigenanalysis, optional
        A linearisation already computed for these samples (else computed here).
    tolerance : float
        As in :func:`rk4_step_limit`.

    Examples
    --------
    For the disc brake at the paper's step (see ``docs/brake.md``)::

        check = rk4_step_stability(DiscBrake().compiled, dt=1e-6)
        check.stable               # [False]
        check.max_stable_dt        # about 3.1e-7 s
        check.limiting_eigenvalue  # about -8.9e6 1/s: a friction-damped pad mode
    """
    if not (np.isfinite(dt) and dt > 0):
        raise InvalidParameterError(f"time step dt must be > 0 s, got {dt!r}")
    if analysis is None:
        analysis = eigenanalysis(system, samples, tolerance=tolerance)
    lam = analysis.eigenvalues
    max_dt, limiting = rk4_step_limit(lam, tolerance)
    magnitude = np.abs(lam)
    growing = lam.real > tolerance * magnitude
    amplification = rk4_amplification(lam * dt)
    undamped = np.abs(lam.real) <= tolerance * magnitude
    on_axis = rk4_amplification(1j * lam.imag * dt)  # undamped: judged on the imaginary axis
    judged = np.where(undamped, on_axis, amplification)
    amplified = (judged > 1.0 + 1e-12) & ~growing & np.isfinite(lam)
    return StepStability(
        dt=float(dt),
        max_stable_dt=max_dt,
        limiting_eigenvalue=limiting,
        amplification=amplification,
        amplified=amplified,
        growing=growing,
        analysis=analysis,
    )
