"""An integrator's tolerance and how a check tightens it: one object, one default.

A step-size controller holds its tolerances (cf. diffrax's ``PIDController``); so
does :class:`Tolerance`, together with how much tighter the runs that check a
result are: the study's check of its time integration
(:mod:`fuzzymbs.study.integration_check`), the pilot that chooses a tolerance for
the cut widths, and the reference runs of the brake's shared steps
(:mod:`fuzzymbs.mbs.shared_steps`) divide the tolerance by ``tightening``; a
fixed-step integrator's check (RK4: the brake's ``integrator="rk4"``, the gears'
dynamic mode) divides its step by ``step_division``.

:data:`DEFAULT_TOLERANCE` is the one default of ROS34PW2 (the brake's integrator,
:func:`fuzzymbs.mbs.integrate.simulate`): rtol 1e-2 and atol 1e-5 rtol, backed by
the convergence measurements of docs/brake.md ("Accuracy of the time integration",
"Bands above the numerical noise"). The mechanisms' defaults are tolerance objects
too (:data:`fuzzymbs.mbs.mechanism_model.ENGINE_TOLERANCE`, the slider-crank's
``TOLERANCE``); the study reads a model's ``tolerance`` where it has one, else
this default's tightening.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError

__all__ = ["ATOL_PER_RTOL", "DEFAULT_TOLERANCE", "Tolerance", "tolerance_of"]

#: atol of a tolerance that gives none: this fraction of rtol (positions in m, velocities
#: in m/s; 1e-4 rtol left the brake caliper's 0.7 nm signal 14 % off, docs/brake.md)
ATOL_PER_RTOL = 1e-5


@dataclass(frozen=True)
class Tolerance:
    """The tolerances of an error-controlled integrator and the tightening of its checks.

    A step is accepted when the RMS over the state of ``error / (atol + rtol |x|)`` is at
    most 1.

    Parameters
    ----------
    rtol : float or (B,) array
        Relative tolerance, in (0, 1); one per sample runs the samples of one batch at
        different tolerances (:func:`fuzzymbs.mbs.integrate.simulate`).
    atol : float, (B,) array or None
        Absolute tolerance (> 0); None: :data:`ATOL_PER_RTOL` times rtol, so that it
        scales with rtol when the tolerance is tightened.
    tightening : float
        A check or reference run divides rtol and atol by this (> 1): with an
        error-controlled integrator the global error falls about in proportion, so the
        difference to the tighter run estimates the error (default 10).
    step_division : int
        A fixed-step integrator's check run divides its step by this (>= 2; RK4's error
        falls 16-fold at half the step; default 2).
    """

    rtol: float | NDArray[np.float64]
    atol: float | NDArray[np.float64] | None = None
    tightening: float = 10.0
    step_division: int = 2

    def __post_init__(self) -> None:
        rtol = np.atleast_1d(np.asarray(self.rtol, dtype=float))
        if rtol.ndim != 1 or not (np.all(np.isfinite(rtol)) and np.all((rtol > 0) & (rtol < 1))):
            raise InvalidParameterError(f"rtol must be in (0, 1), got {self.rtol!r}")
        if self.atol is not None:
            atol = np.atleast_1d(np.asarray(self.atol, dtype=float))
            if atol.ndim != 1 or not (np.all(np.isfinite(atol)) and np.all(atol > 0)):
                raise InvalidParameterError(f"atol must be > 0, got {self.atol!r}")
        if not (np.isfinite(self.tightening) and self.tightening > 1):
            raise InvalidParameterError(f"tightening must be > 1, got {self.tightening!r}")
        if isinstance(self.step_division, bool) or not (
            isinstance(self.step_division, int | np.integer) and self.step_division >= 2
        ):
            raise InvalidParameterError(
                f"step_division must be a whole number >= 2, got {self.step_division!r}"
            )

    def tightened(self, factor: float | None = None) -> Tolerance:
        """rtol and atol divided by ``factor`` (default :attr:`tightening`); an atol of
        None stays a fraction of rtol."""
        factor = self.tightening if factor is None else factor
        if not (np.isfinite(factor) and factor > 0):
            raise InvalidParameterError(f"factor must be > 0, got {factor!r}")
        atol = None if self.atol is None else self.atol / factor
        return dataclasses.replace(self, rtol=self.rtol / factor, atol=atol)

    def with_values(self, rtol: Any = None, atol: Any = None) -> Tolerance:
        """This tolerance with ``rtol`` and ``atol`` replaced where given (not None)."""
        pairs = (("rtol", rtol), ("atol", atol))
        given = {name: value for name, value in pairs if value is not None}
        return dataclasses.replace(self, **given) if given else self

    def arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(rtol, atol)`` as 1-D arrays (one value, or one per sample), atol filled in
        from rtol where it is None: what the kernel takes."""
        rtol = np.atleast_1d(np.asarray(self.rtol, dtype=float))
        if self.atol is None:
            return rtol, ATOL_PER_RTOL * rtol
        return rtol, np.atleast_1d(np.asarray(self.atol, dtype=float))


#: ROS34PW2's tolerance unless a model or a call gives another: rtol 1e-2, atol 1e-5 rtol;
#: checks ten times tighter (RK4: half the step)
DEFAULT_TOLERANCE = Tolerance(rtol=1e-2)


def tolerance_of(model: Any) -> Tolerance:
    """A model's :class:`Tolerance` (its ``tolerance`` attribute), else
    :data:`DEFAULT_TOLERANCE` (a model that only offers ``tightened``)."""
    tolerance = getattr(model, "tolerance", None)
    return tolerance if isinstance(tolerance, Tolerance) else DEFAULT_TOLERANCE
