"""Compiled batch kernel of the FE loaded tooth contact (Numba).

The same algorithm as :func:`fuzzymbs.models.gears.fe_contact.solve_position`,
which stays the readable reference (and the second method of the tests): per
mesh position the rigid geometry of every tooth pair, the compliance matrix from
both gears' influence tables, the Hertzian flattening secants, the linear
complementarity problem by an active-set method (enumeration of the active sets
as the fallback), repeated until the lag and the forces settle. Here the whole
batch of samples runs in one call, in parallel over the samples.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzymbs.models.gears.flank_contact import (
    CENTER,
    NO_CONTACT,
    PHI_REF2,
    PINION_TIP,
    PITCH1,
    PITCH2,
    RB1,
    RB2,
    THETA_REF1,
    TIP_ROLL1,
    TIP_ROLL2,
    WHEEL_TIP,
    pair_contact,
)

__all__ = ["solve_batch"]

NOT_CONVERGED, NO_CONTACT_STATUS = 1, 2


@numba.njit(cache=True, inline="always")
def _weights(grid, roll):
    spacing = (grid[-1] - grid[0]) / (grid.shape[0] - 1)
    index = min(max(int((roll - grid[0]) // spacing), 0), grid.shape[0] - 2)
    weight = min(max((roll - grid[index]) / spacing, 0.0), 1.0)
    return index, weight


@numba.njit(cache=True)
def _bilinear(table, row, grid, roll_i, roll_j, out):
    i, wi = _weights(grid, roll_i)
    j, wj = _weights(grid, roll_j)
    for a in range(2):
        for c in range(2):
            out[a, c] = (
                (1 - wi) * (1 - wj) * table[row, i, j, a, c]
                + (1 - wi) * wj * table[row, i, j + 1, a, c]
                + wi * (1 - wj) * table[row, i + 1, j, a, c]
                + wi * wj * table[row, i + 1, j + 1, a, c]
            )


@numba.njit(cache=True)
def _linear(table, grid, roll, out):
    i, w = _weights(grid, roll)
    for a in range(2):
        for c in range(2):
            out[a, c] = (1 - w) * table[i, a, c] + w * table[i + 1, a, c]


@numba.njit(cache=True, inline="always")
def _quadratic(u, m, v):
    return u[0] * (m[0, 0] * v[0] + m[0, 1] * v[1]) + u[1] * (m[1, 0] * v[0] + m[1, 1] * v[1])


@numba.njit(cache=True)
def _solve_active(matrix, overlap, lever, torque, active, force):
    """Forces of the active pairs and the lag; returns (ok, lag)."""
    n = overlap.shape[0]
    count = 0
    for i in range(n):
        if active[i]:
            count += 1
    index = np.empty(count, dtype=np.int64)
    k = 0
    for i in range(n):
        if active[i]:
            index[k] = i
            k += 1
    system = np.zeros((count + 1, count + 1))
    rhs = np.zeros(count + 1)
    for a in range(count):
        for c in range(count):
            system[a, c] = matrix[index[a], index[c]]
        system[a, count] = -lever[index[a]]
        system[count, a] = lever[index[a]]
        rhs[a] = overlap[index[a]]
    rhs[count] = torque
    if abs(np.linalg.det(system)) == 0.0:
        return False, 0.0
    solution = np.linalg.solve(system, rhs)
    force[:] = 0.0
    for a in range(count):
        force[index[a]] = solution[a]
    return True, solution[count]


@numba.njit(cache=True)
def _lcp(matrix, overlap, lever, torque, active, force):
    """Active set, then enumeration; returns (lag, ok). ``force`` is filled."""
    n = overlap.shape[0]
    scale = 1e-9
    for i in range(n):
        scale = max(scale, abs(overlap[i]))
    tol = 1e-12 * scale
    lever_max = 1e-12
    for i in range(n):
        lever_max = max(lever_max, lever[i])
    force_tol = 1e-12 * abs(torque) / lever_max
    any_active = False
    for i in range(n):
        any_active = any_active or active[i]
    if not any_active:
        active[np.argmax(overlap)] = True
    for _ in range(4 * n + 4):
        ok, lag = _solve_active(matrix, overlap, lever, torque, active, force)
        if not ok:
            break
        worst, lowest = -1, -force_tol
        for i in range(n):
            if active[i] and force[i] < lowest:
                worst, lowest = i, force[i]
        if worst >= 0:
            active[worst] = False
            if not np.any(active):
                active[np.argmax(overlap)] = True
            continue
        worst, highest = -1, tol
        for i in range(n):
            if not active[i]:
                residual = overlap[i] + lever[i] * lag
                for j in range(n):
                    residual -= matrix[i, j] * force[j]
                if residual > highest:
                    worst, highest = i, residual
        if worst >= 0:
            active[worst] = True
            continue
        for i in range(n):
            force[i] = max(force[i], 0.0)
        return lag, True
    # fallback: every active set, the complementary one (unique for positive definite C)
    best_violation, best_lag = np.inf, 0.0
    best_force = np.zeros(n)
    trial = np.zeros(n)
    for mask in range(1, 1 << n):
        for i in range(n):
            active[i] = (mask >> i) & 1 == 1
        ok, lag = _solve_active(matrix, overlap, lever, torque, active, trial)
        if not ok:
            continue
        negative = False
        for i in range(n):
            if active[i] and trial[i] < 0.0:
                negative = True
        if negative:
            continue
        violation = -np.inf
        for i in range(n):
            if not active[i]:
                residual = overlap[i] + lever[i] * lag
                for j in range(n):
                    residual -= matrix[i, j] * trial[j]
                violation = max(violation, residual)
        if violation < best_violation:
            best_violation, best_lag = violation, lag
            best_force[:] = trial
    force[:] = best_force
    return best_lag, best_violation < np.inf


@numba.njit(cache=True)
def _flattening(force, radius, width, depth1, depth2, modulus, poisson, plane_strain):
    """Secant compliance [m/N] of both bodies' Hertzian flattening to their reference depths."""
    factor = 1.0 - poisson * poisson if plane_strain else 1.0
    shift = poisson / (2.0 * (1.0 - poisson)) if plane_strain else poisson / 2.0
    compliance = factor / modulus
    e_star = 1.0 / (2.0 * compliance)
    force = max(force, 1e-6)
    half = math.sqrt(4.0 * force * radius / (math.pi * width * e_star))
    total = 0.0
    for depth in (depth1, depth2):
        total += 2.0 * compliance / (math.pi * width) * (math.log(2.0 * depth / half) - shift)
    return total


@numba.njit(cache=True)
def _position(position, g, pairs, torque, modulus, poisson, width, edge, plane_strain,
              grid1, surface1, reference1, depth1, grid2, surface2, reference2, depth2,
              lag, force_out, kind_out):  # fmt: skip
    """One mesh position (``fe_contact.solve_position``); returns (lag, status)."""
    theta_kin = position * g[PITCH1]
    theta2 = -position * g[PITCH2]
    n = pairs.shape[0]
    half1 = (surface1.shape[0] - 1) // 2
    half2 = (surface2.shape[0] - 1) // 2
    force = np.zeros(n)
    kind = np.zeros(n, dtype=np.int64)
    overlap = np.zeros(n)
    lever = np.zeros(n)
    roll1 = np.zeros(n)
    roll2 = np.zeros(n)
    load1 = np.zeros((n, 2))
    load2 = np.zeros((n, 2))
    radius = np.zeros(n)
    block = np.zeros((2, 2))
    step = torque / (g[RB1] ** 2 * 1e9)
    for iteration in range(60):
        live = 0
        for i in range(n):
            k = pairs[i]
            theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
            phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
            kd, delta, qx, qy, nx, ny, _, _, _, _ = pair_contact(theta, 0.0, phi, 0.0, g)
            kind[i] = kd
            if kd == NO_CONTACT:
                continue
            live += 1
            c1, s1 = math.cos(theta), math.sin(theta)
            c2, s2 = math.cos(phi), math.sin(phi)
            px, py = c1 * qx + s1 * qy, -s1 * qx + c1 * qy
            wx, wy = c2 * (qx - g[CENTER]) + s2 * qy, -s2 * (qx - g[CENTER]) + c2 * qy
            roll1[i] = math.sqrt(max(px * px + py * py - g[RB1] ** 2, 0.0))
            roll2[i] = math.sqrt(max(wx * wx + wy * wy - g[RB2] ** 2, 0.0))
            if kd == PINION_TIP:
                roll1[i] = g[TIP_ROLL1]
            elif kd == WHEEL_TIP:
                roll2[i] = g[TIP_ROLL2]
            rho1 = edge if kd == PINION_TIP else max(roll1[i], 1e-9)
            rho2 = edge if kd == WHEEL_TIP else max(roll2[i], 1e-9)
            radius[i] = rho1 * rho2 / (rho1 + rho2)
            overlap[i] = delta
            lever[i] = qx * ny - qy * nx
            load1[i, 0], load1[i, 1] = -(c1 * nx + s1 * ny), -(-s1 * nx + c1 * ny)
            load2[i, 0], load2[i, 1] = c2 * nx + s2 * ny, -s2 * nx + c2 * ny
        if live == 0:
            lag += step
            step *= 2.0
            if step > g[PITCH1]:
                return lag, NO_CONTACT_STATUS
            continue
        index = np.empty(live, dtype=np.int64)
        k = 0
        for i in range(n):
            if kind[i] != NO_CONTACT:
                index[k] = i
                k += 1
        matrix = np.zeros((live, live))
        for a in range(live):
            ia = index[a]
            for c in range(live):
                ic = index[c]
                value = 0.0
                if a == c:
                    _linear(reference1, grid1, roll1[ia], block)
                    value += _quadratic(load1[ia], block, load1[ia])
                    _linear(reference2, grid2, roll2[ia], block)
                    value += _quadratic(load2[ia], block, load2[ia])
                else:
                    d1 = pairs[ia] - pairs[ic]
                    if abs(d1) <= half1:
                        _bilinear(surface1, d1 + half1, grid1, roll1[ia], roll1[ic], block)
                        value += _quadratic(load1[ia], block, load1[ic])
                    d2 = pairs[ic] - pairs[ia]
                    if abs(d2) <= half2:
                        _bilinear(surface2, d2 + half2, grid2, roll2[ia], roll2[ic], block)
                        value += _quadratic(load2[ia], block, load2[ic])
                matrix[a, c] = value
        matrix = 0.5 * (matrix + matrix.T) / modulus
        sub_overlap = np.empty(live)
        sub_lever = np.empty(live)
        active = np.zeros(live, dtype=np.bool_)
        for a in range(live):
            ia = index[a]
            seed = force[ia] if force[ia] > 0.0 else torque / g[RB1]
            matrix[a, a] += _flattening(seed, radius[ia], width, depth1, depth2, modulus,
                                        poisson, plane_strain)  # fmt: skip
            sub_overlap[a] = overlap[ia]
            sub_lever[a] = lever[ia]
            active[a] = force[ia] > 0.0
        sub_force = np.zeros(live)
        delta_lag, _ = _lcp(matrix, sub_overlap, sub_lever, torque, active, sub_force)
        change = 0.0
        new_force = np.zeros(n)
        for a in range(live):
            new_force[index[a]] = sub_force[a]
        for i in range(n):
            change = max(change, abs(new_force[i] - force[i]))
        force[:] = new_force
        lag += delta_lag
        if abs(delta_lag) * g[RB1] < 1e-13 and change * g[RB1] / torque < 1e-7 and iteration > 0:
            for i in range(n):
                force_out[i] = force[i]
                kind_out[i] = kind[i] if force[i] > 0.0 else 0
            return lag, 0
    for i in range(n):
        force_out[i] = force[i]
        kind_out[i] = kind[i] if force[i] > 0.0 else 0
    return lag, NOT_CONVERGED


@numba.njit(cache=True, parallel=True)
def solve_batch(geometry, status, positions, pairs, torque, modulus, poisson, width, edge,
                plane_strain, grid1, surface1, reference1, depth1, grid2, surface2,
                reference2, depth2):  # fmt: skip
    """STE of a batch of samples that share one Poisson's ratio (their tables).

    Parameters
    ----------
    geometry : (B, G) each sample's geometry vector (``sample_geometry``)
    status : (B,) geometry status (0 ok); samples with a status are skipped
    positions : (P,) mesh positions; pairs : (K,) tooth-pair indices
    torque, modulus : (B,) pinion torque [N m], Young's modulus [Pa]
    poisson, width, edge : Poisson's ratio, face width [m], tip-corner radius [m]
    plane_strain : bool
    grid*, surface*, reference*, depth* : the pinion's (1) and wheel's (2) flank
        tables (``FlankCompliance`` arrays, E = 1) and reference depths [m]

    Returns
    -------
    ste (B, P) [m], force (B, P, K) [N], kind (B, P, K), status (B,)
    """
    n_samples = geometry.shape[0]
    n_pos = positions.shape[0]
    n_pairs = pairs.shape[0]
    ste = np.full((n_samples, n_pos), np.nan)
    force = np.zeros((n_samples, n_pos, n_pairs))
    kind = np.zeros((n_samples, n_pos, n_pairs), dtype=np.int64)
    out_status = status.copy()
    for b in numba.prange(n_samples):
        if out_status[b] != 0:
            continue
        g = geometry[b]
        lag = 0.0
        for j in range(n_pos):
            lag, flag = _position(positions[j], g, pairs, torque[b], modulus[b], poisson,
                                  width, edge, plane_strain, grid1, surface1, reference1,
                                  depth1, grid2, surface2, reference2, depth2, lag,
                                  force[b, j], kind[b, j])  # fmt: skip
            if flag != 0:
                out_status[b] = flag
                break
            ste[b, j] = g[RB1] * lag
        if out_status[b] != 0:
            for j in range(n_pos):
                ste[b, j] = np.nan
    return ste, force, kind, out_status
