"""Linearisation of a planar mechanism, joints included: eigenvalues at a state.

The joints leave n - c independent directions: the null space N of the
constraint Jacobian G at the state (orthonormal, from the SVD). The
equations of motion are differentiated along those directions only
(central differences of the constrained accelerations, each perturbed state
projected back onto the joints), which gives the reduced first-order system
d/dt (y, y') = J (y, y') with y = N^T z. Its eigenvalues are those of the
mechanism about a static equilibrium, or about a steady motion whose
equations do not depend on time in the moving frame (a rotor at constant
speed).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar import kernels
from fuzzymbs.mbs.planar.simulation import PROJECTION_TOLERANCE
from fuzzymbs.mbs.planar.system import Mechanism, joint_rows


@dataclass(frozen=True)
class Linearization:
    """The reduced Jacobian at a state and its eigenvalues.

    Attributes
    ----------
    eigenvalues : (2 (n - c),) complex [1/s], sorted by imaginary part then real part.
    matrix : (2 (n - c), 2 (n - c)) reduced Jacobian.
    basis : (n, n - c) orthonormal directions the joints leave free.
    """

    eigenvalues: NDArray[np.complex128]
    matrix: NDArray[np.float64]
    basis: NDArray[np.float64]

    def frequencies(self) -> NDArray[np.float64]:
        """Positive damped angular frequencies [rad/s], ascending (oscillatory modes only)."""
        imag = self.eigenvalues.imag
        return np.sort(imag[imag > 1e-9])


def free_directions(jac: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """An orthonormal basis (n, n - rank) of the null space of the joints' Jacobian."""
    if jac.shape[0] == 0:
        return np.eye(n)
    _, singular, vt = scipy.linalg.svd(jac)
    rank = int(np.sum(singular > 1e-10 * max(1.0, singular.max())))
    return vt[rank:].T


def linearize(
    mechanism: Mechanism,
    t: float = 0.0,
    state: ArrayLike | None = None,
    step: float = 1e-6,
) -> Linearization:
    """Linearise ``mechanism`` at time ``t`` about ``state`` (default: its initial state).

    Parameters
    ----------
    mechanism : Mechanism
    t : float
        Time [s] (drives are evaluated there).
    state : array_like, shape (2n,), optional
        Coordinates and rates; projected onto the joints first.
    step : float
        Relative central-difference step.
    """
    layout, data, initial = mechanism.pack()
    arrays = layout.arrays()
    n, c = (int(s) for s in layout.sizes)
    x0 = initial.copy() if state is None else np.array(state, dtype=float)
    if x0.shape != (2 * n,) or not np.isfinite(x0).all():
        raise InvalidParameterError(
            f"state must be {2 * n} finite numbers (z then v), got shape {x0.shape}"
        )
    user = mechanism.user_function()
    if (
        not kernels.project(t, x0[:n], x0[n:], arrays, data, PROJECTION_TOLERANCE)
        <= PROJECTION_TOLERANCE
    ):
        raise InvalidParameterError("the state cannot be projected onto the joints")
    _, jac = joint_rows(t, layout, data, x0)
    basis = free_directions(jac, n)
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)

    def reduced_rate(
        position: NDArray[np.float64], velocity: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        x = x0.copy()
        x[:n] += position
        x[n:] += velocity
        kernels.project(t, x[:n], x[n:], arrays, data, 1e-13)
        if not kernels.accelerations(t, x[:n], x[n:], arrays, data, user, system, solution):
            raise InvalidParameterError("the mass matrix with the joints is singular at this state")
        return np.concatenate([basis.T @ x[n:], basis.T @ solution[:n]])

    return central_linearization(reduced_rate, basis, step * max(1.0, float(np.abs(x0).max())))


def central_linearization(
    reduced_rate: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]],
    basis: NDArray[np.float64],
    step: float,
) -> Linearization:
    """The reduced Jacobian by central differences and its eigenvalues.

    ``reduced_rate(position, velocity)`` gives (N^T v, N^T a) after moving the state by
    ``position`` and ``velocity`` (velocity coordinates, then projected onto the joints);
    column k of the Jacobian moves the position (k < f) or the velocity (k >= f) by
    +-``step`` along column k mod f of ``basis`` (n, f).
    """
    n, free = basis.shape
    zero = np.zeros(n)
    matrix = np.empty((2 * free, 2 * free))
    for k in range(2 * free):
        direction = basis[:, k % free] * step
        if k < free:
            plus, minus = reduced_rate(direction, zero), reduced_rate(-direction, zero)
        else:
            plus, minus = reduced_rate(zero, direction), reduced_rate(zero, -direction)
        matrix[:, k] = (plus - minus) / (2 * step)
    eigenvalues = np.linalg.eigvals(matrix)
    order = np.lexsort((eigenvalues.real, eigenvalues.imag))
    return Linearization(eigenvalues[order], matrix, basis)
