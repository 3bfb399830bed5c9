"""Kinematics of spatial bodies and markers: rotations, a marker's motion, and the rows
that map a force, a torque or a joint equation onto a body's velocity coordinates
(r', w, q'); the foreshortening of a stiffened beam's nodes. See
:mod:`fuzzymbs.mbs.spatial.kernels` for the coordinates and the layout arrays.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.spatial.bodies import FORESHORTENED_NODES


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
    """Where a stiffened body's beam axis e (3) sits in its data (after K_i and K_ij)."""
    r = bodies[body, 3]
    return bodies[body, 2] + 13 + 6 * r + 12 * r * r + 9 * r + 3 * r + 12 * r * r


@nb.njit(cache=True)
def marker_foreshortening(k, markers, bodies, data, q, gq, axis):
    """A marker on a stiffened beam: G q into ``gq`` and the axis into ``axis``; False (and
    zeros) for any other marker."""
    body = markers[k, 0]
    gq[:] = 0.0
    axis[:] = 0.0
    if body < 0 or bodies[body, 4] != FORESHORTENED_NODES:
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
    # on a stiffened beam the point moves back along the axis by 1/2 q^T G q: its rate
    # is q'^T G q, the velocity-quadratic part of its acceleration q'^T G q'
    shorten = np.zeros(3)  # the foreshortening's acceleration, q'^T G q' along the axis
    if bodies[body, 4] == FORESHORTENED_NODES:
        gq = np.empty(r)
        axis = np.empty(3)
        marker_foreshortening(k, markers, bodies, data, q, gq, axis)
        curvature = 0.0
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
            shorten[i] = curvature * axis[i]
    w = v[vo + 3 : vo + 6]
    ws = np.empty(3)
    quadratic = np.empty(3)
    spin_terms(w, s, sd, ws, quadratic)
    for i in range(3):
        quadratic[i] -= shorten[i]
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
def to_body_frame(q, po, vector, out):
    """out = A^T vector: a global vector in the frame of the body whose position starts
    at q[po] (its Euler parameters at q[po + 3:po + 7])."""
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    for i in range(3):
        out[i] = rot[0, i] * vector[0] + rot[1, i] * vector[1] + rot[2, i] * vector[2]


@nb.njit(cache=True)
def add_turn_row(body, bodies, q, local, weight, target):
    """target[body's angular velocity coordinates] += local x (A^T weight): the part of
    weight^T d(A local)/dw for a vector ``local`` fixed in the body frame."""
    if body < 0:
        return
    vo = bodies[body, 1]
    bw = np.empty(3)
    to_body_frame(q, bodies[body, 0], weight, bw)
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
        d = markers[k, 1]
        local = np.empty(3)
        to_body_frame(q, bodies[body, 0], weight, local)
        for i in range(3):
            for m in range(r):
                target[vo + 6 + m] += data[d + 12 + i * r + m] * local[i]
        if bodies[body, 4] == FORESHORTENED_NODES:  # a stiffened beam: Psi - e (G q)^T
            gq = np.empty(r)
            axis = np.empty(3)
            marker_foreshortening(k, markers, bodies, data, q, gq, axis)
            along = axis[0] * local[0] + axis[1] * local[1] + axis[2] * local[2]
            for m in range(r):
                target[vo + 6 + m] -= along * gq[m]


@nb.njit(cache=True)
def add_torque_row(k, markers, bodies, q, torque, target):
    """target[marker k's body angular velocity coordinates] += A^T torque."""
    body = markers[k, 0]
    if body < 0:
        return
    vo = bodies[body, 1]
    local = np.empty(3)
    to_body_frame(q, bodies[body, 0], torque, local)
    for i in range(3):
        target[vo + 3 + i] += local[i]


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
