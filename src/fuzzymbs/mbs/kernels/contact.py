"""Master-slave penalty contact with regularised Coulomb friction, LANES per vector.

One contact pass: every slave node of one body against the master surface of
another, given as a structured grid of master nodes over a chart (plane or
polar). Per slave: chart coordinates, master cell, gap ``g = n . (x_s - x_m)``,
normal force ``f_N = -c_p g - d v_n`` where ``g < 0`` and ``f_N > 0``,
friction ``f_T = -mu f_N v_t / sqrt(|v_t|^2 + eps^2)``; the force acts on the
slave node and, with the opposite sign and the bilinear shape functions'
weights, on the four master nodes (docs/theory.md). A two-pass (symmetric)
contact is two passes with the roles swapped.

A slave almost always finds the same master cell in all lanes (the samples
differ by per cent, the cells are millimetres): then the master nodes'
positions, velocities and reactions are vector loads and stores. Lanes in
different cells gather per lane, with the same arithmetic. "On the patch",
"gap < 0" and "compressive" are selects, not branches.
"""

from __future__ import annotations

import numba as nb

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.charts import TWO_PI, atan2, locate, pass_scales
from fuzzymbs.mbs.kernels.kinematics import frame_matrix
from fuzzymbs.mbs.kernels.layout import (
    B_DOF0,
    B_KIND,
    B_NTR,
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
    CF_DAMPING,
    CF_EPS,
    I_CELL,
    I_NODES,
    I_U,
    I_V,
    KIND_ROTATING,
    KIND_TRANSLATING,
    S_ETA,
    S_NRM,
    S_ON,
    S_XI,
    S_XM,
)

L = V.LANES


@nb.njit(cache=True)
def max_slaves(ci):
    """Largest number of slave nodes of one contact pass (0 without contact)."""
    largest = 0
    for c in range(ci.shape[0]):
        largest = max(largest, ci[c, C_NSLAVE])
    return largest


@nb.njit(cache=True)
def cells_per_lane(u_vec, v_vec, ugrid, vgrid, periodic, scales, scratch, cells):
    """Master cell of each lane by the scalar :func:`~fuzzymbs.mbs.kernels.charts.locate`
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


@nb.njit(cache=True)
def uniform_chart(u_vec, v_vec, u_first, u_scale, v_first, v_scale, periodic):
    """Chart coordinates in cells, ``((u - u_0) s_u, (v - v_0) s_v)``, v wrapped into the
    turn first: the arithmetic of the scalar :func:`~fuzzymbs.mbs.kernels.charts.locate`
    (no fast-math contraction), so that the vector and per-lane paths agree bit for bit."""
    fu = (u_vec - u_first) * u_scale
    if periodic:
        above = V.where_le(V.splat(v_first + TWO_PI), v_vec, v_vec - TWO_PI, v_vec)
        v_vec = V.where_lt(v_vec, V.splat(v_first), v_vec + TWO_PI, above)
    return fu, (v_vec - v_first) * v_scale


@nb.njit(cache=True)
def cell_offset(f, index):
    """``f - index``: the local coordinate in a cell, rounded as in ``locate``."""
    return f - index


@nb.njit(cache=True)
def bilinear(wa, wb, wc, wd, values, a, b, c, d):
    """``wa x_a + wb x_b + wc x_c + wd x_d`` of the lane vectors at a, b, c, d in
    ``values``, as a fixed chain of fused multiply-adds: compiled without fast-math
    reassociation, so every lane gets the same rounding whether its corners were
    loaded as vectors or gathered lane by lane."""
    value = V.fma(wb, V.load(values, b), wa * V.load(values, a))
    return V.fma(wd, V.load(values, d), V.fma(wc, V.load(values, c), value))


@nb.njit(cache=True)
def react(forces, at, w, f):
    """``forces[at:at + L] -= w f`` with one rounding (as :func:`bilinear`, no fast-math)."""
    V.store(forces, at, V.fma(V.splat(0.0) - w, f, V.load(forces, at)))


#: vectors per slave in the Jacobian record: d f / d x_rel (3 x 3, row-major),
#: d f / d v_rel (3 x 3), the four master weights
JREC = 22


@nb.njit(cache=True, fastmath=V.FAST)
def record_force_law(jrec, at, normal, slide, direction, friction, stiffness, damping, on, weights):
    """Derivatives of one contact point's force law into the Jacobian record at ``at``.

    With the force ``f = f_N n + s_f v_t`` (``s_f = -mu f_N / sqrt(|v_t|^2 + eps^2)``,
    ``f_N = -c_p g - d v_n``), the normal n and the master weights held fixed:

    * ``d f / d x_rel = -c_p a n^T`` with ``a = d f / d f_N = n - mu v_t / sqrt(...)``,
    * ``d f / d v_rel = -d a n^T + s_f (I - n n^T - u u^T)``, ``u = v_t / sqrt(...)``,

    ``x_rel = x_slave - x_master``, ``v_rel`` likewise (docs/theory.md). ``stiffness``
    and ``damping`` are c_p and d times the in-contact mask, ``on`` the mask itself.
    """
    for r in range(3):
        for q in range(3):
            ident = 1.0 if r == q else 0.0
            k_rq = -(stiffness * direction[r] * normal[q])
            c_rq = friction * (ident - normal[r] * normal[q] - slide[r] * slide[q])
            c_rq = on * c_rq - damping * direction[r] * normal[q]
            V.store(jrec, at + L * (3 * r + q), k_rq)
            V.store(jrec, at + L * (9 + 3 * r + q), c_rq)
    for q in range(4):
        V.store(jrec, at + L * (18 + q), weights[q])


@nb.njit(cache=True, fastmath=V.FAST, error_model="numpy")
def contact_pass(c, x, p, sysdata, work):
    """Penalty normal force and regularised Coulomb friction of pass c, all lanes.

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
    jrec, jnodes = work[10], work[11]
    record = work[12][0] != 0  # also the force law's derivatives, for the Jacobian
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
    eps2 = V.splat(cf[c, CF_EPS] * cf[c, CF_EPS])
    damping = cf[c, CF_DAMPING]
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
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = frame_matrix(rot_a, mb)
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
    row0 = 0  # this pass's first slave among all passes' (the Jacobian record's rows)
    for other in range(c):
        row0 += ci[other, C_NSLAVE]
    if record:
        jrec[L * JREC * row0 : L * JREC * (row0 + nslave)] = 0.0
    for k in range(nslave):
        ms = L * 3 * slaves[k]
        xs0 = V.load(node_x, ms)
        xs1 = V.load(node_x, ms + L)
        xs2 = V.load(node_x, ms + 2 * L)
        a1 = xs0 * ua0 + xs1 * ua1 + xs2 * ua2 - cu
        a2 = xs0 * va0 + xs1 * va1 + xs2 * va2 - cv
        if polar:
            V.store(charts, L * k, V.sqrt(a1 * a1 + a2 * a2))
            V.store(charts, L * (nslave + k), atan2(a2, a1))
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
            fu, fv = uniform_chart(u_vec, v_vec, u_first, u_scale, v_first, v_scale, periodic)
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
            fast = V.same_lanes(cell_f)
        if fast:
            if V.all_zero(on):  # on is 0 or 1 per lane
                continue
            xi = cell_offset(fu, i_f)
            eta = cell_offset(fv, j_f)
            i = int(V.get(i_f, 0))
            j = int(V.get(j_f, 0))
            shared = True
        else:
            shared, any_on = cells_per_lane(
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
            xm0 = bilinear(wa, wb, wc, wd, node_x, na, nb_, nc, nd)
            xm1 = bilinear(wa, wb, wc, wd, node_x, na + L, nb_ + L, nc + L, nd + L)
            xm2 = bilinear(wa, wb, wc, wd, node_x, na + 2 * L, nb_ + 2 * L, nc + 2 * L, nd + 2 * L)
            vm0 = bilinear(wa, wb, wc, wd, node_v, na, nb_, nc, nd)
            vm1 = bilinear(wa, wb, wc, wd, node_v, na + L, nb_ + L, nc + L, nd + L)
            vm2 = bilinear(wa, wb, wc, wd, node_v, na + 2 * L, nb_ + 2 * L, nc + 2 * L, nd + 2 * L)
        else:
            # the corners gathered lane by lane into scratch rows, then the same vector
            # arithmetic as above: a lane's result does not depend on the path taken
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
                if record:
                    jn = L * 4 * (row0 + k) + lane
                    jnodes[jn] = grid[i * nv + j]
                    jnodes[jn + L] = grid[(i + 1) * nv + j]
                    jnodes[jn + 2 * L] = grid[(i + 1) * nv + j1]
                    jnodes[jn + 3 * L] = grid[i * nv + j1]
                cells[L * (I_NODES + 1) + lane] = gb
                cells[L * (I_NODES + 2) + lane] = gc
                cells[L * (I_NODES + 3) + lane] = gd
                for q in range(4):
                    node = cells[L * (I_NODES + q) + lane]
                    for d in range(3):
                        scratch[L * (S_XM + 6 * q + d) + lane] = node_x[node + d * L]
                        scratch[L * (S_XM + 6 * q + 3 + d) + lane] = node_v[node + d * L]
                for d in range(3):
                    nrm[d * L + lane] = normals[3 * (i * ncv + j) + d]
            m0 = V.load(nrm, 0)
            m1 = V.load(nrm, L)
            m2 = V.load(nrm, 2 * L)
            c0 = L * S_XM
            step = 6 * L
            xm0 = bilinear(wa, wb, wc, wd, scratch, c0, c0 + step, c0 + 2 * step, c0 + 3 * step)
            c0 += L
            xm1 = bilinear(wa, wb, wc, wd, scratch, c0, c0 + step, c0 + 2 * step, c0 + 3 * step)
            c0 += L
            xm2 = bilinear(wa, wb, wc, wd, scratch, c0, c0 + step, c0 + 2 * step, c0 + 3 * step)
            c0 += L
            vm0 = bilinear(wa, wb, wc, wd, scratch, c0, c0 + step, c0 + 2 * step, c0 + 3 * step)
            c0 += L
            vm1 = bilinear(wa, wb, wc, wd, scratch, c0, c0 + step, c0 + 2 * step, c0 + 3 * step)
            c0 += L
            vm2 = bilinear(wa, wb, wc, wd, scratch, c0, c0 + step, c0 + 2 * step, c0 + 3 * step)
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
            # -mu f_N / sqrt(s) as -(mu f_N / s) sqrt(s): the division does not wait for the
            # square root's result (this chain was the pass's longest, docs/benchmarks.md)
            slip2 = vt0 * vt0 + vt1 * vt1 + vt2 * vt2 + eps2
            scale = -((mu * fn) / slip2) * V.sqrt(slip2)
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
        if record:
            in_contact = V.where_lt(gap, zero, V.where_lt(zero, on, one, zero), zero)
            if kinetic:
                in_contact = V.where_lt(zero, fn, in_contact, zero)
                inv_s = 1.0 / V.sqrt(slip2)
                slide = (vt0 * inv_s, vt1 * inv_s, vt2 * inv_s)
                mu_s = V.where_eq(mu, zero, zero, mu * inv_s)
                direction = (n0 - mu_s * vt0, n1 - mu_s * vt1, n2 - mu_s * vt2)
                friction = scale
            else:
                slide = (zero, zero, zero)
                direction = (n0, n1, n2)
                friction = zero
            record_force_law(
                jrec,
                L * JREC * (row0 + k),
                (n0, n1, n2),
                slide,
                direction,
                friction,
                penalty * in_contact,
                damping * in_contact,
                in_contact,
                (wa, wb, wc, wd),
            )
            if shared:
                jn = L * 4 * (row0 + k)
                for lane in range(L):
                    jnodes[jn + lane] = na // (3 * L)
                    jnodes[jn + L + lane] = nb_ // (3 * L)
                    jnodes[jn + 2 * L + lane] = nc // (3 * L)
                    jnodes[jn + 3 * L + lane] = nd // (3 * L)
        V.store(node_f, ms, V.load(node_f, ms) + f0)
        V.store(node_f, ms + L, V.load(node_f, ms + L) + f1)
        V.store(node_f, ms + 2 * L, V.load(node_f, ms + 2 * L) + f2)
        if shared:
            for node, w in ((na, wa), (nb_, wb), (nc, wc), (nd, wd)):
                react(node_f, node, w, f0)
                react(node_f, node + L, w, f1)
                react(node_f, node + 2 * L, w, f2)
        else:
            # gathered, reduced with the same vector arithmetic, scattered back
            for q in range(4):
                w = (wa, wb, wc, wd)[q]
                for d in range(3):
                    row = L * (S_XM + 3 * q + d)
                    for lane in range(L):
                        scratch[row + lane] = node_f[cells[L * (I_NODES + q) + lane] + d * L]
                    react(scratch, row, w, (f0, f1, f2)[d])
                    for lane in range(L):
                        node_f[cells[L * (I_NODES + q) + lane] + d * L] = scratch[row + lane]
