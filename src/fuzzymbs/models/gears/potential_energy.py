"""Potential-energy tooth model and the time-varying mesh stiffness (the reference).

The tooth is a non-uniform cantilever along its centreline, from the point
where the fillet meets the root circle to the contact point, with the real
generated profile (trochoidal fillet + involute, :class:`SpurGear.half_thickness`).
The normal contact force F, at angle alpha_1 to the tooth's transverse
direction, bends, shears and compresses it (Yang & Lin 1987; Tian 2004;
Chaari et al. 2009):

    1/k_b = int [cos(a1)(x_c - x) - sin(a1) h_c]^2 / (E I_x) dx,  I_x = (2 h_x)^3 b / 12
    1/k_s = int 1.2 cos^2(a1) / (G A_x) dx,                      A_x = 2 h_x b
    1/k_a = int sin^2(a1) / (E A_x) dx

and the body under the tooth yields (fillet-foundation term of Sainsot,
Velex & Duverger, J. Mech. Des. 126 (2004) 748):

    1/k_f = cos^2(a1)/(E b) [L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q* tan^2 a1)]

with u_f the distance from the root circle to where the force line crosses the
centreline, S_f = 2 r_f theta_f the root thickness, and L*, M*, P*, Q*
polynomials in h_fi = r_f / r_int and theta_f (Sainsot's table).

Compliances are along the line of action [m/N]. Plane stress (E), as in Tian.
The mesh: a pair's compliance is 1/k_con + the four terms of both teeth;
pairs in contact act in parallel (rigid-kinematics contact zones, no extended
contact); STE = F / k_mesh with F = T1 / r_b1.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzymbs.models.gears.geometry import GearPair, SpurGear

# Sainsot et al. (2004), Table 1: X* = A/theta_f^2 + B h^2 + C h/theta_f + D/theta_f + E h + F
_SAINSOT = {
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}

SHEAR_FACTOR = 1.2  # rectangular section


def sainsot_coefficients(root_half_angle: float, rim_ratio: float) -> dict[str, float]:
    """L*, M*, P*, Q* of the fillet-foundation formula for theta_f [rad], h_fi = r_f/r_int."""
    t, h = root_half_angle, rim_ratio
    return {
        name: a / t**2 + b * h**2 + c * h / t + d / t + e * h + f
        for name, (a, b, c, d, e, f) in _SAINSOT.items()
    }


def contact_point(gear: SpurGear, roll_length: np.ndarray) -> tuple[np.ndarray, ...]:
    """Tooth-local contact point and load angle for contact at roll length s_g.

    Parameters
    ----------
    roll_length : array
        Distance s_g of the contact point from this gear's base-circle tangent
        point along the line of action [m] (s for the pinion, L - s for the wheel).

    Returns
    -------
    x_c, h_c, alpha_1 : arrays
        Distance along the centreline from the gear centre [m], half thickness
        (distance from the centreline) [m], and the angle alpha_1 between the
        force and the tooth's transverse direction [rad] (alpha_1 > 0: the force
        also compresses the tooth).
    """
    s = np.asarray(roll_length, dtype=float)
    radius = np.hypot(gear.base_radius, s)
    psi = gear.half_angle(radius)
    alpha_1 = s / gear.base_radius - gear.base_half_angle
    return radius * np.cos(psi), radius * np.sin(psi), alpha_1


def tooth_compliance(
    gear: SpurGear, roll_length: np.ndarray, points: int = 600
) -> dict[str, np.ndarray]:
    """Bending, shear, axial and fillet-foundation compliance of one tooth [m/N].

    Parameters
    ----------
    gear : SpurGear
    roll_length : array
        Contact positions as roll lengths s_g [m] (see :func:`contact_point`).
    points : int
        Integration points along the centreline (trapezoidal rule).

    Returns
    -------
    dict with "bending", "shear", "axial", "foundation" and "total", each shaped
    like ``roll_length``.
    """
    shape = np.shape(roll_length)
    x_c, h_c, alpha_1 = contact_point(gear, np.ravel(roll_length))
    e_mod, g_mod, width = gear.youngs_modulus, gear.shear_modulus, gear.face_width
    x_root = gear.root_radius * math.cos(gear.root_half_angle)
    # integrate each contact position from the fillet root to its contact point
    fraction = np.linspace(0.0, 1.0, points)
    x = x_root + np.outer(x_c - x_root, fraction)  # (S, N)
    h = gear.half_thickness(x.ravel()).reshape(x.shape)
    area = 2.0 * h * width
    inertia = (2.0 * h) ** 3 * width / 12.0
    cos_a, sin_a = np.cos(alpha_1)[:, None], np.sin(alpha_1)[:, None]
    arm = cos_a * (x_c[:, None] - x) - sin_a * h_c[:, None]
    bending = np.trapezoid(arm**2 / (e_mod * inertia), x, axis=1)
    shear = np.trapezoid(SHEAR_FACTOR * cos_a**2 / (g_mod * area), x, axis=1)
    axial = np.trapezoid(sin_a**2 / (e_mod * area), x, axis=1)
    coeff = sainsot_coefficients(gear.root_half_angle, gear.root_radius / gear.rim_radius)
    u_f = x_c - h_c * np.tan(alpha_1) - gear.root_radius
    s_f = 2.0 * gear.root_radius * gear.root_half_angle
    ratio = u_f / s_f
    foundation = (
        np.cos(alpha_1) ** 2
        / (e_mod * width)
        * (
            coeff["L"] * ratio**2
            + coeff["M"] * ratio
            + coeff["P"] * (1.0 + coeff["Q"] * np.tan(alpha_1) ** 2)
        )
    )
    parts = {"bending": bending, "shear": shear, "axial": axial, "foundation": foundation}
    parts["total"] = bending + shear + axial + foundation
    return {name: value.reshape(shape) for name, value in parts.items()}


def pair_tooth_compliance(pair: GearPair, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tooth compliance of pinion and wheel [m/N] for contact at s (from T1) [m]."""
    s = np.asarray(s, dtype=float)
    pinion = tooth_compliance(pair.pinion, s)["total"]
    wheel = tooth_compliance(pair.wheel, pair.line_of_action_length - s)["total"]
    return pinion, wheel


def contact_positions(pair: GearPair, positions: np.ndarray) -> np.ndarray:
    """Line-of-action coordinate s [m] of the pairs k = 0, 1, ... at each mesh position.

    Returns (P, K) with NaN where pair k is not in (rigid, kinematic) contact.
    """
    s_start, s_end = pair.path_of_contact
    pairs = np.arange(0, math.ceil(pair.contact_ratio) + 1)
    s = s_start + (np.asarray(positions, dtype=float)[:, None] + pairs[None, :]) * pair.base_pitch
    return np.where(s <= s_end + 1e-15, s, np.nan)


def mesh_stiffness(
    pair: GearPair, positions: np.ndarray, contact_stiffness: float
) -> dict[str, np.ndarray]:
    """Time-varying mesh stiffness of the potential-energy model over mesh positions.

    Parameters
    ----------
    positions : (P,) fractions of the mesh period (0 = pair 0 enters at A)
    contact_stiffness : float
        Linear contact stiffness k_con [N/m] in series with the teeth.

    Returns
    -------
    dict: "mesh_stiffness" (P,) [N/m], "pair_stiffness" (P, K) [N/m] (0 when out
    of contact), "s" (P, K) [m].
    """
    s = contact_positions(pair, positions)
    active = np.isfinite(s)
    pinion, wheel = pair_tooth_compliance(pair, np.where(active, s, pair.path_of_contact[0]))
    compliance = 1.0 / contact_stiffness + pinion + wheel
    pair_stiffness = np.where(active, 1.0 / compliance, 0.0)
    return {"mesh_stiffness": pair_stiffness.sum(axis=1), "pair_stiffness": pair_stiffness, "s": s}


def reference_ste(
    pair: GearPair, torque: float, positions: np.ndarray, contact_stiffness: float
) -> np.ndarray:
    """Potential-energy STE [m] over mesh positions: F / k_mesh with F = T1 / r_b1."""
    mesh = mesh_stiffness(pair, positions, contact_stiffness)["mesh_stiffness"]
    return torque / pair.pinion.base_radius / mesh
