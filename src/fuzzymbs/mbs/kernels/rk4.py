"""Classic fixed-step RK4 for a batch of samples, LANES per block in lockstep.

The paper's integrator (dt = 1 us for the brake; stable only for
``|lambda dt| < 2.785`` on the real axis, docs/theory.md). :func:`rk4` hands
the blocks to threads; each block integrates up to LANES samples in the lanes
of one vector (:func:`start_block`, :func:`advance_block`), padding lanes
repeating the block's last sample.

A lane whose sample fails (non-finite state, output beyond its bound) is
flagged and then repeats a healthy lane of its block, so that it neither
spreads NaN nor pushes the block off the shared master cells; its outputs are
NaN.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.layout import NONFINITE, OK, OUT_OF_BOUND
from fuzzymbs.mbs.kernels.rhs import make_work, rhs, set_lane
from fuzzymbs.mbs.kernels.threads import round_robin

L = V.LANES


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def retire_failed(first, count, status, alive, out, x, p):
    """Flag newly failed lanes (NaN outputs) and let them repeat a healthy lane.

    Returns True when no lane of the block is healthy any more.
    """
    healthy = -1
    for lane in range(count):
        if alive[lane] and status[first + lane] == OK:
            healthy = lane
            break
    for lane in range(count):
        if alive[lane] and status[first + lane] != OK:
            alive[lane] = False
            out[first + lane, :, :] = np.nan
    if healthy < 0:
        return True
    for lane in range(L):
        source = lane if lane < count else count - 1  # padding lanes repeat the last sample
        if not alive[source]:
            for i in range(x.shape[0] // L):
                x[L * i + lane] = x[L * i + healthy]
            for i in range(p.shape[0] // L):
                p[L * i + lane] = p[L * i + healthy]
    return False


#: Slices a block's steps are cut into when blocks share threads (at least MIN_SLICE steps)
SLICES = 16
MIN_SLICE = 32


def rk4(sysdata, params, x0, timing, recording, per_block) -> None:
    """RK4 of a batch of samples in blocks of ``per_block`` (1 to 4), the blocks over threads.

    Parameters
    ----------
    sysdata : the compiled system's data tuple.
    params : (B, n_slots) parameter rows; x0 : (B, 2n) initial states.
    timing : ``(t0, dt, n_steps, record_every)``: start time and step [s], steps, and
        every how many steps the outputs are recorded.
    recording : ``(out_w, bound, out, status, fail_t)``: out_w (n_out, 2n) linear
        output functionals; bound (n_out,) an output with |y| > bound stops the sample
        (status OUT_OF_BOUND); out (B, n_out, n_rec), status, fail_t (B,) (per-sample
        status code, failure time [s] or NaN) are filled in place.
    per_block : samples per block; 4 fills every lane, 1 gives each sample a block of its
        own (its lanes repeat it), so that no result depends on another sample.

    With more than one block and thread, each block advances ``SLICES`` slices of
    steps at a time and goes back to the end of the queue (:func:`round_robin`): the
    threads share the last blocks instead of one thread running the last whole block
    alone. Slicing does not change a block's arithmetic: results are the same bits.
    """
    nsamples = params.shape[0]
    n_steps = timing[2]
    n_blocks = -(-nsamples // per_block)

    def start(block: int):
        first = block * per_block
        return start_block(sysdata, params, x0, recording, first, min(per_block, nsamples - first))

    def advance(block: int, state, begin: int, end: int) -> bool:
        first = block * per_block
        count = min(per_block, nsamples - first)
        return advance_block(sysdata, timing, recording, first, count, state, begin, end)

    slice_steps = max(MIN_SLICE, -(-(n_steps + 1) // SLICES))
    round_robin(n_blocks, n_steps + 1, slice_steps, start, advance)


@nb.njit(cache=True, nogil=True)
def start_block(sysdata, params, x0, recording, first, count):
    """Lane state of samples ``first .. first + count - 1`` (count <= 4) at the start.

    Returns ``(x, p, alive, stages, work)``: lane states and parameter rows
    (lanes beyond count repeat the last sample), which lanes are still healthy,
    the RK4 stage vectors (k1..k4, intermediate state) and the right-hand side's
    work arrays. Sets the samples' status to OK.
    """
    status, fail_t = recording[3], recording[4]
    nslots = params.shape[1]
    nstate = x0.shape[1]
    p = np.empty(nslots * L)
    x = np.empty(nstate * L)
    for lane in range(L):
        src = first + min(lane, count - 1)
        set_lane(p, lane, params[src])
        set_lane(x, lane, x0[src])
    alive = np.ones(L, dtype=np.bool_)
    for lane in range(count):
        status[first + lane] = OK
        fail_t[first + lane] = np.nan
    return x, p, alive, np.empty((5, nstate * L)), make_work(sysdata)


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def output_value(x, out_w, o):
    """Output o of the lane states ``x``: ``sum_i w_oi x_i`` as a lane vector.

    The sum runs over the weights' columns (the state's 2n entries): ``x`` may be a longer
    work row, whose entries past the state are not the state's (reading ``out_w`` past
    its row instead read whatever memory followed it, NaN included)."""
    y = V.splat(0.0)
    for i in range(out_w.shape[1]):
        w = out_w[o, i]
        if w != 0.0:
            y = V.fma(V.splat(w), V.load(x, L * i), y)
    return y


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def store_output(recording, sample, o, rec, value, t):
    """Output o of ``sample`` at record ``rec`` (time t); a value beyond the output's bound
    (or not finite) flags the sample (arguments as :func:`rk4`)."""
    _, bound, out, status, fail_t = recording
    out[sample, o, rec] = value
    if not abs(value) <= bound[o]:  # also catches NaN
        status[sample] = OUT_OF_BOUND if np.isfinite(value) else NONFINITE
        fail_t[sample] = t


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def record(x, recording, first, count, alive, rec, t):
    """Outputs of the block's healthy lanes at time t into record ``rec``; a lane whose
    output leaves its bound (or is not finite) is flagged (arguments as :func:`rk4`)."""
    out_w = recording[0]
    for o in range(out_w.shape[0]):
        y = output_value(x, out_w, o)
        for lane in range(count):
            if alive[lane]:
                store_output(recording, first + lane, o, rec, V.get(y, lane), t)


@nb.njit(cache=True, nogil=True)
def advance_block(sysdata, timing, recording, first, count, state, step_begin, step_end):
    """Steps ``step_begin .. step_end - 1`` of a block (from :func:`start_block`), on the
    calling thread (arguments as :func:`rk4`).

    Step s records the outputs at ``t0 + s dt`` (every ``record_every`` steps) and
    then advances to the next time, except the last step ``n_steps``. Returns False
    when the block is done: its last step taken, or no healthy lane left.
    """
    t0, dt, n_steps, record_every = timing
    out, status, fail_t = recording[2], recording[3], recording[4]
    x, p, alive, stages, work = state
    k1, k2, k3, k4, xt = stages[0], stages[1], stages[2], stages[3], stages[4]
    nstate = x.shape[0] // L
    size = nstate * L
    # the lanes' time, one clock for all: the right-hand side takes a time per lane, as
    # the adaptive integrators' lanes keep their own (one compiled form of it, not two)
    clock = np.empty(L)
    for step in range(step_begin, step_end):
        t = t0 + step * dt
        if step % record_every == 0:
            record(x, recording, first, count, alive, step // record_every, t)
            if retire_failed(first, count, status, alive, out, x, p):
                return False
        if step == n_steps:
            return False
        clock[:] = t
        rhs(clock, x, k1, p, sysdata, work)
        for m in range(size):
            xt[m] = x[m] + 0.5 * dt * k1[m]
        clock[:] = t + 0.5 * dt
        rhs(clock, xt, k2, p, sysdata, work)
        for m in range(size):
            xt[m] = x[m] + 0.5 * dt * k2[m]
        rhs(clock, xt, k3, p, sysdata, work)
        for m in range(size):
            xt[m] = x[m] + dt * k3[m]
        clock[:] = t + dt
        rhs(clock, xt, k4, p, sysdata, work)
        bad = V.splat(0.0)
        for i in range(nstate):
            m = L * i
            increment = V.load(k1, m) + 2.0 * V.load(k2, m) + 2.0 * V.load(k3, m)
            xi = V.load(x, m) + dt / 6.0 * (increment + V.load(k4, m))
            V.store(x, m, xi)
            bad = bad + xi * 0.0  # NaN in a lane with a non-finite entry
        for lane in range(count):
            if alive[lane] and not V.get(bad, lane) == 0.0:
                status[first + lane] = NONFINITE
                fail_t[first + lane] = t + dt
        if retire_failed(first, count, status, alive, out, x, p):
            return False
    return True
