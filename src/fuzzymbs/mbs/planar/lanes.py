"""Time integration of planar mechanisms LANES samples at a time, one per SIMD lane.

The samples of a fuzzy study share a mechanism's structure, so LANES of them run
through the same arithmetic: each lane of a block holds a sample, the physics
compiles for lane arrays (:mod:`fuzzymbs.mbs.planar.lanewise`) and the
constrained system is solved LANES at a time
(:func:`fuzzymbs.mbs.planar.elimination.solve_lanes`); the Runge-Kutta stages
combine vectors of LANES.

Every lane keeps its own clock, as :func:`fuzzymbs.mbs.planar.integrator.run_sample`
does for a sample alone: its own step size, error norm, acceptance, output
times, projection and failure status. A lane that has finished, failed or pads
a short block is masked: its vector arithmetic goes on and is discarded, and no
lane's value enters another's. Each lane does the one-sample kernel's arithmetic
in the same order, so a sample's trajectory is bit for bit the one-sample
kernel's, whatever block and lane it runs in and whatever its lane mates do
(tests/mbs/planar/test_lanes.py).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.planar.elimination import remove_velocity_excess, solve_lanes
from fuzzymbs.mbs.planar.integrator import (
    budget_status,
    error_norm,
    integrate_range,
    record,
    replayed_step,
    solve_range,
    step_outcome,
    tableau,
)
from fuzzymbs.mbs.planar.kernels import (
    FINISHED,
    NOT_FINITE,
    PROJECTION_FAILED,
    REPLAY_ENDED,
    RUNNING,
    body_terms,
    failed_before,
    force_terms,
    joint_terms,
    project,
)

L = V.LANES


@nb.njit(cache=True)
def lane_scratch(layout):
    """Scratch arrays of :func:`derivative_lanes` and :func:`project_lanes`: the
    lanes' mass matrices, Jacobians, four joint rows and forces, the saddle-point system
    and its right-hand side, and one lane's rows (3, max(n, c)) and Jacobian (c, n)
    where a lane is handled alone."""
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
        np.empty((3, max(n, c))),
        np.empty((c, n)),
    )


@nb.njit(cache=True)
def derivative_lanes(
    t, x, n, c, layout, data, lanes, samples, user_force, scratch, active, ok, out
):
    """out = (v, z'') of every lane at (t[lane], x); ``ok[lane]`` False where the
    equations are singular or their solution not finite. ``lanes`` holds the lanes'
    data rows (D, LANES)."""
    mass, jac, rows, forces, system, rhs, lone, _ = scratch
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
            row = data[samples[lane]]
            force_terms(t[lane], layout, row, lone[0, :n], lone[1, :n], user_force, lone[2, :n])
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
def project_lanes(t, x, n, c, layout, data, lanes, samples, scratch, moved, tolerance, worst):
    """:func:`fuzzymbs.mbs.planar.kernels.project` of the lanes marked ``moved``, in place
    on ``x``; ``worst[lane]`` receives the largest joint residual left (inf if the
    projection failed).

    The joints' rows are evaluated once for all lanes. A lane whose position residual
    is within ``tolerance`` (after a step it is: the position Newton iteration does not
    run) takes its velocity projection from these rows, which are those the scalar
    projection evaluates again at the same state; any other lane is projected alone.
    """
    jac, rows, lone, lone_jac = scratch[1], scratch[2], scratch[6], scratch[7]
    state = x.reshape((2 * n, L))
    z = state[:n]
    v = state[n:]
    jac[:] = 0.0
    joint_terms(t, layout, lanes, z, v, jac, rows[0], rows[1], rows[2], rows[3])
    for lane in range(L):
        if not moved[lane]:
            continue
        largest = 0.0
        for r in range(c):
            largest = max(largest, abs(rows[0, r, lane]))
        if largest <= tolerance:
            for r in range(c):
                for j in range(n):
                    lone_jac[r, j] = jac[r, j, lane]
                lone[0, r] = rows[2, r, lane]
            for i in range(n):
                lone[1, i] = v[i, lane]
            if remove_velocity_excess(lone_jac, lone[0, :c], lone[1], lone[2, :c]):
                for i in range(n):
                    v[i, lane] = lone[1, i]
                worst[lane] = largest
            else:
                worst[lane] = np.inf
            continue
        for i in range(n):
            lone[0, i] = z[i, lane]
            lone[1, i] = v[i, lane]
        row = data[samples[lane]]
        worst[lane] = project(t[lane], lone[0, :n], lone[1, :n], layout, row, tolerance)
        for i in range(n):
            z[i, lane] = lone[0, i]
            v[i, lane] = lone[1, i]


@nb.njit(cache=True)
def stage_lanes(x, k, weights, stage, step, trial):
    """trial = x + step sum_j weights[j] k[j] over j < stage, each lane with its own
    ``step`` (:func:`fuzzymbs.mbs.planar.integrator.stage_state`'s arithmetic)."""
    steps = V.load(step, 0)
    for i in range(x.size // L):
        acc = V.splat(0.0)
        for j in range(stage):
            acc = acc + weights[j] * V.load(k[j], L * i)
        V.store(trial, L * i, V.load(x, L * i) + steps * acc)


@nb.njit(cache=True)
def lane_error(x, trial, k, lane, step, rtol, atol, e, e_low, lone):
    """:func:`fuzzymbs.mbs.planar.integrator.error_norm` of lane ``lane`` (its values
    gathered into the scratch ``lone`` (stages + 3, 2n))."""
    size = lone.shape[1]
    for i in range(size):
        lone[0, i] = x[L * i + lane]
        lone[1, i] = trial[L * i + lane]
        for j in range(k.shape[0]):
            lone[2 + j, i] = k[j, L * i + lane]
    return error_norm(lone[0], lone[1], lone[2:], step, rtol, atol, e, e_low)


@nb.njit(cache=True)
def integrate_block(
    times, initial, layout, data, user_force, control, states, report, steps, block
):  # fmt: skip
    """Integrate the samples ``block = (first, count)`` (count <= LANES), one per lane, as
    :func:`fuzzymbs.mbs.planar.integrator.run_sample` integrates one (``control``
    as there); each sample's report goes to its row of ``report`` (B, 4). ``steps`` =
    (sequences, lengths, logs): the step sequences a lane replays and the logs of its
    accepted steps' end times (:func:`fuzzymbs.mbs.planar.integrator.run_range`).

    A block of fewer than LANES samples repeats its last sample in the lanes left
    (masked from the start: their arithmetic is never read).
    """
    first, count = block
    n = layout[4][0]
    c = layout[4][1]
    size = 2 * n
    scratch = lane_scratch(layout)
    method, rtol, atol, first_step, max_steps, tolerance = control
    sequences, lengths, logs = steps
    nodes, a, b, e, e_low, exponent = tableau(method)
    stages = b.size
    samples = np.empty(L, dtype=np.int64)
    lanes = np.empty((data.shape[1], L))
    x = np.empty(size * L)
    replay = np.zeros(L, dtype=np.bool_)
    for lane in range(L):
        samples[lane] = first + min(lane, count - 1)
        lanes[:, lane] = data[samples[lane]]
        replay[lane] = lengths[samples[lane]] > 0
        for i in range(size):
            x[L * i + lane] = initial[samples[lane], i]
    k = np.empty((stages + 1, size * L))
    trial = np.empty(size * L)
    lone = np.empty((stages + 3, size))
    status = np.full(L, RUNNING, dtype=np.int64)
    accepted = np.zeros(L, dtype=np.int64)
    rejected = np.zeros(L, dtype=np.int64)
    worst = np.zeros(L)
    residual = np.zeros(L)
    t = np.full(L, times[0])
    h = np.full(L, first_step)
    step = np.zeros(L)
    ends = np.zeros(L)  # a replaying lane's step end time
    stage_t = np.empty(L)
    last = np.zeros(L, dtype=np.bool_)
    moved = np.ones(L, dtype=np.bool_)  # the lanes whose state a step (or the start) moved
    active = np.zeros(L, dtype=np.bool_)
    ok = np.ones(L, dtype=np.bool_)
    target = np.ones(L, dtype=np.int64)  # each lane's next output time
    project_lanes(t, x, n, c, layout, data, lanes, samples, scratch, moved, tolerance, worst)
    for lane in range(count):
        if worst[lane] <= tolerance:
            active[lane] = True
            for i in range(size):
                states[samples[lane], 0, i] = x[L * i + lane]
        else:
            status[lane] = PROJECTION_FAILED
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
            moved[lane] = False
            if active[lane] and replay[lane]:
                s = samples[lane]
                sequence = sequences[s, : lengths[s]]
                ends[lane], last[lane] = replayed_step(
                    sequence, accepted[lane], t[lane], times[target[lane]]
                )
                if not ends[lane] == ends[lane]:  # NaN: no step of the sequence fits
                    status[lane] = REPLAY_ENDED
                    active[lane] = False
                    continue
                going = True
                step[lane] = ends[lane] - t[lane]
            elif active[lane]:
                going = True
                end = times[target[lane]] - t[lane]
                last[lane] = h[lane] >= end
                step[lane] = end if last[lane] else h[lane]
        if not going:
            break
        for stage in range(1, stages + 1):
            # the stages' states and times, the last one the step's solution (FSAL)
            stage_lanes(x, k, a[stage] if stage < stages else b, stage, step, trial)
            for lane in range(L):
                stage_t[lane] = t[lane] + (
                    nodes[stage] * step[lane] if stage < stages else step[lane]
                )
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
            err = lane_error(x, trial, k, lane, step[lane], rtol, atol, e, e_low, lone)
            if not math.isfinite(err):
                status[lane] = NOT_FINITE
                active[lane] = False
                continue
            if replay[lane]:  # taken unless not finite (integrator.conclude_replayed)
                success = True
                t[lane] = ends[lane]
            else:
                success, h[lane] = step_outcome(err, exponent, step[lane], last[lane], h[lane])
                if success:
                    t[lane] = times[target[lane]] if last[lane] else t[lane] + step[lane]
            if success:
                accepted[lane] += 1
                if accepted[lane] <= logs.shape[1]:
                    logs[samples[lane], accepted[lane] - 1] = t[lane]
                moved[lane] = True
                for i in range(size):
                    x[L * i + lane] = trial[L * i + lane]
            else:
                rejected[lane] += 1
        if c:
            project_lanes(
                t, x, n, c, layout, data, lanes, samples, scratch, moved, tolerance, residual
            )
        for lane in range(L):
            if not active[lane]:
                continue
            if moved[lane]:
                if c:
                    if not residual[lane] <= tolerance:
                        status[lane] = PROJECTION_FAILED
                        worst[lane] = residual[lane]
                        active[lane] = False
                        continue
                    worst[lane] = max(worst[lane], residual[lane])
                    # the next step's first stage: the projected rates and the accelerations
                    # of the solution's evaluation (integrator.run_sample)
                    for i in range(n):
                        k[0, L * i + lane] = x[L * (n + i) + lane]
                        k[0, L * (n + i) + lane] = k[stages, L * (n + i) + lane]
                else:
                    for i in range(size):
                        k[0, L * i + lane] = k[stages, L * i + lane]
            code = budget_status(h[lane], t[lane], accepted[lane], rejected[lane], max_steps)
            if code != FINISHED:
                status[lane] = code
                active[lane] = False
                continue
            # the output times the lane has reached (one, unless a step rounds past two)
            while target[lane] < times.size and not t[lane] < times[target[lane]]:
                for i in range(size):
                    states[samples[lane], target[lane], i] = x[L * i + lane]
                target[lane] += 1
            if target[lane] == times.size:
                status[lane] = FINISHED
                active[lane] = False
    for lane in range(count):
        record(report, first + lane, (status[lane], accepted[lane], rejected[lane], worst[lane]))


@nb.njit(cache=True, nogil=True)
def integrate_blocks(
    start, stop, times, initial, layout, data, user_force, control, states, report, steps
):
    """:func:`integrate_block` for the blocks ``start:stop`` of LANES consecutive samples
    (the GIL released, so :func:`fuzzymbs.mbs.kernels.threads.for_each_range` runs
    ranges side by side). ``report`` (B, 4) and ``steps`` as for
    :func:`fuzzymbs.mbs.planar.integrator.integrate_range`.

    A block of one sample runs the one-sample kernel: the same numbers, bit for bit,
    in three quarters of the time (a block of 4 lanes costs 1.3 times one sample
    alone: 52 against 39 ms CPU on the slider-crank).
    """
    samples = initial.shape[0]
    for index in range(start, stop):
        first = L * index
        count = min(L, samples - first)
        if count == 1:
            integrate_range(
                first, first + 1, times, initial, layout, data, user_force, control, states,
                report, steps,
            )  # fmt: skip
        else:
            block = (first, count)
            integrate_block(
                times, initial, layout, data, user_force, control, states, report, steps, block
            )


@nb.njit(cache=True, nogil=True)
def solve_blocks(start, stop, times, states, layout, data, user_force, out):
    """:func:`fuzzymbs.mbs.planar.integrator.solve_range` for the blocks ``start:stop`` of
    LANES samples: z'' and lambda at every stored state into ``out`` (B, T, n + c), bit for
    bit the one-sample solve (NaN where a sample had failed; a block of one sample runs
    it)."""
    n = layout[4][0]
    c = layout[4][1]
    scratch = lane_scratch(layout)
    rhs = scratch[5]
    samples = np.empty(L, dtype=np.int64)
    lanes = np.empty((data.shape[1], L))
    x = np.empty(2 * n * L)
    rates = np.empty(2 * n * L)  # (v, z''), unused: the solution is in rhs
    t = np.empty(L)
    active = np.ones(L, dtype=np.bool_)
    ok = np.ones(L, dtype=np.bool_)
    for index in range(start, stop):
        count = min(L, states.shape[0] - L * index)
        if count == 1:  # a lone sample: the one-sample solve (the same numbers)
            solve_range(L * index, L * index + 1, times, states, layout, data, user_force, out)
            continue
        for lane in range(L):
            samples[lane] = L * index + min(lane, count - 1)
            lanes[:, lane] = data[samples[lane]]
        for i in range(states.shape[1]):
            for lane in range(L):
                t[lane] = times[i]
                for j in range(2 * n):
                    x[L * j + lane] = states[samples[lane], i, j]
            derivative_lanes(
                t, x, n, c, layout, data, lanes, samples, user_force, scratch, active, ok, rates
            )
            for lane in range(count):
                s = samples[lane]
                if failed_before(states, s, i, out):
                    continue
                for j in range(n + c):
                    out[s, i, j] = rhs[L * j + lane] if ok[lane] else np.nan
