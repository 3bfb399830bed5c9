"""ISO 6336-1 (method B) tooth stiffness: single stiffness c' and mesh stiffness c_gamma_alpha.

ISO 6336-1:2019, clause 9 (tooth stiffness parameters):

    q' = C1 + C2/z_n1 + C3/z_n2 + C4 x1 + C5 x1/z_n1 + C6 x2 + C7 x2/z_n2 + C8 x1^2 + C9 x2^2
    c'_th = 1/q'                                                   [N/(mm um)]
    c' = c'_th C_M C_R C_B cos(beta) [(F_t K_A / b) / 100]^0.25 if F_t K_A / b < 100 N/mm
    C_B = [1 + 0.5 (1.2 - h_fP/m_n)] [1 - 0.02 (20 deg - alpha_Pn)]
    c_gamma_alpha = c' (0.75 eps_alpha + 0.25)

with virtual tooth numbers z_n = z / (cos^2(beta_b) cos(beta)). Units follow
the standard: c', c_gamma_alpha in N/(mm um) (= 1e9 N/m per metre of face).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import GearPair

ISO_COEFFICIENTS = (
    0.04723,
    0.15551,
    0.25791,
    -0.00635,
    -0.11654,
    -0.00193,
    -0.24188,
    0.00529,
    0.00182,
)
#: C_M: correction from the theoretical to measured stiffness of solid gears.
THEORY_CORRECTION = 0.8


@dataclass(frozen=True)
class IsoStiffness:
    """ISO 6336-1 method B stiffness values [N/(mm um)]."""

    single_theoretical: float  # c'_th
    single: float  # c'
    mesh: float  # c_gamma_alpha
    basic_rack_factor: float  # C_B
    load_factor: float  # [(F_t K_A/b)/100]^0.25 or 1


def iso_tooth_stiffness(
    teeth: tuple[int, int],
    profile_shift: tuple[float, float],
    transverse_contact_ratio: float,
    helix_angle: float = 0.0,
    normal_pressure_angle: float = math.radians(20.0),
    dedendum_coefficient: float = 1.25,
    rim_factor: float = 1.0,
    line_load: float | None = None,
) -> IsoStiffness:
    """ISO 6336-1 method B single and mesh stiffness.

    Parameters
    ----------
    teeth : (z1, z2)
        Tooth numbers (external gears).
    profile_shift : (x1, x2)
        Profile shift coefficients.
    transverse_contact_ratio : float
        eps_alpha.
    helix_angle : float
        beta [rad].
    normal_pressure_angle : float
        alpha_Pn of the basic rack [rad].
    dedendum_coefficient : float
        h_fP / m_n of the basic rack.
    rim_factor : float
        C_R (1 for solid gears).
    line_load : float, optional
        F_t K_A / b [N/mm]; below 100 N/mm the stiffness is reduced.
    """
    z1, z2 = teeth
    if min(z1, z2) < 5:
        raise InvalidParameterError(f"teeth must be >= 5, got {teeth!r}")
    if not transverse_contact_ratio >= 1.0:
        raise InvalidParameterError(
            f"transverse_contact_ratio must be >= 1, got {transverse_contact_ratio!r}"
        )
    x1, x2 = profile_shift
    beta = helix_angle
    transverse = math.atan(math.tan(normal_pressure_angle) / math.cos(beta))
    beta_b = math.atan(math.tan(beta) * math.cos(transverse))
    factor = math.cos(beta_b) ** 2 * math.cos(beta)
    zn1, zn2 = z1 / factor, z2 / factor
    c = ISO_COEFFICIENTS
    q = (
        c[0]
        + c[1] / zn1
        + c[2] / zn2
        + c[3] * x1
        + c[4] * x1 / zn1
        + c[5] * x2
        + c[6] * x2 / zn2
        + c[7] * x1**2
        + c[8] * x2**2
    )
    single_th = 1.0 / q
    basic_rack = (1.0 + 0.5 * (1.2 - dedendum_coefficient)) * (
        1.0 - 0.02 * (20.0 - math.degrees(normal_pressure_angle))
    )
    load = 1.0
    if line_load is not None:
        if not line_load > 0.0:
            raise InvalidParameterError(f"line_load must be positive, got {line_load!r}")
        load = min(1.0, (line_load / 100.0) ** 0.25)
    single = single_th * THEORY_CORRECTION * rim_factor * basic_rack * math.cos(beta) * load
    mesh = single * (0.75 * transverse_contact_ratio + 0.25)
    return IsoStiffness(single_th, single, mesh, basic_rack, load)


def iso_pair_stiffness(pair: GearPair, torque: float) -> IsoStiffness:
    """ISO stiffness of a spur pair at pinion torque T1 [N m] (F_t at the reference circle)."""
    p, w = pair.pinion, pair.wheel
    width_mm = min(p.face_width, w.face_width) * 1e3
    tangential = torque / p.pitch_radius
    return iso_tooth_stiffness(
        (p.teeth, w.teeth),
        (p.profile_shift, w.profile_shift),
        pair.contact_ratio,
        normal_pressure_angle=p.pressure_angle,
        dedendum_coefficient=p.dedendum,
        line_load=tangential / width_mm,
    )


def iso_mean_ste(pair: GearPair, torque: float) -> float:
    """Mean STE estimate [m]: F / (c_gamma_alpha b), F = T1 / r_b1 along the line of action."""
    stiffness = iso_pair_stiffness(pair, torque)
    width_mm = min(pair.pinion.face_width, pair.wheel.face_width) * 1e3
    mesh_n_per_m = stiffness.mesh * width_mm * 1e6  # N/(mm um) * mm -> N/um -> N/m
    return torque / pair.pinion.base_radius / mesh_n_per_m
