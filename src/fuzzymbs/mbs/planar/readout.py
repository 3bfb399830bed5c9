"""What a stored planar trajectory tells: energies, marker motion and element forces at every
state."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from fuzzymbs.mbs.planar.kernels import (
    BUSHING,
    CONTACT,
    MARKER_STATE_SIZE,
    ROTATIONAL_SPRING_DAMPER,
    SPRING_DAMPER,
    add_angle_load,
    add_point_load,
    body_terms,
    element_force,
    live_states,
    marker_state,
    plus_dot,
)


@nb.njit(cache=True)
def potential_energy(layout, data, z, v):
    """Gravity, elastic (modal) and spring energy of a state [J].

    Gravity: -g . (m r + A S(q)) per body, S the first moment with the
    foreshortening; elastic: 1/2 q^T K q; springs: 1/2 k (l - l0)^2, torsion
    springs 1/2 k (angle - a0)^2, bushings 1/2 (d - d0)^T K (d - d0) and their angular
    part, contacts 1/2 k g^2 while closed. Drives,
    loads and user forces are not conservative and have no potential here.
    """
    bodies, markers, elements = layout[0], layout[1], layout[3]
    gx = data[0]
    gy = data[1]
    energy = 0.0
    for b in range(bodies.shape[0]):
        o = bodies[b, 0]
        m = bodies[b, 1]
        d = bodies[b, 2]
        ia = d + 4
        icx = ia + 2 * m
        icy = icx + m
        ik = icy + m + 2 * m * m
        ikga = ik + 3 * m * m
        sx = data[d + 1]
        sy = data[d + 2]
        for i in range(m):
            qi = z[o + 3 + i]
            sx += data[icx + i] * qi
            sy += data[icy + i] * qi
            for j in range(m):
                energy += 0.5 * qi * data[ik + m * i + j] * z[o + 3 + j]
                if bodies[b, 3] != 0:
                    sx -= 0.5 * qi * data[ikga + m * i + j] * z[o + 3 + j]
        c = math.cos(z[o + 2])
        s = math.sin(z[o + 2])
        energy -= gx * (data[d] * z[o] + c * sx - s * sy)
        energy -= gy * (data[d] * z[o + 1] + s * sx + c * sy)
    si = np.empty(MARKER_STATE_SIZE)
    sj = np.empty(MARKER_STATE_SIZE)
    for e in range(elements.shape[0]):
        kind = elements[e, 0]
        ki = elements[e, 1]
        kj = elements[e, 2]
        d = elements[e, 3]
        if (
            kind != SPRING_DAMPER
            and kind != ROTATIONAL_SPRING_DAMPER
            and kind != CONTACT
            and kind != BUSHING
        ):
            continue
        marker_state(ki, markers, bodies, data, z, v, si)
        marker_state(kj, markers, bodies, data, z, v, sj)
        if kind == SPRING_DAMPER:
            length = math.sqrt((sj[0] - si[0]) ** 2 + (sj[1] - si[1]) ** 2)
            energy += 0.5 * data[d] * (length - data[d + 2]) ** 2
        elif kind == ROTATIONAL_SPRING_DAMPER:
            energy += 0.5 * data[d] * (sj[2] - si[2] - data[d + 2]) ** 2
        elif kind == BUSHING:
            ca = math.cos(si[2])
            sa = math.sin(si[2])
            dx = sj[0] - si[0]
            dy = sj[1] - si[1]
            energy += 0.5 * data[d] * (ca * dx + sa * dy - data[d + 6]) ** 2
            energy += 0.5 * data[d + 1] * (-sa * dx + ca * dy - data[d + 7]) ** 2
            energy += 0.5 * data[d + 2] * (sj[2] - si[2] - data[d + 8]) ** 2
        else:
            dx = si[0] - sj[0]
            dy = si[1] - sj[1]
            if data[d + 4] > 0.0:
                gap = math.sqrt(dx * dx + dy * dy) - data[d + 4]
            else:
                gap = -math.sin(sj[2]) * dx + math.cos(sj[2]) * dy
            if gap < 0.0:
                energy += 0.5 * data[d] * gap * gap
    return energy


@nb.njit(cache=True)
def energy_at(states, layout, data, out):
    """Kinetic and potential energy at every stored state: out (B, T, 2) [J]."""
    n = layout[4][0]
    mass = np.zeros((n, n))
    forces = np.zeros(n)
    for s, i in live_states(states, out):
        x = states[s, i]
        mass[:, :] = 0.0
        body_terms(layout[0], data[s], x[:n], x[n:], mass, forces)
        kinetic = 0.0
        for a in range(n):
            for b in range(n):
                kinetic += 0.5 * x[n + a] * mass[a, b] * x[n + b]
        out[s, i, 0] = kinetic
        out[s, i, 1] = potential_energy(layout, data[s], x[:n], x[n:])


@nb.njit(cache=True)
def markers_at(markers_wanted, states, layout, data, out):
    """State of the wanted markers at every stored state: out (B, T, K, 6)."""
    bodies, markers = layout[0], layout[1]
    n = layout[4][0]
    marker = np.empty(MARKER_STATE_SIZE)
    for s in range(states.shape[0]):
        for i in range(states.shape[1]):
            x = states[s, i]
            for w in range(markers_wanted.size):
                marker_state(markers_wanted[w], markers, bodies, data[s], x[:n], x[n:], marker)
                out[s, i, w, :] = marker[:6]


@nb.njit(cache=True, nogil=True)
def element_forces_at(element, times, states, layout, data, user_force, out):
    """Force element ``element``'s load on its marker i at every stored state: out (B, T, 3)
    = (fx, fy, torque), global, NaN after a failure."""
    n = layout[4][0]
    si = np.empty(MARKER_STATE_SIZE)
    sj = np.empty(MARKER_STATE_SIZE)
    load = np.zeros(3)
    for s, i in live_states(states, out):
        x = states[s, i]
        element_force(element, times[i], layout, data[s], x[:n], x[n:], user_force, si, sj, load)
        out[s, i, :] = load


@nb.njit(cache=True)
def marker_accelerations_at(marker, states, solved, layout, data, out):
    """Marker ``marker``'s acceleration at every stored state: out (B, T, 3) = ax, ay and the
    angular acceleration, from the solved z'' (``solved[..., :n]``): the marker's Jacobian
    rows times z'' plus the velocity-quadratic part of its acceleration."""
    bodies, markers = layout[0], layout[1]
    n = layout[4][0]
    state = np.empty(MARKER_STATE_SIZE)
    row = np.zeros(n)
    for s, i in live_states(solved, out):  # NaN where the state is, or unsolved
        x = states[s, i]
        marker_state(marker, markers, bodies, data[s], x[:n], x[n:], state)
        for c in range(3):
            row[:] = 0.0
            if c < 2:
                add_point_load(
                    marker, markers, bodies, data[s], x[:n], state, 1.0 - c, float(c), row
                )
            else:
                add_angle_load(marker, markers, bodies, data[s], 1.0, row)
            out[s, i, c] = plus_dot(state[6 + c] if c < 2 else 0.0, row, solved[s, i])
