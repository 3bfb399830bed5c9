"""Time integration of planar mechanisms four samples at a time, one per SIMD lane.

(prototype) per-lane scalar assembly, vector solve and stage arithmetic.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.planar.integrator import (
    budget_status,
    error_norm,
    record,
    step_outcome,
    tableau,
)
from fuzzymbs.mbs.planar.kernels import (
    FINISHED,
    NOT_FINITE,
    PROJECTION_FAILED,
    RUNNING,
    body_terms,
    force_terms,
    joint_terms,
    project,
)

L = V.LANES


@nb.njit(cache=True)
def solve_lanes(a, b, size, ok):
    """Solve a x = b in each lane by :func:`fuzzymbs.mbs.planar.elimination.solve_in_place`'s
    arithmetic; ``a`` (size size L,) and ``b`` (size L,) lane-minor, x into ``b``.

    ``ok[lane]`` is set False where that lane's pivot is zero or not finite.
    """
    columns = np.empty(size, dtype=np.int64)
    zero = V.splat(0.0)
    for k in range(size):
        # the pivot search of every lane at once: the first strictly largest magnitude
        # (a NaN never wins, as in the scalar search)
        largest = V.vabs(V.load(a, L * (size * k + k)))
        best = V.splat(k)
        for i in range(k + 1, size):
            value = V.vabs(V.load(a, L * (size * i + k)))
            best = V.where_lt(largest, value, V.splat(i), best)
            largest = V.where_lt(largest, value, value, largest)
        uniform = True
        for lane in range(L):
            top = V.get(largest, lane)
            if not (top > 0.0 and math.isfinite(top)):
                ok[lane] = False
            uniform = uniform and V.get(best, lane) == V.get(best, 0)
        if uniform:  # the usual case: every lane swaps the same rows, a vector at a time
            other = int(V.get(best, 0))
            if other != k:
                for j in range(size):
                    top = V.load(a, L * (size * k + j))
                    V.store(a, L * (size * k + j), V.load(a, L * (size * other + j)))
                    V.store(a, L * (size * other + j), top)
                top = V.load(b, L * k)
                V.store(b, L * k, V.load(b, L * other))
                V.store(b, L * other, top)
        else:
            for lane in range(L):
                other = int(V.get(best, lane))
                if other != k:
                    for j in range(size):
                        top = L * (size * k + j) + lane
                        below = L * (size * other + j) + lane
                        a[top], a[below] = a[below], a[top]
                    top = L * k + lane
                    below = L * other + lane
                    b[top], b[below] = b[below], b[top]
        count = 0
        for j in range(k + 1, size):
            at = L * (size * k + j)
            if a[at] != 0.0 or a[at + 1] != 0.0 or a[at + 2] != 0.0 or a[at + 3] != 0.0:
                columns[count] = j
                count += 1
        inverse = 1.0 / V.load(a, L * (size * k + k))
        bk = V.load(b, L * k)
        for i in range(k + 1, size):
            factor = V.load(a, L * (size * i + k)) * inverse
            f = L * (size * i + k)
            if a[f] == 0.0 and a[f + 1] == 0.0 and a[f + 2] == 0.0 and a[f + 3] == 0.0:
                continue
            for index in range(count):
                j = columns[index]
                pivot_row = V.load(a, L * (size * k + j))
                at = L * (size * i + j)
                old = V.load(a, at)
                new = V.where_eq(pivot_row, zero, old, old - factor * pivot_row)
                V.store(a, at, V.where_eq(factor, zero, old, new))
            old = V.load(b, L * i)
            V.store(b, L * i, V.where_eq(factor, zero, old, old - factor * bk))
    for i in range(size - 1, -1, -1):
        acc = V.load(b, L * i)
        for j in range(i + 1, size):
            acc = acc - V.load(a, L * (size * i + j)) * V.load(b, L * j)
        V.store(b, L * i, acc / V.load(a, L * (size * i + i)))
    for lane in range(L):
        for i in range(size):
            if not math.isfinite(b[L * i + lane]):
                ok[lane] = False


@nb.njit(cache=True)
def lane_scratch(layout):
    """Scratch arrays of :func:`derivative_lanes`: the four lanes' mass matrices, Jacobians,
    four joint rows and forces, the saddle-point system and its right-hand side, and one
    sample's coordinates, rates and forces (force elements, lane by lane)."""
    n = layout[4][0]
    c = layout[4][1]
    big = n + c
    return (
        np.empty((n, n, L)),
        np.empty((c, n, L)),
        np.empty((4, c, L)),
        np.empty((n, L)),
        np.empty(big * big * L),
        np.empty(big * L),
        np.empty((3, n)),
    )


@nb.njit(cache=True)
def derivative_lanes(
    t, x, n, c, layout, data, lanes, samples, user_force, scratch, active, ok, out
):
    """out = (v, z'') of every lane at (t[lane], x); ``ok[lane]`` False where the
    equations are singular or their solution not finite. ``lanes`` holds the lanes'
    data rows (D, 4)."""
    mass, jac, rows, forces, system, rhs, lone = scratch
    size = n + c
    state = x.reshape((2 * n, L))
    z = state[:n]
    v = state[n:]
    mass[:] = 0.0
    jac[:] = 0.0
    forces[:] = 0.0
    body_terms(layout[0], lanes, z, v, mass, forces)
    if layout[3].shape[0]:  # force elements branch on their values: lane by lane
        for lane in range(L):
            if not active[lane]:
                continue
            for i in range(n):
                lone[0, i] = z[i, lane]
                lone[1, i] = v[i, lane]
                lone[2, i] = forces[i, lane]
            force_terms(t[lane], layout, data[samples[lane]], lone[0], lone[1], user_force, lone[2])
            for i in range(n):
                forces[i, lane] = lone[2, i]
    if c:
        joint_terms(t, layout, lanes, z, v, jac, rows[0], rows[1], rows[2], rows[3])
    for i in range(n):
        for j in range(n):
            V.store(system, L * (size * i + j), V.load(mass, L * (n * i + j)))
        V.store(rhs, L * i, V.load(forces, L * i))
    zero = V.splat(0.0)
    for r in range(c):
        for j in range(n):
            value = V.load(jac, L * (n * r + j))
            V.store(system, L * (size * (n + r) + j), value)
            V.store(system, L * (size * j + n + r), value)
        for j in range(c):
            V.store(system, L * (size * (n + r) + n + j), zero)
        V.store(rhs, L * (n + r), -V.load(rows[1], L * r) + V.load(rows[3], L * r))
    for lane in range(L):
        ok[lane] = True
    solve_lanes(system, rhs, size, ok)
    for i in range(n):
        V.store(out, L * i, V.load(x, L * (n + i)))
        V.store(out, L * (n + i), V.load(rhs, L * i))


@nb.njit(cache=True)
def _lane_copy(src, lane, size, dst):
    for i in range(size):
        dst[i] = src[L * i + lane]


@nb.njit(cache=True)
def _lane_store(src, lane, size, dst):
    for i in range(size):
        dst[L * i + lane] = src[i]


@nb.njit(cache=True)
def integrate_block(
    times, initial, layout, data, user_force, control, states, report, first, count
):
    """Integrate samples ``first .. first + count - 1`` (count <= 4), one per lane."""
    sizes = layout[4]
    n = sizes[0]
    c = sizes[1]
    size = 2 * n
    scratch = lane_scratch(layout)
    method, rtol, atol, first_step, max_steps, tolerance = control
    pair = tableau(method)
    nodes, a, b, e, e_low, exponent = pair
    stages = b.size
    samples = np.empty(L, dtype=np.int64)
    lanes = np.empty((data.shape[1], L))
    for lane in range(L):
        samples[lane] = first + min(lane, count - 1)
        lanes[:, lane] = data[samples[lane]]
    x = np.empty(size * L)
    k = np.empty((stages + 1, size * L))
    trial = np.empty(size * L)
    lone = np.empty(size)
    lone_k = np.empty((stages + 1, size))
    status = np.full(L, RUNNING, dtype=np.int64)
    accepted = np.zeros(L, dtype=np.int64)
    rejected = np.zeros(L, dtype=np.int64)
    worst = np.zeros(L)
    t = np.full(L, times[0])
    h = np.full(L, first_step)
    step = np.zeros(L)
    last = np.zeros(L, dtype=np.bool_)
    target = np.ones(L, dtype=np.int64)  # each lane's next output
    active = np.ones(L, dtype=np.bool_)
    ok = np.ones(L, dtype=np.bool_)
    stage_t = np.empty(L)
    for lane in range(L):
        s = samples[lane]
        lone[:] = initial[s]
        worst[lane] = project(t[lane], lone[:n], lone[n:], layout, data[s], tolerance)
        if not worst[lane] <= tolerance:
            status[lane] = PROJECTION_FAILED
        _lane_store(lone, lane, size, x)
        if lane < count and status[lane] == RUNNING:
            states[s, 0, :] = lone
        active[lane] = status[lane] == RUNNING and lane < count  # a padded lane idles
    derivative_lanes(
        t, x, n, c, layout, data, lanes, samples, user_force, scratch, active, ok, k[0]
    )
    for lane in range(L):
        if active[lane] and not ok[lane]:
            status[lane] = NOT_FINITE
            active[lane] = False
    while True:
        going = False
        for lane in range(L):
            if active[lane]:
                going = True
                end = times[target[lane]] - t[lane]
                last[lane] = h[lane] >= end
                step[lane] = end if last[lane] else h[lane]
        if not going:
            break
        steps = V.load(step, 0)
        clock = V.load(t, 0)
        for stage in range(1, stages + 1):
            weights = a[stage] if stage < stages else b
            for i in range(size):
                acc = V.splat(0.0)
                for j in range(stage):
                    acc = acc + weights[j] * V.load(k[j], L * i)
                V.store(trial, L * i, V.load(x, L * i) + steps * acc)
            if stage < stages:
                V.store(stage_t, 0, clock + nodes[stage] * steps)
            else:
                V.store(stage_t, 0, clock + steps)
            derivative_lanes(
                stage_t,
                trial,
                n,
                c,
                layout,
                data,
                lanes,
                samples,
                user_force,
                scratch,
                active,
                ok,
                k[stage],
            )
            for lane in range(L):
                if active[lane] and not ok[lane]:
                    status[lane] = NOT_FINITE
                    active[lane] = False
        for lane in range(L):
            if not active[lane]:
                continue
            s = samples[lane]
            _lane_copy(x, lane, size, lone)
            for j in range(stages + 1):
                _lane_copy(k[j], lane, size, lone_k[j])
            trial_lane = np.empty(size)
            _lane_copy(trial, lane, size, trial_lane)
            err = error_norm(lone, trial_lane, lone_k, step[lane], rtol, atol, e, e_low)
            if not math.isfinite(err):
                status[lane] = NOT_FINITE
                active[lane] = False
                continue
            success, h[lane] = step_outcome(err, exponent, step[lane], last[lane], h[lane])
            if success:
                t[lane] = times[target[lane]] if last[lane] else t[lane] + step[lane]
                accepted[lane] += 1
                if c:
                    residual = project(
                        t[lane], trial_lane[:n], trial_lane[n:], layout, data[s], tolerance
                    )
                    if not residual <= tolerance:
                        status[lane] = PROJECTION_FAILED
                        worst[lane] = residual
                        active[lane] = False
                        continue
                    worst[lane] = max(worst[lane], residual)
                    for i in range(n):
                        k[0, L * i + lane] = trial_lane[n + i]
                        k[0, L * (n + i) + lane] = k[stages, L * (n + i) + lane]
                else:
                    for i in range(size):
                        k[0, L * i + lane] = k[stages, L * i + lane]
                _lane_store(trial_lane, lane, size, x)
            else:
                rejected[lane] += 1
            code = budget_status(h[lane], t[lane], accepted[lane], rejected[lane], max_steps)
            if code != FINISHED:
                status[lane] = code
                active[lane] = False
                continue
            while target[lane] < times.size and not t[lane] < times[target[lane]]:
                if lane < count:
                    _lane_copy(x, lane, size, lone)
                    states[s, target[lane], :] = lone
                target[lane] += 1
            if target[lane] == times.size:
                status[lane] = FINISHED
                active[lane] = False
    for lane in range(count):
        record(report, first + lane, (status[lane], accepted[lane], rejected[lane], worst[lane]))


@nb.njit(cache=True, nogil=True)
def integrate_blocks(
    start, stop, times, initial, layout, data, user_force, control, states, report
):
    """:func:`integrate_block` for blocks ``start:stop`` of four samples (GIL released)."""
    samples = initial.shape[0]
    for block in range(start, stop):
        first = L * block
        integrate_block(
            times,
            initial,
            layout,
            data,
            user_force,
            control,
            states,
            report,
            first,
            min(L, samples - first),
        )
