"""Derivatives of a mechanism model's outputs by internal numerical differentiation.

A mechanism model's parameters reach the physics through the user's ``build``
function, so no derivative of the equations of motion with respect to them is
at hand. Its outputs' derivatives are taken instead as central differences of
runs on one discretisation (Bock's *internal numerical differentiation*): each
sample runs with its accepted steps logged, and for every parameter ``p_k`` two
runs at ``p_k +- delta_k`` replay exactly those steps
(:mod:`fuzzymbs.mbs.planar.step_sequences`). No step is then accepted, rejected
or sized differently between the two, so their difference is a smooth function
of ``delta_k``, and the quotient is the derivative of the sample's own discrete
trajectory to ``O(delta^2)``. Differences of runs that each chose their own steps
would carry the step control's jumps divided by ``2 delta`` (docs/mechanisms.md).

The step is relative, ``delta_k = GRADIENT_STEP |p_k|`` (``GRADIENT_STEP`` where
``p_k = 0``, in the parameter's SI unit). Cost: two runs per parameter besides
the sample's own (:data:`GRADIENT_COST`), all of them one batch of the engine;
docs/mechanisms.md ("Derivatives") has the convergence in the step and the
check against closed forms.

A pair whose second difference ``y+ + y- - 2 y`` exceeds :data:`LEFT_TRAJECTORY`
of the output's largest value is too far from the sample's own run for a central
difference: the output bends that much over the step, or the pair left the
sample's trajectory (a replay is only as stable as the steps it takes, and a
stiffer perturbed sample on steps the step control chose at the edge of the
method's stability grows where the sample did not). The sample is then reported
failed, with the parameter and the output, rather than given that quotient.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError

#: relative step of the central differences (docs/mechanisms.md, "Derivatives of the
#: outputs": on the registered mechanisms the truncation at 1e-4 is 1e-6 to 1e-8 of a
#: derivative for parameters that leave the beams as they are; parameters that reshape
#: a beam carry the reduction's round-off over the step, which passes the truncation
#: below 1e-4)
GRADIENT_STEP = 1e-4
#: runs per parameter differentiated, as a fraction of the run without (the study's
#: ``gradient_cost``): the two replayed runs of the central difference
GRADIENT_COST = 2.0
#: a pair of replayed runs whose second difference exceeds this fraction of the output's
#: largest value is too far from the sample's run for a central difference (at the
#: default step the registered mechanisms' pairs stay within 8e-3: the pendulum's tip
#: deflection, whose phase moves with the beam's length; 1e-5 elsewhere)
LEFT_TRAJECTORY = 0.1


def checked_wrt(wrt: Sequence[str], parameters: Sequence[str]) -> tuple[str, ...]:
    """``wrt`` as a tuple of distinct names of ``parameters``, or a clear error."""
    if isinstance(wrt, str):
        raise InvalidParameterError(f"wrt must be a sequence of parameter names, got {wrt!r}")
    names = tuple(wrt)
    unknown = sorted(set(names) - set(parameters))
    if unknown:
        raise InvalidParameterError(
            f"cannot differentiate with respect to {unknown}: this model's parameters "
            f"are {sorted(parameters)}"
        )
    if len(set(names)) != len(names):
        raise InvalidParameterError(f"wrt names a parameter twice: {list(names)}")
    return names


def differences(
    parameters: list[dict[str, float]], names: tuple[str, ...], live: NDArray[np.bool_]
) -> tuple[list[dict[str, float]], list[int], NDArray[np.float64]]:
    """The perturbed samples of the central differences: for each live sample s and each
    name k, ``p_k + delta`` then ``p_k - delta``. Returns (their parameters, the sample
    each belongs to, deltas (B, P); NaN for a sample not live)."""
    deltas = np.full((len(parameters), len(names)), np.nan)
    perturbed: list[dict[str, float]] = []
    owners: list[int] = []
    for s, p in enumerate(parameters):
        if not live[s]:
            continue
        for k, name in enumerate(names):
            value = p[name]
            delta = GRADIENT_STEP * (abs(value) if value != 0.0 else 1.0)
            deltas[s, k] = delta
            for sign in (1.0, -1.0):
                perturbed.append({**p, name: value + sign * delta})
                owners.append(s)
    return perturbed, owners, deltas


def gradients_and_failures(
    readers: dict[str, Callable[[Any], NDArray[np.float64]]],
    result: Any,
    run: Callable[[list[dict[str, float]], list[NDArray[np.float64]]], Any],
    parameters: list[dict[str, float]],
    names: tuple[str, ...],
) -> tuple[dict[str, NDArray[np.float64]], list[str | None]]:
    """The outputs' derivatives ``{output: (B, T, P)}`` of the samples of ``result`` (a run
    with ``log_steps``), and per sample why its differences failed (None: they did not).

    ``run(parameters, sequences)`` runs the perturbed samples, each on its sequence. A
    sample that failed itself gets NaN derivatives and no perturbed runs.
    """
    samples = len(parameters)
    live = ~np.asarray(result.failed, dtype=bool)
    perturbed, owners, deltas = differences(parameters, names, live)
    gradients: dict[str, NDArray[np.float64]] = {}
    reasons: list[str | None] = [None] * samples
    if not perturbed:
        for output, reader in readers.items():
            shape = np.asarray(reader(result)).shape
            gradients[output] = np.full((*shape, len(names)), np.nan)
        return gradients, reasons
    runs = run(perturbed, [result.step_logs[s] for s in owners])
    for i, s in enumerate(owners):
        if runs.failed[i] and reasons[s] is None:
            k = (i // 2) % len(names)
            side = "+" if i % 2 == 0 else "-"
            reasons[s] = f"its run at {names[k]} {side} {deltas[s, k]:.3g}: {runs.failure(i)}"
    rows = np.flatnonzero(live)
    for output, reader in readers.items():
        values = np.asarray(reader(runs), dtype=float)
        pairs = values.reshape(rows.size, len(names), 2, *values.shape[1:])
        _check_pairs(output, pairs, np.asarray(reader(result), dtype=float)[rows], rows, names,
                     deltas, reasons)  # fmt: skip
        quotient = (pairs[:, :, 0] - pairs[:, :, 1]) / (
            2.0 * deltas[rows].reshape(rows.size, len(names), *([1] * (values.ndim - 1)))
        )
        gradient = np.full((samples, *values.shape[1:], len(names)), np.nan)
        gradient[rows] = np.moveaxis(quotient, 1, -1)
        gradients[output] = gradient
    return gradients, reasons


def _check_pairs(output, pairs, nominal, rows, names, deltas, reasons) -> None:
    """Give ``reasons[s]`` to each sample s whose pair of replayed runs of some parameter
    is too far from its run on ``output`` (:data:`LEFT_TRAJECTORY`; not finite counts)."""
    axes = tuple(range(2, pairs.ndim - 1))
    scale = np.abs(nominal).reshape(nominal.shape[0], -1).max(axis=1)
    second = np.abs(pairs[:, :, 0] + pairs[:, :, 1] - 2.0 * nominal[:, None])
    worst = second.max(axis=axes) if axes else second
    for i, s in enumerate(rows):
        for k, name in enumerate(names):
            if reasons[s] is None and not worst[i, k] <= LEFT_TRAJECTORY * scale[i]:
                reasons[s] = (
                    f"its runs at {name} +- {deltas[s, k]:.3g} are too far from its own on "
                    f"{output!r} for a central difference (second difference "
                    f"{worst[i, k]:.3g}, the output's largest value {scale[i]:.3g}): the "
                    "output bends that much over the step, or the runs left its trajectory "
                    "on the replayed steps"
                )
