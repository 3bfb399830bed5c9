"""Linearisation of a mechanism of either engine, joints included: eigenvalues at a state.

The joints leave n - c independent directions: the null space N of the
constraint Jacobian G at the state (orthonormal, from the SVD). The
equations of motion are differentiated along those directions only
(central differences of the constrained accelerations, each perturbed state
projected back onto the joints), which gives the reduced first-order system
d/dt (y, y') = J (y, y') with y = N^T z. Its eigenvalues are those of the
mechanism about a static equilibrium, or about a steady motion whose
equations do not depend on time in the moving frame (a rotor at constant
speed).

Each engine's ``Mechanism.reduced_system`` supplies the reduced rate: in the
plane a position moves by adding the direction; in space it moves in velocity
coordinates (the frame origin, a small rotation in the body frame, the modal
coordinates) and is projected back onto the joints, so the Euler parameters
stay unit quaternions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.assembly import PROJECTION_TOLERANCE, Assembly

#: ``reduced_rate(position, velocity) -> (N^T v, N^T a)`` (:func:`central_linearization`)
ReducedRate = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


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
    mechanism: Assembly,
    t: float = 0.0,
    state: ArrayLike | None = None,
    step: float = 1e-6,
) -> Linearization:
    """Linearise ``mechanism``, planar or spatial, at time ``t`` about ``state`` (default:
    its initial state).

    Parameters
    ----------
    mechanism : Mechanism
        A :class:`fuzzymbs.mbs.planar.Mechanism` or a :class:`fuzzymbs.mbs.spatial.Mechanism`.
    t : float
        Time [s] (drives are evaluated there).
    state : array_like, optional
        Projected onto the joints first. Planar: coordinates then rates, shape (2n,);
        spatial: positions (r, Euler parameters, q per body) then velocities (r', w, q'
        per body).
    step : float
        Central-difference step: in the plane relative to the state's largest magnitude, in
        space in velocity coordinates [m, rad, modal units].

    Returns
    -------
    Linearization
        Eigenvalues, the reduced Jacobian and the free directions (in velocity coordinates).
    """
    # each engine's Mechanism gives its own reduced system (reduced_system)
    return central_linearization(*mechanism.reduced_system(t, state, step))


def projected_state(
    engine: ModuleType,
    t: float,
    state: ArrayLike | None,
    initial: NDArray[np.float64],
    split: int,
    layout: Any,
    data: NDArray[np.float64],
    order: str,
) -> NDArray[np.float64]:
    """``state`` (default ``initial``), checked and projected onto the joints.

    Parameters
    ----------
    engine : module
        The engine's kernels (``project``).
    t : float
        Time [s].
    state : array_like or None
        Positions (``split`` numbers) then velocities.
    initial : ndarray
        The mechanism's initial state (its size is the state's).
    split : int
        The number of positions.
    layout, data
        The packed mechanism.
    order : str
        What the state holds, in the messages.
    """
    x0 = initial.copy() if state is None else np.array(state, dtype=float)
    if x0.shape != initial.shape or not np.isfinite(x0).all():
        raise InvalidParameterError(
            f"state must be {initial.size} finite numbers ({order}), got shape {x0.shape}"
        )
    if not (
        engine.project(t, x0[:split], x0[split:], layout, data, PROJECTION_TOLERANCE)
        <= PROJECTION_TOLERANCE
    ):
        raise InvalidParameterError("the state cannot be projected onto the joints")
    return x0


def reduced_rate_function(
    engine: ModuleType,
    t: float,
    x0: NDArray[np.float64],
    split: int,
    layout: Any,
    data: NDArray[np.float64],
    user: object,
    basis: NDArray[np.float64],
    constraints: int,
    move: Callable[[NDArray[np.float64], NDArray[np.float64]], None],
) -> ReducedRate:
    """``reduced_rate(position, velocity)`` for :func:`central_linearization`.

    The state ``x0`` (``split`` positions, then the velocities) is moved by ``position``
    (``move(positions, position)``, in velocity coordinates) and ``velocity``, projected
    onto the joints and the constrained accelerations a solved with the engine's kernels
    (``project``, ``accelerations``); it returns (N^T v, N^T a) with N = ``basis``.
    """
    n = basis.shape[0]
    system = np.empty((n + constraints, n + constraints))
    solution = np.empty(n + constraints)

    def reduced_rate(
        position: NDArray[np.float64], velocity: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        x = x0.copy()
        move(x[:split], position)
        x[split:] += velocity
        q, v = x[:split], x[split:]
        engine.project(t, q, v, layout, data, 1e-13)
        if not engine.accelerations(t, q, v, layout, data, user, system, solution):
            raise InvalidParameterError("the mass matrix with the joints is singular at this state")
        return np.concatenate([basis.T @ v, basis.T @ solution[:n]])

    return reduced_rate


def central_linearization(
    reduced_rate: ReducedRate,
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
