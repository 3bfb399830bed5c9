"""Solves of a symmetric interpolation system that grows by bordering, round by round.

The adaptive method's Hermite correction (:mod:`fuzzymbs.fuzzy.hermite_correction`)
solves one collocation system per round; from one round to the next the runs only
grow, so the new system is the old one bordered by the new functionals' rows and
columns. Ordering the unknowns by the round that brought them,

    A_k = [[A_(k-1), B_k], [B_k^T, C_k]],   S_k = C_k - B_k^T A_(k-1)^(-1) B_k,

block elimination solves ``A_k x = r`` from a factorisation of the first block and one
Schur complement per round: ``x_2 = S_k^(-1) (r_2 - Y_k^T r_1)`` with ``Y_k = A_(k-1)^(-1)
B_k`` (stored; ``B_k^T A_(k-1)^(-1) = Y_k^T`` as A is symmetric), then ``x_1 =
A_(k-1)^(-1) r_1 - Y_k x_2``. A round's extension costs ``O(N^2 m)`` for ``m`` new
unknowns instead of a fresh ``O(N^3)`` factorisation (block LU and the Cholesky
factorisation: Golub and Van Loan, Matrix Computations, 4th ed., 2013, ch. 3 and 4).

For a conditionally positive definite kernel whose first block holds the polynomial
tail (the interpolant through the first round's functionals exists), each ``S_k`` is
symmetric positive definite: it is the new functionals' conditional covariance given
the old (Wendland, Scattered Data Approximation, 2005, ch. 16). It is factorised by
Cholesky, which fails when the new functionals are (numerically) dependent on the old;
the caller then falls back to a fresh solve of the whole system.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

__all__ = ["BorderedSystem"]


class BorderedSystem:
    """A factorised symmetric system, extended by new trailing rows and columns.

    Parameters
    ----------
    matrix : ndarray (N, N)
        The first block, symmetric and nonsingular (LU with partial pivoting: it may be
        indefinite, as a kernel system with its polynomial tail is).

    Raises
    ------
    numpy.linalg.LinAlgError
        If the first block is singular (an exactly zero pivot) or not finite.
    """

    def __init__(self, matrix: NDArray[np.float64]) -> None:
        # imported here: the fuzzy engine loads SciPy's linear algebra (0.25 s) only when
        # a correction with gradients is solved
        import scipy.linalg

        matrix = np.asarray(matrix, dtype=float)
        if not np.all(np.isfinite(matrix)):
            raise np.linalg.LinAlgError("the first block has entries that are not finite")
        with warnings.catch_warnings():  # a zero pivot is raised as an error below
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            lu, pivots = scipy.linalg.lu_factor(matrix, check_finite=False)
        if np.any(np.diag(lu) == 0.0):
            raise np.linalg.LinAlgError("the first block is singular")
        self._first = (lu, pivots)
        #: (start, Y_k (start, m), Cholesky factor of S_k (m, m)) per extension
        self._levels: tuple[tuple[int, NDArray[np.float64], NDArray[np.float64]], ...] = ()
        self.size = len(matrix)

    def extended(self, border: NDArray[np.float64], corner: NDArray[np.float64]) -> BorderedSystem:
        """The system bordered by ``border`` (N, m) and ``corner`` (m, m); this one is left
        as it is (the new one shares its factors).

        Raises
        ------
        numpy.linalg.LinAlgError
            If the Schur complement is not numerically positive definite (the new
            rows depend on the old ones).
        """
        return self.extended_solve(border, corner, np.zeros((self.size + len(corner), 0)))[0]

    def extended_solve(
        self,
        border: NDArray[np.float64],
        corner: NDArray[np.float64],
        right: NDArray[np.float64],
    ) -> tuple[BorderedSystem, NDArray[np.float64]]:
        """:meth:`extended`, and the grown system's solution for ``right`` (N + m, k):
        ``A^(-1) r_1`` comes with ``Y = A^(-1) B`` from one solve of the old system (its
        factors read once for both), and the new block from the Schur complement."""
        border = np.asarray(border, dtype=float)
        corner = np.asarray(corner, dtype=float)
        right = np.asarray(right, dtype=float)
        if border.shape != (self.size, len(corner)) or corner.shape[0] != corner.shape[1]:
            raise ValueError(
                f"border {border.shape} and corner {corner.shape} do not fit a system of "
                f"{self.size} unknowns"
            )
        if right.ndim != 2 or right.shape[0] != self.size + len(corner):
            raise ValueError(
                f"right-hand side {right.shape} for {self.size + len(corner)} unknowns"
            )
        grown = object.__new__(BorderedSystem)
        grown._first = self._first
        grown.size = self.size + len(corner)
        if not len(corner):
            grown._levels = self._levels
            return grown, self.solve(right)
        both = self.solve(np.concatenate((border, right[: self.size]), axis=1))
        solved, old = both[:, : len(corner)], both[:, len(corner) :]
        schur = corner - border.T @ solved
        schur = 0.5 * (schur + schur.T)
        if not np.all(np.isfinite(schur)):
            raise np.linalg.LinAlgError("the Schur complement is not finite")
        factor = np.linalg.cholesky(schur)  # raises LinAlgError if not positive definite
        grown._levels = (*self._levels, (self.size, np.ascontiguousarray(solved), factor))
        new = _cholesky_solve(factor, right[self.size :] - solved.T @ right[: self.size])
        return grown, np.concatenate((old - solved @ new, new))

    def solve(self, right: NDArray[np.float64]) -> NDArray[np.float64]:
        """``x`` with ``A x = right`` (right: (size,) or (size, k))."""
        import scipy.linalg

        right = np.asarray(right, dtype=float)
        if right.shape[0] != self.size:
            raise ValueError(f"right-hand side of {right.shape[0]} rows for {self.size} unknowns")
        x = np.empty_like(right)
        first = len(self._first[0])
        x[:first] = scipy.linalg.lu_solve(self._first, right[:first], check_finite=False)
        for start, solved, factor in self._levels:
            stop = start + factor.shape[0]
            reduced = right[start:stop] - solved.T @ right[:start]
            new = _cholesky_solve(factor, reduced)
            x[:start] -= solved @ new
            x[start:stop] = new
        return x


def _cholesky_solve(factor: NDArray[np.float64], right: NDArray[np.float64]) -> NDArray[np.float64]:
    """``S^(-1) right`` from the lower Cholesky factor of S."""
    import scipy.linalg

    return scipy.linalg.cho_solve((factor, True), right, check_finite=False)
