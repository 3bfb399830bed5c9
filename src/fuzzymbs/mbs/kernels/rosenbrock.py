"""A linearly implicit integrator with error control for a block of LANES samples: ROS34PW2,
or RODAS4 (the method is an argument of the kernel, whose stage loop runs over the
tableau's stages; the methods' tableaux are in
:mod:`fuzzymbs.mbs.kernels.rosenbrock_methods`).

ROS34PW2 (Rang & Angermann, BIT 45 (2005) 761) is a Rosenbrock-W method: 4 stages,
order 3 with an embedded order-2 solution, stiffly accurate and L-stable, and it
keeps its order with an approximate Jacobian (W-method). With the Jacobian ``J``
and ``Gamma = (gamma_ij)`` (diagonal gamma) a step is

    (I - gamma h J) k_i = h f(t + alpha_i h, y + sum_j a_ij k_j)
                          + gamma_i h^2 f_t + h J sum_{j<i} gamma_ij k_j,
    y_new = y + sum_i b_i k_i,   y_hat = y + sum_i bhat_i k_i.

It runs in the transformed variables ``u = Gamma k`` (no products with J per
stage): ``(I / (gamma h) - J) u_i = f(Y_i) + sum_{j<i} (c_ij / h) u_j + gamma_i h f_t``
with ``Y_i = y + sum_j at_ij u_j``, ``at = A Gamma^-1``, ``c = -Gamma^-1`` below the
diagonal, weights ``m = b Gamma^-1`` and ``mhat = bhat Gamma^-1`` (computed here from
the paper's tableau). For the state ``[q, v]`` with ``J = [[0, I], [A_q, B_v]]`` the
stage system reduces to the velocities: ``(I / (gamma h) - B_v - gamma h A_q) u_v =
r_v + gamma h A_q r_q``, ``u_q = gamma h (r_q + u_v)``: one n x n LU per lane and step
(docs/theory.md). ``f_t`` is a forward difference in time (the prescribed rotations
and force profiles).

Each lane is a sample with its own clock: its own step, error
norm ``RMS(e_i / (atol + rtol max(|y_i|, |y_new,i|)))``, acceptance, Jacobian
age and records, so that a sample's outputs are bit for bit the same whatever
samples share its block (a shared step would make every sample's error depend
on its neighbours). The lanes still share every vector instruction. The next
step follows Gustafsson's PI controller (Hairer & Wanner, Solving ODEs II,
Sec. IV.8), ``h_new = h min(5, max(0.2, 0.9 err^(-0.7/3) err_prev^(0.4/3)))``
after an accepted step (no growth right after a rejection) and
``h max(0.2, 0.9 err^(-1/3))`` after a rejected one: on the brake's impact
transient it rejects a third as many steps as the plain controller and lands
nearer the tolerance (benchmarks/ros_accuracy.py). The steps do not stop at the
recording times: the outputs there come from the cubic Hermite interpolant of the
covering step (x and f at both ends; f at the end is the next step's first
stage), and only the last step is shortened. On the brake over 10 ms this took 8 %
fewer steps than stopping at every 10 us record (15,490 against 16,847 at rtol 1e-2).

Forward sensitivities (the outputs' derivatives with respect to parameters) ride along
on the same steps, each stage solved with the state's LU
(:mod:`fuzzymbs.mbs.kernels.sensitivities`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.dense_output import hermite, record_lanes
from fuzzymbs.mbs.kernels.jacobian import jacobian
from fuzzymbs.mbs.kernels.jacobian_log import (
    NO_JACOBIANS,
    lanes_from_log,
    log_jacobian,
    take_logged,
)
from fuzzymbs.mbs.kernels.layout import NONFINITE, STEP_TOO_SMALL
from fuzzymbs.mbs.kernels.linalg import lu_factor_lanes, reduced_stage_solve
from fuzzymbs.mbs.kernels.rhs import copy_lanes, rhs
from fuzzymbs.mbs.kernels.rk4 import record, retire_failed, start_block
from fuzzymbs.mbs.kernels.rosenbrock_methods import COEFFICIENTS
from fuzzymbs.mbs.kernels.sensitivities import (
    S_ROW,
    accept_sensitivities,
    end_sensitivities,
    keep_stage,
    new_sensitivities,
    no_sensitivity,
    record_sensitivities,
    record_sensitivity_lanes,
    retire_sensitivities,
    step_sensitivities,
)
from fuzzymbs.mbs.kernels.threads import round_robin

L = V.LANES

#: a step along a shared sequence (from one point to the next) is accepted up to this
#: error norm (its own steps: 1): its neighbours' errors there scatter about 1, and a
#: rejection takes a lane off the sequence and out of step with its block and makes it
#: evaluate Jacobians of its own. With the logging run's Jacobians (``_LOGGED``) brake
#: studies 1 and 2's plans (benchmarks/shared_accept.py, docs/theory.md "Shared steps")
#: keep their band errors from 2 to 10 and take 0.92-0.97 of the CPU at 4 against 2
#: (at most 8 % more above); with Jacobians of their own, study 1's caliper band error
#: rose from 0.02 % at 2 to 0.54 % at 4 (benchmarks/logged_jacobians.py), so 2 there
SHARED_ACCEPT, SHARED_ACCEPT_LOGGED = 2.0, 4.0
#: after a rejected step the Jacobian is renewed if it is at least this many accepted
#: steps old (a younger one is not the likely cause). On the brake over 10 ms at rtol
#: 1e-2: 2.0 s against 2.1-2.2 s when every rejection renews it (thresholds 2 and 5
#: were slower than 3), errors 0.27 % and 0.25 % of the peak (nominal, corner)
RENEW_AFTER_REJECT = 3
#: largest growth of the step from one step to the next
MAX_GROWTH = 5.0


#: control rows of a block between slices, one column per lane (:func:`start_block_ros`)
(_H, _ERR_PREV, _LU_STEP, _JAC_AGE, _NEED_JAC, _F_KNOWN) = range(6)
(_AFTER_REJECT, _ACCEPTED, _REJECTED, _NEXT_REC, _T, _STEP) = range(6, 12)
_GRID = 12  # the lane's next point of a shared step sequence
#: the work a lane needed: right-hand sides (the f_t difference and the records'
#: included, the Jacobian's own f not), Jacobians, LU factorisations (for a block of one
#: sample, the block's calls; lanes of a mixed block share the calls they need together)
(_N_RHS, _N_JAC, _N_LU) = (13, 14, 15)
#: the lane's sensitivity right-hand side at its step's start known (``G0``), and
#: the right-hand sides the sensitivities took (not counted in ``_N_RHS``)
(_G_KNOWN, _N_SENS_RHS) = (16, 17)
_CONTROL_ROWS = 18
#: step proposal after reaching a point of a shared step sequence: the whole next interval
_OPEN = np.inf


@nb.njit(cache=True, nogil=True)
def start_block_ros(sysdata, params, x0, recording, first, count, h0, stages, nsens=0):
    """State of a block of samples ``first .. first + count - 1`` (count <= 4) at the start:
    ``(x, p, alive, work, vectors, matrices, piv, sens, sens_work, control)``, advanced by
    :func:`advance_block_ros` with a method of ``stages`` stages. ``control`` holds one
    column per lane: every lane keeps its own time, step, error history and Jacobian age.
    ``sens``, ``sens_work``: the sensitivities to ``nsens`` parameters and their work
    arrays (:mod:`fuzzymbs.mbs.kernels.sensitivities`)."""
    x, p, alive, _, work = start_block(sysdata, params, x0, recording, first, count)
    size = x.shape[0]
    n = size // (2 * L)
    # f0, f_t, stage f, stage state, stage right-hand side, new state, solve, scratch for
    # the right-hand side and f(t + delta) of lanes that renew f0 or J, then u_1..u_s
    vectors = np.zeros((9 + stages, size))
    # da/dq, da/dv, the stage matrix I / (gamma h) - B_v - gamma h A_q per lane then its
    # LU, and da/dq, da/dv fresh for the lanes that renew their Jacobian
    matrices = np.zeros((5, n * n * L))
    piv = np.zeros(n * L, dtype=np.int64)
    sens, sens_work = new_sensitivities(nsens, stages, size, p.shape[0])
    control = np.zeros((_CONTROL_ROWS, L))
    for lane in range(L):
        control[_H, lane] = h0
        control[_STEP, lane] = h0
        control[_ERR_PREV, lane] = 1.0  # the last accepted step's error (PI control)
        control[_LU_STEP, lane] = -1.0  # the step the LU factors were made for
        control[_NEED_JAC, lane] = 1.0  # J and f_t are renewed every JACOBIAN_AGE steps
    return x, p, alive, work, vectors, matrices, piv, sens, sens_work, control


@nb.njit(cache=True, nogil=True, fastmath=V.FAST)
def advance_block_ros(
    sysdata,
    timing,
    recording,
    tolerances,
    coefficients,
    first,
    count,
    state,
    rec_begin,
    rec_end,
    sequence,
    renewals,
    step_log,
    sensitivity,
    jacobians,
):
    """Advances a block until records ``.. rec_end - 1`` are written (a step that passes
    ``rec_end`` also writes the records it covers). Returns False when the block is
    done (its last record written, or no healthy lane left).

    Every lane is a sample of its own: its own time, step size, error control,
    Jacobian age and recording, so that its outputs are bit for bit those of the
    sample run alone, whatever the other lanes hold. The lanes still share each
    vector instruction; a lane that has reached the slice's end (or failed) is
    masked out, and its arithmetic is discarded. A lane due for a new Jacobian
    waits, so that one evaluation serves several lanes: on its own steps until
    every stepping lane is due, on a shared sequence while a lane behind it steps
    on without needing one (it catches up and needs one at the same point);
    an f0 evaluation is made for all lanes when any stepping lane needs one, and
    both are kept only by the lanes that asked for them.

    Steps are chosen by the error control alone; the outputs at the recording
    times come from the cubic Hermite interpolant of the step that covers them
    (``x`` and ``f`` at both ends, O(h^4) like the method's local error), and
    only the last step is shortened, to end at the last recording time.

    With a shared step sequence (``sequence``: the ends of the steps, increasing,
    the last at the final time; empty: the lanes choose their own steps), every
    lane steps from point to point of the sequence. The error control still
    guards each step (an error norm up to :data:`SHARED_ACCEPT` along the sequence,
    ``SHARED_ACCEPT_LOGGED`` reading a log): a step it rejects is cut into the
    lane's own smaller steps up to the next point, so a lane leaves the sequence only
    where the sequence is too coarse for it, and its outputs stay its own.
    ``renewals`` (empty, or one
    per point: 1.0 where the logged sample evaluated its Jacobian at the step's start,
    for instance after a rejected try) makes a lane that arrives at a point renew its
    Jacobian there too, so that the logged sample replayed on its sequence repeats
    the logging run's arithmetic (to the rounding of the step lengths).

    ``timing = (t0, record_interval, n_records, h0)``; ``recording`` as for
    :func:`fuzzymbs.mbs.kernels.rk4.rk4`; ``tolerances = (rtol, atol, h_min)``, rtol
    and atol one per sample of the batch;
    ``coefficients``: :data:`COEFFICIENTS`; ``state`` from :func:`start_block_ros`.
    ``step_log`` (R, C), C > 1: row r receives the ends of the accepted steps of
    sample r of the batch (r < R, in its first block) and whether each one's Jacobian
    was evaluated at its start, in pairs from ``step_log[r, 1]`` (``step_log[r, 0]``:
    their number; -1 when the row is full); C = 1: nothing is logged.

    ``sensitivity = (directions, sens_settings, out_s)``: forward sensitivities
    ``S_k = dx/dp_k`` to P parameters integrated with the state by the same method on
    the state's steps, each stage's solve with the state's LU (docs/theory.md, "Forward
    sensitivities"). ``directions`` (P, slots): 1.0 in the slots parameter k sets (a
    name may set several); ``sens_settings = (delta,)``: the relative perturbation of
    the differences (:data:`fuzzymbs.mbs.kernels.sensitivities.SENS_DELTA`); ``out_s``
    (B, n_out, n_rec, P) receives the outputs' derivatives at the records. The
    sensitivities only read the state's arithmetic and never steer it, so the outputs
    and steps are bit for bit those of the run without (P = 0). Their stages are
    computed once a step is accepted, from the state's stage points kept for them: a
    rejected step costs them nothing.
    """
    t0, interval, n_records = timing[0], timing[1], int(timing[2])
    out, status, fail_t = recording[2], recording[3], recording[4]
    rtols, atols, h_min = tolerances
    # each lane's tolerances (a padded lane: its block's last sample's)
    rtol = V.splat(0.0)
    atol = V.splat(0.0)
    for lane in range(L):
        rtol = V.insert(rtol, lane, rtols[first + min(lane, count - 1)])
        atol = V.insert(atol, lane, atols[first + min(lane, count - 1)])
    at, cc, m, me, alpha, gsum, settings = coefficients
    stages = m.shape[0]
    gamma, exponent, jacobian_age = settings[0], settings[1], settings[2]
    x, p, alive, work, vectors, matrices, piv, sens, sens_work, control = state
    nsens = sensitivity[0].shape[0]
    sens_block = (*sensitivity, sens, sens_work)
    g_known = control[_G_KNOWN]  # the lane's sensitivity right-hand side at t known
    f0, ft, fy, y, r = vectors[0], vectors[1], vectors[2], vectors[3], vectors[4]
    x_new, rhs_v, f_fresh, ft_fresh = vectors[5], vectors[6], vectors[7], vectors[8]
    u = vectors[9:]
    jq, jv, mat, jq_fresh, jv_fresh = (
        matrices[0],
        matrices[1],
        matrices[2],
        matrices[3],
        matrices[4],
    )
    size = x.shape[0]
    nstate = size // L
    n = nstate // 2
    t_final = t0 + (n_records - 1) * interval
    tiny = 1e-12 * interval
    shared = sequence.shape[0] > 0
    forced = shared and renewals.shape[0] == sequence.shape[0]
    logging = step_log.shape[1] > 1 and first == 0
    # a logging block's lane 0 writes its Jacobians, a run on its sequence reads them
    jac_log, jac_rows, jac_ctl = jacobians
    jac_state = (control[_NEED_JAC], control[_JAC_AGE], control[_LU_STEP])
    writing = jac_ctl[0] == 1.0 and logging
    reading = jac_ctl[0] == 2.0 and shared
    accept_shared = SHARED_ACCEPT_LOGGED if reading else SHARED_ACCEPT
    from_log = np.zeros(L, dtype=np.bool_)
    own = np.zeros(L, dtype=np.bool_)
    h = control[_H]
    err_prev = control[_ERR_PREV]
    lu_step = control[_LU_STEP]
    jac_age = control[_JAC_AGE]
    need_jac = control[_NEED_JAC]
    f_known = control[_F_KNOWN]  # f(t, x) of the lane known
    after_reject = control[_AFTER_REJECT]  # no growth right after a rejected step
    accepted = control[_ACCEPTED]
    rejected = control[_REJECTED]
    next_rec = control[_NEXT_REC]  # the lane's first record not written yet
    t = control[_T]
    steps = control[_STEP]
    stepping = np.zeros(L, dtype=np.bool_)
    renew = np.zeros(L, dtype=np.bool_)
    last = np.zeros(L, dtype=np.bool_)
    took = np.zeros(L, dtype=np.bool_)
    covered = np.zeros(L, dtype=np.bool_)  # an accepted step that covers a record
    pending = np.zeros(L, dtype=np.bool_)
    t_lane = np.empty(L)
    delta = np.empty(L)
    theta = np.empty(L)
    records = np.zeros(L, dtype=np.int64)
    rec_times = np.empty(L)
    place = (h, control[_GRID], t, t0)  # where each lane stands (lanes_from_log)
    going = True
    if next_rec[0] == 0.0:  # the block's first call: record the initial state
        for lane in range(L):
            t[lane] = t0
            next_rec[lane] = 1.0
        # record 0 as an int64: a literal 0 would compile record (and store_output) again
        record(x, recording, first, count, alive, np.int64(0), t0)
        for k in range(nsens):
            for lane in range(L):
                pending[lane] = lane < count and alive[lane]
                records[lane] = 0
            out_s = sensitivity[2]
            record_sensitivity_lanes(
                sens[k, S_ROW], recording[0], out_s, first, pending, records, k
            )
        if retire_failed(first, count, status, alive, out, x, p) or n_records == 1:
            going = False
        elif nsens > 0:
            retire_sensitivities(count, alive, sens)
    while going:
        # the lanes that step now: healthy, and short of the slice's last record
        any_stepping = False
        for lane in range(L):
            stepping[lane] = lane < count and alive[lane] and next_rec[lane] < rec_end
            stepping[lane] = stepping[lane] and next_rec[lane] < n_records
            t_lane[lane] = t[lane]
            if stepping[lane]:
                any_stepping = True
                # the step ends at the next point of the sequence (the final time when
                # the lane chooses its own steps) if the proposal reaches it
                end = sequence[int(control[_GRID, lane])] if shared else t_final
                if forced and h[lane] == _OPEN and jac_age[lane] != 0.0:
                    # at a point of the sequence whose logged step took a fresh Jacobian
                    if renewals[int(control[_GRID, lane])] != 0.0:
                        need_jac[lane] = 1.0
                step = min(h[lane], end - t[lane])
                last[lane] = step >= end - t[lane] - tiny
                steps[lane] = end - t[lane] if last[lane] else step
        if not any_stepping:
            break
        # a lane that needs a new Jacobian waits (masked) so that one evaluation serves
        # several lanes. On its own steps it waits until every stepping lane needs one
        # (the lanes' renewals fall into step; with the shared-sequence rule below, whose
        # lanes' own schedules never meet, the brake's study-1 corners at rtol 1e-3 took
        # 8.9 s instead of 6.1 s). On a shared sequence it
        # waits only while a lane behind it steps on without needing one: that lane
        # catches up and needs one at the same logged point. A lane that waited for lanes
        # ahead of it would stay behind, waiting at every renewal (the same corners on a
        # shared sequence: 38,752 iterations of the block against 31,956, for 31,281
        # steps of the slowest lane). Waiting changes nothing in a lane's own arithmetic,
        # so its result stays independent of its block mates.
        all_need = True
        for lane in range(L):
            all_need = all_need and not (stepping[lane] and need_jac[lane] == 0.0)
        any_renew = False
        for lane in range(L):
            renew[lane] = stepping[lane] and need_jac[lane] != 0.0
            wait = renew[lane] and not all_need
            if wait and shared:
                wait = False
                for other in range(L):
                    behind = stepping[other] and need_jac[other] == 0.0 and t[other] < t[lane]
                    wait = wait or behind
            if wait:
                stepping[lane] = False
                renew[lane] = False
            any_renew = any_renew or renew[lane]
        # a lane at a point of a logged sequence takes the logged step's Jacobian; the
        # others evaluate their own, as a block
        any_own, any_logged = lanes_from_log(renew, reading, place, jac_rows, from_log, own)
        if any_own:
            jacobian(t_lane, x, p, sysdata, work, f_fresh, jq_fresh, jv_fresh)
            for lane in range(L):
                if own[lane]:
                    control[_N_JAC, lane] += 1.0
                    control[_N_RHS, lane] += 1.0
            # explicit time dependence (prescribed rotations, force profiles)
            for lane in range(L):
                delta[lane] = max(1e-9, 1e-7 * abs(t[lane]))
                theta[lane] = t[lane] + delta[lane]
            rhs(theta, x, ft_fresh, p, sysdata, work)
            for lane in range(L):
                if own[lane]:
                    for k in range(nstate):
                        e = L * k + lane
                        ft[e] = (ft_fresh[e] - f_fresh[e]) / delta[lane]
                        f0[e] = f_fresh[e]
                    need_jac[lane] = 0.0
                    jac_age[lane] = 0.0
                    f_known[lane] = 1.0
                    lu_step[lane] = -1.0
            copy_lanes(jq_fresh, jq, own)
            copy_lanes(jv_fresh, jv, own)
            if writing and own[0]:
                log_jacobian(jq, jv, ft, n, nstate, jac_log, jac_ctl)
        if any_logged:
            take_logged(from_log, control[_GRID], jacobians, n, nstate, jq, jv, ft, jac_state)
        any_renew = False
        for lane in range(L):
            renew[lane] = stepping[lane] and f_known[lane] == 0.0
            any_renew = any_renew or renew[lane]
        if any_renew:
            rhs(t_lane, x, f_fresh, p, sysdata, work)
            for lane in range(L):
                if renew[lane]:
                    control[_N_RHS, lane] += 1.0
            copy_lanes(f_fresh, f0, renew)
            for lane in range(L):
                if renew[lane]:
                    f_known[lane] = 1.0
        refactor = False
        for lane in range(L):
            refactor = refactor or (stepping[lane] and steps[lane] != lu_step[lane])
        step_v = V.load(steps, 0)
        gh = gamma * step_v
        if refactor:
            # every lane's matrix is a function of its own J and step alone: a lane
            # refactorised with an unchanged step gets the same factors
            inv_gh = 1.0 / gh
            for e in range(n * n):
                V.store(mat, L * e, -(V.load(jv, L * e) + gh * V.load(jq, L * e)))
            for i in range(n):
                at_ii = L * (n * i + i)
                V.store(mat, at_ii, V.load(mat, at_ii) + inv_gh)
            lu_factor_lanes(mat, n, piv)
            for lane in range(L):
                if stepping[lane] and steps[lane] != lu_step[lane]:
                    control[_N_LU, lane] += 1.0
                lu_step[lane] = steps[lane]
        for s in range(stages):
            if s == 0:
                stage_f = f0
            else:
                for i in range(nstate):
                    acc = V.load(x, L * i)
                    for j in range(s):
                        acc = acc + at[s, j] * V.load(u[j], L * i)
                    V.store(y, L * i, acc)
                for lane in range(L):
                    theta[lane] = t[lane] + alpha[s] * steps[lane]
                rhs(theta, y, fy, p, sysdata, work)
                for lane in range(L):
                    if stepping[lane]:
                        control[_N_RHS, lane] += 1.0
                stage_f = fy
            ft_factor = gsum[s] * step_v
            for i in range(nstate):
                acc = V.load(stage_f, L * i) + ft_factor * V.load(ft, L * i)
                for j in range(s):
                    acc = acc + (cc[s, j] / step_v) * V.load(u[j], L * i)
                V.store(r, L * i, acc)
            # velocity-reduced solve: (I/(g h) - B - g h A) u_v = r_v + g h A r_q
            reduced_stage_solve(jq, mat, piv, n, gh, r, rhs_v, u[s])
            if nsens > 0 and s > 0:  # for the sensitivities, once the step is accepted
                keep_stage(sens_work, s, stages, y, stage_f)
        # new state and each lane's error norm; a lane whose error is not finite fails
        squares = V.splat(0.0)
        for i in range(nstate):
            xi = V.load(x, L * i)
            xn = xi
            e = V.splat(0.0)
            for j in range(stages):
                uj = V.load(u[j], L * i)
                xn = xn + m[j] * uj
                e = e + me[j] * uj
            V.store(x_new, L * i, xn)
            ax = V.vabs(xi)
            an = V.vabs(xn)
            scaled = e / (atol + rtol * V.where_lt(ax, an, an, ax))
            squares = squares + scaled * scaled
        newly_failed = False
        any_record = False
        for lane in range(L):
            took[lane] = False
            covered[lane] = False
            if not stepping[lane]:
                continue
            err = np.sqrt(V.get(squares, lane) / nstate)
            if not np.isfinite(err):
                status[first + lane] = NONFINITE
                fail_t[first + lane] = t[lane]
                newly_failed = True
            elif err <= (accept_shared if shared and last[lane] else 1.0):
                took[lane] = True
                if last[lane]:
                    theta[lane] = sequence[int(control[_GRID, lane])] if shared else t_final
                else:
                    theta[lane] = t[lane] + steps[lane]
                if logging and lane < step_log.shape[0]:
                    logged = int(step_log[lane, 0])
                    if 0 <= logged < (step_log.shape[1] - 1) // 2:
                        step_log[lane, 1 + 2 * logged] = theta[lane]
                        step_log[lane, 2 + 2 * logged] = 1.0 if jac_age[lane] == 0.0 else 0.0
                        step_log[lane, 0] = logged + 1
                        if writing and lane == 0 and logged < jac_rows.shape[0]:
                            # the row of the Jacobian this step took (-1: none logged)
                            kept = jac_ctl[1] <= jac_log.shape[0]
                            jac_rows[logged] = jac_ctl[1] - 1.0 if kept else -1.0
                    else:
                        step_log[lane, 0] = -1.0
                accepted[lane] += 1.0
                jac_age[lane] += 1.0
                need_jac[lane] = 1.0 if jac_age[lane] >= jacobian_age else 0.0
                factor = MAX_GROWTH
                if err > 0.0:
                    pi = 0.9 * err ** (-0.7 * exponent) * err_prev[lane] ** (0.4 * exponent)
                    factor = min(MAX_GROWTH, max(0.2, pi))
                err_prev[lane] = max(err, 1e-4)
                if after_reject[lane] != 0.0:
                    factor = min(factor, 1.0)
                after_reject[lane] = 0.0
                h[lane] = steps[lane] * factor
                if shared and last[lane]:
                    control[_GRID, lane] += 1.0
                    h[lane] = _OPEN  # the next step: the sequence's next interval
                f_known[lane] = 0.0
                covered[lane] = t0 + next_rec[lane] * interval <= theta[lane] + tiny
                any_record = any_record or covered[lane]
            else:
                rejected[lane] += 1.0
                after_reject[lane] = 1.0
                h[lane] = steps[lane] * max(0.2, 0.9 * err**-exponent)
                # an aged Jacobian may be the cause
                if jac_age[lane] >= RENEW_AFTER_REJECT:
                    need_jac[lane] = 1.0
                if h[lane] < h_min:
                    status[first + lane] = STEP_TOO_SMALL
                    fail_t[first + lane] = t[lane]
                    newly_failed = True
            if not took[lane]:
                theta[lane] = t[lane]
        any_took = False
        for lane in range(L):
            any_took = any_took or took[lane]
        if nsens > 0 and any_took:
            state_step = (at, cc, m, alpha, gamma, steps, step_v, jq, mat, piv, work)
            counter = control[_N_SENS_RHS]
            step_sensitivities(
                took, g_known, counter, t_lane, x, f0, sens_block, p, state_step, sysdata
            )
        if any_record:
            # the records the accepted steps cover, from each lane's Hermite interpolant;
            # f at a step's end is that lane's next f0
            rhs(theta, x_new, fy, p, sysdata, work)
            for lane in range(L):
                if covered[lane]:
                    control[_N_RHS, lane] += 1.0
            # the sensitivities' right-hand sides at the step's end: their interpolant's
            # slope there, and the next step's first stage
            if nsens > 0:
                counter = control[_N_SENS_RHS]
                end_sensitivities(theta, x_new, fy, covered, counter, sens_block, p, sysdata, work)
            while True:
                any_pending = False
                for lane in range(L):
                    rec_times[lane] = t0 + next_rec[lane] * interval
                    pending[lane] = covered[lane] and next_rec[lane] < n_records
                    pending[lane] = pending[lane] and rec_times[lane] <= theta[lane] + tiny
                    records[lane] = int(next_rec[lane])
                    delta[lane] = min(1.0, (rec_times[lane] - t[lane]) / steps[lane])
                    any_pending = any_pending or pending[lane]
                if not any_pending:
                    break
                hermite(x, f0, x_new, fy, step_v, V.load(delta, 0), y)
                record_lanes(y, recording, first, pending, records, rec_times)
                if nsens > 0:
                    theta_v = V.load(delta, 0)
                    record_sensitivities(
                        sens_block, recording[0], step_v, theta_v, first, pending, records
                    )
                for lane in range(L):
                    if pending[lane]:
                        next_rec[lane] += 1.0
            newly_failed = True  # a record may have flagged a lane out of bound
        for lane in range(L):
            if took[lane]:
                for k in range(nstate):
                    e = L * k + lane
                    x[e] = x_new[e]
                    if covered[lane]:
                        f0[e] = fy[e]
                if covered[lane]:
                    f_known[lane] = 1.0
                t[lane] = theta[lane]
        accept_sensitivities(took, covered, g_known, sens)
        if newly_failed:
            if retire_failed(first, count, status, alive, out, x, p):
                going = False
            elif nsens > 0:
                retire_sensitivities(count, alive, sens)
    more = False
    for lane in range(count):
        more = more or (alive[lane] and next_rec[lane] < n_records)
    return more


#: slices (in recording intervals) a block's run is cut into when blocks share threads
SLICES = 16


def ros34pw2(
    sysdata,
    params,
    x0,
    timing,
    recording,
    tolerances,
    per_block,
    counts,
    sequence,
    renewals,
    step_log,
    coefficients=COEFFICIENTS,
    sensitivity=None,
    jacobians=None,
) -> None:
    """ROS34PW2 (or the Rosenbrock method of ``coefficients``, e.g. RODAS4) of a batch in
    blocks of ``per_block`` (1 to 4) samples over the threads.

    Arguments as :func:`advance_block_ros` (``sensitivity`` None: no sensitivities);
    ``counts (B, 2)`` receives the accepted and rejected steps of each sample, ``(B, 5)``
    also the right-hand sides, Jacobians and LU factorisations each took part in, ``(B,
    6)`` also the right-hand sides of its sensitivities. Blocks advance
    ``SLICES`` slices of recording intervals at a time, round robin over the
    threads (:func:`fuzzymbs.mbs.kernels.threads.round_robin`): with 9 blocks on 2
    threads each thread carries 4.5 blocks instead of 5 and 4. Slicing does not
    change a block's arithmetic.
    """
    nsamples = params.shape[0]
    n_records = timing[2]
    n_blocks = -(-nsamples // per_block)
    if sensitivity is None:
        sensitivity = no_sensitivity(params.shape[1], nsamples, recording[0].shape[0], n_records)
    nsens = sensitivity[0].shape[0]
    if jacobians is None:
        jacobians = NO_JACOBIANS

    def start(block: int):
        first = block * per_block
        count = min(per_block, nsamples - first)
        # on a shared sequence the first step is its first interval (finite: a lane that
        # does not step still carries its step into the vector arithmetic)
        h0 = sequence[0] - timing[0] if sequence.shape[0] > 0 else timing[3]
        return start_block_ros(
            sysdata, params, x0, recording, first, count, h0, coefficients[2].shape[0], nsens
        )

    def advance(block: int, state, begin: int, end: int) -> bool:
        first = block * per_block
        count = min(per_block, nsamples - first)
        going = advance_block_ros(
            sysdata,
            timing,
            recording,
            tolerances,
            coefficients,
            first,
            count,
            state,
            begin,
            end,
            sequence,
            renewals,
            step_log,
            sensitivity,
            jacobians,
        )
        if not going or end >= n_records:
            control = state[-1]
            for lane in range(count):
                counts[first + lane, 0] = int(control[_ACCEPTED, lane])
                counts[first + lane, 1] = int(control[_REJECTED, lane])
                if counts.shape[1] >= 5:
                    counts[first + lane, 2] = int(control[_N_RHS, lane])
                    counts[first + lane, 3] = int(control[_N_JAC, lane])
                    counts[first + lane, 4] = int(control[_N_LU, lane])
                if counts.shape[1] >= 6:
                    counts[first + lane, 5] = int(control[_N_SENS_RHS, lane])
        return going

    round_robin(n_blocks, n_records, max(1, -(-n_records // SLICES)), start, advance)
