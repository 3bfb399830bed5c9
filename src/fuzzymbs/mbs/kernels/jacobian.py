"""Jacobian of the right-hand side, LANES samples (lanes) per call: the linearly implicit
integrators' matrix, assembled from the physics' own derivatives.

For the state ``x = [q, v]`` the right-hand side is ``[v, a(t, q, v)]``, so its
Jacobian is ``[[0, I], [A, B]]`` with ``A = da/dq`` and ``B = da/dv``
(n x n each). :func:`jacobian` evaluates the right-hand side once with the
contact passes recording the derivatives of their force law
(:func:`fuzzymbs.mbs.kernels.contact.record_force_law`) and assembles:

* the modal stiffness and damping (``-omega^2``, ``-2 zeta omega``), the rotating
  bodies' gyroscopic, centrifugal and Euler terms and the springs, exactly;
* each contact point's ``W^T (K W + C W_q)`` and ``W^T C W``, with ``W`` the
  3 x n map from the coordinates to the relative position of slave and master
  point (``sum_j sigma_j dx_j/dq``, sigma = 1 for the slave node and ``-w`` for
  the master nodes), ``W_q`` the same for the relative velocity's dependence on
  the rotating bodies' modal coordinates (``A Omega [e x] Psi``), ``K`` and
  ``C`` the force law's derivatives. The master weights and normal are held
  fixed: their change with the slave's tangential position is left out
  (docs/theory.md says what that costs);
* the translating bodies' mass inverse applied to the rows, as in
  :func:`fuzzymbs.mbs.kernels.rhs.rhs`.

Layout: ``jq[L * (n * i + j) + lane] = d a_i / d q_j`` (likewise ``jv``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.contact import JREC
from fuzzymbs.mbs.kernels.kinematics import body_row, frame_matrix
from fuzzymbs.mbs.kernels.layout import (
    B_MAT0,
    B_PSI0,
    C_MBODY,
    C_NSLAVE,
    C_SBODY,
    C_SLAVE0,
    KIND_ROTATING,
    KIND_TRANSLATING,
)
from fuzzymbs.mbs.kernels.rhs import rhs

L = V.LANES


@nb.njit(cache=True, fastmath=V.FAST, error_model="numpy")
def jacobian(t, x, p, sysdata, work, dx, jq, jv):
    """``dx`` <- the right-hand side at (t, x); ``jq``, ``jv`` <- ``da/dq``, ``da/dv``.

    Arguments as :func:`fuzzymbs.mbs.kernels.rhs.rhs`; ``jq`` and ``jv`` are
    ``n n L`` arrays (module docstring).
    """
    ndof, bi, bf = sysdata[0], sysdata[1], sysdata[2]
    dof_k2, dof_c, fpool, ipool, lg = sysdata[4], sysdata[5], sysdata[6], sysdata[7], sysdata[9]
    n = ndof
    work[12][0] = 1
    rhs(t, x, dx, p, sysdata, work)  # the frames, node kinematics and the contact record
    work[12][0] = 0
    rot, rot_a = work[4], work[5]
    jq[:] = 0.0
    jv[:] = 0.0
    zero = V.splat(0.0)

    # modal stiffness and damping; rotating bodies' gyroscopic, centrifugal, Euler terms
    for b in range(bi.shape[0]):
        kind, dof0, ntr, nm, _, _ = body_row(bi, b)
        qd0 = dof0 + ntr
        for j in range(nm):
            d = qd0 + j
            _add(jq, n, d, d, zero - dof_k2[d])
            _add(jv, n, d, d, zero - dof_c[d])
        if kind == KIND_ROTATING and nm > 0:
            omega = V.load(rot, L * (3 * b + 1))
            alpha = V.load(rot, L * (3 * b + 2))
            w2 = omega * omega
            g0 = bi[b, B_MAT0]
            c0 = g0 + nm * nm
            for j in range(nm):
                for k in range(nm):
                    gk = fpool[g0 + j * nm + k]
                    ck = fpool[c0 + j * nm + k]
                    _add(jq, n, qd0 + j, qd0 + k, zero - (w2 * ck + alpha * gk))
                    _add(jv, n, qd0 + j, qd0 + k, zero - 2.0 * omega * gk)

    # linear spring/damper groups: Q[idx] -= k K x[idx] + c D v[idx]
    for g in range(lg.shape[0]):
        d0, size, m0 = lg[g, 0], lg[g, 1], lg[g, 2]
        k = V.load(p, L * lg[g, 3])
        c = V.load(p, L * lg[g, 4])
        idx = ipool[d0 : d0 + size]
        for a in range(size):
            for bb in range(size):
                _add(jq, n, idx[a], idx[bb], zero - k * fpool[m0 + a * size + bb])
                _add(jv, n, idx[a], idx[bb], zero - c * fpool[m0 + size * size + a * size + bb])

    _contact_jacobian(n, bi, bf, fpool, ipool, sysdata[11], rot, rot_a, work, jq, jv)
    _mass_inverse_rows(n, bi, fpool, jq)
    _mass_inverse_rows(n, bi, fpool, jv)


@nb.njit(cache=True, inline="always")
def _add(jac, n, i, j, value):
    at = L * (n * i + j)
    V.store(jac, at, V.load(jac, at) + value)


@nb.njit(cache=True, fastmath=V.FAST)
def _contact_jacobian(n, bi, bf, fpool, ipool, ci, rot, rot_a, work, jq, jv):
    """Add every recorded contact point's ``W^T (K W + C W_q)`` to jq and ``W^T C W`` to jv.

    Pass by pass: the points' rows of ``W``, ``K W + C W_q`` and ``C W`` are gathered
    (columns: the two bodies' coordinates) and jq, jv receive the products in one
    sweep (:func:`_gathered_products`), so that an element of jq and jv is loaded and
    stored once per pass, not once per point.
    """
    scratch = (
        np.zeros(3 * n * L),  # a point's W, all lanes per vector: [L (n r + col) + lane]
        np.zeros(3 * n * L),  # its W_q
        # one point's gathered rows (the per-lane path), layout of the pass's with stride 3
        np.zeros(3 * n * L),
        np.zeros(3 * n * L),
        np.zeros(3 * n * L),
        np.zeros(JREC * L),  # one lane's record, the others zero
        np.empty(4, dtype=np.int64),  # a point's master nodes
        np.empty(n, dtype=np.int64),  # the pass's columns
    )
    _contact_points(n, bi, bf, fpool, ipool, ci, rot, rot_a, work, jq, jv, scratch)


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def _contact_points(n, bi, bf, fpool, ipool, ci, rot, rot_a, work, jq, jv, scratch):
    """The products of :func:`_contact_jacobian`, into its work arrays ``scratch``."""
    jrec, jnodes = work[10], work[11]
    w_rows, kq_rows, kv_rows = work[13], work[14], work[15]
    wl, wql, point_w, point_kq, point_kv, masked, masters, cols = scratch
    # the counters and offsets passed below are int64 from the start: a literal 0 or 3
    # (or a counter first typed as one) would compile each callee once more per literal
    zero, point_stride = np.int64(0), np.int64(3)
    row0 = 0
    for c in range(ci.shape[0]):
        nslave = ci[c, C_NSLAVE]
        sb = ci[c, C_SBODY]
        mb = ci[c, C_MBODY]
        slaves = ipool[ci[c, C_SLAVE0] : ci[c, C_SLAVE0] + nslave]
        cols0, cols1 = _body_columns(bi, sb)
        cols2, cols3 = _body_columns(bi, mb)
        if mb == sb:
            cols2, cols3 = cols1, cols1
        ranges = (cols0, cols1, cols2, cols3)
        ncol = zero
        for half in range(2):
            for col in range(ranges[2 * half], ranges[2 * half + 1]):
                cols[ncol] = col
                ncol += 1
        stride = 3 * nslave  # gathered rows per column
        rows = zero
        for k in range(nslave):
            base = L * JREC * (row0 + k)
            # the usual case: one set of master nodes for all lanes, one vector pass; else
            # each lane alone through the same vector arithmetic (the other lanes' record
            # zeroed) and only its own lane gathered, so that a lane's Jacobian does not
            # depend on its neighbours' path
            if _shared_nodes(jnodes, row0 + k):
                if not _any_active(jrec, base):
                    continue
                for q in range(4):
                    masters[q] = jnodes[L * 4 * (row0 + k) + L * q]
                _contact_point_lanes(
                    n, bi, bf, fpool, rot, rot_a, jrec, base, slaves[k], masters, sb, mb,
                    ranges, wl, wql, cols, ncol, stride, rows, w_rows, kq_rows, kv_rows,
                )  # fmt: skip
                rows += 3
                continue
            if not _any_active(jrec, base):
                continue
            _clear_rows(ncol, stride, rows, w_rows, kq_rows, kv_rows)
            for lane in range(L):
                active = False
                for e in range(18):
                    active = active or jrec[base + L * e + lane] != 0.0
                if not active:
                    continue
                for e in range(JREC * L):
                    masked[e] = jrec[base + e] if e % L == lane else 0.0
                for q in range(4):
                    masters[q] = jnodes[L * 4 * (row0 + k) + L * q + lane]
                _contact_point_lanes(
                    n, bi, bf, fpool, rot, rot_a, masked, zero, slaves[k], masters, sb, mb,
                    ranges, wl, wql, cols, ncol, point_stride, zero, point_w, point_kq, point_kv,
                )  # fmt: skip
                _copy_lane(point_w, point_kq, point_kv, ncol, stride, rows, lane,
                           w_rows, kq_rows, kv_rows)  # fmt: skip
            rows += 3
        _gathered_products(n, cols, ncol, stride, rows, w_rows, kq_rows, kv_rows, jq, jv)
        row0 += nslave


@nb.njit(cache=True)
def _copy_lane(point_w, point_kq, point_kv, ncol, stride, rows, lane, w_rows, kq_rows, kv_rows):
    """Lane ``lane`` of one point's gathered rows (stride 3) into the pass's rows
    ``rows .. rows + 2`` (layout ``[L (stride ic + row) + lane]``)."""
    for ic in range(ncol):
        for r in range(3):
            src = L * (3 * ic + r) + lane
            dst = L * (stride * ic + rows + r) + lane
            w_rows[dst] = point_w[src]
            kq_rows[dst] = point_kq[src]
            kv_rows[dst] = point_kv[src]


@nb.njit(cache=True)
def _clear_rows(ncol, stride, rows, w_rows, kq_rows, kv_rows):
    """Zero a point's three gathered rows in every lane (lanes out of contact add 0)."""
    zero = V.splat(0.0)
    for ic in range(ncol):
        for r in range(3):
            dst = L * (stride * ic + rows + r)
            V.store(w_rows, dst, zero)
            V.store(kq_rows, dst, zero)
            V.store(kv_rows, dst, zero)


@nb.njit(cache=True)
def _gathered_products(n, cols, ncol, stride, rows, w_rows, kq_rows, kv_rows, jq, jv):
    """``jq += W^T (K W + C W_q)``, ``jv += W^T (C W)`` over a pass's gathered rows.

    Tiles of 2 x 2 elements of both matrices (eight accumulators, six loads per eight
    fused multiply-adds). Compiled without fast-math: each element's sum runs over
    the rows in their order, so a row that is zero in a lane (out of contact there,
    gathered for another lane) leaves that lane's sum bit for bit unchanged.
    """
    zero = V.splat(0.0)
    for ia in range(0, ncol, 2):
        ib = ia + 1 if ia + 1 < ncol else ia
        for ja in range(0, ncol, 2):
            jb = ja + 1 if ja + 1 < ncol else ja
            q_aa = q_ab = q_ba = q_bb = zero
            v_aa = v_ab = v_ba = v_bb = zero
            wa0 = L * stride * ia
            wb0 = L * stride * ib
            ka0 = L * stride * ja
            kb0 = L * stride * jb
            for r in range(rows):
                w_a = V.load(w_rows, wa0 + L * r)
                w_b = V.load(w_rows, wb0 + L * r)
                kq_a = V.load(kq_rows, ka0 + L * r)
                kq_b = V.load(kq_rows, kb0 + L * r)
                kv_a = V.load(kv_rows, ka0 + L * r)
                kv_b = V.load(kv_rows, kb0 + L * r)
                q_aa = V.fma(w_a, kq_a, q_aa)
                q_ab = V.fma(w_a, kq_b, q_ab)
                q_ba = V.fma(w_b, kq_a, q_ba)
                q_bb = V.fma(w_b, kq_b, q_bb)
                v_aa = V.fma(w_a, kv_a, v_aa)
                v_ab = V.fma(w_a, kv_b, v_ab)
                v_ba = V.fma(w_b, kv_a, v_ba)
                v_bb = V.fma(w_b, kv_b, v_bb)
            _add_pair(jq, jv, n, cols[ia], cols[ja], q_aa, v_aa)
            if jb != ja:
                _add_pair(jq, jv, n, cols[ia], cols[jb], q_ab, v_ab)
            if ib != ia:
                _add_pair(jq, jv, n, cols[ib], cols[ja], q_ba, v_ba)
                if jb != ja:
                    _add_pair(jq, jv, n, cols[ib], cols[jb], q_bb, v_bb)


@nb.njit(cache=True, inline="always")
def _add_pair(jq, jv, n, i, j, value_q, value_v):
    at = L * (n * i + j)
    V.store(jq, at, V.load(jq, at) + value_q)
    V.store(jv, at, V.load(jv, at) + value_v)


@nb.njit(cache=True)
def _shared_nodes(jnodes, row):
    """True if the lanes of contact point ``row`` have the same master nodes."""
    at = L * 4 * row
    for q in range(4):
        node = jnodes[at + L * q]
        for lane in range(1, L):
            if jnodes[at + L * q + lane] != node:
                return False
    return True


@nb.njit(cache=True)
def _any_active(jrec, base):
    """True if contact point ``base`` is in contact in some lane (K or C not zero)."""
    for e in range(18 * L):
        if jrec[base + e] != 0.0:
            return True
    return False


@nb.njit(cache=True, fastmath=V.FAST)
def _contact_point_lanes(
    n, bi, bf, fpool, rot, rot_a, jrec, base, slave, masters, sb, mb, ranges, wl, wql,
    cols, ncol, stride, rows, w_rows, kq_rows, kv_rows,
):  # fmt: skip
    """One contact point's ``W``, ``K W + C W_q`` and ``C W`` (3 x n, on the two bodies'
    columns ``cols``) for all lanes at once (the lanes share the slave and master
    nodes; weights, frames and K, C differ), written to the gathered rows ``rows ..
    rows + 2`` (layout ``[L (stride ic + row) + lane]``)."""
    zero = V.splat(0.0)
    for half in range(2):
        for col in range(ranges[2 * half], ranges[2 * half + 1]):
            for r in range(3):
                V.store(wl, L * (n * r + col), zero)
                V.store(wql, L * (n * r + col), zero)
    _node_map_lanes(bi, bf, fpool, rot, rot_a, sb, slave, V.splat(1.0), n, wl, wql)
    _master_map_lanes(bi, bf, fpool, rot, rot_a, mb, masters, jrec, base, n, wl, wql)
    _point_rows(jrec, base, n, wl, wql, cols, ncol, stride, rows, w_rows, kq_rows, kv_rows)


@nb.njit(cache=True, fastmath=V.FAST)
def _point_rows(jrec, base, n, wl, wql, cols, ncol, stride, rows, w_rows, kq_rows, kv_rows):
    """The rows of W, ``K W + C W_q`` and ``C W`` from the maps ``wl``, ``wql`` and the
    force law's K, C of the record at ``base`` (held in registers across the columns)."""
    b = base
    k00, k01, k02 = V.load(jrec, b), V.load(jrec, b + L), V.load(jrec, b + 2 * L)
    k10, k11, k12 = V.load(jrec, b + 3 * L), V.load(jrec, b + 4 * L), V.load(jrec, b + 5 * L)
    k20, k21, k22 = V.load(jrec, b + 6 * L), V.load(jrec, b + 7 * L), V.load(jrec, b + 8 * L)
    b = base + 9 * L
    c00, c01, c02 = V.load(jrec, b), V.load(jrec, b + L), V.load(jrec, b + 2 * L)
    c10, c11, c12 = V.load(jrec, b + 3 * L), V.load(jrec, b + 4 * L), V.load(jrec, b + 5 * L)
    c20, c21, c22 = V.load(jrec, b + 6 * L), V.load(jrec, b + 7 * L), V.load(jrec, b + 8 * L)
    for ic in range(ncol):
        col = cols[ic]
        w0 = V.load(wl, L * col)
        w1 = V.load(wl, L * (n + col))
        w2 = V.load(wl, L * (2 * n + col))
        z0 = V.load(wql, L * col)
        z1 = V.load(wql, L * (n + col))
        z2 = V.load(wql, L * (2 * n + col))
        v0 = V.fma(c02, w2, V.fma(c01, w1, c00 * w0))
        v1 = V.fma(c12, w2, V.fma(c11, w1, c10 * w0))
        v2 = V.fma(c22, w2, V.fma(c21, w1, c20 * w0))
        q0 = V.fma(k02, w2, V.fma(k01, w1, k00 * w0))
        q1 = V.fma(k12, w2, V.fma(k11, w1, k10 * w0))
        q2 = V.fma(k22, w2, V.fma(k21, w1, k20 * w0))
        q0 = q0 + V.fma(c02, z2, V.fma(c01, z1, c00 * z0))
        q1 = q1 + V.fma(c12, z2, V.fma(c11, z1, c10 * z0))
        q2 = q2 + V.fma(c22, z2, V.fma(c21, z1, c20 * z0))
        at = L * (stride * ic + rows)
        V.store(w_rows, at, w0)
        V.store(w_rows, at + L, w1)
        V.store(w_rows, at + 2 * L, w2)
        V.store(kq_rows, at, q0)
        V.store(kq_rows, at + L, q1)
        V.store(kq_rows, at + 2 * L, q2)
        V.store(kv_rows, at, v0)
        V.store(kv_rows, at + L, v1)
        V.store(kv_rows, at + 2 * L, v2)


@nb.njit(cache=True, fastmath=V.FAST)
def _node_map_lanes(bi, bf, fpool, rot, rot_a, b, node, sigma, n, wl, wql):
    """The node's maps ``sigma dx/dq`` (``sigma`` a vector) added to ``wl`` and, for a
    rotating body, its relative-velocity maps ``sigma A (Omega e x Psi)`` to ``wql``."""
    kind, dof0, ntr, nm, n0, _ = body_row(bi, b)
    for a in range(ntr):
        for r in range(3):
            at = L * (n * r + dof0 + a)
            V.store(wl, at, V.load(wl, at) + sigma * bf[b, 3 + 3 * a + r])
    if nm == 0:
        return
    qd0 = dof0 + ntr
    row = bi[b, B_PSI0] + (node - n0) * 3 * nm
    if kind == KIND_ROTATING:
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = frame_matrix(rot_a, b)
        om = V.load(rot, L * (3 * b + 1)) * sigma
        e0, e1, e2 = bf[b, 12], bf[b, 13], bf[b, 14]
        for j in range(nm):
            u0 = fpool[row + j]
            u1 = fpool[row + nm + j]
            u2 = fpool[row + 2 * nm + j]
            z0 = om * (e1 * u2 - e2 * u1)  # sigma Omega e x u
            z1 = om * (e2 * u0 - e0 * u2)
            z2 = om * (e0 * u1 - e1 * u0)
            col = qd0 + j
            _add_row(wl, wql, L * col, sigma, a00, a01, a02, u0, u1, u2, z0, z1, z2)
            _add_row(wl, wql, L * (n + col), sigma, a10, a11, a12, u0, u1, u2, z0, z1, z2)
            _add_row(wl, wql, L * (2 * n + col), sigma, a20, a21, a22, u0, u1, u2, z0, z1, z2)
    else:
        for j in range(nm):
            for r in range(3):
                at = L * (n * r + qd0 + j)
                V.store(wl, at, V.load(wl, at) + sigma * fpool[row + r * nm + j])


@nb.njit(cache=True, fastmath=V.FAST)
def _master_map_lanes(bi, bf, fpool, rot, rot_a, b, masters, jrec, base, n, wl, wql):
    """The four master nodes' maps, ``sum_q sigma_q dx_q/dq``, for all lanes: the
    weighted mode shapes are summed in the body frame first, then rotated once (a
    quarter of the rotations of four :func:`_node_map_lanes` calls; the same sum)."""
    kind, dof0, ntr, nm, n0, _ = body_row(bi, b)
    zero = V.splat(0.0)
    s0 = zero - V.load(jrec, base + L * 18)
    s1 = zero - V.load(jrec, base + L * 19)
    s2 = zero - V.load(jrec, base + L * 20)
    s3 = zero - V.load(jrec, base + L * 21)
    total = s0 + s1 + s2 + s3
    for a in range(ntr):
        for r in range(3):
            at = L * (n * r + dof0 + a)
            V.store(wl, at, V.load(wl, at) + total * bf[b, 3 + 3 * a + r])
    if nm == 0:
        return
    qd0 = dof0 + ntr
    psi0 = bi[b, B_PSI0]
    row0 = psi0 + (masters[0] - n0) * 3 * nm
    row1 = psi0 + (masters[1] - n0) * 3 * nm
    row2 = psi0 + (masters[2] - n0) * 3 * nm
    row3 = psi0 + (masters[3] - n0) * 3 * nm
    rotating = kind == KIND_ROTATING
    if rotating:
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = frame_matrix(rot_a, b)
        om = V.load(rot, L * (3 * b + 1))
        e0, e1, e2 = bf[b, 12], bf[b, 13], bf[b, 14]
    for j in range(nm):
        col = qd0 + j
        u0 = s0 * fpool[row0 + j] + s1 * fpool[row1 + j]
        u0 = u0 + s2 * fpool[row2 + j] + s3 * fpool[row3 + j]
        u1 = s0 * fpool[row0 + nm + j] + s1 * fpool[row1 + nm + j]
        u1 = u1 + s2 * fpool[row2 + nm + j] + s3 * fpool[row3 + nm + j]
        u2 = s0 * fpool[row0 + 2 * nm + j] + s1 * fpool[row1 + 2 * nm + j]
        u2 = u2 + s2 * fpool[row2 + 2 * nm + j] + s3 * fpool[row3 + 2 * nm + j]
        if rotating:
            z0 = om * (e1 * u2 - e2 * u1)  # Omega e x (sum sigma u)
            z1 = om * (e2 * u0 - e0 * u2)
            z2 = om * (e0 * u1 - e1 * u0)
            one = V.splat(1.0)
            _add_row(wl, wql, L * col, one, a00, a01, a02, u0, u1, u2, z0, z1, z2)
            _add_row(wl, wql, L * (n + col), one, a10, a11, a12, u0, u1, u2, z0, z1, z2)
            _add_row(wl, wql, L * (2 * n + col), one, a20, a21, a22, u0, u1, u2, z0, z1, z2)
        else:
            V.store(wl, L * col, V.load(wl, L * col) + u0)
            V.store(wl, L * (n + col), V.load(wl, L * (n + col)) + u1)
            V.store(wl, L * (2 * n + col), V.load(wl, L * (2 * n + col)) + u2)


@nb.njit(cache=True, fastmath=V.FAST, inline="always")
def _add_row(wl, wql, at, sigma, c0, c1, c2, u0, u1, u2, z0, z1, z2):
    """One row r of a rotating body's maps: ``A[r] . u`` (times sigma) and ``A[r] . z``."""
    V.store(wl, at, V.load(wl, at) + sigma * (c0 * u0 + c1 * u1 + c2 * u2))
    V.store(wql, at, V.load(wql, at) + (c0 * z0 + c1 * z1 + c2 * z2))


@nb.njit(cache=True)
def _body_columns(bi, b):
    """First and end coordinate of body b."""
    _, dof0, ntr, nm, _, _ = body_row(bi, b)
    return dof0, dof0 + ntr + nm


@nb.njit(cache=True, fastmath=V.FAST)
def _mass_inverse_rows(n, bi, fpool, jac):
    """Generalised forces -> accelerations on the rows of every translating body
    (Schur complement of ``[[m P P^T, B], [B^T, I]]``, as in the right-hand side),
    column by column (each column is a generalised force), all lanes per vector."""
    r = np.empty(3 * L)  # ntr <= 3
    acc_s = np.empty(3 * L)
    for b in range(bi.shape[0]):
        kind, dof0, ntr, nm, _, _ = body_row(bi, b)
        if kind != KIND_TRANSLATING:
            continue
        s0 = bi[b, B_MAT0]
        b0 = s0 + ntr * ntr
        qd0 = dof0 + ntr
        for j in range(n):
            for a in range(ntr):
                value = V.load(jac, L * (n * (dof0 + a) + j))
                for m in range(nm):
                    value = value - fpool[b0 + a * nm + m] * V.load(jac, L * (n * (qd0 + m) + j))
                V.store(r, L * a, value)
            for a in range(ntr):
                value = V.splat(0.0)
                for a2 in range(ntr):
                    value = value + fpool[s0 + a * ntr + a2] * V.load(r, L * a2)
                V.store(acc_s, L * a, value)
                V.store(jac, L * (n * (dof0 + a) + j), value)
            for m in range(nm):
                at = L * (n * (qd0 + m) + j)
                value = V.load(jac, at)
                for a in range(ntr):
                    value = value - fpool[b0 + a * nm + m] * V.load(acc_s, L * a)
                V.store(jac, at, value)
