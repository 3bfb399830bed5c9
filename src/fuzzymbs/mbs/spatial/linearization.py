"""Linearisation of a spatial mechanism, joints included: eigenvalues at a state.

As in the plane (:mod:`fuzzymbs.mbs.planar.linearization`): the joints leave the
directions N, the null space of the joints' Jacobian G on the velocities
(r', w, q'); the constrained accelerations are differentiated along them by
central differences. A position is moved along a direction in velocity
coordinates (the frame origin, a small rotation in the body frame, the modal
coordinates), then projected back onto the joints, so the Euler parameters
stay unit quaternions. The reduced system is d/dt (y, y') = J (y, y') with
y = N^T (the displacement in those coordinates). :func:`linearize` is the planar
engine's, which takes either engine's mechanism.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.mbs.planar.linearization import (
    ReducedRate,
    free_directions,
    linearize,
    projected_state,
    reduced_rate_function,
)
from fuzzymbs.mbs.spatial import kernels, kinematics
from fuzzymbs.mbs.spatial.system import Mechanism


def reduced_system(
    mechanism: Mechanism, t: float, state: ArrayLike | None, step: float
) -> tuple[ReducedRate, NDArray[np.float64], float]:
    """What :func:`~fuzzymbs.mbs.planar.linearization.central_linearization` takes for a
    spatial mechanism: the reduced rate (positions moved in velocity coordinates), the
    joints' free directions and the step."""
    mechanism.check(t)
    layout, data, initial = mechanism.pack()
    nq, n, c = (int(s) for s in layout[4])
    x0 = projected_state(kernels, t, state, initial, nq, layout, data, "positions then velocities")
    jac = np.zeros((c, n))
    if c:
        spare = [np.empty(c) for _ in range(4)]
        kernels.joint_terms(t, layout, data, x0[:nq], x0[nq:], jac, *spare)
    basis = free_directions(jac, n)
    user = mechanism.user_function()

    def move(positions: NDArray[np.float64], position: NDArray[np.float64]) -> None:
        kinematics.displace(positions, layout[0], position)

    return (
        reduced_rate_function(kernels, t, x0, nq, layout, data, user, basis, c, move),
        basis,
        step,
    )


__all__ = ["linearize", "reduced_system"]
