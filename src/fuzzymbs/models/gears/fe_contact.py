"""Loaded tooth contact of a gear pair from FE flank compliances: one mesh position.

At a mesh position the wheel is held at its kinematic angle and the pinion turns
by the lag phi under the torque T1 (STE = r_b1 phi, as in ``gear-pair``). Every
tooth pair k that can touch has, from the rigid geometry of
:func:`~fuzzymbs.models.gears.flank_contact.pair_contact` (conjugate contact on
the line of action or a tip corner against the mating flank, off it; tip relief
and centre-distance deviation included), an overlap delta_k(phi), a contact
normal and the lever arm L_k = d delta_k / d phi about the pinion axis. The
contact forces F_k and the lag solve the complementarity problem

    delta_k(phi) - w_k(F) <= 0,  F_k >= 0,  F_k (delta_k(phi) - w_k(F)) = 0,
    sum_k L_k F_k = T1,

with the elastic approach w_k = sum_j C_kj F_j + h_k(F_k) F_k: C from the FE
influence coefficients of both gears (couplings through the rims included), h_k
the secant of the local Hertzian flattening down to the reference depth
(:mod:`fuzzymbs.models.gears.half_plane`). The geometry is linearised in phi and
the secants frozen; the linear problem is solved by an active-set method (exact
for a positive definite C in a few steps, with enumeration of the active sets as
the fallback) and the linearisation is updated until phi and the forces settle.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from fuzzymbs.models.gears.fe_compliance import FlankCompliance
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
from fuzzymbs.models.gears.half_plane import contact_half_width, depth_approach

__all__ = ["ContactSettings", "solve_lcp", "solve_lcp_enumerated", "solve_position"]


@dataclass(frozen=True)
class ContactSettings:
    """Material, compliance tables and contact data of one sample.

    Attributes
    ----------
    pinion, wheel : FlankCompliance
        Influence tables (E = 1 Pa).
    youngs_modulus : float
        E of both gears [Pa].
    poisson_ratio : float
        nu of both gears (the tables were computed with it).
    face_width : float
        b [m].
    edge_radius : float
        Rounding radius of a tip corner in corner contact [m] (its Hertz curvature).
    analysis : str
        "plane-strain" or "plane-stress" (the local flattening follows the FE model).
    """

    pinion: FlankCompliance
    wheel: FlankCompliance
    youngs_modulus: float
    poisson_ratio: float
    face_width: float
    edge_radius: float
    analysis: str


def _weights(grid: np.ndarray, roll: float) -> tuple[int, float]:
    """Linear interpolation index and weight of ``roll`` on ``grid`` (clamped)."""
    # uniform grid (fe_mesh): the index is arithmetic
    spacing = (grid[-1] - grid[0]) / (grid.size - 1)
    index = min(max(int((roll - grid[0]) // spacing), 0), grid.size - 2)
    weight = (roll - grid[index]) / spacing
    return index, min(max(weight, 0.0), 1.0)


def _surface(table: FlankCompliance, offset: int, roll_i: float, roll_j: float) -> np.ndarray:
    """2x2 influence of a load at roll_j (tooth 0) on roll_i (tooth ``offset``), or zeros."""
    row = table.offset_index(offset)
    if row is None:
        return np.zeros((2, 2))
    i, wi = _weights(table.grid_roll, roll_i)
    j, wj = _weights(table.grid_roll, roll_j)
    block = table.surface[row, i : i + 2, j : j + 2]
    return (
        (1 - wi) * (1 - wj) * block[0, 0]
        + (1 - wi) * wj * block[0, 1]
        + wi * (1 - wj) * block[1, 0]
        + wi * wj * block[1, 1]
    )


def _reference(table: FlankCompliance, roll: float) -> np.ndarray:
    i, w = _weights(table.grid_roll, roll)
    return (1 - w) * table.reference[i] + w * table.reference[i + 1]


def _rotate(vector: tuple[float, float], angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1]])


@dataclass
class _PairState:
    kind: int
    overlap: float
    lever: float
    roll1: float
    roll2: float
    load1: np.ndarray  # load direction on the pinion tooth, tooth-local
    load2: np.ndarray  # load direction on the wheel tooth, tooth-local
    radius: float  # relative radius of curvature R [m]


def _pair_state(k: int, theta_kin: float, theta2: float, lag: float, g: np.ndarray,
                edge_radius: float) -> _PairState:  # fmt: skip
    theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
    phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
    kind, delta, qx, qy, nx, ny, _, _, _, _ = pair_contact(theta, 0.0, phi, 0.0, g)
    if kind == NO_CONTACT:
        return _PairState(kind, -math.inf, 0.0, 0.0, 0.0, np.zeros(2), np.zeros(2), 0.0)
    p1 = _rotate((qx, qy), -theta)
    p2 = _rotate((qx - g[CENTER], qy), -phi)
    roll1 = math.sqrt(max(p1 @ p1 - g[RB1] ** 2, 0.0))
    roll2 = math.sqrt(max(p2 @ p2 - g[RB2] ** 2, 0.0))
    if kind == PINION_TIP:
        roll1 = g[TIP_ROLL1]
    elif kind == WHEEL_TIP:
        roll2 = g[TIP_ROLL2]
    rho1 = edge_radius if kind == PINION_TIP else max(roll1, 1e-9)
    rho2 = edge_radius if kind == WHEEL_TIP else max(roll2, 1e-9)
    return _PairState(
        kind=int(kind),
        overlap=float(delta),
        lever=qx * ny - qy * nx,
        roll1=roll1,
        roll2=roll2,
        load1=_rotate((-nx, -ny), -theta),
        load2=_rotate((nx, ny), -phi),
        radius=rho1 * rho2 / (rho1 + rho2),
    )


def _local_secant(force: float, state: _PairState, settings: ContactSettings) -> float:
    """Secant compliance [m/N] of both bodies' flattening down to their reference depths."""
    e, nu, b = settings.youngs_modulus, settings.poisson_ratio, settings.face_width
    force = max(force, 1e-6)
    half = contact_half_width(force, b, state.radius, ((e, nu), (e, nu)), settings.analysis)
    total = 0.0
    for table in (settings.pinion, settings.wheel):
        total += float(
            depth_approach(force, b, half, table.reference_depth, e, nu, settings.analysis)
        )
    return total / force


def _compliance(
    states: list[_PairState], pairs: np.ndarray, settings: ContactSettings
) -> np.ndarray:
    """Structural compliance C [m/N] among the given pair states (both gears)."""
    n = len(states)
    matrix = np.zeros((n, n))
    for a in range(n):
        for c in range(n):
            sa, sc = states[a], states[c]
            if a == c:
                g1 = _reference(settings.pinion, sa.roll1)
                g2 = _reference(settings.wheel, sa.roll2)
            else:
                # pinion tooth of pair k is k pitches counter-clockwise, the wheel's clockwise
                g1 = _surface(settings.pinion, int(pairs[a] - pairs[c]), sa.roll1, sc.roll1)
                g2 = _surface(settings.wheel, int(pairs[c] - pairs[a]), sa.roll2, sc.roll2)
            matrix[a, c] = sa.load1 @ g1 @ sc.load1 + sa.load2 @ g2 @ sc.load2
    matrix = 0.5 * (matrix + matrix.T)  # Maxwell-Betti; removes interpolation asymmetry
    return matrix / settings.youngs_modulus


def _solve_active(matrix, overlap, lever, torque, active):
    index = np.flatnonzero(active)
    n = index.size
    system = np.zeros((n + 1, n + 1))
    system[:n, :n] = matrix[np.ix_(index, index)]
    system[:n, n] = -lever[index]
    system[n, :n] = lever[index]
    rhs = np.concatenate((overlap[index], [torque]))
    try:
        solution = np.linalg.solve(system, rhs)
    except np.linalg.LinAlgError:
        return None, None
    force = np.zeros(overlap.size)
    force[index] = solution[:n]
    return force, solution[n]


def solve_lcp(
    matrix: np.ndarray,
    overlap: np.ndarray,
    lever: np.ndarray,
    torque: float,
    active: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """Contact forces and lag of the linear complementarity problem (active set).

    Finds F >= 0 and x with ``overlap + lever x - matrix F <= 0``, complementary to
    F, and ``lever . F = torque``.

    Parameters
    ----------
    matrix : (n, n) positive definite compliance [m/N]
    overlap : (n,) rigid overlap at x = 0 [m]
    lever : (n,) d overlap / d x [m/rad] (positive)
    torque : float
        Pinion torque [N m].
    active : (n,) bool, optional
        Initial guess of the loaded pairs (default: the largest overlap).

    Returns
    -------
    force (n,) [N], x [rad]
    """
    n = overlap.size
    if active is None or not np.any(active):
        active = np.zeros(n, dtype=bool)
        active[int(np.argmax(overlap + lever * 0.0))] = True
    active = active.copy()
    tol = 1e-12 * max(float(np.max(np.abs(overlap))), 1e-9)
    force_tol = 1e-12 * abs(torque) / max(float(np.max(lever)), 1e-12)
    for _ in range(4 * n + 4):
        force, lag = _solve_active(matrix, overlap, lever, torque, active)
        if force is None:
            break
        if np.any(force[active] < -force_tol):
            worst = np.flatnonzero(active)[np.argmin(force[active])]
            active[worst] = False
            if not np.any(active):
                active[int(np.argmax(overlap))] = True
            continue
        residual = overlap + lever * lag - matrix @ force
        residual[active] = -np.inf
        if residual.max() > tol:
            active[int(np.argmax(residual))] = True
            continue
        return np.maximum(force, 0.0), float(lag)
    return solve_lcp_enumerated(matrix, overlap, lever, torque)


def solve_lcp_enumerated(
    matrix: np.ndarray, overlap: np.ndarray, lever: np.ndarray, torque: float
) -> tuple[np.ndarray, float]:
    """The same problem by trying every active set (a check and the fallback; n <= 8)."""
    n = overlap.size
    tol = 1e-9 * max(float(np.max(np.abs(overlap))), 1e-12)
    best = None
    for size in range(1, n + 1):
        for subset in itertools.combinations(range(n), size):
            active = np.zeros(n, dtype=bool)
            active[list(subset)] = True
            force, lag = _solve_active(matrix, overlap, lever, torque, active)
            if force is None or np.any(force[active] < 0.0):
                continue
            residual = overlap + lever * lag - matrix @ force
            violation = float(np.max(residual[~active], initial=-np.inf))
            if violation <= tol:
                return force, float(lag)
            if best is None or violation < best[0]:
                best = (violation, force, float(lag))
    if best is None:
        raise ArithmeticError("no active set carries the torque")
    return best[1], best[2]


def solve_position(
    position: float,
    g: np.ndarray,
    pairs: np.ndarray,
    torque: float,
    settings: ContactSettings,
    lag: float = 0.0,
    max_iterations: int = 60,
) -> tuple[float, np.ndarray, np.ndarray, int]:
    """Lag, pair forces and contact kinds at one mesh position.

    Parameters
    ----------
    position : float
        Mesh position as a fraction of the mesh period.
    g : (G,) sample geometry vector (``sample_geometry``).
    pairs : (K,) tooth-pair indices.
    torque : float
        Pinion torque T1 [N m].
    settings : ContactSettings
    lag : float
        Starting value of the pinion lag [rad] (the previous position's).

    Returns
    -------
    lag [rad], force (K,) [N], kind (K,), status (0 converged, 1 not converged,
    2 no pair in contact)
    """
    theta_kin = position * g[PITCH1]
    theta2 = -position * g[PITCH2]
    n = pairs.size
    force = np.zeros(n)
    kinds = np.zeros(n, dtype=np.int8)
    secant = np.zeros(n)
    step = torque / (g[RB1] ** 2 * 1e9)  # a first turn into contact, if nothing touches
    for iteration in range(max_iterations):
        states = [
            _pair_state(int(k), theta_kin, theta2, lag, g, settings.edge_radius) for k in pairs
        ]
        live = [i for i, s in enumerate(states) if s.kind != NO_CONTACT]
        if not live:
            lag += step
            step *= 2.0
            if step > g[PITCH1]:
                return lag, force, kinds, 2
            continue
        sub = [states[i] for i in live]
        matrix = _compliance(sub, pairs[live], settings)
        for a, i in enumerate(live):
            secant[i] = _local_secant(
                force[i] if force[i] > 0 else torque / g[RB1], states[i], settings
            )
            matrix[a, a] += secant[i]
        overlap = np.array([s.overlap for s in sub])
        lever = np.array([s.lever for s in sub])
        new_force, delta_lag = solve_lcp(matrix, overlap, lever, torque, force[live] > 0)
        previous = force.copy()
        force[:] = 0.0
        force[live] = new_force
        lag += delta_lag
        kinds[:] = 0
        for i in live:
            kinds[i] = states[i].kind if force[i] > 0 else 0
        change = np.max(np.abs(force - previous)) * g[RB1] / torque
        if abs(delta_lag) * g[RB1] < 1e-13 and change < 1e-7 and iteration > 0:
            return lag, force, kinds, 0
    return lag, force, kinds, 1
