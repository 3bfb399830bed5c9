"""MUBOCO-PR: the pseudo-rigid, contact-based spur-gear pair (quasi-static STE).

Each gear is a rigid foundation on a fixed axis; each tooth a rigid body
hinged where its centreline meets the root circle, with a rotational spring
(tooth stiffness k_t [N m/rad]). The drive flanks of every tooth pair that can
touch are checked for contact (conjugate or tip-corner, see
:mod:`fuzzymbs.models.gears.flank_contact`) and pushed apart by the penalty law
F = k_con delta^m1.

Quasi-static transmission error: the wheel is held at its kinematic angle, the
pinion carries the drive torque T1 and is free; at each mesh position Newton's
method solves the pinion angle and all hinge angles (the contact active set
follows from the penetrations). STE = r_b1 (theta1 - theta1_kinematic) [m],
positive when the pinion leads (the loaded wheel lags), i.e. theta1 r_b1 +
theta2 r_b2 with both angles counter-clockwise.

Manufacturing tolerances act per sample inside the batch kernel: each sample's
geometry vector (centre-distance deviation, tip relief) is made by
:func:`~fuzzymbs.models.gears.flank_contact.sample_geometries` before the sample loop,
so a batch may mix deviations without recompiling; a sample whose pair cannot run
(jammed, interference, contact ratio < 1, ...) gets its status and NaN outputs.

This module holds the compiled quasi-static solver (Numba kernels); the batched
model built on it, :class:`~fuzzymbs.models.gears.model.MubocoPR`, is in
:mod:`fuzzymbs.models.gears.model`, its dynamic mode in
:mod:`fuzzymbs.models.gears.dynamics`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzymbs.models.gears.flank_contact import (
    GEOMETRY_TEXT,
    PHI_REF2,
    PITCH1,
    PITCH2,
    RB1,
    THETA_REF1,
    pair_moments,
    sample_geometries,
)
from fuzzymbs.models.gears.geometry import GearPair

STATUS_OK, STATUS_NOT_CONVERGED, STATUS_NO_CONTACT = 0, 1, 2
STATUS_TEXT = {
    STATUS_NOT_CONVERGED: "Newton iteration did not converge",
    STATUS_NO_CONTACT: "no tooth pair in contact (cannot carry the torque)",
    **GEOMETRY_TEXT,
}


def pair_indices(pair: GearPair, contact_ratio: float | None = None) -> np.ndarray:
    """Tooth pairs that can touch during one mesh period (pair 0 starts at point A).

    Pair k is at s_A + (p + k) p_b on the line of action for mesh position p in
    [0, 1); one extra pair on each side catches extended (corner) contact.
    ``contact_ratio`` (default the pair's) may be larger, for a batch whose
    centre-distance deviations raise it (the largest over the batch); a pair that
    never touches changes no result.
    """
    ratio = pair.contact_ratio if contact_ratio is None else max(contact_ratio, pair.contact_ratio)
    return np.arange(-1, math.floor(ratio) + 2, dtype=np.int64)


@numba.njit(cache=True)
def _residual(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, out):
    """Equilibrium residuals [N m]: out[0] pinion, out[1+2i] / out[2+2i] hinges of pair i.

    Returns the largest penetration (negative when nothing touches).
    """
    out[0] = torque
    deepest = -1.0
    rigid1 = not math.isfinite(kt1)
    rigid2 = not math.isfinite(kt2)
    for i in range(pairs.shape[0]):
        k = pairs[i]
        theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
        phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
        kind, delta, _, m_p, _, m_h1, m_h2 = pair_moments(
            theta, beta1[i], phi, beta2[i], g, k_con, m1
        )
        if kind != 0 and delta > deepest:
            deepest = delta
        out[0] += m_p
        out[1 + 2 * i] = beta1[i] if rigid1 else m_h1 - kt1 * beta1[i]
        out[2 + 2 * i] = beta2[i] if rigid2 else m_h2 - kt2 * beta2[i]
    return deepest


@numba.njit(cache=True)
def _pair_jacobian(lag, theta_kin, theta2, b1, b2, k, g, k_con, m1, kt1, kt2, jac):
    """3x3 forward-difference Jacobian of (pinion moment, hinge1, hinge2) of one pair.

    Columns: d/d lag, d/d beta1, d/d beta2. Rows of a rigid tooth are the identity.
    """
    theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
    phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
    base = pair_moments(theta, b1, phi, b2, g, k_con, m1)
    steps = (1e-6 * abs(lag) + 1e-13, 1e-6 * abs(b1) + 1e-13, 1e-6 * abs(b2) + 1e-13)
    for col in range(3):
        h = steps[col]
        if col == 0:
            pert = pair_moments(theta + h, b1, phi, b2, g, k_con, m1)
        elif col == 1:
            pert = pair_moments(theta, b1 + h, phi, b2, g, k_con, m1)
        else:
            pert = pair_moments(theta, b1, phi, b2 + h, g, k_con, m1)
        jac[0, col] = (pert[3] - base[3]) / h
        jac[1, col] = (pert[5] - base[5]) / h
        jac[2, col] = (pert[6] - base[6]) / h
    jac[1, 1] -= kt1 if math.isfinite(kt1) else 0.0
    jac[2, 2] -= kt2 if math.isfinite(kt2) else 0.0
    if not math.isfinite(kt1):
        jac[1, 0], jac[1, 1], jac[1, 2], jac[0, 1] = 0.0, 1.0, 0.0, 0.0
    if not math.isfinite(kt2):
        jac[2, 0], jac[2, 1], jac[2, 2], jac[0, 2] = 0.0, 0.0, 1.0, 0.0


@numba.njit(cache=True)
def _solve_position(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2):
    """Newton with line search for one mesh position; updates beta1/beta2 in place.

    Returns (lag, status, iterations).
    """
    n_pairs = pairs.shape[0]
    res = np.empty(1 + 2 * n_pairs)
    trial = np.empty(1 + 2 * n_pairs)
    jac = np.empty((3, 3))
    x = np.empty((n_pairs, 2))
    y = np.empty((n_pairs, 2))
    b1_old = np.empty(n_pairs)
    b2_old = np.empty(n_pairs)
    rb1 = g[RB1]
    # residual floor: the penetration s1 + s2 - L cancels lengths ~ a_w, so moments carry
    # round-off ~ 1e-16 a_w k_con r_b; accept stagnation below a looser bound
    tol = 1e-9 * max(abs(torque), 1e-6)
    loose = 1e-6 * max(abs(torque), 1e-6)
    # penetration of one pair carrying the whole load: start/restart guess
    target = (abs(torque) / (rb1 * k_con)) ** (1.0 / m1)
    if lag == 0.0:  # cold start: turn the pinion until the deepest pair carries the load
        deepest = _residual(
            lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, res
        )
        lag = (target - deepest) / rb1
    for iteration in range(80):
        deepest = _residual(
            lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, res
        )
        norm = np.max(np.abs(res))
        if norm < tol:
            return lag, 0, iteration
        # Schur complement of the arrowhead system (pinion angle couples all pairs)
        j00 = 0.0
        r0 = res[0]
        for i in range(n_pairs):
            _pair_jacobian(
                lag, theta_kin, theta2, beta1[i], beta2[i], pairs[i], g, k_con, m1, kt1, kt2, jac
            )
            det = jac[1, 1] * jac[2, 2] - jac[1, 2] * jac[2, 1]
            ra, rb = res[1 + 2 * i], res[2 + 2 * i]
            x[i, 0] = (jac[2, 2] * ra - jac[1, 2] * rb) / det
            x[i, 1] = (-jac[2, 1] * ra + jac[1, 1] * rb) / det
            y[i, 0] = (jac[2, 2] * jac[1, 0] - jac[1, 2] * jac[2, 0]) / det
            y[i, 1] = (-jac[2, 1] * jac[1, 0] + jac[1, 1] * jac[2, 0]) / det
            j00 += jac[0, 0] - jac[0, 1] * y[i, 0] - jac[0, 2] * y[i, 1]
            r0 -= jac[0, 1] * x[i, 0] + jac[0, 2] * x[i, 1]
        if j00 >= 0.0 or deepest <= 0.0:
            # nothing carries load: turn the pinion until the closest pair touches
            if deepest < -0.5 * g[PITCH1] * rb1:
                return lag, 2, iteration
            lag += (target - deepest) / rb1
            continue
        d_lag = -r0 / j00
        for i in range(n_pairs):
            b1_old[i], b2_old[i] = beta1[i], beta2[i]
        scale = 1.0
        for _ in range(12):
            for i in range(n_pairs):
                beta1[i] = b1_old[i] - scale * (x[i, 0] + y[i, 0] * d_lag)
                beta2[i] = b2_old[i] - scale * (x[i, 1] + y[i, 1] * d_lag)
            _residual(
                lag + scale * d_lag,
                theta_kin,
                theta2,
                beta1,
                beta2,
                pairs,
                g,
                torque,
                k_con,
                m1,
                kt1,
                kt2,
                trial,
            )
            if np.max(np.abs(trial)) < norm:
                break
            scale *= 0.5
        else:
            # no descent along the Newton direction: round-off floor reached
            for i in range(n_pairs):
                beta1[i], beta2[i] = b1_old[i], b2_old[i]
            return lag, 0 if norm < loose else 1, iteration
        lag += scale * d_lag
    _residual(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, res)
    if np.max(np.abs(res)) < tol:
        return lag, 0, 80
    return lag, 1, 80


@numba.njit(cache=True)
def _pair_equilibrium(lag, theta_kin, theta2, i, beta1, beta2, pairs, g, k_con, m1, kt1, kt2, tol):
    """Hinge equilibrium of tooth pair i at a fixed pinion lag; returns its pinion moment.

    Starts from unbent teeth: if they do not touch there, they do not touch bent either
    (the load bends both teeth away from each other), so both hinge angles are 0;
    otherwise the solution lies strictly inside contact, where the 2x2 Newton iteration
    (with line search) is smooth. Updates beta1[i], beta2[i].
    """
    k = pairs[i]
    theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
    phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
    rigid1 = not math.isfinite(kt1)
    rigid2 = not math.isfinite(kt2)
    b1 = 0.0
    b2 = 0.0
    jac = np.empty((3, 3))
    kind, delta, _, m_p, _, m_h1, m_h2 = pair_moments(theta, b1, phi, b2, g, k_con, m1)
    if kind != 0 and delta > 0.0 and not (rigid1 and rigid2):
        for _ in range(60):
            r1 = b1 if rigid1 else m_h1 - kt1 * b1
            r2 = b2 if rigid2 else m_h2 - kt2 * b2
            norm = max(abs(r1), abs(r2))
            if norm < tol:
                break
            _pair_jacobian(lag, theta_kin, theta2, b1, b2, k, g, k_con, m1, kt1, kt2, jac)
            det = jac[1, 1] * jac[2, 2] - jac[1, 2] * jac[2, 1]
            d1 = -(jac[2, 2] * r1 - jac[1, 2] * r2) / det
            d2 = -(-jac[2, 1] * r1 + jac[1, 1] * r2) / det
            scale = 1.0
            accepted = False
            for _ in range(30):
                t1, t2 = b1 + scale * d1, b2 + scale * d2
                _, _, _, tm_p, _, tm_h1, tm_h2 = pair_moments(theta, t1, phi, t2, g, k_con, m1)
                q1 = t1 if rigid1 else tm_h1 - kt1 * t1
                q2 = t2 if rigid2 else tm_h2 - kt2 * t2
                if max(abs(q1), abs(q2)) < norm:
                    accepted = True
                    break
                scale *= 0.5
            if not accepted:
                break
            b1, b2, m_p, m_h1, m_h2 = t1, t2, tm_p, tm_h1, tm_h2
    beta1[i] = b1
    beta2[i] = b2
    return m_p


@numba.njit(cache=True)
def _net_moment(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, tol):
    """Pinion torque plus the contact moments with every pair's hinges in equilibrium."""
    total = torque
    for i in range(pairs.shape[0]):
        total += _pair_equilibrium(
            lag, theta_kin, theta2, i, beta1, beta2, pairs, g, k_con, m1, kt1, kt2, tol
        )
    return total


@numba.njit(cache=True)
def _solve_nested(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2):
    """Fallback for a mesh position where Newton stalls: nested solution.

    Newton's line search can stall where the solution sits on a contact kink, e.g. a
    tooth pair that just touches (the entering pair of a tip relief matched to the load
    touches at the start of contact with zero force) or one leaving contact mid-flank.
    Here every pair's hinges are solved for a fixed pinion lag (a smooth 2x2 problem,
    :func:`_pair_equilibrium`) and the lag by bracketing and the Illinois method: the
    net moment falls monotonically as the pinion turns into the wheel. Same tolerance
    as Newton. Returns (lag, status); updates beta1/beta2.
    """
    tol = 1e-9 * max(abs(torque), 1e-6)
    rb1 = g[RB1]
    step = max((abs(torque) / (rb1 * k_con)) ** (1.0 / m1), 1e-9) / rb1
    low = lag
    f_low = _net_moment(low, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1,
                        kt1, kt2, tol)  # fmt: skip
    if abs(f_low) < tol:
        return low, 0
    # bracket the root: net moment > 0 at `low`, < 0 at `high`
    direction = 1.0 if f_low > 0.0 else -1.0
    high, f_high = low, f_low
    for _ in range(60):
        high = low + direction * step
        f_high = _net_moment(high, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con,
                             m1, kt1, kt2, tol)  # fmt: skip
        if (f_high > 0.0) != (f_low > 0.0):
            break
        low, f_low = high, f_high
        step *= 2.0
        if step > 0.5 * g[PITCH1]:
            return lag, 2  # no pair comes into contact
    else:
        return lag, 1
    if f_low < 0.0:
        low, high, f_low, f_high = high, low, f_high, f_low
    # Illinois (regula falsi with halving of a stuck end)
    side = 0
    for _ in range(200):
        trial = (low * f_high - high * f_low) / (f_high - f_low)
        f_trial = _net_moment(trial, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con,
                              m1, kt1, kt2, tol)  # fmt: skip
        if abs(f_trial) < tol or abs(high - low) <= 1e-15 * abs(trial):
            return trial, 0
        if f_trial > 0.0:
            low, f_low = trial, f_trial
            if side == 1:
                f_high *= 0.5
            side = 1
        else:
            high, f_high = trial, f_trial
            if side == -1:
                f_low *= 0.5
            side = -1
    return lag, 1


def solve_static_batch(g, positions, pairs, torque, k_con, m1, kt1, kt2):
    """Quasi-static STE of a batch of nominal samples (no tolerances).

    :func:`solve_static_batch_tolerances` with zero centre-distance deviation and
    zero tip relief (same arguments without those two, same returns).
    """
    zeros = np.zeros(np.shape(torque)[0])
    return solve_static_batch_tolerances(
        g, positions, pairs, torque, k_con, m1, kt1, kt2, zeros, zeros
    )


def solve_static_batch_tolerances(
    g, positions, pairs, torque, k_con, m1, kt1, kt2, center_deviation, tip_relief
):
    """Quasi-static STE of a batch of samples over the mesh positions.

    The arrays go to the compiled kernel as C-contiguous, writable float64 (pairs:
    int64), whatever the caller holds (a column view, a read-only array): the kernel is
    then compiled for one signature only, not once per memory layout (each costs about
    10 s of compilation on the first run).

    Parameters
    ----------
    g : (G,) nominal geometry vector (``pack_geometry``)
    positions : (P,) mesh positions as fractions of the mesh period, increasing
    pairs : (K,) tooth-pair indices
    torque, k_con, kt1, kt2 : (B,) pinion torque [N m], contact stiffness
        [N/m^m1], pinion and wheel tooth stiffness [N m/rad] (inf = rigid)
    m1 : contact exponent
    center_deviation, tip_relief : (B,) centre-distance deviation a_w - a [m] and
        linear tip relief C_a of both gears [m] (``sample_geometry``)

    Returns
    -------
    ste (B, P) [m], wheel_moment (B, P) [N m] (contact moment on the wheel about
    its centre, counter-clockwise), pair_force (B, P, K) [N], pair_kind (B, P, K),
    status (B,) 0 ok / 1 not converged / 2 no contact / a geometry status
    (``GEOMETRY_TEXT``), and the hinge angles (B, K) of both gears' teeth at the
    last position.
    """

    def kernel_array(values, dtype=np.float64):
        array = np.ascontiguousarray(values, dtype=dtype)
        return array if array.flags.writeable else array.copy()

    return _solve_static_batch(
        kernel_array(g),
        kernel_array(positions),
        kernel_array(pairs, np.int64),
        kernel_array(torque),
        kernel_array(k_con),
        float(m1),
        kernel_array(kt1),
        kernel_array(kt2),
        kernel_array(center_deviation),
        kernel_array(tip_relief),
    )


@numba.njit(cache=True, parallel=True)
def _solve_static_batch(
    g, positions, pairs, torque, k_con, m1, kt1, kt2, center_deviation, tip_relief
):
    """:func:`solve_static_batch_tolerances` compiled (arrays as it passes them)."""
    n_samples = torque.shape[0]
    n_pos = positions.shape[0]
    n_pairs = pairs.shape[0]
    ste = np.full((n_samples, n_pos), np.nan)
    wheel_moment = np.full((n_samples, n_pos), np.nan)
    pair_force = np.zeros((n_samples, n_pos, n_pairs))
    pair_kind = np.zeros((n_samples, n_pos, n_pairs), dtype=np.int8)
    status = np.zeros(n_samples, dtype=np.int64)
    last1 = np.zeros((n_samples, n_pairs))
    last2 = np.zeros((n_samples, n_pairs))
    rb1 = g[RB1]
    geometry = sample_geometries(g, center_deviation, tip_relief, status)
    for b in numba.prange(n_samples):
        if status[b] != 0:
            continue
        gb = geometry[b]
        beta1 = np.zeros(n_pairs)
        beta2 = np.zeros(n_pairs)
        lag = 0.0
        for j in range(n_pos):
            theta_kin = positions[j] * gb[PITCH1]
            theta2 = -positions[j] * gb[PITCH2]
            saved_lag = lag
            lag, flag, _ = _solve_position(
                lag, theta_kin, theta2, beta1, beta2, pairs, gb, torque[b], k_con[b], m1,
                kt1[b], kt2[b],
            )  # fmt: skip
            if flag == 1:  # Newton stalled: nested solution from the last converged state
                guess = saved_lag if j > 0 else lag
                lag, flag = _solve_nested(
                    guess, theta_kin, theta2, beta1, beta2, pairs, gb, torque[b], k_con[b],
                    m1, kt1[b], kt2[b],
                )  # fmt: skip
            if flag != 0:
                status[b] = flag
                break
            ste[b, j] = rb1 * lag
            total = 0.0
            for i in range(n_pairs):
                k = pairs[i]
                theta = theta_kin + lag + gb[THETA_REF1] + k * gb[PITCH1]
                phi = theta2 + gb[PHI_REF2] - k * gb[PITCH2]
                kind, _, force, _, m_w, _, _ = pair_moments(
                    theta, beta1[i], phi, beta2[i], gb, k_con[b], m1
                )
                pair_force[b, j, i] = force
                pair_kind[b, j, i] = kind
                total += m_w
            wheel_moment[b, j] = total
        for i in range(n_pairs):  # element by element: no slice-assignment code to compile
            last1[b, i] = beta1[i]
            last2[b, i] = beta2[i]
        if status[b] != 0:
            for j in range(n_pos):
                ste[b, j] = np.nan
                wheel_moment[b, j] = np.nan
    return ste, wheel_moment, pair_force, pair_kind, status, last1, last2
