"""Evaluate one chunk of samples with a batched model, isolating failed samples.

This runs on workers (process pool, Dask), so it is a plain module-level
function of picklable arguments.
"""

from __future__ import annotations

import os
import re
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fuzzymbs.errors import ModelOutputError

#: Optional model outputs that flag failed samples instead of carrying data.
FAILED_KEY = "failed"
REASON_KEY = "failure_reason"
#: Optional model output giving coordinate values found while running (e.g. the time column
#: of an external program's output file): ``{dim: (T,) array}``, not batched.
COORDS_KEY = "coords"
#: The model's gradients when a study calls it with ``wrt=names`` (a model that declares
#: ``differentiable``): ``{output: (B, *output_shape, len(wrt))}``, the last axis in
#: ``wrt`` order and in the parameters' units.
GRADIENTS_KEY = "gradients"
#: an output name becomes NetCDF variables (``<name>_lower``) and plot file names
#: (``<name>_membership_time_0.5.png``): it starts with a letter, digit or "_", holds
#: no path separator, control or reserved file-name character, and is at most 100 long
MAX_OUTPUT_NAME = 100
_SAFE_NAME = re.compile(r"[A-Za-z0-9_][^/\\\x00-\x1f\x7f<>:\"|?*]*")


def check_output_name(name: object, where: str = "model output") -> str:
    """``name`` if it can be a NetCDF variable and part of a file name, else raise.

    Raises
    ------
    ModelOutputError
        Not a string, empty, too long, or holding characters that a file name or a
        NetCDF variable cannot hold (names the output and what is allowed).
    """
    if (
        not isinstance(name, str)
        or len(name) > MAX_OUTPUT_NAME
        or not _SAFE_NAME.fullmatch(name)
        or name != name.rstrip()
    ):
        raise ModelOutputError(
            f"{where} name {name!r} cannot name a dataset variable and a plot file: "
            f"use at most {MAX_OUTPUT_NAME} characters, starting with a letter, digit or "
            '"_", without path separators, control characters or any of <>:"|?*'
        )
    return name


@dataclass
class ChunkResult:
    """Outputs of samples ``start:stop`` and which of them failed.

    ``outputs[name]`` is ``(B, ...)`` float64 with NaN rows for failed samples,
    or absent when every sample of the chunk failed before its shape was known.
    """

    start: int
    stop: int
    outputs: dict[str, np.ndarray]
    failed: np.ndarray  # (B,) bool
    reasons: np.ndarray  # (B,) str, "" where the sample succeeded
    coords: dict[str, np.ndarray] = field(default_factory=dict)  # returned under COORDS_KEY
    #: ``{output: (B, *shape, len(wrt))}`` where the model was asked for its gradients (NaN
    #: rows for failed samples); empty otherwise
    gradients: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def size(self) -> int:
        return self.stop - self.start

    def without_outputs(self) -> ChunkResult:
        """The chunk's extent, failures and coordinates, without its outputs and gradients
        (what a streaming runner keeps once the outputs were reduced)."""
        return ChunkResult(self.start, self.stop, {}, self.failed, self.reasons, self.coords)


def rows_in_order(
    chunks: Sequence[ChunkResult],
    count: int,
    shapes: Mapping[str, tuple[int, ...]],
    arrays: Callable[[ChunkResult], Mapping[str, np.ndarray]],
) -> dict[str, np.ndarray]:
    """Every array named in ``shapes``, ``(count, *shape)`` in sample order, gathered
    from the chunks' ``arrays(chunk)`` (their outputs or gradients); NaN rows where no
    chunk holds that array."""
    gathered = {}
    for name, shape in shapes.items():
        merged = np.full((count, *shape), np.nan)
        for chunk in chunks:
            values = arrays(chunk)
            if name in values:
                merged[chunk.start : chunk.stop] = values[name]
        gathered[name] = merged
    return gathered


def _checked_coords(raw: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The coordinate values a model returned under :data:`COORDS_KEY` (1-D float arrays)."""
    given = raw.get(COORDS_KEY)
    if given is None:
        return {}
    if not isinstance(given, Mapping):
        raise ModelOutputError(
            f"model output {COORDS_KEY!r} must be a dict {{dimension: 1-D array}}, "
            f"got {type(given).__name__}"
        )
    coords = {}
    for dim, values in given.items():
        array = np.asarray(values, dtype=np.float64)
        if array.ndim != 1 or not np.isfinite(array).all():
            raise ModelOutputError(
                f"coordinate {dim!r} returned by the model must be a finite 1-D array"
            )
        coords[str(dim)] = array
    return coords


class OutputCheck:
    """Every chunk of a study returns the same outputs with the same trailing shapes.

    The one place that compares chunks with each other (each chunk's own
    values are checked where it is evaluated): a study run passes every chunk
    of its screening, its plan and its validation runs through one instance,
    whether the chunk was just computed or read from the store, before its
    values are used.
    """

    def __init__(self) -> None:
        self.shapes: dict[str, tuple[int, ...]] | None = None
        self._first = ""

    def check(self, chunk: ChunkResult, table: str = "the plan") -> None:
        """Raise :class:`ModelOutputError` if ``chunk`` (of sample table ``table``)
        disagrees with the chunks before it.

        A chunk whose samples all failed has no values to compare (none is used).
        """
        if chunk.failed.all():
            return
        where = f"samples {chunk.start} to {chunk.stop - 1} of {table}"
        shapes = {name: tuple(np.shape(values)[1:]) for name, values in chunk.outputs.items()}
        for name, values in chunk.outputs.items():
            if np.shape(values)[:1] != (chunk.size,) or np.asarray(values).dtype.kind != "f":
                raise ModelOutputError(
                    f"output {name!r} of {where} is not a ({chunk.size}, ...) array of numbers"
                )
        if not shapes:
            raise ModelOutputError(f"{where}: the model returned no outputs")
        if self.shapes is None:
            self.shapes, self._first = shapes, where
            return
        if set(shapes) != set(self.shapes):
            added = sorted(set(shapes) - set(self.shapes))
            gone = sorted(set(self.shapes) - set(shapes))
            change = "; ".join(
                part
                for part in (f"new {added}" if added else "", f"missing {gone}" if gone else "")
                if part
            )
            raise ModelOutputError(
                f"the model's outputs differ between {self._first} and {where}: {change}. "
                "A model must return the same outputs for every sample"
            )
        for name, shape in shapes.items():
            if shape != self.shapes[name]:
                raise ModelOutputError(
                    f"model output {name!r} has trailing shape {shape} for {where} but "
                    f"{self.shapes[name]} for {self._first}; a model must return the same "
                    "shape for every sample"
                )


def merged_coords(chunks: Sequence[ChunkResult]) -> dict[str, np.ndarray]:
    """The coordinates the chunks returned, which must agree between chunks.

    Raises
    ------
    ModelOutputError
        A coordinate differs between two chunks (names the samples).
    """
    merged: dict[str, np.ndarray] = {}
    first: dict[str, int] = {}
    for chunk in chunks:
        for dim, values in chunk.coords.items():
            if dim not in merged:
                merged[dim], first[dim] = values, chunk.start
            elif values.shape != merged[dim].shape or not np.allclose(
                values, merged[dim], rtol=1e-9, atol=0.0
            ):
                raise ModelOutputError(
                    f"coordinate {dim!r} differs between the runs from sample {first[dim]} "
                    f"and sample {chunk.start}; every run must report the same {dim!r} values"
                )
    return merged


def _checked_outputs(
    raw: Any, size: int, wanted: Sequence[str] | None
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Validate a model's return value; mark non-finite or flagged samples failed."""
    if not isinstance(raw, Mapping):
        raise ModelOutputError(
            f"the model returned {type(raw).__name__}; it must return a dict "
            "{output name: (B, ...) array}"
        )
    reserved = (FAILED_KEY, REASON_KEY, COORDS_KEY, GRADIENTS_KEY)
    names = list(wanted) if wanted else [k for k in raw if k not in reserved]
    failed = np.zeros(size, dtype=bool)
    reasons = np.full(size, "", dtype=object)
    if FAILED_KEY in raw:
        flagged = np.asarray(raw[FAILED_KEY], dtype=bool).reshape(-1)
        if flagged.shape != (size,):
            raise ModelOutputError(
                f"model output {FAILED_KEY!r} has shape {flagged.shape}, expected ({size},)"
            )
        given = raw.get(REASON_KEY)
        given = np.asarray(given, dtype=object).reshape(-1) if given is not None else None
        for i in np.flatnonzero(flagged):
            text = str(given[i]) if given is not None and given.shape == (size,) else ""
            reasons[i] = text or "the model flagged this sample as failed"
        failed |= flagged
    if not names and not failed.all():
        raise ModelOutputError(
            "the model returned no outputs"
            + (f" (only {', '.join(map(repr, raw))})" if raw else "")
            + "; it must return at least one {output name: (B, ...) array}"
        )
    outputs: dict[str, np.ndarray] = {}
    for name in names:
        check_output_name(name)
        if name not in raw and failed.all():
            continue  # every sample failed: a model may return no outputs at all then
        if name not in raw:
            raise ModelOutputError(
                f"the model returned no output {name!r}; it returned: {', '.join(map(str, raw))}"
            )
        try:
            given = np.asarray(raw[name])
        except (TypeError, ValueError) as exc:  # e.g. a ragged list
            raise ModelOutputError(
                f"model output {name!r} is not a numeric array ({exc}); return a "
                "(B, ...) array of numbers"
            ) from None
        if np.iscomplexobj(given):
            raise ModelOutputError(
                f"model output {name!r} is complex; return real quantities "
                "(e.g. magnitude and phase as separate outputs)"
            )
        if given.dtype.kind not in "biuf":  # strings such as "13.5" are no numbers
            raise ModelOutputError(
                f"model output {name!r} holds {given.dtype} values, not numbers; "
                "return a (B, ...) array of numbers"
            )
        values = np.array(given, dtype=np.float64)
        if values.ndim == 0 or values.shape[0] != size:
            raise ModelOutputError(
                f"model output {name!r} has shape {values.shape}; its leading axis must be "
                f"the batch of {size} samples"
            )
        finite = np.isfinite(values.reshape(size, -1)).all(axis=1)
        for i in np.flatnonzero(~finite & ~failed):
            reasons[i] = f"non-finite value (NaN or inf) in output {name!r}"
        failed |= ~finite
        outputs[name] = values
    for values in outputs.values():
        values[failed] = np.nan
    return outputs, failed, reasons


def _checked_gradients(
    raw: Mapping[str, Any],
    outputs: Mapping[str, np.ndarray],
    failed: np.ndarray,
    reasons: np.ndarray,
    wrt: Sequence[str],
) -> dict[str, np.ndarray]:
    """The gradients a model returned under :data:`GRADIENTS_KEY` when called with ``wrt``,
    one ``(B, *shape, len(wrt))`` array per kept output (NaN rows where a sample failed).

    A gradient with NaN or inf fails its sample (``failed`` and ``reasons`` are updated in
    place): a run whose gradient is unknown is reported, never averaged in.

    Raises
    ------
    ModelOutputError
        No gradients, not a dict, an output without its gradient, a wrong shape, complex
        or non-numeric values: the model breaks the gradient protocol.
    """
    given = raw.get(GRADIENTS_KEY)
    asked = f"the model was called with wrt={list(wrt)}"
    if given is None and failed.all():
        return {}  # every sample failed: a model may return nothing then
    if not isinstance(given, Mapping):
        got = "no gradients" if given is None else f"{type(given).__name__}"
        raise ModelOutputError(
            f"{asked} (it declares them differentiable) but returned {got} under "
            f"{GRADIENTS_KEY!r}; it must return {{output name: (B, *output shape, "
            f"{len(wrt)}) array}}, the last axis in the order of wrt"
        )
    size = len(failed)
    gradients: dict[str, np.ndarray] = {}
    for name, values in outputs.items():
        if name not in given:
            raise ModelOutputError(
                f"{asked} but returned no gradient of output {name!r} (gradients of: "
                f"{', '.join(map(str, given)) or 'none'})"
            )
        try:
            slope = np.asarray(given[name])
        except (TypeError, ValueError) as exc:
            raise ModelOutputError(f"gradient of output {name!r} is not an array ({exc})") from None
        expected = (size, *values.shape[1:], len(wrt))
        if slope.dtype.kind not in "biuf" or slope.shape != expected:
            kind = "complex" if np.iscomplexobj(slope) else f"{slope.dtype} {slope.shape}"
            raise ModelOutputError(
                f"gradient of output {name!r} must be a real array of shape {expected} "
                f"(samples, output shape, one entry per parameter of wrt={list(wrt)}), got {kind}"
            )
        slope = np.array(slope, dtype=np.float64)
        finite = np.isfinite(slope.reshape(size, -1, len(wrt)))
        for i in np.flatnonzero(~finite.all(axis=(1, 2)) & ~failed):
            bad = [wrt[k] for k in np.flatnonzero(~finite[i].all(axis=0))]
            reasons[i] = (
                f"non-finite gradient (NaN or inf) of output {name!r} with respect to "
                f"{', '.join(bad)}"
            )
            failed[i] = True
        gradients[name] = slope
    for name in outputs:
        outputs[name][failed] = np.nan
    for slope in gradients.values():
        slope[failed] = np.nan
    return gradients


class SampleStopped(Exception):
    """A model call ended by the runner: it exited or ran over its time limit."""


#: the interpreter's own os._exit: a model's call is intercepted, the runner's is not
_REAL_EXIT = os._exit


def hard_exit(status: int) -> None:
    """End this process at once (``os._exit``), also while a model's call is intercepted."""
    _REAL_EXIT(status)


def _guarded() -> bool:
    """Exit and time-limit guards need signals and a global: only a process's main thread."""
    return threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer")


@contextmanager
def _guards(limit: float | None) -> Iterator[None]:
    """While a model runs: ``os._exit`` raises, and SIGALRM after ``limit`` seconds raises."""
    if not _guarded():
        yield
        return

    def refuse_exit(code: int) -> None:
        raise SampleStopped(f"the model called os._exit({code})")

    def time_up(_signum: int, _frame: Any) -> None:
        raise SampleStopped(f"timed out after {limit:g} s")

    os._exit = refuse_exit  # type: ignore[assignment]
    previous = signal.signal(signal.SIGALRM, time_up) if limit is not None else None
    try:
        if limit is not None:
            signal.setitimer(signal.ITIMER_REAL, limit)
        yield
    finally:
        try:  # an alarm firing just now still leaves the handler and os._exit restored
            if limit is not None:
                signal.setitimer(signal.ITIMER_REAL, 0)
        finally:
            if limit is not None:
                signal.signal(signal.SIGALRM, previous)
            os._exit = _REAL_EXIT


def _call_model(
    model: Any,
    columns: Mapping[str, np.ndarray],
    limit: float | None,
    wrt: Sequence[str] | None = None,
) -> Any:
    """``model(columns)`` (with ``wrt``: ``model(columns, wrt=list(wrt))``); an exit or a
    time-out of the model raises :class:`SampleStopped`."""
    try:
        with _guards(limit):
            if wrt:
                return model(dict(columns), wrt=list(wrt))
            return model(dict(columns))
    except SystemExit as exc:  # a model's sys.exit must not end the study (with status 0)
        raise SampleStopped(f"the model called sys.exit({exc.code!r})") from None


def evaluate_chunk(
    model: Any,
    columns: Mapping[str, np.ndarray],
    start: int,
    outputs: Sequence[str] | None = None,
    timeout: float | None = None,
    threads: int | None = None,
    wrt: Sequence[str] | None = None,
) -> ChunkResult:
    """Evaluate samples ``start : start + B`` with one model call.

    If the batched call raises, the samples are re-evaluated one by one so
    only the failing ones are marked failed (with the exception as reason).
    Outputs that break the model contract (not a dict, wrong leading axis,
    complex or non-numeric values) are a bug of the model, not a failed
    sample: they raise at once, without re-evaluating sample by sample.

    Parameters
    ----------
    model : callable
        ``model({name: (B,) array}) -> {output: (B, ...) array}``.
    columns : mapping of str to (B,) ndarray
        Every parameter column of the chunk (fuzzy and crisp).
    start : int
        Index of the chunk's first sample in the plan.
    outputs : sequence of str, optional
        Outputs to keep (default: all the model returns).
    timeout : float, optional
        Seconds a sample may take (a batch of B samples: B times as long); a
        sample over it fails with reason "timed out". Enforced where the chunk
        runs in a process's main thread (inline and process executors, on POSIX).
    threads : int, optional
        The compiled kernels limited to this many threads for the chunk (a worker of a
        pool, :func:`kernel_threads`); None: as they are.
    wrt : sequence of str, optional
        Parameters to differentiate with respect to: the model is called as
        ``model(columns, wrt=list(wrt))`` and its gradients are checked and kept
        (:attr:`ChunkResult.gradients`; a non-finite gradient fails its sample). None or
        empty: ``model(columns)``, as for every model.

    A model that calls ``sys.exit`` or ``os._exit`` (the latter where enforced
    like the timeout) fails the affected samples with that reason instead of
    ending the process.

    Raises
    ------
    ModelOutputError
        The model's return value breaks the contract (names the samples).
    """
    if threads is not None:
        with kernel_threads(threads):
            return evaluate_chunk(model, columns, start, outputs, timeout, None, wrt)
    size = len(next(iter(columns.values())))
    try:
        # a batch may take ``timeout`` per sample; a single sample, ``timeout``
        raw = _call_model(model, columns, None if timeout is None else timeout * size, wrt)
    except Exception as exc:
        if size == 1:
            return ChunkResult(
                start,
                start + 1,
                {},
                np.ones(1, dtype=bool),
                np.array(
                    [str(exc) if isinstance(exc, SampleStopped) else f"{type(exc).__name__}: {exc}"]
                ),
            )
    else:
        try:
            data, failed, reasons = _checked_outputs(raw, size, outputs)
            coords = _checked_coords(raw)
            slopes = _checked_gradients(raw, data, failed, reasons, wrt) if wrt else {}
        except ModelOutputError as exc:
            raise ModelOutputError(
                f"{exc} (model called with samples {start} to {start + size - 1}, B = {size})"
            ) from None
        return ChunkResult(start, start + size, data, failed, reasons.astype(str), coords, slopes)
    # Isolate the failing samples: one call per sample, only after a batched call raised.
    singles = [
        evaluate_chunk(
            model,
            {k: v[i : i + 1] for k, v in columns.items()},
            start + i,
            outputs,
            timeout,
            None,
            wrt,
        )
        for i in range(size)
    ]
    failed = np.concatenate([s.failed for s in singles])
    reasons = np.concatenate([s.reasons for s in singles]).astype(str)
    data: dict[str, np.ndarray] = {}
    shapes = {n: v.shape[1:] for s in singles for n, v in s.outputs.items()}
    for name, shape in shapes.items():
        merged = np.full((size, *shape), np.nan)
        for i, single in enumerate(singles):
            if name in single.outputs:
                if single.outputs[name].shape[1:] != shape:
                    raise ModelOutputError(
                        f"model output {name!r} changes shape between samples: "
                        f"{single.outputs[name].shape[1:]} vs {shape}"
                    )
                merged[i] = single.outputs[name][0]
        data[name] = merged
    coords = merged_coords(singles)
    slopes: dict[str, np.ndarray] = {}
    for name in data if wrt else ():
        rows = [s.gradients.get(name) for s in singles]
        shape = next((r.shape[1:] for r in rows if r is not None), None)
        if shape is not None:
            slopes[name] = np.stack(
                [r[0] if r is not None else np.full(shape, np.nan) for r in rows]
            )
    return ChunkResult(start, start + size, data, failed, reasons, coords, slopes)


@contextmanager
def kernel_threads(threads: int | None) -> Iterator[None]:
    """The compiled kernels limited to ``threads`` threads inside the block.

    A worker of a process pool or a Dask cluster shares the machine's cores with
    the other workers: Numba's default (every core) in each of them oversubscribes
    the machine (measured: 2 single-thread Dask workers 1.65 times one inline core
    with Numba's default, 1.83 with one thread each; docs/benchmarks.md). The
    limit is set in the worker thread that runs the chunk (Numba's thread count is
    per thread) and restored afterwards; the kernels parallelise over samples, so
    the result does not depend on it. ``None``, or a model without Numba: as is.
    """
    numba = sys.modules.get("numba")
    if threads is None or numba is None:
        yield
        return
    previous = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(previous)
