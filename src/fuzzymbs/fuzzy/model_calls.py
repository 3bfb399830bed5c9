"""A batched model called on the rows of a table of parameter points, chunk by chunk.

Every plan evaluates its model this way (:meth:`fuzzymbs.fuzzy.transform.Plan.evaluate`,
each round of :meth:`fuzzymbs.fuzzy.transform.RoundsPlan.evaluate`), with the
same checks of what the model returns.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError, ModelOutputError

__all__ = ["evaluate_table"]


def evaluate_table(
    model: Callable[[dict[str, NDArray[np.float64]]], Mapping[str, Any]],
    names: Iterable[str],
    table: NDArray[np.float64],
    chunk_size: int | None = None,
) -> dict[str, NDArray]:
    """A batched model at the rows of ``table`` (K, n), ``chunk_size`` rows per call (all
    at once if None): every output with leading axis K (:meth:`Plan.evaluate`, and the
    rounds of the adaptive method's plan).

    Raises
    ------
    InvalidPlanError
        ``chunk_size`` not a positive int or None.
    ModelOutputError
        If the model returns something other than a mapping of numeric ndarrays with
        leading axis B, or outputs change between chunks.
    """
    count = len(table)
    if chunk_size is None:
        chunk_size = max(count, 1)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int | np.integer):
        raise InvalidPlanError(f"chunk_size must be a positive int or None, got {chunk_size!r}")
    if chunk_size < 1:
        raise InvalidPlanError(f"chunk_size must be >= 1, got {chunk_size!r}")
    columns = {name: table[:, i].copy() for i, name in enumerate(names)}
    pieces: dict[str, list[NDArray]] = {}
    for start in range(0, count, int(chunk_size)):
        stop = min(start + int(chunk_size), count)
        batch = {name: column[start:stop] for name, column in columns.items()}
        result = model(batch)
        _check_model_output(result, stop - start, pieces, start)
        for name, value in result.items():
            pieces.setdefault(name, []).append(value)
    return {name: np.concatenate(parts, axis=0) for name, parts in pieces.items()}


def _check_model_output(
    result: Any, batch: int, seen: Mapping[str, list[NDArray]], start: int
) -> None:
    """Raise ModelOutputError unless ``result`` is {name: numeric ndarray (batch, ...)}."""
    if not isinstance(result, Mapping) or not result:
        raise ModelOutputError(
            "a model must return a non-empty dict {output name: ndarray (B, ...)}, got "
            f"{type(result).__name__}"
        )
    if seen and set(result) != set(seen):
        raise ModelOutputError(
            f"model outputs changed between chunks: {sorted(seen)} before, {sorted(result)} "
            f"for samples from {start}"
        )
    for key, value in result.items():
        if not isinstance(value, np.ndarray):
            raise ModelOutputError(
                f"model output {key!r} must be a NumPy array with leading axis {batch}, got "
                f"{type(value).__name__}"
            )
        if value.ndim == 0 or value.shape[0] != batch:
            raise ModelOutputError(
                f"model output {key!r} must have leading axis B={batch} (one row per sample), "
                f"got shape {value.shape}"
            )
        if not (np.issubdtype(value.dtype, np.number) or value.dtype == np.bool_):
            hint = (
                " (failure flags and reasons are read by fuzzymbs.Study; with a bare plan, "
                "drop them and pass failed=... to retransform)"
                if key == "failure_reason"
                else ""
            )
            raise ModelOutputError(
                f"model output {key!r} must be numeric, got dtype {value.dtype}{hint}"
            )
        if seen and seen[key][0].shape[1:] != value.shape[1:]:
            raise ModelOutputError(
                f"model output {key!r} changed trailing shape between chunks: "
                f"{seen[key][0].shape[1:]} then {value.shape[1:]}"
            )
