"""Derivatives of a model's outputs as central differences of runs on one discretisation.

Where no derivative of the equations of motion with respect to a parameter is at
hand -- a mechanism model's parameters reach the physics through the user's
``build`` function; RK4 integrates no sensitivity equations -- the outputs'
derivatives are central differences of runs that take the sample's own steps
(Bock's *internal numerical differentiation*): for every parameter ``p_k`` two
runs at ``p_k +- delta_k`` on the steps the sample took, which a mechanism's run
logs and its perturbed runs replay (:mod:`fuzzymbs.mbs.planar.step_sequences`)
and RK4's fixed step gives every run alike. No step is then accepted, rejected
or sized differently between the two, so their difference is a smooth function
of ``delta_k``, and the quotient is the derivative of the sample's own discrete
trajectory to ``O(delta^2)``. Differences of runs that each chose their own steps
would carry the step control's jumps divided by ``2 delta`` (docs/mechanisms.md).

The step is relative, ``delta_k = GRADIENT_STEP |p_k|`` (``GRADIENT_STEP`` where
``p_k = 0``, in the parameter's SI unit), unless the model names an absolute one (a
mechanism model's ``gradient_steps``: a misalignment whose default is 0 m wants
micrometres, not 1e-4 m). Cost: two runs per parameter besides
the sample's own (:data:`GRADIENT_COST`), all of them one batch of the engine;
docs/mechanisms.md ("Derivatives of the outputs") has the convergence in the
step and the checks against closed forms.

A pair whose second difference ``y+ + y- - 2 y`` exceeds :data:`LEFT_TRAJECTORY`
of the output's largest value is too far from the sample's own run for a central
difference: the output bends that much over the step, or the pair left the
sample's trajectory (a replay is only as stable as the steps it takes, and a
stiffer perturbed sample on steps the step control chose at the edge of the
method's stability grows where the sample did not). The sample is then reported
failed, with the parameter and the output, rather than given that quotient.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
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
#: ``gradient_cost``): the two runs of the central difference
GRADIENT_COST = 2.0
#: a pair of runs whose second difference exceeds this fraction of the output's largest
#: value is too far from the sample's run for a central difference (at the default step
#: the registered mechanisms' pairs stay within 8e-3: the pendulum's tip deflection,
#: whose phase moves with the beam's length; 1e-5 elsewhere)
LEFT_TRAJECTORY = 0.1

#: ``run(perturbed parameters, the sample each belongs to) -> (outputs {name: (N, ...)},
#: failed (N,), why each failed (N,))``: the perturbed runs, each on its sample's steps
PerturbedRuns = Callable[
    [list[dict[str, float]], list[int]],
    tuple[Mapping[str, NDArray[np.float64]], NDArray[np.bool_], Sequence[str]],
]


def checked_steps(steps: Mapping[str, float] | None, parameters: Sequence[str]) -> dict[str, float]:
    """``steps`` (absolute steps of named parameters) as a dict, or a clear error naming an
    unknown parameter or a step that is not a positive finite number."""
    checked: dict[str, float] = {}
    for name, step in (steps or {}).items():
        if name not in parameters:
            raise InvalidParameterError(
                f"gradient_steps names {name!r}, not a parameter of this model "
                f"({sorted(parameters)})"
            )
        value = float(step)
        if not (np.isfinite(value) and value > 0.0):
            raise InvalidParameterError(
                f"gradient_steps[{name!r}] must be a positive finite step, got {step!r}"
            )
        checked[name] = value
    return checked


def perturbed_samples(
    parameters: list[dict[str, float]],
    names: tuple[str, ...],
    live: NDArray[np.bool_],
    steps: Mapping[str, float] | None = None,
) -> tuple[list[dict[str, float]], list[int], NDArray[np.float64]]:
    """The perturbed samples of the central differences: for each live sample s and each
    name k, ``p_k + delta`` then ``p_k - delta`` (``delta`` the step ``steps`` gives the
    name, else relative: :data:`GRADIENT_STEP`). Returns (their parameters, the sample
    each belongs to, deltas (B, P); NaN for a sample not live)."""
    steps = steps or {}
    deltas = np.full((len(parameters), len(names)), np.nan)
    perturbed: list[dict[str, float]] = []
    owners: list[int] = []
    for s, p in enumerate(parameters):
        if not live[s]:
            continue
        for k, name in enumerate(names):
            value = p[name]
            delta = steps.get(name, GRADIENT_STEP * (abs(value) if value != 0.0 else 1.0))
            deltas[s, k] = delta
            for sign in (1.0, -1.0):
                perturbed.append({**p, name: value + sign * delta})
                owners.append(s)
    return perturbed, owners, deltas


def central_differences(
    nominal: Mapping[str, NDArray[np.float64]],
    failed: NDArray[np.bool_],
    parameters: list[dict[str, float]],
    names: tuple[str, ...],
    run: PerturbedRuns,
    steps: Mapping[str, float] | None = None,
) -> tuple[dict[str, NDArray[np.float64]], list[str | None]]:
    """The outputs' derivatives ``{output: (B, ..., P)}`` and per sample why they failed
    (None: they did not).

    ``nominal`` holds the samples' own outputs (B, ...), ``failed`` which of them failed,
    ``parameters`` each sample's parameters; ``run`` runs the perturbed samples
    (:data:`PerturbedRuns`); ``steps`` the absolute steps of some names (the others'
    are relative, :data:`GRADIENT_STEP`). A sample that failed itself gets NaN
    derivatives and no perturbed runs.
    """
    samples = len(parameters)
    live = ~np.asarray(failed, dtype=bool)
    perturbed, owners, deltas = perturbed_samples(parameters, names, live, steps)
    reasons: list[str | None] = [None] * samples
    gradients: dict[str, NDArray[np.float64]] = {}
    if not perturbed:
        for output, values in nominal.items():
            gradients[output] = np.full((*np.shape(values), len(names)), np.nan)
        return gradients, reasons
    outputs, runs_failed, why = run(perturbed, owners)
    for i, s in enumerate(owners):
        if runs_failed[i] and reasons[s] is None:
            k = (i // 2) % len(names)
            side = "+" if i % 2 == 0 else "-"
            reasons[s] = f"its run at {names[k]} {side} {deltas[s, k]:.3g}: {why[i]}"
    rows = np.flatnonzero(live)
    for output, own in nominal.items():
        values = np.asarray(outputs[output], dtype=float)
        pairs = values.reshape(rows.size, len(names), 2, *values.shape[1:])
        _check_pairs(output, pairs, np.asarray(own, dtype=float)[rows], rows, names, deltas,
                     reasons)  # fmt: skip
        quotient = (pairs[:, :, 0] - pairs[:, :, 1]) / (
            2.0 * deltas[rows].reshape(rows.size, len(names), *([1] * (values.ndim - 1)))
        )
        gradient = np.full((samples, *values.shape[1:], len(names)), np.nan)
        gradient[rows] = np.moveaxis(quotient, 1, -1)
        gradients[output] = gradient
    return gradients, reasons


def _check_pairs(output, pairs, nominal, rows, names, deltas, reasons) -> None:
    """Give ``reasons[s]`` to each sample s whose pair of runs of some parameter is too
    far from its run on ``output`` (:data:`LEFT_TRAJECTORY`; not finite counts)."""
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


def on_fixed_steps(model: Any, samples: Mapping[str, Any], names: tuple[str, ...]) -> dict:
    """``model(samples, wrt=names)`` of a :class:`~fuzzymbs.mbs.integrate.SimulationModel`
    whose integrator takes fixed steps (RK4): its outputs as without ``names``, and
    ``"gradients"`` by :func:`central_differences` of runs on the same steps (every run
    takes them); a sample whose differences fail is failed, saying why."""
    columns = {name: np.atleast_1d(np.asarray(v, dtype=float)) for name, v in samples.items()}
    count = len(next(iter(columns.values()))) if columns else 1
    defaults = model.parameter_defaults
    parameters = [
        {**{n: defaults[n] for n in names}, **{n: float(c[i]) for n, c in columns.items()}}
        for i in range(count)
    ]
    result = model.simulate(samples)

    def perturbed(rows: list[dict[str, float]], owners: list[int]) -> tuple:
        moved = model.simulate({name: np.array([p[name] for p in rows]) for name in rows[0]})
        return moved.outputs, moved.failed, list(moved.failure_reason)

    gradients, reasons = central_differences(
        result.outputs, result.failed, parameters, names, perturbed
    )
    failed, why = with_failures(result.failed, result.failure_reason, reasons)
    return {
        **result.outputs,
        "failed": failed,
        "failure_reason": np.array(why, dtype=str),
        "gradients": gradients,
    }


def with_failures(
    failed: NDArray[np.bool_], why: Sequence[str], reasons: Sequence[str | None]
) -> tuple[NDArray[np.bool_], list[str]]:
    """A model's ``failed`` and failure texts with the samples whose differences failed
    (``reasons``, from :func:`central_differences`) failed too, saying why."""
    failed = np.array(failed, dtype=bool)
    why = list(why)
    for i, reason in enumerate(reasons):
        if reason is not None:
            failed[i] = True
            why[i] = f"derivatives failed: {reason}"
    return failed, why
