"""Time integration of spatial mechanisms: an explicit Runge-Kutta pair per sample (the
planar engine's loop, :func:`fuzzymbs.mbs.planar.integrator.run_sample`, with its tableaus,
error norm and step control) on the positions with the Euler parameters' kinematics, joints
projected after every accepted step; ranges of samples run with the GIL released.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.planar.integrator import run_range
from fuzzymbs.mbs.planar.kernels import live_states
from fuzzymbs.mbs.spatial.kernels import accelerations, project


@nb.njit(cache=True)
def _position_rates(layout, q, v, out):
    """The positions' rates into ``out[:nq]``: r' = v, p' = 1/2 p (0, w), q' = q'."""
    bodies = layout[0]
    for b in range(bodies.shape[0]):
        po = bodies[b, 0]
        vo = bodies[b, 1]
        for i in range(3):
            out[po + i] = v[vo + i]
        e0, e1, e2, e3 = q[po + 3], q[po + 4], q[po + 5], q[po + 6]
        wx, wy, wz = v[vo + 3], v[vo + 4], v[vo + 5]
        out[po + 3] = 0.5 * (-e1 * wx - e2 * wy - e3 * wz)
        out[po + 4] = 0.5 * (e0 * wx + e2 * wz - e3 * wy)
        out[po + 5] = 0.5 * (e0 * wy - e1 * wz + e3 * wx)
        out[po + 6] = 0.5 * (e0 * wz + e1 * wy - e2 * wx)
        for x in range(bodies[b, 3]):
            out[po + 7 + x] = v[vo + 6 + x]


@nb.njit(cache=True)
def _arrays(layout):
    """(nq, system, solution): the positions' count and the constrained solve's arrays."""
    sizes = layout[4]
    n = sizes[1]
    c = sizes[2]
    return sizes[0], np.empty((n + c, n + c)), np.empty(n + c)


@nb.njit(cache=True)
def _rates(t, x, layout, data, user_force, scratch, out):
    """(q', v') at (t, x) into ``out``; False if the accelerations are not finite."""
    nq, system, solution = scratch
    n = layout[4][1]
    q = x[:nq]
    v = x[nq:]
    ok = accelerations(t, q, v, layout, data, user_force, system, solution)
    _position_rates(layout, q, v, out)
    for i in range(n):
        out[nq + i] = solution[i]
    return ok


@nb.njit(cache=True)
def _project(t, x, layout, data, scratch, tolerance):
    """The joints' projection of x = (q, v), Euler parameters normalised."""
    nq = scratch[0]
    return project(t, x[:nq], x[nq:], layout, data, tolerance)


@nb.njit(cache=True)
def _first_stage(x, k, stages, layout, scratch):
    """k[0] = (q', v') after an accepted step: the position rates at the projected state,
    the solution's accelerations."""
    nq = scratch[0]
    _position_rates(layout, x[:nq], x[nq:], k[0])
    k[0, nq:] = k[stages, nq:]


@nb.njit(cache=True, nogil=True)
def integrate_range(start, stop, *run):
    """The planar engine's Runge-Kutta loop
    (:func:`fuzzymbs.mbs.planar.integrator.run_range`) on (q, v) with the Euler parameters'
    kinematics, for sample rows ``start:stop`` (GIL released); ``run`` = (times, initial,
    layout, data, user_force, control, states, report, steps), as the planar engine's
    :func:`fuzzymbs.mbs.planar.integrator.integrate_range` takes it."""
    run_range(_arrays, _rates, _project, _first_stage, start, stop, run)


@nb.njit(cache=True, nogil=True)
def solve_range(start, stop, times, states, layout, data, user_force, out):
    """(r'', w', q'') and the multipliers at every stored state of rows ``start:stop`` into
    ``out`` (B, T, n + c); NaN after a failure."""
    nq = layout[4][0]
    n = layout[4][1]
    c = layout[4][2]
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)
    for s, i in live_states(states[start:stop], out[start:stop]):
        x = states[start + s, i]
        if accelerations(
            times[i], x[:nq], x[nq:], layout, data[start + s], user_force, system, solution
        ):
            out[start + s, i, :] = solution
        else:
            out[start + s, i, :] = np.nan
