"""What a stored spatial trajectory tells: marker motion and accelerations, energies and
element forces at every state."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.planar.kernels import failed_before, live_states, plus_dot
from fuzzymbs.mbs.spatial.elements import (
    BUSHING,
    CONTACT,
    CONTACT_POINT_SIZE,
    SPRING_DAMPER,
    SURFACE_CONTACT,
    bushing_offsets,
    contact_force,
    element_force,
    surface_contact_force,
)
from fuzzymbs.mbs.spatial.kernels import body_terms
from fuzzymbs.mbs.spatial.kinematics import add_point_row, marker_state, rotation


@nb.njit(cache=True)
def markers_at(wanted, states, layout, data, out):
    """Position and velocity of the wanted markers at every stored state: out (B, T, K, 6)."""
    bodies, markers = layout[0], layout[1]
    nq = layout[4][0]
    state = np.empty((6, 3))
    for s, i in live_states(states, out):
        x = states[s, i]
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
    point = np.empty(CONTACT_POINT_SIZE)
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
            if failed_before(states, s, t, out):
                continue
            x = states[s, t]
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
                # a stiffened body's first moment: S - 1/2 sum_i (q^T K_i q) e_i
                o_ka = o_k + 2 * r
                for i in range(3):
                    first = row[d + 1 + i]
                    if bodies[b, 4] != 0:
                        for m in range(r):
                            for k in range(r):
                                first -= (
                                    0.5
                                    * q[po + 7 + m]
                                    * row[o_ka + (i * r + m) * r + k]
                                    * q[po + 7 + k]
                                )
                    for m in range(r):
                        first += row[o_ct + i * r + m] * q[po + 7 + m]
                    for k in range(3):
                        potential -= g[k] * rot[k, i] * first
                    potential -= g[i] * row[d] * q[po + i]
                for m in range(r):
                    elastic += 0.5 * row[o_k + m] * q[po + 7 + m] ** 2
            for e in range(elements.shape[0]):
                kind = elements[e, 0]
                if not (
                    kind == SPRING_DAMPER
                    or kind == CONTACT
                    or kind == BUSHING
                    or kind == SURFACE_CONTACT
                ):
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
                if kind == CONTACT or kind == SURFACE_CONTACT:
                    if kind == CONTACT:
                        gap = contact_force(
                            markers, bodies, row, d, elements[e, 2], q, v, si, sj, force, point
                        )
                    else:
                        gap = surface_contact_force(
                            markers, bodies, row, d, elements[e, 2], q, v, si, force, point
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


@nb.njit(cache=True, nogil=True)
def element_forces_at(element, times, states, layout, data, user_force, out):
    """Force element ``element``'s load on its marker i at every stored state: out (B, T, 6)
    = force and torque, global, NaN after a failure."""
    nq = layout[4][0]
    si = np.empty((6, 3))
    sj = np.empty((6, 3))
    load = np.empty(6)
    point = np.empty(CONTACT_POINT_SIZE)
    for s, i in live_states(states, out):
        x = states[s, i]
        element_force(
            element, times[i], layout, data[s], x[:nq], x[nq:], user_force, si, sj, load, point
        )
        out[s, i, :] = load


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
    for s, i in live_states(solved, out):  # NaN where the state is, or unsolved
        x = states[s, i]
        q = x[:nq]
        marker_state(marker, markers, bodies, data[s], q, x[nq:], state)
        for c in range(3):
            row[:] = 0.0
            add_point_row(marker, markers, bodies, data[s], q, state[3].copy(), unit[c], row)
            out[s, i, c] = plus_dot(state[2, c], row, solved[s, i])
            out[s, i, 3 + c] = 0.0
        if body >= 0:
            rotation(q, bodies[body, 0] + 3, rot)
            vo = bodies[body, 1]
            for c in range(3):
                for k in range(3):
                    out[s, i, 3 + c] += rot[c, k] * solved[s, i, vo + 3 + k]
