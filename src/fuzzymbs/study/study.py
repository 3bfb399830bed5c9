"""Study: a model, fuzzy parameters and a transformation method, run chunk by chunk.

The only place where the fuzzy engine and a model meet::

    study = Study("product", {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)})
    result = study.run()                 # -> StudyResult (xarray.Dataset inside)
    result.dataset["z_lower"]            # alpha-cut bounds per level

With ``method="extended", nonmonotonic="auto"`` the study first evaluates the
screening of :mod:`fuzzymbs.fuzzy.screening` (every parameter's axis through
the modal point) with the same model, executor and store, and builds the
extended plan with the parameters found non-monotonic.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidParameterError,
    InvalidPlanError,
    UnsupportedOperationError,
)
from fuzzymbs.study.evaluation import ChunkResult, evaluate_chunk
from fuzzymbs.study.registry import ModelSpec, ParameterInfo, get_model, load_callable
from fuzzymbs.study.result import StudyResult, build_dataset, check_output_names

if TYPE_CHECKING:  # pragma: no cover
    from fuzzymbs.fuzzy.transform import Plan

__all__ = ["DEFAULT_CHUNK_SIZE", "ON_FAILURE", "Study", "StudyResult"]

logger = logging.getLogger(__name__)

#: Samples per task unless the study says otherwise (hundreds per task, one model call each).
DEFAULT_CHUNK_SIZE = 256
ON_FAILURE = ("raise", "fail-fast", "partial")
#: ``nonmonotonic`` value asking the study to find the non-monotonic parameters itself
AUTO = "auto"
#: sub-folder of a store holding the screening chunks of a ``nonmonotonic="auto"`` study
SCREENING_FOLDER = "screening"


def _model_label(model: Any) -> str:
    kind = model if hasattr(model, "__qualname__") else type(model)
    return f"{kind.__module__}.{kind.__qualname__}"


def _json_options(options: Mapping[str, Any]) -> dict[str, Any]:
    try:
        return json.loads(json.dumps(dict(options), sort_keys=True))
    except TypeError as exc:
        raise InvalidParameterError(
            f"model options must be plain data (numbers, strings, lists, tables): {exc}"
        ) from None


class Study:
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
    method : {"general", "reduced", "extended", "grid", "sparse"}
        Transformation scheme.
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
    screening_rtol : float, optional
        With ``nonmonotonic="auto"``: reversals along a parameter's axis up to
        this fraction of an output element's range are ignored (default
        :data:`fuzzymbs.fuzzy.screening.DEFAULT_RTOL`).
    sparse_level, search_points : int, optional
        Method "sparse" only: sparse-grid level and search points per cut box
        (see :func:`fuzzymbs.fuzzy.transform.plan`).
    name, description : str, optional
        Labels used in results, summaries and output folders.

    Raises
    ------
    InvalidParameterError
        Unknown model, unknown parameter or output names (the message lists the
        valid ones), missing values for parameters without a default, bad options.
    InvalidFuzzyNumberError, InvalidPlanError
        From the fuzzy engine, for invalid fuzzy numbers or plan settings.
    """

    def __init__(
        self,
        model: str | Callable[..., Any],
        parameters: Mapping[str, Any],
        method: str = "reduced",
        levels: int | Sequence[float] = 4,
        outputs: Sequence[str] | None = None,
        *,
        model_options: Mapping[str, Any] | None = None,
        nonmonotonic: Sequence[str] | str | None = None,
        screening_rtol: float | None = None,
        sparse_level: int | None = None,
        search_points: int | None = None,
        name: str | None = None,
        description: str = "",
    ) -> None:
        from fuzzymbs.fuzzy.numbers import FuzzyNumber
        from fuzzymbs.fuzzy.screening import DEFAULT_RTOL, screening_samples
        from fuzzymbs.fuzzy.transform import plan as make_plan
        from fuzzymbs.study.parameters import fuzzy_number_from_definition

        self.model_options = _json_options(model_options or {})
        self.spec: ModelSpec | None = None
        self._factory: Callable[..., Any] | None = None  # named models: for the source digest
        if isinstance(model, str):
            self.model_name = model
            if ":" in model:
                factory = load_callable(model)
            else:
                self.spec = get_model(model)
                factory = self.spec.factory
                unknown = sorted(set(self.model_options) - set(self.spec.options))
                if unknown:
                    allowed = ", ".join(self.spec.options) or "(none)"
                    raise InvalidParameterError(
                        f"model {model!r} has no option(s) {unknown}; its options: {allowed}"
                    )
            self._factory = factory
            try:
                self.model = factory(**self.model_options)
            except TypeError as exc:
                raise InvalidParameterError(
                    f"model {model!r} rejected the options {self.model_options}: {exc}"
                ) from exc
        elif callable(model):
            if self.model_options:
                raise InvalidParameterError(
                    "model_options only apply to a model given by name or 'package.module:callable'"
                )
            self.model = model
            self.model_name = _model_label(model)
        else:
            raise InvalidParameterError(
                f"model must be a registered name, 'package.module:callable' or a batched "
                f"callable, got {model!r}"
            )

        self.parameter_info: dict[str, ParameterInfo] | None = (
            dict(self.spec.parameters) if self.spec else self._declared_parameters(self.model)
        )
        fuzzy: dict[str, FuzzyNumber] = {}
        crisp: dict[str, float] = {}
        for key, value in parameters.items():
            if isinstance(value, FuzzyNumber):
                fuzzy[key] = value
            elif isinstance(value, Mapping):
                fuzzy[key] = fuzzy_number_from_definition(value, key)
            elif isinstance(value, int | float | np.number) and not isinstance(value, bool):
                if not math.isfinite(float(value)):
                    raise InvalidParameterError(f"crisp parameter {key!r} must be finite")
                crisp[key] = float(value)
            else:
                raise InvalidParameterError(
                    f"parameter {key!r}: expected a FuzzyNumber, a definition such as "
                    f'{{"type": "triangular", "modal": 1.0, "spread": 0.1}} or a number, '
                    f"got {value!r}"
                )
        if self.parameter_info is not None:
            unknown = [key for key in parameters if key not in self.parameter_info]
            if unknown:
                valid = ", ".join(f"{n} [{info.unit}]" for n, info in self.parameter_info.items())
                raise InvalidParameterError(
                    f"unknown parameter(s) {unknown} for model {self.model_name!r}; "
                    f"valid parameters: {valid}"
                )
            for key, info in self.parameter_info.items():
                if key in parameters:
                    continue
                if info.default is None:
                    raise InvalidParameterError(
                        f"parameter {key!r} of model {self.model_name!r} has no default; "
                        "give it as a fuzzy number or a crisp value"
                    )
                crisp[key] = float(info.default)
        if not fuzzy:
            raise InvalidParameterError("a study needs at least one fuzzy parameter")
        self.constants = crisp
        self._fuzzy = fuzzy
        self._levels = levels
        #: the screening report of a ``nonmonotonic="auto"`` study once screened, else None
        self.screening: dict[str, Any] | None = None
        self.auto_nonmonotonic = isinstance(nonmonotonic, str) and nonmonotonic == AUTO
        self._plan: Plan | None = None
        if self.auto_nonmonotonic:
            if method != "extended":
                raise InvalidPlanError(
                    f"nonmonotonic={AUTO!r} is only used by method='extended', not {method!r}"
                )
            if sparse_level is not None or search_points is not None:
                raise InvalidPlanError(
                    "sparse_level and search_points only apply to method='sparse', not 'extended'"
                )
            self._screening_samples = screening_samples(fuzzy, levels)
            self.screening_rtol = DEFAULT_RTOL if screening_rtol is None else screening_rtol
            _check_rtol(self.screening_rtol)
        else:
            self.screening_rtol = None
            if screening_rtol is not None:
                raise InvalidPlanError(
                    f"screening_rtol={screening_rtol!r} is only used with "
                    f"nonmonotonic={AUTO!r}, not {nonmonotonic!r}"
                )
            self._plan = make_plan(
                fuzzy,
                method=method,
                levels=levels,
                nonmonotonic=nonmonotonic,
                sparse_level=sparse_level,
                search_points=search_points,
            )

        known_outputs = self._declared_outputs()
        if outputs is not None:
            outputs = [str(o) for o in outputs]
            if not outputs:
                raise InvalidParameterError("outputs, when given, must name at least one output")
            if known_outputs is not None:
                unknown = [o for o in outputs if o not in known_outputs]
                if unknown:
                    raise InvalidParameterError(
                        f"unknown output(s) {unknown} of model {self.model_name!r}; "
                        f"outputs: {', '.join(known_outputs)}"
                    )
        self.outputs: tuple[str, ...] | None = tuple(outputs) if outputs else None
        self.output_names: tuple[str, ...] = self.outputs or tuple(known_outputs or ())
        check_output_names(dict.fromkeys(self.output_names))  # before any evaluation
        self.name = name or (self.model_name.split(":")[-1].split(".")[-1])
        self.description = description

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
    @staticmethod
    def _declared_parameters(model: Any) -> dict[str, ParameterInfo] | None:
        declared = getattr(model, "parameters", None)
        if isinstance(declared, Mapping) and all(
            isinstance(v, ParameterInfo) for v in declared.values()
        ):
            return dict(declared)
        return None

    def _declared_outputs(self) -> list[str] | None:
        if self.spec is not None:
            return list(self.spec.outputs)
        declared = getattr(self.model, "outputs", None)
        if isinstance(declared, Mapping):
            return list(declared)
        return None

    @property
    def coords(self) -> dict[str, np.ndarray]:
        """Coordinates of the model's trailing output axes (e.g. ``{"time": t}``)."""
        return {k: np.asarray(v) for k, v in (getattr(self.model, "coords", None) or {}).items()}

    def output_dims(self, output: str) -> tuple[str, ...]:
        """Expected trailing dimensions of ``output`` (from ``model.output_dims`` or coords)."""
        declared = getattr(self.model, "output_dims", None) or {}
        if output in declared:
            return tuple(declared[output])
        return tuple(self.coords)

    def units(self) -> dict[str, str]:
        """Output name -> unit, where the model declares it."""
        if self.spec is not None:
            return dict(self.spec.outputs)
        declared = getattr(self.model, "outputs", None)
        return {k: str(v) for k, v in declared.items()} if isinstance(declared, Mapping) else {}

    def identity(self) -> dict[str, Any]:
        """What a result store must match: plan fingerprint, model, options, crisp values.

        A model object may add its own settings by defining ``identity()``
        returning plain data (e.g. a digest of its configuration); without it,
        a model passed as an object is identified by its name only.
        """
        return {"plan_fingerprint": self.plan.fingerprint(), **self._model_identity()}

    def _model_identity(self) -> dict[str, Any]:
        """The part of :meth:`identity` that does not depend on the plan."""
        identity = {
            "model": self.model_name,
            "model_options": self.model_options,
            "constants": self.constants,
            "outputs": list(self.outputs) if self.outputs else None,
        }
        model_identity = getattr(self.model, "identity", None)
        if callable(model_identity):
            identity["model_identity"] = model_identity()
        return identity

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
        return {"screening_fingerprint": digest.hexdigest(), **self._model_identity()}

    def _plan_levels(self) -> np.ndarray:
        from fuzzymbs.fuzzy.transform import make_levels

        return make_levels(self._levels)

    def code_version(self) -> dict[str, Any]:
        """What code computes the samples: fuzzymbs version and model source digest.

        A result store records it next to :meth:`identity` and refuses to resume
        chunks computed by other code (see :mod:`fuzzymbs.study.code_version`;
        the digest is None for models defined outside fuzzymbs).
        """
        from fuzzymbs.study.code_version import code_version

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
        keep_raw: bool = True,
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
        keep_raw : bool
            Keep the raw outputs of every sample in the dataset.

        Raises
        ------
        IncompleteResultError
            Samples failed and ``on_failure`` is not "partial" (or no level is complete),
            or screening samples failed so that the screening cannot decide.
        StoreMismatchError
            ``store`` holds chunks of a different study, or (with ``resume=True``)
            chunks computed by another fuzzymbs version or model source.
        """

        _check_run_settings(on_failure, chunk_size)
        started = time.perf_counter()
        requested_size = DEFAULT_CHUNK_SIZE if chunk_size is None else int(chunk_size)
        code = self.code_version()  # recorded by the store and in the provenance
        # one executor for the screening and the plan, started only if something is evaluated
        work = _LazyExecutor(executor, self._check_picklable)
        try:
            if self._plan is None:
                self._screen(work, requested_size, store, resume, progress, on_failure, code)
            count = len(self.plan)
            chunk_store, size, chunk_count, results, missing, reused = _open_chunks(
                store, self.identity(), count, requested_size, resume, code
            )
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
            evaluated = self._evaluate_chunks(
                self.plan.samples,
                missing,
                size,
                results,
                chunk_store,
                work,
                progress=(progress, reused, self.name),
                fail_fast=(
                    (lambda: self._raise_if_failed(results, during=True))
                    if on_failure == "fail-fast"
                    else None
                ),
            )
        finally:
            work.close()
        executor_label = work.label or "none (every chunk from the store)"

        ordered = [results[i] for i in range(chunk_count)]
        outputs, failed, reasons = _assemble(ordered, count)
        if failed.all():
            raise IncompleteResultError(
                f"all {count} samples of study {self.name!r} failed; first reason: {reasons[0]}"
            )
        touched = self.plan.levels_touched(failed)
        if failed.any() and (on_failure != "partial" or touched.all()):
            raise IncompleteResultError(self._failure_message(failed, reasons, touched))
        wall_time = time.perf_counter() - started
        dataset = build_dataset(
            self,
            outputs,
            failed,
            reasons,
            wall_time=wall_time,
            evaluated=evaluated,
            reused=reused,
            executor=executor_label,
            chunk_size=size,
            on_failure=on_failure,
            code=code,
            keep_raw=keep_raw,
        )
        return StudyResult(dataset)

    def screen(
        self,
        executor: Any = None,
        chunk_size: int | None = None,
        store: str | Path | None = None,
        resume: bool = True,
        progress: bool = False,
        on_failure: str = "raise",
    ) -> dict[str, Any]:
        """Screen a ``nonmonotonic="auto"`` study and build its extended plan.

        :meth:`run` does this itself; call it to see the detected parameters
        (and the plan size) before running the plan. The model is evaluated
        at :func:`~fuzzymbs.fuzzy.screening.screening_samples` (with the
        crisp values of the study), chunk by chunk on ``executor``; with a
        ``store``, the chunks go to ``STORE/screening/`` and a rerun reuses
        them. Failed screening samples are left out of the decision (listed
        in the report), except with ``on_failure="fail-fast"``, which raises.
        A second call returns the first report.

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
            _check_run_settings(on_failure, chunk_size)
            size = DEFAULT_CHUNK_SIZE if chunk_size is None else int(chunk_size)
            code = self.code_version() if store is not None else None
            work = _LazyExecutor(executor, self._check_picklable)
            try:
                self._screen(work, size, store, resume, progress, on_failure, code)
            finally:
                work.close()
        assert self.screening is not None
        return self.screening

    def _screen(
        self,
        work: _LazyExecutor,
        size: int,
        store: str | Path | None,
        resume: bool,
        progress: bool,
        on_failure: str,
        code: dict[str, Any] | None,
    ) -> None:
        """Evaluate the screening samples, decide, and build the extended plan."""
        from fuzzymbs.fuzzy.screening import nonmonotonic_parameters
        from fuzzymbs.fuzzy.transform import plan as make_plan

        screening = self._screening_samples
        count = len(screening.samples)
        chunk_store, size, chunk_count, results, missing, reused = _open_chunks(
            None if store is None else Path(store) / SCREENING_FOLDER,
            self._screening_identity(),
            count,
            size,
            resume,
            code,
        )
        logger.info(
            "study %s: screening for non-monotonic parameters, %d samples, %d from the store",
            self.name,
            count,
            reused,
        )

        def stop_at_failure() -> None:
            failed, reasons = _assemble([results[i] for i in sorted(results)], count)[1:]
            if failed.any():
                raise IncompleteResultError(
                    f"stopped early (fail-fast): screening of study {self.name!r}: "
                    + self._screening_failures(failed, reasons)
                )

        fail_fast = stop_at_failure if on_failure == "fail-fast" else None
        if fail_fast is not None and results:
            fail_fast()
        evaluated = self._evaluate_chunks(
            screening.samples,
            missing,
            size,
            results,
            chunk_store,
            work,
            progress=(progress, reused, f"{self.name} (screening)"),
            fail_fast=fail_fast,
        )
        outputs, failed, reasons = _assemble([results[i] for i in range(chunk_count)], count)
        if failed.all():
            raise IncompleteResultError(
                f"all {count} screening samples of study {self.name!r} failed; "
                f"first reason: {reasons[0]}"
            )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                report = nonmonotonic_parameters(
                    screening, outputs, self.screening_rtol, failed=failed
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
        self._plan = make_plan(
            self._fuzzy, method="extended", levels=self._levels, nonmonotonic=report["nonmonotonic"]
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

    def _evaluate_chunks(
        self,
        samples: np.ndarray,
        missing: Sequence[int],
        size: int,
        results: dict[int, ChunkResult],
        chunk_store: Any,
        work: _LazyExecutor,
        *,
        progress: tuple[bool, int, str],
        fail_fast: Callable[[], None] | None,
    ) -> int:
        """Evaluate chunks ``missing`` of ``samples`` into ``results`` (and the store).

        Returns the number of samples evaluated. ``fail_fast`` is called (and
        pending chunks cancelled) after a chunk with a failed sample.
        """
        count = len(samples)
        enabled, already, label = progress
        evaluated = 0
        with _progress_bar(enabled, count, already, label) as advance:
            pending: dict[Future, int] = {}
            queue = list(missing)
            resolved = work.get() if queue else None
            while queue or pending:
                assert resolved is not None
                while queue and len(pending) < resolved.in_flight:
                    index = queue.pop(0)
                    start, stop = index * size, min((index + 1) * size, count)
                    future = resolved.executor.submit(
                        evaluate_chunk,
                        self.model,
                        self._columns(samples, start, stop),
                        start,
                        self.outputs,
                    )
                    pending[future] = index
                done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
                for future in done:
                    index = pending.pop(future)
                    chunk = future.result()
                    if chunk_store is not None:
                        chunk_store.write(index, chunk)
                    results[index] = chunk
                    evaluated += chunk.size
                    advance(chunk.size)
                    if chunk.failed.any():
                        logger.warning(
                            "chunk %d: %d of %d samples failed (first: %s)",
                            index,
                            int(chunk.failed.sum()),
                            chunk.size,
                            chunk.reasons[np.flatnonzero(chunk.failed)[0]],
                        )
                        if fail_fast is not None:
                            for other in pending:
                                other.cancel()
                            fail_fast()
        return evaluated

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


def _check_run_settings(on_failure: str, chunk_size: Any) -> None:
    if on_failure not in ON_FAILURE:
        raise InvalidParameterError(f"on_failure={on_failure!r}; allowed: {', '.join(ON_FAILURE)}")
    if chunk_size is not None and (
        isinstance(chunk_size, bool)
        or not isinstance(chunk_size, int | np.integer)
        or chunk_size < 1
    ):
        raise InvalidParameterError(f"chunk_size must be a positive int, got {chunk_size!r}")


def _check_rtol(value: Any) -> None:
    from fuzzymbs.fuzzy.screening import _check_tolerance

    _check_tolerance("screening_rtol", value)


class _LazyExecutor:
    """The run's executor, started on first use (a run served by the store starts none)."""

    def __init__(self, spec: Any, check: Callable[[Any], None]) -> None:
        self.spec = spec
        self._check = check  # closes the executor and raises if the model cannot travel
        self._resolved: Any = None
        self.label: str | None = None

    def get(self) -> Any:
        if self._resolved is None:
            from fuzzymbs.study.executors import resolve_executor

            resolved = resolve_executor(self.spec)
            if resolved.label.startswith("processes"):
                self._check(resolved)
            self._resolved = resolved
            self.label = resolved.label
        return self._resolved

    def close(self) -> None:
        if self._resolved is not None:
            self._resolved.close()


def _open_chunks(
    store: str | Path | None,
    identity: dict[str, Any],
    count: int,
    size: int,
    resume: bool,
    code: dict[str, Any] | None,
) -> tuple[Any, int, int, dict[int, ChunkResult], list[int], int]:
    """Open (or skip, without ``store``) the chunk store of ``count`` samples.

    Returns the store (or None), the chunk size in force (a resumed store keeps
    its own), the chunk count, the chunks already stored, the missing chunk
    indices and the number of samples reused.
    """
    from fuzzymbs.study.store import ChunkStore

    chunk_store = None
    if store is not None:
        chunk_store = ChunkStore.open(store, identity, count, size, resume=resume, code=code)
        size = chunk_store.chunk_size
    chunk_count = math.ceil(count / size)
    results = _stored_chunks(chunk_store, chunk_count)
    missing = [i for i in range(chunk_count) if i not in results]
    reused = sum(results[i].size for i in results)
    return chunk_store, size, chunk_count, results, missing, reused


def _stored_chunks(chunk_store: Any, chunk_count: int) -> dict[int, ChunkResult]:
    """The readable chunks of a store (none without one)."""
    results: dict[int, ChunkResult] = {}
    if chunk_store is not None:
        for index in chunk_store.finished():
            if index < chunk_count:
                stored = chunk_store.read(index)
                if stored is not None:
                    results[index] = stored
    return results


def _assemble(
    chunks: Sequence[ChunkResult], count: int
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Concatenate chunk results in sample order; NaN rows where a chunk had no data."""
    failed = np.concatenate([c.failed for c in chunks]).astype(bool)
    reasons = np.concatenate([np.asarray(c.reasons, dtype=object) for c in chunks]).astype(str)
    shapes: dict[str, tuple[int, ...]] = {}
    for chunk in chunks:
        for name, values in chunk.outputs.items():
            shapes.setdefault(name, values.shape[1:])
    outputs = {}
    for name, shape in shapes.items():
        merged = np.full((count, *shape), np.nan)
        for chunk in chunks:
            if name in chunk.outputs:
                merged[chunk.start : chunk.stop] = chunk.outputs[name]
        outputs[name] = merged
    return outputs, failed, reasons


@contextmanager
def _progress_bar(
    enabled: bool, total: int, already: int, label: str
) -> Iterator[Callable[[int], None]]:
    """A Rich progress bar with ETA (or a no-op when disabled)."""
    if not enabled:
        yield lambda _n: None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = (
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("samples"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=total, completed=already)
        yield lambda n: bar.advance(task, n)
