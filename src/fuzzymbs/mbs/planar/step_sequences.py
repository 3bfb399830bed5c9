"""Step sequences of the mechanism engines: logging a run's steps and replaying them.

A run can log the end time of every accepted step (``simulate(..., log_steps=True)``)
and another run can take exactly those steps, without the step control
(``simulate(..., step_sequences=...)``): both engines' Runge-Kutta loops
(:func:`fuzzymbs.mbs.planar.integrator.run_sample`, the planar lanes kernel) then
take the sequence's steps as they come, with the same stages, projection and
output times. A replay of a run's own sequence repeats its trajectory to
round-off (the step lengths are the differences of the logged times), and runs
with nearby parameters replayed on one sequence differ by a smooth function of
the parameters: no step is accepted or rejected differently, so their difference
quotients are derivatives of one discretisation (internal numerical
differentiation; :mod:`fuzzymbs.mbs.central_differences`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError

#: accepted steps a run's log holds at first; a run that takes more is run again with a
#: log of its length (the same steps: a run does not depend on its log)
LOG_CAPACITY = 65_536

StepArrays = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]


def replay_arrays(
    step_sequences: Sequence[ArrayLike] | None, samples: int, times: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The kernels' (sequences (B, K), lengths (B,)) of ``step_sequences`` (one per sample;
    None or an empty one: the step control chooses), checked.

    Raises
    ------
    InvalidParameterError
        Not one sequence per sample, or a sequence that is not finite, strictly
        increasing from ``times[0]`` on, ending at ``times[-1]`` and through every
        output time.
    """
    if step_sequences is None:
        return np.zeros((samples, 0)), np.zeros(samples, dtype=np.int64)
    if len(step_sequences) != samples:
        raise InvalidParameterError(
            f"step_sequences must hold one sequence per sample ({samples}), "
            f"got {len(step_sequences)}"
        )
    rows = [np.asarray(seq, dtype=float).ravel() for seq in step_sequences]
    # a logged step ends at an output time, or a few ulps past it (the step control's
    # t + h may round past one)
    slack = 4.0 * np.spacing(np.abs(times[1:]))
    for i, row in enumerate(rows):
        if row.size == 0:
            continue
        steps = np.diff(np.concatenate([[times[0]], row]))
        last = row[-1] - times[-1]
        if not np.isfinite(row).all() or np.any(steps <= 0) or not 0 <= last <= slack[-1]:
            raise InvalidParameterError(
                f"step_sequences[{i}] must be finite, strictly increasing step end times "
                f"after {times[0]!r} ending at the last output time {times[-1]!r}"
            )
        at = np.searchsorted(row, times[1:])  # the first step end at or after each time
        if np.any(row[at] - times[1:] > slack):
            raise InvalidParameterError(
                f"step_sequences[{i}] must end a step at every output time (a run's "
                "logged steps do)"
            )
    lengths = np.array([row.size for row in rows], dtype=np.int64)
    sequences = np.zeros((samples, int(lengths.max(initial=0))))
    for i, row in enumerate(rows):
        sequences[i, : row.size] = row
    return sequences, lengths


def run_logging(
    run: Callable[[StepArrays], NDArray[np.float64]],
    replay: tuple[NDArray[np.float64], NDArray[np.int64]],
    samples: int,
    log_steps: bool,
) -> tuple[NDArray[np.float64], tuple[NDArray[np.float64], ...] | None]:
    """Run a batch (``run(steps) -> report``, report (B, 4) with the accepted steps in
    column 1), with each sample's accepted steps logged if ``log_steps``.

    Returns the report and the logs (one array of end times per sample, up to its
    failure where it failed), or None without ``log_steps``. A log that overflowed
    :data:`LOG_CAPACITY` runs the batch again with logs of the longest run's length.
    """
    capacity = LOG_CAPACITY if log_steps else 0
    while True:
        logs = np.zeros((samples, capacity))
        report = run((*replay, logs))
        if not log_steps:
            return report, None
        accepted = report[:, 1].astype(np.int64)
        longest = int(accepted.max(initial=0))
        if longest <= capacity:
            return report, tuple(logs[s, : accepted[s]].copy() for s in range(samples))
        capacity = longest
