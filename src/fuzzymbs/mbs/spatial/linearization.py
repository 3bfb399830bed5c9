"""Linearisation of a spatial mechanism, joints included: eigenvalues at a state.

As in the plane (:mod:`fuzzymbs.mbs.planar.linearization`): the joints leave the
directions N, the null space of the joints' Jacobian G on the velocities
(r', w, q'); the constrained accelerations are differentiated along them by
central differences. A position is moved along a direction in velocity
coordinates (the frame origin, a small rotation in the body frame, the modal
coordinates), then projected back onto the joints, so the Euler parameters
stay unit quaternions. The reduced system is d/dt (y, y') = J (y, y') with
y = N^T (the displacement in those coordinates).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar.linearization import (
    Linearization,
    central_linearization,
    free_directions,
)
from fuzzymbs.mbs.spatial import kernels, kinematics
from fuzzymbs.mbs.spatial.system import PROJECTION_TOLERANCE, Mechanism


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
    state : array_like, optional
        Positions (r, Euler parameters, q per body) then velocities (r', w, q' per body);
        projected onto the joints first.
    step : float
        Central-difference step [m, rad, modal units].

    Returns
    -------
    Linearization
        Eigenvalues, the reduced Jacobian and the free directions (in velocity coordinates).
    """
    mechanism.check(t)
    layout, data, initial = mechanism.pack()
    nq, n, c = (int(s) for s in layout[4])
    x0 = initial.copy() if state is None else np.array(state, dtype=float)
    if x0.shape != (nq + n,) or not np.isfinite(x0).all():
        raise InvalidParameterError(
            f"state must be {nq + n} finite numbers (positions then velocities), "
            f"got shape {x0.shape}"
        )
    if not kernels.project(t, x0[:nq], x0[nq:], layout, data, PROJECTION_TOLERANCE) <= (
        PROJECTION_TOLERANCE
    ):
        raise InvalidParameterError("the state cannot be projected onto the joints")
    jac = np.zeros((c, n))
    if c:
        spare = [np.empty(c) for _ in range(4)]
        kernels.joint_terms(t, layout, data, x0[:nq], x0[nq:], jac, *spare)
    basis = free_directions(jac, n)
    user = mechanism.user_function()
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)

    def reduced_rate(
        position: NDArray[np.float64], velocity: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        x = x0.copy()
        kinematics.displace(x[:nq], layout[0], position)
        x[nq:] += velocity
        kernels.project(t, x[:nq], x[nq:], layout, data, 1e-13)
        if not kernels.accelerations(t, x[:nq], x[nq:], layout, data, user, system, solution):
            raise InvalidParameterError("the mass matrix with the joints is singular at this state")
        return np.concatenate([basis.T @ x[nq:], basis.T @ solution[:n]])

    return central_linearization(reduced_rate, basis, step)
