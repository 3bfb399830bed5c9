"""Evaluate one chunk of samples with a batched model, isolating failed samples.

This runs on workers (process pool, Dask), so it is a plain module-level
function of picklable arguments.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
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

    @property
    def size(self) -> int:
        return self.stop - self.start

    def without_outputs(self) -> ChunkResult:
        """The chunk's extent, failures and coordinates, without its outputs (what a
        streaming runner keeps once the outputs were reduced)."""
        return ChunkResult(self.start, self.stop, {}, self.failed, self.reasons, self.coords)


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
    reserved = (FAILED_KEY, REASON_KEY, COORDS_KEY)
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
    outputs: dict[str, np.ndarray] = {}
    for name in names:
        if name not in raw and failed.all():
            continue  # every sample failed: a model may return no outputs at all then
        if name not in raw:
            raise ModelOutputError(
                f"the model returned no output {name!r}; it returned: {', '.join(map(str, raw))}"
            )
        if np.iscomplexobj(raw[name]):
            raise ModelOutputError(
                f"model output {name!r} is complex; return real quantities "
                "(e.g. magnitude and phase as separate outputs)"
            )
        try:
            values = np.array(raw[name], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ModelOutputError(f"model output {name!r} is not numeric: {exc}") from exc
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


def evaluate_chunk(
    model: Any,
    columns: Mapping[str, np.ndarray],
    start: int,
    outputs: Sequence[str] | None = None,
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

    Raises
    ------
    ModelOutputError
        The model's return value breaks the contract (names the samples).
    """
    size = len(next(iter(columns.values())))
    try:
        raw = model(dict(columns))
    except Exception as exc:
        if size == 1:
            return ChunkResult(
                start,
                start + 1,
                {},
                np.ones(1, dtype=bool),
                np.array([f"{type(exc).__name__}: {exc}"]),
            )
    else:
        try:
            data, failed, reasons = _checked_outputs(raw, size, outputs)
            coords = _checked_coords(raw)
        except ModelOutputError as exc:
            raise ModelOutputError(
                f"{exc} (model called with samples {start} to {start + size - 1}, B = {size})"
            ) from None
        return ChunkResult(start, start + size, data, failed, reasons.astype(str), coords)
    # Isolate the failing samples: one call per sample, only after a batched call raised.
    singles = [
        evaluate_chunk(model, {k: v[i : i + 1] for k, v in columns.items()}, start + i, outputs)
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
    return ChunkResult(start, start + size, data, failed, reasons, coords)


def evaluate_chunk_on_worker(
    threads: int | None,
    model: Any,
    columns: Mapping[str, np.ndarray],
    start: int,
    outputs: Sequence[str] | None = None,
) -> ChunkResult:
    """:func:`evaluate_chunk` with the compiled kernels limited to ``threads`` threads.

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
        return evaluate_chunk(model, columns, start, outputs)
    previous = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        return evaluate_chunk(model, columns, start, outputs)
    finally:
        numba.set_num_threads(previous)
