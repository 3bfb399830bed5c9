"""Forward sensitivities ``S_k = dx/dp_k`` integrated with the state by the Rosenbrock
kernel (:mod:`fuzzymbs.mbs.kernels.rosenbrock`), LANES samples per block as the state.

The sensitivities satisfy ``S_k' = f_x(x, p) S_k + f_p_k(x, p)``, ``S_k(0) = 0`` (the
initial state does not depend on the parameters). They are integrated by the state's
method on the state's steps (staggered direct): the state's error control alone chooses
the steps, so a run's outputs are bit for bit those of the run without sensitivities.
Each stage solves with the state's LU, i.e. the method runs on the augmented system with
the block-diagonal matrix ``diag(J, J)``; ROS34PW2, a W-method, keeps its order with it
(RODAS4 does not: its sensitivities converge at first order; docs/theory.md, "Forward
sensitivities").

The sensitivity right-hand side at a stage is a directional difference of the compiled
right-hand side, ``(f(Y + eps S, p + eps e_k) - f(Y, p)) / eps`` with ``f(Y, p)`` the
state's own stage value: one right-hand side per parameter and stage, for every model of
the engine, with nothing differentiated by hand (the contact's friction, the master
face's interpolation, the prescribed rotations). The stages are computed once the
state's step is accepted, from the stage points the state kept (:func:`keep_stage`), so
that a rejected step costs the sensitivities nothing. The records interpolate ``S`` with
the cubic Hermite interpolant of the step, its slopes the sensitivity right-hand side at
both ends (the one at the end is the next step's first stage).

Layout: ``sens`` (P, 4 + stages, size), per parameter the rows ``S_ROW`` (S at the
lane's time), ``S_NEW`` (at the step's end), ``G0``, ``G1`` (the right-hand side at
the step's start and end), then the stages' increments U_i; ``work`` (4 + 2 stages +
parameter rows, size): scratch rows ``W_*``, the state's stage points Y_i and their f,
then the perturbed parameter row laid over as many rows as it needs. Every row is as long
as the state, so that a loop over a row's length (an output's weights, a lane copy)
never runs past the state.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.dense_output import hermite
from fuzzymbs.mbs.kernels.linalg import reduced_stage_solve
from fuzzymbs.mbs.kernels.rhs import copy_lanes, rhs
from fuzzymbs.mbs.kernels.rk4 import output_value

L = V.LANES

#: rows of a parameter's sensitivity arrays (module docstring)
S_ROW, S_NEW, G0, G1, U0 = range(5)
#: rows of the sensitivities' work array: the perturbed state, its f, a sensitivity
#: right-hand side, the velocity-reduced solve's right-hand side; from ``W_STAGES`` the
#: state's stage points Y_i, from ``W_STAGES + stages`` their f; the last rows hold the
#: perturbed parameter row (:func:`parameter_rows`)
W_MOVED, W_FMOVED, W_G, W_SOLVE, W_STAGES = range(5)

#: relative perturbation of the differences (:func:`perturbation`). On the brake's first
#: millisecond (benchmarks/brake_sensitivities.py, against central differences of whole
#: runs at rtol 1e-6): 1e-7 left rounding noise of 26 times the pads' derivative to k_c
#: (a 7e-16 m per N/m quantity) and 85 % of the caliper's to the disc speed, 1e-5 0.19
#: and 1.2 %, 1e-4 1.5 % and 0.02 %; 1e-3 no better, the pads' derivative to k growing
#: from 1.3e-5 to 3.8e-5 of its peak. The differences' own error is O(delta) relative:
#: 1.4e-4 of the peak on a spring-mass oscillator (the spring force is bilinear in k and
#: x), 1e-4 on a block sliding on a belt (tests/mbs/test_sensitivities.py), far below what
#: a fuzzy band asks (a per cent of its width)
SENS_DELTA = 1e-4


def no_sensitivity(slots: int, batch: int, n_out: int, n_records: int) -> tuple:
    """The kernel's ``sensitivity`` argument for a run without sensitivities (P = 0;
    the same types as with them, so one compiled kernel serves both)."""
    return (
        np.zeros((0, slots)),
        np.array([SENS_DELTA]),
        np.zeros((batch, n_out, n_records, 0)),
    )


@nb.njit(cache=True)
def new_sensitivities(nsens, stages, size, slots):
    """``(sens, work)`` of a block (module docstring; zero: S(0) = 0); ``slots``: the
    length of the lanes' parameter row."""
    sens = np.zeros((nsens, 4 + stages, size))
    rows = W_STAGES + 2 * stages + parameter_rows(slots, size) if nsens > 0 else 1
    return sens, np.zeros((rows, size))


@nb.njit(cache=True)
def parameter_rows(slots, size):
    """Rows of ``size`` entries that hold a parameter row of ``slots`` entries."""
    return (slots + size - 1) // size


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def perturbation(p, direction, delta):
    """Per lane, the parameter's perturbation in the differences: ``delta`` times the
    lane's value (``delta`` itself for a value of zero), so that the state moves by
    ``delta`` times ``p_k S_k``, the change a 100 % change of p_k would make to first
    order: a relative perturbation of the same size in state and parameter."""
    scale = V.splat(0.0)
    for slot in range(direction.shape[0]):
        if direction[slot] != 0.0:
            value = V.vabs(V.load(p, L * slot))
            scale = V.where_lt(scale, value, value, scale)
    return V.where_eq(scale, V.splat(0.0), V.splat(delta), delta * scale)


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def sensitivity_rhs(theta, xb, fb, s, direction, p, delta, sysdata, rhs_work, work, dst):
    """``dst`` <- the sensitivity right-hand side ``f_x(x) s + f_p(x)`` at the lane
    times ``theta`` and states ``xb``, with ``fb = f(theta, xb)`` known: the directional
    difference ``(f(xb + eps s, p + eps e_k) - fb) / eps`` (eps from :func:`perturbation`,
    e_k the parameter's ``direction`` in the slots; ``rhs_work`` the right-hand side's
    work arrays, ``work`` the sensitivities')."""
    size = xb.shape[0]
    eps = perturbation(p, direction, delta)
    first = work.shape[0] - parameter_rows(p.shape[0], size)  # the last rows (contiguous)
    p_moved = work.reshape(-1)[first * size : first * size + p.shape[0]]
    for slot in range(direction.shape[0]):
        value = V.load(p, L * slot)
        if direction[slot] != 0.0:
            value = value + direction[slot] * eps
        V.store(p_moved, L * slot, value)
    moved, f_moved = work[W_MOVED], work[W_FMOVED]
    for i in range(size // L):
        V.store(moved, L * i, V.load(xb, L * i) + eps * V.load(s, L * i))
    rhs(theta, moved, f_moved, p_moved, sysdata, rhs_work)
    for i in range(size // L):
        V.store(dst, L * i, (V.load(f_moved, L * i) - V.load(fb, L * i)) / eps)


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def keep_stage(work, s, stages, y, stage_f):
    """Keep the state's stage point ``y`` and its f for the sensitivities (stages s > 0;
    stage 0 is the step's start)."""
    for i in range(y.shape[0] // L):
        V.store(work[W_STAGES + s], L * i, V.load(y, L * i))
        V.store(work[W_STAGES + stages + s], L * i, V.load(stage_f, L * i))


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def sensitivity_stage(s, theta, sk, direction, p, delta, method, sysdata, rhs_work, work):
    """Stage ``s`` of one parameter's sensitivity (``sk``: its rows), once the state's step
    is computed: ``(I / (gamma h) - J) U_s = G_s + sum_j (c_sj / h) U_j`` with the
    state's factors, ``G_s`` the sensitivity right-hand side at ``(Y_s, S_s = S + sum_j
    at_sj U_j)``: at stage 0 the one at the step's start, then :func:`sensitivity_rhs` at
    the kept stage point. No ``f_t`` term: the W-method keeps its order with the block-
    diagonal Jacobian ``diag(J, J)``, which drops it (docs/theory.md). ``method = (at,
    cc, gamma, h, jq, mat, piv)``: the tableau, the lanes' steps (a vector), the
    Jacobian's ``A_q`` block and the stage matrix's LU."""
    at, cc, gamma, step_v, jq, mat, piv = method
    stages = at.shape[0]
    nstate = sk.shape[1] // L
    n = nstate // 2
    gh = gamma * step_v
    g = sk[G0]
    if s > 0:
        g = work[W_G]
        s_stage = work[W_SOLVE]  # S_s, until the difference has read it
        for i in range(nstate):
            acc = V.load(sk[S_ROW], L * i)
            for j in range(s):
                acc = acc + at[s, j] * V.load(sk[U0 + j], L * i)
            V.store(s_stage, L * i, acc)
        y, fy = work[W_STAGES + s], work[W_STAGES + stages + s]
        sensitivity_rhs(theta, y, fy, s_stage, direction, p, delta, sysdata, rhs_work, work, g)
    r = work[W_MOVED]
    for i in range(nstate):
        acc = V.load(g, L * i)
        for j in range(s):
            acc = acc + (cc[s, j] / step_v) * V.load(sk[U0 + j], L * i)
        V.store(r, L * i, acc)
    # velocity-reduced solve with the state's factors
    reduced_stage_solve(jq, mat, piv, n, gh, r, work[W_SOLVE], sk[U0 + s])


@nb.njit(cache=True, fastmath=V.FAST)
def step_sensitivities(took, g_known, counter, t, x, f0, sensitivity, p, state_step, sysdata):
    """The sensitivities' step for the lanes whose state step is accepted (``took``):
    their right-hand side at the step's start where the last step's record did not leave
    it (``g_known`` per lane), the stages at the kept stage points, and ``S_NEW``.

    ``sensitivity = (directions, settings, out_s, sens, work)``; ``state_step = (at, cc,
    m, alpha, gamma, steps, h, jq, mat, piv, rhs_work)``: the tableau, the lanes' steps
    (an array and a vector), the Jacobian's ``A_q`` and the stage matrix's LU, the right-
    hand side's work arrays. ``counter`` (per lane) counts the right-hand sides."""
    directions, settings, _, sens, work = sensitivity
    at, cc, m, alpha, gamma, steps, step_v, jq, mat, piv, rhs_work = state_step
    nsens = directions.shape[0]
    delta = settings[0]
    stages = m.shape[0]
    renew = np.zeros(L, dtype=np.bool_)
    any_renew = False
    for lane in range(L):
        renew[lane] = took[lane] and g_known[lane] == 0.0
        any_renew = any_renew or renew[lane]
    if any_renew:
        for k in range(nsens):
            g = work[W_G]
            sensitivity_rhs(
                t, x, f0, sens[k, S_ROW], directions[k], p, delta, sysdata, rhs_work, work, g
            )
            copy_lanes(g, sens[k, G0], renew)
        for lane in range(L):
            if renew[lane]:
                g_known[lane] = 1.0
                counter[lane] += nsens
    stage_t = np.empty(L)
    method = (at, cc, gamma, step_v, jq, mat, piv)
    for s in range(stages):
        for lane in range(L):
            stage_t[lane] = t[lane] + alpha[s] * steps[lane]
        for k in range(nsens):
            sensitivity_stage(
                s, stage_t, sens[k], directions[k], p, delta, method, sysdata, rhs_work, work
            )
        if s > 0:
            for lane in range(L):
                if took[lane]:
                    counter[lane] += nsens
    nstate = x.shape[0] // L
    for k in range(nsens):
        sk = sens[k]
        for i in range(nstate):
            acc = V.load(sk[S_ROW], L * i)
            for j in range(stages):
                acc = acc + m[j] * V.load(sk[U0 + j], L * i)
            V.store(sk[S_NEW], L * i, acc)


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def end_sensitivities(theta, x_new, fy, covered, counter, sensitivity, p, sysdata, rhs_work):
    """For the lanes whose accepted step covers a record: the sensitivity right-hand side
    at the step's end (``G1``, with ``fy = f(theta, x_new)``), the interpolant's slope
    there and the next step's first stage."""
    directions, settings, _, sens, work = sensitivity
    nsens = directions.shape[0]
    for k in range(nsens):
        g = work[W_G]
        sensitivity_rhs(
            theta,
            x_new,
            fy,
            sens[k, S_NEW],
            directions[k],
            p,
            settings[0],
            sysdata,
            rhs_work,
            work,
            g,
        )
        copy_lanes(g, sens[k, G1], covered)
    for lane in range(L):
        if covered[lane]:
            counter[lane] += nsens


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def record_sensitivities(sensitivity, out_w, step_v, theta_v, first, lanes, records):
    """The outputs' derivatives ``out_w S`` at ``t + theta h`` (the step's Hermite
    interpolant of S, slopes ``G0`` and ``G1``) into ``out_s[sample, output, record,
    k]`` for the lanes marked in ``lanes`` (outputs are linear in the state)."""
    directions, _, out_s, sens, work = sensitivity
    value = work[W_G]
    for k in range(directions.shape[0]):
        sk = sens[k]
        hermite(sk[S_ROW], sk[G0], sk[S_NEW], sk[G1], step_v, theta_v, value)
        record_sensitivity_lanes(value, out_w, out_s, first, lanes, records, k)


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def record_sensitivity_lanes(sv, out_w, out_s, first, lanes, records, k):
    """The outputs' derivatives ``out_w sv`` of the lanes marked in ``lanes`` into
    ``out_s[sample, output, records[lane], k]``."""
    for o in range(out_w.shape[0]):
        value = output_value(sv, out_w, o)
        for lane in range(L):
            if lanes[lane]:
                out_s[first + lane, o, records[lane], k] = V.get(value, lane)


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def accept_sensitivities(took, covered, g_known, sens):
    """The lanes whose step is accepted take ``S_NEW`` (and, where the step covered a
    record, ``G1`` as the next step's first stage)."""
    size = sens.shape[2]
    for lane in range(L):
        if not took[lane]:
            continue
        for k in range(sens.shape[0]):
            for i in range(size // L):
                e = L * i + lane
                sens[k, S_ROW, e] = sens[k, S_NEW, e]
                if covered[lane]:
                    sens[k, G0, e] = sens[k, G1, e]
        g_known[lane] = 1.0 if covered[lane] else 0.0


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def retire_sensitivities(count, alive, sens):
    """Failed lanes (and padding lanes repeating a failed sample) take the sensitivities
    of the block's first healthy lane, as :func:`fuzzymbs.mbs.kernels.rk4.retire_failed`
    gives them its state: finite numbers in every lane's arithmetic."""
    healthy = -1
    for lane in range(count):
        if alive[lane]:
            healthy = lane
            break
    if healthy < 0:
        return
    for lane in range(L):
        if not alive[min(lane, count - 1)]:
            for k in range(sens.shape[0]):
                for row in range(sens.shape[1]):
                    for i in range(sens.shape[2] // L):
                        sens[k, row, L * i + lane] = sens[k, row, L * i + healthy]
