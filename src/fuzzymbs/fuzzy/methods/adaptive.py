"""The adaptive method: rounds of points proposed until the bounds are certified.

Its points are not known in advance: each round's points follow from the
outputs of the rounds before (:class:`~fuzzymbs.fuzzy.adaptive.AdaptiveTransformation`,
the engine :meth:`Adaptive.start` makes). A plan with this method is the
variant of :class:`~fuzzymbs.fuzzy.transform.Plan` that runs in rounds
(:class:`~fuzzymbs.fuzzy.transform.RoundsPlan`); its certification is its method
check, so a study makes no validation runs for it. Its count is its run budget,
the most it runs.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.adaptive import NOISE, AdaptiveOutcome, AdaptiveTransformation
from fuzzymbs.fuzzy.methods.base import CountRequest, Method, option
from fuzzymbs.fuzzy.numbers import FuzzyNumber

__all__ = [
    "DEFAULT_ADAPTIVE_MAX_RUNS",
    "DEFAULT_ADAPTIVE_TOLERANCE",
    "Adaptive",
    "AdaptiveWarning",
    "noise_message",
]

#: certified error (on the cut-width scale) at which the adaptive method stops
DEFAULT_ADAPTIVE_TOLERANCE = 0.01
#: run budget of the adaptive method unless the caller sets one
DEFAULT_ADAPTIVE_MAX_RUNS = 2000
#: search-grid points per cut box on the surrogate unless the caller sets them
DEFAULT_ADAPTIVE_SEARCH_POINTS = 20_000
#: the model's gradients enter the rounds where the model can give them all
GRADIENTS_AUTO = "auto"
#: the certificate covers the bounds (default) or the surrogate everywhere
CERTIFY_BOUNDS = "bounds"


class AdaptiveWarning(UserWarning):
    """The adaptive method stopped before its error reached the tolerance: at its run budget,
    or because the model's own noise is larger than what refinement can remove."""


def noise_message(runs: int, noise: float, tolerance: float) -> str:
    """The one line that says the model's noise stopped the adaptive method.

    Parameters
    ----------
    runs : int
        Runs the method used.
    noise, tolerance : float
        The measured noise and ``method_tolerance``, on the cut-width scale.

    Returns
    -------
    str
        What stopped the rounds and what to do about it.
    """
    return (
        f"adaptive method stopped after {runs} runs: the model's own noise, about "
        f"{100 * noise:.3g} % of the cut width, exceeds what refinement can remove "
        f"(tolerance {100 * tolerance:.3g} %); integrate more accurately (a converged "
        "integrator or a tighter tolerance) or raise method_tolerance"
    )


@dataclass(frozen=True)
class Adaptive(Method):
    """The adaptive transformation method.

    Parameters
    ----------
    method_tolerance : float
        Certified error at which the rounds stop, on the cut-width scale
        (:func:`~fuzzymbs.fuzzy.band_scale.band_miss`); default 0.01.
    max_runs : int
        Run budget (default 2,000); at least ``2 n + 2``, the first round.
    search_points : int
        Search-grid points per cut box on the surrogate (default 20,000; at least 3^n).
    gradients : {"auto", True, False}
        Whether a study asks the model for the gradients of its outputs with respect to
        the fuzzy parameters and hands them to the surrogate
        (:mod:`fuzzymbs.fuzzy.hermite_correction`): ``"auto"`` (default) where the model
        declares every fuzzy parameter in ``model.differentiable`` and a run with them
        costs at most 1.4 runs without (``model.gradient_cost``;
        :func:`fuzzymbs.study.gradients.gradient_parameters`), ``True`` always (an
        error for a model that cannot), ``False`` never (the value-only rounds).
    certify : {"bounds", "global"}
        What the certified error covers (:class:`~fuzzymbs.fuzzy.adaptive.AdaptiveTransformation`):
        ``"bounds"`` (default) the surrogate's error where it can move a bound;
        ``"global"`` also its error everywhere it is checked, on the support's cut widths,
        with ``n`` exploration runs a round: for a model nothing is known about, at more
        runs (docs/fuzzy.md, "Models it was never tuned on").
    """

    name = "adaptive"
    summary = (
        "rounds until its certified error is below method_tolerance; the model decides "
        "the runs, at most max_runs"
    )
    supports_influence = True
    supports_streaming = False
    supports_validation = False
    runs_in_rounds = True

    method_tolerance: float = option(
        DEFAULT_ADAPTIVE_TOLERANCE,
        "certified error (of the cut width) at which the rounds stop",
        must="a positive number (e.g. 0.01 for 1 % of the cut width)",
        minimum=0.0,
    )
    max_runs: int = option(
        DEFAULT_ADAPTIVE_MAX_RUNS,
        "run budget: the most it runs",
        must="a whole number >= 2 n + 2 (its first round)",
        minimum=1,
    )
    search_points: int = option(
        DEFAULT_ADAPTIVE_SEARCH_POINTS,
        "search-grid points per cut box on the surrogate",
        must="an int >= 3^n",
        minimum=1,
    )
    gradients: Literal["auto", True, False] = option(
        GRADIENTS_AUTO,
        "use the model's gradients with respect to the fuzzy parameters: auto (where the "
        "model can give them all at most doubling a run's cost), true or false",
        must='"auto", true or false',
    )
    certify: Literal["bounds", "global"] = option(
        CERTIFY_BOUNDS,
        "what the certified error covers: bounds (where the surrogate can move a bound) "
        "or global (the surrogate everywhere it is checked, at more runs)",
        must='"bounds" or "global"',
    )

    def checked(self, names: tuple[str, ...]) -> Adaptive:
        """A budget of at least the first round; ``search_points`` at least ``3^n``."""
        least = 2 * len(names) + 2
        if self.max_runs < least:
            raise InvalidPlanError(
                f"max_runs of the adaptive method must be a whole number >= {least} (its "
                f"first round: 2 n + 2 runs for n = {len(names)} parameters), got "
                f"{self.max_runs!r}"
            )
        if self.search_points < 3 ** len(names):
            raise InvalidPlanError(
                f"search_points must be an int >= 3^n = {3 ** len(names)}, "
                f"got {self.search_points!r}"
            )
        return self

    def describe(self) -> dict[str, Any]:
        """The options; ``gradients`` and ``certify`` only where they are not the
        default, so that the plans (and the stores) of studies that leave them alone keep
        their fingerprints."""
        values = self.option_values()
        if values["gradients"] == GRADIENTS_AUTO:
            del values["gradients"]
        if values["certify"] == CERTIFY_BOUNDS:
            del values["certify"]
        return values

    def count(self, request: CountRequest) -> tuple[int, bool]:
        """The run budget: no fixed count (the model's outputs decide the rounds)."""
        return self.max_runs, False

    def start(
        self, parameters: dict[str, FuzzyNumber], levels: NDArray[np.float64]
    ) -> AdaptiveTransformation:
        """The engine of the rounds, from the first round."""
        return AdaptiveTransformation(
            parameters,
            levels,
            self.method_tolerance,
            self.max_runs,
            self.search_points,
            self.certify,
        )

    def stop_message(self, outcome: AdaptiveOutcome) -> str | None:
        """What stopped the rounds above the tolerance (the model's noise or the budget),
        and what to do; None when they converged."""
        if outcome.status == NOISE:
            return noise_message(outcome.runs, outcome.noise, self.method_tolerance)
        if not outcome.converged:
            return (
                f"the adaptive method stopped at its run budget (max_runs = "
                f"{self.max_runs}, {outcome.runs} runs) with a certified error of "
                f"{outcome.error:.3g} of the cut width, above method_tolerance = "
                f"{self.method_tolerance:g}; raise max_runs to reach the tolerance"
            )
        return None

    def judge(self, outcome: AdaptiveOutcome) -> None:
        """Warn (:class:`AdaptiveWarning`, :meth:`stop_message`) when the budget or the
        model's noise stopped the rounds above the tolerance."""
        message = self.stop_message(outcome)
        if message is not None:
            warnings.warn(message, AdaptiveWarning, stacklevel=3)

    def attrs(self, outcome: AdaptiveOutcome) -> dict[str, Any]:
        """Result attributes: ``method_error``, ``method_error_bound`` (``"certified"``),
        ``method_tolerance``, ``method_converged``, ``adaptive_runs``, ``adaptive_rounds``,
        ``adaptive_status`` (``"converged"``, ``"budget"`` or ``"noise"``),
        ``adaptive_noise`` (the model's noise on the cut-width scale; NaN if not measured)
        and ``adaptive_certify`` (``"bounds"`` or ``"global"``)."""
        return {
            "method_error": float(outcome.error),
            "method_error_bound": outcome.bound,
            "method_tolerance": float(self.method_tolerance),
            "method_converged": int(outcome.converged),
            "adaptive_runs": int(outcome.runs),
            "adaptive_rounds": int(outcome.rounds),
            "adaptive_status": outcome.status,
            "adaptive_noise": float(outcome.noise),
            "adaptive_certify": self.certify,
        }
