"""Modal values of the MUBOCO-PR stiffnesses, defined analytically.

* Contact stiffness k_con: the penalty law F = k_con delta^m1 fitted (least
  squares) to the Weber-Banaschek line-contact approach at the loads the tooth
  pairs carry over one mesh period at the design torque.
* Tooth stiffness k_t: the pseudo-rigid tooth adds d^2/k_t along the line of
  action (d the hinge lever arm); 1/k_t is fitted by least squares so that
  d(s)^2/k_t matches the potential-energy tooth compliance
  (:mod:`fuzzymbs.models.gears.potential_energy`) over the path of contact.

Weber-Banaschek (Weber & Banaschek, Formänderung und Profilrücknahme bei
gerad- und schrägverzahnten Rädern, 1953), approach of two elastic bodies in
line contact, each measured to a depth h_i (here the distance from the contact
point along the normal to the tooth centreline):

    delta = 2 F / (pi b) sum_i (1 - nu_i^2)/E_i [ln(2 h_i / a) - nu_i / (2 (1 - nu_i))]

with the Hertz half-width a = sqrt(4 F R / (pi b E*)), 1/R = 1/rho_1 + 1/rho_2
(radii of curvature at the contact = roll lengths), 1/E* = sum (1 - nu_i^2)/E_i.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import GearPair, SpurGear
from fuzzymbs.models.gears.potential_energy import contact_point, pair_tooth_compliance


def hinge_lever_arm(gear: SpurGear, roll_length: np.ndarray) -> np.ndarray:
    """Lever arm d [m] of the tooth hinge about the line of action (THEORY.md section 2).

    d = r_b - r_f cos(alpha_1), alpha_1 = tan(alpha_p) - alpha_2,
    alpha_2 = pi/(2z) + 2 x tan(alpha)/z + inv(alpha)  (the base half-angle psi_b).

    THEORY.md's alpha_2 omits the profile-shift term 2 x tan(alpha)/z; it is needed
    for x != 0 (checked against the moment arm computed from the contact geometry,
    tests/models/test_gear_identification.py). tan(alpha_p) = s_g / r_b is the roll
    angle of the contact point.
    """
    alpha_1 = np.asarray(roll_length, dtype=float) / gear.base_radius - gear.base_half_angle
    return gear.base_radius - gear.root_radius * np.cos(alpha_1)


def weber_banaschek_approach(
    force: np.ndarray,
    face_width: float,
    curvature_radii: tuple[np.ndarray, np.ndarray],
    depths: tuple[np.ndarray, np.ndarray],
    youngs_moduli: tuple[float, float],
    poisson_ratios: tuple[float, float],
) -> np.ndarray:
    """Approach delta [m] of two bodies in line contact under the normal force [N]."""
    force = np.asarray(force, dtype=float)
    rho1, rho2 = (np.asarray(r, dtype=float) for r in curvature_radii)
    radius = rho1 * rho2 / (rho1 + rho2)
    compliance = [(1.0 - nu**2) / e for e, nu in zip(youngs_moduli, poisson_ratios, strict=True)]
    e_star = 1.0 / sum(compliance)
    half_width = np.sqrt(4.0 * force * radius / (math.pi * face_width * e_star))
    total = 0.0
    for c, nu, h in zip(compliance, poisson_ratios, depths, strict=True):
        total = total + c * (np.log(2.0 * np.asarray(h) / half_width) - nu / (2.0 * (1.0 - nu)))
    return 2.0 * force / (math.pi * face_width) * total


@dataclass(frozen=True)
class IdentifiedStiffness:
    """Identified modal values and the data of the fit.

    Attributes
    ----------
    contact_stiffness : float
        k_con [N/m^m1].
    tooth_stiffness : float
        Common k_t fitted to the sum of both teeth [N m/rad].
    pinion_tooth_stiffness, wheel_tooth_stiffness : float
        k_t fitted to each gear's teeth separately [N m/rad].
    s : ndarray
        Line-of-action samples of the path of contact [m] (from T1).
    pe_pinion, pe_wheel : ndarray
        Potential-energy tooth compliances at s [m/N].
    lever_pinion, lever_wheel : ndarray
        Hinge lever arms at s [m].
    fit_error : float
        RMS of (fitted - PE) / mean PE of the pair's tooth compliance (common k_t).
    contact_loads, contact_approach : ndarray
        Pair loads [N] and Weber-Banaschek approaches [m] used for k_con.
    """

    contact_stiffness: float
    tooth_stiffness: float
    pinion_tooth_stiffness: float
    wheel_tooth_stiffness: float
    s: np.ndarray
    pe_pinion: np.ndarray
    pe_wheel: np.ndarray
    lever_pinion: np.ndarray
    lever_wheel: np.ndarray
    fit_error: float
    contact_loads: np.ndarray
    contact_approach: np.ndarray


def contact_depth(gear: SpurGear, roll_length: np.ndarray) -> np.ndarray:
    """Distance from the contact point along the flank normal to the tooth centreline [m]."""
    _, h_c, alpha_1 = contact_point(gear, roll_length)
    return h_c / np.cos(alpha_1)


def identify(
    pair: GearPair, torque: float, contact_exponent: float = 1.0, samples: int = 121
) -> IdentifiedStiffness:
    """Identify k_con and k_t of the MUBOCO-PR pair at the design pinion torque [N m].

    The pair loads for the contact fit come from the load sharing of the
    potential-energy mesh (stiffness-proportional in double contact).
    """
    if not (math.isfinite(torque) and torque > 0.0):
        raise InvalidParameterError(f"torque must be positive, got {torque!r}")
    p, w = pair.pinion, pair.wheel
    length = pair.line_of_action_length
    s_start, s_end = pair.path_of_contact
    s = np.linspace(s_start, s_end, samples)
    pe_pinion, pe_wheel = pair_tooth_compliance(pair, s)
    d1 = hinge_lever_arm(p, s)
    d2 = hinge_lever_arm(w, length - s)
    # least squares in the compliances 1/k_t (linear in the unknown)
    pinion_kt = float(np.sum(d1**4) / np.sum(d1**2 * pe_pinion))
    wheel_kt = float(np.sum(d2**4) / np.sum(d2**2 * pe_wheel))
    lever_sq = d1**2 + d2**2
    common_kt = float(np.sum(lever_sq**2) / np.sum(lever_sq * (pe_pinion + pe_wheel)))
    target = pe_pinion + pe_wheel
    fit_error = float(np.sqrt(np.mean((lever_sq / common_kt - target) ** 2)) / np.mean(target))

    # pair loads over one mesh period, sharing by the PE pair stiffness (first guess
    # of the contact part: Weber-Banaschek at the full load)
    force_total = torque / p.base_radius
    positions = np.linspace(0.0, 1.0, 60, endpoint=False)
    from fuzzymbs.models.gears.potential_energy import contact_positions

    s_pairs = contact_positions(pair, positions)
    active = np.isfinite(s_pairs)
    s_act = np.where(active, s_pairs, s_start)

    def approach(load: np.ndarray, at: np.ndarray) -> np.ndarray:
        return weber_banaschek_approach(
            load,
            p.face_width if p.face_width <= w.face_width else w.face_width,
            (at, length - at),
            (contact_depth(p, at), contact_depth(w, length - at)),
            (p.youngs_modulus, w.youngs_modulus),
            (p.poisson_ratio, w.poisson_ratio),
        )

    tooth_1, tooth_2 = pair_tooth_compliance(pair, s_act)
    contact_c = approach(np.full(s_act.shape, force_total), s_act) / force_total
    for _ in range(3):  # fixed point: the share depends (weakly) on the contact compliance
        stiffness = np.where(active, 1.0 / (tooth_1 + tooth_2 + contact_c), 0.0)
        loads = force_total * stiffness / stiffness.sum(axis=1, keepdims=True)
        safe = np.where(active, loads, force_total)
        contact_c = approach(safe, s_act) / safe
    loads_used = loads[active]
    approach_used = approach(loads_used, s_act[active])
    m1 = contact_exponent
    contact_stiffness = float(
        np.sum(loads_used * approach_used**m1) / np.sum(approach_used ** (2 * m1))
    )
    return IdentifiedStiffness(
        contact_stiffness=contact_stiffness,
        tooth_stiffness=common_kt,
        pinion_tooth_stiffness=pinion_kt,
        wheel_tooth_stiffness=wheel_kt,
        s=s,
        pe_pinion=pe_pinion,
        pe_wheel=pe_wheel,
        lever_pinion=d1,
        lever_wheel=d2,
        fit_error=fit_error,
        contact_loads=loads_used,
        contact_approach=approach_used,
    )
