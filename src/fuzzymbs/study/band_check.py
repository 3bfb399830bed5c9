"""A finished study's bands checked against independent points of the model.

A study estimates its own errors: the method's (``method_error``, certified by the
adaptive method's rounds or a lower bound from validation runs) and the time
integration's (``time_integration_error``, from tighter re-runs of the samples that
give the bounds). Both reuse the study's own runs and model. This check does not:
it draws scrambled Halton points (a seed of its own, so they are none of the plan's
or the validation's points) in chosen cut boxes of the fuzzy parameters (by default
the support, mu = 0, and the mu = 0.5 box), runs them on an independent model (the
study's model on each sample's own steps, its tolerance divided by its tightening,
:func:`independent_model`), and reports per output and level how far any point's
output lies outside that level's band ``[lower, upper]``, on the cut-width scale of
:mod:`fuzzymbs.fuzzy.band_scale` (``max(local cut width, 0.1 x the level's widest
cut)``). A point is held against every level whose cut box contains it: a point of
the mu = 0.5 box against the cuts of mu = 0, 0.25 and 0.5 (and of a higher level
whose box it falls into), a point of the support against the support's cut.

Points are a sample: a miss of 0 says that no point found one, and a larger miss
is a lower bound of the bands' true miss, the same kind as a fixed method's
``method_error`` (:data:`~fuzzymbs.fuzzy.band_scale.LOWER_BOUND`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy.band_scale import WIDTH_FLOOR, level_widest
from fuzzymbs.fuzzy.halton import halton
from fuzzymbs.fuzzy.transform import Plan
from fuzzymbs.fuzzy.validation_points import box_level
from fuzzymbs.tolerance import Tolerance, tolerance_of

__all__ = [
    "BOXES",
    "SEED",
    "BandCheck",
    "band_check_points",
    "band_misses",
    "check_bands",
    "check_study_bands",
    "independent_model",
]

#: seed of the check's scrambled Halton points (not the validation points' seed)
SEED = 20261130
#: the cut boxes the points are drawn in by default: the support and the mu = 0.5 box
BOXES = (0.0, 0.5)

Bands = Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64]]]


@dataclass(frozen=True)
class BandCheck:
    """What :func:`check_bands` found.

    Attributes
    ----------
    levels : (L,) the bands' levels.
    misses : output -> (L,) the largest miss of any point held against that level, on
        the cut-width scale (0: every point inside the band; NaN: no point in that
        level's box, or a cut of no width).
    points : (L,) how many points were held against each level.
    runs, failed : the points run, and how many of them failed (left out).
    error : the largest miss over outputs and levels (NaN: nothing could be checked).
    worst : output, level, parameter values and element of the largest miss; None when
        no point left a band.
    time_integration : the independent model's time integration in words ("" without).
    rtol : the independent model's relative tolerance (NaN without one).
    samples : (runs, n) the points, columns in the plan's parameter order.
    point_misses : (runs,) each point's largest miss over outputs and levels (NaN:
        failed), e.g. to re-run the points that miss at a tighter tolerance.
    """

    levels: NDArray[np.float64]
    misses: dict[str, NDArray[np.float64]]
    points: NDArray[np.int64]
    runs: int
    failed: int
    error: float
    worst: dict[str, Any] | None
    time_integration: str = ""
    rtol: float = float("nan")
    samples: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 0)), repr=False)
    point_misses: NDArray[np.float64] = field(default_factory=lambda: np.empty(0), repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe summary (misses per output as lists over the levels, NaN as None)."""

        def number(value: float) -> float | None:
            return float(value) if np.isfinite(value) else None

        return {
            "levels": [float(v) for v in self.levels],
            "misses": {name: [number(v) for v in m] for name, m in self.misses.items()},
            "points": [int(v) for v in self.points],
            "runs": self.runs,
            "failed": self.failed,
            "error": number(self.error),
            "worst": self.worst,
            "time_integration": self.time_integration,
            "rtol": number(self.rtol),
        }


def band_check_points(
    plan: Plan, count: int, level: float, seed: int = SEED
) -> NDArray[np.float64]:
    """``count`` scrambled Halton points in the cut box of ``level``.

    Parameters
    ----------
    plan : the study's plan (its fuzzy parameters, in column order).
    count : number of points.
    level : membership level of the box (0: the support).
    seed : seed of the scrambling; each level's points take ``seed`` plus the level's
        per mille, so that the points of two boxes are not scaled copies of each other.

    Returns
    -------
    ndarray
        (count, n) parameter values.
    """
    box = np.array([plan.parameters[name].cuts([level])[0] for name in plan.names])  # (n, 2)
    unit = halton(count, len(plan.names), seed=seed + round(1000 * level))
    return box[:, 0] + unit * (box[:, 1] - box[:, 0])


def band_misses(
    plan: Plan,
    bands: Bands,
    samples: NDArray[np.float64],
    outputs: Mapping[str, NDArray[np.float64]],
    failed: NDArray[np.bool_] | None = None,
) -> tuple[
    dict[str, NDArray[np.float64]], NDArray[np.float64], NDArray[np.int64], dict[str, Any] | None
]:
    """How far the outputs of ``samples`` lie outside ``bands``, per output and level.

    Parameters
    ----------
    plan : the plan whose levels and cut boxes the bands belong to.
    bands : output -> ``(lower, upper)``, each (L, *shape).
    samples : (P, n) parameter values, columns in ``plan.names`` order.
    outputs : output -> (P, *shape) the model's outputs at ``samples``.
    failed : (P,) runs to leave out.

    Returns
    -------
    (misses, point_misses, points, worst)
        ``misses``: output -> (L,) the largest ``(max(l - y, 0) + max(y - u, 0)) /
        max(u - l, 0.1 max(u - l))`` over the points inside each level's box and the
        elements (NaN: no such point, or no width); ``point_misses``: (P,) each point's
        largest over the outputs, levels and elements (NaN: failed); ``points``: (L,)
        points per level; ``worst``: where the largest miss is, or None (no point left
        a band).
    """
    samples = np.asarray(samples, dtype=float)
    levels = len(plan.levels)
    ok = np.ones(len(samples), bool) if failed is None else ~np.asarray(failed, bool)
    top = box_level(plan, samples)  # a point lies in the box of every level up to it
    inside = (np.arange(levels)[:, None] <= top[None, :]) & ok[None, :]  # (L, P)
    misses: dict[str, NDArray[np.float64]] = {}
    per_point = np.where(ok, 0.0, np.nan)
    worst: dict[str, Any] | None = None
    largest = 0.0  # a point exactly on a band is no miss
    for name, (lower, upper) in bands.items():
        lo = np.asarray(lower, dtype=float).reshape(levels, -1)
        hi = np.asarray(upper, dtype=float).reshape(lo.shape)
        width = hi - lo
        widest = level_widest(width)
        scale = np.maximum(width, WIDTH_FLOOR * widest)  # (L, size)
        usable = (widest[:, 0] > 0) & np.isfinite(scale).all(axis=1)
        y = np.asarray(outputs[name], dtype=float).reshape(len(samples), 1, -1)  # (P, 1, size)
        beyond = np.maximum(lo[None] - y, 0.0) + np.maximum(y - hi[None], 0.0)  # (P, L, size)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(inside.T[:, :, None] & usable[None, :, None], beyond / scale, np.nan)
        with np.errstate(invalid="ignore"):
            per_point = np.fmax(per_point, np.nan_to_num(ratio, nan=0.0).max(axis=(1, 2)))
        found = np.full(levels, np.nan)
        for j in range(levels):
            if not np.isfinite(ratio[:, j]).any():
                continue
            found[j] = float(np.nanmax(ratio[:, j]))
            if found[j] > largest:
                largest = found[j]
                point, element = np.unravel_index(np.nanargmax(ratio[:, j]), ratio[:, j].shape)
                shape = np.shape(lower)[1:]
                worst = {
                    "output": name,
                    "level": float(plan.levels[j]),
                    "parameters": dict(zip(plan.names, samples[point].tolist(), strict=True)),
                    "element": [int(i) for i in np.unravel_index(element, shape)] if shape else [],
                    "miss": float(found[j]),
                }
        misses[name] = found
    per_point[~ok] = np.nan
    return misses, per_point, inside.sum(axis=1).astype(np.int64), worst


def independent_model(model: Any, factor: float | None = None) -> Any:
    """The model a study's bands are checked with: ``model`` on each sample's own steps
    (``own_steps()`` of a model on shared steps), its tolerance divided by ``factor``
    (default: its tolerance's tightening, 10) where it has one (``tightened``);
    a model without time integration as it is.

    Raises
    ------
    InvalidParameterError
        ``model`` shares steps and cannot give them up (no ``own_steps``).
    """
    if getattr(model, "shares_steps", False):
        own_steps = getattr(model, "own_steps", None)
        if not callable(own_steps):
            raise InvalidParameterError(
                "the model runs on shared steps and has no own_steps(): give check_bands "
                "a model with each sample on its own steps"
            )
        model = own_steps()
    tightened = getattr(model, "tightened", None)
    if not callable(tightened):
        return model
    return tightened(tolerance_of(model).tightening if factor is None else factor)


def check_bands(
    model: Callable[[Mapping[str, NDArray[np.float64]]], Mapping[str, Any]],
    plan: Plan,
    bands: Bands,
    count: int = 16,
    boxes: Sequence[float] = BOXES,
    seed: int = SEED,
    constants: Mapping[str, float] | None = None,
) -> BandCheck:
    """Run ``count`` independent points in each of ``boxes`` and measure how far they
    leave ``bands`` (module docstring).

    Parameters
    ----------
    model : batched model, ``{parameter: (P,)}`` -> ``{output: (P, *shape)}`` (and
        optionally ``"failed"``: (P,) bool); an independent one
        (:func:`independent_model`).
    plan : the plan the bands belong to (parameters, levels, cut boxes).
    bands : output -> ``(lower, upper)``, each (L, *shape) in the plan's level order.
    count : points per box.
    boxes : membership levels of the cut boxes the points are drawn in.
    seed : seed of the points (:func:`band_check_points`).
    constants : crisp parameters given to every run.

    Returns
    -------
    BandCheck
    """
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
        raise InvalidParameterError(f"count must be a whole number >= 1, got {count!r}")
    samples = np.vstack([band_check_points(plan, count, level, seed) for level in boxes])
    columns = {name: np.ascontiguousarray(samples[:, i]) for i, name in enumerate(plan.names)}
    for name, value in (constants or {}).items():
        columns[name] = np.full(len(samples), value)
    outputs = model(columns)
    failed = np.asarray(outputs.get("failed", np.zeros(len(samples), bool)), dtype=bool)
    for name in bands:  # a non-finite output fails its run, as in a study
        values = np.asarray(outputs[name], dtype=float).reshape(len(samples), -1)
        failed = failed | ~np.isfinite(values).all(axis=1)
    misses, point_misses, points, worst = band_misses(plan, bands, samples, outputs, failed)
    finite = [m[np.isfinite(m)] for m in misses.values()]
    error = max((float(m.max()) for m in finite if m.size), default=float("nan"))
    tolerance = getattr(model, "tolerance", None)  # time-integrated models only
    return BandCheck(
        levels=np.asarray(plan.levels, dtype=float),
        misses=misses,
        points=points,
        runs=len(samples),
        failed=int(failed.sum()),
        error=error,
        worst=worst,
        time_integration=str(getattr(model, "time_integration", "")),
        rtol=float(np.max(tolerance.rtol)) if isinstance(tolerance, Tolerance) else float("nan"),
        samples=samples,
        point_misses=point_misses,
    )


def check_study_bands(
    study: Any,
    result: Any,
    count: int = 16,
    boxes: Sequence[float] = BOXES,
    seed: int = SEED,
    factor: float | None = None,
) -> BandCheck:
    """:func:`check_bands` of a finished study's result on :func:`independent_model` of
    the model the study ran (its chosen tolerance divided by ``factor``, default 10).

    Parameters
    ----------
    study : the :class:`~fuzzymbs.study.study.Study` after ``run`` (its ``model`` is the
        one it chose).
    result : its :class:`~fuzzymbs.study.result.StudyResult` (or the dataset).
    count, boxes, seed : as :func:`check_bands`.
    factor : the independent model's tolerance is the study's divided by this.
    """
    data = getattr(result, "dataset", result)
    bands = {
        name: (data[f"{name}_lower"].values, data[f"{name}_upper"].values)
        for name in study.output_names
    }
    model = independent_model(study.model, factor)
    return check_bands(model, study.plan, bands, count, boxes, seed, study.constants)
