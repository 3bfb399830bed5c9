"""Every time-integrated study checks its own time integration.

A model that integrates in time offers ``tightened()``: the same model with a
tenfold tighter tolerance (fixed-step RK4: half the step); a model with
modes that do not integrate in time returns None there. After the study's
runs, the runner re-integrates the modal sample (all parameters at their
modal values, a run of every transformation-method plan) with it and reports
the largest deviation over the study's outputs, each relative to its own peak:

    error = max over outputs o of max_t |y_o(t) - y_o,tight(t)| / max_t |y_o,tight(t)|

With an error-controlled integrator the global error falls about in
proportion to the tolerance, so this difference estimates the study's own
error (it is measured, not assumed: docs/brake.md, "Accuracy of the time
integration"). The result goes into result.nc (attribute
``time_integration_error``) and summary.txt; above the study's tolerance
(``integration_tolerance``, default 0.5 %) the runner warns. Models without
``tightened`` (no time integration) are left out.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: default largest time-integration error a study accepts without a warning (of the peak)
DEFAULT_TOLERANCE = 0.005


class TimeIntegrationWarning(UserWarning):
    """A study's time-integration error exceeds its tolerance (or could not be checked)."""


@dataclass(frozen=True)
class IntegrationCheck:
    """Outcome of :func:`check_time_integration`.

    Attributes
    ----------
    error : largest deviation relative to the output's peak (NaN: not checked, see note).
    tolerance : the study's tolerance.
    method : the model's time integration in words (``model.time_integration``).
    note : why the check failed, or "".
    """

    error: float
    tolerance: float
    method: str
    note: str = ""

    def to_attrs(self) -> dict[str, Any]:
        """Dataset attributes (NetCDF-safe: numbers and strings)."""
        return {
            "time_integration_error": float(self.error),
            "time_integration_tolerance": float(self.tolerance),
            "time_integration": self.method,
            "time_integration_note": self.note,
        }


def peak_relative_deviation(coarse: np.ndarray, fine: np.ndarray) -> float:
    """``max |coarse - fine| / max |fine|`` (NaN if fine is zero or not finite)."""
    peak = float(np.max(np.abs(fine))) if fine.size else 0.0
    if not np.isfinite(peak) or peak == 0.0:
        return float("nan")
    return float(np.max(np.abs(coarse - fine)) / peak)


def check_time_integration(
    model: Any,
    sample: Mapping[str, np.ndarray],
    outputs: Mapping[str, np.ndarray],
    names: Sequence[str],
    tolerance: float = DEFAULT_TOLERANCE,
    sample_failed: bool = False,
) -> IntegrationCheck | None:
    """Re-run one sample with ``model.tightened()`` and compare with its study outputs.

    Parameters
    ----------
    model : the study's model; without a callable ``tightened`` the check is skipped.
    sample : ``{name: (1,)}`` parameter columns of the sample (the modal one).
    outputs : ``{name: array}`` that sample's outputs as the study computed them.
    names : the study's outputs to compare.
    tolerance : the study's largest acceptable error (relative to each output's peak).
    sample_failed : the sample failed in the study: nothing to compare with, so it is
        not re-run and the check is reported as not made.

    Returns
    -------
    IntegrationCheck or None
        None for models that do not integrate in time (no ``tightened``, or it
        returns None). Warns
        (:class:`TimeIntegrationWarning`) when the error exceeds ``tolerance`` or
        cannot be computed.
    """
    tightened: Callable[[], Any] | None = getattr(model, "tightened", None)
    tight = tightened() if callable(tightened) else None
    if tight is None:
        return None
    method = str(getattr(model, "time_integration", ""))
    note = ""
    error = float("nan")
    check = {} if sample_failed else tight(dict(sample))
    if sample_failed:
        note = "the modal sample failed, so it could not be re-run"
    elif np.asarray(check.get("failed", [False])).any():
        reason = np.asarray(check.get("failure_reason", [""]))[0]
        note = f"the tightened re-run of the modal sample failed ({reason})"
    else:
        deviations = [
            peak_relative_deviation(
                np.asarray(outputs[name], dtype=float), np.asarray(check[name], dtype=float)[0]
            )
            for name in names
        ]
        finite = [d for d in deviations if np.isfinite(d)]
        if finite:
            error = max(finite)
        else:
            note = "no output of the modal sample is finite and non-zero"
    result = IntegrationCheck(error, tolerance, method, note)
    if note:
        warnings.warn(f"time integration not checked: {note}", TimeIntegrationWarning, stacklevel=3)
    elif error > tolerance:
        warnings.warn(
            f"time-integration error {error:.3g} of the peak exceeds the study's tolerance "
            f"{tolerance:g} ({method}): the modal sample re-integrated with a tenfold tighter "
            "tolerance (RK4: half the step) differs by that much. Tighten the model's rtol "
            "(or dt), or raise integration_tolerance.",
            TimeIntegrationWarning,
            stacklevel=3,
        )
    return result
