"""A kernel correction that makes the adaptive method's surrogate interpolate every run.

The sparse grid of :mod:`fuzzymbs.fuzzy.chebyshev_grid` interpolates the model
at its nodes only; the adaptive method also runs the model at points off the
grid (certification at the surrogate's extremal points, exploration). Their
residuals ``r_i = f(x_i) - s(x_i)`` (zero at the nodes) are interpolated by a
polyharmonic spline, the cubic kernel ``phi(d) = d^3`` with a linear
polynomial part (Wendland, Scattered Data Approximation, Cambridge 2005,
ch. 8: conditionally positive definite of order 2, so the interpolant exists
and is unique for distinct points), one column per output element:

    c(x) = s(x) + sum_i w_i |x - x_i|^3 + a_0 + a^T x,
    sum_i w_i = 0, sum_i w_i x_i = 0.

``c`` takes the model's value at every run: where a certification run found the
surrogate off, the next round's bounds start from the true value there. The
kernel has no length scale, so the correction is the smoothest (minimum
bending energy) function through the residuals and stays small between
nodes where the residuals are zero.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from numpy.typing import NDArray

__all__ = ["KernelCorrection", "cubic_kernel", "distances", "distinct_centres"]

#: float64 entries of one block of kernel values: each block makes a few arrays of this
#: size (distances, kernel, design matrix), so 512 kB each stay in the core's cache. Against
#: 4,000,000 (benchmarks/correction_blocks.py, 2026-12-02, Xeon host, 2 MiB L2 a core): the
#: adaptive method on the oscillator and the chain at 0.5 % damping without gradients (2,324
#: and 1,354 runs, the time the method's) 0.58 and 0.56 of the wall time, 1,048,576 0.68 and
#: 0.64; the same runs and certified errors
_BLOCK_ENTRIES = 65_536
#: points closer than this (unit coordinates) are one centre
_SAME = 1e-9


class KernelCorrection:
    """The cubic-spline interpolant of residuals at scattered points (unit coordinates).

    Parameters
    ----------
    centres : ndarray (P, n)
        Points of ``[-1, 1]^n`` (the runs); of points closer than ``1e-9`` to an earlier
        one only the earlier is kept (its residual is the one interpolated).
    residuals : ndarray (P, E)
        Values to interpolate, one column per output element.
    moving : ndarray (n,) of bool
        Directions that vary (a direction of zero width is left out of the distances).
    """

    def __init__(
        self, centres: NDArray[np.float64], residuals: NDArray[np.float64], moving: NDArray
    ) -> None:
        self.moving, self.centres, distinct = distinct_centres(centres, moving)
        residuals = np.asarray(residuals, dtype=float)[distinct]
        count, dimension = self.centres.shape
        kernel = cubic_kernel(self.centres, self.centres)
        tail = np.concatenate((np.ones((count, 1)), self.centres), axis=1)
        system = np.zeros((count + dimension + 1, count + dimension + 1))
        system[:count, :count] = kernel
        system[:count, count:] = tail
        system[count:, :count] = tail.T
        right = np.zeros((count + dimension + 1, residuals.shape[1]))
        right[:count] = residuals
        try:
            solution = np.linalg.solve(system, right)
        except np.linalg.LinAlgError:  # coinciding points: the least-squares interpolant
            solution = np.linalg.lstsq(system, right, rcond=None)[0]
        self.weights = solution[:count]  # (P, E)
        self.tail = solution[count:]  # (1 + n_moving, E)

    @cached_property
    def _stacked(self) -> NDArray[np.float64]:
        """(P + 1 + n_moving, E): the weights over the tail, the rows of one product."""
        return np.concatenate((self.weights, self.tail))

    def values(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """(Q, E) the correction at points (Q, n)."""
        points = np.atleast_2d(np.asarray(points, dtype=float))[:, self.moving]
        out = np.empty((len(points), self.weights.shape[1]))
        block = self._block()
        for start in range(0, len(points), block):
            part = points[start : start + block]
            self._block_values(part, distances(part, self.centres), out[start : start + block])
        return out

    def _block(self) -> int:
        """Points per block of kernel values."""
        return max(1, _BLOCK_ENTRIES // max(1, len(self.centres)))

    def _block_values(
        self, part: NDArray[np.float64], distance: NDArray[np.float64], out: NDArray[np.float64]
    ) -> None:
        """``out`` (q, E) <- the correction at ``part`` (q, m), ``distance`` (q, P) its
        distances to the centres."""
        count = len(self.centres)
        # [|x - c|^3, 1, x] times the stacked weights: one matrix product, no (Q, E)
        # temporaries (a third of the time of the three terms added)
        design = np.empty((len(part), count + 1 + part.shape[1]))
        design[:, :count] = distance * distance * distance
        design[:, count] = 1.0
        design[:, count + 1 :] = part
        np.matmul(design, self._stacked, out=out)

    def at(self, points: NDArray[np.float64], element: NDArray[np.intp]) -> NDArray[np.float64]:
        """(K,) the correction of element ``element[k]`` at ``points[k]``."""
        points = np.asarray(points, dtype=float)[:, self.moving]
        out = np.empty(len(points))
        block = max(1, _BLOCK_ENTRIES // max(1, len(self.centres)))
        for start in range(0, len(points), block):
            part, own = points[start : start + block], element[start : start + block]
            kernel = cubic_kernel(part, self.centres)  # (k, P)
            tail = self.tail[:, own]  # (1 + n, k)
            out[start : start + block] = (
                (kernel * self.weights[:, own].T).sum(axis=1)
                + tail[0]
                + (part * tail[1:].T).sum(axis=1)
            )
        return out

    def gradient_at(
        self, points: NDArray[np.float64], element: NDArray[np.intp]
    ) -> NDArray[np.float64]:
        """(K, n) the gradient of element ``element[k]``'s correction at ``points[k]``
        (zero along the directions that do not vary)."""
        full = np.asarray(points, dtype=float)
        points = full[:, self.moving]
        slope = np.empty_like(points)
        block = max(1, _BLOCK_ENTRIES // max(1, len(self.centres)))
        for start in range(0, len(points), block):
            part, own = points[start : start + block], element[start : start + block]
            distance = distances(part, self.centres)  # (k, P)
            # grad_x |x - c|^3 = 3 |x - c| (x - c): sum_p 3 d_kp w_pk (x_k - c_p)
            factor = 3.0 * distance * self.weights[:, own].T  # (k, P)
            slope[start : start + block] = (
                factor.sum(axis=1)[:, None] * part - factor @ self.centres + self.tail[1:, own].T
            )
        gradient = np.zeros_like(full)
        gradient[:, self.moving] = slope
        return gradient


def distinct_centres(
    centres: NDArray[np.float64], moving: NDArray
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.bool_]]:
    """``moving`` as booleans, the centres (P, n) in the moving directions with every point
    closer than ``1e-9`` to an earlier one left out, and which rows were kept (P,)."""
    moving = np.asarray(moving, dtype=bool)
    centres = np.asarray(centres, dtype=float)[:, moving]
    distinct = ~np.triu(distances(centres, centres) < _SAME, k=1).any(axis=0)
    return moving, centres[distinct], distinct


def distances(points: NDArray[np.float64], centres: NDArray[np.float64]) -> NDArray[np.float64]:
    """(Q, P) ``|x_q - c_p|``."""
    squared = (
        np.einsum("qi,qi->q", points, points)[:, None]
        + np.einsum("pi,pi->p", centres, centres)[None, :]
        - 2.0 * points @ centres.T
    )
    return np.sqrt(np.maximum(squared, 0.0, out=squared), out=squared)


def cubic_kernel(points: NDArray[np.float64], centres: NDArray[np.float64]) -> NDArray[np.float64]:
    """(Q, P) ``|x_q - c_p|^3``."""
    distance = distances(points, centres)
    return distance * distance * distance
