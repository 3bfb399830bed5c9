"""Study: a model, fuzzy parameters and a transformation method, run chunk by chunk.

The only place where the fuzzy engine and a model meet::

    study = Study("product", {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)})
    result = study.run()                 # -> StudyResult (xarray.Dataset inside)
    result.dataset["z_lower"]            # alpha-cut bounds per level

With ``method="extended", nonmonotonic="auto"`` the study first evaluates the
screening of :mod:`fuzzymbs.fuzzy.screening` (every parameter's axis through
the modal point) with the same model, executor and store, and builds the
extended plan with the parameters found non-monotonic.

:class:`Study` holds a study's state and runs its steps; each step has a
module of its own: :mod:`~fuzzymbs.study.planning` (model, parameters,
outputs, plan), :mod:`~fuzzymbs.study.execution` and
:mod:`~fuzzymbs.study.evaluation` (chunks on an executor; one chunk on a
worker), :mod:`~fuzzymbs.study.result` (retransformation into the result
dataset) and :mod:`~fuzzymbs.study.store` (the chunk store for resume).
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidParameterError,
    ModelOutputError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy.methods import Method
from fuzzymbs.fuzzy.methods.adaptive import AdaptiveWarning
from fuzzymbs.fuzzy.transform import Plan, make_levels
from fuzzymbs.study.adaptive_rounds import run_rounds
from fuzzymbs.study.code_version import code_version
from fuzzymbs.study.evaluation import ChunkResult, OutputCheck, merged_coords
from fuzzymbs.study.execution import (
    DEFAULT_CHUNK_SIZE,
    ON_FAILURE,
    LazyExecutor,
    check_run_settings,
)
from fuzzymbs.study.extra_runs import StudyRuns
from fuzzymbs.study.gradients import gradient_parameters
from fuzzymbs.study.integration_check import ToleranceChoice
from fuzzymbs.study.judging_records import JudgingRecords
from fuzzymbs.study.method_check import DEFAULT_METHOD_TOLERANCE
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.study.planning import (
    AUTO,
    build_plan,
    checked_outputs,
    declared_parameters,
    is_method_option,
    resolve_model,
    split_parameters,
)
from fuzzymbs.study.registry import ParameterInfo
from fuzzymbs.study.result import (
    StudyResult,
    build_dataset,
    check_output_names,
    import_result_modules,
)
from fuzzymbs.study.store import open_chunks
from fuzzymbs.study.streaming import ChunkFeed, integration_inputs

__all__ = ["DEFAULT_CHUNK_SIZE", "ON_FAILURE", "Study", "StudyOptions", "StudyResult"]

logger = logging.getLogger(__name__)


class Study(StudyRuns):
    """A fuzzy study: model + fuzzy parameters + transformation method.

    Parameters
    ----------
    model : str or callable
        A registered model name (see ``fuzzymbs info``), a reference
        ``"package.module:callable"`` to a factory, or a batched model itself
        (``model({name: (B,) array}) -> {output: (B, ...) array}``).
    parameters : mapping
        Parameter name -> :class:`~fuzzymbs.fuzzy.numbers.FuzzyNumber`, a
        study-file definition such as ``{"type": "triangular", "modal": 2e5,
        "spread": 0.1}``, or a plain number (a crisp value overriding the default).
    method : {"general", "reduced", "extended", "grid", "sparse", "adaptive"} or Method
        Transformation method, by name or as a method object of
        :mod:`fuzzymbs.fuzzy.methods` holding its own options (e.g.
        ``Sparse(sparse_level=2)``; then ``sparse_level`` and ``search_points`` are not
        given here). ``"adaptive"`` refines a surrogate of every output in
        rounds until its certified error is at most ``method_tolerance``
        (:mod:`fuzzymbs.fuzzy.adaptive`); each round runs through the executor and,
        with a store, into ``STORE/adaptive-<round>-<fingerprint>/``. Its
        certification is its method check: no validation runs are made.
    levels : int or sequence of float
        Number of alpha levels m (mu_j = j/m) or explicit levels from 0 to 1.
    outputs : sequence of str, optional
        Subset of the model outputs to keep (default: all).
    model_options : mapping, optional
        Keyword options for the model factory (registered or referenced models).
    nonmonotonic : sequence of str or "auto", optional
        Parameters that get interior points (method "extended"). ``"auto"``:
        find them by a screening run before the plan is built (see
        :meth:`screen`); the plan is then known only after :meth:`screen` or
        :meth:`run`. A parameter literally named "auto" is given as ``["auto"]``.
    options : StudyOptions, optional
        The study's own options (:class:`~fuzzymbs.study.options.StudyOptions`: the
        checks of its time integration and of its method, the screening tolerance, the
        run limit), all defaults if not given.
    **given
        Options by name, replacing those of ``options``: any study option
        (``validation_runs=0``, ``integration_tolerance=0.005``, ``max_runs=None``,
        ...; ``fuzzymbs info`` lists them) or an option of the method given by name
        (``sparse_level=2`` with ``method="sparse"``).
    name, description : str, optional
        Labels used in results, summaries and output folders.

    Raises
    ------
    InvalidParameterError
        Unknown model, unknown parameter or output names (the message lists the
        valid ones), missing values for parameters without a default, an unknown or
        invalid study option (naming it).
    InvalidFuzzyNumberError, InvalidPlanError
        From the fuzzy engine, for invalid fuzzy numbers or plan settings.
    """

    def __init__(
        self,
        model: str | Callable[..., Any],
        parameters: Mapping[str, Any],
        method: str | Method = "reduced",
        levels: int | Sequence[float] = 4,
        outputs: Sequence[str] | None = None,
        *,
        model_options: Mapping[str, Any] | None = None,
        nonmonotonic: Sequence[str] | str | None = None,
        options: StudyOptions | None = None,
        name: str | None = None,
        description: str = "",
        **given: Any,
    ) -> None:
        # a name is the study's option where StudyOptions declares it, else the method's
        method_options = {key: given.pop(key) for key in list(given) if is_method_option(key)}
        options = StudyOptions.given(options, given)
        self.integration_choice: ToleranceChoice | None = None
        self._check_model: Any = None  # the check's tighter model, re-runs made ahead
        resolved = resolve_model(model, model_options or {})
        self.model = resolved.model
        self.model_name = resolved.name
        self.model_options = resolved.options
        self.spec = resolved.spec
        self._run_coords: dict[str, np.ndarray] = {}
        #: every chunk of the screening, plan and validation runs agrees with the others
        self._output_check = OutputCheck()
        self._factory = resolved.factory  # registered or referenced models: the source digest
        static = self.spec is not None and not self.spec.dynamic
        self.parameter_info: dict[str, ParameterInfo] | None = (
            dict(self.spec.parameters) if static else declared_parameters(self.model)
        )
        check_parameters = getattr(self.model, "check_parameters", None)
        if callable(check_parameters):  # a model that explains why a name is refused
            check_parameters(list(parameters))
        fuzzy, crisp = split_parameters(parameters, self.parameter_info, self.model_name)
        self.constants = crisp
        self._fuzzy = fuzzy
        self._levels = levels
        #: the screening report of a ``nonmonotonic="auto"`` study once screened, else None
        self.screening: dict[str, Any] | None = None
        self.auto_nonmonotonic = isinstance(nonmonotonic, str) and nonmonotonic == AUTO
        self._plan, self._screening_samples, screening_rtol = build_plan(
            fuzzy, method, levels, nonmonotonic, options, method_options
        )
        # one tolerance: the method's own where it declares one (adaptive), else the check's
        scheme = getattr(self._plan, "scheme", None)
        method_tolerance = options.method_tolerance
        if scheme is not None and scheme.declares("method_tolerance"):
            method_tolerance = scheme.method_tolerance
        #: the study's options, with the defaults that depend on the method filled in
        self.options = replace(
            options,
            screening_rtol=screening_rtol,
            method_tolerance=(
                DEFAULT_METHOD_TOLERANCE if method_tolerance is None else method_tolerance
            ),
        )
        known_outputs = self._declared_outputs()
        self.outputs = checked_outputs(outputs, known_outputs, self.model_name)
        self.output_names: tuple[str, ...] = self.outputs or tuple(known_outputs or ())
        check_output_names(dict.fromkeys(self.output_names))  # before any evaluation
        self.name = name or (self.model_name.split(":")[-1].split(".")[-1])
        self.description = description
        self.gradient_parameters()  # gradients = true with a model that cannot: refused now

    @property
    def plan(self) -> Plan:
        """The sampling plan (for ``nonmonotonic="auto"``: known after :meth:`screen`).

        Raises
        ------
        UnsupportedOperationError
            For an auto study that has not been screened yet.
        """
        if self._plan is None:
            raise UnsupportedOperationError(
                f"study {self.name!r} uses nonmonotonic={AUTO!r}: its extended plan is built "
                "from a screening run of the model; call study.screen() or study.run() first"
            )
        return self._plan

    # ----------------------------------------------------------------- helpers
    def _declared_outputs(self) -> list[str] | None:
        if self.spec is not None and not self.spec.dynamic:
            return list(self.spec.outputs)
        declared = getattr(self.model, "outputs", None)
        if isinstance(declared, Mapping):
            return list(declared)
        return None

    @property
    def coords(self) -> dict[str, np.ndarray]:
        """Coordinates of the model's trailing output axes (e.g. ``{"time": t}``).

        Declared by the model (``model.coords``) or, for a model that learns them
        while running (an external program's output file), returned by its runs
        (:data:`~fuzzymbs.study.evaluation.COORDS_KEY`).
        """
        declared = getattr(self.model, "coords", None) or {}
        return {**self._run_coords, **{k: np.asarray(v) for k, v in declared.items()}}

    def _adopt_coords(self, chunks: Sequence[ChunkResult]) -> None:
        """Keep the coordinates the runs returned; they must agree with earlier runs.

        Raises
        ------
        ModelOutputError
            A coordinate differs between runs (of the plan, screening or validation).
        """
        for dim, values in merged_coords(chunks).items():
            known = self._run_coords.setdefault(dim, values)
            if known.shape != values.shape or not np.allclose(known, values, rtol=1e-9, atol=0):
                raise ModelOutputError(
                    f"coordinate {dim!r} returned by the model differs between this study's "
                    "runs (plan, screening or validation); every run must report the same values"
                )

    def output_dims(self, output: str) -> tuple[str, ...]:
        """Expected trailing dimensions of ``output`` (from ``model.output_dims`` or coords)."""
        declared = getattr(self.model, "output_dims", None) or {}
        if output in declared:
            return tuple(declared[output])
        return tuple(self.coords)

    def units(self) -> dict[str, str]:
        """Output name -> unit, where the model declares it."""
        if self.spec is not None and not self.spec.dynamic:
            return dict(self.spec.outputs)
        declared = getattr(self.model, "outputs", None)
        return {k: str(v) for k, v in declared.items()} if isinstance(declared, Mapping) else {}

    def identity(self) -> dict[str, Any]:
        """What a result store must match: plan fingerprint, model, options, crisp values.

        A model object may add its own settings by defining ``identity()``
        returning plain data (e.g. a digest of its configuration); without it,
        a model passed as an object is identified by its name only.
        """
        return {"plan_fingerprint": self.plan.fingerprint(), **self.model_identity()}

    def model_identity(self) -> dict[str, Any]:
        """The part of :meth:`identity` that does not depend on the plan."""
        identity = {
            "model": self.model_name,
            "model_options": self.model_options,
            "constants": self.constants,
            "outputs": list(self.outputs) if self.outputs else None,
        }
        own = getattr(self.model, "identity", None)  # the model object's own settings
        if callable(own):
            identity["model_identity"] = own()
        if self.integration_choice is not None:
            identity["integration_tolerance_factor"] = self.integration_choice.factor
            if self.integration_choice.shared_steps:
                identity["integration_shared_steps"] = True
        return identity

    def gradient_parameters(self) -> tuple[str, ...]:
        """The fuzzy parameters the study asks its model's gradients for with every run
        (:func:`~fuzzymbs.study.gradients.gradient_parameters`): all of them where the
        method uses gradients (the adaptive method's option ``gradients``, ``"auto"`` by
        default) and the model declares every one in ``model.differentiable``; else none.

        Raises
        ------
        InvalidParameterError
            ``gradients = true`` and the model cannot differentiate with respect to some
            fuzzy parameters (naming them).
        """
        if self._plan is None:  # an extended plan still to be screened: no gradients
            return ()
        setting = getattr(self._plan.scheme, "gradients", False)  # a method that uses them
        return gradient_parameters(self.model, self._plan.names, setting, self.model_name)

    def _plan_levels(self) -> np.ndarray:
        return make_levels(self._levels)

    def code_version(self) -> dict[str, Any]:
        """What code computes the samples: fuzzymbs version and model source digest.

        A result store records it next to :meth:`identity` and refuses to resume
        chunks computed by other code (see :mod:`fuzzymbs.study.code_version`:
        the digest covers the fuzzymbs source a model uses and the file, or the
        compiled code, of a model defined outside fuzzymbs).
        """
        return code_version(self.model, self._factory)

    def columns(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Every parameter column (fuzzy and crisp) of samples ``start:stop``."""
        return self._columns(self.plan.samples, start, stop)

    def _columns(self, samples: np.ndarray, start: int, stop: int) -> dict[str, np.ndarray]:
        """Every parameter column of rows ``start:stop`` of a sample table (plan or screening)."""
        block = samples[start:stop]
        columns = {name: np.ascontiguousarray(block[:, i]) for i, name in enumerate(self._fuzzy)}
        for name, value in self.constants.items():
            columns[name] = np.full(stop - start, value)
        return columns

    def __repr__(self) -> str:
        if self._plan is None:
            return (
                f"Study(model={self.model_name!r}, parameters={list(self._fuzzy)}, "
                f"method='extended', levels={len(self._plan_levels()) - 1}, "
                f"nonmonotonic={AUTO!r} (not screened yet))"
            )
        return (
            f"Study(model={self.model_name!r}, parameters={list(self.plan.names)}, "
            f"method={self.plan.method!r}, levels={len(self.plan.levels) - 1}, "
            f"samples={len(self.plan)})"
        )

    # --------------------------------------------------------------------- run
    def run(
        self,
        executor: Any = None,
        chunk_size: int | None = None,
        store: str | Path | None = None,
        resume: bool = True,
        progress: bool = True,
        on_failure: str = "raise",
        keep_raw: bool | None = None,
        timeout: float | None = None,
    ) -> StudyResult:
        """Evaluate the plan's samples chunk by chunk and retransform.

        A ``nonmonotonic="auto"`` study not screened yet is screened first
        (see :meth:`screen`), on the same executor and, with a store, into
        ``STORE/screening/``.

        Parameters
        ----------
        executor : None, str, Executor or distributed.Client
            ``None``/"inline" (default), "processes[:N]", "dask://host:port", a
            ``distributed.Client`` or any ``concurrent.futures.Executor``.
        chunk_size : int, optional
            Samples per task (one model call each); default 256.
        store : str or Path, optional
            Directory where every finished chunk is written before the next is
            awaited; a rerun with the same study evaluates only missing chunks.
        resume : bool
            Reuse the chunks of a matching store (False: discard them, also when
            they were computed by another fuzzymbs version or model source).
        progress : bool
            Show a progress bar with ETA (Rich) on stderr.
        on_failure : {"raise", "fail-fast", "partial"}
            What to do when samples fail: raise after evaluating everything,
            raise at the first failed chunk, or return bounds of the complete
            levels only (incomplete levels are NaN and flagged).
        keep_raw : bool, optional
            Put every sample's outputs into the dataset (``o_samples``). Default:
            only when they take at most 64 MiB
            (:data:`~fuzzymbs.study.streaming.RAW_LIMIT_BYTES`); the outputs are
            reduced chunk by chunk as they arrive, so without them the run's
            memory does not grow with the number of runs. With a ``store`` the
            chunks keep every sample's outputs anyway
            (:func:`fuzzymbs.study.store.read_outputs` reads them back).
        timeout : float, optional
            Seconds a sample may take (a batch of B samples: B times as long);
            a sample over it fails with reason "timed out after ... s". Enforced
            for Python models on the inline and process executors (POSIX), where
            a model's ``sys.exit``/``os._exit`` also fails its samples instead of
            ending the run. Default: no limit.

        Raises
        ------
        IncompleteResultError
            Samples failed and ``on_failure`` is not "partial" (or no level is complete),
            or screening samples failed so that the screening cannot decide.
        StoreMismatchError
            ``store`` holds chunks of a different study, or (with ``resume=True``)
            chunks computed by another fuzzymbs version or model source.
        """

        check_run_settings(on_failure, chunk_size, timeout)
        started = time.perf_counter()
        requested_size = DEFAULT_CHUNK_SIZE if chunk_size is None else int(chunk_size)
        code = self.code_version()  # recorded by the store and in the provenance
        # one executor for the screening and the plan, started only if something is evaluated
        # while the runs are out on other processes, this one imports what it needs after
        work = LazyExecutor(executor, self._check_picklable, timeout, import_result_modules)
        try:
            if self._plan is None:
                self._screen((work, requested_size, resume, progress, code), store, on_failure)
            # the pilot's choice and the time-integration check are kept in the store too
            self._records = JudgingRecords(store, resume, code)
            self._choose_integration(progress)
            if self.plan.scheme.runs_in_rounds:
                return self._run_in_rounds(
                    (work, requested_size, resume, progress, code),
                    store,
                    keep_raw,
                    on_failure,
                    started,
                )
            count = len(self.plan)
            chunk_store, size, chunk_count, results, missing, reused = open_chunks(
                store, self.identity(), count, requested_size, resume, code, load=False
            )
            # outputs are reduced chunk by chunk in sample order and then dropped
            feed = ChunkFeed(
                self.plan, count, size, results, chunk_store, keep_raw, self._output_check
            )
            feed.drain()
            logger.info(
                "study %s: %d samples in %d chunks of %d; %d chunks from the store, %d to evaluate",
                self.name,
                count,
                chunk_count,
                size,
                len(results),
                len(missing),
            )
            if on_failure == "fail-fast":
                self._raise_if_failed(results, during=True)
            evaluated = self._evaluate_rows(
                self.plan.samples,
                (chunk_store, size, results, missing, reused),
                work,
                (progress, None),
                fail_fast=(
                    (lambda: self._raise_if_failed(results, during=True))
                    if on_failure == "fail-fast"
                    else None
                ),
                on_chunk=feed.add,
                may_submit=feed.may_submit,
            )
            feed.drain()
            self._adopt_coords([results[i] for i in range(chunk_count)])
            failed, reasons = feed.failed, feed.reasons_array()
            validation = None
            if not failed.all() and (on_failure == "partial" or not failed.any()):
                if self.validation_count() and getattr(self.model, "shares_steps", False):
                    # the check's samples are known: their re-runs go on beside the
                    # method check's (its rounds leave a core idle while they search)
                    inputs = integration_inputs(
                        feed, self.output_names, failed, self.options.integration_runs, False
                    )
                    self._start_check(inputs[0])
                validation = self._validate(
                    work, feed, failed, requested_size, store, resume, progress, code
                )
        finally:
            work.close()
        executor_label = work.label or "none (every chunk from the store)"
        if failed.all():
            raise IncompleteResultError(
                f"all {count} samples of study {self.name!r} failed; first reason: {reasons[0]}"
            )
        touched = self.plan.levels_touched(failed)
        if failed.any() and (on_failure != "partial" or touched.all()):
            raise IncompleteResultError(self._failure_message(failed, reasons, touched))
        integration = self._check_time_integration(feed, failed, progress=progress)
        wall_time = time.perf_counter() - started
        dataset = build_dataset(
            self,
            feed,
            failed,
            reasons,
            wall_time=wall_time,
            evaluated=evaluated,
            reused=reused,
            executor=executor_label,
            chunk_size=size,
            on_failure=on_failure,
            code=code,
            integration=integration,
            validation=validation,
        )
        if self.integration_choice is not None:
            dataset.attrs.update(self.integration_choice.to_attrs())
        return StudyResult(dataset)

    def _run_in_rounds(
        self,
        settings: tuple[LazyExecutor, int, bool, bool, dict[str, Any]],
        store: str | Path | None,
        keep_raw: bool | None,
        on_failure: str,
        started: float,
    ) -> StudyResult:
        """The rounds of a plan that runs in rounds (:mod:`fuzzymbs.study.adaptive_rounds`),
        then the result; its certification replaces the validation runs of the fixed
        methods (``settings``: executor, chunk size, resume, progress, code version)."""
        work, size, _, progress, code = settings
        wrt = self.gradient_parameters()
        outputs, evaluated, reused = run_rounds(self, settings, store, wrt)
        plan = self.plan
        count = len(plan)
        failed = np.zeros(count, dtype=bool)
        reasons = np.full(count, "", dtype=object)
        feed = ChunkFeed(plan, count, count, (), None, keep_raw, self._output_check)
        feed.add(0, ChunkResult(0, count, outputs, failed, reasons))
        integration = self._check_time_integration(feed, failed, outputs, progress)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AdaptiveWarning)  # build_dataset would repeat it
            dataset = build_dataset(
                self,
                feed,
                failed,
                reasons.astype(str),
                wall_time=time.perf_counter() - started,
                evaluated=evaluated,
                reused=reused,
                executor=work.label or "none (every chunk from the store)",
                chunk_size=size,
                on_failure=on_failure,
                code=code,
                integration=integration,
            )
        dataset.attrs.update(plan.attrs())
        # whether the rounds used the model's gradients, and with respect to what
        dataset.attrs["adaptive_gradients"] = ", ".join(wrt) if wrt else "none"
        stopped = plan.scheme.stop_message(plan.outcome())
        if stopped is not None:
            message = f"study {self.name!r}: {stopped}"
            logger.warning("%s", message)
            warnings.warn(message, AdaptiveWarning, stacklevel=3)
        if self.integration_choice is not None:
            dataset.attrs.update(self.integration_choice.to_attrs())
        return StudyResult(dataset)

    def _check_picklable(self, resolved: Any) -> None:
        """Fail early and clearly when the model cannot travel to worker processes."""
        import pickle

        try:
            pickle.dumps(self.model)
        except Exception as exc:
            resolved.close()
            raise InvalidParameterError(
                f"model {self.model_name!r} cannot be pickled, so it cannot run on "
                f"executor {resolved.label!r} ({type(exc).__name__}: {exc}); define it at "
                "module level or use the inline executor"
            ) from exc

    def _failure_message(self, failed: np.ndarray, reasons: np.ndarray, touched: Any) -> str:
        indices = np.flatnonzero(failed)
        listed = "; ".join(f"sample {i}: {reasons[i]}" for i in indices[:5])
        more = f" (and {len(indices) - 5} more)" if len(indices) > 5 else ""
        levels = ", ".join(f"{mu:.4g}" for mu in self.plan.levels[np.asarray(touched)])
        advice = (
            "The core level (mu = 1) is among them, so no level can be bounded."
            if np.asarray(touched).all()
            else "Use on_failure='partial' to keep the complete levels."
        )
        return (
            f"{len(indices)} of {len(self.plan)} samples of study {self.name!r} failed, "
            f"so the alpha levels mu = {levels} cannot be bounded: {listed}{more}. {advice}"
        )

    def _raise_if_failed(self, results: Mapping[int, ChunkResult], during: bool) -> None:
        count = len(self.plan)
        failed = np.zeros(count, dtype=bool)
        reasons = np.full(count, "", dtype=object)
        for chunk in results.values():
            failed[chunk.start : chunk.stop] = chunk.failed
            reasons[chunk.start : chunk.stop] = chunk.reasons
        if failed.any():
            message = self._failure_message(failed, reasons, self.plan.levels_touched(failed))
            raise IncompleteResultError(("stopped early (fail-fast): " if during else "") + message)
