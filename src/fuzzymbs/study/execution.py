"""Evaluate a study's sample table chunk by chunk on an executor, with progress and a store.

The client side of the evaluation step: chunks go to the executor as tasks of
:func:`fuzzymbs.study.evaluation.evaluate_chunk` (which runs on the workers),
each finished chunk is written to the chunk store before the runner waits for
the next, and :func:`assemble_chunks` puts the chunks back in sample order.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Future, wait
from contextlib import contextmanager
from typing import Any

import numpy as np

from fuzzymbs.errors import IncompleteResultError, InvalidParameterError
from fuzzymbs.study.evaluation import ChunkResult, OutputCheck, evaluate_chunk, rows_in_order
from fuzzymbs.study.executors import resolve_executor

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "ON_FAILURE",
    "LazyExecutor",
    "assemble_chunks",
    "check_run_settings",
    "evaluate_chunks",
    "progress_bar",
    "progress_phase",
]

logger = logging.getLogger(__name__)

#: Samples per task unless the study says otherwise (hundreds per task, one model call each).
DEFAULT_CHUNK_SIZE = 256
#: What a study does when samples fail: raise after evaluating everything, raise at the
#: first failed chunk, or keep the complete levels only.
ON_FAILURE = ("raise", "fail-fast", "partial")


def check_run_settings(on_failure: str, chunk_size: Any, timeout: Any = None) -> None:
    """Raise :class:`InvalidParameterError` for an unknown ``on_failure``, a bad chunk
    size or a bad per-sample ``timeout``."""
    if timeout is not None and (
        isinstance(timeout, bool)
        or not isinstance(timeout, int | float)
        or not (np.isfinite(timeout) and timeout > 0)
    ):
        raise InvalidParameterError(
            f"timeout must be a positive number of seconds per sample, got {timeout!r}"
        )
    if on_failure not in ON_FAILURE:
        raise InvalidParameterError(f"on_failure={on_failure!r}; allowed: {', '.join(ON_FAILURE)}")
    if chunk_size is not None and (
        isinstance(chunk_size, bool)
        or not isinstance(chunk_size, int | np.integer)
        or chunk_size < 1
    ):
        raise InvalidParameterError(f"chunk_size must be a positive int, got {chunk_size!r}")


class LazyExecutor:
    """The run's executor, started on first use (a run served by the store starts none).

    Parameters
    ----------
    spec : None, str, Executor or distributed.Client
        As the ``executor`` argument of :meth:`fuzzymbs.study.study.Study.run`.
    check : callable
        Called with a freshly started process pool (closes it and raises if the
        model cannot travel to worker processes).
    timeout : float, optional
        Seconds a sample may take (see
        :func:`~fuzzymbs.study.evaluation.evaluate_chunk`); None: no limit.
    meanwhile : callable, optional
        Work this process does after the runs and can do before them: called once, in a
        daemon thread, when the first chunks are out on other processes (an executor
        other than inline), where this thread only waits for them (:meth:`waiting`).
        Its errors are logged, not raised (what it prepares is done again when needed).
    """

    def __init__(
        self,
        spec: Any,
        check: Callable[[Any], None],
        timeout: float | None = None,
        meanwhile: Callable[[], Any] | None = None,
    ) -> None:
        self.spec = spec
        self._check = check
        self.timeout = timeout
        self._resolved: Any = None
        self.label: str | None = None
        self._meanwhile = meanwhile

    def get(self) -> Any:
        """The resolved executor (see :func:`fuzzymbs.study.executors.resolve_executor`)."""
        if self._resolved is None:
            resolved = resolve_executor(self.spec)
            if resolved.label.startswith("processes"):
                self._check(resolved)
            self._resolved = resolved
            self.label = resolved.label
        return self._resolved

    def waiting(self) -> None:
        """Say that chunks are out: starts ``meanwhile`` (once) if they run elsewhere."""
        if self._meanwhile is None or self.label in (None, "inline"):
            return
        work, self._meanwhile = self._meanwhile, None

        def run() -> None:
            try:
                work()
            except Exception as exc:  # done again, and raised, where it is needed
                logger.debug("work meanwhile failed: %s", exc)

        threading.Thread(target=run, name="fuzzymbs-meanwhile", daemon=True).start()

    def close(self) -> None:
        """Shut the executor down if it was started."""
        if self._resolved is not None:
            self._resolved.close()


def evaluate_chunks(
    model: Any,
    outputs: Sequence[str] | None,
    columns: Callable[[int, int], Mapping[str, np.ndarray]],
    count: int,
    missing: Sequence[int],
    size: int,
    results: dict[int, ChunkResult],
    chunk_store: Any,
    work: LazyExecutor,
    *,
    progress: tuple[bool, int, str],
    fail_fast: Callable[[], None] | None,
    on_chunk: Callable[[int, ChunkResult], None] | None = None,
    may_submit: Callable[[], bool] | None = None,
    wrt: Sequence[str] = (),
) -> int:
    """Evaluate chunks ``missing`` of a table of ``count`` samples into ``results``.

    Parameters
    ----------
    model : the batched model; outputs : the outputs to keep (None: all).
    columns : ``columns(start, stop)`` gives every parameter column of samples
        ``start:stop``.
    size : samples per chunk; chunk ``i`` holds samples ``i size`` to ``(i + 1) size``.
    results : filled in place, chunk index -> :class:`ChunkResult`.
    chunk_store : a :class:`~fuzzymbs.study.store.ChunkStore` that receives every
        finished chunk before the next is awaited, or None.
    progress : ``(enabled, samples already done, label)`` of the progress bar.
    fail_fast : called (after cancelling the pending chunks) when a chunk holds a
        failed sample; it raises. None: evaluate everything.
    on_chunk : called with every finished chunk (after it was stored); ``results``
        then keeps the chunk without its outputs (streaming: memory does not grow
        with the run count).
    may_submit : while it returns False no further chunk is submitted (the
        consumer's backlog is full); chunks already running still finish.
    wrt : the parameters the model differentiates its outputs with respect to in every
        chunk (:func:`~fuzzymbs.study.evaluation.evaluate_chunk`); empty: none.

    Returns
    -------
    int
        The number of samples evaluated.

    Raises
    ------
    IncompleteResultError
        A worker ended while evaluating a chunk (a model that crashed its
        process, or a lost Dask worker); the chunks finished before are stored.
    """
    enabled, already, label = progress
    evaluated = 0
    started = time.perf_counter()
    with progress_bar(enabled, count, already, label) as advance:
        pending: dict[Future, int] = {}
        queue = list(missing)
        resolved = work.get() if queue else None
        while queue or pending:
            assert resolved is not None
            while (
                queue
                and len(pending) < resolved.in_flight
                and (not pending or may_submit is None or may_submit())
            ):
                index = queue.pop(0)
                start, stop = index * size, min((index + 1) * size, count)
                # wrt only where asked: a task without it is the same call as ever
                extra = (tuple(wrt),) if wrt else ()
                try:
                    future = resolved.executor.submit(
                        evaluate_chunk,
                        model,
                        columns(start, stop),
                        start,
                        outputs,
                        work.timeout,
                        resolved.task_threads,
                        *extra,
                    )
                except BrokenExecutor as exc:  # a worker died on an earlier chunk
                    raise _lost_worker(exc, start, stop, resolved.label) from exc
                pending[future] = index
            work.waiting()
            done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            for future in done:
                index = pending.pop(future)
                chunk = _chunk_result(future, index, size, count, resolved.label)
                if chunk_store is not None:
                    chunk_store.write(index, chunk)
                if on_chunk is not None:
                    on_chunk(index, chunk)
                    chunk = chunk.without_outputs()
                results[index] = chunk
                evaluated += chunk.size
                advance(chunk.size)
                if evaluated == chunk.size and len(queue) + len(pending) > 0:
                    _log_estimate(label, chunk, count - already, started, chunk_store, size)
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


#: Dask's errors for a task whose worker died (matched by name: Dask is optional)
_LOST_WORKER = frozenset({"KilledWorker", "CommClosedError", "FutureCancelledError"})


def _chunk_result(future: Future, index: int, size: int, count: int, label: str) -> ChunkResult:
    """The chunk a finished task computed; a lost worker becomes a one-line error."""
    try:
        return future.result()
    except BrokenExecutor as exc:  # the task never returned: its worker process ended
        lost: BaseException = exc
    except Exception as exc:
        if type(exc).__name__ not in _LOST_WORKER:
            raise
        lost = exc
    start, stop = index * size, min((index + 1) * size, count)
    raise _lost_worker(lost, start, stop, label) from lost


def _lost_worker(exc: BaseException, start: int, stop: int, label: str) -> IncompleteResultError:
    """The one-line error for a worker that ended while (or before) running samples start:stop."""
    return IncompleteResultError(
        f"a worker of executor {label!r} ended while evaluating samples {start} to "
        f"{stop - 1} or an earlier chunk ({type(exc).__name__}: {exc}); the model may have "
        "crashed its process (e.g. a fatal signal, out of memory). The chunks finished "
        "before are stored; run with the inline executor to see the model's own error"
    )


def _log_estimate(
    label: str, first: ChunkResult, remaining: int, started: float, chunk_store: Any, size: int
) -> None:
    """After the first (pilot) chunk: the run's size, time and disk estimate."""
    elapsed = time.perf_counter() - started
    per_sample = elapsed / max(first.size, 1)
    disk = ""
    if chunk_store is not None:
        path = chunk_store.chunk_path(first.start // size)
        if path.exists():
            chunks = -(-remaining // size)
            disk = f", about {path.stat().st_size * chunks / 1e6:.3g} MB of chunks on disk"
    logger.info(
        "%s: %d samples to evaluate; the first chunk took %.3g s for %d samples: about %.3g s "
        "on one worker (less in parallel)%s",
        label,
        remaining,
        elapsed,
        first.size,
        per_sample * remaining,
        disk,
    )


def assemble_chunks(
    chunks: Sequence[ChunkResult],
    count: int,
    check: OutputCheck | None = None,
    table: str = "the sample table",
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Concatenate chunk results in sample order; NaN rows where a chunk had no data.

    Every chunk passes ``check`` first (default: a new
    :class:`~fuzzymbs.study.evaluation.OutputCheck`; a study passes its own, so
    that its screening, plan and validation runs agree), ``table`` naming them.

    Returns ``(outputs {name: (count, ...)}, failed (count,) bool, reasons (count,) str)``.
    """
    check = OutputCheck() if check is None else check
    for chunk in chunks:
        check.check(chunk, table)
    failed = np.concatenate([c.failed for c in chunks]).astype(bool)
    reasons = np.concatenate([np.asarray(c.reasons, dtype=object) for c in chunks]).astype(str)
    shapes: dict[str, tuple[int, ...]] = {}
    used = [chunk for chunk in chunks if not chunk.failed.all()]  # others: NaN rows
    for chunk in used:
        for name, values in chunk.outputs.items():
            shapes.setdefault(name, values.shape[1:])
    outputs = rows_in_order(used, count, shapes, lambda chunk: chunk.outputs)
    return outputs, failed, reasons


@contextmanager
def progress_bar(
    enabled: bool, total: int, already: int, label: str
) -> Iterator[Callable[[int], None]]:
    """A Rich progress bar with ETA on stderr (or a no-op when disabled)."""
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


@contextmanager
def progress_phase(enabled: bool, label: str, total: int | None = None) -> Iterator[None]:
    """A progress line on stderr for work done in one call (a study's choice of the
    integrator tolerance, its time-integration check): a pulsing bar and the elapsed
    time while it runs, full when it returns (``total``: its samples, if known). A
    no-op when disabled."""
    if not enabled:
        yield
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    columns = (TextColumn("[bold]{task.description}"), BarColumn(), TimeElapsedColumn())
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=None)
        yield
        bar.update(task, total=total or 1, completed=total or 1)
