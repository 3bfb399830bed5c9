"""A gradient-enhanced kernel correction: the adaptive surrogate through values and slopes.

When the model returns the derivatives of its outputs with respect to the fuzzy
parameters alongside the outputs, every run carries ``n + 1`` data per output
element instead of one. The adaptive method's surrogate (a Chebyshev sparse grid,
:mod:`fuzzymbs.fuzzy.chebyshev_grid`, plus a cubic polyharmonic correction,
:mod:`fuzzymbs.fuzzy.residual_correction`) then interpolates both: the residual
values ``r_i = f(x_i) - s(x_i)`` (zero at the grid's nodes) and the residual
gradients ``g_i = grad f(x_i) - grad s(x_i)`` at every run with a gradient, grid
nodes included. This is Hermite-Birkhoff interpolation with a conditionally
positive definite kernel (Wendland, Scattered Data Approximation, Cambridge
2005, ch. 16; Wu, Approx. Theory Appl. 8 (1992) 1): with ``Phi(x, y) = |x - y|^3``,

    c(x) = sum_i w_i Phi(x, x_i) + sum_g sum_l v_gl d/dy_l Phi(x, y)|_(y = x_g)
           + a_0 + a^T x,

    d/dy_l Phi(x, y) = -3 |x - y| (x - y)_l,
    d^2/(dx_k dy_l) Phi(x, y) = -3 (delta_kl |x - y| + (x - y)_k (x - y)_l / |x - y|)
                                (zero where x = y),

and the linear tail is constrained by both kinds of functionals:
``sum_i w_i = 0`` and ``sum_i w_i x_i + sum_g v_g = 0``. The cubic kernel is
``C^2``, so the derivative functionals may act on both of its arguments and the
collocation matrix is symmetric; for distinct points with linearly independent
functionals the interpolant exists and is unique (Wendland, Theorem 16.8).

The class has the interface of :class:`~fuzzymbs.fuzzy.residual_correction.KernelCorrection`
(``values``, ``at``, ``gradient_at``, ``centres``), so the box search and the
extremum confirmation use it unchanged. Without gradients the adaptive method
keeps the value-only correction, bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import ModelOutputError
from fuzzymbs.fuzzy.bordered_system import BorderedSystem
from fuzzymbs.fuzzy.chebyshev_grid import basis_gradient, evaluate_series
from fuzzymbs.fuzzy.residual_correction import (
    KernelCorrection,
    cubic_kernel,
    distinct_centres,
)

__all__ = ["HermiteCorrection", "flatten_gradients", "hermite_correction"]

#: float64 entries of one block of kernel values (its slope terms make (points, centres,
#: directions) arrays besides the values' blocks). Against 4,000,000
#: (benchmarks/correction_blocks.py, 2026-12-02, Xeon host): the chain at 0.5 % damping with
#: gradients 0.75 of the wall time, ringing3 0.95; 65,536 0.92 and 1.02 (many small blocks:
#: the Python per block weighs); the same runs and certified errors
_BLOCK_ENTRIES = 262_144
#: kinds of the system's unknowns: a value's weight, a gradient's, the linear tail's
_VALUE, _GRADIENT, _TAIL = 0, 1, 2


def _positions(
    kind: NDArray[np.int64], index: NDArray[np.int64], count: int, gradients: int
) -> NDArray[np.int64]:
    """Rows of the unknowns ``(kind, index)`` in the layout values (``count``), gradients
    (``gradients``), tail."""
    return index + np.where(
        kind == _VALUE, 0, np.where(kind == _GRADIENT, count, count + gradients)
    )


def functional_block(
    centres_a: NDArray[np.float64],
    slopes_a: NDArray[np.float64],
    centres_b: NDArray[np.float64],
    slopes_b: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The kernel between two sets of functionals: rows the values at ``centres_a`` (P, m)
    and the gradients at ``slopes_a`` (G, m), columns those at ``centres_b``, ``slopes_b``;
    gradients g-major (row ``P + m g + k``: d/dx_k at x_g)."""
    dimension = centres_a.shape[1]
    values_a, values_b = len(centres_a), len(centres_b)
    gradients_a, gradients_b = len(slopes_a) * dimension, len(slopes_b) * dimension
    block = np.empty((values_a + gradients_a, values_b + gradients_b))
    block[:values_a, :values_b] = cubic_kernel(centres_a, centres_b)
    # d/dx_k at x_g of |x - x_j|^3: 3 |x_g - x_j| (x_g - x_j)_k; rows (g, k) g-major
    d = slopes_a[:, None, :] - centres_b[None, :, :]  # (G, P, m)
    r = np.linalg.norm(d, axis=2)
    block[values_a:, :values_b] = (3.0 * r[:, :, None] * d).transpose(0, 2, 1).reshape(-1, values_b)
    d = slopes_b[:, None, :] - centres_a[None, :, :]
    r = np.linalg.norm(d, axis=2)
    block[:values_a, values_b:] = (
        (3.0 * r[:, :, None] * d).transpose(0, 2, 1).reshape(-1, values_a).T
    )
    # d^2 / dx_k dy_l: -3 (delta_kl r + d_k d_l / r), zero at r = 0
    d = slopes_a[:, None, :] - slopes_b[None, :, :]  # (G, H, m)
    r = np.linalg.norm(d, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        outer = np.where(r[:, :, None, None] > 0.0, d[:, :, :, None] * d[:, :, None, :], 0.0)
        outer = outer / np.where(r > 0.0, r, 1.0)[:, :, None, None]
    second = -3.0 * (r[:, :, None, None] * np.eye(dimension) + outer)  # (G, H, m, m)
    block[values_a:, values_b:] = second.transpose(0, 2, 1, 3).reshape(gradients_a, gradients_b)
    return block


def tail_block(centres: NDArray[np.float64], sloped_count: int) -> NDArray[np.float64]:
    """(1 + m, P + G m): the linear tail ``[1, x]`` under the values at the centres and
    its gradient ``[0, e_k]`` under the gradients (g-major)."""
    count, dimension = centres.shape
    tail = np.zeros((dimension + 1, count + sloped_count * dimension))
    tail[0, :count] = 1.0
    tail[1:, :count] = centres.T
    tail[1:, count:] = np.tile(np.eye(dimension), (1, sloped_count))
    return tail


class HermiteCorrection(KernelCorrection):
    """The cubic-spline interpolant of residual values and gradients (unit coordinates).

    Parameters
    ----------
    centres : ndarray (P, n)
        Points of ``[-1, 1]^n`` (the runs); of points closer than ``1e-9`` to an earlier
        one only the earlier is kept (with its residual and gradient).
    residuals : ndarray (P, E)
        Values to interpolate, one column per output element.
    slopes : ndarray (P, E, n)
        Gradients to interpolate (unit coordinates); rows where ``sloped`` is False are
        ignored.
    sloped : ndarray (P,) of bool
        The centres with a gradient.
    moving : ndarray (n,) of bool
        Directions that vary (a direction of zero width is left out).
    previous : KernelCorrection, optional
        An earlier round's correction. Where it is a Hermite correction and these
        centres continue its centres (the same first ones, with and without gradients
        alike, and the same ``moving``), its factorised system is bordered by the new
        functionals (:class:`~fuzzymbs.fuzzy.bordered_system.BorderedSystem`): ``O(N^2
        m)`` for ``m`` new unknowns instead of a fresh ``O(N^3)`` solve. Otherwise, or
        where the new functionals are numerically dependent on the old, the system is
        solved afresh.
    """

    def __init__(
        self,
        centres: NDArray[np.float64],
        residuals: NDArray[np.float64],
        slopes: NDArray[np.float64],
        sloped: NDArray[np.bool_],
        moving: NDArray,
        previous: KernelCorrection | None = None,
    ) -> None:
        self.moving, self.centres, distinct = distinct_centres(centres, moving)
        residuals = np.asarray(residuals, dtype=float)[distinct]
        self._keep = np.asarray(sloped, dtype=bool)[distinct]
        slopes = np.asarray(slopes, dtype=float)[distinct][self._keep][:, :, self.moving]
        self.slope_centres = self.centres[self._keep]  # (G, m)
        count, dimension = self.centres.shape
        sloped_count = len(self.slope_centres)
        elements = residuals.shape[1]
        # the data: values, gradients (g-major), the tail's zeros
        data = np.concatenate(
            (
                residuals,
                slopes.transpose(0, 2, 1).reshape(sloped_count * dimension, elements),
                np.zeros((dimension + 1, elements)),
            )
        )
        grown = self._grown(previous, data)
        if grown is not None:
            self._system, self._order, solved = grown
        else:
            self._system, self._order = self._factorised()
            kind, index = self._order
            right = data[_positions(kind, index, count, sloped_count * dimension)]
            if self._system is not None:
                solved = self._system.solve(right)
            else:  # dependent functionals: the least-squares interpolant
                solved = np.linalg.lstsq(self._matrix(), right, rcond=None)[0]
        kind, index = self._order
        solution = np.empty_like(solved)
        solution[_positions(kind, index, count, sloped_count * dimension)] = solved
        size = count + sloped_count * dimension
        self.weights = solution[:count]  # (P, E)
        self.slope_weights = solution[count:size].reshape(sloped_count, dimension, elements)
        # sum_l c_gl v_gle: the part of the derivative terms that does not depend on x
        self._anchor = np.einsum("gl,gle->ge", self.slope_centres, self.slope_weights)
        self.tail = solution[size:]  # (1 + m, E)

    def _matrix(self) -> NDArray[np.float64]:
        """The whole collocation system: values, gradients (g-major), then the tail."""
        dimension = self.centres.shape[1]
        kernel = functional_block(
            self.centres, self.slope_centres, self.centres, self.slope_centres
        )
        size = len(kernel)
        tail = tail_block(self.centres, len(self.slope_centres)).T  # (size, 1 + m)
        system = np.zeros((size + dimension + 1, size + dimension + 1))
        system[:size, :size] = kernel
        system[:size, size:] = tail
        system[size:, :size] = tail.T
        return system

    def _factorised(self) -> tuple[BorderedSystem | None, tuple[NDArray, NDArray]]:
        """The whole system factorised afresh (None where it is singular) and its order."""
        count, dimension = self.centres.shape
        kind = np.repeat(
            [_VALUE, _GRADIENT, _TAIL], [count, len(self.slope_centres) * dimension, dimension + 1]
        )
        index = np.concatenate(
            (
                np.arange(count),
                np.arange(len(self.slope_centres) * dimension),
                np.arange(dimension + 1),
            )
        )
        try:
            system = BorderedSystem(self._matrix())
        except np.linalg.LinAlgError:
            system = None
        return system, (kind, index)

    def _grown(
        self, previous: KernelCorrection | None, data: NDArray[np.float64]
    ) -> tuple[BorderedSystem, tuple[NDArray, NDArray], NDArray[np.float64]] | None:
        """``previous``'s factorised system bordered by this one's new runs, its order
        and its solution for ``data`` (values, gradients, tail), where ``previous`` is a
        Hermite correction with a factorised system and this one's centres continue its
        centres; None otherwise."""
        if not isinstance(previous, HermiteCorrection) or previous._system is None:
            return None
        old, old_sloped = len(previous.centres), len(previous.slope_centres)
        if (
            not np.array_equal(previous.moving, self.moving)
            or old > len(self.centres)
            or not np.array_equal(previous.centres, self.centres[:old])
            or not np.array_equal(previous._keep, self._keep[:old])
        ):
            return None
        dimension = self.centres.shape[1]
        new_centres = self.centres[old:]
        new_slopes = self.slope_centres[old_sloped:]
        # rows: every old functional (values, gradients, tail), in the old system's order
        rows = np.concatenate(
            (
                functional_block(previous.centres, previous.slope_centres, new_centres, new_slopes),
                tail_block(new_centres, len(new_slopes)),
            )
        )
        kind, index = previous._order
        border = rows[_positions(kind, index, old, old_sloped * dimension)]
        corner = functional_block(new_centres, new_slopes, new_centres, new_slopes)
        kind = np.concatenate(
            (
                kind,
                np.full(len(new_centres), _VALUE),
                np.full(len(new_slopes) * dimension, _GRADIENT),
            )
        )
        index = np.concatenate(
            (
                index,
                np.arange(old, len(self.centres)),
                np.arange(old_sloped * dimension, len(self.slope_centres) * dimension),
            )
        )
        gradients = len(self.slope_centres) * dimension
        right = data[_positions(kind, index, len(self.centres), gradients)]
        try:
            system, solved = previous._system.extended_solve(border, corner, right)
        except np.linalg.LinAlgError:  # the new runs depend on the old: a fresh solve
            return None
        return system, (kind, index), solved

    def _slope_parts(
        self, part: NDArray[np.float64], own: NDArray[np.intp]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``x_k - x_g`` (k, G, m), its length (k, G) and element ``own[k]``'s gradient
        weights at each slope centre (k, G, m)."""
        d = part[:, None, :] - self.slope_centres[None, :, :]
        weights = self.slope_weights[:, :, own].transpose(2, 0, 1)
        return d, np.linalg.norm(d, axis=2), weights

    def _block(self) -> int:
        centres = len(self.centres) + len(self.slope_centres) * max(1, self.centres.shape[1])
        return max(1, _BLOCK_ENTRIES // max(1, centres))

    # each method adds the gradient functionals' terms to the value-only correction's
    # (KernelCorrection: the kernel on the centres and the linear tail)

    def _block_values(
        self, part: NDArray[np.float64], distance: NDArray[np.float64], out: NDArray[np.float64]
    ) -> None:
        """``out`` (q, E) <- the correction at ``part`` (q, m), ``distance`` (q, P) its
        distances to the centres (the slope centres are among them: one distance matrix)."""
        super()._block_values(part, distance, out)
        if not len(self.slope_centres):
            return
        # -3 sum_g |x - x_g| (x - x_g) . v_g
        r = distance[:, self._keep]  # (q, G)
        along = sum(
            part[:, l : l + 1] * (r @ self.slope_weights[:, l, :]) for l in range(part.shape[1])
        )
        out -= 3.0 * (along - r @ self._anchor)

    def at(self, points: NDArray[np.float64], element: NDArray[np.intp]) -> NDArray[np.float64]:
        """(K,) the correction of element ``element[k]`` at ``points[k]``."""
        out = super().at(points, element)
        if not len(self.slope_centres):
            return out
        points = np.asarray(points, dtype=float)[:, self.moving]
        block = self._block()
        for start in range(0, len(points), block):
            part, own = points[start : start + block], element[start : start + block]
            d, r, weights = self._slope_parts(part, own)
            out[start : start + block] -= 3.0 * np.einsum("kg,kgl,kgl->k", r, d, weights)
        return out

    def gradient_at(
        self, points: NDArray[np.float64], element: NDArray[np.intp]
    ) -> NDArray[np.float64]:
        """(K, n) the gradient of element ``element[k]``'s correction at ``points[k]``
        (zero along the directions that do not vary)."""
        gradient = super().gradient_at(points, element)
        if not len(self.slope_centres):
            return gradient
        points = np.asarray(points, dtype=float)[:, self.moving]
        slope = gradient[:, self.moving]
        block = self._block()
        for start in range(0, len(points), block):
            part, own = points[start : start + block], element[start : start + block]
            # grad of -3 r (d . v) = -3 (r v + d (d . v) / r), zero at r = 0
            d, r, weights = self._slope_parts(part, own)
            dot = np.einsum("kgl,kgl->kg", d, weights)
            ratio = np.where(r > 0.0, dot / np.where(r > 0.0, r, 1.0), 0.0)
            slope[start : start + block] -= 3.0 * (
                np.einsum("kg,kgl->kl", r, weights) + np.einsum("kg,kgl->kl", ratio, d)
            )
        gradient[:, self.moving] = slope
        return gradient


def hermite_correction(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    units: NDArray[np.float64],
    values: NDArray[np.float64],
    nodes: NDArray[np.bool_],
    slopes: NDArray[np.float64],
    sloped: NDArray[np.bool_],
    moving: NDArray[np.bool_],
    previous: KernelCorrection | None = None,
) -> HermiteCorrection:
    """The gradient-enhanced correction of a sparse grid's series through runs.

    Parameters
    ----------
    degrees, coefficients : the series (D, n) and (D, E).
    units : ndarray (N, n)
        The runs (unit cube).
    values : ndarray (N, E)
        The model's outputs there.
    nodes : ndarray (N,) of bool
        The runs that are grid nodes (their value residual is round-off: set to zero).
    slopes : ndarray (N, E, n)
        The model's gradients (unit coordinates) where ``sloped``.
    sloped, moving : ndarray of bool
        Runs with a gradient; directions that vary.
    previous : the correction of an earlier round (value-only or not), whose runs the
        first of ``units`` repeat: a Hermite correction's factorised system is bordered
        by the new runs (:mod:`fuzzymbs.fuzzy.bordered_system`) instead of being solved
        afresh.
    """
    residuals = values - evaluate_series(degrees, coefficients, units)
    residuals[nodes] = 0.0
    slope_residuals = np.zeros_like(slopes)
    if sloped.any():
        _, gradient = basis_gradient(degrees, units[sloped])  # (n, G, D)
        series_slope = np.einsum("igd,de->gei", gradient, coefficients)
        slope_residuals[sloped] = slopes[sloped] - series_slope
    return HermiteCorrection(units, residuals, slope_residuals, sloped, moving, previous)


def flatten_gradients(
    gradients: Mapping[str, ArrayLike],
    layout: Mapping[str, tuple[int, tuple[int, ...]]],
    count: int,
    half_width: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Gradients ``{name: (B, *shape, n)}`` in parameter units as one (B, E, n) array in
    the unit cube's coordinates: ``df/du_i = df/dx_i (high_i - low_i) / 2`` (the chain
    rule through ``x = low + (u + 1) (high - low) / 2``); zero along a direction of zero
    width.

    Raises
    ------
    ModelOutputError
        Not the outputs' names, a wrong shape, or NaN or inf.
    """
    if not isinstance(gradients, Mapping) or set(gradients) != set(layout):
        given = sorted(gradients) if isinstance(gradients, Mapping) else type(gradients).__name__
        raise ModelOutputError(
            f"gradients must be a dict with the outputs' names {sorted(layout)}, got {given}"
        )
    dimension = len(half_width)
    parts = []
    for name, (_, shape) in layout.items():
        value = np.asarray(gradients[name], dtype=float)
        if value.shape != (count, *shape, dimension):
            raise ModelOutputError(
                f"gradient of {name!r} must have shape {(count, *shape, dimension)} (runs, "
                f"output shape, parameters), got {value.shape}"
            )
        if not np.all(np.isfinite(value)):
            raise ModelOutputError(f"gradient of {name!r} has NaN or inf")
        parts.append(value.reshape(count, -1, dimension))
    return np.concatenate(parts, axis=1) * half_width
