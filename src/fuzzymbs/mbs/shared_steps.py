"""One step sequence for every sample of a study, and the modal sample's error removed.

A fuzzy band is read on its width, and with a +-1 % parameter the brake's cuts
are a few tenths of a per cent of the signal's peak wide. With each sample on
its own adaptive step sequence, the integration error varies from sample to
sample like noise (the steps jump where the error estimate crosses 1), and the
bands only settle once that noise is far below the cut width: rtol 1.7e-5
for the brake's study 1 (docs/brake.md).

Here every sample takes the step sequence of the modal sample instead (its
accepted steps at the model's rtol, logged once, and where it renewed its
Jacobian), so that the integration
error is a smooth function of the parameters, ``e(p) ~ e(p0) + e'(p0) (p -
p0)``. Its common part ``e(p0)`` is the modal sample's own error: the modal
sample is integrated once more at a tight reference tolerance, and the
difference, the correction ``c(t) = y_ref(p0, t) - y(p0, t)``, is added to
every sample's outputs (a control variate: the modal sample's outputs become
the reference's, the others keep only the error's variation across the cut).
On the brake's study 1, the 33 runs on the modal sample's steps at rtol 1e-3,
corrected with a converged reference, give bands within 0.37 % of their
width of the rtol 1e-6 bands, against 21 % with a sequence of their own at the
same rtol (docs/brake.md, "Bands above the numerical noise").

The logging run itself stands for the modal sample's run on the sequence: every
sample renews its Jacobian where the logging run did (after a rejected try, as
well as by age), so the replay repeats the logging run's arithmetic to the
rounding of the step lengths (the brake over 10 ms at rtol 1e-2: 4e-12 of the
pads' peak, 1e-7 of the caliper's; without the renewals 5e-4 and 948 rejected
steps), and no replay is run: a study's modal sample takes the logging run.

Runs on the sequence are kept for reuse where a study makes them before its plan:
the pilot that chooses the tolerance runs the corners of a cut through
``deviations``, and when its model becomes the study's, the plan takes those
runs instead of repeating them (the brake's study 1: the 8 corners of the mu =
0.75 cut, all of them plan points). A sample's outputs do not depend on its
batch, so a kept run is bit for bit the run it saves.

The error control still guards every step: a step it rejects is cut into the
sample's own smaller steps up to the next point of the sequence, so a sample
leaves the sequence only where the sequence is too coarse for it. A sample's
outputs depend on the modal point and the settings alone, never on the samples
that share its batch.

The reference is the modal sample's runs at :data:`REFERENCE_RTOL` and ten
times it (the model tolerance's ``tightening``, :class:`fuzzymbs.tolerance.Tolerance`),
extrapolated with the error law ``e(r) = C r^q`` (q =
:data:`REFERENCE_ORDER`, measured over rtol 1e-2 to 1e-5 on the brake):
``y_ref = y(r) + (y(r) - y(10 r)) / (10^q - 1)``. On the brake's studies it is
as accurate as one run at a tenth of ``r`` that costs twice as much (against
the modal sample at rtol 1e-7: 0.050 % and 0.26 % of study 1's and study 2's
cut widths, the run at rtol 1e-6 0.050 % and 0.27 %; docs/brake.md). Its
error enters every sample alike; it is estimated as that of the run a decade
tighter, ``|y(r) - y(10 r)| / ((10^q - 1) 10^q)`` (0.052 % and 0.26 %), and a
study adds it to its time-integration error.

The reference runs are the longest runs of a study (the brake's 10 ms at rtol
1e-5 and 1e-4, lanes of one SIMD block: 18.5 s of one core alone, the run at
1e-6 it replaces 31.3 s; benchmarks/reference_extrapolation.py). They run in
a background thread from :func:`share_steps` on, while the caller goes on with what does
not need them: :meth:`SimulationModel.deviations` (a sample's outputs minus the
modal sample's on the same steps, all a study's choice of tolerance compares)
and further step sequences (:meth:`SimulationModel.tightened`). The correction,
the reference and its error wait for them when first asked for.

The block's first lanes log the modal sample at the model's tolerance tightened
twice and three times (:func:`ahead_tolerances`; a lane costs nothing beside the
reference's; at the brake's rtol 1e-2 they are the two reference runs themselves):
the logging runs of the step sequences a study's choice and its check most likely
take (its pilot's model at a tenth, tightened once more; a choice of a hundredth,
tightened once more). A sequence asked for at exactly one of those tolerances (the
same settings, :meth:`SimulationModel.tightened`) takes it instead of a logging run
of its own; its outputs are bit for bit those of that run (each lane on its own
steps).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.background import Background
from fuzzymbs.errors import InvalidParameterError, SimulationDivergedError
from fuzzymbs.mbs.simulate_checks import samples_per_block
from fuzzymbs.tolerance import Tolerance, tolerance_of


class SimulationModel(Protocol):
    """What this module needs of a :class:`~fuzzymbs.mbs.integrate.SimulationModel` (a
    protocol, so that integrate, which uses this module, is not imported here)."""

    settings: dict[str, Any]
    outputs: dict[str, Any]
    shared: SharedSteps | None
    compiled: Any

    def simulate(self, samples: Mapping[str, NDArray[np.float64]], **overrides: Any) -> Any: ...


__all__ = [
    "REFERENCE_EQUIVALENT_RTOL",
    "REFERENCE_ORDER",
    "REFERENCE_RTOL",
    "KeptRun",
    "SharedSteps",
    "ahead_tolerance",
    "ahead_tolerances",
    "checked_renewals",
    "checked_sequence",
    "kept_run",
    "logged_steps",
    "predicted_reference_error",
    "share_steps",
]

#: tolerance of the tighter of the modal sample's two reference runs (the other at the
#: model tolerance's tightening, ten, times it); their extrapolation is the reference
REFERENCE_RTOL = 1e-5
#: the one-run tolerance the extrapolated reference's error is estimated as (a decade
#: tighter: on the brake's studies as accurate as that run, docs/brake.md)
REFERENCE_EQUIVALENT_RTOL = REFERENCE_RTOL / 10
#: ROS34PW2's global error falls about as rtol^0.88 with a sequence of its own
#: (brake studies, rtol 1e-2 to 1e-5, docs/brake.md)
REFERENCE_ORDER = 0.88
#: longest log of the run logged ahead (its modal sample's accepted steps)
_AHEAD_CAPACITY = 10**6


@dataclass(frozen=True, eq=False)
class SharedSteps:
    """What the samples of a :class:`~fuzzymbs.mbs.integrate.SimulationModel` share.

    Attributes
    ----------
    modal : the modal sample, ``{parameter: value}``.
    sequence : (K,) the ends of the modal sample's accepted steps [s].
    renewals : (K,) True where the modal sample's step took a fresh Jacobian at its
        start (every sample renews there too).
    modal_outputs : output -> (T,) the modal sample on these steps (the logging run).
    references : the reference runs' ``(reference, reference_error, logged_ahead)``,
        perhaps still running (:class:`Background`); ``logged_ahead`` maps ``(rtol,
        atol)`` of each lane logged ahead (one that failed left out) to its logging
        run (a one-sample ``SimulationResult``).
    reference_rtol : the tighter reference run's tolerance (the other at the tolerance's
        tightening times it).
    kept : runs on these steps at the model's settings, kept for reuse: the parameter
        row's bytes -> :class:`KeptRun` (the logging run for the modal sample; the runs
        of :meth:`~fuzzymbs.mbs.integrate.SimulationModel.deviations`, a study's pilot).
    ahead : the tolerances of the runs logged ahead in the references' block (empty:
        none); a tightened model at exactly one of them takes its run.
    jacobians : the logging run's Jacobians (``jacobian_log`` of
        :func:`~fuzzymbs.mbs.integrate.simulate`), which every sample takes where it
        renews its own at a point of the sequence (ROS34PW2; None: a sequence logged
        ahead in a later lane of the references' block than the first, or RODAS4, whose
        order needs its own).
    """

    modal: dict[str, float]
    sequence: NDArray[np.float64]
    renewals: NDArray[np.bool_]
    modal_outputs: dict[str, NDArray[np.float64]]
    references: Background[tuple[dict, dict, Any]]
    reference_rtol: float
    kept: dict[bytes, KeptRun] = field(default_factory=dict, repr=False)
    ahead: tuple[Tolerance, ...] = ()
    jacobians: tuple[NDArray[np.float64], NDArray[np.float64]] | None = field(
        default=None, repr=False
    )

    @property
    def reference(self) -> dict[str, NDArray[np.float64]]:
        """output -> (T,) the modal sample extrapolated from its runs at ``reference_rtol``
        and ten times it (waits for them)."""
        return self.references.result()[0]

    @property
    def reference_error(self) -> dict[str, NDArray[np.float64]]:
        """output -> (T,) the reference's estimated error (waits for its runs)."""
        return self.references.result()[1]

    @property
    def correction(self) -> dict[str, NDArray[np.float64]]:
        """output -> (T,) added to every sample's output: reference - modal."""
        reference = self.reference
        return {name: reference[name] - values for name, values in self.modal_outputs.items()}


@dataclass(frozen=True)
class KeptRun:
    """One sample's run on a shared sequence, kept for reuse: a sample's outputs do not
    depend on the samples that share its batch, so the kept run is the run it saves."""

    outputs: dict[str, NDArray[np.float64]]
    failed: bool
    failure_reason: str
    failure_time: float
    step_counts: NDArray[np.int64]
    #: the outputs' derivatives (T, P) when the run integrated sensitivities, else empty
    gradients: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    #: the parameters of ``gradients``' last axis
    gradient_parameters: tuple[str, ...] = ()

    def has_gradients(self, names: tuple[str, ...]) -> bool:
        """True when the run holds the outputs' derivatives with respect to ``names``."""
        return set(names) <= set(self.gradient_parameters)

    def gradients_for(self, names: tuple[str, ...]) -> dict[str, NDArray[np.float64]]:
        """The outputs' derivatives (T, len(names)), the last axis in ``names``' order."""
        columns = [self.gradient_parameters.index(name) for name in names]
        return {output: values[:, columns] for output, values in self.gradients.items()}


def kept_run(result, row: int) -> KeptRun:
    """Sample ``row`` of a :class:`~fuzzymbs.mbs.integrate.SimulationResult` (with its
    outputs' derivatives, if it has them)."""
    gradients = result.gradients or {}
    return KeptRun(
        {name: values[row].copy() for name, values in result.outputs.items()},
        bool(result.failed[row]),
        str(result.failure_reason[row]),
        float(result.failure_time[row]),
        np.asarray(result.step_counts[row]).copy(),
        {name: values[row].copy() for name, values in gradients.items()},
        tuple(result.gradient_parameters) if gradients else (),
    )


def logged_steps(step_log: NDArray[np.float64]) -> NDArray[np.float64]:
    """(count, 2): the logged steps' ends and their Jacobian flags."""
    count = int(step_log[0])
    if count < 0:
        raise InvalidParameterError(
            f"log_steps: more than {(step_log.size - 1) // 2} steps, more than the log holds"
        )
    return step_log[1 : 1 + 2 * count].reshape(count, 2)


def checked_renewals(
    renewals: NDArray[np.bool_] | None, sequence: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The Jacobian flags of a shared sequence as the kernel takes them (empty: none)."""
    if renewals is None:
        return np.empty(0)
    flags = np.asarray(renewals)
    if sequence.size == 0:
        raise InvalidParameterError("jacobian_renewals needs a step_sequence")
    if flags.dtype != np.bool_ or flags.shape != sequence.shape:
        raise InvalidParameterError(
            f"jacobian_renewals must be a bool array of the step_sequence's length "
            f"{sequence.size}, got {flags.dtype} of shape {flags.shape}"
        )
    return flags.astype(float)


def checked_sequence(
    sequence: NDArray[np.float64] | None, adaptive: bool, t_end: float
) -> NDArray[np.float64]:
    """The shared step sequence as the kernel takes it (empty: no sequence); ``adaptive``:
    the integrator is a Rosenbrock method (RK4 takes no sequence)."""
    if sequence is None:
        return np.empty(0)
    if not adaptive:
        raise InvalidParameterError("step_sequence needs an integrator of ('ros34pw2', 'rodas4')")
    points = np.asarray(sequence, dtype=float)
    if points.ndim != 1 or points.size == 0 or not np.all(np.isfinite(points)):
        raise InvalidParameterError("step_sequence must be a non-empty 1-D array of finite times")
    if points[0] <= 0.0 or np.any(np.diff(points) <= 0.0):
        raise InvalidParameterError("step_sequence must increase from above t = 0")
    if abs(points[-1] - t_end) > 1e-9 * t_end:
        raise InvalidParameterError(
            f"step_sequence must end at t_end = {t_end} s, got {points[-1]!r}"
        )
    points = np.ascontiguousarray(points)
    points[-1] = t_end  # the kernel's final time, exactly
    return points


def predicted_reference_error(
    coarse: SharedSteps, coarse_rtol: float, fine: SharedSteps, fine_rtol: float
) -> dict[str, NDArray[np.float64]]:
    """output -> (T,) the reference's error predicted from the modal sample's logging
    runs at two tolerances, before the reference has run: with ``e(r) = C r^q`` (q =
    :data:`REFERENCE_ORDER`), ``e(coarse) = |y(coarse) - y(fine)| / (1 - (fine /
    coarse)^q)``, scaled to the tolerance the reference's error is estimated as
    (:data:`REFERENCE_EQUIVALENT_RTOL`, a tenth of ``reference_rtol``). On the brake
    (10 ms, rtol 1e-2 and 1e-3) it predicts 0.049 % / 0.21 % of study 1's / study 2's
    cut widths, against 0.052 % / 0.29 % estimated from reference runs at rtol 1e-6
    and 1e-5."""
    q = REFERENCE_ORDER
    ratio = fine_rtol / coarse_rtol
    equivalent = coarse.reference_rtol * (REFERENCE_EQUIVALENT_RTOL / REFERENCE_RTOL)
    scale = (equivalent / coarse_rtol) ** q / (1.0 - ratio**q)
    return {
        name: np.abs(values - fine.modal_outputs[name]) * scale
        for name, values in coarse.modal_outputs.items()
        if name in fine.modal_outputs
    }


def _single(modal: Mapping[str, float]) -> dict[str, NDArray[np.float64]]:
    return {name: np.array([float(value)]) for name, value in modal.items()}


def _failure(result, row: int, modal: Mapping[str, float], what: str) -> None:
    """Raises if sample ``row`` of ``result`` failed."""
    if result.failed[row]:
        raise SimulationDivergedError(
            f"shared steps: the modal sample {dict(modal)} failed {what}"
            f"({result.failure_reason[row]} at t = {result.failure_time[row]:g} s)"
        )


def _run(model: SimulationModel, modal: Mapping[str, float], **extra):
    """The modal sample alone, with ``extra`` settings; raises if it fails."""
    result = model.simulate(_single(modal), **extra)
    _failure(result, 0, modal, "")
    return result


def ahead_tolerance(tolerance: Tolerance) -> Tolerance:
    """The tolerance of the step sequence logged beside the reference runs: ``tolerance``
    tightened twice by its ``tightening``. A study's choice tightens the model's tolerance
    that much or more (:data:`fuzzymbs.study.integration_check.MIN_SHARED_FACTOR`; the
    brake's study 1 takes 10) and its check as much again, divided in this order, as
    :meth:`~fuzzymbs.mbs.integrate.SimulationModel.tightened` divides it."""
    return tolerance.tightened().tightened()


def ahead_tolerances(tolerance: Tolerance) -> tuple[Tolerance, ...]:
    """The tolerances logged ahead beside the reference runs: :func:`ahead_tolerance`
    and, unless tighter than :data:`REFERENCE_RTOL` (a lane the block would wait for),
    that tightened once more (divided as
    :meth:`~fuzzymbs.mbs.integrate.SimulationModel.tightened` divides it)."""
    twice = ahead_tolerance(tolerance)
    thrice = twice.tightened()
    return (twice,) if thrice.rtol < REFERENCE_RTOL else (twice, thrice)


def _reference_runs(
    model: SimulationModel,
    modal: Mapping[str, float],
    ahead: tuple[Tolerance, ...] = (),
) -> tuple[dict, dict, dict]:
    """The reference (the modal sample's runs at :data:`REFERENCE_RTOL` and the
    tolerance's tightening times it, extrapolated), its estimated error, output -> (T,),
    and the modal sample's logging runs at the tolerances ``ahead``, ``(rtol, atol)`` ->
    a one-sample result (left out: a run that failed or whose log overflowed; all, and
    the block run again without logs: the first lane's log overflowed).

    The runs are lanes of one block, each with its own tolerance and steps (its outputs
    bit for bit those of the run alone): the block costs about as much as the tightest
    run alone. A run logged ahead is a reference run when their tolerances agree (the
    brake's rtol 1e-2: both, at 1e-4 and 1e-5).
    """
    tolerance = model.settings["tolerance"]
    rtol, atol = tolerance.rtol, tolerance.atol  # atol None: a fraction
    tolerances = (REFERENCE_RTOL, tolerance.tightening * REFERENCE_RTOL)
    references = [(r, None if atol is None else atol * r / rtol) for r in tolerances]
    logged = [
        (t.rtol, t.atol) for t in ahead if (t.atol is None) == (atol is None)
    ]  # of this model's kind
    logged = logged[: samples_per_block(model.settings.get("kernel", "auto"))]
    # first: the kernel logs the first samples' steps
    lanes = logged + [lane for lane in references if lane not in logged]
    rows = tuple(lanes.index(lane) for lane in references)
    rtols = np.array([lane[0] for lane in lanes])
    atols = None if atol is None else np.array([lane[1] for lane in lanes])
    try:
        runs = model.simulate(
            _copies(modal, len(lanes)),
            tolerance=replace(tolerance, rtol=rtols, atol=atols),
            log_steps=_AHEAD_CAPACITY if logged else False,
            log_samples=max(len(logged), 1),
            # the first lane's Jacobians too, for the model that takes its sequence
            log_jacobians=bool(logged) and model.settings["integrator"] == "ros34pw2",
        )
    except InvalidParameterError:  # the first lane's log overflowed: the references alone
        if not logged:
            raise
        return _reference_runs(model, modal)
    runs_ahead = {
        lane: _logged_lane(runs, row)
        for row, lane in enumerate(logged)
        if not runs.failed[row] and runs.step_logs[row] is not None
    }
    return (*_extrapolated(model, modal, runs, rows), runs_ahead)


def _logged_lane(runs, row: int):
    """Sample ``row`` of a run with ``log_samples`` above it, as a one-sample run whose
    ``step_times`` and ``step_renewals`` are its own."""
    times, renewals = runs.step_logs[row]
    one = slice(row, row + 1)
    return replace(
        runs,
        outputs={name: values[one] for name, values in runs.outputs.items()},
        failed=runs.failed[one],
        failure_reason=runs.failure_reason[one],
        failure_time=runs.failure_time[one],
        step_counts=runs.step_counts[one],
        step_times=times,
        step_renewals=renewals,
        step_logs=[(times, renewals)],
        work_counts=None if runs.work_counts is None else runs.work_counts[one],
        jacobian_log=runs.jacobian_log if row == 0 else None,  # the first lane's alone
    )


def _copies(modal: Mapping[str, float], count: int) -> dict[str, NDArray[np.float64]]:
    return {name: np.array([float(value)] * count) for name, value in modal.items()}


def _extrapolated(
    model: SimulationModel, modal: Mapping[str, float], runs, rows, order: float = REFERENCE_ORDER
):
    """``(reference, error)`` from the rows ``rows = (tight, loose)`` of ``runs`` (at
    REFERENCE_RTOL and k = the model tolerance's tightening times it):
    ``y(r) + (y(r) - y(k r)) / (k^q - 1)`` and ``|y(r) - y(k r)| / ((k^q - 1) k^q)``,
    q = ``order``; raises if either run failed."""
    tight, loose = rows
    ratio = tolerance_of(model).tightening
    _failure(runs, tight, modal, f"at rtol {REFERENCE_RTOL:g} ")
    _failure(runs, loose, modal, f"at rtol {ratio * REFERENCE_RTOL:g} ")
    gain = ratio**order
    reference, error = {}, {}
    for name in model.outputs:
        step = runs.outputs[name][tight] - runs.outputs[name][loose]
        reference[name] = runs.outputs[name][tight] + step / (gain - 1.0)
        error[name] = np.abs(step) / ((gain - 1.0) * gain)
    return reference, error


def _logged_run(model: SimulationModel, modal: Mapping[str, float]):
    """The modal sample at the model's own tolerance, its accepted steps logged."""
    capacity = 10**6
    log_jacobians = model.settings["integrator"] == "ros34pw2"  # a W-method
    while True:  # a log as long as the modal sample's steps need
        try:
            return _run(model, modal, log_steps=capacity, log_jacobians=log_jacobians)
        except InvalidParameterError:
            if capacity >= 10**9:
                raise
            capacity *= 8


def share_steps(
    model: SimulationModel,
    modal: Mapping[str, float],
    references: Background[tuple[dict, dict, Any]] | None = None,
    ahead: tuple[Tolerance, ...] = (),
) -> SimulationModel:
    """``model`` with every sample on the modal sample's step sequence, corrected.

    Parameters
    ----------
    model : a ROS34PW2 :class:`~fuzzymbs.mbs.integrate.SimulationModel`.
    modal : the modal sample, ``{parameter: value}`` (names of the model's system).
    references : the reference runs of an earlier call (a tightened model keeps its
        reference); default: started here in the background, at
        :data:`REFERENCE_RTOL` and the tolerance's tightening times it, with the modal
        sample logged at :func:`ahead_tolerances` in the same block.
    ahead : with ``references``: the tolerances they log ahead at; a model at exactly
        one of them takes that run (waiting for the block) instead of its own.

    Returns
    -------
    SimulationModel
        A copy whose ``shared`` holds the sequence and the correction.

    Raises
    ------
    SimulationDivergedError
        If the modal sample fails at the model's tolerance; a failure of a reference
        run is raised where the correction or the reference's error is first used.
    """
    if model.settings["integrator"] not in ("ros34pw2", "rodas4"):
        raise InvalidParameterError("shared steps need integrator='ros34pw2' or 'rodas4'")
    plain = copy.copy(model)
    plain.shared = None
    # every bound parameter named (the unnamed at their defaults): the reference block
    # runs the modal sample twice, which needs columns to repeat
    modal = {
        **plain.compiled.parameters.defaults(),
        **{name: float(value) for name, value in modal.items()},
    }
    tolerance = plain.settings["tolerance"]
    logged = None
    if references is None:
        ahead = ahead_tolerances(tolerance)
        references = Background(_reference_runs, plain, modal, ahead)
    elif any((tolerance.rtol, tolerance.atol) == (t.rtol, t.atol) for t in ahead):
        # none: the lane failed or the log overflowed; run it here
        logged = references.result()[2].get((tolerance.rtol, tolerance.atol))
    if logged is None:
        logged = _logged_run(plain, modal)
    # the logging run stands for the modal sample's replay: with the logged Jacobian
    # renewals the replay repeats its arithmetic (to the rounding of the step lengths)
    outputs = {name: logged.outputs[name][0] for name in model.outputs}
    shared = copy.copy(plain)
    shared.shared = SharedSteps(
        modal,
        logged.step_times,
        logged.step_renewals,
        outputs,
        references,
        REFERENCE_RTOL,
        ahead=ahead,
        jacobians=logged.jacobian_log,
    )
    # and a study's modal sample takes it (its outputs become the reference's)
    modal_row = model.compiled.parameters.values(_single(modal))[0]
    shared.shared.kept[modal_row.tobytes()] = kept_run(logged, 0)
    return shared
