"""Time integration of planar mechanisms: an explicit Runge-Kutta pair, one sample per call.

Each sample has its own steps (its trajectory is the same in any batch) and
hits every output time exactly; the error control covers every coordinate and
rate, the constrained ones included; after every accepted step the joints are
projected (:func:`fuzzymbs.mbs.planar.kernels.project`), and the next step's
first stage reuses the accelerations evaluated at the unprojected solution
(first same as last). Ranges of samples run
over the shared thread pool with the GIL released. The loop (:func:`run_sample`) is the
spatial engine's too: each engine passes it its rates, projection and next first stage.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from scipy.integrate import DOP853 as _SCIPY_DOP853

from fuzzymbs.mbs.planar.kernels import (
    FINISHED,
    NOT_FINITE,
    PROJECTION_FAILED,
    REPLAY_ENDED,
    STEP_TOO_SMALL,
    TOO_MANY_STEPS,
    accelerations_in,
    failed_before,
    project,
    workspace,
)

#: the explicit Runge-Kutta pairs, by name (``simulate(method=...)``)
DOPRI5 = 0
DOP853 = 1
METHODS = {"dopri5": DOPRI5, "dop853": DOP853}

# Dormand-Prince 5(4) (Hairer, Norsett & Wanner, Solving ODEs I, table II.5.2): six
# stages, the seventh evaluated at the 5th-order solution (FSAL) for the error estimate
_C5 = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
_A5 = np.array(
    [
        [0, 0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
    ]
)
_B5 = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
_E5 = np.append(_B5, 0.0) - np.array(
    [5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40]
)
# Dormand & Prince's 8(5,3) (Hairer, Norsett & Wanner I, sec. II.10; the code DOP853):
# twelve stages and the thirteenth at the solution, whose 5th- and 3rd-order error
# estimates are combined. Its stability region reaches |h lambda| = 5.9 along the
# imaginary axis, where Dormand-Prince 5(4)'s ends near 1: for undamped stiff modes
# that is five times the step for 12 evaluations instead of 6 (docs/mechanisms.md). The
# coefficients are the public class attributes of SciPy's DOP853, which transcribes them
# from Hairer's code.
_C8 = np.ascontiguousarray(_SCIPY_DOP853.C)
_A8 = np.ascontiguousarray(_SCIPY_DOP853.A)
_B8 = np.ascontiguousarray(_SCIPY_DOP853.B)
_E8 = np.ascontiguousarray(_SCIPY_DOP853.E5)
_E8_LOW = np.ascontiguousarray(_SCIPY_DOP853.E3)


@nb.njit(cache=True)
def tableau(method):
    """(c, a, b, e, e_low, exponent) of the pair ``method``: stage times, coefficients,
    weights, error weights (over the stages and the evaluation at the solution; e_low
    zero for a single estimate) and the step-size exponent 1 / (estimate order + 1)."""
    if method == DOP853:
        return _C8, _A8, _B8, _E8, _E8_LOW, 1.0 / 8.0
    return _C5, _A5, _B5, _E5, np.zeros(7), 1.0 / 5.0


@nb.njit(cache=True)
def stage_time(t, c, stage, step):
    """The time stage ``stage`` of a step from t is evaluated at."""
    return t + c[stage] * step


@nb.njit(cache=True)
def stage_state(x, k, a, stage, step, trial):
    """trial = x + step sum_j a[stage, j] k[j]: the state stage ``stage`` is evaluated at."""
    for i in range(x.size):
        acc = 0.0
        for j in range(stage):
            acc += a[stage, j] * k[j, i]
        trial[i] = x[i] + step * acc


@nb.njit(cache=True)
def solution_state(x, k, b, step, trial):
    """trial = x + step sum_j b[j] k[j]: the step's solution (the last row of ``k`` is then
    evaluated there)."""
    for i in range(x.size):
        acc = 0.0
        for j in range(b.size):
            acc += b[j] * k[j, i]
        trial[i] = x[i] + step * acc


@nb.njit(cache=True)
def stage_input(x, k, pair, stage, t, step, trial):
    """The state (into ``trial``) and the time (returned) stage ``stage`` of a step of the
    pair ``pair`` (:func:`tableau`) from (t, x) is evaluated at; the stage after the last
    is the step's solution, evaluated for the error estimate (FSAL)."""
    nodes, a, b = pair[0], pair[1], pair[2]
    if stage < b.size:
        stage_state(x, k, a, stage, step, trial)
        return stage_time(t, nodes, stage, step)
    solution_state(x, k, b, step, trial)
    return t + step


@nb.njit(cache=True)
def error_norm(x, trial, k, step, rtol, atol, e, e_low):
    """Error estimate of a step, each component scaled by atol + rtol max(|x|, |trial|).

    One estimate (``e_low`` zero): its root mean square (Hairer, Norsett & Wanner I,
    eq. II.4.11). Two (DOP853): ||e5||^2 / sqrt(||e5||^2 + 0.01 ||e3||^2), which
    behaves like an order-8 estimate where both are small (Hairer & Wanner's DOP853).
    """
    combined = False
    for j in range(e_low.size):
        if e_low[j] != 0.0:
            combined = True
    err = 0.0
    low = 0.0
    for i in range(x.size):
        high = 0.0
        third = 0.0
        for j in range(e.size):
            high += e[j] * k[j, i]
            third += e_low[j] * k[j, i]
        scale = atol + rtol * max(abs(x[i]), abs(trial[i]))
        if combined:
            err += (high / scale) ** 2
            low += (third / scale) ** 2
        else:
            err += (step * high / scale) ** 2
    if not combined:
        return math.sqrt(err / x.size)
    if err == 0.0 and low == 0.0:
        return 0.0
    return abs(step) * err / math.sqrt((err + 0.01 * low) * x.size)


@nb.njit(cache=True)
def step_factor(err, exponent):
    """The next step over this one: 0.9 err^(-exponent), kept within 0.2 to 5."""
    return min(5.0, max(0.2, 0.9 * err ** (-exponent))) if err > 0.0 else 5.0


@nb.njit(cache=True)
def step_outcome(err, exponent, step, last, h):
    """(accepted, next step) after a step of size ``step`` with error norm ``err``; ``last``
    marks a step cut short to reach an output time, whose success keeps ``h`` unless the
    error asks for less."""
    factor = step_factor(err, exponent)
    if err <= 1.0:
        return True, (step * factor if not last or factor < 1.0 else h)
    return False, step * min(1.0, factor)


@nb.njit(cache=True)
def budget_status(h, t, accepted, rejected, max_steps):
    """STEP_TOO_SMALL or TOO_MANY_STEPS if the run must stop, else FINISHED (go on)."""
    if h < 1e-14 * max(1.0, abs(t)):
        return STEP_TOO_SMALL
    if accepted + rejected > max_steps:
        return TOO_MANY_STEPS
    return FINISHED


@nb.njit(cache=True)
def record(report, row, outcome):
    """Write a sample's (status, accepted, rejected, largest residual) into ``report[row]``."""
    status, accepted, rejected, worst = outcome
    report[row, 0] = status
    report[row, 1] = accepted
    report[row, 2] = rejected
    report[row, 3] = worst


@nb.njit(cache=True)
def start_run(control, x0):
    """(pair, x, k, trial) of a run of the pair ``control[0]`` from ``x0``: its tableau
    (:func:`tableau`), the state (a copy of x0), the stages' rates (the last row: the
    evaluation at the solution) and the state a stage is evaluated at."""
    pair = tableau(control[0])
    k = np.empty((pair[2].size + 1, x0.size))
    return pair, x0.copy(), k, np.empty(x0.size)


@nb.njit(cache=True)
def next_step(h, t, target):
    """(last, step): the step of size h from t, cut short (``last``) to end at ``target``
    if h would reach it."""
    last = h >= target - t
    return last, (target - t if last else h)


@nb.njit(cache=True)
def conclude_step(x, trial, k, t, step, last, h, target, control, pair):
    """A step's outcome once its stages are evaluated (``trial`` its solution):
    (finite, accepted, t, h). Not finite: its error estimate is not. Accepted: ``x``
    takes the solution and t its time (``target`` after a last step). h: the next step
    to try (:func:`step_outcome`)."""
    _, _, _, e, e_low, exponent = pair
    err = error_norm(x, trial, k, step, control[1], control[2], e, e_low)
    if not math.isfinite(err):
        return False, False, t, h
    success, h = step_outcome(err, exponent, step, last, h)
    if success:
        t = target if last else t + step
        x[:] = trial
    return True, success, t, h


@nb.njit(cache=True)
def replayed_step(sequence, accepted, t, target):
    """(end, last) of the replayed step from t: the sequence's next end time, and whether
    it reaches the output time ``target`` (a logged step may end an ulp past it, as the
    step control's sum t + h can; the output then takes that state, as it did); end is
    NaN where the sequence has no next step after t (REPLAY_ENDED)."""
    if accepted >= sequence.size:
        return np.nan, False
    end = sequence[accepted]
    if not t < end:
        return np.nan, False
    return end, end >= target


@nb.njit(cache=True)
def conclude_replayed(x, trial, k, step, control, pair):
    """A replayed step's outcome once its stages are evaluated: always taken (``x`` takes
    the solution ``trial``) unless its error estimate, computed as the step control
    computes it, is not finite (returns False)."""
    _, _, _, e, e_low, _ = pair
    if not math.isfinite(error_norm(x, trial, k, step, control[1], control[2], e, e_low)):
        return False
    x[:] = trial
    return True


@nb.njit(cache=True)
def evaluation_arrays(layout):
    """(n, c, system, solution, work): the coordinates and joint equations of ``layout``
    and the arrays :func:`accelerations_in` takes, allocated once per run."""
    n = layout[4][0]
    c = layout[4][1]
    return n, c, np.empty((n + c, n + c)), np.empty(n + c), workspace(layout)


@nb.njit(inline="always")
def run_sample(
    rates, project, first_stage, times, x0, layout, data, user_force, scratch, control, states,
    steps,
):  # fmt: skip
    """Integrate one sample from ``times[0]``, storing its state at every time: the explicit
    Runge-Kutta loop of both engines, their own parts supplied as jitted functions.

    Parameters
    ----------
    rates : ``rates(t, x, layout, data, user_force, scratch, out) -> ok``
        The state's rate into ``out``; False where the accelerations are not finite.
    project : ``project(t, x, layout, data, scratch, tolerance) -> residual``
        Moves ``x`` onto the joints (in place) and returns the largest residual left.
    first_stage : ``first_stage(x, k, stages, layout, scratch)``
        The next step's first stage ``k[0]`` after an accepted, projected step: the
        positions' rates at the projected state, the accelerations of the solution's
        evaluation ``k[stages]`` (the projection moves the state by its tolerance, which
        changes them at round-off: docs/mechanisms.md).
    times, x0, layout, data, user_force
        Output times, initial state, the mechanism's layout and parameter row, and its user
        force function.
    scratch
        The engine's work arrays, as ``rates``, ``project`` and ``first_stage`` take them.
    control
        (method, rtol, atol, first step, step budget, projection tolerance): the pair's code
        (:data:`METHODS`), the step control's tolerances, the first step [s], the steps
        (accepted and rejected) allowed, and the largest joint residual the projection
        after each step may leave.
    states
        (T, size) output rows; those after a failure stay as they are (NaN).
    steps
        (sequence, log): the end times of the steps to take, replayed without the step
        control (empty: the step control chooses them; a replay that runs out of steps
        before the last output time ends with REPLAY_ENDED), and the array that receives
        each accepted step's end time (as many as it holds).

    Returns
    -------
    (status, accepted steps, rejected steps, largest joint residual)

    Notes
    -----
    Inlined (``inline="always"``) into each engine's cached kernel, so that the engine's
    functions are called, never passed on as values: Numba stores a dispatcher passed on
    as a value by its address, which makes the calling kernel impossible to cache.
    """
    _, _, _, first_step, max_steps, tolerance = control
    sequence, log = steps
    replay = sequence.size > 0
    pair, x, k, trial = start_run(control, x0)
    stages = k.shape[0] - 1
    t = times[0]
    worst = project(t, x, layout, data, scratch, tolerance)
    if not worst <= tolerance:
        return PROJECTION_FAILED, 0, 0, worst
    states[0, :] = x
    if not rates(t, x, layout, data, user_force, scratch, k[0]):
        return NOT_FINITE, 0, 0, worst
    h = first_step
    accepted = np.int64(0)  # not a literal 0: replayed_step would compile once more
    rejected = 0
    for out in range(1, times.size):
        target = times[out]
        while t < target:
            end = t
            if replay:
                end, last = replayed_step(sequence, accepted, t, target)
                if not end == end:  # NaN: no step of the sequence fits
                    return REPLAY_ENDED, accepted, rejected, worst
                step = end - t
            else:
                last, step = next_step(h, t, target)
            for stage in range(1, stages + 1):
                time = stage_input(x, k, pair, stage, t, step, trial)
                if not rates(time, trial, layout, data, user_force, scratch, k[stage]):
                    return NOT_FINITE, accepted, rejected, worst
            if replay:
                finite = conclude_replayed(x, trial, k, step, control, pair)
                success = True
                t = end
            else:
                finite, success, t, h = conclude_step(
                    x, trial, k, t, step, last, h, target, control, pair
                )
            if not finite:
                return NOT_FINITE, accepted, rejected, worst
            if success:
                accepted += 1
                if accepted <= log.size:
                    log[accepted - 1] = t
                residual = project(t, x, layout, data, scratch, tolerance)
                if not residual <= tolerance:
                    return PROJECTION_FAILED, accepted, rejected, residual
                worst = max(worst, residual)
                first_stage(x, k, stages, layout, scratch)
            else:
                rejected += 1
            status = budget_status(h, t, accepted, rejected, max_steps)
            if status != FINISHED:
                return status, accepted, rejected, worst
        states[out, :] = x
    return FINISHED, accepted, rejected, worst


@nb.njit(inline="always")
def run_range(arrays, rates, project, first_stage, start, stop, run):
    """:func:`run_sample` for sample rows ``start:stop``, an engine's ``arrays(layout)``
    allocating each sample's ``scratch``; ``run`` = (times, initial, layout, data,
    user_force, control, states, report, steps), ``report`` (B, 4) receiving each sample's
    outcome (:func:`record`), ``steps`` = (sequences (B, K), lengths (B,), logs (B, C)):
    sample s replays ``sequences[s, :lengths[s]]`` (none where 0) and logs into ``logs[s]``
    (:func:`run_sample`'s ``steps``). Inlined for the reason :func:`run_sample` is."""
    times, initial, layout, data, user_force, control, states, report, steps = run
    sequences, lengths, logs = steps
    for s in range(start, stop):
        scratch = arrays(layout)
        outcome = run_sample(
            rates,
            project,
            first_stage,
            times,
            initial[s],
            layout,
            data[s],
            user_force,
            scratch,
            control,
            states[s],
            (sequences[s, : lengths[s]], logs[s]),
        )
        record(report, s, outcome)


@nb.njit(cache=True)
def _rates(t, x, layout, data, user_force, scratch, out):
    """(z', v') = (v, z'') at (t, x) into ``out``; False if not finite."""
    n, _, system, solution, work = scratch
    ok = accelerations_in(work, t, x[:n], x[n:], layout, data, user_force, system, solution)
    out[:n] = x[n:]
    out[n:] = solution[:n]
    return ok


@nb.njit(cache=True)
def _project(t, x, layout, data, scratch, tolerance):
    """The joints' projection of x = (z, v) (0.0 without joints: nothing to move)."""
    n = scratch[0]
    return project(t, x[:n], x[n:], layout, data, tolerance)


@nb.njit(cache=True)
def _first_stage(x, k, stages, layout, scratch):
    """k[0] = (v, z'') after an accepted step: the projected rates, the solution's
    accelerations (without joints x is the solution, and this is k[stages])."""
    n = scratch[0]
    k[0, :n] = x[n:]
    k[0, n:] = k[stages, n:]


@nb.njit(cache=True, nogil=True)
def integrate_range(start, stop, *run):
    """The explicit Runge-Kutta pair for sample rows ``start:stop`` (:func:`run_range` with
    the planar engine's rates, projection and first stage), the GIL released, so
    :func:`fuzzymbs.mbs.kernels.threads.for_each_range` runs ranges side by side.

    ``run`` = (times, initial, layout, data, user_force, control, states, report, steps):
    ``control`` as :func:`run_sample` takes it; ``states`` (B, T, 2n) NaN, filled up to
    a sample's failure; ``report`` (B, 4) receives status, accepted and rejected steps
    and the largest joint residual of each sample; ``steps`` the replayed and logged
    step sequences (:func:`run_range`).
    """
    run_range(evaluation_arrays, _rates, _project, _first_stage, start, stop, run)


@nb.njit(cache=True, nogil=True)
def solve_range(start, stop, times, states, layout, data, user_force, out):
    """z'' and lambda at every stored state of rows ``start:stop`` into ``out`` (B, T, n + c)."""
    n, _, system, solution, work = evaluation_arrays(layout)
    for s in range(start, stop):
        for i in range(states.shape[1]):
            if failed_before(states, s, i, out):
                continue
            x = states[s, i]
            if accelerations_in(
                work, times[i], x[:n], x[n:], layout, data[s], user_force, system, solution
            ):
                out[s, i, :] = solution
            else:
                out[s, i, :] = np.nan
