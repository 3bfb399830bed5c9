"""Compiled physics of spatial mechanisms: one sample per call, a batch per kernel.

Every body is a floating frame with r modal coordinates (r = 0: rigid, its
frame at its centre of mass). Coordinates of a body: the frame origin r, its
Euler parameters p = (p0, p1, p2, p3) (a unit quaternion: no singular
orientation) and the modal coordinates q; velocities: r', the angular velocity
w in the body frame and q'. The mass matrix of a body, from its inertia shape
integrals (Shabana, Dynamics of Multibody Systems, ch. 5; Schwertassek &
Wallrapp, Dynamik flexibler Mehrkoerpersysteme, ch. 5), with S(q) = S0 + C_t q
the first moment, J(q) the inertia about the frame origin and A the rotation::

    [ m I        -A S~        A C_t        ]
    [ S~ A^T      J(q)        C_r + G_i q  ]
    [ C_t^T A^T   (sym.)      I            ]

and the velocity-quadratic and elastic terms are written out in
:func:`body_terms` (the derivation is in docs/mechanisms.md). For a rigid body
this is Newton-Euler, diag(m I, J) (Haug, Computer Aided Kinematics and
Dynamics of Mechanical Systems, ch. 11; Nikravesh, Computer-Aided Analysis of
Mechanical Systems, ch. 6). The Euler parameters follow p' = 1/2 p (0, w) and
are renormalised after every step. Joints are built from Haug's primitives on
markers (a point and three axes of a body; on a flexible body the point may
move with the modes): coincident points (3 equations), perpendicular axes
(dot-1), an axis perpendicular to the line between the points (dot-2), and a
rotational driver. The joints' Jacobian G acts on the velocities (r', w, q');
the constrained equations are solved for the accelerations as in the planar
engine (:mod:`fuzzymbs.mbs.planar.kernels`), and positions and velocities are
projected onto the joints after every accepted step.

Layout arrays (int64):

- bodies  (nb, 5): position offset (7 + r per body), velocity offset (6 + r per
  body), data offset, mode count r, stiffening (0 none; else the body data end with
  K_i (3 r r), K_ij (9 r r) and a beam's axis e (3); 1: a beam, whose markers carry
  their nodes' foreshortening, 2: stress stiffening only, axis zero, no marker data)
- markers (nk, 2): body (-1 ground), data offset (point 3, axes 9, mode shape 3 r)
- joints  (nj, 6): kind, marker i, marker j, first row, data offset, drive profile (-1 none)
- forces  (nf, 5): kind, marker i, marker j (-1 none), data offset, profile (-1 none)
- sizes: position count, velocity count, equation count

Body data: m, S0 (3), J0 (9), then for r > 0: C_t (3 r), C_r (3 r), G_i (3 r r),
C_ij (9 r r), c_ij (9 r), a (r), omega^2 (r), 2 zeta omega (r) -- the
:class:`~fuzzymbs.mbs.modal_body.ModalBody` integrals, a = integral of rho xbar . Psi.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.planar.elimination import (
    finish_projection,
    joint_buffers,
    largest_magnitude,
    project_rows,
    solve_constrained,
)
from fuzzymbs.mbs.planar.kernels import (  # the run status codes are the planar engine's
    FINISHED,
    NOT_FINITE,
    PROJECTION_FAILED,
    STEP_TOO_SMALL,
    TOO_MANY_STEPS,
    joint_row,
    profile,
)
from fuzzymbs.mbs.spatial.elements import force_terms
from fuzzymbs.mbs.spatial.kinematics import (
    add_point_row,
    add_vector_row,
    cross,
    displace,
    marker_axes,
    marker_state,
    rotate,
    rotation,
    spin_terms,
)

__all__ = [
    "FINISHED",
    "NOT_FINITE",
    "PROJECTION_FAILED",
    "STEP_TOO_SMALL",
    "TOO_MANY_STEPS",
    "accelerations",
    "body_terms",
    "joint_terms",
    "project",
]

SPHERICAL = 0
REVOLUTE = 1
UNIVERSAL = 2
CYLINDRICAL = 3
PRISMATIC = 4
FIXED = 5


@nb.njit(cache=True)
def body_terms(bodies, data, q, v, mass, forces):
    """Mass matrix blocks, velocity-quadratic, gravity and elastic forces of every body.

    With u = xbar + Psi q a material point in the body frame and the virtual
    displacement dr + A (-u~ dpi + Psi dq), the inertia forces are (rows r, w, q)::

        m r'' - A S~ w' + A C_t q''      + A (w~ w~ S + 2 w~ C_t q')
        S~ A^T r'' + J w' + M_wq q''     + w~ J w + 2 (w (a + q).q' - int rho Psi q' (u . w))
        C_t^T A^T r'' + M_wq^T w' + q''  + sum_ij w_i w_j (c_ij + C_ij q) + 2 sum_i w_i G_i q'

    with M_wq = C_r + (G_i q)_i, J(q) = J0 - sum_m (c_ij + c_ji)_m q_m - q^T C_ij q,
    int rho x_k Psi_j = c_kj + delta_kj a and int rho Psi_j Psi_k^T = C_kj + delta_kj I
    (from E_i E_j v = e_j v_i - delta_ij v). Gravity g: m g, S~ A^T g, C_t^T A^T g.
    The modes add -omega^2 q - 2 zeta omega q'.

    A stiffened body (:class:`~fuzzymbs.mbs.modal_body.StressStiffening`: K_i of a unit
    body force along e_i, K_ij of the centrifugal unit state w_i w_j) has
    S(q) - 1/2 sum_i (q^T K_i q) e_i as its first moment, S_q = C_t - sum_i e_i (K_i q)^T
    in place of C_t, and J(q) - (q^T K_ij q)_ij; its Lagrange equations add
    A sum_i e_i (q'^T K_i q') to the translation's forces, 2 (q^T K_ij q')_ij w to the
    rotation's and -sum_ij w_i w_j K_ij q to the modes' (the centrifugal stiffening;
    gravity and frame acceleration stiffen through S_q). A beam's foreshortening is the
    case K_i = e_i K_a, K_ij = (delta_ij - e_i e_j) K_s, as the planar engine's beams.
    """
    g = data[0:3]
    rot = np.empty((3, 3))
    first = np.empty(3)
    inertia = np.empty((3, 3))
    for b in range(bodies.shape[0]):
        po = bodies[b, 0]
        vo = bodies[b, 1]
        d = bodies[b, 2]
        r = bodies[b, 3]
        m = data[d]
        rotation(q, po + 3, rot)
        w = v[vo + 3 : vo + 6]
        o_ct = d + 13
        o_cr = o_ct + 3 * r
        o_g = o_cr + 3 * r
        o_cc = o_g + 3 * r * r
        o_cl = o_cc + 9 * r * r
        o_a = o_cl + 9 * r
        o_k = o_a + r
        o_d = o_k + r
        modal = q[po + 7 : po + 7 + r]
        modal_rate = v[vo + 6 : vo + 6 + r]
        # a stiffened body (StressStiffening: K_i, K_ij): K_i q, q^T K_i q, q'^T K_i q'
        # and the inertia's q^T K_ij q, q^T K_ij q'
        shape = np.empty((3, r))
        kaq = np.zeros((3, r))
        axial_form = np.zeros(3)
        axial_curvature = np.zeros(3)
        spin_form = np.zeros((3, 3))
        spin_rate = np.zeros((3, 3))
        stiffened = bodies[b, 4] != 0
        if stiffened:
            o_ka = o_d + r
            o_ks = o_ka + 3 * r * r
            for i in range(3):
                for x in range(r):
                    kav = 0.0
                    for y in range(r):
                        kaq[i, x] += data[o_ka + (i * r + x) * r + y] * modal[y]
                        kav += data[o_ka + (i * r + x) * r + y] * modal_rate[y]
                    axial_form[i] += modal[x] * kaq[i, x]
                    axial_curvature[i] += modal_rate[x] * kav
                for j in range(i, 3):
                    form = 0.0
                    rate = 0.0
                    for x in range(r):
                        ksq = 0.0
                        for y in range(r):
                            ksq += data[o_ks + ((3 * i + j) * r + x) * r + y] * modal[y]
                        form += modal[x] * ksq
                        rate += modal_rate[x] * ksq
                    spin_form[i, j] = spin_form[j, i] = form
                    spin_rate[i, j] = spin_rate[j, i] = rate
        for i in range(3):
            for x in range(r):
                shape[i, x] = data[o_ct + i * r + x] - kaq[i, x]
        # S(q), S_q q', J(q)
        ct_rate = np.zeros(3)
        for i in range(3):
            first[i] = data[d + 1 + i] - 0.5 * axial_form[i]
            for x in range(r):
                first[i] += data[o_ct + i * r + x] * modal[x]
                ct_rate[i] += shape[i, x] * modal_rate[x]
            for j in range(3):
                value = data[d + 4 + 3 * i + j]
                for x in range(r):
                    value -= (
                        data[o_cl + (3 * i + j) * r + x] + data[o_cl + (3 * j + i) * r + x]
                    ) * modal[x]
                    cq = 0.0
                    for y in range(r):
                        cq += data[o_cc + ((3 * i + j) * r + x) * r + y] * modal[y]
                    value -= modal[x] * cq
                inertia[i, j] = value - spin_form[i, j]
        # translation block and its coupling to rotation (-A S~) and modes (A C_t)
        # (A S~)_ij = sum_k A_ik S~_kj, S~ = skew(S)
        for i in range(3):
            mass[vo + i, vo + i] += m
            a_s = np.empty(3)
            a_s[0] = rot[i, 1] * first[2] - rot[i, 2] * first[1]  # (A S~)_i0
            a_s[1] = rot[i, 2] * first[0] - rot[i, 0] * first[2]  # (A S~)_i1
            a_s[2] = rot[i, 0] * first[1] - rot[i, 1] * first[0]  # (A S~)_i2
            for j in range(3):
                mass[vo + i, vo + 3 + j] -= a_s[j]
                mass[vo + 3 + j, vo + i] -= a_s[j]
                mass[vo + 3 + i, vo + 3 + j] += inertia[i, j]
            for x in range(r):
                value = 0.0
                for k in range(3):
                    value += rot[i, k] * shape[k, x]
                mass[vo + i, vo + 6 + x] += value
                mass[vo + 6 + x, vo + i] += value
        for i in range(3):
            for x in range(r):
                value = data[o_cr + i * r + x]
                for y in range(r):
                    value += data[o_g + (i * r + x) * r + y] * modal[y]
                mass[vo + 3 + i, vo + 6 + x] += value
                mass[vo + 6 + x, vo + 3 + i] += value
        for x in range(r):
            mass[vo + 6 + x, vo + 6 + x] += 1.0
        # translation forces: m g - A (w~ w~ S + 2 w~ S_q q') (+ A e q'^T K_a q')
        ws = np.empty(3)
        quadratic = np.empty(3)
        spin_terms(w, first, ct_rate, ws, quadratic)
        local_g = np.empty(3)
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += rot[i, j] * (quadratic[j] - axial_curvature[j])
            forces[vo + i] += m * g[i] - acc
            local_g[i] = rot[0, i] * g[0] + rot[1, i] * g[1] + rot[2, i] * g[2]
        # rotation forces: S~ A^T g - w~ J w - 2 (w (a + q).q' - int rho Psi q' (u . w))
        moment = np.empty(3)
        cross(first, local_g, moment)
        jw = np.empty(3)
        for i in range(3):
            jw[i] = inertia[i, 0] * w[0] + inertia[i, 1] * w[1] + inertia[i, 2] * w[2]
        gyro = np.empty(3)
        cross(w, jw, gyro)
        along = 0.0
        for x in range(r):
            along += (data[o_a + x] + modal[x]) * modal_rate[x]
        for j in range(3):
            spread = 0.0
            for k in range(3):
                part = 0.0
                for x in range(r):
                    inner = data[o_cl + (3 * k + j) * r + x]
                    if k == j:
                        inner += data[o_a + x] + modal[x]
                    for y in range(r):
                        inner += data[o_cc + ((3 * k + j) * r + x) * r + y] * modal[y]
                    part += modal_rate[x] * inner
                spread += w[k] * part
            forces[vo + 3 + j] += moment[j] - gyro[j] - 2.0 * (w[j] * along - spread)
        if stiffened:  # - J' w of the stiffening's inertia -(q^T K_ij q)
            for j in range(3):
                for k in range(3):
                    forces[vo + 3 + j] += 2.0 * spin_rate[j, k] * w[k]
        # modal forces: S_q^T A^T g - sum_ij w_i w_j (c_ij + C_ij q) - 2 sum_i w_i G_i q'
        #               - omega^2 q - 2 zeta omega q' (- sum_ij w_i w_j K_ij q)
        o_ks = o_d + r + 3 * r * r
        for x in range(r):
            value = -data[o_k + x] * modal[x] - data[o_d + x] * modal_rate[x]
            for i in range(3):
                value += shape[i, x] * local_g[i]
                coriolis = 0.0
                for y in range(r):
                    coriolis += data[o_g + (i * r + x) * r + y] * modal_rate[y]
                value -= 2.0 * w[i] * coriolis
                for j in range(3):
                    centrifugal = data[o_cl + (3 * i + j) * r + x]
                    for y in range(r):
                        centrifugal += data[o_cc + ((3 * i + j) * r + x) * r + y] * modal[y]
                        if stiffened:
                            centrifugal += data[o_ks + ((3 * i + j) * r + x) * r + y] * modal[y]
                    value -= w[i] * w[j] * centrifugal
            forces[vo + 6 + x] += value


@nb.njit(cache=True)
def _dot1(ki, kj, ai, aj, q, markers, bodies, geo_i, geo_j, row, jac):
    """Rows and quadratic term of axis ai of marker i perpendicular to axis aj of marker j."""
    axes_i, rates_i, quad_i, local_i = geo_i
    axes_j, rates_j, quad_j, local_j = geo_j
    add_vector_row(ki, markers, bodies, q, local_i[:, ai].copy(), axes_j[:, aj].copy(), jac[row])
    add_vector_row(kj, markers, bodies, q, local_j[:, aj].copy(), axes_i[:, ai].copy(), jac[row])
    value = 0.0
    quadratic = 0.0
    for i in range(3):
        value += axes_i[i, ai] * axes_j[i, aj]
        quadratic += axes_j[i, aj] * quad_i[i, ai] + axes_i[i, ai] * quad_j[i, aj]
        quadratic += 2.0 * rates_i[i, ai] * rates_j[i, aj]
    return value, quadratic


@nb.njit(cache=True)
def joint_terms(t, layout, data, q, v, jac, residual, quadratic, rate, acceleration):
    """Rows of every joint (residual, Jacobian on (r', w), quadratic part, drive terms)."""
    bodies, markers, joints = layout[0], layout[1], layout[2]
    si = np.empty((6, 3))
    sj = np.empty((6, 3))
    geo_i = (np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)))
    geo_j = (np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)))
    unit = np.eye(3)
    for jn in range(joints.shape[0]):
        kind, ki, kj, row, d, drive = joint_row(joints, jn)
        marker_state(ki, markers, bodies, data, q, v, si)
        marker_state(kj, markers, bodies, data, q, v, sj)
        marker_axes(ki, markers, bodies, data, q, v, geo_i[0], geo_i[1], geo_i[2], geo_i[3])
        marker_axes(kj, markers, bodies, data, q, v, geo_j[0], geo_j[1], geo_j[2], geo_j[3])
        r = row
        if kind == SPHERICAL or kind == REVOLUTE or kind == UNIVERSAL or kind == FIXED:
            for c in range(3):
                residual[r] = si[0, c] - sj[0, c]
                quadratic[r] = si[2, c] - sj[2, c]
                add_point_row(ki, markers, bodies, data, q, si[3].copy(), unit[c].copy(), jac[r])
                add_point_row(kj, markers, bodies, data, q, sj[3].copy(), -unit[c], jac[r])
                r += 1
        else:  # cylindrical, prismatic: marker j's point on marker i's z axis
            dvec = sj[0] - si[0]
            dvel = sj[1] - si[1]
            for a in range(2):
                axis = geo_i[0][:, a].copy()
                value = 0.0
                quad = 0.0
                for c in range(3):
                    value += axis[c] * dvec[c]
                    quad += dvec[c] * geo_i[2][c, a] + axis[c] * (sj[2, c] - si[2, c])
                    quad += 2.0 * geo_i[1][c, a] * dvel[c]
                residual[r] = value
                quadratic[r] = quad
                add_vector_row(ki, markers, bodies, q, geo_i[3][:, a].copy(), dvec.copy(), jac[r])
                add_point_row(kj, markers, bodies, data, q, sj[3].copy(), axis, jac[r])
                add_point_row(ki, markers, bodies, data, q, si[3].copy(), -axis, jac[r])
                r += 1
        # perpendicular axes: z_i with x_j, y_j (revolute, cylindrical, prismatic, fixed),
        # z_i with z_j (universal); x_i with y_j (prismatic, fixed: no turn about z)
        pairs = np.zeros((3, 2), dtype=np.int64)
        count = 0
        if kind == REVOLUTE or kind == CYLINDRICAL or kind == PRISMATIC or kind == FIXED:
            pairs[0, 0], pairs[0, 1] = 2, 0
            pairs[1, 0], pairs[1, 1] = 2, 1
            count = 2
        elif kind == UNIVERSAL:
            pairs[0, 0], pairs[0, 1] = 2, 2
            count = 1
        if kind == PRISMATIC or kind == FIXED:
            pairs[count, 0], pairs[count, 1] = 0, 1
            count += 1
        for p in range(count):
            value, quad = _dot1(
                ki, kj, pairs[p, 0], pairs[p, 1], q, markers, bodies, geo_i, geo_j, r, jac
            )
            residual[r] = value
            quadratic[r] = quad
            r += 1
        for x in range(row, r):
            rate[x] = 0.0
            acceleration[x] = 0.0
        if drive >= 0:
            f, fd, fdd = profile(drive, data, d, t)
            c = math.cos(f)
            s = math.sin(f)
            # sin(phi - f) = c (x_j . y_i) - s (x_j . x_i), phi the turn of x_j about z_i
            jac_one = np.zeros(jac.shape[1])
            jac_two = np.zeros(jac.shape[1])
            # int64, not literals: each literal argument would compile _dot1 once more
            zero, one = np.int64(0), np.int64(1)
            d1, q1 = _dot1(
                ki, kj, one, zero, q, markers, bodies, geo_i, geo_j, zero, jac_one.reshape((1, -1))
            )
            d2, q2 = _dot1(
                ki, kj, zero, zero, q, markers, bodies, geo_i, geo_j, zero, jac_two.reshape((1, -1))
            )
            rate1 = 0.0
            rate2 = 0.0
            for x in range(jac.shape[1]):
                jac[r, x] += c * jac_one[x] - s * jac_two[x]
                rate1 += jac_one[x] * v[x]
                rate2 += jac_two[x] * v[x]
            residual[r] = c * d1 - s * d2
            quadratic[r] = (
                c * q1
                - s * q2
                - 2.0 * fd * (s * rate1 + c * rate2)
                - (c * fd * fd + s * fdd) * d1
                + (s * fd * fd - c * fdd) * d2
            )
            rate[r] = fd * (s * d1 + c * d2)
            acceleration[r] = 0.0


@nb.njit(cache=True)
def accelerations(t, q, v, layout, data, user_force, system, solution):
    """Solve the constrained equations at (t, q, v): solution = ((r'', w', q''), lambda)."""
    sizes = layout[4]
    n = sizes[1]
    c = sizes[2]
    solution[:] = 0.0
    mass = np.zeros((n, n))
    body_terms(layout[0], data, q, v, mass, solution[:n])
    force_terms(t, layout, data, q, v, user_force, solution[:n])
    jac = np.zeros((c, n))
    residual = np.empty(c)
    quadratic = np.empty(c)
    rate = np.empty(c)
    acceleration = np.empty(c)
    if c:
        joint_terms(t, layout, data, q, v, jac, residual, quadratic, rate, acceleration)
    return solve_constrained(mass, jac, quadratic, acceleration, system, solution)


@nb.njit(cache=True)
def project(t, q, v, layout, data, tolerance):
    """Renormalise the Euler parameters and move (q, v) onto the joints (least change
    in (r, rotation) and in (r', w)); the largest residual left, or inf."""
    bodies = layout[0]
    sizes = layout[4]
    n = sizes[1]
    c = sizes[2]
    for b in range(bodies.shape[0]):
        rotate(q, bodies[b, 0] + 3, 0.0, 0.0, 0.0)
    if c == 0:
        return 0.0
    residual, quadratic, rate, acceleration, jac = joint_buffers(c, n)
    step = np.zeros(n)
    worst = np.inf
    for _ in range(8):
        jac[:, :] = 0.0
        joint_terms(t, layout, data, q, v, jac, residual, quadratic, rate, acceleration)
        worst = largest_magnitude(residual)
        if worst <= tolerance:
            break
        step[:] = 0.0
        if not project_rows(jac, residual, step):  # step = -G^T (G G^T)^-1 g
            return np.inf
        displace(q, bodies, step)
    if not worst <= tolerance:
        return np.inf
    jac[:, :] = 0.0
    joint_terms(t, layout, data, q, v, jac, residual, quadratic, rate, acceleration)
    return finish_projection(jac, rate, v, residual, worst)
