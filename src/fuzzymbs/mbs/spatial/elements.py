"""Force elements of spatial mechanisms: springs, loads, contact, bushings and user force
laws, each evaluated on its own (:func:`element_force`) and summed into generalised forces
(:func:`force_terms`).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels.charts import locate
from fuzzymbs.mbs.planar.kernels import element_row, profile
from fuzzymbs.mbs.spatial.kinematics import (
    add_point_row,
    add_torque_row,
    add_turn_row,
    cross,
    marker_axes,
    marker_state,
    rotation,
    to_body_frame,
)

SPRING_DAMPER = 0
MARKER_LOAD = 1
USER_FORCE = 2
CONTACT = 3
BUSHING = 4
SURFACE_CONTACT = 5
#: Where a contact's reaction acts, as :func:`element_force` returns it: the point (3,
#: global) for a Contact; for a SurfaceContact the surface point in the master's frame
#: (3), then the cell (i, j), its bilinear coordinates (xi, eta) and 1 if on the patch.
CONTACT_POINT_SIZE = 8
# a SurfaceContact's numbers after its law (stiffness, damping, friction, eps):
# chart kind, periodic, nu, nv, chart frame (9), look-up scales (4), then the grids
_SC_HEAD = 21
#: Numbers a user force function receives for each marker: position (3), velocity (3),
#: angular velocity (3, global) and the axes x, y, z (3 each, global).
USER_STATE_SIZE = 18


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
def contact_law(data, d, gap, normal, slip, force):
    """The penalty law with regularised Coulomb friction (``data[d:d + 4]``: stiffness,
    damping, friction, eps) for a closed gap (< 0) and the slip velocity ``slip`` of the
    point over the surface (overwritten): the force on the point into ``force`` (zero
    while the normal force would pull)."""
    closing = normal[0] * slip[0] + normal[1] * slip[1] + normal[2] * slip[2]
    press = -data[d] * gap - data[d + 1] * closing
    if press <= 0.0:
        return
    eps = data[d + 3]
    sliding = 0.0
    for c in range(3):
        slip[c] -= closing * normal[c]
        sliding += slip[c] ** 2
    scale = data[d + 2] * press / math.sqrt(sliding + eps * eps)
    for c in range(3):
        force[c] = press * normal[c] - scale * slip[c]


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
    contact_law(data, d, gap, normal, slip, force)
    return gap


@nb.njit(cache=True)
def surface_offsets(data, d):
    """A SurfaceContact's grid sizes and where its arrays start in ``data``:
    (nu, nv, cells along v, u grid, v grid, normals, node positions, mode shapes)."""
    nu = int(data[d + 6])
    nv = int(data[d + 7])
    ncv = nv if data[d + 5] != 0.0 else nv - 1  # a periodic angle grid wraps around
    o_u = d + _SC_HEAD
    o_v = o_u + nu
    o_n = o_v + nv
    o_x = o_n + 3 * (nu - 1) * ncv
    return nu, nv, ncv, o_u, o_v, o_n, o_x, o_x + 3 * nu * nv


@nb.njit(cache=True)
def cell_corners(i, j, xi, eta, nv):
    """The four grid nodes of cell (i, j) (the v index wraps) and their bilinear weights
    at (xi, eta), in the brake kernel's order."""
    j1 = j + 1 if j + 1 < nv else 0
    corners = (i * nv + j, (i + 1) * nv + j, (i + 1) * nv + j1, i * nv + j1)
    weights = ((1.0 - xi) * (1.0 - eta), xi * (1.0 - eta), xi * eta, (1.0 - xi) * eta)
    return corners, weights


@nb.njit(cache=True)
def surface_contact_force(markers, bodies, data, d, kj, q, v, si, force, point):
    """Penalty contact of marker i's point with the meshed surface of marker j's body
    (:class:`fuzzymbs.mbs.spatial.forces.SurfaceContact`): the force on marker i into
    ``force``, the surface point and cell into ``point`` (:data:`CONTACT_POINT_SIZE`);
    returns the gap [m] (negative: penetration; +inf off the patch).

    The point is looked up in the chart of the master frame, the cell's four nodes give
    the deformed surface point and its velocity by their bilinear weights, the cell's
    undeformed normal turns with the frame (as the brake's contact kernel does).
    """
    for c in range(3):
        force[c] = 0.0
    point[7] = 0.0
    body = markers[kj, 0]
    po = bodies[body, 0]
    vo = bodies[body, 1]
    r = bodies[body, 3]
    polar = data[d + 4] != 0.0
    periodic = data[d + 5] != 0.0
    fr = d + 8
    scales = (data[d + 17], data[d + 18] != 0.0, data[d + 19], data[d + 20] != 0.0)
    nu, nv, ncv, o_u, o_v, o_n, o_x, o_psi = surface_offsets(data, d)
    # the point in the master frame, then in the chart
    arm = np.empty(3)
    for c in range(3):
        arm[c] = si[0, c] - q[po + c]
    local = np.empty(3)
    to_body_frame(q, po, arm, local)
    a = 0.0
    b = 0.0
    for c in range(3):
        a += (local[c] - data[fr + c]) * data[fr + 3 + c]
        b += (local[c] - data[fr + c]) * data[fr + 6 + c]
    if polar:
        u = math.sqrt(a * a + b * b)
        w = math.atan2(b, a)
    else:
        u = a
        w = b
    on, i, j, xi, eta = locate(u, w, data[o_u : o_u + nu], data[o_v : o_v + nv], periodic, scales)
    if not on:
        return math.inf
    corners, weights = cell_corners(i, j, xi, eta, nv)
    s = np.zeros(3)  # the surface point, master frame, deformed
    sd = np.zeros(3)  # its elastic velocity, master frame
    for k in range(4):
        node = corners[k]
        wk = weights[k]
        for c in range(3):
            s[c] += wk * data[o_x + 3 * node + c]
            for m in range(r):
                psi = data[o_psi + (3 * node + c) * r + m]
                s[c] += wk * psi * q[po + 7 + m]
                sd[c] += wk * psi * v[vo + 6 + m]
    rot = np.empty((3, 3))
    rotation(q, po + 3, rot)
    ws = np.empty(3)
    cross(v[vo + 3 : vo + 6], s, ws)
    cell = 3 * (i * ncv + j)
    normal = np.zeros(3)
    gap = 0.0
    slip = np.empty(3)
    for c in range(3):
        xm = q[po + c]
        vm = v[vo + c]
        for k in range(3):
            xm += rot[c, k] * s[k]
            vm += rot[c, k] * (ws[k] + sd[k])
            normal[c] += rot[c, k] * data[o_n + cell + k]
        slip[c] = si[1, c] - vm
        gap += normal[c] * (si[0, c] - xm)
    for c in range(3):
        point[c] = s[c]
    point[3] = i
    point[4] = j
    point[5] = xi
    point[6] = eta
    point[7] = 1.0
    if gap >= 0.0:
        return gap
    contact_law(data, d, gap, normal, slip, force)
    return gap


@nb.njit(cache=True)
def add_surface_point_row(body, bodies, data, d, q, point, weight, target):
    """target += weight^T dp/d(r', w, q') for the surface point of a SurfaceContact
    (``point`` from :func:`surface_contact_force`): the frame's rows at the point, and
    the modal rows of its four nodes, each by its bilinear weight."""
    vo = bodies[body, 1]
    r = bodies[body, 3]
    for c in range(3):
        target[vo + c] += weight[c]
    add_turn_row(body, bodies, q, point[:3].copy(), weight, target)
    if r == 0:
        return
    local = np.empty(3)
    to_body_frame(q, bodies[body, 0], weight, local)
    _, nv, _, _, _, _, _, o_psi = surface_offsets(data, d)
    corners, weights = cell_corners(int(point[3]), int(point[4]), point[5], point[6], nv)
    for k in range(4):
        for c in range(3):
            share = weights[k] * local[c]
            row = o_psi + (3 * corners[k] + c) * r
            for m in range(r):
                target[vo + 6 + m] += data[row + m] * share


@nb.njit(cache=True)
def add_frame_point_row(body, bodies, q, point, weight, target):
    """target += weight^T dp/d(r', w) for the global ``point`` moving with ``body``'s
    frame (no modal part)."""
    if body < 0:
        return
    po = bodies[body, 0]
    vo = bodies[body, 1]
    arm = np.empty(3)
    for i in range(3):
        arm[i] = point[i] - q[po + i]
        target[vo + i] += weight[i]
    local = np.empty(3)
    to_body_frame(q, po, arm, local)
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
    kind, ki, kj, d, code = element_row(elements, e)
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
    elif kind == SURFACE_CONTACT:
        force = np.empty(3)
        surface_contact_force(markers, bodies, data, d, kj, q, v, si, force, point)
        load[:3] = force
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
    point = np.empty(CONTACT_POINT_SIZE)
    for e in range(elements.shape[0]):
        kind = elements[e, 0]
        ki = elements[e, 1]
        kj = elements[e, 2]
        element_force(e, t, layout, data, q, v, user_force, si, sj, load, point)
        add_point_row(ki, markers, bodies, data, q, si[3].copy(), load[:3].copy(), forces)
        add_torque_row(ki, markers, bodies, q, load[3:].copy(), forces)
        if kj < 0 or kind == MARKER_LOAD:
            continue
        if kind == CONTACT:  # the surface's point moves with marker j's frame
            add_frame_point_row(markers[kj, 0], bodies, q, point[:3].copy(), -load[:3], forces)
        elif kind == SURFACE_CONTACT:
            if point[7] != 0.0:
                d = elements[e, 3]
                add_surface_point_row(markers[kj, 0], bodies, data, d, q, point, -load[:3], forces)
        elif kind == BUSHING:  # marker j: the force and the angular spring's torque
            add_point_row(kj, markers, bodies, data, q, sj[3].copy(), -load[:3], forces)
            span = np.empty(3)
            moment = np.empty(3)
            for c in range(3):
                span[c] = sj[0, c] - si[0, c]
            cross(span, load[:3].copy(), moment)
            add_torque_row(kj, markers, bodies, q, moment - load[3:], forces)
        else:
            add_point_row(kj, markers, bodies, data, q, sj[3].copy(), -load[:3], forces)
            add_torque_row(kj, markers, bodies, q, -load[3:], forces)
