"""Compiled physics of planar mechanisms: one sample per call, a batch per kernel.

State of a mechanism: the absolute coordinates z of every body (frame
position x, y, frame angle theta, modal coordinates q) and their rates v.
The constrained equations of motion (index-1 form, Lagrange multipliers
lambda; Haug, Computer Aided Kinematics and Dynamics of Mechanical Systems,
ch. 11; Shabana, Dynamics of Multibody Systems, ch. 5 for the floating-frame
terms) are solved for the accelerations at every evaluation::

    [ M(z)  G(z)^T ] [ z'' ]   [ Q(t, z, v)                 ]
    [ G(z)  0      ] [ lam ] = [ -zeta(z, v) + f''(t)       ]

with g(z, t) = 0 the joint equations, G = dg/dz and zeta the part of g''
quadratic in the velocities. Drift is removed by projecting the positions
onto g = 0 and the velocities onto G v = f'(t) after every accepted step, so
the stored trajectory satisfies the joints to the projection tolerance.

The layout arrays (int64) say which numbers of a sample's ``data`` row
belong to which body, marker, joint and force
(:meth:`fuzzymbs.mbs.planar.system.Mechanism.pack` writes them):

- bodies  (nb, 4): coordinate offset, mode count, data offset, stiffening flag
- markers (nk, 3): body (-1 ground), data offset, mode count
- joints  (nj, 6): kind, marker i, marker j, first equation row, data offset,
  drive profile (-1 none)
- forces  (nf, 5): kind, marker i, marker j (-1 none), data offset, profile (-1 none)
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba import types
from numba.extending import overload

from fuzzymbs.mbs.assembly import USER_FORCE_SIGNATURE
from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.planar.elimination import (
    finish_projection,
    joint_buffers,
    largest_magnitude,
    project_rows,
    solve_constrained,
)
from fuzzymbs.mbs.planar.lanewise import LANES, add, add2, at, cos, put, rows, sin, zero

# joint kinds
REVOLUTE = 0
PRISMATIC = 1
FIXED = 2
# force kinds
SPRING_DAMPER = 0
ROTATIONAL_SPRING_DAMPER = 1
MARKER_LOAD = 2
USER_FORCE = 3
CONTACT = 4
BUSHING = 5
# run status
RUNNING = 0
#: Length of a marker's state (:func:`marker_state`).
MARKER_STATE_SIZE = 12

FINISHED = 1
NOT_FINITE = 2
STEP_TOO_SMALL = 3
TOO_MANY_STEPS = 4
PROJECTION_FAILED = 5
#: a replayed step sequence ended, or passed an output time, before the run's end
REPLAY_ENDED = 6


@nb.cfunc(USER_FORCE_SIGNATURE, cache=True)
def no_user_force(element, t, marker_i, marker_j, parameters, out):  # pragma: no cover - compiled
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0


@nb.njit(cache=True)
def failed_before(states, s, i, out):
    """True, with ``out[s, i]`` set to NaN, if sample ``s`` had failed by stored time ``i``
    (a failed run's states are NaN from the failure on)."""
    if math.isfinite(states[s, i, 0]):
        return False
    out[s, i] = np.nan
    return True


@nb.njit(cache=True)
def live_states(states, out):
    """The (sample, stored time) pairs (K, 2) where ``states`` (B, T, m) holds numbers, in
    order, with ``out[s, i]`` set to NaN at the others (:func:`failed_before`): the states a
    run reached, or quantities solved from them (NaN where those are)."""
    live = np.empty((states.shape[0] * states.shape[1], 2), dtype=np.int64)
    count = 0
    for s in range(states.shape[0]):
        for i in range(states.shape[1]):
            if not failed_before(states, s, i, out):
                live[count, 0] = s
                live[count, 1] = i
                count += 1
    return live[:count]


@nb.njit(cache=True)
def plus_dot(start, row, values):
    """start + sum_k row[k] values[k] over ``row`` (in order): a Jacobian row times the
    solved accelerations."""
    total = start
    for k in range(row.size):
        total += row[k] * values[k]
    return total


@nb.njit(cache=True)
def joint_row(joints, jn):
    """Joint ``jn``'s row of the layout: (kind, marker i, marker j, first equation row, data
    offset, drive profile)."""
    return joints[jn, 0], joints[jn, 1], joints[jn, 2], joints[jn, 3], joints[jn, 4], joints[jn, 5]


@nb.njit(cache=True)
def element_row(elements, e):
    """Force element ``e``'s row of the layout: (kind, marker i, marker j, data offset,
    profile)."""
    return elements[e, 0], elements[e, 1], elements[e, 2], elements[e, 3], elements[e, 4]


@nb.njit(cache=True)
def marker_row(k, markers, bodies):
    """Marker ``k``'s (body, data offset, mode count, the body's coordinate offset); body
    -1 and offset -1 on the ground."""
    body = markers[k, 0]
    return body, markers[k, 1], markers[k, 2], bodies[body, 0] if body >= 0 else -1


@nb.njit(cache=True)
def modal_products(data, start, z, v, o, m):
    """(K_i q, K_i q'): the row of m numbers at ``data[start:]`` times the modal coordinates
    and rates of the body at coordinate offset ``o`` (a geometric matrix's row)."""
    kq = zero(data)
    kv = zero(data)
    for j in range(m):
        kq += at(data, start + j) * at(z, o + 3 + j)
        kv += at(data, start + j) * at(v, o + 3 + j)
    return kq, kv


@nb.njit(cache=True)
def profile(code, p, off, t):
    """(f, f', f'') of the profile ``code`` with parameters ``p[off:off + 4]`` at ``t``."""
    start = p[off]
    if code == 0:  # constant rate
        return start + p[off + 1] * t, p[off + 1], 0.0
    if code == 1:  # spin-up (Kane, Ryan & Banerjee 1987)
        speed = p[off + 1]
        duration = p[off + 2]
        if t < duration:
            w = 2.0 * math.pi / duration
            f = speed / duration * (0.5 * t * t + (math.cos(w * t) - 1.0) / (w * w))
            fd = speed / duration * (t - math.sin(w * t) / w)
            fdd = speed / duration * (1.0 - math.cos(w * t))
            return start + f, fd, fdd
        return start + speed * (t - 0.5 * duration), speed, 0.0
    # harmonic
    amplitude = p[off + 1]
    frequency = p[off + 2]
    arg = frequency * t + p[off + 3]
    return (
        start + amplitude * math.sin(arg),
        amplitude * frequency * math.cos(arg),
        -amplitude * frequency * frequency * math.sin(arg),
    )


@nb.njit(cache=True)
def _foreshortening(k, markers, bodies, data, z, v):
    """(-1/2 q^T K_n q, (K_n q) . q', q'^T K_n q') of marker ``k``'s node, or zeros.

    K_n is the node's geometric matrix (integral of Phi'^T Phi' from the root to
    the node): the node moves along the beam by u_f = -1/2 q^T K_n q as the beam
    bends (it foreshortens), which is where geometric stiffening comes from.
    """
    body = markers[k, 0]
    m = markers[k, 2]
    shift = zero(data)
    rate = zero(data)
    curvature = zero(data)
    if body < 0 or m == 0 or bodies[body, 3] == 0:
        return shift, rate, curvature
    d = markers[k, 1] + 3 + 3 * m
    o = bodies[body, 0]
    for i in range(m):
        kq, kv = modal_products(data, d + m * i, z, v, o, m)
        shift -= 0.5 * at(z, o + 3 + i) * kq
        rate += kq * at(v, o + 3 + i)
        curvature += at(v, o + 3 + i) * kv
    return shift, rate, curvature


@nb.njit(cache=True)
def marker_state(k, markers, bodies, data, z, v, out):
    """Kinematics of marker ``k`` into ``out`` (:data:`MARKER_STATE_SIZE`,).

    out = x, y, angle, vx, vy, angular velocity, the velocity-quadratic part of
    the acceleration (2), A R u (2): the point's position relative to its
    frame origin turned by +90 degrees (its derivative by the frame angle), and
    the cosine and sine of the frame angle (for :func:`add_point_load`, which
    would otherwise evaluate them again for every row it adds).
    On a stiffened flexible body the node's foreshortening is part of u.
    """
    body = markers[k, 0]
    d = markers[k, 1]
    m = markers[k, 2]
    ux = at(data, d)
    uy = at(data, d + 1)
    if body < 0:
        put(out, 0, ux)
        put(out, 1, uy)
        put(out, 2, at(data, d + 2))
        for i in range(3, MARKER_STATE_SIZE):
            put(out, i, 0.0)
        put(out, 10, 1.0)
        return
    o = bodies[body, 0]
    angle = at(data, d + 2)
    rate = zero(data)
    dux = zero(data)
    duy = zero(data)
    for j in range(m):
        qj = at(z, o + 3 + j)
        vj = at(v, o + 3 + j)
        px = at(data, d + 3 + j)
        py = at(data, d + 3 + m + j)
        ps = at(data, d + 3 + 2 * m + j)
        ux += px * qj
        uy += py * qj
        dux += px * vj
        duy += py * vj
        angle += ps * qj
        rate += ps * vj
    shift, shift_rate, curvature = _foreshortening(k, markers, bodies, data, z, v)
    ux += shift
    dux -= shift_rate
    th = at(z, o + 2)
    w = at(v, o + 2)
    c = cos(th)
    s = sin(th)
    aux = c * ux - s * uy  # A u
    auy = s * ux + c * uy
    adx = c * dux - s * duy  # A u'
    ady = s * dux + c * duy
    put(out, 0, at(z, o) + aux)
    put(out, 1, at(z, o + 1) + auy)
    put(out, 2, th + angle)
    put(out, 3, at(v, o) - w * auy + adx)
    put(out, 4, at(v, o + 1) + w * aux + ady)
    put(out, 5, w + rate)
    # -w^2 A u + 2 w A R u' + A (-q'^T K_n q', 0)
    put(out, 6, -w * w * aux - 2.0 * w * ady - c * curvature)
    put(out, 7, -w * w * auy + 2.0 * w * adx - s * curvature)
    put(out, 8, -auy)
    put(out, 9, aux)
    put(out, 10, c)
    put(out, 11, s)


@nb.njit(cache=True)
def add_point_load(k, markers, bodies, data, z, state, fx, fy, target):
    """target[body coordinates] += (dp/dz)^T (fx, fy) for marker ``k``.

    The same product gives a force's generalised force and a position
    equation's Jacobian row. ``state`` is the marker's :func:`marker_state`.
    On a stiffened flexible body dp/dq holds the foreshortening -(K_n q) along
    the beam, so that an axial force at the node stiffens (tension) or
    softens (compression) the modes.
    """
    body, d, m, o = marker_row(k, markers, bodies)
    if body < 0:
        return
    add(target, o, fx)
    add(target, o + 1, fy)
    add(target, o + 2, at(state, 8) * fx + at(state, 9) * fy)
    c = at(state, 10)  # the frame angle's cosine and sine (marker_state)
    s = at(state, 11)
    axial = c * fx + s * fy  # the force along the body's x axis
    stiffened = bodies[body, 3] != 0
    dk = d + 3 + 3 * m
    for j in range(m):
        px = at(data, d + 3 + j)
        py = at(data, d + 3 + m + j)
        value = (c * px - s * py) * fx + (s * px + c * py) * fy
        if stiffened:
            kq = zero(data)
            for i in range(m):
                kq += at(data, dk + m * j + i) * at(z, o + 3 + i)
            value -= axial * kq
        add(target, o + 3 + j, value)


@nb.njit(cache=True)
def add_frame_point_load(body, bodies, z, px, py, fx, fy, target):
    """target[body coordinates] += the generalised force of (fx, fy) at the global point
    (px, py) moving with ``body``'s frame (no modal part)."""
    if body < 0:
        return
    o = bodies[body, 0]
    target[o] += fx
    target[o + 1] += fy
    target[o + 2] += -(py - z[o + 1]) * fx + (px - z[o]) * fy


@nb.njit(cache=True)
def contact_force(markers, bodies, data, d, kj, z, v, si, sj, out):
    """Penalty contact of marker i's point with marker j's surface; returns the contact
    point (x, y) on the surface and writes the force on marker i into ``out``.

    The surface is marker j's x axis (outward normal: its y axis) or, with a radius
    (``data[d + 4] > 0``), the circle of that radius about marker j (outward normal
    radial). Normal force f_N = k max(0, -g) - c g' (never pulling), friction
    -mu f_N v_t / sqrt(v_t^2 + eps^2) (regularised Coulomb) against the slip of
    the point over the surface, whose points move with marker j's frame.
    """
    radius = data[d + 4]
    dx = si[0] - sj[0]
    dy = si[1] - sj[1]
    if radius > 0.0:
        distance = math.sqrt(dx * dx + dy * dy)
        nx = dx / distance
        ny = dy / distance
        gap = distance - radius
    else:
        nx = -math.sin(sj[2])
        ny = math.cos(sj[2])
        gap = nx * dx + ny * dy
    cx = si[0] - gap * nx
    cy = si[1] - gap * ny
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    if gap >= 0.0:
        return cx, cy
    # velocity of the surface's material point at (cx, cy): the frame of marker j's body
    vcx = 0.0
    vcy = 0.0
    body = markers[kj, 0] if kj >= 0 else -1
    if body >= 0:
        o = bodies[body, 0]
        w = v[o + 2]
        vcx = v[o] - w * (cy - z[o + 1])
        vcy = v[o + 1] + w * (cx - z[o])
    slip_x = si[3] - vcx
    slip_y = si[4] - vcy
    closing = nx * slip_x + ny * slip_y
    tangential = -ny * slip_x + nx * slip_y
    normal = -data[d] * gap - data[d + 1] * closing
    if normal <= 0.0:
        return cx, cy
    eps = data[d + 3]
    friction = -data[d + 2] * normal * tangential / math.sqrt(tangential * tangential + eps * eps)
    out[0] = normal * nx - friction * ny
    out[1] = normal * ny + friction * nx
    return cx, cy


@nb.njit(cache=True)
def add_angle_load(k, markers, bodies, data, torque, target):
    """target[body coordinates] += (d angle/dz)^T torque for marker ``k``."""
    body, d, m, o = marker_row(k, markers, bodies)
    if body < 0:
        return
    add(target, o + 2, torque)
    for j in range(m):
        add(target, o + 3 + j, at(data, d + 3 + 2 * m + j) * torque)


@nb.njit(cache=True)
def slide_row(ex, ey, ki, kj, markers, bodies, data, z, si, sj, row):
    """A prismatic joint's equation on the offset d = p_j - p_i along the direction
    e = (ex, ey) that turns with marker i: returns (e . d, its velocity-quadratic part
    zeta) and adds dg/dz into ``row``. With e' = w e_perp, e_perp = (-ey, ex):
    g'' = e . (a_j - a_i) + 2 w e_perp . d' - w^2 e . d + (w' e_perp . d)."""
    px = -ey
    py = ex
    dx = at(sj, 0) - at(si, 0)
    dy = at(sj, 1) - at(si, 1)
    dvx = at(sj, 3) - at(si, 3)
    dvy = at(sj, 4) - at(si, 4)
    w = at(si, 5)
    value = ex * dx + ey * dy
    relative = ex * (at(sj, 6) - at(si, 6)) + ey * (at(sj, 7) - at(si, 7))
    quadratic = relative + 2.0 * w * (px * dvx + py * dvy) - w * w * value
    add_point_load(kj, markers, bodies, data, z, sj, ex, ey, row)
    add_point_load(ki, markers, bodies, data, z, si, -ex, -ey, row)
    add_angle_load(ki, markers, bodies, data, px * dx + py * dy, row)
    return value, quadratic


@nb.njit(cache=True)
def joint_rows(kind, drive):
    """Number of equations of a joint."""
    return (3 if kind == FIXED else 2) + (1 if drive >= 0 else 0)


@nb.njit(cache=True)
def body_terms(bodies, data, z, v, mass_matrix, forces):
    """Every body's mass-matrix block and its generalised forces (quadratic
    velocity terms, gravity, elastic and damping forces).

    A stiffened flexible body carries the foreshortening of its points,
    u_f = -1/2 q^T G(x) q along the beam: its first moment is
    S(q) = s0 + C1 q - 1/2 (q^T K_a q) e_x and its inertia about the frame
    origin J(q) = J0 + 2 a q + q^T (M_qq - K_s) q, with K_a and K_s the geometric
    matrices of the axial and centrifugal unit loads. Lagrange's equations of
    that kinetic and potential energy give the geometric stiffening by gravity,
    frame acceleration and spin, each with its reciprocal term, so the energy
    is conserved (module docstring of :mod:`fuzzymbs.fe.beam` for K_a, K_s).
    """
    gx = at(data, 0)
    gy = at(data, 1)
    for b in range(bodies.shape[0]):
        o = bodies[b, 0]
        m = bodies[b, 1]
        d = bodies[b, 2]
        stiffened = bodies[b, 3] != 0
        mass = at(data, d)
        ia = d + 4
        ib = ia + m
        icx = ib + m
        icy = icx + m
        imq = icy + m
        igy = imq + m * m
        ik = igy + m * m
        idp = ik + m * m
        ikgs = idp + m * m
        ikga = ikgs + m * m
        th = at(z, o + 2)
        w = at(v, o + 2)
        c = cos(th)
        s = sin(th)
        # S = s0 + C1 q (- 1/2 q^T K_a q e_x), and S_q q'
        sx = at(data, d + 1)
        sy = at(data, d + 2)
        cvx = zero(data)
        cvy = zero(data)
        axial_curvature = zero(data)  # q'^T K_a q'
        for i in range(m):
            sx += at(data, icx + i) * at(z, o + 3 + i)
            sy += at(data, icy + i) * at(z, o + 3 + i)
            cvx += at(data, icx + i) * at(v, o + 3 + i)
            cvy += at(data, icy + i) * at(v, o + 3 + i)
            if stiffened:
                kaq, kav = modal_products(data, ikga + m * i, z, v, o, m)
                sx -= 0.5 * at(z, o + 3 + i) * kaq
                cvx -= kaq * at(v, o + 3 + i)
                axial_curvature += at(v, o + 3 + i) * kav
        arsx = -(s * sx + c * sy)  # A R S
        arsy = c * sx - s * sy
        add2(mass_matrix, o, o, mass)
        add2(mass_matrix, o + 1, o + 1, mass)
        add2(mass_matrix, o, o + 2, arsx)
        add2(mass_matrix, o + 2, o, arsx)
        add2(mass_matrix, o + 1, o + 2, arsy)
        add2(mass_matrix, o + 2, o + 1, arsy)
        inertia = at(data, d + 3)
        spin = zero(data)
        for i in range(m):
            qi = at(z, o + 3 + i)
            # a + (M_qq - K_s) q, G q, G q', the elastic and damping forces, K_a q
            aq = at(data, ia + i)
            gq = zero(data)
            gv = zero(data)
            kq = zero(data)
            kaq = zero(data)
            for j in range(m):
                qj = at(z, o + 3 + j)
                shape = at(data, imq + m * i + j)
                if stiffened:
                    shape -= at(data, ikgs + m * i + j)
                    kaq += at(data, ikga + m * i + j) * qj
                aq += shape * qj
                gq += at(data, igy + m * i + j) * qj
                gv += at(data, igy + m * i + j) * at(v, o + 3 + j)
                add2(mass_matrix, o + 3 + i, o + 3 + j, at(data, imq + m * i + j))
                kq += at(data, ik + m * i + j) * qj + at(data, idp + m * i + j) * at(v, o + 3 + j)
            inertia += at(data, ia + i) * qi + aq * qi
            # A S_q[:, i], S_q = C1 - e_x (K_a q)^T
            sqx = at(data, icx + i) - kaq
            sqy = at(data, icy + i)
            acx = c * sqx - s * sqy
            acy = s * sqx + c * sqy
            add2(mass_matrix, o, o + 3 + i, acx)
            add2(mass_matrix, o + 3 + i, o, acx)
            add2(mass_matrix, o + 1, o + 3 + i, acy)
            add2(mass_matrix, o + 3 + i, o + 1, acy)
            coupling = at(data, ib + i) + gq
            add2(mass_matrix, o + 2, o + 3 + i, coupling)
            add2(mass_matrix, o + 3 + i, o + 2, coupling)
            spin += aq * at(v, o + 3 + i)
            add(forces, o + 3 + i, w * w * aq - 2.0 * w * gv + acx * gx + acy * gy - kq)
        add2(mass_matrix, o + 2, o + 2, inertia)
        # w^2 A S - 2 w A R S_q q' + A e_x q'^T K_a q'
        add(
            forces,
            o,
            w * w * (c * sx - s * sy)
            + 2.0 * w * (s * cvx + c * cvy)
            + c * axial_curvature
            + mass * gx,
        )
        add(
            forces,
            o + 1,
            w * w * (s * sx + c * sy)
            - 2.0 * w * (c * cvx - s * cvy)
            + s * axial_curvature
            + mass * gy,
        )
        add(forces, o + 2, -2.0 * w * spin + arsx * gx + arsy * gy)


@nb.njit(cache=True)
def joint_terms(t, layout, data, z, v, jac, residual, quadratic, rate, acceleration):
    """Rows of every joint: residual g, Jacobian G, quadratic part zeta, and the
    drive's f'(t) (``rate``) and f''(t) (``acceleration``)."""
    bodies, markers, joints = layout[0], layout[1], layout[2]
    si = rows(data, MARKER_STATE_SIZE)
    sj = rows(data, MARKER_STATE_SIZE)
    for jn in range(joints.shape[0]):
        kind, ki, kj, row, d, drive = joint_row(joints, jn)
        marker_state(ki, markers, bodies, data, z, v, si)
        marker_state(kj, markers, bodies, data, z, v, sj)
        dx = at(sj, 0) - at(si, 0)
        dy = at(sj, 1) - at(si, 1)
        if kind == REVOLUTE or kind == FIXED:
            for r in range(2):
                put(residual, row + r, -dx if r == 0 else -dy)
                put(quadratic, row + r, at(si, 6 + r) - at(sj, 6 + r))
                put(rate, row + r, 0.0)
                put(acceleration, row + r, 0.0)
            add_point_load(ki, markers, bodies, data, z, si, 1.0, 0.0, jac[row])
            add_point_load(kj, markers, bodies, data, z, sj, -1.0, 0.0, jac[row])
            add_point_load(ki, markers, bodies, data, z, si, 0.0, 1.0, jac[row + 1])
            add_point_load(kj, markers, bodies, data, z, sj, 0.0, -1.0, jac[row + 1])
            r = row + 2
        else:  # prismatic: marker j slides along marker i's x axis, not across it
            ex = -sin(at(si, 2))
            ey = cos(at(si, 2))
            value, zeta = slide_row(ex, ey, ki, kj, markers, bodies, data, z, si, sj, jac[row])
            put(residual, row, value)
            put(quadratic, row, zeta)
            put(rate, row, 0.0)
            put(acceleration, row, 0.0)
            r = row + 1
        if kind != REVOLUTE:  # the relative angle held at its initial value
            put(residual, r, at(sj, 2) - at(si, 2) - at(data, d))
            put(quadratic, r, 0.0)
            put(rate, r, 0.0)
            put(acceleration, r, 0.0)
            add_angle_load(kj, markers, bodies, data, 1.0, jac[r])
            add_angle_load(ki, markers, bodies, data, -1.0, jac[r])
            r += 1
        if drive >= 0:
            f, fd, fdd = drive_profile(drive, data, d + 1, t)
            put(rate, r, fd)
            put(acceleration, r, fdd)
            if kind == PRISMATIC:  # the slide along the axis
                ex = cos(at(si, 2))
                ey = sin(at(si, 2))
                along, zeta = slide_row(ex, ey, ki, kj, markers, bodies, data, z, si, sj, jac[r])
                put(quadratic, r, zeta)
                put(residual, r, along - f)
            else:  # the relative angle
                put(residual, r, at(sj, 2) - at(si, 2) - f)
                put(quadratic, r, 0.0)
                add_angle_load(kj, markers, bodies, data, 1.0, jac[r])
                add_angle_load(ki, markers, bodies, data, -1.0, jac[r])


def drive_profile(code, data, off, t):
    """:func:`profile` of a sample at time t, or of the lanes (``data`` (D, LANES), ``t``
    (LANES,)) one lane at a time: (f, f', f'') as floats or vectors."""
    raise NotImplementedError("compiled only")


@overload(drive_profile)
def _drive_profile(code, data, off, t):
    if isinstance(t, types.Array):

        def lanes(code, data, off, t):
            f = np.empty(LANES)
            fd = np.empty(LANES)
            fdd = np.empty(LANES)
            for lane in range(LANES):
                f[lane], fd[lane], fdd[lane] = profile(code, data[:, lane], off, t[lane])
            return V.load(f, 0), V.load(fd, 0), V.load(fdd, 0)

        return lanes
    return lambda code, data, off, t: profile(code, data, off, t)


@nb.njit(cache=True)
def element_force(e, t, layout, data, z, v, user_force, si, sj, out):
    """Force element ``e``'s load on marker i into ``out``: (fx, fy) [N], global, and the
    torque [N m]; ``si``, ``sj`` receive the markers' states (sj zero without marker j).
    Returns the point (x, y) where marker j's body takes the reaction: marker j's point,
    or the contact point on the surface for a contact."""
    bodies, markers, elements = layout[0], layout[1], layout[3]
    kind, ki, kj, d, code = element_row(elements, e)
    marker_state(ki, markers, bodies, data, z, v, si)
    if kj >= 0:
        marker_state(kj, markers, bodies, data, z, v, sj)
    else:
        sj[:] = 0.0
    if kind == SPRING_DAMPER:
        dx = sj[0] - si[0]
        dy = sj[1] - si[1]
        length = math.sqrt(dx * dx + dy * dy)
        ex = dx / length
        ey = dy / length
        lengthening = ex * (sj[3] - si[3]) + ey * (sj[4] - si[4])
        tension = data[d] * (length - data[d + 2]) + data[d + 1] * lengthening
        out[0] = tension * ex
        out[1] = tension * ey
        out[2] = 0.0
    elif kind == ROTATIONAL_SPRING_DAMPER:
        out[0] = 0.0
        out[1] = 0.0
        out[2] = data[d] * (sj[2] - si[2] - data[d + 2]) + data[d + 1] * (sj[5] - si[5])
    elif kind == MARKER_LOAD:
        scale = 1.0
        if code >= 0:
            scale, _, _ = profile(code, data, d + 4, t)
        fx = data[d] * scale
        fy = data[d + 1] * scale
        if data[d + 3] != 0.0:  # given in the marker's frame
            ca = math.cos(si[2])
            sa = math.sin(si[2])
            fx, fy = ca * fx - sa * fy, sa * fx + ca * fy
        out[0] = fx
        out[1] = fy
        out[2] = data[d + 2] * scale
    elif kind == CONTACT:
        return contact_force(markers, bodies, data, d, kj, z, v, si, sj, out)
    elif kind == BUSHING:
        # marker j's offset and its rate in marker i's frame (d/dt A^T d = A^T d' - w x ...)
        ca = math.cos(si[2])
        sa = math.sin(si[2])
        dx = sj[0] - si[0]
        dy = sj[1] - si[1]
        lx = ca * dx + sa * dy
        ly = -sa * dx + ca * dy
        rx = ca * (sj[3] - si[3]) + sa * (sj[4] - si[4]) + si[5] * ly
        ry = -sa * (sj[3] - si[3]) + ca * (sj[4] - si[4]) - si[5] * lx
        fx = data[d] * (lx - data[d + 6]) + data[d + 3] * rx  # on marker i, its frame
        fy = data[d + 1] * (ly - data[d + 7]) + data[d + 4] * ry
        out[0] = ca * fx - sa * fy
        out[1] = sa * fx + ca * fy
        # the torque on marker i: the angular spring's, less the moment of marker j's force
        # about marker i (so that the pair's moment vanishes)
        out[2] = (
            data[d + 2] * (sj[2] - si[2] - data[d + 8])
            + data[d + 5] * (sj[5] - si[5])
            + dx * out[1]
            - dy * out[0]
        )
    else:
        count = int(data[d])
        user_force(e, t, si[:6].copy(), sj[:6].copy(), data[d + 1 : d + 1 + count].copy(), out)
    return sj[0], sj[1]


@nb.njit(cache=True)
def force_terms(t, layout, data, z, v, user_force, forces):
    """Generalised forces of every force element, added to ``forces``."""
    bodies, markers, elements = layout[0], layout[1], layout[3]
    if elements.shape[0] == 0:
        return
    si = np.empty(MARKER_STATE_SIZE)
    sj = np.empty(MARKER_STATE_SIZE)
    out = np.zeros(3)
    for e in range(elements.shape[0]):
        ki = elements[e, 1]
        kj = elements[e, 2]
        px, py = element_force(e, t, layout, data, z, v, user_force, si, sj, out)
        add_point_load(ki, markers, bodies, data, z, si, out[0], out[1], forces)
        add_angle_load(ki, markers, bodies, data, out[2], forces)
        if kj < 0:
            continue
        if elements[e, 0] == CONTACT:  # the surface's point moves with marker j's frame
            add_frame_point_load(markers[kj, 0], bodies, z, px, py, -out[0], -out[1], forces)
        elif elements[e, 0] == BUSHING:  # marker j: the force and the angular spring's torque
            add_point_load(kj, markers, bodies, data, z, sj, -out[0], -out[1], forces)
            torque = out[2] - (sj[0] - si[0]) * out[1] + (sj[1] - si[1]) * out[0]
            add_angle_load(kj, markers, bodies, data, -torque, forces)
        else:
            add_point_load(kj, markers, bodies, data, z, sj, -out[0], -out[1], forces)
            add_angle_load(kj, markers, bodies, data, -out[2], forces)


@nb.njit(cache=True)
def workspace(layout):
    """Scratch arrays of :func:`accelerations_in` for ``layout``: the mass matrix (n, n), the
    joints' Jacobian (c, n) and four (c,) rows (allocated once per run, not per stage)."""
    n = layout[4][0]
    c = layout[4][1]
    return (
        np.empty((n, n)),
        np.empty((c, n)),
        np.empty(c),
        np.empty(c),
        np.empty(c),
        np.empty(c),
    )


@nb.njit(cache=True)
def accelerations(t, z, v, layout, data, user_force, system, solution):
    """Solve the constrained equations at (t, z, v) into ``solution`` = (z'', lambda).

    ``system`` is an (n + c, n + c) scratch matrix. Returns False if the
    matrix is singular or the result not finite.
    """
    return accelerations_in(workspace(layout), t, z, v, layout, data, user_force, system, solution)


@nb.njit(cache=True)
def accelerations_in(work, t, z, v, layout, data, user_force, system, solution):
    """:func:`accelerations` with the scratch arrays ``work`` (:func:`workspace`)."""
    c = layout[4][1]
    # the mass matrix in its own C-ordered array: body_terms then compiles once, for the
    # layout Mechanism.check passes too (a block of ``system`` is not C-ordered)
    mass, jac, residual, quadratic, rate, acceleration = work
    mass[:, :] = 0.0
    jac[:, :] = 0.0
    solution[:] = 0.0
    n = mass.shape[0]
    body_terms(layout[0], data, z, v, mass, solution[:n])
    force_terms(t, layout, data, z, v, user_force, solution[:n])
    if c:
        joint_terms(t, layout, data, z, v, jac, residual, quadratic, rate, acceleration)
    return solve_constrained(mass, jac, quadratic, acceleration, system, solution)


@nb.njit(cache=True)
def project(t, z, v, layout, data, tolerance):
    """Move (z, v) onto the joints' position and velocity manifolds (least change).

    Newton steps z <- z - G^T (G G^T)^-1 g until max|g| <= tolerance, then
    v <- v - G^T (G G^T)^-1 (G v - f'). Returns the largest |g| left, or inf
    if the projection does not converge.
    """
    sizes = layout[4]
    n = sizes[0]
    c = sizes[1]
    if c == 0:
        return 0.0
    residual, quadratic, rate, acceleration, jac = joint_buffers(c, n)
    worst = np.inf
    for _ in range(6):
        jac[:, :] = 0.0
        joint_terms(t, layout, data, z, v, jac, residual, quadratic, rate, acceleration)
        worst = largest_magnitude(residual)
        if worst <= tolerance:
            break
        if not project_rows(jac, residual, z):
            return np.inf
    if not worst <= tolerance:
        return np.inf
    jac[:, :] = 0.0
    joint_terms(t, layout, data, z, v, jac, residual, quadratic, rate, acceleration)
    return finish_projection(jac, rate, v, residual, worst)
