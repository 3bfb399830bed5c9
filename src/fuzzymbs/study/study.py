"""Study: a model, fuzzy parameters and a transformation method, run chunk by chunk.

The only place where the fuzzy engine and a model meet::

    study = Study("product", {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)})
    result = study.run()                 # -> StudyResult (xarray.Dataset inside)
    result.dataset["z_lower"]            # alpha-cut bounds per level
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidParameterError,
)
from fuzzymbs.study.evaluation import ChunkResult, evaluate_chunk
from fuzzymbs.study.registry import ModelSpec, ParameterInfo, get_model, load_callable
from fuzzymbs.study.result import StudyResult, build_dataset, check_output_names

__all__ = ["DEFAULT_CHUNK_SIZE", "ON_FAILURE", "Study", "StudyResult"]

logger = logging.getLogger(__name__)

#: Samples per task unless the study says otherwise (hundreds per task, one model call each).
DEFAULT_CHUNK_SIZE = 256
ON_FAILURE = ("raise", "fail-fast", "partial")


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
    method : {"general", "reduced", "extended", "grid"}
        Transformation scheme.
    levels : int or sequence of float
        Number of alpha levels m (mu_j = j/m) or explicit levels from 0 to 1.
    outputs : sequence of str, optional
        Subset of the model outputs to keep (default: all).
    model_options : mapping, optional
        Keyword options for the model factory (registered or referenced models).
    nonmonotonic : sequence of str, optional
        Parameters that get interior points (method "extended").
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
        nonmonotonic: Sequence[str] | None = None,
        name: str | None = None,
        description: str = "",
    ) -> None:
        from fuzzymbs.fuzzy.numbers import FuzzyNumber
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
        self.plan = make_plan(fuzzy, method=method, levels=levels, nonmonotonic=nonmonotonic)

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
        identity = {
            "plan_fingerprint": self.plan.fingerprint(),
            "model": self.model_name,
            "model_options": self.model_options,
            "constants": self.constants,
            "outputs": list(self.outputs) if self.outputs else None,
        }
        model_identity = getattr(self.model, "identity", None)
        if callable(model_identity):
            identity["model_identity"] = model_identity()
        return identity

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
        block = self.plan.samples[start:stop]
        columns = {
            name: np.ascontiguousarray(block[:, i]) for i, name in enumerate(self.plan.names)
        }
        for name, value in self.constants.items():
            columns[name] = np.full(stop - start, value)
        return columns

    def __repr__(self) -> str:
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
            Samples failed and ``on_failure`` is not "partial" (or no level is complete).
        StoreMismatchError
            ``store`` holds chunks of a different study, or (with ``resume=True``)
            chunks computed by another fuzzymbs version or model source.
        """
        from fuzzymbs.study.executors import resolve_executor
        from fuzzymbs.study.store import ChunkStore

        if on_failure not in ON_FAILURE:
            raise InvalidParameterError(
                f"on_failure={on_failure!r}; allowed: {', '.join(ON_FAILURE)}"
            )
        if chunk_size is not None and (
            isinstance(chunk_size, bool)
            or not isinstance(chunk_size, int | np.integer)
            or chunk_size < 1
        ):
            raise InvalidParameterError(f"chunk_size must be a positive int, got {chunk_size!r}")
        started = time.perf_counter()
        count = len(self.plan)
        size = DEFAULT_CHUNK_SIZE if chunk_size is None else int(chunk_size)
        chunk_store = None
        if store is not None:
            chunk_store = ChunkStore.open(
                store, self.identity(), count, size, resume=resume, code=self.code_version()
            )
            size = chunk_store.chunk_size
        chunk_count = math.ceil(count / size)
        results: dict[int, ChunkResult] = {}
        if chunk_store is not None:
            for index in chunk_store.finished():
                if index < chunk_count:
                    stored = chunk_store.read(index)
                    if stored is not None:
                        results[index] = stored
        missing = [i for i in range(chunk_count) if i not in results]
        reused = sum(results[i].size for i in results)
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

        # nothing to evaluate: do not start workers or connect to a cluster
        resolved = resolve_executor(executor if missing else None)
        if not missing:
            resolved.label = "none (every chunk from the store)"
        if resolved.label.startswith("processes"):
            self._check_picklable(resolved)
        evaluated = 0
        try:
            with _progress_bar(progress, count, reused, self.name) as advance:
                pending: dict[Future, int] = {}
                queue = list(missing)
                while queue or pending:
                    while queue and len(pending) < resolved.in_flight:
                        index = queue.pop(0)
                        start, stop = index * size, min((index + 1) * size, count)
                        future = resolved.executor.submit(
                            evaluate_chunk,
                            self.model,
                            self.columns(start, stop),
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
                            if on_failure == "fail-fast":
                                for other in pending:
                                    other.cancel()
                                self._raise_if_failed(results, during=True)
        finally:
            resolved.close()

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
            executor=resolved.label,
            chunk_size=size,
            on_failure=on_failure,
            keep_raw=keep_raw,
        )
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
