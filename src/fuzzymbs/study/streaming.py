"""A study's outputs reduced chunk by chunk as they arrive: memory independent of the run count.

:class:`ChunkFeed` receives the plan's chunks in any order (from the executor,
or from the chunk store on resume), puts them back in sample order and feeds
each output to an :class:`~fuzzymbs.fuzzy.accumulate.OutputAccumulator`; the
chunk is dropped afterwards. What stays in memory is the accumulators (a few
arrays of the output's shape per level), the failed flags and reasons (one per
sample), the chunks waiting for an earlier one (at most a few per worker), and
the raw per-sample outputs only when they are kept (``keep_raw``; by default
only below :data:`RAW_LIMIT_BYTES`, the chunk store keeps them anyway).

Sparse plans are collected whole: their interpolant needs every sample.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fuzzymbs.errors import StoreMismatchError
from fuzzymbs.fuzzy.accumulate import OutputAccumulator, StreamLayout
from fuzzymbs.fuzzy.retransform import FuzzyResult, from_accumulated
from fuzzymbs.study.evaluation import ChunkResult, OutputCheck
from fuzzymbs.study.integration_check import CutBounds, choose_samples

__all__ = ["RAW_LIMIT_BYTES", "ChunkFeed"]

logger = logging.getLogger(__name__)

#: raw per-sample outputs go into the result by default only below this size [bytes]
RAW_LIMIT_BYTES = 64 * 2**20
#: chunks that may wait for an earlier one before the runner stops submitting new ones
BACKLOG_CHUNKS = 16


class ChunkFeed:
    """Puts a plan's chunks in sample order and reduces each output online.

    Parameters
    ----------
    plan : Plan
        The study's plan.
    count, size : the number of samples and the chunk size.
    stored : iterable of int
        Chunks in the store (read from ``chunk_store`` when their turn comes).
    chunk_store : ChunkStore or None
    keep_raw : bool or None
        Keep every sample's outputs: True, False, or None (only if they take
        at most :data:`RAW_LIMIT_BYTES`).
    check : OutputCheck, optional
        What every chunk passes before it is reduced (the study's own, shared
        with its screening and validation runs; default: a new one).
    """

    def __init__(
        self,
        plan: Any,
        count: int,
        size: int,
        stored: Any,
        chunk_store: Any,
        keep_raw: bool | None = None,
        check: OutputCheck | None = None,
    ) -> None:
        self.plan = plan
        self.count = count
        self.chunk_count = math.ceil(count / size) if count else 0
        self.stored = set(stored)
        self.chunk_store = chunk_store
        self.keep_raw = keep_raw
        # sparse and adaptive plans bound their cuts by a surrogate of every sample
        self.layout = StreamLayout(plan) if plan.scheme.supports_streaming else None
        self.failed = np.zeros(count, dtype=bool)
        self.reasons = np.full(count, "", dtype=object)
        self.accumulators: dict[str, OutputAccumulator] = {}
        self.raw: dict[str, np.ndarray] | None = None
        self._pending_failed: list[tuple[int, int]] = []  # all-failed chunks before any shape
        self._buffer: dict[int, ChunkResult] = {}
        self._next = 0
        self._check = OutputCheck() if check is None else check
        self._results: tuple[dict[str, FuzzyResult], list[Any]] | None = None

    # ----------------------------------------------------------------- feeding
    def add(self, index: int, chunk: ChunkResult) -> None:
        """A finished chunk (any order); it is reduced once every earlier one was."""
        self._buffer[index] = chunk
        self.drain()

    def backlog(self) -> int:
        """Chunks waiting for an earlier one."""
        return len(self._buffer)

    def may_submit(self) -> bool:
        """False while too many chunks wait for an earlier one (bounds the memory)."""
        return len(self._buffer) < BACKLOG_CHUNKS

    def drain(self) -> None:
        """Reduce every chunk that is next in line: buffered, or in the store."""
        while self._next < self.chunk_count:
            index = self._next
            if index in self._buffer:
                chunk = self._buffer.pop(index)
            elif index in self.stored:
                chunk = self.chunk_store.read(index)
                if chunk is None:  # vanished or damaged since it was opened
                    raise StoreMismatchError(
                        f"stored chunk {index} of {self.chunk_store.path} changed or vanished "
                        "while this run used it (another process writing into the same "
                        "store?); rerun to evaluate it again"
                    )
            else:
                return
            self._consume(chunk)
            self._next += 1

    def _consume(self, chunk: ChunkResult) -> None:
        self._check.check(chunk)  # same outputs and shapes as every chunk before
        start, stop = chunk.start, chunk.stop
        self.failed[start:stop] = np.asarray(chunk.failed, dtype=bool)
        self.reasons[start:stop] = np.asarray(chunk.reasons, dtype=object)
        if not chunk.outputs or chunk.failed.all():  # no value of it is used
            if self.accumulators or self.raw is not None:
                self._skip_failed(start, stop)
            else:
                self._pending_failed.append((start, stop))
            return
        if not self.accumulators and self.raw is None:
            self._start(chunk.outputs)
        for name, values in chunk.outputs.items():
            if self.layout is not None:
                self.accumulators[name].update(start, values, chunk.failed)
            if self.raw is not None:
                self.raw[name][start:stop] = values

    def _start(self, outputs: Mapping[str, np.ndarray]) -> None:
        """Create the accumulators (and raw arrays) once the outputs' shapes are known."""
        shapes = {name: np.shape(values)[1:] for name, values in outputs.items()}
        raw_bytes = 8 * self.count * sum(int(np.prod(s, dtype=np.int64)) for s in shapes.values())
        keep = self.keep_raw if self.keep_raw is not None else raw_bytes <= RAW_LIMIT_BYTES
        if keep or self.layout is None:  # sparse plans need every sample
            self.raw = {name: np.full((self.count, *s), np.nan) for name, s in shapes.items()}
        if self.layout is not None:
            self.accumulators = {
                name: OutputAccumulator(self.layout, shape) for name, shape in shapes.items()
            }
        for start, stop in self._pending_failed:
            self._skip_failed(start, stop)
        self._pending_failed.clear()
        logger.debug(
            "study outputs %s: raw outputs %.1f MB, %s",
            list(shapes),
            raw_bytes / 1e6,
            "kept" if self.raw is not None else "left in the chunk store",
        )

    def _skip_failed(self, start: int, stop: int) -> None:
        """Feed a range of failed samples (they only advance the accumulators)."""
        for accumulator in self.accumulators.values():
            accumulator.update(
                start, np.zeros((stop - start, *accumulator.shape)), np.ones(stop - start, bool)
            )

    # --------------------------------------------------------------- results
    @property
    def complete(self) -> bool:
        """Every chunk was reduced."""
        return self._next == self.chunk_count

    def results(self, check_monotonic: bool = True) -> dict[str, FuzzyResult]:
        """The retransformed outputs (warns like :meth:`Plan.retransform`, on every call;
        with ``check_monotonic`` the first call's results are kept and returned again)."""
        import warnings

        if not check_monotonic:
            return self._retransform(False)
        if self._results is None:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                fuzzy = self._retransform(True)
            self._results = (fuzzy, list(caught))
        fuzzy, caught = self._results
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return fuzzy

    def _retransform(self, check_monotonic: bool) -> dict[str, FuzzyResult]:
        if not self.complete:
            raise RuntimeError(f"{self._next} of {self.chunk_count} chunks reduced")
        if self.layout is None:
            assert self.raw is not None
            fuzzy = self.plan.retransform(
                dict(self.raw), failed=self.failed, check_monotonic=check_monotonic
            )
            return fuzzy if isinstance(fuzzy, dict) else {"output": fuzzy}
        return {
            name: from_accumulated(
                self.plan,
                accumulator.finish(self.failed, name=name, check_monotonic=check_monotonic),
            )
            for name, accumulator in self.accumulators.items()
        }

    def nominal(self) -> dict[str, np.ndarray]:
        """Every output at the all-modal sample (NaN if it failed)."""
        index = self.plan.nominal_index
        if self.raw is not None:
            return {name: values[index] for name, values in self.raw.items()}
        return {
            name: accumulator.nominal.reshape(accumulator.shape)
            for name, accumulator in self.accumulators.items()
        }

    def bound_tally(self, level: int) -> np.ndarray:
        """(N,) how many output elements (of all outputs) each sample bounds at ``level``."""
        if self.layout is None:
            raise RuntimeError("sparse plans have no per-level bounds to tally")
        tally = np.zeros(self.count, dtype=np.int64)
        for accumulator in self.accumulators.values():
            tally += accumulator.bound_tally(level)
        return tally

    def bounding_samples(self) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
        """Output -> (L, size) the samples that give each nested cut bound (lower, upper);
        None for a sparse plan (its bounds come from an interpolant)."""
        if self.layout is None:
            return None
        return {
            name: accumulator.nested_extremes()[2:]
            for name, accumulator in self.accumulators.items()
        }

    def reasons_array(self) -> np.ndarray:
        """(N,) failure reasons as str ("" where the sample succeeded)."""
        return self.reasons.astype(str)


def integration_inputs(
    feed: ChunkFeed,
    names: Sequence[str],
    failed: np.ndarray,
    runs: int,
    include_nominal: bool = True,
) -> tuple[list[int], dict[str, CutBounds | None]]:
    """What the time-integration check needs from a finished feed: the samples to re-run
    (:func:`~fuzzymbs.study.integration_check.choose_samples`) and each output's nested
    bounds with the samples that give them (None for a sparse plan, whose bounds come
    from an interpolant: its check falls back to the modal sample). ``include_nominal``
    False leaves the modal sample out (a model on shared steps has no error there)."""
    nominal = feed.plan.nominal_index
    if feed.layout is None:
        return ([] if failed[nominal] else [nominal]), {name: None for name in names}
    levels = len(feed.plan.levels)
    tallies = [feed.bound_tally(level) for level in range(levels)]
    samples = choose_samples(
        tallies, nominal, np.asarray(failed, dtype=bool), runs, include_nominal
    )
    bounds = {}
    for name in names:
        lower, upper, lower_sample, upper_sample = feed.accumulators[name].nested_extremes()
        bounds[name] = CutBounds(lower, upper, lower_sample, upper_sample)
    return samples, bounds
