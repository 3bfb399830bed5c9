"""EXPERIMENT (not used by fuzzymbs): lockstep kernels, the sample as the SIMD axis.

Session 2's attempt at the brake's speed target, kept so that its figures in
docs/embs.md ("Samples in lockstep") can be reproduced: ``python
benchmarks/lockstep.py`` compares it with :func:`fuzzymbs.mbs.kernels.rk4_batch` on
the 33-sample brake (agreement and time) and profiles its parts per lane. It is
correct and slower; the reasons are in docs/embs.md. First run: about a minute of
Numba compilation.

Every sample of a study integrates the same equations with different parameter
values, so a block of ``L`` samples (lanes) can run through the right-hand
side together: each per-sample quantity gets a trailing lane axis (state
``X (2n, L)``, parameters ``P (slots, L)``, node positions ``(nodes, 3, L)``),
and every innermost loop runs over the lanes, contiguous in memory. Then

* the mode-shape products ``U = Psi q`` and ``Q = Psi^T F`` reuse each
  mode-shape element for all lanes (matrix-matrix instead of matrix-vector);
* the contact law of one slave node runs for all lanes at once: the lanes
  almost always find their slave in the same master cell (the samples differ
  by a few per cent), and then the master nodes' positions, velocities and
  reactions are contiguous lane vectors. Lanes in different cells take a
  per-lane path with the same formula;
* "in contact or not" and "on the patch or not" are selects, not branches.

The arithmetic is that of :func:`fuzzymbs.mbs.kernels.rhs` (same formulas,
summation order may differ: results agree to rounding). A lane whose sample
fails (non-finite state, output beyond its bound) is flagged and then
shadows a healthy lane of its block (state and parameters copied), so that it
neither produces NaN in the shared work nor pushes its block off the shared
cells; its outputs are NaN as in the per-sample kernel.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import (
    _TWO_PI,
    B_DOF0,
    B_KIND,
    B_MAT0,
    B_NM,
    B_NODE0,
    B_NODE1,
    B_NTR,
    B_PROF,
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
    CF_USCALE,
    CF_UUNIFORM,
    CF_VSCALE,
    CF_VUNIFORM,
    FAST,
    KIND_ROTATING,
    KIND_TRANSLATING,
    NONFINITE,
    OK,
    OUT_OF_BOUND,
    _atan2_select,
    _profile,
)

# lane scratch rows of the contact pass: chart frame per lane, then per-slave values
_UA, _VA, _CU, _CV = 0, 3, 6, 7
_XI, _ETA, _ON, _CELL_I, _CELL_J, _U, _V = 8, 9, 10, 11, 12, 13, 14
_FORCE, _WEIGHT = 15, 18  # force (3 rows), bilinear weights of the 4 master nodes (4 rows)
_N_SCRATCH = 22


@nb.njit(cache=True)
def make_lane_work(sysdata, lanes):
    """Work arrays of one block of ``lanes`` samples.

    ``(q_gen (n, L), node_x, node_v, node_f (tracked, 3, L), rot (bodies, 6, L),
    rot_a (bodies, 3, 3, L), scratch (22, L), acc (4, L))``.
    """
    ndof = sysdata[0]
    nbody = sysdata[1].shape[0]
    ntracked = sysdata[3].shape[0]
    return (
        np.zeros((ndof, lanes)),
        np.zeros((ntracked, 3, lanes)),
        np.zeros((ntracked, 3, lanes)),
        np.zeros((ntracked, 3, lanes)),
        np.zeros((nbody, 6, lanes)),
        np.zeros((nbody, 3, 3, lanes)),
        np.zeros((_N_SCRATCH, lanes)),
        np.zeros((4, lanes)),
    )


@nb.njit(cache=True, fastmath=FAST)
def rhs_lanes(t, x, dx, p, sysdata, work):
    """Time derivatives ``dx (2n, L)`` of the lane states ``x (2n, L)`` at time t.

    ``p (slots, L)``: the lanes' parameter columns. Same equations as
    :func:`fuzzymbs.mbs.kernels.rhs`.
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
        cf,
    ) = sysdata
    q_gen, node_x, node_v, node_f, rot, rot_a, scratch, acc = work
    lanes = x.shape[1]
    nbody = bi.shape[0]
    for i in range(ndof):
        for l in range(lanes):
            dx[i, l] = x[ndof + i, l]
            q_gen[i, l] = 0.0

    # prescribed rotations: angle, speed, acceleration and A(t) per rotating body and lane
    for b in range(nbody):
        if bi[b, B_KIND] == KIND_ROTATING:
            value, integral, slope = _profile(fpool, ptab, bi[b, B_PROF], t)
            speed = p[bi[b, B_SPEED]]
            e0 = bf[b, 12]
            e1 = bf[b, 13]
            e2 = bf[b, 14]
            for l in range(lanes):
                angle = speed[l] * integral
                rot[b, 0, l] = angle
                rot[b, 1, l] = speed[l] * value
                rot[b, 2, l] = speed[l] * slope
                c = np.cos(angle)
                s = np.sin(angle)
                v = 1.0 - c
                rot_a[b, 0, 0, l] = c + e0 * e0 * v
                rot_a[b, 0, 1, l] = e0 * e1 * v - e2 * s
                rot_a[b, 0, 2, l] = e0 * e2 * v + e1 * s
                rot_a[b, 1, 0, l] = e1 * e0 * v + e2 * s
                rot_a[b, 1, 1, l] = c + e1 * e1 * v
                rot_a[b, 1, 2, l] = e1 * e2 * v - e0 * s
                rot_a[b, 2, 0, l] = e2 * e0 * v - e1 * s
                rot_a[b, 2, 1, l] = e2 * e1 * v + e0 * s
                rot_a[b, 2, 2, l] = c + e2 * e2 * v

    # linear spring/damper groups: Q[idx] -= k K x[idx] + c D v[idx]
    stiff_acc = acc[0]
    damp_acc = acc[1]
    for g in range(lg.shape[0]):
        d0 = lg[g, 0]
        n = lg[g, 1]
        m0 = lg[g, 2]
        k = p[lg[g, 3]]
        c = p[lg[g, 4]]
        damped = False
        for l in range(lanes):
            damped |= c[l] != 0.0
        idx = ipool[d0 : d0 + n]
        for a in range(n):
            stiff_acc[:] = 0.0
            damp_acc[:] = 0.0
            for bb in range(n):
                w = fpool[m0 + a * n + bb]
                xr = x[idx[bb]]
                for l in range(lanes):
                    stiff_acc[l] += w * xr[l]
            if damped:
                for bb in range(n):
                    w = fpool[m0 + n * n + a * n + bb]
                    vr = x[ndof + idx[bb]]
                    for l in range(lanes):
                        damp_acc[l] += w * vr[l]
            target = q_gen[idx[a]]
            for l in range(lanes):
                target[l] -= k[l] * stiff_acc[l] + c[l] * damp_acc[l]

    # nodal forces (generalised vectors precomputed)
    for f in range(nfi.shape[0]):
        b = nfi[f, 0]
        v0 = nfi[f, 1]
        magnitude = p[nfi[f, 3]]
        scale = 1.0
        if nfi[f, 2] >= 0:
            scale, _, _ = _profile(fpool, ptab, nfi[f, 2], t)
        dof0 = bi[b, B_DOF0]
        if nfi[f, 4] == 0:
            for i in range(bi[b, B_NTR] + bi[b, B_NM]):
                w = scale * fpool[v0 + i]
                target = q_gen[dof0 + i]
                for l in range(lanes):
                    target[l] += magnitude[l] * w
        else:
            nm = bi[b, B_NM]
            for j in range(nm):
                w_c = fpool[v0 + j]
                w_1c = fpool[v0 + nm + j]
                w_s = fpool[v0 + 2 * nm + j]
                target = q_gen[dof0 + j]
                for l in range(lanes):
                    c = np.cos(rot[b, 0, l])
                    s = np.sin(rot[b, 0, l])
                    target[l] += magnitude[l] * scale * (c * w_c + (1.0 - c) * w_1c - s * w_s)

    if ci.shape[0] > 0:
        _node_kinematics_lanes(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
        node_f[:, :, :] = 0.0
        for c in range(ci.shape[0]):
            _contact_pass_lanes(
                c, x, p, bi, bf, ci, cf, fpool, ipool, rot_a, node_x, node_v, node_f, scratch
            )
        _map_node_forces_lanes(bi, bf, fpool, rot_a, node_f, q_gen, acc)

    # equations of motion body by body (mass-normalised modes: diagonal elastic part)
    for b in range(nbody):
        kind = bi[b, B_KIND]
        dof0 = bi[b, B_DOF0]
        ntr = bi[b, B_NTR]
        nm = bi[b, B_NM]
        m0 = bi[b, B_MAT0]
        qd0 = dof0 + ntr
        for j in range(nm):
            d = qd0 + j
            kk = dof_k2[d]
            cc = dof_c[d]
            target = q_gen[d]
            qr = x[d]
            vr = x[ndof + d]
            for l in range(lanes):
                target[l] -= cc * vr[l] + kk * qr[l]
        if kind == KIND_ROTATING and nm > 0:
            g0 = m0
            c0 = m0 + nm * nm
            l0 = m0 + 2 * nm * nm
            e0 = l0 + nm
            omega = rot[b, 1]
            alpha = rot[b, 2]
            gyro = acc[0]
            gyro_q = acc[1]
            cent = acc[2]
            for j in range(nm):
                gyro[:] = 0.0
                gyro_q[:] = 0.0
                cent[:] = 0.0
                for kq in range(nm):
                    g = fpool[g0 + j * nm + kq]
                    cm = fpool[c0 + j * nm + kq]
                    qr = x[qd0 + kq]
                    vr = x[ndof + qd0 + kq]
                    for l in range(lanes):
                        gyro[l] += g * vr[l]
                        gyro_q[l] += g * qr[l]
                        cent[l] += cm * qr[l]
                load_c = fpool[l0 + j]
                load_e = fpool[e0 + j]
                target = q_gen[qd0 + j]
                for l in range(lanes):
                    w = omega[l]
                    target[l] -= (
                        w * w * (load_c + cent[l])
                        + alpha[l] * (load_e + gyro_q[l])
                        + 2.0 * w * gyro[l]
                    )
        if kind == KIND_TRANSLATING:
            # Schur complement of [[m P P^T, B], [B^T, I]]: s'' = S^-1 (f_s - B f_q)
            s0 = m0
            b0 = m0 + ntr * ntr
            for a in range(ntr):
                r = rot[b, 3 + a]  # scratch
                r[:] = q_gen[dof0 + a]
                for j in range(nm):
                    w = fpool[b0 + a * nm + j]
                    qg = q_gen[qd0 + j]
                    for l in range(lanes):
                        r[l] -= w * qg[l]
            for a in range(ntr):
                out = dx[ndof + dof0 + a]
                out[:] = 0.0
                for a2 in range(ntr):
                    w = fpool[s0 + a * ntr + a2]
                    r = rot[b, 3 + a2]
                    for l in range(lanes):
                        out[l] += w * r[l]
            for j in range(nm):
                out = dx[ndof + qd0 + j]
                out[:] = q_gen[qd0 + j]
                for a in range(ntr):
                    w = fpool[b0 + a * nm + j]
                    sa = dx[ndof + dof0 + a]
                    for l in range(lanes):
                        out[l] -= w * sa[l]
        else:
            for j in range(nm):
                dx[ndof + qd0 + j, :] = q_gen[qd0 + j]


@nb.njit(cache=True, fastmath=FAST)
def _node_kinematics_lanes(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v):
    """Inertial positions and velocities of the tracked nodes, all lanes.

    ``U (node*3, L) = Psi_block (node*3, modes) q (modes, L)``: four modes per sweep
    over the transposed block, each mode-shape element used for all lanes.
    """
    lanes = x.shape[1]
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
        pos = node_x[n0:n1]
        vel = node_v[n0:n1]
        pos[:, :, :] = 0.0
        vel[:, :, :] = 0.0
        j = 0
        while j + 4 <= nm:
            q0 = x[qd0 + j]
            q1 = x[qd0 + j + 1]
            q2 = x[qd0 + j + 2]
            q3 = x[qd0 + j + 3]
            v0 = x[ndof + qd0 + j]
            v1 = x[ndof + qd0 + j + 1]
            v2 = x[ndof + qd0 + j + 2]
            v3 = x[ndof + qd0 + j + 3]
            for k in range(width):
                a = fpool[psit + j * width + k]
                b_ = fpool[psit + (j + 1) * width + k]
                c = fpool[psit + (j + 2) * width + k]
                d = fpool[psit + (j + 3) * width + k]
                pk = pos[k // 3, k % 3]
                vk = vel[k // 3, k % 3]
                for l in range(lanes):
                    pk[l] += a * q0[l] + b_ * q1[l] + c * q2[l] + d * q3[l]
                    vk[l] += a * v0[l] + b_ * v1[l] + c * v2[l] + d * v3[l]
            j += 4
        while j < nm:
            qj = x[qd0 + j]
            vj = x[ndof + qd0 + j]
            for k in range(width):
                a = fpool[psit + j * width + k]
                pk = pos[k // 3, k % 3]
                vk = vel[k // 3, k % 3]
                for l in range(lanes):
                    pk[l] += a * qj[l]
                    vk[l] += a * vj[l]
            j += 1
        if kind == KIND_ROTATING:
            # x = o + A y, v = A (Omega e x y + ydot), y = xbar + u
            e0 = bf[b, 12]
            e1 = bf[b, 13]
            e2 = bf[b, 14]
            o0 = bf[b, 0]
            o1 = bf[b, 1]
            o2 = bf[b, 2]
            om = rot[b, 1]
            a = rot_a[b]
            for i in range(n0, n1):
                xb0 = node_xbar[i, 0]
                xb1 = node_xbar[i, 1]
                xb2 = node_xbar[i, 2]
                px = node_x[i]
                pv = node_v[i]
                for l in range(lanes):
                    u0 = xb0 + px[0, l]
                    u1 = xb1 + px[1, l]
                    u2 = xb2 + px[2, l]
                    w = om[l]
                    z0 = pv[0, l] + w * (e1 * u2 - e2 * u1)
                    z1 = pv[1, l] + w * (e2 * u0 - e0 * u2)
                    z2 = pv[2, l] + w * (e0 * u1 - e1 * u0)
                    px[0, l] = o0 + a[0, 0, l] * u0 + a[0, 1, l] * u1 + a[0, 2, l] * u2
                    px[1, l] = o1 + a[1, 0, l] * u0 + a[1, 1, l] * u1 + a[1, 2, l] * u2
                    px[2, l] = o2 + a[2, 0, l] * u0 + a[2, 1, l] * u1 + a[2, 2, l] * u2
                    pv[0, l] = a[0, 0, l] * z0 + a[0, 1, l] * z1 + a[0, 2, l] * z2
                    pv[1, l] = a[1, 0, l] * z0 + a[1, 1, l] * z1 + a[1, 2, l] * z2
                    pv[2, l] = a[2, 0, l] * z0 + a[2, 1, l] * z1 + a[2, 2, l] * z2
        else:
            # frame translation r = o + sum_a axis_a s_a (and its rate) per lane, in rot[b, 3:6]
            # (scratch; the translating body's rotation rows are unused)
            shift = rot[b, 3:6]
            for d in range(3):
                shift[d, :] = bf[b, d]
            for a_ in range(ntr):
                ax0 = bf[b, 3 + 3 * a_]
                ax1 = bf[b, 4 + 3 * a_]
                ax2 = bf[b, 5 + 3 * a_]
                sa = x[dof0 + a_]
                va = x[ndof + dof0 + a_]
                for i in range(n0, n1):
                    pv = node_v[i]
                    for l in range(lanes):
                        pv[0, l] += ax0 * va[l]
                        pv[1, l] += ax1 * va[l]
                        pv[2, l] += ax2 * va[l]
                for l in range(lanes):
                    shift[0, l] += ax0 * sa[l]
                    shift[1, l] += ax1 * sa[l]
                    shift[2, l] += ax2 * sa[l]
            for i in range(n0, n1):
                xb0 = node_xbar[i, 0]
                xb1 = node_xbar[i, 1]
                xb2 = node_xbar[i, 2]
                px = node_x[i]
                for l in range(lanes):
                    px[0, l] += shift[0, l] + xb0
                    px[1, l] += shift[1, l] + xb1
                    px[2, l] += shift[2, l] + xb2


@nb.njit(cache=True, inline="always")
def _contact_force(
    xs0, xs1, xs2, xm0, xm1, xm2, vr0, vr1, vr2, n0, n1, n2, on, penalty, mu, eps2, damping
):
    """Penalty normal force plus regularised Coulomb friction on the slave; 0 if not in contact.

    The formula of :func:`fuzzymbs.mbs.kernels._contact_pass`, with the tests
    (on the patch, gap < 0, compressive normal force) as selects.
    """
    gap = n0 * (xs0 - xm0) + n1 * (xs1 - xm1) + n2 * (xs2 - xm2)
    vn = n0 * vr0 + n1 * vr1 + n2 * vr2
    fn = -penalty * gap - damping * vn
    vt0 = vr0 - vn * n0
    vt1 = vr1 - vn * n1
    vt2 = vr2 - vn * n2
    scale = -mu * fn / np.sqrt(vt0 * vt0 + vt1 * vt1 + vt2 * vt2 + eps2)
    active = on and gap < 0.0 and fn > 0.0
    f0 = fn * n0 + scale * vt0 if active else 0.0
    f1 = fn * n1 + scale * vt1 if active else 0.0
    f2 = fn * n2 + scale * vt2 if active else 0.0
    return f0, f1, f2


@nb.njit(cache=True, fastmath=FAST, error_model="numpy")
def _contact_pass_lanes(
    c, x, p, bi, bf, ci, cf, fpool, ipool, rot_a, node_x, node_v, node_f, scratch
):
    """One contact pass for all lanes (see the module docstring for the two paths)."""
    lanes = x.shape[1]
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
    penalty = p[ci[c, C_PEN]]
    mu = p[ci[c, C_MU]]
    eps2 = cf[c, 9] * cf[c, 9]
    damping = cf[c, 10]
    u_first = ugrid[0]
    u_scale = cf[c, CF_USCALE]
    u_uniform = cf[c, CF_UUNIFORM] != 0.0
    v_first = vgrid[0]
    v_cells = nv if periodic else nv - 1
    v_scale = cf[c, CF_VSCALE]
    v_uniform = cf[c, CF_VUNIFORM] != 0.0
    u_last = float(nu - 1)
    v_last = float(v_cells)
    kind = bi[mb, B_KIND]
    rotating = kind == KIND_ROTATING
    am = rot_a[mb]

    # master chart frame per lane: inertial axes ua, va and offsets cu, cv such that the
    # chart coordinates of an inertial point x are (x . ua - cu, x . va - cv)
    ua = scratch[_UA : _UA + 3]
    va = scratch[_VA : _VA + 3]
    cu = scratch[_CU]
    cv = scratch[_CV]
    chart_o_u = cf[c, 0] * cf[c, 3] + cf[c, 1] * cf[c, 4] + cf[c, 2] * cf[c, 5]
    chart_o_v = cf[c, 0] * cf[c, 6] + cf[c, 1] * cf[c, 7] + cf[c, 2] * cf[c, 8]
    for l in range(lanes):
        o0 = bf[mb, 0]
        o1 = bf[mb, 1]
        o2 = bf[mb, 2]
        if kind == KIND_TRANSLATING:
            dof0 = bi[mb, B_DOF0]
            for a in range(bi[mb, B_NTR]):
                sa = x[dof0 + a, l]
                o0 += bf[mb, 3 + 3 * a] * sa
                o1 += bf[mb, 4 + 3 * a] * sa
                o2 += bf[mb, 5 + 3 * a] * sa
        for d in range(3):
            if rotating:
                ua[d, l] = am[d, 0, l] * cf[c, 3] + am[d, 1, l] * cf[c, 4] + am[d, 2, l] * cf[c, 5]
                va[d, l] = am[d, 0, l] * cf[c, 6] + am[d, 1, l] * cf[c, 7] + am[d, 2, l] * cf[c, 8]
            else:
                ua[d, l] = cf[c, 3 + d]
                va[d, l] = cf[c, 6 + d]
        cu[l] = o0 * ua[0, l] + o1 * ua[1, l] + o2 * ua[2, l] + chart_o_u
        cv[l] = o0 * va[0, l] + o1 * va[1, l] + o2 * va[2, l] + chart_o_v

    ua0 = scratch[_UA]
    ua1 = scratch[_UA + 1]
    ua2 = scratch[_UA + 2]
    va0 = scratch[_VA]
    va1 = scratch[_VA + 1]
    va2 = scratch[_VA + 2]
    xi_r = scratch[_XI]
    eta_r = scratch[_ETA]
    on_r = scratch[_ON]
    ci_r = scratch[_CELL_I]
    cj_r = scratch[_CELL_J]
    u_r = scratch[_U]
    v_r = scratch[_V]
    f0_r = scratch[_FORCE]
    f1_r = scratch[_FORCE + 1]
    f2_r = scratch[_FORCE + 2]
    wa_r = scratch[_WEIGHT]
    wb_r = scratch[_WEIGHT + 1]
    wc_r = scratch[_WEIGHT + 2]
    wd_r = scratch[_WEIGHT + 3]
    a00 = am[0, 0]
    a01 = am[0, 1]
    a02 = am[0, 2]
    a10 = am[1, 0]
    a11 = am[1, 1]
    a12 = am[1, 2]
    a20 = am[2, 0]
    a21 = am[2, 1]
    a22 = am[2, 2]
    for k in range(slaves.shape[0]):
        s = slaves[k]
        xs0 = node_x[s, 0]
        xs1 = node_x[s, 1]
        xs2 = node_x[s, 2]
        # chart coordinates and cell of every lane (branch-free: vectorised over lanes)
        for l in range(lanes):
            a1 = xs0[l] * ua0[l] + xs1[l] * ua1[l] + xs2[l] * ua2[l] - cu[l]
            a2 = xs0[l] * va0[l] + xs1[l] * va1[l] + xs2[l] * va2[l] - cv[l]
            u = np.sqrt(a1 * a1 + a2 * a2) if polar else a1
            v = _atan2_select(a2, a1) if polar else a2
            if periodic:
                v = v + _TWO_PI if v < v_first else v
                v = v - _TWO_PI if v >= v_first + _TWO_PI else v
            fu = (u - u_first) * u_scale
            fv = (v - v_first) * v_scale
            on = fu >= 0.0 and fu <= u_last and fv >= 0.0 and fv <= v_last
            fu = min(fu, u_last) if fu > 0.0 else 0.0  # also NaN -> 0: a valid cell
            fv = min(fv, v_last) if fv > 0.0 else 0.0
            i = min(int(fu), nu - 2)
            j = min(int(fv), v_cells - 1)
            u_r[l] = u
            v_r[l] = v
            on_r[l] = 1.0 if on else 0.0
            ci_r[l] = i
            cj_r[l] = j
            xi_r[l] = fu - i
            eta_r[l] = fv - j
        if not (u_uniform and v_uniform):
            for l in range(lanes):  # short walk from the scaled guess, local coordinates
                i = int(ci_r[l])
                j = int(cj_r[l])
                u = u_r[l]
                v = v_r[l]
                if not u_uniform:
                    while i > 0 and u < ugrid[i]:
                        i -= 1
                    while i < nu - 2 and u > ugrid[i + 1]:
                        i += 1
                    xi_r[l] = (u - ugrid[i]) / (ugrid[i + 1] - ugrid[i])
                if not v_uniform:
                    while j > 0 and v < vgrid[j]:
                        j -= 1
                    upper = vgrid[j + 1] if j + 1 < nv else v_first + _TWO_PI
                    while j < v_cells - 1 and v > upper:
                        j += 1
                        upper = vgrid[j + 1] if j + 1 < nv else v_first + _TWO_PI
                    eta_r[l] = (v - vgrid[j]) / (upper - vgrid[j])
                ci_r[l] = i
                cj_r[l] = j
        i0 = ci_r[0]
        j0 = cj_r[0]
        shared = True
        for l in range(lanes):
            shared &= (ci_r[l] == i0) & (cj_r[l] == j0)
        if shared:
            # all lanes in one master cell: contiguous lane rows, vectorised force law
            i = int(i0)
            j = int(j0)
            j1 = j + 1 if j + 1 < nv else 0
            na = grid[i * nv + j]
            nb_ = grid[(i + 1) * nv + j]
            nc = grid[(i + 1) * nv + j1]
            nd = grid[i * nv + j1]
            k3 = 3 * (i * ncv + j)
            m0 = normals[k3]
            m1 = normals[k3 + 1]
            m2 = normals[k3 + 2]
            xa0, xa1, xa2 = node_x[na, 0], node_x[na, 1], node_x[na, 2]
            xb0, xb1, xb2 = node_x[nb_, 0], node_x[nb_, 1], node_x[nb_, 2]
            xc0, xc1, xc2 = node_x[nc, 0], node_x[nc, 1], node_x[nc, 2]
            xd0, xd1, xd2 = node_x[nd, 0], node_x[nd, 1], node_x[nd, 2]
            vs0, vs1, vs2 = node_v[s, 0], node_v[s, 1], node_v[s, 2]
            va_0, va_1, va_2 = node_v[na, 0], node_v[na, 1], node_v[na, 2]
            vb0, vb1, vb2 = node_v[nb_, 0], node_v[nb_, 1], node_v[nb_, 2]
            vc0, vc1, vc2 = node_v[nc, 0], node_v[nc, 1], node_v[nc, 2]
            vd0, vd1, vd2 = node_v[nd, 0], node_v[nd, 1], node_v[nd, 2]
            for l in range(lanes):
                xi = xi_r[l]
                eta = eta_r[l]
                wa = (1.0 - xi) * (1.0 - eta)
                wb = xi * (1.0 - eta)
                wc = xi * eta
                wd = (1.0 - xi) * eta
                if rotating:
                    n0 = a00[l] * m0 + a01[l] * m1 + a02[l] * m2
                    n1 = a10[l] * m0 + a11[l] * m1 + a12[l] * m2
                    n2 = a20[l] * m0 + a21[l] * m1 + a22[l] * m2
                else:
                    n0 = m0
                    n1 = m1
                    n2 = m2
                f0, f1, f2 = _contact_force(
                    xs0[l],
                    xs1[l],
                    xs2[l],
                    wa * xa0[l] + wb * xb0[l] + wc * xc0[l] + wd * xd0[l],
                    wa * xa1[l] + wb * xb1[l] + wc * xc1[l] + wd * xd1[l],
                    wa * xa2[l] + wb * xb2[l] + wc * xc2[l] + wd * xd2[l],
                    vs0[l] - (wa * va_0[l] + wb * vb0[l] + wc * vc0[l] + wd * vd0[l]),
                    vs1[l] - (wa * va_1[l] + wb * vb1[l] + wc * vc1[l] + wd * vd1[l]),
                    vs2[l] - (wa * va_2[l] + wb * vb2[l] + wc * vc2[l] + wd * vd2[l]),
                    n0,
                    n1,
                    n2,
                    on_r[l] != 0.0,
                    penalty[l],
                    mu[l],
                    eps2,
                    damping,
                )
                f0_r[l] = f0
                f1_r[l] = f1
                f2_r[l] = f2
                wa_r[l] = wa
                wb_r[l] = wb
                wc_r[l] = wc
                wd_r[l] = wd
            # scatter: one short loop per node component, each vectorised
            for d in range(3):
                fr = scratch[_FORCE + d]
                _add_row(node_f[s, d], fr)
                _sub_weighted_row(node_f[na, d], wa_r, fr)
                _sub_weighted_row(node_f[nb_, d], wb_r, fr)
                _sub_weighted_row(node_f[nc, d], wc_r, fr)
                _sub_weighted_row(node_f[nd, d], wd_r, fr)
        else:
            # lanes in different cells: each lane gathers its own master nodes
            for l in range(lanes):
                i = int(ci_r[l])
                j = int(cj_r[l])
                j1 = j + 1 if j + 1 < nv else 0
                na = grid[i * nv + j]
                nb_ = grid[(i + 1) * nv + j]
                nc = grid[(i + 1) * nv + j1]
                nd = grid[i * nv + j1]
                k3 = 3 * (i * ncv + j)
                m0 = normals[k3]
                m1 = normals[k3 + 1]
                m2 = normals[k3 + 2]
                xi = xi_r[l]
                eta = eta_r[l]
                wa = (1.0 - xi) * (1.0 - eta)
                wb = xi * (1.0 - eta)
                wc = xi * eta
                wd = (1.0 - xi) * eta
                if rotating:
                    n0 = a00[l] * m0 + a01[l] * m1 + a02[l] * m2
                    n1 = a10[l] * m0 + a11[l] * m1 + a12[l] * m2
                    n2 = a20[l] * m0 + a21[l] * m1 + a22[l] * m2
                else:
                    n0 = m0
                    n1 = m1
                    n2 = m2
                xm = np.empty(3)  # not in the hot path (shared cells are the rule)
                vm = np.empty(3)
                for d in range(3):
                    xm[d] = (
                        wa * node_x[na, d, l]
                        + wb * node_x[nb_, d, l]
                        + wc * node_x[nc, d, l]
                        + wd * node_x[nd, d, l]
                    )
                    vm[d] = node_v[s, d, l] - (
                        wa * node_v[na, d, l]
                        + wb * node_v[nb_, d, l]
                        + wc * node_v[nc, d, l]
                        + wd * node_v[nd, d, l]
                    )
                f0, f1, f2 = _contact_force(
                    xs0[l],
                    xs1[l],
                    xs2[l],
                    xm[0],
                    xm[1],
                    xm[2],
                    vm[0],
                    vm[1],
                    vm[2],
                    n0,
                    n1,
                    n2,
                    on_r[l] != 0.0,
                    penalty[l],
                    mu[l],
                    eps2,
                    damping,
                )
                force = (f0, f1, f2)
                for d in range(3):
                    fd = force[d]
                    node_f[s, d, l] += fd
                    node_f[na, d, l] -= wa * fd
                    node_f[nb_, d, l] -= wb * fd
                    node_f[nc, d, l] -= wc * fd
                    node_f[nd, d, l] -= wd * fd


@nb.njit(cache=True, inline="always")
def _add_row(target, row):
    for l in range(target.shape[0]):
        target[l] += row[l]


@nb.njit(cache=True, inline="always")
def _sub_weighted_row(target, weight, row):
    for l in range(target.shape[0]):
        target[l] -= weight[l] * row[l]


@nb.njit(cache=True, fastmath=FAST)
def _map_node_forces_lanes(bi, bf, fpool, rot_a, node_f, q_gen, acc):
    """Generalised forces of the tracked nodes' forces for all lanes: P^T F, Psi^T A^T F.

    A body none of whose tracked nodes carries a force in any lane is skipped;
    otherwise one dense product ``(modes, node*3) x (node*3, L)``, four modes per sweep.
    """
    lanes = q_gen.shape[1]
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
        total = acc[0:3]
        total[:, :] = 0.0
        loaded = False
        for i in range(n0, n1):
            for d in range(3):
                fr = node_f[i, d]
                tr = total[d]
                for l in range(lanes):
                    tr[l] += fr[l]
                    loaded |= fr[l] != 0.0
        if not loaded:
            continue
        for a in range(ntr):
            target = q_gen[dof0 + a]
            w0 = bf[b, 3 + 3 * a]
            w1 = bf[b, 4 + 3 * a]
            w2 = bf[b, 5 + 3 * a]
            t0 = total[0]
            t1 = total[1]
            t2 = total[2]
            for l in range(lanes):
                target[l] += w0 * t0[l] + w1 * t1[l] + w2 * t2[l]
        if nm == 0:
            continue
        if kind == KIND_ROTATING:  # to the body frame, in place
            a = rot_a[b]
            for i in range(n0, n1):
                fi = node_f[i]
                for l in range(lanes):
                    f0 = fi[0, l]
                    f1 = fi[1, l]
                    f2 = fi[2, l]
                    fi[0, l] = a[0, 0, l] * f0 + a[1, 0, l] * f1 + a[2, 0, l] * f2
                    fi[1, l] = a[0, 1, l] * f0 + a[1, 1, l] * f1 + a[2, 1, l] * f2
                    fi[2, l] = a[0, 2, l] * f0 + a[1, 2, l] * f1 + a[2, 2, l] * f2
        width = 3 * (n1 - n0)
        psit = bi[b, B_PSIT0]
        j = 0
        while j + 4 <= nm:
            t0 = q_gen[qd0 + j]
            t1 = q_gen[qd0 + j + 1]
            t2 = q_gen[qd0 + j + 2]
            t3 = q_gen[qd0 + j + 3]
            for k in range(width):
                w0 = fpool[psit + j * width + k]
                w1 = fpool[psit + (j + 1) * width + k]
                w2 = fpool[psit + (j + 2) * width + k]
                w3 = fpool[psit + (j + 3) * width + k]
                fr = node_f[n0 + k // 3, k % 3]
                for l in range(lanes):
                    f = fr[l]
                    t0[l] += w0 * f
                    t1[l] += w1 * f
                    t2[l] += w2 * f
                    t3[l] += w3 * f
            j += 4
        while j < nm:
            t0 = q_gen[qd0 + j]
            for k in range(width):
                w0 = fpool[psit + j * width + k]
                fr = node_f[n0 + k // 3, k % 3]
                for l in range(lanes):
                    t0[l] += w0 * fr[l]
            j += 1


def lane_blocks(n_samples: int, n_threads: int, max_lanes: int = 32) -> int:
    """Lanes per block: blocks of at most ``max_lanes``, a multiple of the threads, balanced.

    33 samples on 2 threads give 2 blocks of 17 lanes (one lane padding).
    """
    n_blocks = max(n_threads, -(-n_samples // max_lanes))
    n_blocks = -(-n_blocks // n_threads) * n_threads
    return max(1, -(-n_samples // n_blocks))


@nb.njit(cache=True, parallel=True)
def rk4_lanes(
    sysdata, params, x0, t0, dt, n_steps, record_every, out_w, bound, out, status, fail_t, lanes
):
    """Classic fixed-step RK4, blocks of ``lanes`` samples in lockstep (prange over blocks).

    Same arguments and results as :func:`fuzzymbs.mbs.kernels.rk4_batch`, plus
    ``lanes``. A block's last lanes beyond the batch repeat its last sample.
    """
    nsamples = params.shape[0]
    nslots = params.shape[1]
    nstate = x0.shape[1]
    nout = out_w.shape[0]
    nblocks = (nsamples + lanes - 1) // lanes
    for blk in nb.prange(nblocks):
        first = blk * lanes
        count = min(lanes, nsamples - first)
        work = make_lane_work(sysdata, lanes)
        p = np.empty((nslots, lanes))
        x = np.empty((nstate, lanes))
        for l in range(lanes):
            src = first + min(l, count - 1)
            for i in range(nslots):
                p[i, l] = params[src, i]
            for i in range(nstate):
                x[i, l] = x0[src, i]
        k1 = np.empty((nstate, lanes))
        k2 = np.empty((nstate, lanes))
        k3 = np.empty((nstate, lanes))
        k4 = np.empty((nstate, lanes))
        xt = np.empty((nstate, lanes))
        y = np.empty(lanes)
        bad = np.empty(lanes)
        alive = np.ones(lanes, dtype=np.bool_)
        for l in range(count):
            status[first + l] = OK
            fail_t[first + l] = np.nan
        flat_x = x.reshape(-1)
        flat_xt = xt.reshape(-1)
        f1 = k1.reshape(-1)
        f2 = k2.reshape(-1)
        f3 = k3.reshape(-1)
        size = nstate * lanes
        rec = 0
        for step in range(n_steps + 1):
            t = t0 + step * dt
            if step % record_every == 0:
                for o in range(nout):
                    y[:] = 0.0
                    for i in range(nstate):
                        w = out_w[o, i]
                        if w != 0.0:
                            for l in range(lanes):
                                y[l] += w * x[i, l]
                    for l in range(count):
                        if alive[l]:
                            out[first + l, o, rec] = y[l]
                            if not abs(y[l]) <= bound[o]:  # also catches NaN
                                status[first + l] = OUT_OF_BOUND if np.isfinite(y[l]) else NONFINITE
                                fail_t[first + l] = t
                rec += 1
                if _retire_failed(first, count, status, alive, out, x, p):
                    break
            if step == n_steps:
                break
            rhs_lanes(t, x, k1, p, sysdata, work)
            for m in range(size):
                flat_xt[m] = flat_x[m] + 0.5 * dt * f1[m]
            rhs_lanes(t + 0.5 * dt, xt, k2, p, sysdata, work)
            for m in range(size):
                flat_xt[m] = flat_x[m] + 0.5 * dt * f2[m]
            rhs_lanes(t + 0.5 * dt, xt, k3, p, sysdata, work)
            for m in range(size):
                flat_xt[m] = flat_x[m] + dt * f3[m]
            rhs_lanes(t + dt, xt, k4, p, sysdata, work)
            bad[:] = 0.0
            for i in range(nstate):
                for l in range(lanes):
                    increment = k1[i, l] + 2.0 * k2[i, l] + 2.0 * k3[i, l] + k4[i, l]
                    xi = x[i, l] + dt / 6.0 * increment
                    x[i, l] = xi
                    bad[l] += xi * 0.0  # NaN for a non-finite entry, else 0
            for l in range(count):
                if alive[l] and not bad[l] == 0.0:
                    status[first + l] = NONFINITE
                    fail_t[first + l] = t + dt
            if _retire_failed(first, count, status, alive, out, x, p):
                break


@nb.njit(cache=True)
def _retire_failed(first, count, status, alive, out, x, p):
    """Flag newly failed lanes (NaN outputs) and let them shadow a healthy lane.

    Returns True when no lane of the block is healthy any more.
    """
    lanes = x.shape[1]
    healthy = -1
    for l in range(count):
        if alive[l] and status[first + l] == OK:
            healthy = l
            break
    for l in range(count):
        if alive[l] and status[first + l] != OK:
            alive[l] = False
            out[first + l, :, :] = np.nan
    if healthy < 0:
        return True
    for l in range(lanes):
        if l >= count or not alive[l]:
            # padding and failed lanes repeat a healthy lane: no NaN, same master cells
            if l >= count and alive[min(l, count - 1)]:
                continue
            for i in range(x.shape[0]):
                x[i, l] = x[i, healthy]
            for i in range(p.shape[0]):
                p[i, l] = p[i, healthy]
    return False


def main(steps: int = 200) -> dict[str, float]:
    """Agreement and speed against rk4_batch on 33 brake samples; per-lane cost by part."""
    import time

    import numba

    from fuzzymbs.mbs import kernels as K
    from fuzzymbs.mbs.system import Coordinate
    from fuzzymbs.models.brake import DiscBrake

    compiled = DiscBrake().compiled
    batch = 33
    rng = np.random.default_rng(0)
    samples = {
        "pad_spring_stiffness": 200e3 * (1 + 0.1 * rng.uniform(-1, 1, batch)),
        "caliper_spring_stiffness": 1e3 * (1 + 0.1 * rng.uniform(-1, 1, batch)),
        "nodal_force": 16e3 * (1 + 0.01 * rng.uniform(-1, 1, batch)),
    }
    params = compiled.parameters.values(samples)
    x0 = compiled.zero_state(batch)
    names = ("lower_pad", "upper_pad", "caliper")
    out_w = np.array([compiled.output_functional(Coordinate(n, 0)) for n in names])
    bound = np.ones(3)
    lanes = lane_blocks(batch, numba.get_num_threads())

    def run(kernel, *extra):
        out = np.empty((batch, 3, steps + 1))
        status = np.zeros(batch, dtype=np.int64)
        fail_t = np.full(batch, np.nan)
        start = time.perf_counter()
        settings = (0.0, 1e-6, steps, 1, out_w, bound)
        kernel(compiled.data, params, x0, *settings, out, status, fail_t, *extra)
        return out, time.perf_counter() - start

    run(rk4_lanes, lanes)  # compile
    run(K.rk4_batch)
    reference, batch_seconds = min((run(K.rk4_batch) for _ in range(3)), key=lambda r: r[1])
    lockstep, lane_seconds = min((run(rk4_lanes, lanes) for _ in range(3)), key=lambda r: r[1])
    figures = {
        "lanes": lanes,
        "max_rel_diff": float(np.abs(lockstep - reference).max() / np.abs(reference).max()),
        "rk4_batch_seconds": batch_seconds,
        "rk4_lanes_seconds": lane_seconds,
    }
    figures.update(_profile_parts(compiled, lanes=16))
    return figures


def _profile_parts(compiled, lanes: int, repeats: int = 2000) -> dict[str, float]:
    """Single-thread CPU time per lane and right-hand side: whole, kinematics, contact, map."""
    import time

    data = compiled.data
    p = compiled.parameters.values({})[0]
    x = np.zeros(compiled.n_state)
    x[compiled.body_dofs["lower_pad"].start] = 55e-6
    x[compiled.body_dofs["upper_pad"].start] = -55e-6
    state = np.ascontiguousarray(np.repeat(x[:, None], lanes, 1))
    columns = np.ascontiguousarray(np.repeat(p[:, None], lanes, 1))
    derivative = np.empty_like(state)
    work = make_lane_work(data, lanes)
    parts = {
        "us_per_lane_rhs": (_repeat_rhs_lanes, (state, derivative, columns, data, work)),
        "us_per_lane_kinematics": (_repeat_kinematics_lanes, (state, data, work)),
        "us_per_lane_contact": (_repeat_contact_lanes, (state, columns, data, work)),
        "us_per_lane_force_map": (_repeat_map_lanes, (data, work)),
    }
    figures = {}
    for name, (func, args) in parts.items():
        func(1, *args)
        start = time.process_time()
        func(repeats, *args)
        figures[name] = 1e6 * (time.process_time() - start) / (repeats * lanes)
    return figures


@nb.njit
def _repeat_rhs_lanes(n, x, dx, p, data, work):
    for _ in range(n):
        rhs_lanes(1e-4, x, dx, p, data, work)


@nb.njit
def _repeat_kinematics_lanes(n, x, data, work):
    ndof, bi, bf, node_xbar, fpool = data[0], data[1], data[2], data[3], data[6]
    node_x, node_v, rot, rot_a = work[1], work[2], work[4], work[5]
    for _ in range(n):
        _node_kinematics_lanes(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)


@nb.njit
def _repeat_contact_lanes(n, x, p, data, work):
    bi, bf, fpool, ipool, ci, cf = data[1], data[2], data[6], data[7], data[11], data[12]
    node_x, node_v, node_f, rot_a, scratch = work[1], work[2], work[3], work[5], work[6]
    for _ in range(n):
        for c in range(ci.shape[0]):
            _contact_pass_lanes(
                c, x, p, bi, bf, ci, cf, fpool, ipool, rot_a, node_x, node_v, node_f, scratch
            )


@nb.njit
def _repeat_map_lanes(n, data, work):
    bi, bf, fpool = data[1], data[2], data[6]
    q_gen, node_f, rot_a, acc = work[0], work[3], work[5], work[7]
    for _ in range(n):
        _map_node_forces_lanes(bi, bf, fpool, rot_a, node_f, q_gen, acc)


if __name__ == "__main__":
    import json

    print(json.dumps(main()))
