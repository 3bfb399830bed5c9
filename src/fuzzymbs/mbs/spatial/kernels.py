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
  body), data offset, mode count r, stiffened (1: the body data end with K_a, K_s
  (r r each) and the axis e (3))
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

from fuzzymbs.mbs.planar.integrator import error_norm, stage_state, stage_time, step_factor
from fuzzymbs.mbs.planar.kernels import (  # the run status codes are the planar engine's
    FINISHED,
    NOT_FINITE,
    PROJECTION_FAILED,
    STEP_TOO_SMALL,
    TOO_MANY_STEPS,
    profile,
    project_rows,
    remove_velocity_excess,
    solve_in_place,
)

SPHERICAL = 0
REVOLUTE = 1
UNIVERSAL = 2
CYLINDRICAL = 3
PRISMATIC = 4
FIXED = 5
SPRING_DAMPER = 0
MARKER_LOAD = 1
USER_FORCE = 2
CONTACT = 3
BUSHING = 4
#: Numbers a user force function receives for each marker: position (3), velocity (3),
#: angular velocity (3, global) and the axes x, y, z (3 each, global).
USER_STATE_SIZE = 18


@nb.njit(cache=True)
def rotation(q, o, out):
    """Rotation matrix of the Euler parameters q[o:o + 4] into ``out`` (3, 3)."""
    e0, e1, e2, e3 = q[o], q[o + 1], q[o + 2], q[o + 3]
    out[0, 0] = 2.0 * (e0 * e0 + e1 * e1) - 1.0
    out[0, 1] = 2.0 * (e1 * e2 - e0 * e3)
    out[0, 2] = 2.0 * (e1 * e3 + e0 * e2)
    out[1, 0] = 2.0 * (e1 * e2 + e0 * e3)
    out[1, 1] = 2.0 * (e0 * e0 + e2 * e2) - 1.0
    out[1, 2] = 2.0 * (e2 * e3 - e0 * e1)
    out[2, 0] = 2.0 * (e1 * e3 - e0 * e2)
    out[2, 1] = 2.0 * (e2 * e3 + e0 * e1)
    out[2, 2] = 2.0 * (e0 * e0 + e3 * e3) - 1.0


@nb.njit(cache=True)
def cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@nb.njit(cache=True)
def spin_terms(w, s, sd, ws, quadratic):
    """ws = w x s and quadratic = w x (w x s) + 2 w x s': the body-frame parts of a moving
    point's velocity and acceleration that the frame's turning adds."""
    cross(w, s, ws)
    twice = np.empty(3)
    cross(w, ws, quadratic)
    cross(w, sd, twice)
    for i in range(3):
        quadratic[i] += 2.0 * twice[i]


@nb.njit(cache=True)
def stiffening_axis_offset(bodies, body):
    """Where a stiffened body's axis e (3) sits in its data (after K_a and K_s)."""
    r = bodies[body, 3]
    return bodies[body, 2] + 13 + 6 * r + 12 * r * r + 9 * r + 3 * r + 2 * r * r


@nb.njit(cache=True)
def marker_foreshortening(k, markers, bodies, data, q, gq, axis):
    """A marker on a stiffened body: G q into ``gq`` and the axis into ``axis``; False (and
    zeros) for any other marker."""
    body = markers[k, 0]
    gq[:] = 0.0
    axis[:] = 0.0
    if body < 0 or bodies[body, 4] == 0:
        return False
    r = bodies[body, 3]
    po = bodies[body, 0]
    d = markers[k, 1] + 12 + 3 * r
    o = stiffening_axis_offset(bodies, body)
    for i in range(3):
        axis[i] = data[o + i]
    for x in range(r):
        for y in range(r):
            gq[x] += data[d + x * r + y] * q[po + 7 + y]
    return True


@nb.njit(cache=True)
def marker_state(k, markers, bodies, data, q, v, out):
    """Kinematics of marker ``k``'s point into ``out`` (6, 3).

    Rows: position, velocity, the velocity-quadratic part of the acceleration
    (A (w x (w x s) + 2 w x s'), s' = Psi q' the point's elastic rate), the point s
    in the body frame (deformed), the body's angular velocity w (body frame) and in
    the global frame.
    """
    body = markers[k, 0]
    d = markers[k, 1]
    if body < 0:
        for i in range(3):
            out[0, i] = data[d + i]
            out[3, i] = data[d + i]
        out[1, :] = 0.0
        out[2, :] = 0.0
        out[4, :] = 0.0
        out[5, :] = 0.0
        return
    po = bodies[body, 0]
    vo = bodies[body, 1]
    r = bodies[body, 3]
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    s = np.empty(3)
    sd = np.zeros(3)
    for i in range(3):
        s[i] = data[d + i]
        for m in range(r):
            psi = data[d + 12 + i * r + m]
            s[i] += psi * q[po + 7 + m]
            sd[i] += psi * v[vo + 6 + m]
    # on a stiffened body the point moves back along the axis by 1/2 q^T G q: its rate
    # is q'^T G q, the velocity-quadratic part of its acceleration q'^T G q'
    gq = np.empty(r)
    axis = np.empty(3)
    curvature = 0.0
    if marker_foreshortening(k, markers, bodies, data, q, gq, axis):
        half = 0.0
        rate = 0.0
        g = markers[k, 1] + 12 + 3 * r
        for x in range(r):
            half += 0.5 * q[po + 7 + x] * gq[x]
            rate += v[vo + 6 + x] * gq[x]
            for y in range(r):
                curvature += v[vo + 6 + x] * data[g + x * r + y] * v[vo + 6 + y]
        for i in range(3):
            s[i] -= half * axis[i]
            sd[i] -= rate * axis[i]
    w = v[vo + 3 : vo + 6]
    ws = np.empty(3)
    quadratic = np.empty(3)
    spin_terms(w, s, sd, ws, quadratic)
    for i in range(3):
        quadratic[i] -= curvature * axis[i]
    for i in range(3):
        out[0, i] = q[po + i]
        out[1, i] = v[vo + i]
        out[2, i] = 0.0
        out[5, i] = 0.0
        for j in range(3):
            out[0, i] += rot[i, j] * s[j]
            out[1, i] += rot[i, j] * (ws[j] + sd[j])
            out[2, i] += rot[i, j] * quadratic[j]
            out[5, i] += rot[i, j] * w[j]
        out[3, i] = s[i]
        out[4, i] = w[i]


@nb.njit(cache=True)
def marker_axes(k, markers, bodies, data, q, v, axes, rates, quadratic, local):
    """Marker ``k``'s axes (columns of ``axes``, global), their rates and the
    velocity-quadratic parts of their second derivatives (columns), and the axes in
    the body frame (``local``)."""
    body = markers[k, 0]
    d = markers[k, 1]
    for i in range(3):
        for a in range(3):
            local[i, a] = data[d + 3 + 3 * i + a]
    if body < 0:
        axes[:, :] = local
        rates[:, :] = 0.0
        quadratic[:, :] = 0.0
        return
    po = bodies[body, 0]
    vo = bodies[body, 1]
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    w = v[vo + 3 : vo + 6]
    column = np.empty(3)
    wa = np.empty(3)
    wwa = np.empty(3)
    for a in range(3):
        for i in range(3):
            column[i] = local[i, a]
        cross(w, column, wa)
        cross(w, wa, wwa)
        for i in range(3):
            axes[i, a] = rot[i, 0] * column[0] + rot[i, 1] * column[1] + rot[i, 2] * column[2]
            rates[i, a] = rot[i, 0] * wa[0] + rot[i, 1] * wa[1] + rot[i, 2] * wa[2]
            quadratic[i, a] = rot[i, 0] * wwa[0] + rot[i, 1] * wwa[1] + rot[i, 2] * wwa[2]


@nb.njit(cache=True)
def add_turn_row(body, bodies, q, local, weight, target):
    """target[body's angular velocity coordinates] += local x (A^T weight): the part of
    weight^T d(A local)/dw for a vector ``local`` fixed in the body frame."""
    if body < 0:
        return
    po = bodies[body, 0]
    vo = bodies[body, 1]
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    bw = np.empty(3)
    for i in range(3):
        bw[i] = rot[0, i] * weight[0] + rot[1, i] * weight[1] + rot[2, i] * weight[2]
    arm = np.empty(3)
    cross(local, bw, arm)
    for i in range(3):
        target[vo + 3 + i] += arm[i]


@nb.njit(cache=True)
def add_vector_row(k, markers, bodies, q, local, weight, target):
    """target[velocity coordinates of marker k's body] += weight^T d(A local)/d(r', w):
    ``local`` is a point (3,) of the body (the translation part added by the caller)
    or an axis; the angular part is local x (A^T weight)."""
    add_turn_row(markers[k, 0], bodies, q, local, weight, target)


@nb.njit(cache=True)
def add_point_row(k, markers, bodies, data, q, point, weight, target):
    """target += weight^T dp/d(r', w, q') for marker k's point (``point``: where it is in
    the body frame, deformed; its mode shape from the marker's data)."""
    body = markers[k, 0]
    if body < 0:
        return
    vo = bodies[body, 1]
    r = bodies[body, 3]
    for i in range(3):
        target[vo + i] += weight[i]
    add_vector_row(k, markers, bodies, q, point, weight, target)
    if r:
        rot = np.empty((3, 3))
        rotation(q, bodies[body, 0] + 3, rot)
        d = markers[k, 1]
        # the modal part of the point's Jacobian: Psi - e (G q)^T on a stiffened body
        gq = np.empty(r)
        axis = np.empty(3)
        marker_foreshortening(k, markers, bodies, data, q, gq, axis)
        along = 0.0
        for i in range(3):
            local = rot[0, i] * weight[0] + rot[1, i] * weight[1] + rot[2, i] * weight[2]
            along += axis[i] * local
            for m in range(r):
                target[vo + 6 + m] += data[d + 12 + i * r + m] * local
        for m in range(r):
            target[vo + 6 + m] -= along * gq[m]


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

    A stiffened body (a beam along the unit axis e, foreshortened by -1/2 q^T G(x) q)
    has S(q) - 1/2 (q^T K_a q) e as its first moment, S_q = C_t - e (K_a q)^T in place
    of C_t, and J(q) - (q^T K_s q) (I - e e^T); its Lagrange equations add
    A e (q'^T K_a q') to the translation's forces, 2 (q^T K_s q') (I - e e^T) w to the
    rotation's and -(|w|^2 - (e . w)^2) K_s q to the modes' (the centrifugal stiffening;
    gravity and frame acceleration stiffen through S_q), as the planar engine's beams.
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
        # S_q (C_t, less e (K_a q)^T on a stiffened body) and the foreshortening's scalars
        shape = np.empty((3, r))
        kaq = np.zeros(r)
        ksq = np.zeros(r)
        axis = np.zeros(3)
        axial_form = 0.0  # q^T K_a q
        spin_along = 0.0  # q^T K_s q
        spin_rate = 0.0  # q^T K_s q'
        axial_curvature = 0.0  # q'^T K_a q'
        stiffened = bodies[b, 4] != 0
        if stiffened:
            o_ka = o_d + r
            o_ks = o_ka + r * r
            for i in range(3):
                axis[i] = data[o_ks + r * r + i]
            for x in range(r):
                kav = 0.0
                for y in range(r):
                    kaq[x] += data[o_ka + x * r + y] * modal[y]
                    ksq[x] += data[o_ks + x * r + y] * modal[y]
                    kav += data[o_ka + x * r + y] * modal_rate[y]
                axial_form += modal[x] * kaq[x]
                spin_along += modal[x] * ksq[x]
                spin_rate += modal_rate[x] * ksq[x]
                axial_curvature += modal_rate[x] * kav
        for i in range(3):
            for x in range(r):
                shape[i, x] = data[o_ct + i * r + x] - axis[i] * kaq[x]
        # S(q), S_q q', J(q)
        ct_rate = np.zeros(3)
        for i in range(3):
            first[i] = data[d + 1 + i] - 0.5 * axial_form * axis[i]
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
                if stiffened:
                    value -= spin_along * ((1.0 if i == j else 0.0) - axis[i] * axis[j])
                inertia[i, j] = value
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
                acc += rot[i, j] * (quadratic[j] - axis[j] * axial_curvature)
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
        if stiffened:  # - J' w of the foreshortening's inertia
            axial_spin = axis[0] * w[0] + axis[1] * w[1] + axis[2] * w[2]
            for j in range(3):
                forces[vo + 3 + j] += 2.0 * spin_rate * (w[j] - axis[j] * axial_spin)
        # modal forces: S_q^T A^T g - sum_ij w_i w_j (c_ij + C_ij q) - 2 sum_i w_i G_i q'
        #               - omega^2 q - 2 zeta omega q' (- (|w|^2 - (e . w)^2) K_s q)
        perpendicular_spin = 0.0
        if stiffened:
            axial_spin = axis[0] * w[0] + axis[1] * w[1] + axis[2] * w[2]
            perpendicular_spin = w[0] ** 2 + w[1] ** 2 + w[2] ** 2 - axial_spin**2
        for x in range(r):
            value = -data[o_k + x] * modal[x] - data[o_d + x] * modal_rate[x]
            value -= perpendicular_spin * ksq[x]
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
        kind = joints[jn, 0]
        ki = joints[jn, 1]
        kj = joints[jn, 2]
        row = joints[jn, 3]
        d = joints[jn, 4]
        drive = joints[jn, 5]
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
            d1, q1 = _dot1(
                ki, kj, 1, 0, q, markers, bodies, geo_i, geo_j, 0, jac_one.reshape((1, -1))
            )
            d2, q2 = _dot1(
                ki, kj, 0, 0, q, markers, bodies, geo_i, geo_j, 0, jac_two.reshape((1, -1))
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
def user_state(k, markers, bodies, data, q, v, state, out):
    """The numbers a user force function receives for marker ``k`` (:data:`USER_STATE_SIZE`);
    ``state`` is the marker's :func:`marker_state`."""
    axes = np.empty((3, 3))
    spare = np.empty((3, 3))
    marker_axes(k, markers, bodies, data, q, v, axes, spare, spare, spare)
    for i in range(3):
        out[i] = state[0, i]
        out[3 + i] = state[1, i]
        out[6 + i] = state[5, i]
        for a in range(3):
            out[9 + 3 * a + i] = axes[i, a]


@nb.njit(cache=True)
def contact_force(markers, bodies, data, d, kj, q, v, si, sj, force, point):
    """Penalty contact of marker i's point with marker j's surface: the force on marker i
    into ``force``, the contact point on the surface into ``point`` (global); returns
    the gap [m] (negative: penetration).

    The surface is the plane through marker j normal to its z axis (outward: +z), or,
    with a radius (``data[d + 4] > 0``), the sphere of that radius about marker j. Its
    points move with marker j's body frame. Normal force f_N = k max(0, -g) - c g' (never
    pulling), friction -mu f_N v_t / sqrt(|v_t|^2 + eps^2) (regularised Coulomb) against
    the slip v_t of the point over the surface, as in the plane.
    """
    radius = data[d + 4]
    normal = np.empty(3)
    if radius > 0.0:
        distance = 0.0
        for c in range(3):
            normal[c] = si[0, c] - sj[0, c]
            distance += normal[c] ** 2
        distance = math.sqrt(distance)
        for c in range(3):
            normal[c] /= distance
        gap = distance - radius
    else:
        axes = np.empty((3, 3))
        spare = np.empty((3, 3))
        marker_axes(kj, markers, bodies, data, q, v, axes, spare, spare, spare)
        gap = 0.0
        for c in range(3):
            normal[c] = axes[c, 2]
            gap += normal[c] * (si[0, c] - sj[0, c])
    for c in range(3):
        point[c] = si[0, c] - gap * normal[c]
        force[c] = 0.0
    if gap >= 0.0:
        return gap
    # the surface's material point at the contact point moves with marker j's frame
    slip = np.empty(3)
    for c in range(3):
        slip[c] = si[1, c]
    body = markers[kj, 0]
    if body >= 0:
        po = bodies[body, 0]
        vo = bodies[body, 1]
        arm = np.empty(3)
        for c in range(3):
            arm[c] = point[c] - q[po + c]
        turn = np.empty(3)
        cross(sj[5], arm, turn)
        for c in range(3):
            slip[c] -= v[vo + c] + turn[c]
    closing = normal[0] * slip[0] + normal[1] * slip[1] + normal[2] * slip[2]
    press = -data[d] * gap - data[d + 1] * closing
    if press <= 0.0:
        return gap
    eps = data[d + 3]
    sliding = 0.0
    for c in range(3):
        slip[c] -= closing * normal[c]
        sliding += slip[c] ** 2
    scale = data[d + 2] * press / math.sqrt(sliding + eps * eps)
    for c in range(3):
        force[c] = press * normal[c] - scale * slip[c]
    return gap


@nb.njit(cache=True)
def add_frame_point_row(body, bodies, q, point, weight, target):
    """target += weight^T dp/d(r', w) for the global ``point`` moving with ``body``'s
    frame (no modal part)."""
    if body < 0:
        return
    po = bodies[body, 0]
    vo = bodies[body, 1]
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    local = np.zeros(3)
    for i in range(3):
        for k in range(3):
            local[i] += rot[k, i] * (point[k] - q[po + k])
        target[vo + i] += weight[i]
    add_turn_row(body, bodies, q, local, weight, target)


@nb.njit(cache=True)
def bushing_offsets(markers, bodies, data, d, ki, kj, q, v, si, sj, offset, turn, axes_i, jac):
    """A bushing's deflection in marker i's axes: ``offset`` = marker j's offset less its
    start value, then its rate; ``turn`` = the rotation vector theta of marker j's turn
    since the start, then its rate; ``axes_i`` marker i's axes; ``jac`` J = d theta / d phi
    for a small turn phi of marker j (marker i's axes).

    With R = A_i^T A_j and D = R R0^T (R0 at the start), theta = 1/2 vee(D - D^T) and
    J = 1/2 (tr(D) I - D), from vee(a~ D + D^T a~) = (tr(D) I - D) a.
    """
    axes_j = np.empty((3, 3))
    spare = np.empty((3, 3))
    marker_axes(ki, markers, bodies, data, q, v, axes_i, spare, spare, spare)
    marker_axes(kj, markers, bodies, data, q, v, axes_j, spare, spare, spare)
    span = np.empty(3)
    drift = np.empty(3)
    for c in range(3):
        span[c] = sj[0, c] - si[0, c]
    cross(si[5], span, drift)  # d/dt (A_i^T d) = A_i^T (d' - w_i x d)
    relative = np.zeros((3, 3))  # R = A_i^T A_j
    for a in range(3):
        for b in range(3):
            for c in range(3):
                relative[a, b] += axes_i[c, a] * axes_j[c, b]
    turned = np.zeros((3, 3))  # D = R R0^T
    for a in range(3):
        for b in range(3):
            for c in range(3):
                turned[a, b] += relative[a, c] * data[d + 15 + 3 * b + c]
    trace = turned[0, 0] + turned[1, 1] + turned[2, 2]
    for a in range(3):
        for b in range(3):
            jac[a, b] = -0.5 * turned[a, b]
        jac[a, a] += 0.5 * trace
    spin = np.zeros(3)  # the relative angular velocity in marker i's axes
    for r in range(3):
        offset[r] = -data[d + 12 + r]
        offset[3 + r] = 0.0
        for c in range(3):
            offset[r] += axes_i[c, r] * span[c]
            offset[3 + r] += axes_i[c, r] * (sj[1, c] - si[1, c] - drift[c])
            spin[r] += axes_i[c, r] * (sj[5, c] - si[5, c])
    turn[0] = 0.5 * (turned[2, 1] - turned[1, 2])
    turn[1] = 0.5 * (turned[0, 2] - turned[2, 0])
    turn[2] = 0.5 * (turned[1, 0] - turned[0, 1])
    for r in range(3):
        turn[3 + r] = jac[r, 0] * spin[0] + jac[r, 1] * spin[1] + jac[r, 2] * spin[2]


@nb.njit(cache=True)
def bushing_load(markers, bodies, data, d, ki, kj, q, v, si, sj, load):
    """A bushing's load on marker i (force, torque; global): A_i (K d + C d'), and the
    angular springs' torque A_i J^T (K_angle theta + C_angle theta') plus the moment that
    keeps the pair's moment (:class:`fuzzymbs.mbs.spatial.forces.Bushing`)."""
    offset = np.empty(6)
    turn = np.empty(6)
    axes_i = np.empty((3, 3))
    jac = np.empty((3, 3))
    bushing_offsets(markers, bodies, data, d, ki, kj, q, v, si, sj, offset, turn, axes_i, jac)
    span = np.empty(3)
    force = np.zeros(3)
    torque = np.zeros(3)
    springs = np.empty(3)
    for r in range(3):
        springs[r] = data[d + 3 + r] * turn[r] + data[d + 9 + r] * turn[3 + r]
    for c in range(3):
        span[c] = sj[0, c] - si[0, c]
        for r in range(3):
            local_force = data[d + r] * offset[r] + data[d + 6 + r] * offset[3 + r]
            local_torque = jac[0, r] * springs[0] + jac[1, r] * springs[1] + jac[2, r] * springs[2]
            force[c] += axes_i[c, r] * local_force
            torque[c] += axes_i[c, r] * local_torque
    moment = np.empty(3)
    cross(span, force, moment)
    for c in range(3):
        load[c] = force[c]
        load[3 + c] = torque[c] + moment[c]


@nb.njit(cache=True)
def element_force(e, t, layout, data, q, v, user_force, si, sj, load, point):
    """Force element ``e``'s load on marker i into ``load`` (6): force [N] and torque
    [N m], global; ``si``, ``sj`` receive the markers' states. For a contact, ``point``
    receives the contact point, where marker j's frame takes the reaction."""
    bodies, markers, elements = layout[0], layout[1], layout[3]
    kind = elements[e, 0]
    ki = elements[e, 1]
    kj = elements[e, 2]
    d = elements[e, 3]
    code = elements[e, 4]
    marker_state(ki, markers, bodies, data, q, v, si)
    if kj >= 0:
        marker_state(kj, markers, bodies, data, q, v, sj)
    load[:] = 0.0
    if kind == SPRING_DAMPER:
        span = sj[0] - si[0]
        length = math.sqrt(span[0] ** 2 + span[1] ** 2 + span[2] ** 2)
        lengthening = 0.0
        for c in range(3):
            lengthening += span[c] / length * (sj[1, c] - si[1, c])
        tension = data[d] * (length - data[d + 2]) + data[d + 1] * lengthening
        for c in range(3):
            load[c] = tension * span[c] / length
    elif kind == MARKER_LOAD:
        scale = 1.0
        if code >= 0:
            scale, _, _ = profile(code, data, d + 6, t)
        for c in range(6):
            load[c] = data[d + c] * scale
    elif kind == CONTACT:
        force = np.empty(3)
        contact_force(markers, bodies, data, d, kj, q, v, si, sj, force, point)
        load[:3] = force
    elif kind == BUSHING:
        bushing_load(markers, bodies, data, d, ki, kj, q, v, si, sj, load)
    else:
        state_i = np.empty(USER_STATE_SIZE)
        state_j = np.zeros(USER_STATE_SIZE)
        user_state(ki, markers, bodies, data, q, v, si, state_i)
        if kj >= 0:
            user_state(kj, markers, bodies, data, q, v, sj, state_j)
        count = int(data[d])
        user_force(e, t, state_i, state_j, data[d + 1 : d + 1 + count].copy(), load)


@nb.njit(cache=True)
def force_terms(t, layout, data, q, v, user_force, forces):
    """Generalised forces (on r', w, q') of every force element."""
    bodies, markers, elements = layout[0], layout[1], layout[3]
    si = np.empty((6, 3))
    sj = np.empty((6, 3))
    load = np.empty(6)
    point = np.empty(3)
    for e in range(elements.shape[0]):
        kind = elements[e, 0]
        ki = elements[e, 1]
        kj = elements[e, 2]
        element_force(e, t, layout, data, q, v, user_force, si, sj, load, point)
        add_point_row(ki, markers, bodies, data, q, si[3].copy(), load[:3].copy(), forces)
        _add_torque(ki, markers, bodies, q, load[3:].copy(), forces)
        if kj < 0 or kind == MARKER_LOAD:
            continue
        if kind == CONTACT:  # the surface's point moves with marker j's frame
            add_frame_point_row(markers[kj, 0], bodies, q, point, -load[:3], forces)
        elif kind == BUSHING:  # marker j: the force and the angular spring's torque
            add_point_row(kj, markers, bodies, data, q, sj[3].copy(), -load[:3], forces)
            span = np.empty(3)
            moment = np.empty(3)
            for c in range(3):
                span[c] = sj[0, c] - si[0, c]
            cross(span, load[:3].copy(), moment)
            _add_torque(kj, markers, bodies, q, moment - load[3:], forces)
        else:
            add_point_row(kj, markers, bodies, data, q, sj[3].copy(), -load[:3], forces)
            _add_torque(kj, markers, bodies, q, -load[3:], forces)


@nb.njit(cache=True, nogil=True)
def element_forces_at(element, times, states, layout, data, user_force, out):
    """Force element ``element``'s load on its marker i at every stored state: out (B, T, 6)
    = force and torque, global, NaN after a failure."""
    nq = layout[4][0]
    si = np.empty((6, 3))
    sj = np.empty((6, 3))
    load = np.empty(6)
    point = np.empty(3)
    for s in range(states.shape[0]):
        for i in range(states.shape[1]):
            x = states[s, i]
            if not math.isfinite(x[0]):
                out[s, i, :] = np.nan
                continue
            element_force(
                element, times[i], layout, data[s], x[:nq], x[nq:], user_force, si, sj, load, point
            )
            out[s, i, :] = load


@nb.njit(cache=True, nogil=True)
def solve_range(start, stop, times, states, layout, data, user_force, out):
    """(r'', w', q'') and the multipliers at every stored state of rows ``start:stop`` into
    ``out`` (B, T, n + c); NaN after a failure."""
    nq = layout[4][0]
    n = layout[4][1]
    c = layout[4][2]
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)
    for s in range(start, stop):
        for i in range(states.shape[1]):
            x = states[s, i]
            if math.isfinite(x[0]) and accelerations(
                times[i], x[:nq], x[nq:], layout, data[s], user_force, system, solution
            ):
                out[s, i, :] = solution
            else:
                out[s, i, :] = np.nan


@nb.njit(cache=True)
def _add_torque(k, markers, bodies, q, torque, target):
    body = markers[k, 0]
    if body < 0:
        return
    po = bodies[body, 0]
    vo = bodies[body, 1]
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    for i in range(3):
        target[vo + 3 + i] += rot[0, i] * torque[0] + rot[1, i] * torque[1] + rot[2, i] * torque[2]


@nb.njit(cache=True)
def accelerations(t, q, v, layout, data, user_force, system, solution):
    """Solve the constrained equations at (t, q, v): solution = ((r'', w', q''), lambda)."""
    sizes = layout[4]
    n = sizes[1]
    c = sizes[2]
    system[:, :] = 0.0
    solution[:] = 0.0
    mass = np.zeros((n, n))
    body_terms(layout[0], data, q, v, mass, solution[:n])
    system[:n, :n] = mass
    force_terms(t, layout, data, q, v, user_force, solution[:n])
    if c:
        jac = np.zeros((c, n))
        residual = np.empty(c)
        quadratic = np.empty(c)
        rate = np.empty(c)
        acceleration = np.empty(c)
        joint_terms(t, layout, data, q, v, jac, residual, quadratic, rate, acceleration)
        for r in range(c):
            for x in range(n):
                system[n + r, x] = jac[r, x]
                system[x, n + r] = jac[r, x]
            solution[n + r] = -quadratic[r] + acceleration[r]
    if not solve_in_place(system, solution):
        return False
    for i in range(n + c):
        if not math.isfinite(solution[i]):
            return False
    return True


@nb.njit(cache=True)
def rotate(q, po, dx, dy, dz):
    """q[po:po + 4] <- q (1, d/2), normalised: a small rotation d in the body frame."""
    e0, e1, e2, e3 = q[po], q[po + 1], q[po + 2], q[po + 3]
    h0 = 1.0
    h1 = 0.5 * dx
    h2 = 0.5 * dy
    h3 = 0.5 * dz
    n0 = e0 * h0 - e1 * h1 - e2 * h2 - e3 * h3
    n1 = e0 * h1 + e1 * h0 + e2 * h3 - e3 * h2
    n2 = e0 * h2 - e1 * h3 + e2 * h0 + e3 * h1
    n3 = e0 * h3 + e1 * h2 - e2 * h1 + e3 * h0
    norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    q[po] = n0 / norm
    q[po + 1] = n1 / norm
    q[po + 2] = n2 / norm
    q[po + 3] = n3 / norm


@nb.njit(cache=True)
def displace(q, bodies, step):
    """Move the positions q by ``step``, given in velocity coordinates (r, a small rotation
    in each body frame, modal coordinates)."""
    for b in range(bodies.shape[0]):
        po = bodies[b, 0]
        vo = bodies[b, 1]
        for i in range(3):
            q[po + i] += step[vo + i]
        rotate(q, po + 3, step[vo + 3], step[vo + 4], step[vo + 5])
        for x in range(bodies[b, 3]):
            q[po + 7 + x] += step[vo + 6 + x]


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
    residual = np.empty(c)
    quadratic = np.empty(c)
    rate = np.empty(c)
    acceleration = np.empty(c)
    jac = np.zeros((c, n))
    step = np.zeros(n)
    worst = np.inf
    for _ in range(8):
        jac[:, :] = 0.0
        joint_terms(t, layout, data, q, v, jac, residual, quadratic, rate, acceleration)
        worst = 0.0
        for r in range(c):
            worst = max(worst, abs(residual[r]))
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
    if not remove_velocity_excess(jac, rate, v, residual):
        return np.inf
    return worst


@nb.njit(cache=True)
def _derivative(t, x, layout, data, user_force, system, solution, out):
    bodies = layout[0]
    sizes = layout[4]
    nq = sizes[0]
    n = sizes[1]
    q = x[:nq]
    v = x[nq:]
    ok = accelerations(t, q, v, layout, data, user_force, system, solution)
    for b in range(bodies.shape[0]):
        po = bodies[b, 0]
        vo = bodies[b, 1]
        for i in range(3):
            out[po + i] = v[vo + i]
        e0, e1, e2, e3 = q[po + 3], q[po + 4], q[po + 5], q[po + 6]
        wx, wy, wz = v[vo + 3], v[vo + 4], v[vo + 5]
        # p' = 1/2 p (0, w)
        out[po + 3] = 0.5 * (-e1 * wx - e2 * wy - e3 * wz)
        out[po + 4] = 0.5 * (e0 * wx + e2 * wz - e3 * wy)
        out[po + 5] = 0.5 * (e0 * wy - e1 * wz + e3 * wx)
        out[po + 6] = 0.5 * (e0 * wz + e1 * wy - e2 * wx)
        for x in range(bodies[b, 3]):
            out[po + 7 + x] = v[vo + 6 + x]
    for i in range(n):
        out[nq + i] = solution[i]
    return ok


@nb.njit(cache=True)
def integrate_sample(
    times, x0, layout, data, user_force, rtol, atol, first_step, max_steps, tolerance, states
):
    """Dormand-Prince 5(4) for one sample, as the planar engine's
    (:func:`fuzzymbs.mbs.planar.integrator.integrate_sample`), on (q, v) with the
    Euler parameters' kinematics; (status, accepted, rejected, largest residual)."""
    sizes = layout[4]
    nq = sizes[0]
    n = sizes[1]
    c = sizes[2]
    size = nq + n
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)
    x = x0.copy()
    k = np.empty((7, size))
    trial = np.empty(size)
    t = times[0]
    worst = project(t, x[:nq], x[nq:], layout, data, tolerance)
    if not worst <= tolerance:
        return PROJECTION_FAILED, 0, 0, worst
    states[0, :] = x
    if not _derivative(t, x, layout, data, user_force, system, solution, k[0]):
        return NOT_FINITE, 0, 0, worst
    h = first_step
    accepted = 0
    rejected = 0
    for out in range(1, times.size):
        target = times[out]
        while t < target:
            last = h >= target - t
            step = target - t if last else h
            for stage in range(1, 7):
                stage_state(x, k, stage, step, trial)
                if not _derivative(
                    stage_time(t, stage, step),
                    trial,
                    layout,
                    data,
                    user_force,
                    system,
                    solution,
                    k[stage],
                ):
                    return NOT_FINITE, accepted, rejected, worst
            err = error_norm(x, trial, k, step, rtol, atol)
            if not math.isfinite(err):
                return NOT_FINITE, accepted, rejected, worst
            factor = step_factor(err)
            if err <= 1.0:
                t = target if last else t + step
                x[:] = trial
                accepted += 1
                residual = project(t, x[:nq], x[nq:], layout, data, tolerance)
                if not residual <= tolerance:
                    return PROJECTION_FAILED, accepted, rejected, residual
                worst = max(worst, residual)
                if not _derivative(t, x, layout, data, user_force, system, solution, k[0]):
                    return NOT_FINITE, accepted, rejected, worst
                if not last or factor < 1.0:
                    h = step * factor
            else:
                rejected += 1
                h = step * min(1.0, factor)
            if h < 1e-14 * max(1.0, abs(t)):
                return STEP_TOO_SMALL, accepted, rejected, worst
            if accepted + rejected > max_steps:
                return TOO_MANY_STEPS, accepted, rejected, worst
        states[out, :] = x
    return FINISHED, accepted, rejected, worst


@nb.njit(cache=True, nogil=True)
def integrate_range(
    start,
    stop,
    times,
    initial,
    layout,
    data,
    user_force,
    rtol,
    atol,
    first_step,
    max_steps,
    tolerance,
    states,
    report,
):
    """:func:`integrate_sample` for sample rows ``start:stop`` (GIL released)."""
    for s in range(start, stop):
        status, accepted, rejected, worst = integrate_sample(
            times,
            initial[s],
            layout,
            data[s],
            user_force,
            rtol,
            atol,
            first_step,
            max_steps,
            tolerance,
            states[s],
        )
        report[s, 0] = status
        report[s, 1] = accepted
        report[s, 2] = rejected
        report[s, 3] = worst


@nb.njit(cache=True)
def markers_at(wanted, states, layout, data, out):
    """Position and velocity of the wanted markers at every stored state: out (B, T, K, 6)."""
    bodies, markers = layout[0], layout[1]
    nq = layout[4][0]
    state = np.empty((6, 3))
    for s in range(states.shape[0]):
        for i in range(states.shape[1]):
            x = states[s, i]
            if not math.isfinite(x[0]):
                out[s, i, :, :] = np.nan
                continue
            for w in range(wanted.size):
                marker_state(wanted[w], markers, bodies, data[s], x[:nq], x[nq:], state)
                out[s, i, w, :3] = state[0]
                out[s, i, w, 3:] = state[1]


@nb.njit(cache=True)
def energy_at(states, layout, data, out):
    """Kinetic, gravitational and elastic energy at every stored state: out (B, T, 3).

    Kinetic 1/2 v^T M v (M from :func:`body_terms`); gravitational -g . (m r + A S(q));
    elastic 1/2 omega^2 q^2 of the modes, 1/2 k (l - l0)^2 of the springs, 1/2 k g^2 of
    the closed contacts and the bushings' 1/2 d^T K d + 1/2 theta^T K_angle theta.
    """
    force = np.empty(3)
    point = np.empty(3)
    offset = np.empty(6)
    turn = np.empty(6)
    axes = np.empty((3, 3))
    jac = np.empty((3, 3))
    bodies, markers, elements = layout[0], layout[1], layout[3]
    nq = layout[4][0]
    n = layout[4][1]
    g = np.empty(3)
    si = np.empty((6, 3))
    sj = np.empty((6, 3))
    rot = np.empty((3, 3))
    for s in range(states.shape[0]):
        row = data[s]
        for i in range(3):
            g[i] = row[i]
        for t in range(states.shape[1]):
            x = states[s, t]
            if not math.isfinite(x[0]):
                out[s, t, :] = np.nan
                continue
            q = x[:nq]
            v = x[nq:]
            mass = np.zeros((n, n))
            forces = np.zeros(n)
            body_terms(bodies, row, q, v, mass, forces)
            kinetic = 0.0
            for i in range(n):
                for j in range(n):
                    kinetic += 0.5 * v[i] * mass[i, j] * v[j]
            potential = 0.0
            elastic = 0.0
            for b in range(bodies.shape[0]):
                po = bodies[b, 0]
                d = bodies[b, 2]
                r = bodies[b, 3]
                rotation(q, po + 3, rot)
                o_ct = d + 13
                o_k = o_ct + 6 * r + 3 * r * r + 9 * r * r + 9 * r + r
                # a stiffened body's foreshortening: S - 1/2 (q^T K_a q) e
                o_ka = o_k + 2 * r
                o_axis = o_ka + 2 * r * r
                axial_form = 0.0
                if bodies[b, 4] != 0:
                    for m in range(r):
                        for k in range(r):
                            axial_form += q[po + 7 + m] * row[o_ka + m * r + k] * q[po + 7 + k]
                for i in range(3):
                    first = row[d + 1 + i]
                    if bodies[b, 4] != 0:
                        first -= 0.5 * axial_form * row[o_axis + i]
                    for m in range(r):
                        first += row[o_ct + i * r + m] * q[po + 7 + m]
                    for k in range(3):
                        potential -= g[k] * rot[k, i] * first
                    potential -= g[i] * row[d] * q[po + i]
                for m in range(r):
                    elastic += 0.5 * row[o_k + m] * q[po + 7 + m] ** 2
            for e in range(elements.shape[0]):
                kind = elements[e, 0]
                if kind != SPRING_DAMPER and kind != CONTACT and kind != BUSHING:
                    continue
                d = elements[e, 3]
                marker_state(elements[e, 1], markers, bodies, row, q, v, si)
                marker_state(elements[e, 2], markers, bodies, row, q, v, sj)
                if kind == BUSHING:
                    bushing_offsets(
                        markers,
                        bodies,
                        row,
                        d,
                        elements[e, 1],
                        elements[e, 2],
                        q,
                        v,
                        si,
                        sj,
                        offset,
                        turn,
                        axes,
                        jac,
                    )
                    for r in range(3):
                        elastic += 0.5 * row[d + r] * offset[r] ** 2
                        elastic += 0.5 * row[d + 3 + r] * turn[r] ** 2
                    continue
                if kind == CONTACT:
                    gap = contact_force(
                        markers, bodies, row, d, elements[e, 2], q, v, si, sj, force, point
                    )
                    if gap < 0.0:
                        elastic += 0.5 * row[d] * gap * gap
                    continue
                length = 0.0
                for c in range(3):
                    length += (sj[0, c] - si[0, c]) ** 2
                elastic += 0.5 * row[d] * (math.sqrt(length) - row[d + 2]) ** 2
            out[s, t, 0] = kinetic
            out[s, t, 1] = potential
            out[s, t, 2] = elastic


@nb.njit(cache=True)
def marker_accelerations_at(marker, states, solved, layout, data, out):
    """Marker ``marker``'s acceleration and its body's angular acceleration (global) at every
    stored state: out (B, T, 6), from the solved (r'', w', q'') (``solved[..., :n]``): the
    point's Jacobian rows times them plus the velocity-quadratic part; A w'."""
    bodies, markers = layout[0], layout[1]
    nq = layout[4][0]
    n = layout[4][1]
    state = np.empty((6, 3))
    row = np.zeros(n)
    unit = np.eye(3)
    rot = np.empty((3, 3))
    body = markers[marker, 0]
    for s in range(states.shape[0]):
        for i in range(states.shape[1]):
            x = states[s, i]
            if not math.isfinite(x[0]) or not math.isfinite(solved[s, i, 0]):
                out[s, i, :] = np.nan
                continue
            q = x[:nq]
            marker_state(marker, markers, bodies, data[s], q, x[nq:], state)
            for c in range(3):
                row[:] = 0.0
                add_point_row(marker, markers, bodies, data[s], q, state[3].copy(), unit[c], row)
                acc = state[2, c]
                for k in range(n):
                    acc += row[k] * solved[s, i, k]
                out[s, i, c] = acc
                out[s, i, 3 + c] = 0.0
            if body >= 0:
                rotation(q, bodies[body, 0] + 3, rot)
                vo = bodies[body, 1]
                for c in range(3):
                    for k in range(3):
                        out[s, i, 3 + c] += rot[c, k] * solved[s, i, vo + 3 + k]
