"""Lockstep kernels: four samples per SIMD vector through the right-hand side.

Every sample of a study integrates the same equations with other parameter
values, so four of them (lanes) can share each instruction: every per-sample
quantity is a :mod:`fuzzymbs.mbs.simd` vector, stored lane-minor (element
``i`` of lane ``l`` at ``4 i + l``). The formulas are those of
:func:`fuzzymbs.mbs.kernels.rhs`, line by line; results agree with the
per-sample kernel to rounding (FMA contraction and summation order differ).

* Mode-shape products ``U = Psi q`` and ``Q = Psi^T F`` read each mode-shape
  element once for four lanes.
* A contact slave almost always finds the same master cell in all lanes (the
  samples differ by per cent, the cells are millimetres): then the master
  nodes' positions, velocities and reactions are vector loads and stores.
  Lanes in different cells gather per lane, with the same arithmetic.
* "On the patch", "gap < 0" and "compressive" are selects, not branches.

A lane whose sample fails (non-finite state, output beyond its bound) is
flagged and then repeats a healthy lane of its block, so that it neither
spreads NaN nor pushes the block off the shared cells; its outputs are NaN as
in :func:`fuzzymbs.mbs.kernels.rk4_batch`. Padding lanes of the last block
repeat its last sample. :func:`rk4_auto` runs blocks and single samples in one
parallel call.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs import simd as V
from fuzzymbs.mbs.kernels import (
    _ATAN_COEF,
    _TAN_PI_8,
    _TWO_PI,
    B_DOF0,
    B_KIND,
    B_MAT0,
    B_NM,
    B_NODE0,
    B_NODE1,
    B_NTR,
    B_PROF,
    B_PSI0,
    B_PSIT0,
    B_SPEED,
    C_GRID0,
    C_KIND,
    C_MBODY,
    C_MU,
    C_NORMAL0,
    C_NSLAVE,
    C_NU,
    C_NV,
    C_PEN,
    C_PERIODIC,
    C_SLAVE0,
    C_U0,
    C_V0,
    FAST,
    KIND_ROTATING,
    KIND_TRANSLATING,
    NONFINITE,
    OK,
    OUT_OF_BOUND,
    _profile,
    _rotation,
    integrate_sample,
    locate,
    max_slaves,
    pass_scales,
)

L = V.LANES
# scratch rows (each L wide): Schur right-hand sides / cos, sin of the rotation angle;
# per-lane cell coordinates and on-patch flags; gathered master points and normals
S_SCHUR, S_COS, S_SIN = 0, 0, 1
S_XI, S_ETA, S_ON, S_XM, S_NRM = 3, 4, 5, 6, 12
SCRATCH = 15
# rows of the integer cell table: cell id, i, j, then the four master nodes' offsets
I_CELL, I_U, I_V, I_NODES = 0, 1, 2, 3


@nb.njit(cache=True)
def make_lane_work(sysdata):
    """Work arrays of one block (all flat, lane-minor).

    ``(q_gen (n L), node_x, node_v, node_f (tracked 3 L), rot (bodies 3 L): angle,
    speed, acceleration, rot_a (bodies 9 L), scratch (SCRATCH L), cells (7 L) int,
    rot3 (3, 3), charts (2 slaves L): chart coordinates u, v of a pass's slaves)``.
    Scratch rows: see the ``S_*`` constants.
    """
    ndof = sysdata[0]
    nbody = sysdata[1].shape[0]
    ntracked = sysdata[3].shape[0]
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
        np.zeros(2 * max_slaves(sysdata[11]) * L),
    )


@nb.njit(cache=True, fastmath=FAST, error_model="numpy")
def rhs_lanes(t, x, dx, p, sysdata, work):
    """Time derivatives ``dx (2n L)`` of the lane states ``x (2n L)`` at time t.

    ``p (slots L)``: the lanes' parameter rows, lane-minor.
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
    q_gen, node_x, node_v, node_f, rot, rot_a, scratch, _, rot3, _ = work
    nbody = bi.shape[0]
    for i in range(ndof):
        V.store(dx, L * i, V.load(x, L * (ndof + i)))
        V.store(q_gen, L * i, V.splat(0.0))

    # prescribed rotations per lane (the speed is a parameter, so A differs by lane)
    for b in range(nbody):
        if bi[b, B_KIND] == KIND_ROTATING:
            speed = V.load(p, L * bi[b, B_SPEED])
            value, integral, slope = _profile(fpool, ptab, bi[b, B_PROF], t)
            V.store(rot, L * (3 * b), speed * integral)
            V.store(rot, L * (3 * b + 1), speed * value)
            V.store(rot, L * (3 * b + 2), speed * slope)
            for lane in range(L):
                _rotation(bf[b, 12:15], rot[L * 3 * b + lane], rot3)
                for r in range(3):
                    for c in range(3):
                        rot_a[L * (9 * b + 3 * r + c) + lane] = rot3[r, c]

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
            value, _, _ = _profile(fpool, ptab, nfi[f, 2], t)
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
        _node_kinematics_lanes(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
        for i in range(node_f.shape[0]):
            node_f[i] = 0.0
        for c in range(ci.shape[0]):
            _contact_pass_lanes(c, x, p, sysdata, work)
        _map_node_forces_lanes(bi, bf, fpool, rot_a, node_f, q_gen)

    # equations of motion body by body
    for b in range(nbody):
        kind = bi[b, B_KIND]
        dof0 = bi[b, B_DOF0]
        ntr = bi[b, B_NTR]
        nm = bi[b, B_NM]
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


@nb.njit(cache=True, fastmath=FAST)
def _node_kinematics_lanes(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v):
    """Inertial positions and velocities of the tracked nodes, four lanes per vector."""
    for b in range(bi.shape[0]):
        n0 = bi[b, B_NODE0]
        n1 = bi[b, B_NODE1]
        if n1 <= n0:
            continue
        kind = bi[b, B_KIND]
        dof0 = bi[b, B_DOF0]
        ntr = bi[b, B_NTR]
        nm = bi[b, B_NM]
        psit = bi[b, B_PSIT0]
        qd0 = dof0 + ntr
        width = 3 * (n1 - n0)
        base = 3 * n0
        # U = Psi q: four entries k of the transposed block per sweep over the modes, so
        # that eight independent FMA chains keep both FMA pipes busy
        k = 0
        while k < width:
            k1 = min(k + 1, width - 1)
            k2 = min(k + 2, width - 1)
            k3 = min(k + 3, width - 1)
            p0 = V.splat(0.0)
            p1 = V.splat(0.0)
            p2 = V.splat(0.0)
            p3 = V.splat(0.0)
            w0 = V.splat(0.0)
            w1 = V.splat(0.0)
            w2 = V.splat(0.0)
            w3 = V.splat(0.0)
            for j in range(nm):
                q = V.load(x, L * (qd0 + j))
                v = V.load(x, L * (ndof + qd0 + j))
                row = psit + j * width
                r0 = V.broadcast(fpool, row + k)
                r1 = V.broadcast(fpool, row + k1)
                r2 = V.broadcast(fpool, row + k2)
                r3 = V.broadcast(fpool, row + k3)
                p0 = V.fma(r0, q, p0)
                w0 = V.fma(r0, v, w0)
                p1 = V.fma(r1, q, p1)
                w1 = V.fma(r1, v, w1)
                p2 = V.fma(r2, q, p2)
                w2 = V.fma(r2, v, w2)
                p3 = V.fma(r3, q, p3)
                w3 = V.fma(r3, v, w3)
            # tail entries (k1..k3 clamped to the last one) are written repeatedly, same value
            V.store(node_x, L * (base + k3), p3)
            V.store(node_v, L * (base + k3), w3)
            V.store(node_x, L * (base + k2), p2)
            V.store(node_v, L * (base + k2), w2)
            V.store(node_x, L * (base + k1), p1)
            V.store(node_v, L * (base + k1), w1)
            V.store(node_x, L * (base + k), p0)
            V.store(node_v, L * (base + k), w0)
            k += 4
        if kind == KIND_ROTATING:
            # x = o + A y, v = A (Omega e x y + ydot), y = xbar + u
            om = V.load(rot, L * (3 * b + 1))
            e0 = bf[b, 12]
            e1 = bf[b, 13]
            e2 = bf[b, 14]
            r9 = L * 9 * b
            a00 = V.load(rot_a, r9)
            a01 = V.load(rot_a, r9 + L)
            a02 = V.load(rot_a, r9 + 2 * L)
            a10 = V.load(rot_a, r9 + 3 * L)
            a11 = V.load(rot_a, r9 + 4 * L)
            a12 = V.load(rot_a, r9 + 5 * L)
            a20 = V.load(rot_a, r9 + 6 * L)
            a21 = V.load(rot_a, r9 + 7 * L)
            a22 = V.load(rot_a, r9 + 8 * L)
            o0 = bf[b, 0]
            o1 = bf[b, 1]
            o2 = bf[b, 2]
            for i in range(n0, n1):
                m = L * 3 * i
                u0 = V.load(node_x, m) + node_xbar[i, 0]
                u1 = V.load(node_x, m + L) + node_xbar[i, 1]
                u2 = V.load(node_x, m + 2 * L) + node_xbar[i, 2]
                z0 = V.load(node_v, m) + om * (e1 * u2 - e2 * u1)
                z1 = V.load(node_v, m + L) + om * (e2 * u0 - e0 * u2)
                z2 = V.load(node_v, m + 2 * L) + om * (e0 * u1 - e1 * u0)
                V.store(node_x, m, a00 * u0 + a01 * u1 + a02 * u2 + o0)
                V.store(node_x, m + L, a10 * u0 + a11 * u1 + a12 * u2 + o1)
                V.store(node_x, m + 2 * L, a20 * u0 + a21 * u1 + a22 * u2 + o2)
                V.store(node_v, m, a00 * z0 + a01 * z1 + a02 * z2)
                V.store(node_v, m + L, a10 * z0 + a11 * z1 + a12 * z2)
                V.store(node_v, m + 2 * L, a20 * z0 + a21 * z1 + a22 * z2)
        else:
            r0 = V.splat(bf[b, 0])
            r1 = V.splat(bf[b, 1])
            r2 = V.splat(bf[b, 2])
            w0 = V.splat(0.0)
            w1 = V.splat(0.0)
            w2 = V.splat(0.0)
            for a in range(ntr):
                sa = V.load(x, L * (dof0 + a))
                va = V.load(x, L * (ndof + dof0 + a))
                r0 = r0 + bf[b, 3 + 3 * a] * sa
                r1 = r1 + bf[b, 4 + 3 * a] * sa
                r2 = r2 + bf[b, 5 + 3 * a] * sa
                w0 = w0 + bf[b, 3 + 3 * a] * va
                w1 = w1 + bf[b, 4 + 3 * a] * va
                w2 = w2 + bf[b, 5 + 3 * a] * va
            for i in range(n0, n1):
                m = L * 3 * i
                V.store(node_x, m, V.load(node_x, m) + (r0 + node_xbar[i, 0]))
                V.store(node_x, m + L, V.load(node_x, m + L) + (r1 + node_xbar[i, 1]))
                V.store(node_x, m + 2 * L, V.load(node_x, m + 2 * L) + (r2 + node_xbar[i, 2]))
                V.store(node_v, m, V.load(node_v, m) + w0)
                V.store(node_v, m + L, V.load(node_v, m + L) + w1)
                V.store(node_v, m + 2 * L, V.load(node_v, m + 2 * L) + w2)


@nb.njit(cache=True, fastmath=FAST, inline="always")
def _atan2_lanes(y, x):
    """:func:`fuzzymbs.mbs.kernels.atan2` per lane (same operations, selects)."""
    zero = V.splat(0.0)
    ax = V.vabs(x)
    ay = V.vabs(y)
    num = V.where_lt(ax, ay, ax, ay)
    den = V.where_lt(ax, ay, ay, ax)
    safe_den = V.where_eq(den, zero, V.splat(1.0), den)
    t = num / safe_den
    limit = V.splat(_TAN_PI_8)
    shift = V.where_lt(limit, t, V.splat(0.25 * np.pi), zero)
    t = V.where_lt(limit, t, (t - 1.0) / (t + 1.0), t)
    z = t * t
    poly = V.splat(_ATAN_COEF[9])
    for k in range(8, -1, -1):
        poly = V.fma(poly, z, V.splat(_ATAN_COEF[k]))
    angle = V.fma(t, poly, shift)
    angle = V.where_lt(ax, ay, 0.5 * np.pi - angle, angle)
    angle = V.where_lt(x, zero, np.pi - angle, angle)
    angle = V.where_lt(y, zero, -angle, angle)
    return V.where_eq(den, zero, zero, angle)


@nb.njit(cache=True, inline="always")
def _cells_per_lane(u_vec, v_vec, ugrid, vgrid, periodic, scales, scratch, cells):
    """Master cell of each lane by the scalar :func:`~fuzzymbs.mbs.kernels.locate`
    (the general path: any grid, lanes in different cells).

    Writes xi, eta, on (scratch rows S_XI, S_ETA, S_ON) and cell, i, j (cells
    rows); a lane off the patch gets on = 0 and cell 0. Returns (all lanes in
    one cell, any lane on the patch).
    """
    nv = vgrid.shape[0]
    shared = True
    any_on = False
    for lane in range(L):
        on, i, j, xi, eta = locate(
            V.get(u_vec, lane), V.get(v_vec, lane), ugrid, vgrid, periodic, scales
        )
        any_on = any_on or on
        scratch[L * S_XI + lane] = xi
        scratch[L * S_ETA + lane] = eta
        scratch[L * S_ON + lane] = 1.0 if on else 0.0
        cell = i * nv + j
        cells[L * I_CELL + lane] = cell
        cells[L * I_U + lane] = i
        cells[L * I_V + lane] = j
        if lane > 0 and cell != cells[L * I_CELL]:
            shared = False
    return shared, any_on


@nb.njit(cache=True, fastmath=FAST, error_model="numpy")
def _contact_pass_lanes(c, x, p, sysdata, work):
    """Penalty normal force and regularised Coulomb friction of pass c, four lanes.

    Reads the lanes' node positions and velocities from ``work`` (filled by the
    node kinematics) and adds the contact forces to its node forces.
    """
    bi, bf, fpool, ipool, ci, cf = (
        sysdata[1],
        sysdata[2],
        sysdata[6],
        sysdata[7],
        sysdata[11],
        sysdata[12],
    )
    node_x, node_v, node_f, rot_a = work[1], work[2], work[3], work[5]
    scratch, cells, charts = work[6], work[7], work[9]
    mb = ci[c, C_MBODY]
    nu = ci[c, C_NU]
    nv = ci[c, C_NV]
    periodic = ci[c, C_PERIODIC] == 1
    ugrid = fpool[ci[c, C_U0] : ci[c, C_U0] + nu]
    vgrid = fpool[ci[c, C_V0] : ci[c, C_V0] + nv]
    grid = ipool[ci[c, C_GRID0] : ci[c, C_GRID0] + nu * nv]
    ncv = nv if periodic else nv - 1
    normals = fpool[ci[c, C_NORMAL0] : ci[c, C_NORMAL0] + 3 * (nu - 1) * ncv]
    slaves = ipool[ci[c, C_SLAVE0] : ci[c, C_SLAVE0] + ci[c, C_NSLAVE]]
    polar = ci[c, C_KIND] == 1
    penalty = V.load(p, L * ci[c, C_PEN])
    mu = V.load(p, L * ci[c, C_MU])
    eps2 = V.splat(cf[c, 9] * cf[c, 9])
    damping = cf[c, 10]
    kinetic = damping != 0.0
    for lane in range(L):
        kinetic = kinetic or V.get(mu, lane) != 0.0
    zero = V.splat(0.0)
    # master chart frame per lane: inertial axes ua, va and offsets cu, cv
    kind = bi[mb, B_KIND]
    rotating = kind == KIND_ROTATING
    o0 = V.splat(bf[mb, 0])
    o1 = V.splat(bf[mb, 1])
    o2 = V.splat(bf[mb, 2])
    if kind == KIND_TRANSLATING:
        dof0 = bi[mb, B_DOF0]
        for a in range(bi[mb, B_NTR]):
            sa = V.load(x, L * (dof0 + a))
            o0 = o0 + bf[mb, 3 + 3 * a] * sa
            o1 = o1 + bf[mb, 4 + 3 * a] * sa
            o2 = o2 + bf[mb, 5 + 3 * a] * sa
    if rotating:
        r9 = L * 9 * mb
        a00 = V.load(rot_a, r9)
        a01 = V.load(rot_a, r9 + L)
        a02 = V.load(rot_a, r9 + 2 * L)
        a10 = V.load(rot_a, r9 + 3 * L)
        a11 = V.load(rot_a, r9 + 4 * L)
        a12 = V.load(rot_a, r9 + 5 * L)
        a20 = V.load(rot_a, r9 + 6 * L)
        a21 = V.load(rot_a, r9 + 7 * L)
        a22 = V.load(rot_a, r9 + 8 * L)
    else:
        one = V.splat(1.0)
        a00, a01, a02 = one, zero, zero
        a10, a11, a12 = zero, one, zero
        a20, a21, a22 = zero, zero, one
    ua0 = a00 * cf[c, 3] + a01 * cf[c, 4] + a02 * cf[c, 5]
    ua1 = a10 * cf[c, 3] + a11 * cf[c, 4] + a12 * cf[c, 5]
    ua2 = a20 * cf[c, 3] + a21 * cf[c, 4] + a22 * cf[c, 5]
    va0 = a00 * cf[c, 6] + a01 * cf[c, 7] + a02 * cf[c, 8]
    va1 = a10 * cf[c, 6] + a11 * cf[c, 7] + a12 * cf[c, 8]
    va2 = a20 * cf[c, 6] + a21 * cf[c, 7] + a22 * cf[c, 8]
    chart_o_u = cf[c, 0] * cf[c, 3] + cf[c, 1] * cf[c, 4] + cf[c, 2] * cf[c, 5]
    chart_o_v = cf[c, 0] * cf[c, 6] + cf[c, 1] * cf[c, 7] + cf[c, 2] * cf[c, 8]
    cu = o0 * ua0 + o1 * ua1 + o2 * ua2 + chart_o_u
    cv = o0 * va0 + o1 * va1 + o2 * va2 + chart_o_v
    u_first = ugrid[0]
    v_first = vgrid[0]
    v_cells = nv if periodic else nv - 1
    scales = pass_scales(cf, c)
    u_scale, u_uniform, v_scale, v_uniform = scales
    one = V.splat(1.0)
    # chart coordinates of all slaves first: independent, long-latency (sqrt, atan2)
    # work that the out-of-order core overlaps across slaves, and fewer live registers
    # in the main loop below
    nslave = slaves.shape[0]
    for k in range(nslave):
        ms = L * 3 * slaves[k]
        xs0 = V.load(node_x, ms)
        xs1 = V.load(node_x, ms + L)
        xs2 = V.load(node_x, ms + 2 * L)
        a1 = xs0 * ua0 + xs1 * ua1 + xs2 * ua2 - cu
        a2 = xs0 * va0 + xs1 * va1 + xs2 * va2 - cv
        if polar:
            V.store(charts, L * k, V.sqrt(a1 * a1 + a2 * a2))
            V.store(charts, L * (nslave + k), _atan2_lanes(a2, a1))
        else:
            V.store(charts, L * k, a1)
            V.store(charts, L * (nslave + k), a2)
    for k in range(nslave):
        s = slaves[k]
        ms = L * 3 * s
        xs0 = V.load(node_x, ms)
        xs1 = V.load(node_x, ms + L)
        xs2 = V.load(node_x, ms + 2 * L)
        u_vec = V.load(charts, L * k)
        v_vec = V.load(charts, L * (nslave + k))
        # master cell of every lane: vectorised on uniform grids when all lanes share
        # it (the usual case), else per lane
        fast = False
        if u_uniform and v_uniform:
            fu = (u_vec - u_first) * u_scale
            if periodic:
                v_vec = V.where_lt(v_vec, V.splat(v_first), v_vec + _TWO_PI, v_vec)
                v_vec = V.where_le(V.splat(v_first + _TWO_PI), v_vec, v_vec - _TWO_PI, v_vec)
            fv = (v_vec - v_first) * v_scale
            on = V.where_le(fu, V.splat(nu - 1.0), one, zero)
            on = V.where_le(zero, fu, on, zero)
            on = V.where_le(fv, V.splat(float(v_cells)), on, zero)
            on = V.where_le(zero, fv, on, zero)
            i_f = V.floor(fu)
            i_f = V.where_lt(V.splat(nu - 2.0), i_f, V.splat(nu - 2.0), i_f)
            i_f = V.where_lt(i_f, zero, zero, i_f)
            j_f = V.floor(fv)
            j_f = V.where_lt(V.splat(v_cells - 1.0), j_f, V.splat(v_cells - 1.0), j_f)
            j_f = V.where_lt(j_f, zero, zero, j_f)
            cell_f = i_f * float(nv) + j_f
            c0 = V.get(cell_f, 0)
            fast = c0 == V.get(cell_f, 1) and c0 == V.get(cell_f, 2) and c0 == V.get(cell_f, 3)
        if fast:
            if V.get(on, 0) + V.get(on, 1) + V.get(on, 2) + V.get(on, 3) == 0.0:
                continue
            xi = fu - i_f
            eta = fv - j_f
            i = int(V.get(i_f, 0))
            j = int(V.get(j_f, 0))
            shared = True
        else:
            shared, any_on = _cells_per_lane(
                u_vec, v_vec, ugrid, vgrid, periodic, scales, scratch, cells
            )
            if not any_on:
                continue
            xi = V.load(scratch, L * S_XI)
            eta = V.load(scratch, L * S_ETA)
            on = V.load(scratch, L * S_ON)
            i = cells[L * I_U]
            j = cells[L * I_V]
        wa = (1.0 - xi) * (1.0 - eta)
        wb = xi * (1.0 - eta)
        wc = xi * eta
        wd = (1.0 - xi) * eta
        if shared:
            j1 = j + 1 if j + 1 < nv else 0
            na = L * 3 * grid[i * nv + j]
            nb_ = L * 3 * grid[(i + 1) * nv + j]
            nc = L * 3 * grid[(i + 1) * nv + j1]
            nd = L * 3 * grid[i * nv + j1]
            k3 = 3 * (i * ncv + j)
            m0 = V.splat(normals[k3])
            m1 = V.splat(normals[k3 + 1])
            m2 = V.splat(normals[k3 + 2])
            xm0 = wa * V.load(node_x, na) + wb * V.load(node_x, nb_)
            xm0 = xm0 + wc * V.load(node_x, nc) + wd * V.load(node_x, nd)
            xm1 = wa * V.load(node_x, na + L) + wb * V.load(node_x, nb_ + L)
            xm1 = xm1 + wc * V.load(node_x, nc + L) + wd * V.load(node_x, nd + L)
            xm2 = wa * V.load(node_x, na + 2 * L) + wb * V.load(node_x, nb_ + 2 * L)
            xm2 = xm2 + wc * V.load(node_x, nc + 2 * L) + wd * V.load(node_x, nd + 2 * L)
            vm0 = wa * V.load(node_v, na) + wb * V.load(node_v, nb_)
            vm0 = vm0 + wc * V.load(node_v, nc) + wd * V.load(node_v, nd)
            vm1 = wa * V.load(node_v, na + L) + wb * V.load(node_v, nb_ + L)
            vm1 = vm1 + wc * V.load(node_v, nc + L) + wd * V.load(node_v, nd + L)
            vm2 = wa * V.load(node_v, na + 2 * L) + wb * V.load(node_v, nb_ + 2 * L)
            vm2 = vm2 + wc * V.load(node_v, nc + 2 * L) + wd * V.load(node_v, nd + 2 * L)
        else:
            xm = scratch[L * S_XM : L * (S_XM + 6)]
            nrm = scratch[L * S_NRM : L * (S_NRM + 3)]
            for lane in range(L):
                i = cells[L * I_U + lane]
                j = cells[L * I_V + lane]
                j1 = j + 1 if j + 1 < nv else 0
                ga = L * 3 * grid[i * nv + j] + lane
                gb = L * 3 * grid[(i + 1) * nv + j] + lane
                gc = L * 3 * grid[(i + 1) * nv + j1] + lane
                gd = L * 3 * grid[i * nv + j1] + lane
                cells[L * I_NODES + lane] = ga
                cells[L * (I_NODES + 1) + lane] = gb
                cells[L * (I_NODES + 2) + lane] = gc
                cells[L * (I_NODES + 3) + lane] = gd
                wal = V.get(wa, lane)
                wbl = V.get(wb, lane)
                wcl = V.get(wc, lane)
                wdl = V.get(wd, lane)
                for d in range(3):
                    o = d * L
                    xm[o + lane] = (
                        wal * node_x[ga + o]
                        + wbl * node_x[gb + o]
                        + wcl * node_x[gc + o]
                        + wdl * node_x[gd + o]
                    )
                    xm[3 * L + o + lane] = (
                        wal * node_v[ga + o]
                        + wbl * node_v[gb + o]
                        + wcl * node_v[gc + o]
                        + wdl * node_v[gd + o]
                    )
                    nrm[o + lane] = normals[3 * (i * ncv + j) + d]
            m0 = V.load(nrm, 0)
            m1 = V.load(nrm, L)
            m2 = V.load(nrm, 2 * L)
            xm0 = V.load(xm, 0)
            xm1 = V.load(xm, L)
            xm2 = V.load(xm, 2 * L)
            vm0 = V.load(xm, 3 * L)
            vm1 = V.load(xm, 4 * L)
            vm2 = V.load(xm, 5 * L)
            na = nb_ = nc = nd = 0
        if rotating:
            n0 = a00 * m0 + a01 * m1 + a02 * m2
            n1 = a10 * m0 + a11 * m1 + a12 * m2
            n2 = a20 * m0 + a21 * m1 + a22 * m2
        else:
            n0 = m0
            n1 = m1
            n2 = m2
        gap = n0 * (xs0 - xm0) + n1 * (xs1 - xm1) + n2 * (xs2 - xm2)
        if kinetic:
            vr0 = V.load(node_v, ms) - vm0
            vr1 = V.load(node_v, ms + L) - vm1
            vr2 = V.load(node_v, ms + 2 * L) - vm2
            vn = n0 * vr0 + n1 * vr1 + n2 * vr2
            fn = -(penalty * gap) - damping * vn
            vt0 = vr0 - vn * n0
            vt1 = vr1 - vn * n1
            vt2 = vr2 - vn * n2
            scale = -(mu * fn) / V.sqrt(vt0 * vt0 + vt1 * vt1 + vt2 * vt2 + eps2)
            scale = V.where_eq(mu, zero, zero, scale)  # a frictionless lane: no 0 / 0
            f0 = fn * n0 + scale * vt0
            f1 = fn * n1 + scale * vt1
            f2 = fn * n2 + scale * vt2
            # in contact: on the patch, gap < 0 and compressive normal force
            f0 = V.where_lt(zero, fn, f0, zero)
            f1 = V.where_lt(zero, fn, f1, zero)
            f2 = V.where_lt(zero, fn, f2, zero)
        else:
            fn = -(penalty * gap)
            f0 = fn * n0
            f1 = fn * n1
            f2 = fn * n2
        f0 = V.where_lt(gap, zero, V.where_lt(zero, on, f0, zero), zero)
        f1 = V.where_lt(gap, zero, V.where_lt(zero, on, f1, zero), zero)
        f2 = V.where_lt(gap, zero, V.where_lt(zero, on, f2, zero), zero)
        V.store(node_f, ms, V.load(node_f, ms) + f0)
        V.store(node_f, ms + L, V.load(node_f, ms + L) + f1)
        V.store(node_f, ms + 2 * L, V.load(node_f, ms + 2 * L) + f2)
        if shared:
            for node, w in ((na, wa), (nb_, wb), (nc, wc), (nd, wd)):
                V.store(node_f, node, V.load(node_f, node) - w * f0)
                V.store(node_f, node + L, V.load(node_f, node + L) - w * f1)
                V.store(node_f, node + 2 * L, V.load(node_f, node + 2 * L) - w * f2)
        else:
            for lane in range(L):
                g0 = V.get(f0, lane)
                g1 = V.get(f1, lane)
                g2 = V.get(f2, lane)
                if g0 == 0.0 and g1 == 0.0 and g2 == 0.0:
                    continue
                for q in range(4):
                    node = cells[L * (I_NODES + q) + lane]
                    w = V.get((wa, wb, wc, wd)[q], lane)
                    node_f[node] -= w * g0
                    node_f[node + L] -= w * g1
                    node_f[node + 2 * L] -= w * g2


@nb.njit(cache=True, inline="always")
def _loaded(f0, f1, f2):
    """True if the force (f0, f1, f2) is not zero in some lane (NaN counts as loaded)."""
    size = V.vabs(f0) + V.vabs(f1) + V.vabs(f2)
    return (
        V.get(size, 0) != 0.0
        or V.get(size, 1) != 0.0
        or V.get(size, 2) != 0.0
        or V.get(size, 3) != 0.0
    )


@nb.njit(cache=True, fastmath=FAST)
def _map_node_forces_lanes(bi, bf, fpool, rot_a, node_f, q_gen):
    """Generalised forces of the tracked nodes' forces, four lanes per vector.

    As :func:`fuzzymbs.mbs.kernels._map_node_forces`: a node without force in
    any lane is skipped; a body with more than a quarter of its nodes loaded
    takes the dense transposed product.
    """
    zero = V.splat(0.0)
    for b in range(bi.shape[0]):
        n0 = bi[b, B_NODE0]
        n1 = bi[b, B_NODE1]
        if n1 <= n0:
            continue
        kind = bi[b, B_KIND]
        dof0 = bi[b, B_DOF0]
        ntr = bi[b, B_NTR]
        nm = bi[b, B_NM]
        qd0 = dof0 + ntr
        loaded = 0
        sum0 = zero
        sum1 = zero
        sum2 = zero
        for i in range(n0, n1):
            m = L * 3 * i
            f0 = V.load(node_f, m)
            f1 = V.load(node_f, m + L)
            f2 = V.load(node_f, m + 2 * L)
            sum0 = sum0 + f0
            sum1 = sum1 + f1
            sum2 = sum2 + f2
            loaded += _loaded(f0, f1, f2)
        if loaded == 0:
            continue
        for a in range(ntr):
            d = L * (dof0 + a)
            g = bf[b, 3 + 3 * a] * sum0 + bf[b, 4 + 3 * a] * sum1 + bf[b, 5 + 3 * a] * sum2
            V.store(q_gen, d, V.load(q_gen, d) + g)
        if kind == KIND_ROTATING:  # to the body frame, in place
            r9 = L * 9 * b
            a00 = V.load(rot_a, r9)
            a01 = V.load(rot_a, r9 + L)
            a02 = V.load(rot_a, r9 + 2 * L)
            a10 = V.load(rot_a, r9 + 3 * L)
            a11 = V.load(rot_a, r9 + 4 * L)
            a12 = V.load(rot_a, r9 + 5 * L)
            a20 = V.load(rot_a, r9 + 6 * L)
            a21 = V.load(rot_a, r9 + 7 * L)
            a22 = V.load(rot_a, r9 + 8 * L)
            for i in range(n0, n1):
                m = L * 3 * i
                f0 = V.load(node_f, m)
                f1 = V.load(node_f, m + L)
                f2 = V.load(node_f, m + 2 * L)
                V.store(node_f, m, a00 * f0 + a10 * f1 + a20 * f2)
                V.store(node_f, m + L, a01 * f0 + a11 * f1 + a21 * f2)
                V.store(node_f, m + 2 * L, a02 * f0 + a12 * f1 + a22 * f2)
        if nm == 0:
            continue
        width = 3 * (n1 - n0)
        base = L * 3 * n0
        if 4 * loaded > n1 - n0:
            psit = bi[b, B_PSIT0]
            # four modes per sweep over the entries, even and odd entries apart: eight
            # independent FMA chains (modes beyond nm are clamped and added once only)
            j = 0
            while j < nm:
                j1 = min(j + 1, nm - 1)
                j2 = min(j + 2, nm - 1)
                j3 = min(j + 3, nm - 1)
                e0 = zero
                e1 = zero
                e2 = zero
                e3 = zero
                d0 = zero
                d1 = zero
                d2 = zero
                d3 = zero
                k = 0
                while k + 1 < width:
                    f = V.load(node_f, base + L * k)
                    g = V.load(node_f, base + L * (k + 1))
                    e0 = V.fma(V.broadcast(fpool, psit + j * width + k), f, e0)
                    e1 = V.fma(V.broadcast(fpool, psit + j1 * width + k), f, e1)
                    e2 = V.fma(V.broadcast(fpool, psit + j2 * width + k), f, e2)
                    e3 = V.fma(V.broadcast(fpool, psit + j3 * width + k), f, e3)
                    d0 = V.fma(V.broadcast(fpool, psit + j * width + k + 1), g, d0)
                    d1 = V.fma(V.broadcast(fpool, psit + j1 * width + k + 1), g, d1)
                    d2 = V.fma(V.broadcast(fpool, psit + j2 * width + k + 1), g, d2)
                    d3 = V.fma(V.broadcast(fpool, psit + j3 * width + k + 1), g, d3)
                    k += 2
                if k < width:
                    f = V.load(node_f, base + L * k)
                    e0 = V.fma(V.broadcast(fpool, psit + j * width + k), f, e0)
                    e1 = V.fma(V.broadcast(fpool, psit + j1 * width + k), f, e1)
                    e2 = V.fma(V.broadcast(fpool, psit + j2 * width + k), f, e2)
                    e3 = V.fma(V.broadcast(fpool, psit + j3 * width + k), f, e3)
                V.store(q_gen, L * (qd0 + j), V.load(q_gen, L * (qd0 + j)) + (e0 + d0))
                if j1 > j:
                    V.store(q_gen, L * (qd0 + j1), V.load(q_gen, L * (qd0 + j1)) + (e1 + d1))
                if j2 > j1:
                    V.store(q_gen, L * (qd0 + j2), V.load(q_gen, L * (qd0 + j2)) + (e2 + d2))
                if j3 > j2:
                    V.store(q_gen, L * (qd0 + j3), V.load(q_gen, L * (qd0 + j3)) + (e3 + d3))
                j += 4
            continue
        psi0 = bi[b, B_PSI0]
        for i in range(n0, n1):
            m = L * 3 * i
            f0 = V.load(node_f, m)
            f1 = V.load(node_f, m + L)
            f2 = V.load(node_f, m + 2 * L)
            if not _loaded(f0, f1, f2):
                continue
            row = psi0 + (i - n0) * 3 * nm
            for j in range(nm):
                d = L * (qd0 + j)
                g = V.broadcast(fpool, row + j) * f0 + V.broadcast(fpool, row + nm + j) * f1
                g = g + V.broadcast(fpool, row + 2 * nm + j) * f2
                V.store(q_gen, d, V.load(q_gen, d) + g)


@nb.njit(cache=True)
def _retire_failed(first, count, status, alive, out, x, p):
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


@nb.njit(cache=True, parallel=True)
def rk4_auto(
    sysdata, params, x0, t0, dt, n_steps, record_every, out_w, bound, out, status, fail_t, split
):
    """RK4 of a batch in one parallel call: samples ``[0, split)`` in blocks of four
    (the last one padded), samples ``[split, B)`` one by one (``split = B``: all in
    blocks; ``split = 0``: all one by one, as :func:`fuzzymbs.mbs.kernels.rk4_batch`).

    Arguments and results as :func:`fuzzymbs.mbs.kernels.rk4_batch`. The single
    samples are the first work items, so that with the usual static split of the
    items over the threads they share a thread with fewer blocks.
    """
    nsamples = params.shape[0]
    nsingle = nsamples - split
    nblocks = (split + L - 1) // L
    for item in nb.prange(nsingle + nblocks):
        if item < nsingle:
            integrate_sample(
                sysdata,
                params,
                x0,
                t0,
                dt,
                n_steps,
                record_every,
                out_w,
                bound,
                out,
                status,
                fail_t,
                split + item,
            )
        else:
            first = (item - nsingle) * L
            integrate_block(
                sysdata,
                params,
                x0,
                t0,
                dt,
                n_steps,
                record_every,
                out_w,
                bound,
                out,
                status,
                fail_t,
                first,
                min(L, split - first),
            )


@nb.njit(cache=True)
def integrate_block(
    sysdata,
    params,
    x0,
    t0,
    dt,
    n_steps,
    record_every,
    out_w,
    bound,
    out,
    status,
    fail_t,
    first,
    count,
):
    """RK4 of samples ``first .. first + count - 1`` (count <= 4) in lockstep, on the
    calling thread; lanes beyond count repeat the last of them."""
    nslots = params.shape[1]
    nstate = x0.shape[1]
    nout = out_w.shape[0]
    work = make_lane_work(sysdata)
    p = np.empty(nslots * L)
    x = np.empty(nstate * L)
    for lane in range(L):
        src = first + min(lane, count - 1)
        for i in range(nslots):
            p[L * i + lane] = params[src, i]
        for i in range(nstate):
            x[L * i + lane] = x0[src, i]
    k1 = np.empty(nstate * L)
    k2 = np.empty(nstate * L)
    k3 = np.empty(nstate * L)
    k4 = np.empty(nstate * L)
    xt = np.empty(nstate * L)
    alive = np.ones(L, dtype=np.bool_)
    for lane in range(count):
        status[first + lane] = OK
        fail_t[first + lane] = np.nan
    size = nstate * L
    rec = 0
    for step in range(n_steps + 1):
        t = t0 + step * dt
        if step % record_every == 0:
            for o in range(nout):
                y = V.splat(0.0)
                for i in range(nstate):
                    w = out_w[o, i]
                    if w != 0.0:
                        y = V.fma(V.splat(w), V.load(x, L * i), y)
                for lane in range(count):
                    if alive[lane]:
                        yl = V.get(y, lane)
                        out[first + lane, o, rec] = yl
                        if not abs(yl) <= bound[o]:  # also catches NaN
                            status[first + lane] = OUT_OF_BOUND if np.isfinite(yl) else NONFINITE
                            fail_t[first + lane] = t
            rec += 1
            if _retire_failed(first, count, status, alive, out, x, p):
                break
        if step == n_steps:
            break
        rhs_lanes(t, x, k1, p, sysdata, work)
        for m in range(size):
            xt[m] = x[m] + 0.5 * dt * k1[m]
        rhs_lanes(t + 0.5 * dt, xt, k2, p, sysdata, work)
        for m in range(size):
            xt[m] = x[m] + 0.5 * dt * k2[m]
        rhs_lanes(t + 0.5 * dt, xt, k3, p, sysdata, work)
        for m in range(size):
            xt[m] = x[m] + dt * k3[m]
        rhs_lanes(t + dt, xt, k4, p, sysdata, work)
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
        if _retire_failed(first, count, status, alive, out, x, p):
            break
