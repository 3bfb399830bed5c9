"""Compiled right-hand side and batched integrators of an elastic multibody system.

All system data arrive as one tuple of flat arrays (built by
:meth:`fuzzymbs.mbs.system.System.compile`, layout documented there); the
per-sample scalars (stiffnesses, forces, penalty, friction, speeds) are one row
of a ``(B, n_slots)`` parameter table. No allocation happens inside a time
step: each sample allocates its work arrays once. BLAS is not used; the small
dense products are explicit loops that Numba vectorises.

State of one sample: ``x = [coordinates (n), velocities (n)]``, coordinates
body by body (translations s, then modal coordinates q).
"""

from __future__ import annotations

import numba as nb
import numpy as np

# body table columns
B_KIND, B_DOF0, B_NTR, B_NM, B_NODE0, B_NODE1, B_PSI0, B_MAT0, B_SPEED, B_PROF, B_PSIT0 = range(11)
KIND_FIXED, KIND_TRANSLATING, KIND_ROTATING = 0, 1, 2
# contact table columns
(
    C_SBODY,
    C_MBODY,
    C_SLAVE0,
    C_NSLAVE,
    C_KIND,
    C_NU,
    C_NV,
    C_U0,
    C_V0,
    C_GRID0,
    C_NORMAL0,
    C_PEN,
    C_MU,
    C_PERIODIC,
) = range(14)
# contact float table columns beyond the chart frame (0-8), eps (9) and normal damping (10):
# per-pass constants of the cell look-up, computed once by System.compile
CF_USCALE, CF_UUNIFORM, CF_VSCALE, CF_VUNIFORM = range(11, 15)
# failure codes
OK, NONFINITE, OUT_OF_BOUND = 0, 1, 2
FAILURE_REASONS = {
    OK: "",
    NONFINITE: "non-finite state (NaN or inf)",
    OUT_OF_BOUND: "output beyond the displacement bound",
}

_TWO_PI = 2.0 * np.pi
_TAN_PI_8 = 0.41421356237309503
# atan(t) / t as a polynomial in t^2 on |t| <= tan(pi/8): least-squares Chebyshev fit of
# degree 9 (our fit, checked against numpy.arctan: max error 5e-15 rad, tests/mbs)
_ATAN_COEF = (
    1.0,
    -0.3333333333346282,
    0.20000000018777836,
    -0.14285715131378893,
    0.11111124648605722,
    -0.0909084267663382,
    0.07686907598160936,
    -0.065852479637107,
    0.05277364458123443,
    -0.02865878388466727,
)
# Reassociation and FMA contraction let LLVM vectorise the small dot products; NaN/inf
# semantics are kept (no 'nnan'/'ninf') so that blown-up samples are still detected.
FAST = {"reassoc", "contract", "arcp"}
# error_model="numpy" on loops with float divisions: x / 0 gives inf/NaN (caught by the
# integrators' finiteness check) instead of a ZeroDivisionError branch per division,
# which would keep LLVM from vectorising the loop.


@nb.njit(cache=True, inline="always")
def _profile(fpool, ptab, k, t):
    """Value, integral from t = 0, and slope (right-continuous) of profile k at time t."""
    s = ptab[k, 0]
    m = ptab[k, 1]
    ts = fpool[s : s + m]
    vs = fpool[s + m : s + 2 * m]
    cs = fpool[s + 2 * m : s + 3 * m]
    value, integral, slope = _segment(ts, vs, cs, t)
    _, integral0, _ = _segment(ts, vs, cs, 0.0)
    return value, integral - integral0, slope


@nb.njit(cache=True, inline="always")
def _segment(ts, vs, cs, t):
    m = ts.shape[0]
    if t < ts[0]:
        return vs[0], cs[0] + vs[0] * (t - ts[0]), 0.0
    if t >= ts[m - 1]:
        return vs[m - 1], cs[m - 1] + vs[m - 1] * (t - ts[m - 1]), 0.0
    i = 0
    while ts[i + 1] < t:
        i += 1
    h = ts[i + 1] - ts[i]
    slope = (vs[i + 1] - vs[i]) / h
    tau = t - ts[i]
    return vs[i] + slope * tau, cs[i] + vs[i] * tau + 0.5 * slope * tau * tau, slope


@nb.njit(cache=True, inline="always")
def atan2(y, x):
    """Four-quadrant arctangent [rad], (-pi, pi]; ~3x cheaper than libm's in the contact loop.

    Octant reduction to t = min/max in [0, 1], then t > tan(pi/8) shifted by pi/4 via
    (t - 1) / (t + 1), then the polynomial _ATAN_COEF (max error 5e-15 rad).
    """
    ax = abs(x)
    ay = abs(y)
    swap = ay > ax
    num = ax if swap else ay
    den = ay if swap else ax
    if den == 0.0:
        return 0.0
    t = num / den
    shift = 0.0
    if t > _TAN_PI_8:
        t = (t - 1.0) / (t + 1.0)
        shift = 0.25 * np.pi
    z = t * t
    poly = _ATAN_COEF[9]
    for k in range(8, -1, -1):
        poly = poly * z + _ATAN_COEF[k]
    angle = t * poly + shift
    if swap:
        angle = 0.5 * np.pi - angle
    if x < 0.0:
        angle = np.pi - angle
    if y < 0.0:
        angle = -angle
    return angle


@nb.njit(cache=True, inline="always")
def _atan2_select(y, x):
    """:func:`atan2` without branches (selects only), so that a loop over it vectorises.

    The same operations in the same order as :func:`atan2`, hence the same result.
    """
    ax = abs(x)
    ay = abs(y)
    swap = ay > ax
    num = ax if swap else ay
    den = ay if swap else ax
    safe_den = 1.0 if den == 0.0 else den
    t = num / safe_den
    big = t > _TAN_PI_8
    t = (t - 1.0) / (t + 1.0) if big else t
    shift = 0.25 * np.pi if big else 0.0
    z = t * t
    poly = _ATAN_COEF[9]
    for k in range(8, -1, -1):
        poly = poly * z + _ATAN_COEF[k]
    angle = t * poly + shift
    angle = 0.5 * np.pi - angle if swap else angle
    angle = np.pi - angle if x < 0.0 else angle
    angle = -angle if y < 0.0 else angle
    return 0.0 if den == 0.0 else angle


@nb.njit(cache=True)
def _rotation(axis, angle, out):
    """Rodrigues rotation matrix into out (3, 3)."""
    c = np.cos(angle)
    s = np.sin(angle)
    x, y, z = axis[0], axis[1], axis[2]
    v = 1.0 - c
    out[0, 0] = c + x * x * v
    out[0, 1] = x * y * v - z * s
    out[0, 2] = x * z * v + y * s
    out[1, 0] = y * x * v + z * s
    out[1, 1] = c + y * y * v
    out[1, 2] = y * z * v - x * s
    out[2, 0] = z * x * v - y * s
    out[2, 1] = z * y * v + x * s
    out[2, 2] = c + z * z * v


@nb.njit(cache=True, fastmath=FAST)
def rhs(t, x, dx, p, sysdata, work):
    """Time derivative dx of state x at time t for parameter row p (one sample)."""
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
    q_gen, node_x, node_v, node_f, rot, rot_a = work
    nbody = bi.shape[0]
    for i in range(ndof):
        dx[i] = x[ndof + i]
        q_gen[i] = 0.0

    # prescribed rotations: angle, speed, acceleration and A(t) per rotating body
    for b in range(nbody):
        if bi[b, B_KIND] == KIND_ROTATING:
            speed = p[bi[b, B_SPEED]]
            value, integral, slope = _profile(fpool, ptab, bi[b, B_PROF], t)
            rot[b, 0] = speed * integral
            rot[b, 1] = speed * value
            rot[b, 2] = speed * slope
            _rotation(bf[b, 12:15], rot[b, 0], rot_a[b])

    # linear spring/damper groups: Q[idx] -= k K x[idx] + c D v[idx]
    for g in range(lg.shape[0]):
        d0 = lg[g, 0]
        n = lg[g, 1]
        m0 = lg[g, 2]
        k = p[lg[g, 3]]
        c = p[lg[g, 4]]
        idx = ipool[d0 : d0 + n]
        for a in range(n):
            s = 0.0
            row = fpool[m0 + a * n : m0 + (a + 1) * n]
            for bb in range(n):
                s += row[bb] * x[idx[bb]]
            s *= k
            if c != 0.0:
                sd = 0.0
                row_d = fpool[m0 + n * n + a * n : m0 + n * n + (a + 1) * n]
                for bb in range(n):
                    sd += row_d[bb] * x[ndof + idx[bb]]
                s += c * sd
            q_gen[idx[a]] -= s

    # nodal forces (generalised vectors precomputed)
    for f in range(nfi.shape[0]):
        b = nfi[f, 0]
        v0 = nfi[f, 1]
        magnitude = p[nfi[f, 3]]
        if nfi[f, 2] >= 0:
            value, _, _ = _profile(fpool, ptab, nfi[f, 2], t)
            magnitude *= value
        dof0 = bi[b, B_DOF0]
        if nfi[f, 4] == 0:
            for i in range(bi[b, B_NTR] + bi[b, B_NM]):
                q_gen[dof0 + i] += magnitude * fpool[v0 + i]
        else:
            nm = bi[b, B_NM]
            c = np.cos(rot[b, 0])
            s = np.sin(rot[b, 0])
            for j in range(nm):
                q_gen[dof0 + j] += magnitude * (
                    c * fpool[v0 + j] + (1.0 - c) * fpool[v0 + nm + j] - s * fpool[v0 + 2 * nm + j]
                )

    if ci.shape[0] > 0:
        _node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
        node_f[:, :] = 0.0
        for c in range(ci.shape[0]):
            _contact_pass(c, x, p, bi, bf, ci, cf, fpool, ipool, rot_a, node_x, node_v, node_f)
        _map_node_forces(bi, bf, fpool, rot_a, node_f, q_gen)

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
            q_gen[d] -= dof_c[d] * x[ndof + d] + dof_k2[d] * x[d]
        if kind == KIND_ROTATING and nm > 0:
            omega = rot[b, 1]
            alpha = rot[b, 2]
            g0 = m0
            c0 = m0 + nm * nm
            l0 = m0 + 2 * nm * nm
            e0 = l0 + nm
            w2 = omega * omega
            qv = x[qd0 : qd0 + nm]
            vv = x[ndof + qd0 : ndof + qd0 + nm]
            for j in range(nm):
                grow = fpool[g0 + j * nm : g0 + (j + 1) * nm]
                crow = fpool[c0 + j * nm : c0 + (j + 1) * nm]
                sg = 0.0
                sgq = 0.0
                sc = 0.0
                for k in range(nm):
                    sg += grow[k] * vv[k]
                    sgq += grow[k] * qv[k]
                    sc += crow[k] * qv[k]
                s = w2 * (fpool[l0 + j] + sc) + alpha * (fpool[e0 + j] + sgq) + 2.0 * omega * sg
                q_gen[qd0 + j] -= s
        if kind == KIND_TRANSLATING:
            # Schur complement of [[m P P^T, B], [B^T, I]]: s'' = S^-1 (f_s - B f_q)
            s0 = m0
            b0 = m0 + ntr * ntr
            for a in range(ntr):
                r = q_gen[dof0 + a]
                for j in range(nm):
                    r -= fpool[b0 + a * nm + j] * q_gen[qd0 + j]
                rot[b, 3 + a] = r  # scratch
            for a in range(ntr):
                s = 0.0
                for a2 in range(ntr):
                    s += fpool[s0 + a * ntr + a2] * rot[b, 3 + a2]
                dx[ndof + dof0 + a] = s
            for j in range(nm):
                r = q_gen[qd0 + j]
                for a in range(ntr):
                    r -= fpool[b0 + a * nm + j] * dx[ndof + dof0 + a]
                dx[ndof + qd0 + j] = r
        else:
            for j in range(nm):
                dx[ndof + qd0 + j] = q_gen[qd0 + j]


@nb.njit(cache=True, fastmath=FAST)
def _node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v):
    """Inertial positions and velocities of the tracked nodes.

    The elastic part is ``U = Psi_block q`` for all tracked nodes of a body at once,
    accumulated as axpy's over the modes with the transposed block (mode, node*3):
    contiguous, allocation-free and vectorised.
    """
    ux = node_x.reshape(-1)
    uv = node_v.reshape(-1)
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
        # slices (not offset indexing) so that LLVM vectorises the inner loops
        pos = ux[base : base + width]
        vel = uv[base : base + width]
        for k in range(width):
            pos[k] = 0.0
            vel[k] = 0.0
        # four modes per sweep: a quarter of the loads/stores of pos and vel per product
        j = 0
        while j + 4 <= nm:
            r0 = fpool[psit + j * width : psit + (j + 1) * width]
            r1 = fpool[psit + (j + 1) * width : psit + (j + 2) * width]
            r2 = fpool[psit + (j + 2) * width : psit + (j + 3) * width]
            r3 = fpool[psit + (j + 3) * width : psit + (j + 4) * width]
            q0 = x[qd0 + j]
            q1 = x[qd0 + j + 1]
            q2 = x[qd0 + j + 2]
            q3 = x[qd0 + j + 3]
            v0 = x[ndof + qd0 + j]
            v1 = x[ndof + qd0 + j + 1]
            v2 = x[ndof + qd0 + j + 2]
            v3 = x[ndof + qd0 + j + 3]
            for k in range(width):
                a = r0[k]
                b_ = r1[k]
                c = r2[k]
                d = r3[k]
                pos[k] += a * q0 + b_ * q1 + c * q2 + d * q3
                vel[k] += a * v0 + b_ * v1 + c * v2 + d * v3
            j += 4
        while j < nm:
            qj = x[qd0 + j]
            vj = x[ndof + qd0 + j]
            row = fpool[psit + j * width : psit + (j + 1) * width]
            for k in range(width):
                pos[k] += row[k] * qj
                vel[k] += row[k] * vj
            j += 1
        if kind == KIND_ROTATING:
            # x = o + A y, v = A (Omega e x y + ydot), y = xbar + u
            om = rot[b, 1]
            e0 = bf[b, 12]
            e1 = bf[b, 13]
            e2 = bf[b, 14]
            # A and the origin as scalars: no reloads through the (bodies, 3, 3) array
            a = rot_a[b]
            a00 = a[0, 0]
            a01 = a[0, 1]
            a02 = a[0, 2]
            a10 = a[1, 0]
            a11 = a[1, 1]
            a12 = a[1, 2]
            a20 = a[2, 0]
            a21 = a[2, 1]
            a22 = a[2, 2]
            o0 = bf[b, 0]
            o1 = bf[b, 1]
            o2 = bf[b, 2]
            for i in range(n0, n1):
                u0 = node_xbar[i, 0] + node_x[i, 0]
                u1 = node_xbar[i, 1] + node_x[i, 1]
                u2 = node_xbar[i, 2] + node_x[i, 2]
                z0 = node_v[i, 0] + om * (e1 * u2 - e2 * u1)
                z1 = node_v[i, 1] + om * (e2 * u0 - e0 * u2)
                z2 = node_v[i, 2] + om * (e0 * u1 - e1 * u0)
                node_x[i, 0] = o0 + a00 * u0 + a01 * u1 + a02 * u2
                node_x[i, 1] = o1 + a10 * u0 + a11 * u1 + a12 * u2
                node_x[i, 2] = o2 + a20 * u0 + a21 * u1 + a22 * u2
                node_v[i, 0] = a00 * z0 + a01 * z1 + a02 * z2
                node_v[i, 1] = a10 * z0 + a11 * z1 + a12 * z2
                node_v[i, 2] = a20 * z0 + a21 * z1 + a22 * z2
        else:
            r0 = bf[b, 0]
            r1 = bf[b, 1]
            r2 = bf[b, 2]
            w0 = 0.0
            w1 = 0.0
            w2 = 0.0
            for a in range(ntr):
                sa = x[dof0 + a]
                va = x[ndof + dof0 + a]
                r0 += bf[b, 3 + 3 * a] * sa
                r1 += bf[b, 4 + 3 * a] * sa
                r2 += bf[b, 5 + 3 * a] * sa
                w0 += bf[b, 3 + 3 * a] * va
                w1 += bf[b, 4 + 3 * a] * va
                w2 += bf[b, 5 + 3 * a] * va
            for i in range(n0, n1):
                node_x[i, 0] += r0 + node_xbar[i, 0]
                node_x[i, 1] += r1 + node_xbar[i, 1]
                node_x[i, 2] += r2 + node_xbar[i, 2]
                node_v[i, 0] += w0
                node_v[i, 1] += w1
                node_v[i, 2] += w2


@nb.njit(cache=True, fastmath=FAST, error_model="numpy")
def _contact_pass(c, x, p, bi, bf, ci, cf, fpool, ipool, rot_a, node_x, node_v, node_f):
    """Penalty normal force and regularised Coulomb friction of one contact pass."""
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
    # master frame once per pass: inertial chart axes ua, va, offsets cu, cv, so that the
    # chart coordinates of an inertial point x are (x . ua - cu, x . va - cv)
    kind = bi[mb, B_KIND]
    o0 = bf[mb, 0]
    o1 = bf[mb, 1]
    o2 = bf[mb, 2]
    if kind == KIND_TRANSLATING:
        dof0 = bi[mb, B_DOF0]
        for a in range(bi[mb, B_NTR]):
            sa = x[dof0 + a]
            o0 += bf[mb, 3 + 3 * a] * sa
            o1 += bf[mb, 4 + 3 * a] * sa
            o2 += bf[mb, 5 + 3 * a] * sa
    rotating = kind == KIND_ROTATING
    am = rot_a[mb]
    if rotating:
        ua0 = am[0, 0] * cf[c, 3] + am[0, 1] * cf[c, 4] + am[0, 2] * cf[c, 5]
        ua1 = am[1, 0] * cf[c, 3] + am[1, 1] * cf[c, 4] + am[1, 2] * cf[c, 5]
        ua2 = am[2, 0] * cf[c, 3] + am[2, 1] * cf[c, 4] + am[2, 2] * cf[c, 5]
        va0 = am[0, 0] * cf[c, 6] + am[0, 1] * cf[c, 7] + am[0, 2] * cf[c, 8]
        va1 = am[1, 0] * cf[c, 6] + am[1, 1] * cf[c, 7] + am[1, 2] * cf[c, 8]
        va2 = am[2, 0] * cf[c, 6] + am[2, 1] * cf[c, 7] + am[2, 2] * cf[c, 8]
    else:
        ua0 = cf[c, 3]
        ua1 = cf[c, 4]
        ua2 = cf[c, 5]
        va0 = cf[c, 6]
        va1 = cf[c, 7]
        va2 = cf[c, 8]
    chart_o_u = cf[c, 0] * cf[c, 3] + cf[c, 1] * cf[c, 4] + cf[c, 2] * cf[c, 5]
    chart_o_v = cf[c, 0] * cf[c, 6] + cf[c, 1] * cf[c, 7] + cf[c, 2] * cf[c, 8]
    cu = o0 * ua0 + o1 * ua1 + o2 * ua2 + chart_o_u
    cv = o0 * va0 + o1 * va1 + o2 * va2 + chart_o_v
    # O(1) cell look-up: index = (value - first) * scale; on a uniform grid that is the
    # cell and its local coordinate directly, otherwise a start for a short walk (the
    # scales and uniformity flags are constant per pass: computed by System.compile)
    u_first = ugrid[0]
    u_scale = cf[c, CF_USCALE]
    u_uniform = cf[c, CF_UUNIFORM] != 0.0
    v_first = vgrid[0]
    v_cells = nv if periodic else nv - 1
    v_scale = cf[c, CF_VSCALE]
    v_uniform = cf[c, CF_VUNIFORM] != 0.0
    kinetic = mu != 0.0 or damping != 0.0  # frictionless, undamped: no velocities needed
    # chart coordinates of all slaves first, into two contiguous scratch columns at the
    # end of node_x, so that sqrt, division and the arctangent run SIMD over the slaves
    nslave = slaves.shape[0]
    flat = node_x.reshape(-1)
    chart_u = flat[flat.size - 2 * nslave : flat.size - nslave]
    chart_v = flat[flat.size - nslave :]
    for k in range(nslave):
        s = slaves[k]
        xs0 = node_x[s, 0]
        xs1 = node_x[s, 1]
        xs2 = node_x[s, 2]
        chart_u[k] = xs0 * ua0 + xs1 * ua1 + xs2 * ua2 - cu
        chart_v[k] = xs0 * va0 + xs1 * va1 + xs2 * va2 - cv
    if polar:
        for k in range(nslave):
            a1 = chart_u[k]
            a2 = chart_v[k]
            chart_u[k] = np.sqrt(a1 * a1 + a2 * a2)
            chart_v[k] = _atan2_select(a2, a1)
    for k in range(nslave):
        s = slaves[k]
        u = chart_u[k]
        v = chart_v[k]
        fu = (u - u_first) * u_scale
        if not (0.0 <= fu <= nu - 1):
            continue  # off the patch: no contact, nothing else computed
        i = min(int(fu), nu - 2)
        if u_uniform:
            xi = fu - i
        else:
            while i > 0 and u < ugrid[i]:
                i -= 1
            while i < nu - 2 and u > ugrid[i + 1]:
                i += 1
            xi = (u - ugrid[i]) / (ugrid[i + 1] - ugrid[i])
        if periodic:
            if v < v_first:
                v += _TWO_PI
            elif v >= v_first + _TWO_PI:
                v -= _TWO_PI
        fv = (v - v_first) * v_scale
        if not (0.0 <= fv <= v_cells):
            continue
        j = min(int(fv), v_cells - 1)
        if v_uniform:
            eta = fv - j
        else:
            while j > 0 and v < vgrid[j]:
                j -= 1
            while j < v_cells - 1 and v > (vgrid[j + 1] if j + 1 < nv else v_first + _TWO_PI):
                j += 1
            upper = vgrid[j + 1] if j + 1 < nv else v_first + _TWO_PI
            eta = (v - vgrid[j]) / (upper - vgrid[j])
        j1 = j + 1 if j + 1 < nv else 0
        na = grid[i * nv + j]
        nb_ = grid[(i + 1) * nv + j]
        nc = grid[(i + 1) * nv + j1]
        nd = grid[i * nv + j1]
        wa = (1.0 - xi) * (1.0 - eta)
        wb = xi * (1.0 - eta)
        wc = xi * eta
        wd = (1.0 - xi) * eta
        k3 = 3 * (i * ncv + j)
        m0 = normals[k3]
        m1 = normals[k3 + 1]
        m2 = normals[k3 + 2]
        if rotating:
            n0 = am[0, 0] * m0 + am[0, 1] * m1 + am[0, 2] * m2
            n1 = am[1, 0] * m0 + am[1, 1] * m1 + am[1, 2] * m2
            n2 = am[2, 0] * m0 + am[2, 1] * m1 + am[2, 2] * m2
        else:
            n0 = m0
            n1 = m1
            n2 = m2
        xm0 = wa * node_x[na, 0] + wb * node_x[nb_, 0] + wc * node_x[nc, 0] + wd * node_x[nd, 0]
        xm1 = wa * node_x[na, 1] + wb * node_x[nb_, 1] + wc * node_x[nc, 1] + wd * node_x[nd, 1]
        xm2 = wa * node_x[na, 2] + wb * node_x[nb_, 2] + wc * node_x[nc, 2] + wd * node_x[nd, 2]
        gap = n0 * (node_x[s, 0] - xm0) + n1 * (node_x[s, 1] - xm1) + n2 * (node_x[s, 2] - xm2)
        if gap >= 0.0:
            continue
        if not kinetic:
            fn = -penalty * gap
            f0 = fn * n0
            f1 = fn * n1
            f2 = fn * n2
            _scatter(node_f, s, na, nb_, nc, nd, wa, wb, wc, wd, f0, f1, f2)
            continue
        vr0 = node_v[s, 0] - (
            wa * node_v[na, 0] + wb * node_v[nb_, 0] + wc * node_v[nc, 0] + wd * node_v[nd, 0]
        )
        vr1 = node_v[s, 1] - (
            wa * node_v[na, 1] + wb * node_v[nb_, 1] + wc * node_v[nc, 1] + wd * node_v[nd, 1]
        )
        vr2 = node_v[s, 2] - (
            wa * node_v[na, 2] + wb * node_v[nb_, 2] + wc * node_v[nc, 2] + wd * node_v[nd, 2]
        )
        vn = n0 * vr0 + n1 * vr1 + n2 * vr2
        fn = -penalty * gap - damping * vn
        if fn <= 0.0:
            continue
        vt0 = vr0 - vn * n0
        vt1 = vr1 - vn * n1
        vt2 = vr2 - vn * n2
        scale = -mu * fn / np.sqrt(vt0 * vt0 + vt1 * vt1 + vt2 * vt2 + eps2)
        f0 = fn * n0 + scale * vt0
        f1 = fn * n1 + scale * vt1
        f2 = fn * n2 + scale * vt2
        _scatter(node_f, s, na, nb_, nc, nd, wa, wb, wc, wd, f0, f1, f2)


@nb.njit(cache=True, inline="always")
def pass_scales(cf, c):
    """``(u_scale, u_uniform, v_scale, v_uniform)`` of contact pass c, for :func:`locate`."""
    return (
        cf[c, CF_USCALE],
        cf[c, CF_UUNIFORM] != 0.0,
        cf[c, CF_VSCALE],
        cf[c, CF_VUNIFORM] != 0.0,
    )


@nb.njit(cache=True)
def locate(u, v, ugrid, vgrid, periodic, scales):
    """Master cell of the chart point (u, v): ``(on the patch, i, j, xi, eta)``.

    ``scales = (u_scale, u_uniform, v_scale, v_uniform)`` (``cf`` columns CF_*).
    On a uniform grid the cell and the local coordinate follow from one multiply
    and a truncation; otherwise that is the start of a short walk. A periodic v
    (polar angle) is wrapped into the grid's turn first. Off the patch:
    ``(False, 0, 0, 0.0, 0.0)``.

    Used by the lockstep kernel's per-lane path. :func:`_contact_pass` spells out
    the same steps inline: with this helper its pass measured about 1.4 times
    slower (an A/B in one process during session 3, not kept as a benchmark;
    the reason was not found).
    """
    nu = ugrid.shape[0]
    nv = vgrid.shape[0]
    v_cells = nv if periodic else nv - 1
    u_scale, u_uniform, v_scale, v_uniform = scales
    u_first = ugrid[0]
    v_first = vgrid[0]
    on = False
    i = 0
    j = 0
    xi = 0.0
    eta = 0.0
    fu = (u - u_first) * u_scale
    if 0.0 <= fu <= nu - 1:
        if periodic:
            if v < v_first:
                v += _TWO_PI
            elif v >= v_first + _TWO_PI:
                v -= _TWO_PI
        fv = (v - v_first) * v_scale
        if 0.0 <= fv <= v_cells:
            on = True
            i = min(int(fu), nu - 2)
            j = min(int(fv), v_cells - 1)
            if u_uniform:
                xi = fu - i
            else:
                while i > 0 and u < ugrid[i]:
                    i -= 1
                while i < nu - 2 and u > ugrid[i + 1]:
                    i += 1
                xi = (u - ugrid[i]) / (ugrid[i + 1] - ugrid[i])
            if v_uniform:
                eta = fv - j
            else:
                while j > 0 and v < vgrid[j]:
                    j -= 1
                while j < v_cells - 1 and v > (vgrid[j + 1] if j + 1 < nv else v_first + _TWO_PI):
                    j += 1
                upper = vgrid[j + 1] if j + 1 < nv else v_first + _TWO_PI
                eta = (v - vgrid[j]) / (upper - vgrid[j])
    return on, i, j, xi, eta


@nb.njit(cache=True, inline="always")
def _scatter(node_f, s, na, nb_, nc, nd, wa, wb, wc, wd, f0, f1, f2):
    """Force (f0, f1, f2) on slave node s, its opposite spread over the master nodes."""
    node_f[s, 0] += f0
    node_f[s, 1] += f1
    node_f[s, 2] += f2
    node_f[na, 0] -= wa * f0
    node_f[na, 1] -= wa * f1
    node_f[na, 2] -= wa * f2
    node_f[nb_, 0] -= wb * f0
    node_f[nb_, 1] -= wb * f1
    node_f[nb_, 2] -= wb * f2
    node_f[nc, 0] -= wc * f0
    node_f[nc, 1] -= wc * f1
    node_f[nc, 2] -= wc * f2
    node_f[nd, 0] -= wd * f0
    node_f[nd, 1] -= wd * f1
    node_f[nd, 2] -= wd * f2


@nb.njit(cache=True)
def _is_uniform(grid, cells):
    """True if the ``cells`` intervals of ``grid`` are equal to 1e-12 relative."""
    h = (grid[cells] - grid[0]) / cells
    for k in range(cells):
        if abs(grid[k + 1] - grid[k] - h) > 1e-12 * abs(h):
            return False
    return True


@nb.njit(cache=True, fastmath=FAST)
def _map_node_forces(bi, bf, fpool, rot_a, node_f, q_gen):
    """Generalised forces of the tracked nodes' forces: P^T F and Psi_k^T A^T F.

    Nodes without force (out of contact) are skipped: with few nodes in contact the
    work is one contiguous axpy over the modes per loaded node; when more than a
    quarter of a body's tracked nodes are loaded, one dense transposed product over
    all of them (four modes per sweep, vectorised dot products) is cheaper.
    """
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
        # one branch-free sweep: count the loaded nodes and sum the forces (the frame
        # translations take the resultant; per-node updates of q_gen were a chain of
        # dependent loads and stores)
        loaded = 0
        sum0 = 0.0
        sum1 = 0.0
        sum2 = 0.0
        for i in range(n0, n1):
            f0 = node_f[i, 0]
            f1 = node_f[i, 1]
            f2 = node_f[i, 2]
            sum0 += f0
            sum1 += f1
            sum2 += f2
            loaded += (f0 != 0.0) | (f1 != 0.0) | (f2 != 0.0)
        if loaded == 0:
            continue
        for a in range(ntr):
            q_gen[dof0 + a] += bf[b, 3 + 3 * a] * sum0 + bf[b, 4 + 3 * a] * sum1
            q_gen[dof0 + a] += bf[b, 5 + 3 * a] * sum2
        if kind == KIND_ROTATING:  # to the body frame, in place (zero stays zero)
            a = rot_a[b]
            a00 = a[0, 0]
            a01 = a[0, 1]
            a02 = a[0, 2]
            a10 = a[1, 0]
            a11 = a[1, 1]
            a12 = a[1, 2]
            a20 = a[2, 0]
            a21 = a[2, 1]
            a22 = a[2, 2]
            for i in range(n0, n1):
                f0 = node_f[i, 0]
                f1 = node_f[i, 1]
                f2 = node_f[i, 2]
                node_f[i, 0] = a00 * f0 + a10 * f1 + a20 * f2
                node_f[i, 1] = a01 * f0 + a11 * f1 + a21 * f2
                node_f[i, 2] = a02 * f0 + a12 * f1 + a22 * f2
        if loaded == 0 or nm == 0:
            continue
        target = q_gen[qd0 : qd0 + nm]
        if 4 * loaded > n1 - n0:
            width = 3 * (n1 - n0)
            flat = node_f.reshape(-1)[3 * n0 : 3 * n1]
            psit = bi[b, B_PSIT0]
            j = 0
            while j + 4 <= nm:
                r0 = fpool[psit + j * width : psit + (j + 1) * width]
                r1 = fpool[psit + (j + 1) * width : psit + (j + 2) * width]
                r2 = fpool[psit + (j + 2) * width : psit + (j + 3) * width]
                r3 = fpool[psit + (j + 3) * width : psit + (j + 4) * width]
                a0 = 0.0
                a1 = 0.0
                a2 = 0.0
                a3 = 0.0
                for k in range(width):
                    f = flat[k]
                    a0 += r0[k] * f
                    a1 += r1[k] * f
                    a2 += r2[k] * f
                    a3 += r3[k] * f
                target[j] += a0
                target[j + 1] += a1
                target[j + 2] += a2
                target[j + 3] += a3
                j += 4
            while j < nm:
                row = fpool[psit + j * width : psit + (j + 1) * width]
                acc = 0.0
                for k in range(width):
                    acc += row[k] * flat[k]
                target[j] += acc
                j += 1
            continue
        psi0 = bi[b, B_PSI0]
        for i in range(n0, n1):
            f0 = node_f[i, 0]
            f1 = node_f[i, 1]
            f2 = node_f[i, 2]
            if f0 == 0.0 and f1 == 0.0 and f2 == 0.0:
                continue  # nodes out of contact cost nothing here
            row = psi0 + (i - n0) * 3 * nm
            r0 = fpool[row : row + nm]
            r1 = fpool[row + nm : row + 2 * nm]
            r2 = fpool[row + 2 * nm : row + 3 * nm]
            for j in range(nm):
                target[j] += r0[j] * f0 + r1[j] * f1 + r2[j] * f2


@nb.njit(cache=True)
def max_slaves(ci):
    """Largest number of slave nodes of one contact pass (0 without contact)."""
    largest = 0
    for c in range(ci.shape[0]):
        largest = max(largest, ci[c, C_NSLAVE])
    return largest


@nb.njit(cache=True)
def make_work(sysdata):
    """Per-sample work arrays of the right-hand side.

    ``(q_gen (n), node_x, node_v, node_f (tracked, 3), rot (bodies, 6), rot_a (bodies, 3, 3))``;
    node_x has extra rows at its end, scratch of the contact passes.
    """
    ndof = sysdata[0]
    nbody = sysdata[1].shape[0]
    ntracked = sysdata[3].shape[0]
    # node_x: the tracked nodes, then scratch rows for two chart coordinates per slave
    scratch_rows = (2 * max_slaves(sysdata[11]) + 2) // 3
    return (
        np.zeros(ndof),
        np.zeros((ntracked + scratch_rows, 3)),
        np.zeros((ntracked, 3)),
        np.zeros((ntracked, 3)),
        np.zeros((nbody, 6)),
        np.zeros((nbody, 3, 3)),
    )


@nb.njit(cache=True, parallel=True)
def rk4_batch(
    sysdata, params, x0, t0, dt, n_steps, record_every, out_w, bound, out, status, fail_t
):
    """Classic fixed-step RK4 for a batch of samples (prange over samples).

    Parameters
    ----------
    params : (B, n_slots) parameter rows; x0 : (B, 2n) initial states.
    out_w : (n_out, 2n) linear output functionals; out : (B, n_out, n_rec) filled in place.
    bound : (n_out,) an output with |y| > bound stops the sample (status OUT_OF_BOUND).
    status, fail_t : (B,) per-sample status code and failure time [s] (NaN if ok).
    """
    for b in nb.prange(params.shape[0]):
        integrate_sample(
            sysdata, params, x0, t0, dt, n_steps, record_every, out_w, bound, out, status, fail_t, b
        )


@nb.njit(cache=True)
def integrate_sample(
    sysdata, params, x0, t0, dt, n_steps, record_every, out_w, bound, out, status, fail_t, b
):
    """RK4 of sample b of the batch (arguments as :func:`rk4_batch`), on the calling thread."""
    nstate = x0.shape[1]
    nout = out_w.shape[0]
    work = make_work(sysdata)
    p = params[b]
    x = x0[b].copy()
    k1 = np.empty(nstate)
    k2 = np.empty(nstate)
    k3 = np.empty(nstate)
    k4 = np.empty(nstate)
    xt = np.empty(nstate)
    status[b] = OK
    fail_t[b] = np.nan
    rec = 0
    for step in range(n_steps + 1):
        t = t0 + step * dt
        if step % record_every == 0:
            for o in range(nout):
                y = 0.0
                for i in range(nstate):
                    y += out_w[o, i] * x[i]
                out[b, o, rec] = y
                if not abs(y) <= bound[o]:  # also catches NaN
                    status[b] = OUT_OF_BOUND if np.isfinite(y) else NONFINITE
            rec += 1
        if status[b] != OK or step == n_steps:
            if status[b] != OK:
                fail_t[b] = t
            break
        rhs(t, x, k1, p, sysdata, work)
        for i in range(nstate):
            xt[i] = x[i] + 0.5 * dt * k1[i]
        rhs(t + 0.5 * dt, xt, k2, p, sysdata, work)
        for i in range(nstate):
            xt[i] = x[i] + 0.5 * dt * k2[i]
        rhs(t + 0.5 * dt, xt, k3, p, sysdata, work)
        for i in range(nstate):
            xt[i] = x[i] + dt * k3[i]
        rhs(t + dt, xt, k4, p, sysdata, work)
        finite = True
        for i in range(nstate):
            x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            if not np.isfinite(x[i]):
                finite = False
        if not finite:
            status[b] = NONFINITE
            fail_t[b] = t + dt
            break
    if status[b] != OK:
        out[b, :, :] = np.nan


@nb.njit(cache=True, parallel=True)
def rhs_batch(sysdata, params, rows, times, states, out):
    """out[i] = f(times[i], states[i]) with parameter row params[rows[i]] (prange over i)."""
    for i in nb.prange(states.shape[0]):
        work = make_work(sysdata)
        rhs(times[i], states[i], out[i], params[rows[i]], sysdata, work)
