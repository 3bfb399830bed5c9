"""Time integration of spatial mechanisms: an explicit Runge-Kutta pair per sample (the
planar engine's tableaus, stages, error norm and step control) on the positions with the Euler
parameters' kinematics, joints projected after every accepted step; ranges of samples
run with the GIL released.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.planar.integrator import (
    budget_status,
    conclude_step,
    next_step,
    record,
    stage_input,
    start_run,
)
from fuzzymbs.mbs.planar.kernels import live_states
from fuzzymbs.mbs.spatial.kernels import (
    FINISHED,
    NOT_FINITE,
    PROJECTION_FAILED,
    accelerations,
    project,
)


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
def _derivative(t, x, layout, data, user_force, system, solution, out):
    sizes = layout[4]
    nq = sizes[0]
    n = sizes[1]
    q = x[:nq]
    v = x[nq:]
    ok = accelerations(t, q, v, layout, data, user_force, system, solution)
    _position_rates(layout, q, v, out)
    for i in range(n):
        out[nq + i] = solution[i]
    return ok


@nb.njit(cache=True)
def integrate_sample(times, x0, layout, data, user_force, control, states):
    """The Runge-Kutta pair ``control[0]`` for one sample, as the planar engine's
    (:func:`fuzzymbs.mbs.planar.integrator.integrate_sample`), on (q, v) with the
    Euler parameters' kinematics; (status, accepted, rejected, largest residual)."""
    sizes = layout[4]
    nq = sizes[0]
    n = sizes[1]
    c = sizes[2]
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)
    _, _, _, first_step, max_steps, tolerance = control
    pair, x, k, trial = start_run(control, x0)
    stages = k.shape[0] - 1
    t = times[0]
    worst = project(t, x[:nq], x[nq:], layout, data, tolerance)
    if not worst <= tolerance:
        return PROJECTION_FAILED, 0, 0, worst
    states[0, :] = x
    if not _derivative(t, x, layout, data, user_force, system, solution, k[0]):
        return NOT_FINITE, 0, 0, worst
    h = first_step
    accepted = 0
    rejected = 0
    for out in range(1, times.size):
        target = times[out]
        while t < target:
            last, step = next_step(h, t, target)
            for stage in range(1, stages + 1):
                time = stage_input(x, k, pair, stage, t, step, trial)
                if not _derivative(
                    time, trial, layout, data, user_force, system, solution, k[stage]
                ):
                    return NOT_FINITE, accepted, rejected, worst
            finite, success, t, h = conclude_step(
                x, trial, k, t, step, last, h, target, control, pair
            )
            if not finite:
                return NOT_FINITE, accepted, rejected, worst
            if success:
                accepted += 1
                residual = project(t, x[:nq], x[nq:], layout, data, tolerance)
                if not residual <= tolerance:
                    return PROJECTION_FAILED, accepted, rejected, residual
                worst = max(worst, residual)
                # the next step's first stage: the position rates at the projected state, the
                # accelerations of the solution's evaluation (the projection moves the state
                # by its tolerance, which changes them at round-off: docs/mechanisms.md)
                _position_rates(layout, x[:nq], x[nq:], k[0])
                k[0, nq:] = k[stages, nq:]
            else:
                rejected += 1
            status = budget_status(h, t, accepted, rejected, max_steps)
            if status != FINISHED:
                return status, accepted, rejected, worst
        states[out, :] = x
    return FINISHED, accepted, rejected, worst


@nb.njit(cache=True, nogil=True)
def integrate_range(
    start,
    stop,
    times,
    initial,
    layout,
    data,
    user_force,
    control,
    states,
    report,
):
    """:func:`integrate_sample` for sample rows ``start:stop`` (GIL released)."""
    for s in range(start, stop):
        record(
            report,
            s,
            integrate_sample(times, initial[s], layout, data[s], user_force, control, states[s]),
        )


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
