"""The runs a study adds to its plan's: the screening of a ``nonmonotonic="auto"`` study,
the method check's validation runs, and the time integration's pilot and check.

:class:`StudyRuns` is a part of :class:`fuzzymbs.study.study.Study` (its base
class): the same object, its methods kept in a file of their own because each of
these runs is an idea of its own beside the plan's runs.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import logging
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from fuzzymbs.errors import (
    IncompleteResultError,
    StoreMismatchError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy.screening import nonmonotonic_parameters
from fuzzymbs.fuzzy.transform import Plan
from fuzzymbs.fuzzy.validation import (
    MethodSearch,
    ValidationPoints,
    default_validation_count,
    validation_points,
)
from fuzzymbs.study.execution import (
    DEFAULT_CHUNK_SIZE,
    LazyExecutor,
    assemble_chunks,
    check_run_settings,
    evaluate_chunks,
    progress_phase,
)
from fuzzymbs.study.gradients import assemble_gradients
from fuzzymbs.study.integration_check import (
    IntegrationCheck,
    check_time_integration,
    choose_samples,
    choose_tolerance,
    report_check,
    run_cut_bounds,
)
from fuzzymbs.study.judging_records import CHECK, CHOICE, DeferredModel, JudgingRecords
from fuzzymbs.study.method_check import ValidationRuns
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.study.planning import AUTO
from fuzzymbs.study.store import open_chunks
from fuzzymbs.study.streaming import (
    BACKLOG_CHUNKS,
    RAW_LIMIT_BYTES,
    ChunkFeed,
    integration_inputs,
)

__all__ = ["SCREENING_FOLDER", "VALIDATION_FOLDER", "StudyRuns", "TableRuns"]

logger = logging.getLogger("fuzzymbs.study.study")

#: sub-folder of a store holding the screening chunks of a ``nonmonotonic="auto"`` study
SCREENING_FOLDER = "screening"
#: prefix of the sub-folders of a store holding validation runs' chunks
#: (``validation-<count>-<fingerprint>``)
VALIDATION_FOLDER = "validation"


#: a fixed plan's samples run ahead while a shared-steps reference finishes (two SIMD
#: blocks: about what the core the pilot leaves free does meanwhile on the brake)
RUN_AHEAD = 8


#: a round of validation runs longer than a chunk goes out in a multiple of this many
#: equal chunks, so that no worker of a small pool idles at the end of the round
ROUND_TASKS = 4


def balanced_chunk_size(count: int, size: int) -> int:
    """Chunk size of a round of ``count`` validation runs: at most ``size``, in a multiple
    of :data:`ROUND_TASKS` equal chunks when more than one chunk is needed (the same on
    every executor, so the rounds and their points do not depend on it)."""
    if count <= size:
        return size
    tasks = ROUND_TASKS * math.ceil(math.ceil(count / size) / ROUND_TASKS)
    return math.ceil(count / tasks)


class TableRuns(NamedTuple):
    """The runs of a table of points (:meth:`StudyRuns.run_table`)."""

    #: ``{name: (N, ...)}`` in row order, NaN rows where a run failed
    outputs: dict[str, np.ndarray]
    #: (N,) which runs failed, and why ("" where none)
    failed: np.ndarray
    reasons: np.ndarray
    #: runs evaluated now, and read from the store
    evaluated: int
    reused: int
    #: ``{name: (N, *shape, len(wrt))}`` where the table was run with ``wrt``, else empty
    gradients: dict[str, np.ndarray]


class StudyRuns:
    """Screening, validation runs and the time integration's pilot and check of a
    :class:`~fuzzymbs.study.study.Study` (which defines the attributes used here)."""

    # set by Study.__init__ / Study.run
    model: Any
    name: str
    options: StudyOptions
    run: Callable[..., Any]  # Study.run: its keywords are screen's too
    #: the check's tighter model with re-runs made ahead (:meth:`StudyRuns.check_ahead`)
    _check_model: Any = None
    #: the judging runs' outcomes kept in the store of the run under way (none: no store)
    _records: JudgingRecords = JudgingRecords(None, False, {})

    @property
    def judging_from_store(self) -> list[str]:
        """The judging runs' outcomes the last run took from its store instead of making
        them (:mod:`fuzzymbs.study.judging_records`): ``"integration-choice"``,
        ``"integration-check"``; empty when it made them."""
        return sorted(self._records.taken)

    def _screening_identity(self) -> dict[str, Any]:
        """What a screening store must match: the screening points and the model.

        Not the tolerance: the decision is made again from the stored outputs.
        """
        screening = self._screening_samples
        digest = hashlib.sha256()
        description = {
            "names": list(screening.names),
            "levels": np.asarray(self._plan_levels()).tolist(),
            "parameters": {name: number.to_dict() for name, number in self._fuzzy.items()},
        }
        digest.update(json.dumps(description, sort_keys=True).encode())
        digest.update(np.ascontiguousarray(screening.samples, dtype="<f8").tobytes())
        return {"screening_fingerprint": digest.hexdigest(), **self.model_identity()}

    def _choose_integration(self, progress: bool = False) -> None:
        """Once per study: the model's integrator tolerance chosen for the cut widths
        (``progress``: a progress line while the pilot and reference runs go on)."""
        if not self.options.choose_integration or self.integration_choice is not None:
            return
        if not getattr(self.model, "scalable_tolerance", False):
            return  # choose_tolerance leaves such a model as it is, and records nothing
        plan = self.plan
        modal = plan.samples[plan.nominal_index]
        # everything the choice follows from (the identity: before the choice)
        description = {
            "identity": self.identity(),
            "integration_tolerance": self.options.integration_tolerance,
            "shared_steps": self.options.shared_steps,
            "outputs": list(self.output_names),
        }
        stored = self._records.load(CHOICE, description)
        if stored is not None:  # its model is built when a run needs it
            choice, extras = stored
            self.model = DeferredModel(
                self.model, self._columns(modal[None, :], 0, 1), choice, extras.get("identity")
            )
            self.integration_choice = choice
            logger.info(
                "study %s: integrator tolerance from the store: %s", self.name, choice.method
            )
            return
        label = f"{self.name} (integrator tolerance: pilot and reference runs)"
        with progress_phase(progress, label):
            self.model, self.integration_choice = choose_tolerance(
                self.model,
                lambda table: self._columns(table, 0, len(table)),
                plan.cut_lower,
                plan.cut_upper,
                modal,
                self.output_names,
                self.options.integration_tolerance,
                self.options.shared_steps,
                self._first_points(),
            )
        if self.integration_choice is not None:
            own = getattr(self.model, "identity", None)
            extras = {"identity": own() if callable(own) else None}
            self._records.save(CHOICE, description, self.integration_choice, extras)

    def _first_points(self) -> np.ndarray:
        """The plan's first runs (run ahead while a shared-steps reference finishes): the
        adaptive method's first round, or a fixed plan's first :data:`RUN_AHEAD` samples."""
        plan = self.plan
        if plan.scheme.runs_in_rounds:
            plan.reset()
            points = plan.next_batch()
            plan.reset()
            return points
        return plan.samples[:RUN_AHEAD]

    def validation_points(
        self,
        outputs: Mapping[str, np.ndarray] | None = None,
        failed: np.ndarray | None = None,
        *,
        tally: Callable[[int], np.ndarray] | None = None,
    ) -> ValidationPoints:
        """The first round of the study's validation points
        (:mod:`fuzzymbs.fuzzy.validation`: edge probes and Halton points, a quarter of
        :meth:`validation_count`), given the method's outputs (or, from a run, ``tally``:
        how often each sample bounds a level) and failed runs (without either: Halton
        points only). The later rounds depend on the outputs of the earlier ones."""
        count = self.validation_count()
        search = MethodSearch(self.plan, {}, count, outputs=outputs, failed=failed, tally=tally)
        points = search.next_round()
        return points if points is not None else validation_points(self.plan, 0)

    def validation_count(self) -> int:
        """The study's validation runs in all: ``validation_runs``, or the default
        (:func:`~fuzzymbs.fuzzy.validation.default_validation_count`); none for a method
        that certifies itself (``supports_validation`` False: adaptive)."""
        if not self.plan.scheme.supports_validation:
            return 0
        if self.options.validation_runs is not None:
            return self.options.validation_runs
        return default_validation_count(len(self.plan), len(self.plan.names))

    def _validate(
        self,
        work: LazyExecutor,
        feed: ChunkFeed,
        method_failed: np.ndarray,
        size: int,
        store: str | Path | None,
        resume: bool,
        progress: bool,
        code: dict[str, Any],
    ) -> ValidationRuns | None:
        """The method check in rounds (:class:`~fuzzymbs.fuzzy.validation.MethodSearch`):
        each round's chunks go to ``STORE/validation-<round>-<count>-<fingerprint>`` and
        are reduced as they arrive; None if off."""
        count = self.validation_count()
        if count == 0:
            return None
        try:
            fuzzy = feed.results()
        except IncompleteResultError:  # no level can be bounded: the run says so itself
            return None
        cuts = {name: (result.lower, result.upper) for name, result in fuzzy.items()}
        elements = sum(int(np.prod(np.shape(lo)[1:], dtype=np.int64)) for lo, _ in cuts.values())
        # kept whole as the plan's raw outputs are (a sparse plan keeps those always)
        keep = feed.keep_raw
        if keep is None:
            small = 8 * count * elements <= RAW_LIMIT_BYTES
            keep = small if feed.layout is None else feed.raw is not None and small
        bounds_from = feed.bounding_samples()
        search = MethodSearch(
            self.plan,
            cuts,
            count,
            bounds_from=bounds_from,
            outputs=feed.raw if bounds_from is None else None,
            tally=feed.bound_tally if bounds_from is not None else None,
            failed=method_failed,
            keep_outputs=bool(keep),
        )
        failed_parts: list[np.ndarray] = []
        reason_parts: list[np.ndarray] = []
        evaluated = reused = 0
        round_index = 0
        while (points := search.next_round()) is not None:
            digest = hashlib.sha256(np.ascontiguousarray(points.samples, dtype="<f8").tobytes())
            identity = {
                "validation_fingerprint": digest.hexdigest(),
                "plan_fingerprint": self.plan.fingerprint(),
                **self.model_identity(),
            }
            # a folder per round and set of points: other points start afresh
            folder = (
                f"{VALIDATION_FOLDER}-{round_index}-{count}-"
                f"{identity['validation_fingerprint'][:12]}"
            )
            failed, reasons, done, stored = self._stream_table(
                points.samples,
                identity,
                None if store is None else Path(store) / folder,
                (work, size, resume, progress, code),
                search.add,
                cuts,
            )
            failed_parts.append(failed)
            reason_parts.append(reasons)
            evaluated += done
            reused += stored
            round_index += 1
        outcome = search.outcome()
        failed = np.concatenate(failed_parts) if failed_parts else np.zeros(0, bool)
        reasons = np.concatenate(reason_parts) if reason_parts else np.zeros(0, str)
        logger.info(
            "study %s: %d validation runs in %d rounds (%d from the store, %d failed)",
            self.name,
            len(outcome.points),
            round_index,
            reused,
            int(np.count_nonzero(failed)),
        )
        return ValidationRuns(
            outcome.points,
            outcome,
            failed,
            reasons,
            self.options.method_tolerance,
            self.options.widen_with_validation,
            evaluated=int(evaluated),
            reused=int(reused),
        )

    def _stream_table(
        self,
        table: np.ndarray,
        identity: dict[str, Any],
        folder: Path | None,
        settings: tuple[LazyExecutor, int, bool, bool, dict[str, Any] | None],
        consume: Callable[[int, dict[str, np.ndarray]], None],
        shapes: Mapping[str, tuple[np.ndarray, np.ndarray]],
    ) -> tuple[np.ndarray, np.ndarray, int, int]:
        """Evaluate the rows of a table of validation points chunk by chunk into ``folder``
        and hand each chunk's outputs to ``consume(start, outputs)`` in row order (stored
        chunks are read when their turn comes): ``(failed, reasons, evaluated, reused)``.
        Only the chunks waiting for an earlier one are held."""
        work, size, resume, progress, code = settings
        count = len(table)
        chunk_store, size, chunk_count, results, missing, reused = open_chunks(
            folder, identity, count, balanced_chunk_size(count, size), resume, code, load=False
        )
        stored = set(results)  # read from the store when their turn comes
        failed = np.zeros(count, dtype=bool)
        reasons = np.full(count, "", dtype=object)
        waiting: dict[int, Any] = {}
        turn = [0]

        def take(chunk: Any) -> None:
            self._output_check.check(chunk, "the validation runs")
            self._adopt_coords([chunk])
            rows = slice(chunk.start, chunk.stop)
            failed[rows] = np.asarray(chunk.failed, dtype=bool)
            reasons[rows] = np.asarray(chunk.reasons, dtype=object)
            outputs = {}
            for name, (lower, _) in shapes.items():
                values = chunk.outputs.get(name) if chunk.outputs else None
                if values is None or chunk.failed.all():
                    values = np.full((chunk.size, *np.shape(lower)[1:]), np.nan)
                values = np.array(values, dtype=float)
                values[np.asarray(chunk.failed, dtype=bool)] = np.nan
                outputs[name] = values
            consume(chunk.start, outputs)

        def drain() -> None:
            while turn[0] < chunk_count:
                index = turn[0]
                if index in waiting:
                    chunk = waiting.pop(index)
                elif index in stored and chunk_store is not None:
                    chunk = chunk_store.read(index)
                    if chunk is None:
                        raise StoreMismatchError(
                            f"stored chunk {index} of {chunk_store.path} changed or vanished "
                            "while this run used it; rerun to evaluate it again"
                        )
                else:
                    return
                take(chunk)
                turn[0] += 1

        def arrived(index: int, chunk: Any) -> None:
            waiting[index] = chunk
            drain()

        drain()
        evaluated = self._evaluate_rows(
            table,
            (chunk_store, size, results, missing, reused),
            work,
            (progress, "validation"),
            fail_fast=None,
            on_chunk=arrived,
            may_submit=lambda: len(waiting) < BACKLOG_CHUNKS,
        )
        drain()
        return failed, reasons.astype(str), int(evaluated), int(reused)

    def _check_time_integration(
        self,
        feed: ChunkFeed,
        failed: np.ndarray,
        outputs: Mapping[str, np.ndarray] | None = None,
        progress: bool = False,
    ) -> IntegrationCheck | None:
        """The samples that give the bounds re-run by a time-integrated model at a tighter
        tolerance (:mod:`fuzzymbs.study.integration_check`); ``outputs`` (every run's, of
        a plan whose bounds are not its runs: the adaptive method) bound the cuts by the
        runs inside each box (:func:`~fuzzymbs.study.integration_check.run_cut_bounds`).
        Re-runs made ahead (:meth:`check_ahead`) are taken, not made again."""
        if not callable(getattr(self.model, "tightened", None)):
            return None
        include_nominal = not getattr(self.model, "shares_steps", False)
        if outputs is None:
            samples, bounds = integration_inputs(
                feed, self.output_names, failed, self.options.integration_runs, include_nominal
            )
        else:
            samples, bounds = self._run_check_inputs(outputs, failed, include_nominal)
        description = self._check_description(samples)
        stored = self._records.load(CHECK, description)
        if stored is not None:
            return report_check(stored[0])  # warns again where the run warned
        label = f"{self.name} (time-integration check: {len(samples)} samples, tolerance / 10)"
        tight, self._check_model = self._check_model, None
        with progress_phase(progress, label, len(samples)):
            check = check_time_integration(
                self.model,
                lambda rows: self._columns(self.plan.samples[rows], 0, len(rows)),
                samples,
                bounds,
                feed.nominal(),
                self.plan.nominal_index,
                self.plan.levels,
                self.options.integration_tolerance,
                tight=tight,
            )
        if check is not None:
            self._records.save(CHECK, description, check)
        return check

    def _check_description(self, samples: Sequence[int]) -> dict[str, Any]:
        """What the time-integration check of ``samples`` (rows of the plan) follows from:
        the study's identity (its runs' outputs follow from it) and the samples."""
        return {
            "identity": self.identity(),
            "integration_tolerance": self.options.integration_tolerance,
            "integration_runs": self.options.integration_runs,
            "outputs": list(self.output_names),
            "samples": np.asarray(self.plan.samples[list(samples)], dtype=float).tolist(),
        }

    def _run_check_inputs(
        self, outputs: Mapping[str, np.ndarray], failed: np.ndarray, include_nominal: bool
    ) -> tuple[list[int], dict[str, Any]]:
        """The check's samples and bounds of a plan bounded by its runs inside each cut box
        (``outputs``: every run's so far, in the plan's order)."""
        plan = self.plan
        tallies, run_bounds = run_cut_bounds(
            plan.samples, outputs, plan.cut_lower, plan.cut_upper, failed
        )
        samples = choose_samples(
            tallies, plan.nominal_index, failed, self.options.integration_runs, include_nominal
        )
        return samples, {name: run_bounds.get(name) for name in self.output_names}

    def check_ahead(self, outputs: Mapping[str, np.ndarray]) -> None:
        """Start the time-integration check's re-runs of the samples it would choose from
        the runs so far (``outputs``: every run's, in the plan's order; a plan in rounds
        after what is most likely its last) while the plan's method judges the runs
        (:meth:`_start_check`)."""
        if not getattr(self.model, "shares_steps", False):
            return
        failed = np.zeros(len(self.plan.samples), dtype=bool)
        samples, _ = self._run_check_inputs(outputs, failed, include_nominal=False)
        self._start_check(samples)

    def _start_check(self, samples: list[int]) -> None:
        """Run the time-integration check's re-runs of ``samples`` (rows of the plan) in the
        background on the check's tighter model, kept there: the check takes those it
        chooses in the end instead of running them again (a sample's outputs do not
        depend on its batch, so a kept run is bit for bit the run it saves). Only on
        shared steps (a tighter model with ``run_ahead``); a run ahead that the check does
        not choose is lost."""
        tightened = getattr(self.model, "tightened", None)
        if not samples or not getattr(self.model, "shares_steps", False) or not callable(tightened):
            return
        if self._records.load(CHECK, self._check_description(samples)) is not None:
            return  # the check of these samples is in the store
        tight = self._check_model if self._check_model is not None else tightened()
        run_ahead = getattr(tight, "run_ahead", None)
        if not callable(run_ahead):
            return
        self._check_model = tight
        run_ahead(self._columns(self.plan.samples[samples], 0, len(samples)))

    def screen(self, **settings: Any) -> dict[str, Any]:
        """Screen a ``nonmonotonic="auto"`` study and build its extended plan.

        :meth:`run` does this itself; call it to see the detected parameters
        (and the plan size) before running the plan. The model is evaluated
        at :func:`~fuzzymbs.fuzzy.screening.screening_samples` (with the
        crisp values of the study), chunk by chunk on ``executor``; with a
        ``store``, the chunks go to ``STORE/screening/`` and a rerun reuses
        them. Failed screening samples are left out of the decision (listed
        in the report), except with ``on_failure="fail-fast"``, which raises.
        A second call returns the first report.

        Parameters
        ----------
        **settings
            How to run, the keywords of :meth:`run` (``executor``, ``chunk_size``,
            ``store``, ``resume``, ``progress``, ``on_failure``, ``timeout``; one
            declaration for both), ``progress`` False unless given.

        Returns
        -------
        dict
            The report of :func:`~fuzzymbs.fuzzy.screening.nonmonotonic_parameters`
            plus ``evaluated``, ``reused_from_store``, ``failure_reasons``
            (row -> reason of excluded samples) and ``warnings``; also kept as
            :attr:`screening` and in the result's provenance.

        Raises
        ------
        UnsupportedOperationError
            The study does not use ``nonmonotonic="auto"``.
        IncompleteResultError
            Screening samples failed so that a parameter's axis keeps fewer than
            3 points (or with ``on_failure="fail-fast"``, any failed).
        StoreMismatchError
            ``STORE/screening`` holds the screening of a different study or code.
        """
        if not self.auto_nonmonotonic:
            raise UnsupportedOperationError(
                f"study {self.name!r} names its non-monotonic parameters (or uses method "
                f"{self.plan.method!r}); only a study with nonmonotonic={AUTO!r} is screened"
            )
        if self.screening is None:
            # run's keywords and defaults (a keyword run does not take: a TypeError naming it)
            bound = inspect.signature(self.run).bind(**{"progress": False, **settings})
            bound.apply_defaults()
            given = bound.arguments
            check_run_settings(given["on_failure"], given["chunk_size"], given["timeout"])
            size = DEFAULT_CHUNK_SIZE if given["chunk_size"] is None else int(given["chunk_size"])
            store = given["store"]
            code = self.code_version() if store is not None else None
            work = LazyExecutor(given["executor"], self._check_picklable, given["timeout"])
            try:
                settings = (work, size, given["resume"], given["progress"], code)
                self._screen(settings, store, given["on_failure"])
            finally:
                work.close()
        assert self.screening is not None
        return self.screening

    def _screen(
        self,
        settings: tuple[LazyExecutor, int, bool, bool, dict[str, Any] | None],
        store: str | Path | None,
        on_failure: str,
    ) -> None:
        """Evaluate the screening samples, decide, and build the extended plan
        (``settings``: executor, chunk size, resume, progress, code version)."""
        screening = self._screening_samples
        count = len(screening.samples)

        def stop_at_failure(failed: np.ndarray, reasons: np.ndarray) -> None:
            if failed.any():
                raise IncompleteResultError(
                    f"stopped early (fail-fast): screening of study {self.name!r}: "
                    + self._screening_failures(failed, reasons)
                )

        outputs, failed, reasons, evaluated, reused, _ = self.run_table(
            screening.samples,
            self._screening_identity(),
            None if store is None else Path(store) / SCREENING_FOLDER,
            ("screening", "the screening"),
            settings,
            stop_at_failure if on_failure == "fail-fast" else None,
        )
        logger.info(
            "study %s: screening for non-monotonic parameters, %d samples, %d from the store",
            self.name,
            count,
            reused,
        )
        if failed.all():
            raise IncompleteResultError(
                f"all {count} screening samples of study {self.name!r} failed; "
                f"first reason: {reasons[0]}"
            )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                report = nonmonotonic_parameters(
                    screening, outputs, self.options.screening_rtol, failed=failed
                )
            except IncompleteResultError as exc:
                raise IncompleteResultError(
                    f"screening of study {self.name!r}: {exc} "
                    + self._screening_failures(failed, reasons)
                ) from exc
        report["warnings"] = [str(w.message) for w in caught]
        for text in report["warnings"]:
            logger.warning("study %s: %s", self.name, text)
        report["failure_reasons"] = {
            str(row): str(reasons[row]) or "non-finite output" for row in report["excluded_samples"]
        }
        report["evaluated"] = int(evaluated)
        report["reused_from_store"] = int(reused)
        self._plan = Plan(
            self._fuzzy,
            method="extended",
            levels=self._levels,
            nonmonotonic=report["nonmonotonic"],
            max_runs=self.options.max_runs,
        )
        self.screening = report
        logger.info(
            "study %s: screening (%d runs) found non-monotonic parameters %s; extended plan "
            "of %d samples",
            self.name,
            count,
            report["nonmonotonic"],
            len(self._plan),
        )

    def run_table(
        self,
        table: np.ndarray,
        identity: dict[str, Any],
        folder: Path | None,
        labels: tuple[str, str],
        settings: tuple[LazyExecutor, int, bool, bool, dict[str, Any] | None],
        stop_at_failure: Callable[[np.ndarray, np.ndarray], None] | None = None,
        wrt: Sequence[str] = (),
    ) -> TableRuns:
        """Evaluate the rows of a parameter table (screening points, an adaptive round)
        chunk by chunk into ``folder``: outputs, failures, counts and, with ``wrt``, the
        model's gradients with respect to those parameters (stored with the chunks, so a
        resumed table gets them back too).

        ``labels``: the progress bar's and the output check's names of the runs;
        ``settings``: executor, chunk size, resume, progress, code version;
        ``stop_at_failure(failed, reasons)``: called after every chunk (fail-fast).
        """
        work, size, resume, progress, code = settings
        count = len(table)
        chunk_store, size, chunk_count, results, missing, reused = open_chunks(
            folder, identity, count, size, resume, code
        )
        fail_fast = None
        if stop_at_failure is not None:

            def fail_fast() -> None:
                ready = [results[i] for i in sorted(results)]
                stop_at_failure(*assemble_chunks(ready, count)[1:])

            if results:
                fail_fast()
        evaluated = self._evaluate_rows(
            table,
            (chunk_store, size, results, missing, reused),
            work,
            (progress, labels[0]),
            fail_fast=fail_fast,
            wrt=tuple(wrt),
        )
        ordered = [results[i] for i in range(chunk_count)]
        outputs, failed, reasons = assemble_chunks(ordered, count, self._output_check, labels[1])
        self._adopt_coords(ordered)
        gradients = assemble_gradients(ordered, count, wrt) if wrt else {}
        return TableRuns(outputs, failed, reasons, int(evaluated), int(reused), gradients)

    def _evaluate_rows(
        self,
        table: np.ndarray,
        chunks: tuple[Any, int, dict[int, Any], list[int], int],
        work: LazyExecutor,
        shown: tuple[bool, str | None],
        **hooks: Any,
    ) -> int:
        """Evaluate the missing chunks of a parameter table (the plan's samples, screening
        or validation points) on ``work``: :func:`~fuzzymbs.study.execution.evaluate_chunks`
        with the study's model, outputs and columns; returns how many were evaluated.

        ``chunks``: the store, chunk size, chunks at hand, missing chunks and those reused
        (from :func:`~fuzzymbs.study.store.open_chunks`); ``shown``: a progress bar and its
        label; ``hooks``: ``fail_fast``, ``on_chunk``, ``may_submit``, ``wrt``.
        """
        chunk_store, size, results, missing, reused = chunks
        progress, label = shown
        name = self.name if label is None else f"{self.name} ({label})"
        return evaluate_chunks(
            self.model,
            self.outputs,
            lambda start, stop: self._columns(table, start, stop),
            len(table),
            missing,
            size,
            results,
            chunk_store,
            work,
            progress=(progress, reused, name),
            **hooks,
        )

    def _screening_failures(self, failed: np.ndarray, reasons: np.ndarray) -> str:
        """E.g. "failed screening samples: row 3 (x1=1.5): diverged; ..." (first five)."""
        rows = np.flatnonzero(failed)
        samples = self._screening_samples.samples
        listed = "; ".join(
            f"row {row} ("
            + ", ".join(f"{n}={v:.6g}" for n, v in zip(self._fuzzy, samples[row], strict=True))
            + f"): {reasons[row] or 'non-finite output'}"
            for row in rows[:5]
        )
        more = f" (and {len(rows) - 5} more)" if len(rows) > 5 else ""
        return f"failed screening samples: {listed}{more}"
