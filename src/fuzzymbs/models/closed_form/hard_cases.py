"""Non-monotonic test models with dense-grid truth: where fixed transformation methods fail.

The reduced and extended transformation methods assume outputs monotonic in
the parameters; the general and grid methods see the model only on their
grids. Three closed-form models, each with its fuzzy parameters (triangular, given
as ``(lower, modal, upper)``), break those assumptions the way multibody
models do:

- :func:`bump3`: a scalar with an interior maximum off the centre of the box
  (three parameters);
- :func:`ringing3`: a damped oscillation whose frequency is fuzzy (+-17 %,
  ten periods, so the phase moves by more than a period across the support),
  a 201-point time signal (three parameters);
- :func:`valley4`: a scalar valley that the box corners straddle in two
  pairs of parameters (four parameters).

Each carries its analytic gradient (``case.gradient``: outputs and their derivatives
with respect to the parameters), for the adaptive method's gradient-enhanced surrogate.

:func:`dense_truth` gives their true alpha-cuts from a dense grid of every
level's box (the grid holds each box's corners and centre; its spacing error
is stated there), :func:`fuzzymbs.fuzzy.band_scale.band_miss` the miss of a
method against it.

A model imports no part of the fuzzy engine: the parameters are plain numbers,
which :func:`fuzzymbs.fuzzy.numbers.triangular_numbers` turns into fuzzy numbers
for a plan or a study.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError

__all__ = [
    "GradientModel",
    "HardCase",
    "Triangle",
    "bump3",
    "dense_truth",
    "hard_cases",
    "ringing3",
    "valley4",
]

Model = Callable[[Mapping[str, NDArray[np.float64]]], dict[str, NDArray[np.float64]]]
#: A model with its gradients: samples -> (outputs, {output: (B, *shape, n) gradient}).
GradientModel = Callable[
    [Mapping[str, NDArray[np.float64]]],
    tuple[dict[str, NDArray[np.float64]], dict[str, NDArray[np.float64]]],
]
#: A triangular fuzzy number as ``(lower, modal, upper)``, in the parameter's unit.
Triangle = tuple[float, float, float]


@dataclass(frozen=True)
class HardCase:
    """A test model with its fuzzy parameters.

    Attributes
    ----------
    name : short name.
    model : batched model, samples ``{name: (B,)}`` -> ``{output: (B, *shape)}``.
    triangles : the fuzzy parameters, each triangular as ``(lower, modal, upper)``
        (``triangular_numbers(case.triangles)`` gives them as fuzzy numbers).
    grid : points per axis of :func:`dense_truth` (one count per parameter) that
        resolve the truth to about 0.1 % of the cut width (measured by halving the
        spacing, tests/fuzzy/test_hard_cases.py).
    gradient : the model with its analytic gradients, samples -> ``(outputs, gradients)``,
        ``gradients[output]`` of shape ``(B, *shape, n)``, the last axis in the order of
        ``triangles`` and in the parameters' units (None: the model has none).
    """

    name: str
    model: Model
    triangles: dict[str, Triangle]
    grid: tuple[int, ...]
    gradient: GradientModel | None = None


def _bump(samples: Mapping[str, NDArray[np.float64]]) -> dict[str, NDArray[np.float64]]:
    x1, x2, x3 = (np.asarray(samples[k], dtype=float) for k in ("x1", "x2", "x3"))
    bump = np.exp(-((x1 - 0.35) ** 2 + (x2 + 0.25) ** 2) / 0.18)
    return {"z": bump * (1.0 + 0.4 * x3) + 0.3 * x1 - 0.2 * x2}


def _bump_gradient(samples: Mapping[str, NDArray[np.float64]]) -> tuple[dict, dict]:
    x1, x2, x3 = (np.asarray(samples[k], dtype=float) for k in ("x1", "x2", "x3"))
    bump = np.exp(-((x1 - 0.35) ** 2 + (x2 + 0.25) ** 2) / 0.18)
    height = 1.0 + 0.4 * x3
    slope = np.stack(
        (
            bump * height * (-2.0 * (x1 - 0.35) / 0.18) + 0.3,
            bump * height * (-2.0 * (x2 + 0.25) / 0.18) - 0.2,
            0.4 * bump,
        ),
        axis=-1,
    )
    return {"z": bump * height + 0.3 * x1 - 0.2 * x2}, {"z": slope}


def bump3() -> HardCase:
    """``z = exp(-((x1-0.35)^2 + (x2+0.25)^2)/0.18) (1 + 0.4 x3) + 0.3 x1 - 0.2 x2``,
    ``x1, x2 ~ TFN(-1, 0, 1)``, ``x3 ~ TFN(0, 0.5, 1)``: the maximum lies inside every
    cut box of levels up to about 0.65, away from the corners and the centre."""
    triangles = {"x1": (-1.0, 0.0, 1.0), "x2": (-1.0, 0.0, 1.0), "x3": (0.0, 0.5, 1.0)}
    return HardCase("bump3", _bump, triangles, (81, 81, 81), _bump_gradient)


#: ringing3's time grid: ten periods of the modal frequency (1 Hz), 201 points
RINGING_TIME = np.linspace(0.0, 10.0, 201)


def _ringing(samples: Mapping[str, NDArray[np.float64]]) -> dict[str, NDArray[np.float64]]:
    f = np.asarray(samples["frequency"], dtype=float)[:, None]
    zeta = np.asarray(samples["damping_ratio"], dtype=float)[:, None]
    a = np.asarray(samples["amplitude"], dtype=float)[:, None]
    omega = 2.0 * np.pi * f
    t = RINGING_TIME[None, :]
    return {"y": a * np.exp(-zeta * omega * t) * np.cos(omega * t)}


def _ringing_gradient(samples: Mapping[str, NDArray[np.float64]]) -> tuple[dict, dict]:
    f = np.asarray(samples["frequency"], dtype=float)[:, None]
    zeta = np.asarray(samples["damping_ratio"], dtype=float)[:, None]
    a = np.asarray(samples["amplitude"], dtype=float)[:, None]
    omega = 2.0 * np.pi * f
    t = RINGING_TIME[None, :]
    decay = np.exp(-zeta * omega * t)
    cosine, sine = np.cos(omega * t), np.sin(omega * t)
    y = a * decay * cosine
    # dy/df = 2 pi t A e (-zeta cos - sin), dy/dzeta = -omega t y, dy/dA = e cos
    slope = np.stack(
        (2.0 * np.pi * t * a * decay * (-zeta * cosine - sine), -omega * t * y, decay * cosine),
        axis=-1,
    )
    return {"y": y}, {"y": slope}


def ringing3() -> HardCase:
    """``y(t) = A exp(-zeta 2 pi f t) cos(2 pi f t)`` on 0..10 s (201 points) with
    ``f ~ TFN(0.83, 1, 1.17) Hz``, ``zeta ~ TFN(0.015, 0.02, 0.025)``,
    ``A ~ TFN(0.9, 1, 1.1)``: at 10 s the phase spans 3.4 periods over the support."""
    triangles = {
        "frequency": (0.83, 1.0, 1.17),
        "damping_ratio": (0.015, 0.02, 0.025),
        "amplitude": (0.9, 1.0, 1.1),
    }
    # y is linear in A and monotonic in zeta at fixed f and t: their ends and
    # centre suffice; the phase needs a fine frequency axis
    return HardCase("ringing3", _ringing, triangles, (641, 5, 5), _ringing_gradient)


def _valley(samples: Mapping[str, NDArray[np.float64]]) -> dict[str, NDArray[np.float64]]:
    x1, x2, x3, x4 = (np.asarray(samples[k], dtype=float) for k in ("x1", "x2", "x3", "x4"))
    return {"z": (x1 - 0.5 * x2) ** 2 + (x3 - 0.5 * x4) ** 2 + 0.2 * x1 * x3 + 0.1 * x4}


def _valley_gradient(samples: Mapping[str, NDArray[np.float64]]) -> tuple[dict, dict]:
    x1, x2, x3, x4 = (np.asarray(samples[k], dtype=float) for k in ("x1", "x2", "x3", "x4"))
    first, second = x1 - 0.5 * x2, x3 - 0.5 * x4
    slope = np.stack(
        (2.0 * first + 0.2 * x3, -first, 2.0 * second + 0.2 * x1, -second + 0.1), axis=-1
    )
    return _valley(samples), {"z": slope}


def valley4() -> HardCase:
    """``z = (x1 - x2/2)^2 + (x3 - x4/2)^2 + 0.2 x1 x3 + 0.1 x4``, all ``TFN(-1, 0, 1)``:
    the minimum lies on the valley floors x1 = x2/2, x3 = x4/2 that no corner touches."""
    triangles = {k: (-1.0, 0.0, 1.0) for k in ("x1", "x2", "x3", "x4")}
    return HardCase("valley4", _valley, triangles, (21, 21, 21, 21), _valley_gradient)


def hard_cases() -> list[HardCase]:
    """The three cases, in the order bump3, ringing3, valley4."""
    return [bump3(), ringing3(), valley4()]


def triangle_cut(triangle: Triangle, mu: float) -> tuple[float, float]:
    """The cut at ``mu`` as :class:`fuzzymbs.fuzzy.numbers.Triangular` gives it, bit for bit
    (the truth's grid holds the very box corners a plan samples)."""
    lower, modal, upper = triangle
    if mu == 1.0:
        return modal, modal
    return min(lower + mu * (modal - lower), modal), max(upper - mu * (upper - modal), modal)


def dense_truth(
    case: HardCase, levels: NDArray[np.float64] | list[float], *, refine: int = 1
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """True alpha-cuts of every output from a dense grid of each level's box.

    Parameters
    ----------
    case : the test model.
    levels : (L,) membership levels.
    refine : divide the spacing of the case's grid by this (to measure its error).

    Returns
    -------
    dict
        output -> (lower, upper), each (L, *shape): the smallest and largest value
        over the grid of that level's box, a lower bound of the true range with an
        error below the grid's resolution (the cases' defaults resolve it to about
        0.1 % of the cut width).

    Raises
    ------
    InvalidParameterError
        A level outside [0, 1].
    """
    mus = np.atleast_1d(np.asarray(levels, dtype=float))
    if not np.all((mus >= 0.0) & (mus <= 1.0)):
        raise InvalidParameterError(f"levels must lie in [0, 1], got {mus.tolist()}")
    counts = [(c - 1) * int(refine) + 1 for c in case.grid]
    names = list(case.triangles)
    truth: dict[str, tuple[list, list]] = {}
    for mu in mus:
        axes = [
            np.linspace(*triangle_cut(case.triangles[n], float(mu)), c)
            for n, c in zip(names, counts, strict=True)
        ]
        low: dict[str, NDArray] = {}
        high: dict[str, NDArray] = {}
        # one value of the first axis per batch keeps memory at a slice of the grid
        for first in axes[0]:
            mesh = np.stack([m.ravel() for m in np.meshgrid(*axes[1:], indexing="ij")], axis=1)
            samples = {names[0]: np.full(len(mesh), first)}
            samples.update({n: mesh[:, i] for i, n in enumerate(names[1:])})
            for key, value in case.model(samples).items():
                value = np.asarray(value, dtype=float)
                lo, hi = value.min(axis=0), value.max(axis=0)
                low[key] = lo if key not in low else np.minimum(low[key], lo)
                high[key] = hi if key not in high else np.maximum(high[key], hi)
        for key in low:
            truth.setdefault(key, ([], []))
            truth[key][0].append(low[key])
            truth[key][1].append(high[key])
    return {k: (np.array(lo), np.array(hi)) for k, (lo, hi) in truth.items()}
