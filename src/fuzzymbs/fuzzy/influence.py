"""Measures of influence of the reduced/extended transformation method (Hanss).

At level j the 2^n corner runs of a reduced plan pair up: corners s and
s + 2^(n-1-i) (0-based parameter index i) differ only in parameter i, which
sits at a_i^(j) in the first and b_i^(j) in the second. From these pairs:

gain factor
    eta_i^(j) = sum over the 2^(n-1) pairs (z_s2 - z_s1) / (2^(n-1) (b_i^(j) - a_i^(j)))
mean gain
    eta_i = sum_(j in D_i) w_j eta_i^(j) / sum_(j in D_i) w_j
absolute influence
    kappa_i = sum_j w_j |eta_i^(j)| (b_i^(j) - a_i^(j)) / sum_j w_j
relative influence
    rho_i = kappa_i / sum_q kappa_q  (0 for every parameter if all kappa_q are 0)

D_i are the levels where parameter i's cut has positive width; at a
zero-width cut (the core of a triangular number) the gain is a 0/0 and is
reported as NaN and left out of the mean gain. Its contribution to kappa is
zero (the width factor), so kappa sums over all levels. Weights w_j are the
membership levels mu_j by default (Hanss 2005), uniform, or given explicitly.
Everything is element-wise over the output's trailing axes, so a time signal
gets a time-resolved influence.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError, UnsupportedOperationError
from fuzzymbs.fuzzy.bookkeeping import PlanBookkeeping
from fuzzymbs.fuzzy.labels import DatasetExport, DatasetParts
from fuzzymbs.fuzzy.methods.registry import METHODS
from fuzzymbs.fuzzy.numbers import real_array

__all__ = [
    "Influence",
    "compute_influence",
    "influence_from_sums",
    "influence_refusal",
    "level_weights",
]


def level_weights(weights: str | ArrayLike, levels: NDArray[np.float64]) -> NDArray[np.float64]:
    """Level weights w_j from ``"membership"`` (mu_j), ``"uniform"`` (1) or an explicit array.

    Raises
    ------
    InvalidParameterError
        Unknown name, wrong length, negative or non-finite values, or all zero.
    """
    if isinstance(weights, str):
        if weights == "membership":
            return np.array(levels, dtype=float)
        if weights == "uniform":
            return np.ones(len(levels))
        raise InvalidParameterError(
            f"weights must be 'membership', 'uniform' or an array of {len(levels)} values, "
            f"got {weights!r}"
        )
    values = real_array(
        weights,
        f"weights must be 'membership', 'uniform' or an array of {len(levels)} numbers",
        InvalidParameterError,
    )
    if values.shape != (len(levels),):
        raise InvalidParameterError(
            f"weights must have one value per level ({len(levels)}), got shape {values.shape}"
        )
    if not np.all(np.isfinite(values)) or np.any(values < 0.0) or not np.any(values > 0.0):
        raise InvalidParameterError(
            f"weights must be finite, >= 0 and not all zero, got {values.tolist()}"
        )
    return values


class Influence(DatasetExport):
    """Gain factors and influence measures of every parameter on one output.

    Attributes
    ----------
    names : tuple of str
        Parameter names (axis 0 of every array).
    levels : ndarray (L,)
        Membership levels.
    weights : ndarray (L,)
        Level weights w_j used.
    gain : ndarray (n, L, ...)
        eta_i^(j): output change per unit parameter change [output unit / parameter unit];
        NaN at zero-width cuts and at levels with failed corner runs.
    mean_gain : ndarray (n, ...)
        eta_i [output unit / parameter unit].
    absolute : ndarray (n, ...)
        kappa_i [output unit].
    relative : ndarray (n, ...)
        rho_i [-], sums to 1 over the parameters (all 0 where every kappa is 0).

    Notes
    -----
    :meth:`to_xarray` gives ``{name}_gain`` over ("parameter", "level", *dims),
    ``{name}_mean_gain``, ``{name}_absolute_influence`` and
    ``{name}_relative_influence`` over ("parameter", *dims) and
    ``{name}_level_weight`` over ("level",).
    """

    def __init__(
        self,
        names: Sequence[str],
        levels: ArrayLike,
        weights: ArrayLike,
        gain: ArrayLike,
        mean_gain: ArrayLike,
        absolute: ArrayLike,
        relative: ArrayLike,
    ) -> None:
        self.names = tuple(names)
        self.levels = np.asarray(levels, dtype=float)
        self.weights = np.asarray(weights, dtype=float)
        self.gain = np.asarray(gain, dtype=float)
        self.mean_gain = np.asarray(mean_gain, dtype=float)
        self.absolute = np.asarray(absolute, dtype=float)
        self.relative = np.asarray(relative, dtype=float)
        for array in (self.levels, self.weights, self.gain, self.mean_gain):
            array.setflags(write=False)
        for array in (self.absolute, self.relative):
            array.setflags(write=False)

    def __repr__(self) -> str:
        return f"Influence(names={list(self.names)}, shape={self.shape})"

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the output's own axes (without the parameter axis)."""
        return self.mean_gain.shape[1:]

    def dataset_parts(self, name: str, dims: list[str]) -> DatasetParts:
        """The measures and level weights as Dataset variables (see the Notes)."""
        variables = {
            f"{name}_gain": (("parameter", "level", *dims), self.gain),
            f"{name}_mean_gain": (("parameter", *dims), self.mean_gain),
            f"{name}_absolute_influence": (("parameter", *dims), self.absolute),
            f"{name}_relative_influence": (("parameter", *dims), self.relative),
            f"{name}_level_weight": (("level",), self.weights),
        }
        coordinates = {"parameter": list(self.names), "level": self.levels}
        return DatasetParts(variables, coordinates, {})


def compute_influence(
    plan: PlanBookkeeping,
    outputs: NDArray[np.float64],
    failed: NDArray[np.bool_] | None,
    weights: str | ArrayLike = "membership",
) -> Influence:
    """Influence measures of one output, for a plan whose method supports them
    (``plan.scheme.supports_influence``: the corner runs of a reduced, extended or grid
    plan, the surrogate of an adaptive one): ``plan.retransform(outputs,
    failed).influence(weights)``, the one path to them.

    Parameters
    ----------
    plan : Plan
        A plan whose method supports influence measures.
    outputs : ndarray (N, ...)
        Model output at the plan's samples.
    failed : ndarray (N,) bool or None
        Failed samples; levels with a failed corner get NaN gains.
    weights : {"membership", "uniform"} or array_like (L,)
        Level weights w_j.

    Raises
    ------
    UnsupportedOperationError
        For general and sparse plans (their points do not pair up in one parameter).
    """
    if not plan.scheme.supports_influence:
        raise UnsupportedOperationError(influence_refusal(plan))
    result = plan.retransform(outputs, failed, check_monotonic=False)
    return result.influence(weights)


def influence_refusal(plan: PlanBookkeeping) -> str:
    """Why a plan's results give no influence measures (its method does not support them)."""
    supporting = [name for name, cls in METHODS.items() if cls.supports_influence]
    return (
        f"influence measures need a method that supports them (corner pairs that differ in "
        f"one parameter, or a surrogate: {', '.join(supporting)}); this plan uses "
        f"method={plan.method!r}"
    )


def influence_from_sums(
    plan: PlanBookkeeping,
    pair_sum: NDArray[np.float64],
    bad_level: NDArray[np.bool_],
    trailing: tuple[int, ...],
    weights: str | ArrayLike = "membership",
) -> Influence:
    """Influence measures from the signed corner sums of a reduced/extended plan.

    Parameters
    ----------
    pair_sum : (n, L, E) ndarray
        ``sum over the level's corners s of sign_i(s) z_s / 2^(n-1)`` (sign +1 where
        parameter i is at its upper bound), as :class:`~fuzzymbs.fuzzy.accumulate.
        OutputAccumulator` accumulates it.
    bad_level : (L,) bool
        Levels with a failed corner (their gains are NaN).
    trailing : the output's trailing shape (E = its size).
    """
    w = level_weights(weights, plan.levels)
    count_parameters = len(plan.names)
    width = (plan.cut_upper - plan.cut_lower).T  # (n, L)
    defined = width > 0.0
    safe_width = np.where(defined, width, 1.0)
    gain = np.where(defined[:, :, None], pair_sum / safe_width[:, :, None], np.nan)
    if np.any(bad_level):
        gain[:, bad_level, :] = np.nan
        defined_or_failed = defined | bad_level[None, :]
    else:
        defined_or_failed = defined
    flat = gain  # (n, L, E)
    # mean gain over the levels where the gain exists (and failed ones, which give NaN)
    level_weight = np.where(defined_or_failed, w[None, :], 0.0)  # (n, L)
    weight_sum = level_weight.sum(axis=1)  # (n,)
    term = np.where(level_weight[:, :, None] > 0.0, level_weight[:, :, None] * gain, 0.0)
    has_weight = weight_sum > 0.0
    mean_gain = np.full((count_parameters, flat.shape[2]), np.nan)
    mean_gain[has_weight] = term[has_weight].sum(axis=1) / weight_sum[has_weight, None]
    # absolute influence over all levels; zero-width and zero-weight levels contribute 0
    spread_term = np.where(
        level_weight[:, :, None] > 0.0,
        w[None, :, None] * np.abs(gain) * width[:, :, None],
        0.0,
    )
    absolute = spread_term.sum(axis=1) / w.sum()
    total = absolute.sum(axis=0)  # (k,)
    relative = np.zeros_like(absolute)
    positive = total > 0.0
    relative[:, positive] = absolute[:, positive] / total[positive]
    relative[:, np.isnan(total)] = np.nan
    count_levels = len(plan.levels)
    return Influence(
        plan.names,
        plan.levels,
        w,
        gain.reshape(count_parameters, count_levels, *trailing),
        mean_gain.reshape(count_parameters, *trailing),
        absolute.reshape(count_parameters, *trailing),
        relative.reshape(count_parameters, *trailing),
    )
