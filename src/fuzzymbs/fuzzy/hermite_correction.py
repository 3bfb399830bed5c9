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
from fuzzymbs.fuzzy.chebyshev_grid import basis_gradient, evaluate_series
from fuzzymbs.fuzzy.residual_correction import (
    KernelCorrection,
    cubic_kernel,
    distances,
    distinct_centres,
)

__all__ = ["HermiteCorrection", "flatten_gradients", "hermite_correction"]

#: float64 entries of one block of kernel values
_BLOCK_ENTRIES = 4_000_000


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
    """

    def __init__(
        self,
        centres: NDArray[np.float64],
        residuals: NDArray[np.float64],
        slopes: NDArray[np.float64],
        sloped: NDArray[np.bool_],
        moving: NDArray,
    ) -> None:
        self.moving, self.centres, distinct = distinct_centres(centres, moving)
        residuals = np.asarray(residuals, dtype=float)[distinct]
        keep = np.asarray(sloped, dtype=bool)[distinct]
        slopes = np.asarray(slopes, dtype=float)[distinct][keep][:, :, self.moving]  # (G, E, m)
        self.slope_centres = self.centres[keep]
        count, dimension = self.centres.shape
        sloped_count = len(self.slope_centres)
        elements = residuals.shape[1]
        size = count + sloped_count * dimension
        system = np.zeros((size + dimension + 1, size + dimension + 1))
        system[:count, :count] = cubic_kernel(self.centres, self.centres)
        # d/dx_k at x_g of |x - x_j|^3: 3 |x_g - x_j| (x_g - x_j)_k; rows (g, k) g-major
        d = self.slope_centres[:, None, :] - self.centres[None, :, :]  # (G, P, m)
        r = np.linalg.norm(d, axis=2)
        mixed = (3.0 * r[:, :, None] * d).transpose(0, 2, 1).reshape(-1, count)
        system[count:size, :count] = mixed
        system[:count, count:size] = mixed.T
        # d^2 / dx_k dy_l: -3 (delta_kl r + d_k d_l / r), zero at r = 0
        d = self.slope_centres[:, None, :] - self.slope_centres[None, :, :]  # (G, G, m)
        r = np.linalg.norm(d, axis=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            outer = np.where(r[:, :, None, None] > 0.0, d[:, :, :, None] * d[:, :, None, :], 0.0)
            outer = outer / np.where(r > 0.0, r, 1.0)[:, :, None, None]
        second = -3.0 * (r[:, :, None, None] * np.eye(dimension) + outer)  # (G, G, m, m)
        system[count:size, count:size] = second.transpose(0, 2, 1, 3).reshape(
            sloped_count * dimension, sloped_count * dimension
        )
        tail = np.zeros((size, dimension + 1))
        tail[:count, 0] = 1.0
        tail[:count, 1:] = self.centres
        tail[count:, 1:] = np.tile(np.eye(dimension), (sloped_count, 1))
        system[:size, size:] = tail
        system[size:, :size] = tail.T
        right = np.zeros((size + dimension + 1, elements))
        right[:count] = residuals
        right[count:size] = slopes.transpose(0, 2, 1).reshape(sloped_count * dimension, elements)
        try:
            solution = np.linalg.solve(system, right)
        except np.linalg.LinAlgError:  # dependent functionals: the least-squares interpolant
            solution = np.linalg.lstsq(system, right, rcond=None)[0]
        self.weights = solution[:count]  # (P, E)
        self.slope_weights = solution[count:size].reshape(sloped_count, dimension, elements)
        # sum_l c_gl v_gle: the part of the derivative terms that does not depend on x
        self._anchor = np.einsum("gl,gle->ge", self.slope_centres, self.slope_weights)
        self.tail = solution[size:]  # (1 + m, E)

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

    def values(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """(Q, E) the correction at points (Q, n)."""
        out = super().values(points)
        if not len(self.slope_centres):
            return out
        points = np.atleast_2d(np.asarray(points, dtype=float))[:, self.moving]
        block = self._block()
        for start in range(0, len(points), block):
            part = points[start : start + block]
            # -3 sum_g |x - x_g| (x - x_g) . v_g
            r = distances(part, self.slope_centres)  # (q, G)
            along = sum(
                part[:, l : l + 1] * (r @ self.slope_weights[:, l, :]) for l in range(part.shape[1])
            )
            out[start : start + block] -= 3.0 * (along - r @ self._anchor)
        return out

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
    """
    residuals = values - evaluate_series(degrees, coefficients, units)
    residuals[nodes] = 0.0
    slope_residuals = np.zeros_like(slopes)
    if sloped.any():
        _, gradient = basis_gradient(degrees, units[sloped])  # (n, G, D)
        series_slope = np.einsum("igd,de->gei", gradient, coefficients)
        slope_residuals[sloped] = slopes[sloped] - series_slope
    return HermiteCorrection(units, residuals, slope_residuals, sloped, moving)


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
