"""Inverse fuzzy arithmetic: fuzzy parameters from fuzzy (measured) outputs.

Given a batched model ``z = F(p)`` with scalar outputs and the uncertainty
observed in its outputs as fuzzy numbers, :func:`inverse` finds fuzzy
parameters whose forward propagation by the transformation method reproduces
the observed alpha-cuts (Hanss, "An approach to inverse fuzzy arithmetic",
Fuzzy Sets and Systems 138, 2003; Applied Fuzzy Arithmetic, 2005, ch. 6). The
derivation is in docs/theory.md, "Inverse fuzzy arithmetic"; in short:

1. **Modal values.** The crisp problem ``F(p) = z_core`` (the core midpoints
   of the measured outputs) is solved by least squares from the user's start
   values; it needs at least as many outputs as parameters.
2. **Cut by cut, from the core outwards.** A parameter cut is the modal value
   with a left and a right half-width, ``[p - d_minus, p + d_plus]``. On the
   points of the transformation method at the current cut (every combination
   of each parameter's lower bound, modal value and upper bound: the reduced
   method's corners plus the modal values; for a non-monotonic parameter also
   the bounds of the cuts above it, as in the extended method), the forward
   cut of each output is the range of its values, and the *gain factors* are
   the mean slopes over the left and the right half of each parameter's
   interval, kept separately. A positive gain carries the left half-width into
   the output's lower deviation and the right one into its upper deviation; a
   negative gain swaps them. This gives a linear system for the half-widths
   (2 r equations for 2 n unknowns, least squares for r > n), solved with the
   half-widths bounded below by those of the cut above (nested cuts) and above
   by the parameters' admissible ranges.
3. **Iteration.** The gain factors depend on the cut, so the system is solved
   for a correction of the half-widths from the residual of the true forward
   propagation (a Newton step with the gain factors as the Jacobian, halved
   until the residual falls), until the residual is within ``tolerance`` of
   each output's measured support width. Exact in one step for linear models.

With ``nonmonotonic="auto"`` (default) the identified parameters are screened
along each axis (:mod:`fuzzymbs.fuzzy.screening`); parameters the model is not
monotonic in get interior points and the identification is repeated (the
extended method). A measured uncertainty the model cannot produce (e.g. two
outputs of one parameter with inconsistent spreads) ends in
:class:`~fuzzymbs.errors.InverseMismatchError` carrying the best fit and its
residual, never in a silently wrong answer.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, lsq_linear

from fuzzymbs.errors import InverseMismatchError, InverseProblemError
from fuzzymbs.fuzzy.grids import cartesian
from fuzzymbs.fuzzy.numbers import FuzzyNumber, PiecewiseLinear
from fuzzymbs.fuzzy.screening import nonmonotonic_parameters, screening_samples
from fuzzymbs.fuzzy.transform import make_levels

__all__ = ["DEFAULT_TOLERANCE", "InverseResult", "InverseWarning", "inverse"]

#: largest residual (relative to each output's measured support width) of an accepted fit
DEFAULT_TOLERANCE = 1e-3
#: Newton steps per cut before giving up
DEFAULT_MAX_ITERATIONS = 30
#: half-width used to probe the gain factors of a parameter whose cut is still a point,
#: relative to its modal value (absolute for a zero modal value)
PROBE = 1e-3


class InverseWarning(UserWarning):
    """The identification did not reach its tolerance (with ``on_mismatch="warn"``)."""


@dataclass(frozen=True)
class InverseResult:
    """Outcome of :func:`inverse`.

    Attributes
    ----------
    parameters : dict of str to PiecewiseLinear
        The identified fuzzy parameters (cuts at ``levels``, linear between).
    modal : dict of str to float
        Their modal values (the crisp solution).
    levels : (L,) ndarray
        Membership levels, increasing from 0 to 1.
    measured : dict of str to (L, 2) ndarray
        The measured outputs' cuts at ``levels`` (lower, upper).
    forward : dict of str to (L, 2) ndarray
        Forward propagation of the identified parameters at ``levels``.
    residual : dict of str to (L, 2) ndarray
        ``forward - measured`` relative to the output's measured support width
        (its modal magnitude where the support has no width).
    evaluations : int
        Model evaluations (samples) spent, screening included.
    iterations : (L,) ndarray of int
        Newton steps per level.
    converged : bool
        Every level's residual is within ``tolerance``.
    nonmonotonic : tuple of str
        Parameters given interior points (the extended method); empty: reduced.
    tolerance : float
        The accepted residual.
    screening : dict or None
        The monotonicity screening report (``nonmonotonic="auto"``).
    """

    parameters: dict[str, PiecewiseLinear]
    modal: dict[str, float]
    levels: NDArray[np.float64]
    measured: dict[str, NDArray[np.float64]]
    forward: dict[str, NDArray[np.float64]]
    residual: dict[str, NDArray[np.float64]]
    evaluations: int
    iterations: NDArray[np.int64]
    converged: bool
    nonmonotonic: tuple[str, ...]
    tolerance: float
    screening: dict[str, Any] | None = field(default=None, repr=False)

    @property
    def method(self) -> str:
        """``"extended"`` if some parameter has interior points, else ``"reduced"``."""
        return "extended" if self.nonmonotonic else "reduced"

    @property
    def max_residual(self) -> float:
        """Largest relative residual over outputs, levels and bounds."""
        return max(float(np.max(np.abs(r))) for r in self.residual.values())

    def to_dataset(
        self,
        name: str = "inverse",
        units: Mapping[str, str] | None = None,
    ) -> Any:
        """The result as an :class:`xarray.Dataset`.

        Variables ``parameter_lower``/``parameter_upper`` (level, parameter),
        ``measured_lower``/``measured_upper``, ``forward_lower``/``forward_upper``
        and ``residual_lower``/``residual_upper`` (level, output); attributes
        ``study_name``, ``method``, ``converged``, ``max_residual``, ``tolerance``,
        ``evaluations``, ``nonmonotonic`` and ``parameter_units`` (JSON), so that
        :func:`fuzzymbs.plot.plot_input_memberships` draws the identified parameters.
        """
        import json

        import xarray

        names, outputs = list(self.parameters), list(self.measured)
        cuts = np.stack([self.parameters[n].cuts(self.levels) for n in names], axis=1)

        def by_output(table: Mapping[str, NDArray], side: int) -> NDArray:
            return np.stack([table[o][:, side] for o in outputs], axis=1)

        data = {
            "parameter_lower": (("level", "parameter"), cuts[:, :, 0]),
            "parameter_upper": (("level", "parameter"), cuts[:, :, 1]),
        }
        for label, table in (
            ("measured", self.measured),
            ("forward", self.forward),
            ("residual", self.residual),
        ):
            data[f"{label}_lower"] = (("level", "output"), by_output(table, 0))
            data[f"{label}_upper"] = (("level", "output"), by_output(table, 1))
        units = dict(units or {})
        return xarray.Dataset(
            data,
            coords={"level": self.levels, "parameter": names, "output": outputs},
            attrs={
                "study_name": name,
                "method": self.method,
                "converged": int(self.converged),
                "max_residual": self.max_residual,
                "tolerance": self.tolerance,
                "evaluations": self.evaluations,
                "nonmonotonic": json.dumps(list(self.nonmonotonic)),
                "iterations": json.dumps(self.iterations.tolist()),
                "modal": json.dumps(self.modal),
                "parameter_units": json.dumps({n: units[n] for n in names if n in units}),
            },
        )

    def summary(self) -> str:
        """Identified cuts and residuals as plain text."""
        lines = [
            f"Inverse fuzzy arithmetic ({self.method} method, {len(self.levels)} levels, "
            f"{self.evaluations} model evaluations): "
            + ("converged" if self.converged else "NOT converged")
            + f", largest residual {self.max_residual:.2e} of the measured widths "
            f"(tolerance {self.tolerance:g})",
            "Identified parameters (mu: lower .. upper):",
        ]
        for name, number in self.parameters.items():
            cuts = number.cuts(self.levels)
            text = ", ".join(
                f"{mu:g}: {lo:.6g} .. {hi:.6g}"
                for mu, (lo, hi) in zip(self.levels, cuts, strict=True)
            )
            lines.append(f"  {name}: {text}")
        lines.append("Residual per output (largest over levels, relative):")
        for name, residual in self.residual.items():
            lines.append(f"  {name}: {float(np.max(np.abs(residual))):.2e}")
        return "\n".join(lines)


class _Evaluator:
    """Calls the model on (P, n) points and returns (P, r) outputs, counting evaluations."""

    def __init__(
        self,
        model: Callable[[Mapping[str, NDArray]], Mapping[str, Any]],
        names: Sequence[str],
        outputs: Sequence[str],
    ) -> None:
        self.model = model
        self.names = list(names)
        self.outputs = list(outputs)
        self.count = 0

    def __call__(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        points = np.atleast_2d(points)
        size = len(points)
        self.count += size
        columns = {name: np.ascontiguousarray(points[:, i]) for i, name in enumerate(self.names)}
        try:
            returned = self.model(columns)
        except Exception as exc:  # the model's own error, with the point that caused it
            raise InverseProblemError(
                f"the model raised {type(exc).__name__}: {exc} (at parameters "
                f"{_point_text(self.names, points[0])}{' and others' if size > 1 else ''})"
            ) from exc
        if not isinstance(returned, Mapping):
            raise InverseProblemError(
                f"the model must return a mapping of outputs, got {type(returned).__name__}"
            )
        failed = np.zeros(size, dtype=bool)
        if "failed" in returned:
            failed = np.asarray(returned["failed"], dtype=bool).reshape(size)
        values = np.empty((size, len(self.outputs)))
        for k, name in enumerate(self.outputs):
            if name not in returned:
                raise InverseProblemError(
                    f"the model returns no output {name!r} named in measured; it returns "
                    f"{', '.join(n for n in returned if n not in ('failed', 'failure_reason'))}"
                )
            column = np.asarray(returned[name], dtype=float)
            if column.shape not in ((size,), (size, 1)):
                raise InverseProblemError(
                    f"output {name!r} has shape {column.shape} for {size} samples; inverse "
                    "fuzzy arithmetic needs scalar outputs (B,): reduce a signal to named "
                    "scalar features (a mean, a peak-to-peak value, ...)"
                )
            values[:, k] = column.reshape(size)
        bad = failed | ~np.isfinite(values).all(axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            reason = ""
            if "failure_reason" in returned:
                reason = f": {np.asarray(returned['failure_reason']).reshape(size)[i]}"
            raise InverseProblemError(
                f"the model failed at parameters {_point_text(self.names, points[i])}{reason}; "
                "give bounds that keep the parameters where the model is valid"
            )
        return values


def _point_text(names: Sequence[str], point: NDArray[np.float64]) -> str:
    return "{" + ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, point, strict=True)) + "}"


def _checked_measured(measured: Any) -> dict[str, FuzzyNumber]:
    if not isinstance(measured, Mapping) or not measured:
        raise InverseProblemError(
            "measured must be a non-empty mapping of output names to fuzzy numbers"
        )
    for name, number in measured.items():
        if not isinstance(number, FuzzyNumber):
            raise InverseProblemError(
                f"measured output {name!r} is a {type(number).__name__}, not a fuzzy number "
                "(fuzzymbs.fuzzy.numbers: Triangular, Trapezoidal, PiecewiseLinear, ...)"
            )
    return dict(measured)


def _checked_modal(modal: Any) -> dict[str, float]:
    if not isinstance(modal, Mapping) or not modal:
        raise InverseProblemError(
            "modal must be a non-empty mapping of parameter names to starting values"
        )
    values = {}
    for name, value in modal.items():
        if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
            raise InverseProblemError(
                f"modal start value of {name!r} must be a number, got {value!r}"
            )
        if not math.isfinite(float(value)):
            raise InverseProblemError(f"modal start value of {name!r} must be finite, got {value}")
        values[name] = float(value)
    return values


def _checked_bounds(
    bounds: Mapping[str, tuple[float, float]] | None, modal: Mapping[str, float]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    names = list(modal)
    lower = np.full(len(names), -np.inf)
    upper = np.full(len(names), np.inf)
    for name, pair in (bounds or {}).items():
        if name not in modal:
            raise InverseProblemError(
                f"bounds name an unknown parameter {name!r}; parameters: {', '.join(names)}"
            )
        try:
            low, high = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise InverseProblemError(
                f"bounds of {name!r} must be a pair (lower, upper), got {pair!r}"
            ) from None
        if math.isnan(low) or math.isnan(high) or not low < high:
            raise InverseProblemError(f"bounds of {name!r} need lower < upper, got {pair!r}")
        if not low <= modal[name] <= high:
            raise InverseProblemError(
                f"modal start value {modal[name]!r} of {name!r} lies outside its bounds {pair!r}"
            )
        i = names.index(name)
        lower[i], upper[i] = low, high
    return lower, upper


def _output_scales(cuts: NDArray[np.float64]) -> NDArray[np.float64]:
    """(r,) width of each output's support; its modal magnitude (or 1) where that is 0."""
    width = cuts[:, 0, 1] - cuts[:, 0, 0]
    core = 0.5 * (cuts[:, -1, 0] + cuts[:, -1, 1])
    fallback = np.where(np.abs(core) > 0.0, np.abs(core), 1.0)
    return np.where(width > 0.0, width, fallback)


def _solve_modal(
    evaluate: _Evaluator,
    start: NDArray[np.float64],
    target: NDArray[np.float64],
    scale: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Least-squares solution of F(p) = target (outputs weighted by 1/scale)."""
    typical = np.where(start != 0.0, np.abs(start), 1.0)

    def residual(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return (evaluate(p[None, :])[0] - target) / scale

    def jacobian(p: NDArray[np.float64]) -> NDArray[np.float64]:
        step = 1e-7 * np.maximum(np.abs(p), typical)
        # one-sided steps that stay inside the bounds: forward, or backward at an upper bound
        step = np.where(p + step > upper, -step, step)
        points = np.vstack([p, p + np.diag(step)])
        values = evaluate(points) / scale
        return ((values[1:] - values[0]) / step[:, None]).T

    try:
        solution = least_squares(
            residual,
            np.clip(start, lower, upper),
            jac=jacobian,
            bounds=(lower, upper),
            x_scale=typical,
            xtol=1e-14,
            ftol=1e-14,
            gtol=1e-14,
            max_nfev=200,
        )
    except InverseProblemError as exc:
        raise InverseProblemError(f"the modal (crisp) solution failed: {exc}") from exc
    # status 0: the evaluation budget ran out on a problem without an exact solution (more
    # outputs than parameters); the best fit stands and the residual check reports it
    if not solution.success and solution.status < 0:
        raise InverseProblemError(f"the modal (crisp) solution failed: {solution.message}")
    return np.asarray(solution.x, dtype=float)


class _LevelSolver:
    """Forward propagation and gain factors at one cut, on the transformation-method grid."""

    def __init__(
        self,
        evaluate: _Evaluator,
        modal: NDArray[np.float64],
        count_outputs: int,
        nonmonotonic: NDArray[np.bool_],
        probe: NDArray[np.float64],
    ) -> None:
        self.evaluate = evaluate
        self.modal = modal
        self.nonmonotonic = nonmonotonic
        self.probe = probe
        n, r = len(modal), count_outputs
        # gain factors of the left and right halves, (r, n); probed before the first cut
        self.gain_left = np.zeros((r, n))
        self.gain_right = np.zeros((r, n))
        # midpoints of the point set P_(j+1) of the cut above (extended method)
        self.inner: list[NDArray[np.float64]] = [np.empty(0) for _ in range(n)]

    def close_level(self, widths: NDArray[np.float64]) -> None:
        """Fix this level's cut: the next level's interior points follow from it."""
        for i in np.flatnonzero(self.nonmonotonic):
            low, high = self.modal[i] - widths[0, i], self.modal[i] + widths[1, i]
            points = np.unique(np.concatenate(([low], self.inner[i], [high])))
            self.inner[i] = 0.5 * (points[:-1] + points[1:])

    def propagate(
        self, widths: NDArray[np.float64], update_gains: bool = True
    ) -> NDArray[np.float64]:
        """Forward cut (r, 2) for half-widths ``widths`` = (d_minus, d_plus) of shape (2, n).

        Also refreshes the gain factors of every half whose width exceeds the probe.
        """
        n = len(self.modal)
        axes: list[NDArray[np.float64]] = []
        members: list[NDArray[np.bool_]] = []  # the method's own points on each axis
        positions: list[tuple[int, int, int]] = []  # (lower, modal, upper) index per axis
        for i in range(n):
            low, high = self.modal[i] - widths[0, i], self.modal[i] + widths[1, i]
            # the extended method's points P_j (Hanss's general method) for a non-monotonic
            # parameter: the bounds and the midpoints of P_(j+1); else the reduced corners
            own = (
                np.concatenate(([low], self.inner[i], [high]))
                if self.nonmonotonic[i]
                else (np.array([low, high]))
            )
            # the modal value too: the left and right gain factors need it
            axis = np.unique(np.append(own, self.modal[i]))
            axes.append(axis)
            members.append(np.isin(axis, own))
            positions.append((0, int(np.searchsorted(axis, self.modal[i])), len(axis) - 1))
        grid = cartesian(axes)  # the last parameter fastest: reshapes to the axes
        values = self.evaluate(grid).reshape(*(len(a) for a in axes), -1)
        own_values = values[np.ix_(*members)].reshape(-1, values.shape[-1])
        forward = np.stack([own_values.min(axis=0), own_values.max(axis=0)], axis=1)
        if update_gains:
            for i in range(n):
                lo, mid, hi = positions[i]
                taken = np.moveaxis(values, i, 0)
                other = tuple(range(n - 1))  # the other parameters (outputs last)
                if widths[0, i] > self.probe[i]:
                    slope = (taken[mid] - taken[lo]) / widths[0, i]
                    self.gain_left[:, i] = slope.mean(axis=other) if other else slope
                if widths[1, i] > self.probe[i]:
                    slope = (taken[hi] - taken[mid]) / widths[1, i]
                    self.gain_right[:, i] = slope.mean(axis=other) if other else slope
        return forward

    def probe_gains(self, most: NDArray[np.float64]) -> None:
        """Gain factors of a small cut around the modal point (before the first cut),
        inside the admissible half-widths ``most`` (2, n)."""
        widths = np.minimum(np.vstack([self.probe, self.probe]) * 2.0, most)
        self.propagate(widths)

    def jacobian(
        self, widths: NDArray[np.float64], forward: NDArray[np.float64], most: NDArray
    ) -> NDArray[np.float64]:
        """(2 r, 2 n) like :meth:`matrix`, by finite differences of the forward cut itself
        (used when the gain factors' step does not reduce the residual)."""
        n = widths.shape[1]
        columns = []
        for side in range(2):
            for i in range(n):
                step = 1e-6 * max(widths[side, i], self.probe[i])
                if widths[side, i] + step > most[side, i]:
                    step = -step
                trial = widths.copy()
                trial[side, i] += step
                moved = self.propagate(trial, update_gains=False)
                slope = (moved - forward) / step  # (r, 2)
                columns.append(np.concatenate([-slope[:, 0], slope[:, 1]]))
        return np.stack(columns, axis=1)

    def matrix(self) -> NDArray[np.float64]:
        """(2 r, 2 n): forward lower (rows 0..r-1, sign flipped) and upper bounds per unit
        increase of (d_minus, d_plus)."""
        left, right = self.gain_left, self.gain_right
        # lower deviation: a positive left gain lowers the output with d_minus; a negative
        # right gain lowers it with d_plus (a parameter's upper bound, the output's lower)
        lower_rows = np.hstack([np.clip(left, 0.0, None), np.clip(-right, 0.0, None)])
        upper_rows = np.hstack([np.clip(-left, 0.0, None), np.clip(right, 0.0, None)])
        return np.vstack([lower_rows, upper_rows])


def _identify_levels(
    evaluate: _Evaluator,
    modal: NDArray[np.float64],
    modal_outputs: NDArray[np.float64],
    cuts: NDArray[np.float64],
    scale: NDArray[np.float64],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    nonmonotonic: NDArray[np.bool_],
    tolerance: float,
    max_iterations: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Half-widths (L, 2, n), forward cuts (L, r, 2) and Newton steps (L,) per level."""
    levels_count, n = cuts.shape[1], len(modal)
    probe = PROBE * np.where(modal != 0.0, np.abs(modal), 1.0)
    solver = _LevelSolver(evaluate, modal, len(modal_outputs), nonmonotonic, probe)
    most = np.vstack([modal - lower, upper - modal])  # admissible half-widths
    solver.probe_gains(most)
    widths_all = np.zeros((levels_count, 2, n))
    forward_all = np.zeros((levels_count, len(modal_outputs), 2))
    steps = np.zeros(levels_count, dtype=np.int64)
    widths = np.zeros((2, n))
    forward = np.stack([modal_outputs, modal_outputs], axis=1)
    weights = np.concatenate([1.0 / scale, 1.0 / scale])

    def misfit(forward_cut: NDArray[np.float64], target: NDArray[np.float64]) -> NDArray:
        # forward - measured, relative, lower bounds first
        return np.concatenate(
            [(forward_cut[:, 0] - target[:, 0]) / scale, (forward_cut[:, 1] - target[:, 1]) / scale]
        )

    for j in range(levels_count - 1, -1, -1):  # from the core outwards
        target = cuts[:, j, :]
        floor = widths.copy()  # nested: never narrower than the cut above
        error = misfit(forward, target)
        iteration = 0
        exact = False  # True: finite-difference Jacobian instead of the gain factors
        while np.max(np.abs(error)) > tolerance and iteration < max_iterations:
            iteration += 1
            matrix = solver.jacobian(widths, forward, most) if exact else solver.matrix()
            # forward(d + delta) ~ [lower - A_lo delta, upper + A_up delta]: we want the
            # misfit to vanish, i.e. A delta = [lower - a, b - upper] (weighted)
            rhs = np.concatenate([forward[:, 0] - target[:, 0], target[:, 1] - forward[:, 1]])
            low_step = (floor - widths).ravel()
            high_step = (np.maximum(most, floor) - widths).ravel()
            step = lsq_linear(
                matrix * weights[:, None],
                rhs * weights,
                bounds=(low_step, np.maximum(high_step, np.nextafter(low_step, np.inf))),
                method="bvls",
            ).x.reshape(2, n)
            # halve the step until the residual falls (the gain factors are secants)
            improved = False
            for _ in range(8):
                trial = np.clip(widths + step, floor, np.maximum(most, floor))
                trial_forward = solver.propagate(trial)
                trial_error = misfit(trial_forward, target)
                if np.linalg.norm(trial_error) < np.linalg.norm(error):
                    improved = True
                    break
                step = step / 2.0
            if not improved:
                if exact:
                    break  # the least-squares optimum of this cut: the residual stays
                exact = True  # the gain factors' secants are not enough here: Newton
                continue
            slow = np.linalg.norm(trial_error) > 0.5 * np.linalg.norm(error)
            widths, forward, error = trial, trial_forward, trial_error
            exact = exact or slow
        widths_all[j], forward_all[j], steps[j] = widths, forward, iteration
        solver.close_level(widths)
    return widths_all, forward_all, steps


def inverse(
    model: Callable[[Mapping[str, NDArray]], Mapping[str, Any]],
    measured: Mapping[str, FuzzyNumber],
    modal: Mapping[str, float],
    levels: int | ArrayLike = 4,
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    nonmonotonic: Sequence[str] | str = "auto",
    tolerance: float = DEFAULT_TOLERANCE,
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    on_mismatch: str = "raise",
) -> InverseResult:
    """Identify fuzzy parameters whose forward propagation reproduces fuzzy outputs.

    Parameters
    ----------
    model : callable
        Batched model ``model({name: (B,) array}) -> {output: (B,) array}``
        (scalar outputs; a signal is reduced to named scalar features first).
        May flag failed samples with ``failed`` / ``failure_reason``.
    measured : mapping of str to FuzzyNumber
        Output name -> its observed uncertainty (at least as many outputs as
        parameters).
    modal : mapping of str to float
        Parameter name -> starting value of the crisp (modal) solution; fixes
        the parameters and their order.
    levels : int or sequence of float
        ``m`` for mu_j = j/m, or explicit levels from 0 to 1.
    bounds : mapping of str to (float, float), optional
        Admissible range of a parameter (e.g. ``(0, inf)`` for a stiffness);
        the modal solution and every cut stay inside it.
    nonmonotonic : sequence of str or "auto"
        Parameters the model is not monotonic in (they get interior points:
        the extended method). ``"auto"`` (default): identify with the reduced
        method, screen the result along each parameter's axis and repeat with
        the parameters found non-monotonic.
    tolerance : float
        Largest accepted residual of the forward cuts, relative to each
        output's measured support width (default 1e-3).
    max_iterations : int
        Newton steps per cut.
    on_mismatch : {"raise", "warn"}
        When a residual exceeds ``tolerance`` (a measured uncertainty the
        model cannot produce): raise :class:`~fuzzymbs.errors.InverseMismatchError`
        (default; it carries the best fit as ``.result``) or warn
        (:class:`InverseWarning`) and return it with ``converged = False``.

    Returns
    -------
    InverseResult

    Raises
    ------
    InverseProblemError
        Measured values that are not fuzzy numbers, fewer outputs than
        parameters, bad start values or bounds, outputs the model does not
        return or that are not scalar, a model that fails, a modal solution
        that fails.
    InverseMismatchError
        The forward propagation cannot reproduce the measured cuts within
        ``tolerance`` (with ``on_mismatch="raise"``).

    Examples
    --------
    >>> from fuzzymbs.fuzzy.numbers import Triangular
    >>> model = lambda p: {"z1": p["a"] + p["b"], "z2": p["a"] - 2.0 * p["b"]}
    >>> measured = {"z1": Triangular(2.25, 3.0, 3.75), "z2": Triangular(-1.5, 0.0, 0.75)}
    >>> result = inverse(model, measured, {"a": 1.0, "b": 1.0})
    >>> [round(float(v), 9) for v in result.parameters["a"].alpha_cut(0.0)]
    [1.5, 2.25]
    >>> [round(float(v), 9) for v in result.parameters["b"].alpha_cut(0.0)]
    [0.75, 1.5]
    """
    numbers = _checked_measured(measured)
    start = _checked_modal(modal)
    if len(numbers) < len(start):
        raise InverseProblemError(
            f"underdetermined: {len(numbers)} measured output(s) ({', '.join(numbers)}) for "
            f"{len(start)} parameters ({', '.join(start)}); inverse fuzzy arithmetic needs at "
            "least as many outputs as parameters"
        )
    if on_mismatch not in ("raise", "warn"):
        raise InverseProblemError(f"on_mismatch must be 'raise' or 'warn', got {on_mismatch!r}")
    if not (isinstance(tolerance, int | float) and math.isfinite(tolerance) and tolerance > 0):
        raise InverseProblemError(f"tolerance must be a positive number, got {tolerance!r}")
    if (
        isinstance(max_iterations, bool)
        or not isinstance(max_iterations, int)
        or max_iterations < 1
    ):
        raise InverseProblemError(f"max_iterations must be an int >= 1, got {max_iterations!r}")
    names = list(start)
    if isinstance(nonmonotonic, str):
        if nonmonotonic != "auto":
            raise InverseProblemError(
                f"nonmonotonic must be 'auto' or a list of parameter names, got {nonmonotonic!r}"
            )
        given: list[str] | None = None
    else:
        given = list(nonmonotonic)
        unknown = [name for name in given if name not in start]
        if unknown:
            raise InverseProblemError(
                f"nonmonotonic names unknown parameter(s) {unknown}; parameters: {', '.join(names)}"
            )
    lower, upper = _checked_bounds(bounds, start)
    mus = make_levels(levels)
    outputs = list(numbers)
    cuts = np.stack([numbers[name].cuts(mus) for name in outputs])  # (r, L, 2)
    scale = _output_scales(cuts)
    evaluate = _Evaluator(model, names, outputs)
    target = 0.5 * (cuts[:, -1, 0] + cuts[:, -1, 1])
    modal_values = _solve_modal(
        evaluate, np.array(list(start.values())), target, scale, lower, upper
    )
    modal_outputs = evaluate(modal_values[None, :])[0]

    def run(flags: NDArray[np.bool_]) -> tuple[NDArray, NDArray, NDArray]:
        return _identify_levels(
            evaluate,
            modal_values,
            modal_outputs,
            cuts,
            scale,
            lower,
            upper,
            flags,
            float(tolerance),
            max_iterations,
        )

    flags = np.array([name in (given or []) for name in names])
    widths, forward, steps = run(flags)
    screening = None
    if given is None:
        identified = _fuzzy_parameters(names, modal_values, widths, mus)
        screen = screening_samples(identified, mus)
        values = evaluate(screen.samples)
        screening = nonmonotonic_parameters(
            screen, {name: values[:, k] for k, name in enumerate(outputs)}
        )
        found = set(screening["nonmonotonic"])
        if found:
            flags = np.array([name in found for name in names])
            widths, forward, steps = run(flags)
    parameters = _fuzzy_parameters(names, modal_values, widths, mus)
    forward_cuts = {name: forward[:, k, :] for k, name in enumerate(outputs)}
    measured_cuts = {name: cuts[k] for k, name in enumerate(outputs)}
    residual = {
        name: (forward_cuts[name] - measured_cuts[name]) / scale[k]
        for k, name in enumerate(outputs)
    }
    worst = max(float(np.max(np.abs(r))) for r in residual.values())
    result = InverseResult(
        parameters=parameters,
        modal=dict(zip(names, modal_values.tolist(), strict=True)),
        levels=mus,
        measured=measured_cuts,
        forward=forward_cuts,
        residual=residual,
        evaluations=evaluate.count,
        iterations=steps,
        converged=worst <= tolerance,
        nonmonotonic=tuple(name for name, flag in zip(names, flags, strict=True) if flag),
        tolerance=float(tolerance),
        screening=screening,
    )
    if not result.converged:
        where = _worst_place(result)
        message = (
            f"the model cannot reproduce the measured uncertainty: largest residual "
            f"{worst:.3g} of the measured support width (tolerance {tolerance:g}) {where}; "
            "check that the measured outputs are consistent with each other and with the "
            "model, or that the bounds leave room"
        )
        if on_mismatch == "raise":
            raise InverseMismatchError(message, result)
        warnings.warn(message, InverseWarning, stacklevel=2)
    return result


def _fuzzy_parameters(
    names: Sequence[str],
    modal: NDArray[np.float64],
    widths: NDArray[np.float64],
    mus: NDArray[np.float64],
) -> dict[str, PiecewiseLinear]:
    return {
        name: PiecewiseLinear(mus, modal[i] - widths[:, 0, i], modal[i] + widths[:, 1, i])
        for i, name in enumerate(names)
    }


def _worst_place(result: InverseResult) -> str:
    name, residual = max(result.residual.items(), key=lambda item: np.max(np.abs(item[1])))
    level, side = np.unravel_index(int(np.argmax(np.abs(residual))), residual.shape)
    bound = ("lower", "upper")[side]
    forward = result.forward[name][level, side]
    measured = result.measured[name][level, side]
    return (
        f"at output {name!r}, mu = {result.levels[level]:g}, {bound} bound: forward "
        f"{forward:.6g}, measured {measured:.6g}"
    )
