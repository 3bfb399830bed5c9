"""Every time-integrated study checks its own time integration, on the scale of its bands.

A model that integrates in time offers ``tightened()``: the same model with its
tolerance tightened by its :class:`~fuzzymbs.tolerance.Tolerance`'s ``tightening``,
tenfold (fixed-step RK4: the step divided by its ``step_division``, halved); a
model with modes that do not integrate in time returns None there. After the study's runs the
runner re-integrates the samples that give the cuts' bounds with it and
compares, element by element, each bound with the tighter value of the sample
that gives it:

    error = max over outputs, levels j and elements e of
            |b_j(e) - b_j,tight(e)| / max(w_j(e), 0.1 max_e w_j(e))

with ``b`` the lower and the upper bound and ``w_j(e)`` the cut width: the
normalisation of the method check (:mod:`fuzzymbs.study.method_check`), so that
both errors are read on the scale a fuzzy result is read on, the cut width, not
the signal's peak (a +-1 % parameter has cuts a few tenths of a per cent of the
peak wide). Levels whose cuts have no width anywhere (a triangular number's
core) have no band to distort and are left out.

Re-running every sample would double a study's cost; the check re-runs at most
``runs`` samples (the study option ``integration_runs``, default 8, two SIMD
blocks: :class:`~fuzzymbs.study.options.StudyOptions`): the modal sample, then, the
levels taking turns from the innermost (narrowest) cut outwards, the sample
that gives the most bounds of that level. Elements bounded by a sample that was
not re-run are left out of the maximum, so the figure is an estimate from the
samples that matter most (docs/brake.md measures it against the bands of a
whole plan re-integrated at rtol 1e-6). With an error-controlled integrator the
global error falls about in proportion to the tolerance, so the difference to
the tenfold tighter run estimates the study's own error.

The peak-relative deviation of the modal sample,
``max_t |y - y_tight| / max_t |y_tight|`` (largest over outputs), stays as a
secondary figure (``time_integration_error_peak``). Above the study's
tolerance (the study option ``integration_tolerance``, default 1 % of the cut
width, floored at a tenth of the level's widest cut) the runner warns. Models
without ``tightened`` (no time integration) are left out.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.background import Background
from fuzzymbs.errors import SimulationDivergedError
from fuzzymbs.fuzzy.band_scale import WIDTH_FLOOR, width_relative
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.tolerance import DEFAULT_TOLERANCE, tolerance_of


class TimeIntegrationWarning(UserWarning):
    """A study's time-integration error exceeds its tolerance (or could not be checked)."""


@dataclass(frozen=True)
class CutBounds:
    """One output's nested bounds and the samples that give them, each (L, size)."""

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    lower_sample: NDArray[np.int64]
    upper_sample: NDArray[np.int64]


@dataclass(frozen=True)
class IntegrationCheck:
    """Outcome of :func:`check_time_integration`.

    Attributes
    ----------
    error : largest deviation of a bound relative to the cut width (NaN: not checked).
    tolerance : the study's tolerance (of the cut width).
    method : the model's time integration in words (``model.time_integration``).
    note : why the check failed, or "".
    peak_error : the modal sample's largest deviation relative to the output's peak.
    runs : samples re-run at the tighter tolerance.
    worst : where ``error`` is reached (output, level, element), or "".
    reference_error : for a model on shared steps, its reference run's estimated error
        relative to the cut width (included in ``error``); NaN otherwise.
    """

    error: float
    tolerance: float
    method: str
    note: str = ""
    peak_error: float = float("nan")
    runs: int = 0
    worst: str = ""
    reference_error: float = float("nan")

    def to_attrs(self) -> dict[str, Any]:
        """Dataset attributes (NetCDF-safe: numbers and strings)."""
        return {
            "time_integration_error": float(self.error),
            "time_integration_tolerance": float(self.tolerance),
            "time_integration": self.method,
            "time_integration_note": self.note,
            "time_integration_error_peak": float(self.peak_error),
            "time_integration_runs": int(self.runs),
            "time_integration_worst": self.worst,
            "time_integration_reference_error": float(self.reference_error),
        }


def peak_relative_deviation(coarse: np.ndarray, fine: np.ndarray) -> float:
    """``max |coarse - fine| / max |fine|`` (NaN if fine is zero or not finite)."""
    peak = float(np.max(np.abs(fine))) if fine.size else 0.0
    if not np.isfinite(peak) or peak == 0.0:
        return float("nan")
    return float(np.max(np.abs(coarse - fine)) / peak)


def choose_samples(
    tallies: Sequence[NDArray[np.int64]],
    nominal: int,
    failed: NDArray[np.bool_],
    runs: int,
    include_nominal: bool = True,
) -> list[int]:
    """The samples to re-run: the modal one (unless ``include_nominal`` is False: a model
    on shared steps has no error left there), then, levels taking turns from the innermost
    (the last of ``tallies``) outwards, the one that bounds the most elements of that level
    (``tallies[j]``: (N,) bounds per sample at level j)."""
    chosen = [] if failed[nominal] or not include_nominal else [nominal]
    order = list(range(len(tallies) - 1, -1, -1))
    left = [np.where(failed, -1, tally.astype(np.int64)) for tally in tallies]
    for tally in left:
        tally[chosen] = -1
    if not include_nominal:
        for tally in left:
            tally[nominal] = -1
    while len(chosen) < runs and any(int(t.max(initial=-1)) > 0 for t in left):
        for j in order:
            if len(chosen) >= runs:
                break
            best = int(np.argmax(left[j]))
            if left[j][best] <= 0:
                continue
            chosen.append(best)
            for tally in left:
                tally[best] = -1
    return chosen


def run_cut_bounds(
    samples: NDArray[np.float64],
    outputs: Mapping[str, np.ndarray],
    cut_lower: NDArray[np.float64],
    cut_upper: NDArray[np.float64],
    failed: NDArray[np.bool_],
) -> tuple[list[NDArray[np.int64]], dict[str, CutBounds]]:
    """Each cut's bounds among the runs inside its box, and the runs that give them.

    For a plan whose bounds are not runs of its own (the adaptive method's come from
    a surrogate of its runs, certified by runs at its extremal points): the runs
    that bound a level's outputs are where the surrogate's bounds are decided, so
    their integration error is the bounds'. The widths of these run bounds are at
    most the plan's (a narrower width, a larger relative error: the check errs on
    the safe side).

    Parameters
    ----------
    samples : (N, n) the runs' parameter points.
    outputs : output -> (N, ...) the runs' outputs.
    cut_lower, cut_upper : (L, n) the cut boxes.
    failed : (N,) runs left out.

    Returns
    -------
    (tallies, bounds)
        ``tallies[j]`` (N,) how many bounds of level j each run gives (for
        :func:`choose_samples`); per output, :class:`CutBounds` (-1 where no run lies
        inside a level's box).
    """
    samples = np.asarray(samples, dtype=float)
    count = len(samples)
    span = np.maximum(cut_upper[0] - cut_lower[0], np.abs(cut_lower[0])) * 1e-12
    inside = np.stack(
        [
            np.all((samples >= lo - span) & (samples <= hi + span), axis=1) & ~failed
            for lo, hi in zip(cut_lower, cut_upper, strict=True)
        ]
    )  # (L, N)
    tallies = [np.zeros(count, dtype=np.int64) for _ in range(len(cut_lower))]
    bounds: dict[str, CutBounds] = {}
    for name, values in outputs.items():
        flat = np.asarray(values, dtype=float).reshape(count, -1)
        size = flat.shape[1]
        lower = np.full((len(inside), size), np.nan)
        upper = np.full((len(inside), size), np.nan)
        lower_sample = np.full((len(inside), size), -1, dtype=np.int64)
        upper_sample = np.full((len(inside), size), -1, dtype=np.int64)
        for j, rows in enumerate(inside):
            index = np.flatnonzero(rows)
            if not index.size:
                continue
            block = flat[index]
            low = np.argmin(np.where(np.isnan(block), np.inf, block), axis=0)
            high = np.argmax(np.where(np.isnan(block), -np.inf, block), axis=0)
            columns = np.arange(size)
            lower[j], upper[j] = block[low, columns], block[high, columns]
            lower_sample[j], upper_sample[j] = index[low], index[high]
            if np.any(upper[j] > lower[j]):  # a level without width has no band to distort
                tallies[j] += np.bincount(index[low], minlength=count)
                tallies[j] += np.bincount(index[high], minlength=count)
        bounds[name] = CutBounds(lower, upper, lower_sample, upper_sample)
    return tallies, bounds


def check_time_integration(
    model: Any,
    columns: Callable[[list[int]], Mapping[str, np.ndarray]],
    samples: Sequence[int],
    bounds: Mapping[str, CutBounds | None],
    nominal: Mapping[str, np.ndarray],
    nominal_index: int,
    levels: NDArray[np.float64],
    tolerance: float = StudyOptions.integration_tolerance,
    tight: Any = None,
) -> IntegrationCheck | None:
    """Re-run ``samples`` with ``model.tightened()`` and measure the bounds' deviation.

    Parameters
    ----------
    model : the study's model; without a callable ``tightened`` the check is skipped.
    columns : parameter columns ``{name: (k,)}`` of a list of sample indices.
    samples : the samples to re-run (:func:`choose_samples`); empty: not checked.
    bounds : per output, its nested bounds and the samples giving them (None: an output
        without per-level bookkeeping, e.g. of a sparse plan; only its peak figure).
    nominal : the study's outputs at the modal sample (for the peak figure).
    nominal_index : the modal sample's index.
    levels : (L,) membership levels (for the message).
    tolerance : the study's largest acceptable error (of the cut width).
    tight : ``model.tightened()`` made already (holding re-runs made ahead), or None.

    Returns
    -------
    IntegrationCheck or None
        None for models that do not integrate in time. Warns
        (:class:`TimeIntegrationWarning`) when the error exceeds ``tolerance`` or
        cannot be computed.
    """
    tightened: Callable[[], Any] | None = getattr(model, "tightened", None)
    if tight is None:
        tight = tightened() if callable(tightened) else None
    if tight is None:
        return None
    method = str(getattr(model, "time_integration", ""))
    samples = [int(s) for s in samples]
    if not samples:
        return report_check(IntegrationCheck(np.nan, tolerance, method, "every sample failed"))
    rerun = tight(dict(columns(samples)))
    rerun_failed = np.asarray(rerun.get("failed", np.zeros(len(samples), bool)), dtype=bool)
    if rerun_failed.all():
        reason = np.asarray(rerun.get("failure_reason", [""] * len(samples)))[0]
        note = f"the tightened re-runs failed ({reason})"
        return report_check(IntegrationCheck(np.nan, tolerance, method, note, runs=len(samples)))
    row = np.full(max(max(samples), nominal_index) + 1, -1)
    for k, sample in enumerate(samples):
        if not rerun_failed[k]:
            row[sample] = k
    peak = float("nan")
    if nominal_index < row.size and row[nominal_index] >= 0:
        peaks = [
            peak_relative_deviation(
                np.asarray(nominal[name], dtype=float),
                np.asarray(rerun[name], dtype=float)[row[nominal_index]],
            )
            for name in bounds
        ]
        finite = [d for d in peaks if np.isfinite(d)]
        peak = max(finite) if finite else peak
    error, worst = -np.inf, ""
    # a model on shared steps: its reference run's error moves every sample alike
    reference_error = getattr(model, "reference_error", None)
    reference_part = -np.inf
    for name, cut in bounds.items():
        if cut is None:
            continue
        tight_values = np.asarray(rerun[name], dtype=float).reshape(len(samples), -1)
        deviation = np.full(cut.lower.shape, np.nan)
        for values, giver in ((cut.lower, cut.lower_sample), (cut.upper, cut.upper_sample)):
            known = (giver >= 0) & (giver < row.size)
            rows = np.where(known, row[np.where(known, giver, 0)], -1)
            columns_index = np.broadcast_to(np.arange(values.shape[1]), values.shape)
            d = np.abs(values - tight_values[np.maximum(rows, 0), columns_index])
            deviation = np.fmax(deviation, np.where(rows >= 0, d, np.nan))
        if reference_error is not None and name in reference_error:
            common = np.broadcast_to(
                np.asarray(reference_error[name], dtype=float).reshape(-1), cut.lower.shape
            )
            alone = width_relative(np.array(common), cut.lower, cut.upper)
            if np.isfinite(alone).any():
                reference_part = max(reference_part, float(np.nanmax(alone)))
            deviation = np.where(np.isnan(deviation), common, deviation + common)
        ratio = width_relative(deviation, cut.lower, cut.upper)
        if np.isfinite(ratio).any():
            level, element = np.unravel_index(int(np.nanargmax(ratio)), ratio.shape)
            if ratio[level, element] > error:
                error = float(ratio[level, element])
                worst = f"output {name!r}, level {levels[level]:g}, element {element}"
    note = ""
    if not np.isfinite(error):
        error = float("nan")
        note = "no bound of a re-run sample lies on a cut of non-zero width"
    reference_part = reference_part if np.isfinite(reference_part) else float("nan")
    check = IntegrationCheck(
        error, tolerance, method, note, peak, len(samples), worst, reference_part
    )
    return report_check(check)


def report_check(check: IntegrationCheck) -> IntegrationCheck:
    """Warn about a check that failed or found an error above the tolerance."""
    if check.note:
        warnings.warn(
            f"time integration not checked: {check.note}", TimeIntegrationWarning, stacklevel=4
        )
    elif check.error > check.tolerance:
        warnings.warn(
            f"time-integration error {100 * check.error:.3g} % of the cut width exceeds the "
            f"study's tolerance {100 * check.tolerance:g} % ({check.method}; {check.worst}): "
            f"{check.runs} samples that give the bounds, re-integrated with a tenfold tighter "
            "tolerance (RK4: half the step), move the bounds by that much. Tighten the "
            "model's rtol (or dt), or raise integration_tolerance.",
            TimeIntegrationWarning,
            stacklevel=4,
        )
    return check


#: the integration error is taken to fall as rtol^ORDER when the study chooses its
#: tolerance (measured on the brake's studies against rtol 1e-6: slopes 0.82 to 0.94
#: per decade from 1e-2 to 1e-5, docs/brake.md)
ERROR_ORDER = 0.88
#: the tolerance is chosen for this fraction of the study's integration tolerance (at
#: 0.7 the brake's study 2 landed at 1.005 % of its 1 % tolerance: the error falls
#: more slowly than rtol^0.88 below rtol 1e-5)
TARGET_FRACTION = 0.5
#: the pilot's parameters: at most this many (2^n corners)
PILOT_MAX_PARAMETERS = 6
#: with shared steps, the band error is taken to fall as rtol^SHARED_ORDER (measured on
#: the brake's studies against rtol 1e-6: study 1 10 % at rtol 1e-2, 0.37 % at 1e-3;
#: study 2 4.5 % at 1e-3, 0.55 % at 1e-4, docs/brake.md): the smaller slope
SHARED_ORDER = 1.2
#: with shared steps, a tolerance that must be tightened is tightened at least tenfold
#: (to the pilot's own tighter one: the default tolerance's tightening): between rtol
#: 1e-2 and 1e-3 the brake's coarse sequences do not follow the error law (over its
#: first millisecond, factor 1.78 left 1.30 % of the cut width where 2.57 left 0.37 %:
#: the pilot's estimate moves with the last bits of the arithmetic, docs/brake.md)
MIN_SHARED_FACTOR = DEFAULT_TOLERANCE.tightening
#: a chosen factor up to this many decades above 10 takes the pilot's tenfold tighter
#: model as it is (its sequence is logged already; the error at most 1.2^1.2 of the
#: target); so does a model built ahead for a factor this much below the chosen one
REUSE_DECADES = 0.08
#: a model built ahead for a factor up to this many decades above the chosen one is
#: taken too: its steps cost at most 10^(0.28 x 0.14) = 1.09 times those of the chosen
#: tolerance (ROS34PW2's steps grow about as rtol^-0.28 on the brake), less than a
#: logging run at the chosen one takes on a core of its own (the brake's study 1:
#: 4.6 s of 50 s of runs). For the pilot's tenfold tighter model the window below 10
#: no longer matters: a factor below 10 is raised to 10 (MIN_SHARED_FACTOR)
TIGHTER_REUSE_DECADES = 0.14
#: the model built while the reference finishes is the one for this many times the
#: reference error predicted from the modal logging runs (on the brake's studies 1
#: and 2 the prediction was 0.049 % and 0.21 % of the cut width, the reference's own
#: estimate 0.052 % and 0.29 %: 1.4 times short at worst)
PREDICTION_MARGIN = 1.5


@dataclass(frozen=True)
class ToleranceChoice:
    """What the pilot of :func:`choose_tolerance` found and chose.

    Attributes
    ----------
    factor : the model's tolerance was divided by this (1: kept).
    pilot_error : the estimated band-relative error at the model's own tolerance.
    pilot_runs : runs of the pilot (corners of the innermost cut, modal, modal tightened;
        with shared steps also the modal sample's logging and reference runs).
    method : the chosen time integration in words.
    note : why no choice was made, or "".
    shared_steps : every sample takes the modal sample's step sequence, corrected.
    reference_error : with shared steps, the reference's estimated error relative to
        the pilot's cut widths.
    reference_error_predicted : the same predicted from the modal logging runs before
        the reference had run (which model is built ahead); NaN without a prediction.
    measured_error : with shared steps, the pilot's tighter model's error measured
        against its corners on the sequence logged ahead beside the reference, where the
        law asked for more than that model (NaN: not measured).
    recipe : the factors of the ``tightened`` calls that built the chosen model, in
        order, from the model (on its shared steps where ``shared_steps``):
        :func:`chosen_model` builds it again bit for bit from them (a tenth's tenth
        rounds otherwise than a hundredth).
    """

    factor: float
    pilot_error: float
    pilot_runs: int
    method: str
    note: str = ""
    shared_steps: bool = False
    reference_error: float = float("nan")
    reference_error_predicted: float = float("nan")
    measured_error: float = float("nan")
    recipe: tuple[float, ...] = ()

    def to_attrs(self) -> dict[str, Any]:
        return {
            "integration_measured_error": float(self.measured_error),
            "integration_reference_error_predicted": float(self.reference_error_predicted),
            "integration_pilot_error": float(self.pilot_error),
            "integration_pilot_runs": int(self.pilot_runs),
            "integration_tolerance_factor": float(self.factor),
            "integration_choice_note": self.note,
            "integration_shared_steps": int(self.shared_steps),
            "integration_reference_error": float(self.reference_error),
        }


def choose_tolerance(
    model: Any,
    columns: Callable[[np.ndarray], Mapping[str, np.ndarray]],
    cut_lower: np.ndarray,
    cut_upper: np.ndarray,
    modal: np.ndarray,
    names: Sequence[str],
    tolerance: float = StudyOptions.integration_tolerance,
    shared_steps: bool = True,
    first: np.ndarray | None = None,
) -> tuple[Any, ToleranceChoice | None]:
    """The model with its integrator's tolerance chosen for the study's cut widths.

    A pilot runs the corners of the innermost cut of non-zero width and the modal
    point at the model's own tolerance, and the modal point once more at a tenth of
    it. The corners' spread estimates the narrowest cut widths ``w``, the modal
    point's two runs its integration error ``e``; with the normalisation of the
    check, ``E = max e / max(w, 0.1 max w)``. If E exceeds ``TARGET_FRACTION x
    tolerance``, the tolerance is divided by ``(E / (TARGET_FRACTION tolerance))^(1 /
    ERROR_ORDER)``; it is never loosened. The study's own check afterwards measures
    what the choice achieved.

    Parameters
    ----------
    model : a model whose ``tightened(factor)`` divides its tolerance by any factor and
        that says so with ``scalable_tolerance = True``; other models come back as
        they are, with None.
    columns : parameter columns of a table of fuzzy-parameter rows (k, n).
    cut_lower, cut_upper : (L, n) the plan's cut boxes.
    modal : (n,) the modal point.
    names : the study's outputs.
    tolerance : the study's integration tolerance (of the cut width).
    shared_steps : with a model that offers ``share_steps(modal)`` (and, on shared steps,
        ``deviations(samples)``: outputs minus the modal sample's), put every sample on
        the modal sample's step sequence and correct by the modal sample's error
        (:mod:`fuzzymbs.mbs.shared_steps`); the pilot then compares the corners' deviations
        at the model's tolerance with those at a tenth of it (the reference that corrects
        both drops out: the modal point has no error left to compare) and divides the
        tolerance by ``(E / (TARGET_FRACTION tolerance - E_ref))^(1 / SHARED_ORDER)``,
        ``E_ref`` the reference's own estimated error. Where that asks for more than the
        tenth and the model's hundredth takes the sequence its reference block logs
        (``logged_ahead``), the corners run once more on it: the tenth's own error
        ``E_10`` is measured, and the factor is ``10 (E_10 / budget)^(1 / SHARED_ORDER)``
        (at least 10; the hundredth's model is taken when near enough). From the coarse
        tolerance the law misjudges the tenth's error sixfold either way on the brake
        (docs/brake.md, "Cost").
    first : (k, n) the plan's first points (rows as ``modal``). On shared steps they
        run in the background on the model the choice is likely to take, while the
        reference finishes (``run_ahead``: kept for the plan's first call; lost if
        the choice takes another model).

    Returns
    -------
    (model, ToleranceChoice or None)
    """
    if not getattr(model, "scalable_tolerance", False):
        return model, None
    widths = cut_upper - cut_lower
    inner = [j for j in range(len(widths)) if np.any(widths[j] > 0)]
    n = cut_lower.shape[1]
    if not inner or n > PILOT_MAX_PARAMETERS:
        note = (
            "no cut of non-zero width"
            if not inner
            else f"more than {PILOT_MAX_PARAMETERS} fuzzy parameters (2^n pilot corners)"
        )
        note += ": the model's tolerance is kept"
        return model, ToleranceChoice(1.0, np.nan, 0, model.time_integration, note)
    j = inner[-1]
    corners = np.array(
        [
            [cut_upper[j, i] if (k >> i) & 1 else cut_lower[j, i] for i in range(n)]
            for k in range(2**n)
        ]
    )
    shared_note = ""
    if shared_steps and callable(getattr(model, "share_steps", None)):
        try:
            # the reference runs go on in the background while the pilot runs
            shared = model.share_steps(dict(columns(modal[None, :])))
            return _choose_shared(shared, columns, corners, names, tolerance, first)
        except SimulationDivergedError as error:
            shared_note = f"no shared steps ({error}): each sample keeps its own; "
    table = np.vstack([corners, modal[None, :]])
    coarse = model(dict(columns(table)))
    fine = model.tightened(tolerance_of(model).tightening)(dict(columns(modal[None, :])))
    runs = len(table) + 1
    failed = np.asarray(coarse.get("failed", np.zeros(len(table), bool)), dtype=bool)
    fine_failed = np.asarray(fine.get("failed", [False]), dtype=bool)
    if failed.any() or fine_failed.any():
        note = shared_note + "a pilot run failed; the model's tolerance is kept"
        return model, ToleranceChoice(1.0, np.nan, runs, model.time_integration, note)
    error = 0.0
    for name in names:
        values = np.asarray(coarse[name], dtype=float).reshape(len(table), -1)
        scale = _band_scale(values[:-1])
        if scale is None:
            continue
        deviation = np.abs(values[-1] - np.asarray(fine[name], dtype=float).reshape(-1))
        error = max(error, float(np.max(deviation / scale)))
    target = TARGET_FRACTION * tolerance
    factor = 1.0 if error <= target else float((error / target) ** (1.0 / ERROR_ORDER))
    chosen = model.tightened(factor) if factor > 1.0 else model
    note = shared_note.removesuffix("; ")
    recipe = (factor,) if factor > 1.0 else ()
    return chosen, ToleranceChoice(
        factor, error, runs, chosen.time_integration, note, recipe=recipe
    )


def chosen_model(model: Any, modal: Mapping[str, np.ndarray], choice: ToleranceChoice) -> Any:
    """The model ``choice`` took, built again from ``model`` (the one :func:`choose_tolerance`
    was given) and the modal point's parameter columns ``modal``: on the modal sample's
    shared steps where the choice put the samples there, then tightened by the factors of
    ``choice.recipe`` in turn, as the choice built it (a resumed study takes a stored
    choice without its pilot, :mod:`fuzzymbs.study.judging_records`)."""
    if choice.shared_steps:
        model = model.share_steps(dict(modal))
    for factor in choice.recipe:
        model = model.tightened(factor)
    return model


def _reuses_fine(factor: float, fine: float) -> bool:
    """A factor near enough to the pilot's tighter model's (``fine``, ten) to take it."""
    return _near(factor, fine)


def _near(factor: float, built: float) -> bool:
    """A model built for ``built`` will do for ``factor``: at most REUSE_DECADES looser,
    or TIGHTER_REUSE_DECADES tighter than asked for."""
    decades = np.log10(built / factor)
    return -REUSE_DECADES <= decades <= TIGHTER_REUSE_DECADES


def _prepare(model: Any) -> None:
    """Start building the check's tighter model of ``model`` in the background."""
    prepare = getattr(model, "prepare_tightened", None)
    if callable(prepare):
        prepare()


def _prepared_model(shared: Any, factor: float, first: Mapping | None = None) -> Any:
    """``shared.tightened(factor)``, with the plan's ``first`` points run ahead and the
    check's tighter model started after them."""
    model = shared.tightened(factor)
    _ahead(model, first)
    return model


def _ahead(model: Any, first: Mapping | None) -> None:
    """Run the plan's ``first`` points on ``model`` in the background, then start the
    check's tighter model (one thread after the other: the reference runs beside them)."""
    run_ahead = getattr(model, "run_ahead", None)
    if first is None or not callable(run_ahead):
        _prepare(model)
        return
    run_ahead(first, lambda: _prepare(model))


def _relative_to(errors: Mapping[str, Any], scales: Mapping[str, np.ndarray]) -> float:
    """Largest common error (output -> (size,)) over its output's band scale."""
    largest = 0.0
    for name, scale in scales.items():
        if name in errors:
            common = np.asarray(errors[name], dtype=float).reshape(-1)
            largest = max(largest, float(np.max(common / scale)))
    return largest


def _band_scale(values: np.ndarray) -> np.ndarray | None:
    """max(w, 0.1 max w) of the corners' spread ``values`` (k, size); None if no width."""
    width = values.max(axis=0) - values.min(axis=0)
    widest = float(width.max())
    if not widest > 0:
        return None
    return np.maximum(width, WIDTH_FLOOR * widest)


def _choose_shared(
    shared: Any,
    columns: Callable[[np.ndarray], Mapping[str, np.ndarray]],
    corners: np.ndarray,
    names: Sequence[str],
    tolerance: float,
    first: np.ndarray | None = None,
) -> tuple[Any, ToleranceChoice]:
    """:func:`choose_tolerance` for a model on the modal sample's shared steps.

    The corners are compared as ``deviations`` (minus the modal sample on the same
    steps; the reference that corrects both alike drops out), so that the pilot runs
    while the reference runs do; their estimated error is waited for at the end.
    """
    fine_factor = tolerance_of(shared).tightening  # the pilot's tighter model's
    fine = shared.tightened(fine_factor)
    coarse_out = shared.deviations(dict(columns(corners)))
    fine_out = fine.deviations(dict(columns(corners)))
    runs = 2 * len(corners) + 4  # a logging run each and two reference runs
    failed = np.asarray(coarse_out.get("failed", np.zeros(len(corners), bool)), dtype=bool)
    failed |= np.asarray(fine_out.get("failed", np.zeros(len(corners), bool)), dtype=bool)
    if failed.any():
        note = "a pilot run failed; the model's tolerance is kept (on shared steps)"
        _ = shared.reference_error  # waits: a failed reference run raises here
        _prepare(shared)
        return shared, ToleranceChoice(
            1.0, np.nan, runs, shared.time_integration, note, shared_steps=True
        )
    error, scales = 0.0, {}
    for name in names:
        values = np.asarray(coarse_out[name], dtype=float).reshape(len(corners), -1)
        scale = _band_scale(values)
        if scale is None:
            continue
        scales[name] = scale
        tight = np.asarray(fine_out[name], dtype=float).reshape(len(corners), -1)
        error = max(error, float(np.max(np.abs(values - tight) / scale)))
    target = TARGET_FRACTION * tolerance

    def factor_for(budget: float) -> float:
        # between the pilot's two tolerances the error is not interpolated: on coarse
        # shared sequences it does not follow the law there (MIN_SHARED_FACTOR)
        if error <= budget:
            return 1.0
        return max(MIN_SHARED_FACTOR, float((error / budget) ** (1.0 / SHARED_ORDER)))

    # while the reference runs finish, the model for the reference error predicted from
    # the two modal logging runs (none: an exact reference) is built, the plan's first
    # points run on it, and the check's tighter model is started after them
    predict = getattr(shared, "predicted_reference_error", None)
    prediction = predict(fine) if callable(predict) else None
    predicted = _relative_to(prediction or {}, scales)
    likely = factor_for(max(target - PREDICTION_MARGIN * predicted, 0.5 * target))
    # where the tighter model's own tighter one takes the sequence the reference block
    # logs, a factor above the tighter model's is measured there before it is taken
    logged_ahead = getattr(fine, "logged_ahead", None)
    measurable = callable(logged_ahead) and bool(logged_ahead(fine_factor))
    speculative = ahead_on = None  # the model built ahead; the one running ahead
    first_columns = None if first is None or not len(first) else dict(columns(first))
    if _reuses_fine(likely, fine_factor) or (measurable and likely > 1.0):
        ahead_on = fine  # the pilot's tighter model will do, or is measured first
    elif likely > 1.0:
        speculative = Background(_prepared_model, shared, likely, first_columns)
    else:
        ahead_on = shared
    if ahead_on is not None:
        _ahead(ahead_on, first_columns)
    # waits for the reference runs
    reference_part = _relative_to(shared.reference_error or {}, scales)
    budget = max(target - reference_part, 0.5 * target)  # what the steps may add
    note = ""
    if reference_part > 0.5 * target:
        note = (
            f"the reference's own error ({100 * reference_part:.2g} % of the cut width) "
            "takes more than half the target"
        )
    factor = factor_for(budget)
    tighter, measured = None, float("nan")
    if measurable and factor > fine_factor and not _reuses_fine(factor, fine_factor):
        tighter, measured = _measured_error(fine, fine_factor, columns(corners), fine_out, scales)
        runs += len(corners)
        if np.isfinite(measured):  # the law from the pilot's tighter model, a decade on
            factor = fine_factor * max(1.0, measured / budget) ** (1.0 / SHARED_ORDER)
    built = int(speculative is not None)  # logging runs made for the choice
    if _reuses_fine(factor, fine_factor):
        factor, chosen = fine_factor, fine  # the pilot's tighter model: near enough
        recipe: tuple[float, ...] = (fine_factor,)
    elif tighter is not None and _near(factor, fine_factor**2):
        factor, chosen = fine_factor**2, tighter  # its sequence was logged ahead
        recipe = (fine_factor, fine_factor)
    elif speculative is not None and _near(factor, likely):
        factor, chosen = likely, speculative.result()  # near enough as well
        ahead_on = chosen
        recipe = (likely,)
    else:
        chosen = shared.tightened(factor) if factor > 1.0 else shared
        built += factor > 1.0
        recipe = (factor,) if factor > 1.0 else ()
    if chosen is not ahead_on:
        _prepare(chosen)  # the check's tighter model (the runs ahead start it after them)
    return chosen, ToleranceChoice(
        factor,
        error,
        runs + built,
        chosen.time_integration,
        note,
        shared_steps=True,
        reference_error=reference_part,
        reference_error_predicted=predicted if prediction is not None else float("nan"),
        measured_error=measured,
        recipe=recipe,
    )


def _measured_error(
    fine: Any,
    factor: float,
    corners: Mapping[str, np.ndarray],
    fine_out: Mapping[str, Any],
    scales: Mapping[str, np.ndarray],
) -> tuple[Any, float]:
    """``(fine.tightened(factor), E)``: the pilot's corners on the tighter model (the
    sequence its reference block logged ahead) and ``E``, the largest deviation of
    ``fine``'s corners from them over the band scale of the tighter corners (the
    coarse corners' spread holds the coarse error, a third of it on the brake's study
    2); NaN if a run failed."""
    tighter = fine.tightened(factor)
    tight_out = tighter.deviations(dict(corners))
    failed = np.asarray(tight_out.get("failed", np.zeros(1, bool)), dtype=bool)
    if failed.any():
        return tighter, float("nan")
    measured, count = 0.0, len(next(iter(corners.values())))
    for name in scales:
        values = np.asarray(fine_out[name], dtype=float).reshape(count, -1)
        tight = np.asarray(tight_out[name], dtype=float).reshape(count, -1)
        scale = _band_scale(tight)
        if scale is not None:
            measured = max(measured, float(np.max(np.abs(values - tight) / scale)))
    return tighter, measured
