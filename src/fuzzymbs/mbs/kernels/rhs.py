"""The right-hand side of the equations of motion, LANES samples (lanes) per vector.

Every sample of a study integrates the same equations with other parameter
values, so LANES of them share each instruction: every per-sample quantity is a
:mod:`~fuzzymbs.mbs.kernels.simd` vector, stored lane-minor (element ``i`` of
lane ``l`` at ``L i + l``, ``L = LANES``). A single sample runs as a block whose lanes
repeat it (docs/benchmarks.md measures what that costs).

All system data arrive as one tuple of flat arrays (built by
:meth:`fuzzymbs.mbs.system.System.compile`, layout documented there); the
per-sample scalars (stiffnesses, forces, penalty, friction, speeds) are a
parameter row per lane. No allocation happens inside a time step: each block
allocates its work arrays once (:func:`make_work`). BLAS is not used.

State of one sample: ``x = [coordinates (n), velocities (n)]``, coordinates
body by body (translations s, then modal coordinates q).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.contact import JREC, contact_pass, max_slaves
from fuzzymbs.mbs.kernels.kinematics import (
    body_row,
    frame_rotations,
    map_node_forces,
    node_kinematics,
    profile_lanes,
)
from fuzzymbs.mbs.kernels.layout import (
    B_DOF0,
    B_MAT0,
    B_NM,
    B_NTR,
    C_MBODY,
    C_NSLAVE,
    C_SBODY,
    KIND_ROTATING,
    KIND_TRANSLATING,
    S_COS,
    S_SCHUR,
    S_SIN,
    SCRATCH,
)
from fuzzymbs.mbs.kernels.threads import for_each_range

L = V.LANES


@nb.njit(cache=True)
def make_work(sysdata):
    """Work arrays of one block (all flat, lane-minor).

    ``(q_gen (n L), node_x, node_v, node_f (tracked 3 L), rot (bodies 3 L): angle,
    speed, acceleration, rot_a (bodies 9 L), scratch (SCRATCH L), cells (7 L) int,
    rot3 (3, 3), charts (2 slaves L): chart coordinates u, v of a pass's slaves,
    jrec (JREC slaves L), jnodes (4 slaves L) int: the contact record of the
    Jacobian (all passes' slaves), jflag (1,) int: 1 while the Jacobian records,
    w_rows, kq_rows, kv_rows (columns x 3 slaves L, largest pass): the Jacobian's
    gathered contact rows)``. Scratch rows: see the ``S_*`` constants.
    """
    ndof = sysdata[0]
    nbody = sysdata[1].shape[0]
    ntracked = sysdata[3].shape[0]
    ci = sysdata[11]
    all_slaves = 0
    gathered = 0
    for c in range(ci.shape[0]):
        all_slaves += ci[c, C_NSLAVE]
        _, _, ntr, nm, _, _ = body_row(sysdata[1], ci[c, C_SBODY])
        columns = ntr + nm
        if ci[c, C_MBODY] != ci[c, C_SBODY]:
            _, _, ntr, nm, _, _ = body_row(sysdata[1], ci[c, C_MBODY])
            columns += ntr + nm
        gathered = max(gathered, columns * 3 * ci[c, C_NSLAVE])
    return (
        np.zeros(ndof * L),
        np.zeros(ntracked * 3 * L),
        np.zeros(ntracked * 3 * L),
        np.zeros(ntracked * 3 * L),
        np.zeros(nbody * 3 * L),
        np.zeros(nbody * 9 * L),
        np.zeros(SCRATCH * L),
        np.zeros(7 * L, dtype=np.int64),
        np.zeros((3, 3)),
        np.zeros(2 * max_slaves(ci) * L),
        np.zeros(JREC * all_slaves * L),
        np.zeros(4 * all_slaves * L, dtype=np.int64),
        np.zeros(1, dtype=np.int64),
        np.zeros(gathered * L),
        np.zeros(gathered * L),
        np.zeros(gathered * L),
    )


@nb.njit(cache=True)
def set_lane(lanes, lane, values):
    """Lane ``lane`` of the lane-minor array ``lanes`` <- ``values`` (1-d, one sample's)."""
    for i in range(values.shape[0]):
        lanes[L * i + lane] = values[i]


@nb.njit(cache=True)
def get_lane(lanes, lane, values):
    """``values`` (1-d, one sample's) <- lane ``lane`` of the lane-minor array ``lanes``."""
    for i in range(values.shape[0]):
        values[i] = lanes[L * i + lane]


@nb.njit(cache=True)
def copy_lanes(src, dst, lanes):
    """``dst`` <- ``src`` in the lanes where ``lanes`` is True (lane-minor arrays)."""
    for lane in range(L):
        if lanes[lane]:
            for i in range(src.shape[0] // L):
                dst[L * i + lane] = src[L * i + lane]


@nb.njit(cache=True, fastmath=V.FAST, error_model="numpy", _nrt=V.NO_REFCOUNT)
def rhs(t, x, dx, p, sysdata, work):
    """Time derivatives ``dx (2n L)`` of the lane states ``x (2n L)`` at the lanes' times
    ``t (L,)``. Every caller in the package passes such an array (the same time in all
    lanes where they share a clock), so that this is compiled in one form; a float
    works too, in a form of its own.

    ``p (slots L)``: the lanes' parameter rows, lane-minor; ``work``: from
    :func:`make_work`. Generalised forces of springs, nodal forces and contact
    (through the nodes' kinematics), then the equations of motion body by body
    (mass-normalised modes: diagonal elastic part; rotating bodies' gyroscopic,
    centrifugal and Euler terms; translating bodies by the Schur complement of
    their mass matrix).
    """
    (
        ndof,
        bi,
        bf,
        node_xbar,
        dof_k2,
        dof_c,
        fpool,
        ipool,
        ptab,
        lg,
        nfi,
        ci,
        _,
    ) = sysdata
    q_gen, node_x, node_v, node_f, rot, rot_a, scratch, _, rot3 = work[:9]
    nbody = bi.shape[0]
    for i in range(ndof):
        V.store(dx, L * i, V.load(x, L * (ndof + i)))
        V.store(q_gen, L * i, V.splat(0.0))

    # prescribed rotations per lane (the speed is a parameter, so A differs by lane)
    frame_rotations(t, p, bi, bf, fpool, ptab, rot, rot_a, rot3)

    # linear spring/damper groups
    for g in range(lg.shape[0]):
        d0 = lg[g, 0]
        n = lg[g, 1]
        m0 = lg[g, 2]
        k = V.load(p, L * lg[g, 3])
        c = V.load(p, L * lg[g, 4])
        damped = False
        for lane in range(L):
            damped = damped or V.get(c, lane) != 0.0
        idx = ipool[d0 : d0 + n]
        for a in range(n):
            s = V.splat(0.0)
            row = fpool[m0 + a * n : m0 + (a + 1) * n]
            for bb in range(n):
                s = V.fma(V.splat(row[bb]), V.load(x, L * idx[bb]), s)
            s = s * k
            if damped:
                sd = V.splat(0.0)
                row_d = fpool[m0 + n * n + a * n : m0 + n * n + (a + 1) * n]
                for bb in range(n):
                    sd = V.fma(V.splat(row_d[bb]), V.load(x, L * (ndof + idx[bb])), sd)
                s = s + c * sd
            V.store(q_gen, L * idx[a], V.load(q_gen, L * idx[a]) - s)

    # nodal forces
    for f in range(nfi.shape[0]):
        b = nfi[f, 0]
        v0 = nfi[f, 1]
        magnitude = V.load(p, L * nfi[f, 3])
        if nfi[f, 2] >= 0:
            value, _, _ = profile_lanes(fpool, ptab, nfi[f, 2], t)
            magnitude = magnitude * value
        dof0 = bi[b, B_DOF0]
        if nfi[f, 4] == 0:
            for i in range(bi[b, B_NTR] + bi[b, B_NM]):
                d = L * (dof0 + i)
                V.store(q_gen, d, V.fma(magnitude, V.broadcast(fpool, v0 + i), V.load(q_gen, d)))
        else:
            nm = bi[b, B_NM]
            for lane in range(L):
                scratch[L * S_COS + lane] = np.cos(rot[L * 3 * b + lane])
                scratch[L * S_SIN + lane] = np.sin(rot[L * 3 * b + lane])
            c = V.load(scratch, L * S_COS)
            s = V.load(scratch, L * S_SIN)
            for j in range(nm):
                g = c * fpool[v0 + j] + (1.0 - c) * fpool[v0 + nm + j] - s * fpool[v0 + 2 * nm + j]
                d = L * (dof0 + j)
                V.store(q_gen, d, V.load(q_gen, d) + magnitude * g)

    if ci.shape[0] > 0:
        node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
        for i in range(node_f.shape[0]):
            node_f[i] = 0.0
        for c in range(ci.shape[0]):
            contact_pass(c, x, p, sysdata, work)
        map_node_forces(bi, bf, fpool, rot_a, node_f, q_gen)

    # equations of motion body by body
    for b in range(nbody):
        kind, dof0, ntr, nm, _, _ = body_row(bi, b)
        m0 = bi[b, B_MAT0]
        qd0 = dof0 + ntr
        for j in range(nm):
            d = qd0 + j
            damp = V.splat(dof_c[d]) * V.load(x, L * (ndof + d))
            V.store(q_gen, L * d, V.load(q_gen, L * d) - (damp + dof_k2[d] * V.load(x, L * d)))
        if kind == KIND_ROTATING and nm > 0:
            omega = V.load(rot, L * (3 * b + 1))
            alpha = V.load(rot, L * (3 * b + 2))
            g0 = m0
            c0 = m0 + nm * nm
            l0 = m0 + 2 * nm * nm
            e0 = l0 + nm
            w2 = omega * omega
            for j in range(nm):
                sg = V.splat(0.0)
                sgq = V.splat(0.0)
                sc = V.splat(0.0)
                for k in range(nm):
                    gk = V.broadcast(fpool, g0 + j * nm + k)
                    qk = V.load(x, L * (qd0 + k))
                    sg = V.fma(gk, V.load(x, L * (ndof + qd0 + k)), sg)
                    sgq = V.fma(gk, qk, sgq)
                    sc = V.fma(V.broadcast(fpool, c0 + j * nm + k), qk, sc)
                s = w2 * (sc + fpool[l0 + j]) + alpha * (sgq + fpool[e0 + j]) + 2.0 * omega * sg
                d = L * (qd0 + j)
                V.store(q_gen, d, V.load(q_gen, d) - s)
        if kind == KIND_TRANSLATING:
            # Schur complement of [[m P P^T, B], [B^T, I]]: s'' = S^-1 (f_s - B f_q)
            s0 = m0
            b0 = m0 + ntr * ntr
            for a in range(ntr):
                r = V.load(q_gen, L * (dof0 + a))
                for j in range(nm):
                    r = r - fpool[b0 + a * nm + j] * V.load(q_gen, L * (qd0 + j))
                V.store(scratch, L * (S_SCHUR + a), r)  # ntr <= 3
            for a in range(ntr):
                s = V.splat(0.0)
                for a2 in range(ntr):
                    rhs_a2 = V.load(scratch, L * (S_SCHUR + a2))
                    s = V.fma(V.broadcast(fpool, s0 + a * ntr + a2), rhs_a2, s)
                V.store(dx, L * (ndof + dof0 + a), s)
            for j in range(nm):
                r = V.load(q_gen, L * (qd0 + j))
                for a in range(ntr):
                    r = r - fpool[b0 + a * nm + j] * V.load(dx, L * (ndof + dof0 + a))
                V.store(dx, L * (ndof + qd0 + j), r)
        else:
            for j in range(nm):
                V.store(dx, L * (ndof + qd0 + j), V.load(q_gen, L * (qd0 + j)))


@nb.njit(cache=True)
def rhs_sample(t, x, p, sysdata, work):
    """Time derivative ``(2n,)`` of one sample's state ``x (2n,)`` with parameter row
    ``p (slots,)``, on the calling thread: all lanes repeat the sample.

    For callers that evaluate one state at a time (SciPy's integrators); a
    batch of states goes through :func:`rhs_batch`.
    """
    nstate = x.shape[0]
    xl = np.empty(nstate * L)
    dxl = np.empty(nstate * L)
    pl = np.empty(p.shape[0] * L)
    for lane in range(L):
        set_lane(xl, lane, x)
        set_lane(pl, lane, p)
    rhs(np.full(L, t), xl, dxl, pl, sysdata, work)
    dx = np.empty(nstate)
    get_lane(dxl, np.int64(0), dx)  # lane 0 as an int64: a literal would compile it again
    return dx


def rhs_batch(sysdata, params, rows, times, states, out) -> None:
    """``out[i] = f(times[i], states[i])`` with parameter row ``params[rows[i]]``.

    ``states``, ``out``: (m, 2n). L consecutive states with equal times share a
    block; a block whose times differ evaluates each state in lanes of its own.
    The blocks are split into one contiguous range per thread.
    """
    m = states.shape[0]

    def run(start: int, stop: int) -> None:
        rhs_blocks(sysdata, params, rows, times, states, out, start, stop)

    for_each_range(-(-m // L), run, tasks=nb.get_num_threads())


@nb.njit(cache=True, nogil=True)
def rhs_blocks(sysdata, params, rows, times, states, out, start, stop):
    """Blocks ``start .. stop - 1`` of :func:`rhs_batch` on the calling thread."""
    m = states.shape[0]
    nstate = states.shape[1]
    nslots = params.shape[1]
    work = make_work(sysdata)
    x = np.empty(nstate * L)
    dx = np.empty(nstate * L)
    p = np.empty(nslots * L)
    clock = np.empty(L)
    for block in range(start, stop):
        first = block * L
        count = min(L, m - first)
        same_time = True
        for lane in range(1, count):
            same_time = same_time and times[first + lane] == times[first]
        groups = 1 if same_time else count
        for g in range(groups):
            for lane in range(L):
                # lanes beyond the group's states repeat its last one
                src = first + (min(lane, count - 1) if same_time else g)
                set_lane(x, lane, states[src])
                set_lane(p, lane, params[rows[src]])
            clock[:] = times[first + (0 if same_time else g)]
            rhs(clock, x, dx, p, sysdata, work)
            for lane in range(count if same_time else 1):
                get_lane(dx, lane, out[first + (lane if same_time else g)])
