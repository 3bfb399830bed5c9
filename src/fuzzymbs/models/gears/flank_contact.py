"""Contact between the involute flanks of two pseudo-rigid teeth (compiled kernels).

A tooth is a rigid body hinged at ``H`` (its centreline on the root circle) and
turned by the hinge angle ``beta``. Its drive flank stays an involute of a base
circle of radius r_b, but the circle's centre moves with the tooth. All
involutes of one circle are parallel curves, so the distance of a point from a
flank along the flank normal is exact and cheap: ``r_b`` times the difference
of the involutes' start angles. With that:

* conjugate contact: the common normal is the internal tangent of the two
  (displaced) base circles; penetration ``delta = s1 + s2 - |T1 T2|``;
* corner contact: the tip corner of one tooth against the flank of the other,
  off the line of action (extended contact of loaded teeth).

Manufacturing tolerances (per sample, :func:`sample_geometry`):

* centre-distance deviation: the operating centre distance a_w = a + Delta a
  sets the operating pressure angle cos(alpha_w) = (r_b1 + r_b2) / a_w, the
  path of contact and the reference phases (mesh position 0 is the start of
  contact A at a_w); a pair that jams, interferes or stops meshing is flagged;
* linear tip relief: both gears' flanks are set back along their normal by
  f(s) = C_a (s - s_start) / (s_tip - s_start) for roll lengths s (distance from
  the base tangent point, r_b times the roll angle) above the relief start s_start
  up to the tip s_tip. Conjugate contact subtracts f1(s1) + f2(s2) from the
  penetration (first order in the relief slope C_a / (s_tip - s_start) ~ 1e-3: the
  usual normal-deviation treatment, Velex & Maatar 1996); a tip corner is moved by
  C_a along its own flank normal and the mating flank's relief at the foot point
  is subtracted.

Geometry vector (``pack_geometry``) indices are module constants below. World
frame and sign conventions are those of :mod:`fuzzymbs.models.gears.geometry`.
Contact kinds returned: 0 none, 1 conjugate, 2 pinion tip corner, 3 wheel tip corner.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import GearPair

RB1, RF1, RA1, RFORM1, PSIB1, PSIA1 = 0, 1, 2, 3, 4, 5
RB2, RF2, RA2, RFORM2, PSIB2, PSIA2 = 6, 7, 8, 9, 10, 11
CENTER, PITCH1, PITCH2, THETA_REF1, PHI_REF2, BASE_PITCH = 12, 13, 14, 15, 16, 17
#: zero-backlash centre distance, tip roll lengths sqrt(r_a^2 - r_b^2), relief-start roll
#: lengths, the relief amount C_a (per sample; 0 in ``pack_geometry``), tip half-thicknesses
TIGHT, TIP_ROLL1, TIP_ROLL2, RELIEF_ROLL1, RELIEF_ROLL2, RELIEF = 18, 19, 20, 21, 22, 23
TIP_HALF1, TIP_HALF2 = 24, 25
GEOMETRY_SIZE = 26

NO_CONTACT, CONJUGATE, PINION_TIP, WHEEL_TIP = 0, 1, 2, 3

#: :func:`sample_geometry` status: the sample's pair is valid, or why it is not.
GEOMETRY_OK = 0
JAMMED, NO_TIP_CLEARANCE, NO_MESH, CONTACT_RATIO_BELOW_ONE, INTERFERENCE = 4, 5, 6, 7, 8
RELIEF_TOO_LARGE = 9
GEOMETRY_TEXT = {
    JAMMED: "centre distance below the zero-backlash distance: the teeth jam (backlash < 0)",
    NO_TIP_CLEARANCE: "centre distance too short: a tip reaches the mating root circle",
    NO_MESH: "centre distance too long: the gears do not mesh",
    CONTACT_RATIO_BELOW_ONE: "centre distance too long: contact ratio < 1",
    INTERFERENCE: "centre distance too short: interference (contact below a form circle)",
    RELIEF_TOO_LARGE: "tip relief exceeds half the tip thickness of a tooth",
}


def hpstc_radii(pair: GearPair) -> tuple[float, float]:
    """Radii [m] of the highest points of single tooth contact of pinion and wheel.

    On the line of action (from T1): D = A + p_b on the pinion flank, B = E - p_b on
    the wheel flank. The default relief start ("long relief": the relief spans the
    whole double-contact zone at the tip end of each tooth).
    """
    p, w = pair.pinion, pair.wheel
    s_start, s_end = pair.path_of_contact
    s_d = s_start + pair.base_pitch
    s_b = s_end - pair.base_pitch
    wheel_roll = pair.line_of_action_length - s_b
    return math.hypot(p.base_radius, s_d), math.hypot(w.base_radius, wheel_roll)


def pack_geometry(
    pair: GearPair, relief_start_radii: tuple[float, float] | None = None
) -> np.ndarray:
    """Flatten a gear pair into the float64 vector the kernels read.

    The reference phases put pair 0 at the start of the path of contact (point A)
    when the pinion angle and the wheel angle are both zero; pair k is k base
    pitches further along the line of action.

    Parameters
    ----------
    pair : GearPair
        The nominal pair (its ``center_distance`` is the nominal a).
    relief_start_radii : (float, float), optional
        Radii [m] where the tip relief of the pinion and the wheel starts, each
        between the gear's form and tip radius; default the highest points of single
        tooth contact (:func:`hpstc_radii`). The relief amount is per sample
        (:func:`sample_geometry`); here it is 0.
    """
    p, w = pair.pinion, pair.wheel
    alpha_w = pair.operating_pressure_angle
    length = pair.line_of_action_length
    s_start, _ = pair.path_of_contact
    g = np.zeros(GEOMETRY_SIZE)
    g[RB1], g[RF1], g[RA1], g[RFORM1] = p.base_radius, p.root_radius, p.tip_radius, p.form_radius
    g[PSIB1], g[PSIA1] = p.base_half_angle, float(p.half_angle(p.tip_radius))
    g[RB2], g[RF2], g[RA2], g[RFORM2] = w.base_radius, w.root_radius, w.tip_radius, w.form_radius
    g[PSIB2], g[PSIA2] = w.base_half_angle, float(w.half_angle(w.tip_radius))
    g[CENTER] = pair.center_distance
    g[PITCH1], g[PITCH2] = p.angular_pitch, w.angular_pitch
    g[THETA_REF1] = s_start / p.base_radius - p.base_half_angle - alpha_w
    g[PHI_REF2] = (length - s_start) / w.base_radius - w.base_half_angle + math.pi - alpha_w
    g[BASE_PITCH] = pair.base_pitch
    g[TIGHT] = pair.zero_backlash_center_distance
    g[TIP_ROLL1] = math.sqrt(p.tip_radius**2 - p.base_radius**2)
    g[TIP_ROLL2] = math.sqrt(w.tip_radius**2 - w.base_radius**2)
    starts = hpstc_radii(pair) if relief_start_radii is None else relief_start_radii
    for index, gear, radius, name in (
        (RELIEF_ROLL1, p, starts[0], "pinion"),
        (RELIEF_ROLL2, w, starts[1], "wheel"),
    ):
        radius = float(radius)
        if not gear.form_radius <= radius < gear.tip_radius:
            raise InvalidParameterError(
                f"{name} relief start diameter {2 * radius:.6g} m must lie between the form "
                f"diameter {2 * gear.form_radius:.6g} m and the tip diameter "
                f"{2 * gear.tip_radius:.6g} m"
            )
        g[index] = math.sqrt(radius**2 - gear.base_radius**2)
    g[RELIEF] = 0.0
    g[TIP_HALF1] = p.tip_radius * g[PSIA1]
    g[TIP_HALF2] = w.tip_radius * g[PSIA2]
    return g


@numba.njit(cache=True)
def operating_geometry(g, deviation):
    """Operating geometry at the centre distance a_w = a + ``deviation`` [m].

    Returns
    -------
    (status, a_w, alpha_w, line_length, s_start, contact_ratio, normal_backlash)
        ``status`` :data:`GEOMETRY_OK` or the reason the pair cannot run
        (:data:`GEOMETRY_TEXT`); a_w [m]; operating pressure angle
        alpha_w = arccos((r_b1 + r_b2) / a_w) [rad]; |T1 T2| = a_w sin(alpha_w) [m];
        start of contact A from T1 [m]; transverse contact ratio
        (sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2) - a_w sin(alpha_w)) / p_b;
        normal backlash along the line of action
        j_n = p_b - 2 r_b1 psi_b1 - 2 r_b2 psi_b2 + 2 (r_b1 + r_b2) inv(alpha_w) [m]
        (tooth space of one gear minus tooth thickness of the other, both as base-circle
        arcs; circumferential backlash on the operating pitch circle j_wt = j_n / cos(alpha_w)).
    """
    rb1, rb2 = g[RB1], g[RB2]
    a_w = g[CENTER] + deviation
    alpha_w = math.acos(min((rb1 + rb2) / a_w, 1.0))
    length = math.sqrt(max(a_w * a_w - (rb1 + rb2) ** 2, 0.0))
    s_start = length - g[TIP_ROLL2]
    ratio = (g[TIP_ROLL1] + g[TIP_ROLL2] - length) / g[BASE_PITCH]
    backlash = (
        g[BASE_PITCH]
        - 2.0 * rb1 * g[PSIB1]
        - 2.0 * rb2 * g[PSIB2]
        + 2.0 * (rb1 + rb2) * (math.tan(alpha_w) - alpha_w)
    )
    status = GEOMETRY_OK
    if a_w < g[TIGHT] * (1.0 - 1e-9):
        status = JAMMED
    elif a_w - g[RA1] - g[RF2] <= 0.0 or a_w - g[RA2] - g[RF1] <= 0.0:
        status = NO_TIP_CLEARANCE
    elif a_w >= g[RA1] + g[RA2]:
        status = NO_MESH
    elif ratio < 1.0:
        status = CONTACT_RATIO_BELOW_ONE
    elif s_start < math.sqrt(max(g[RFORM1] ** 2 - rb1 * rb1, 0.0)) - 1e-12 or (
        g[TIP_ROLL1] > length - math.sqrt(max(g[RFORM2] ** 2 - rb2 * rb2, 0.0)) + 1e-12
    ):
        status = INTERFERENCE
    return status, a_w, alpha_w, length, s_start, ratio, backlash


@numba.njit(cache=True)
def operating_geometry_batch(g, deviation):
    """:func:`operating_geometry` of a batch of deviations (B,) [m].

    Returns (status, a_w, alpha_w, contact_ratio, normal_backlash), each (B,).
    """
    n = deviation.shape[0]
    status = np.zeros(n, dtype=np.int64)
    a_w = np.empty(n)
    alpha_w = np.empty(n)
    ratio = np.empty(n)
    backlash = np.empty(n)
    for b in range(n):
        status[b], a_w[b], alpha_w[b], _, _, ratio[b], backlash[b] = operating_geometry(
            g, deviation[b]
        )
    return status, a_w, alpha_w, ratio, backlash


@numba.njit(cache=True)
def sample_geometry(g, deviation, relief, out):
    """Geometry vector of one sample: nominal ``g`` with its tolerances applied.

    Parameters
    ----------
    g : (GEOMETRY_SIZE,) nominal geometry (``pack_geometry``)
    deviation : float
        Centre-distance deviation a_w - a [m].
    relief : float
        Linear tip relief C_a of both gears' teeth [m] (>= 0).
    out : (GEOMETRY_SIZE,) array
        Filled with the sample's geometry (centre distance and reference phases at
        a_w; unchanged from ``g`` when ``deviation`` is 0, so that such a sample
        reproduces the nominal pair bit for bit).

    Returns
    -------
    int
        :data:`GEOMETRY_OK` or the reason the sample's pair cannot run.
    """
    for i in range(g.shape[0]):
        out[i] = g[i]
    out[RELIEF] = relief
    if relief > min(g[TIP_HALF1], g[TIP_HALF2]):
        return RELIEF_TOO_LARGE
    if deviation == 0.0:
        return GEOMETRY_OK
    status, a_w, alpha_w, length, s_start, _, _ = operating_geometry(g, deviation)
    if status != GEOMETRY_OK:
        return status
    out[CENTER] = a_w
    out[THETA_REF1] = s_start / g[RB1] - g[PSIB1] - alpha_w
    out[PHI_REF2] = (length - s_start) / g[RB2] - g[PSIB2] + math.pi - alpha_w
    return GEOMETRY_OK


@numba.njit(cache=True)
def sample_geometries(g, deviation, relief, status):
    """Geometry rows (B, GEOMETRY_SIZE) of a batch, made before a parallel loop over it.

    A row of an array the kernel owns keeps the hot loop as fast as the shared
    nominal vector (an array allocated inside a prange loop and passed down costs
    about 10 % in reference counting). ``deviation``, ``relief`` (B,) [m];
    ``status`` (B,) receives each sample's :func:`sample_geometry` status.
    """
    geometry = np.empty((deviation.shape[0], GEOMETRY_SIZE))
    for b in range(deviation.shape[0]):
        status[b] = sample_geometry(g, deviation[b], relief[b], geometry[b])
    return geometry


@numba.njit(cache=True, inline="always")
def relief_depth(roll_length, start, tip, amount):
    """Linear tip relief [m] at roll length ``roll_length`` (0 below ``start``)."""
    if roll_length <= start:
        return 0.0
    return amount * (roll_length - start) / (tip - start)


@numba.njit(cache=True, inline="always")
def wrap_angle(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    return angle - 2.0 * math.pi * math.floor((angle + math.pi) / (2.0 * math.pi))


@numba.njit(cache=True)
def tooth_pose(centre_x, centre_y, theta, beta, root_radius, base_half, tip_half, tip_radius):
    """Displaced base-circle centre, flank start angle, hinge and tip corner of a tooth.

    ``theta`` is the world angle of the tooth centreline about the gear centre,
    ``beta`` the hinge rotation (counter-clockwise positive).
    """
    hx = centre_x + root_radius * math.cos(theta)
    hy = centre_y + root_radius * math.sin(theta)
    turn = theta + beta
    cx = hx - root_radius * math.cos(turn)
    cy = hy - root_radius * math.sin(turn)
    start = turn + base_half
    tx = cx + tip_radius * math.cos(turn + tip_half)
    ty = cy + tip_radius * math.sin(turn + tip_half)
    return cx, cy, start, hx, hy, tx, ty


@numba.njit(cache=True)
def corner_on_flank(px, py, cx, cy, start, base_radius, form_radius, tip_radius):
    """Penetration of point P into a flank (involute of circle (c, r_b) from ``start``).

    Returns (valid, penetration, normal_x, normal_y, foot_roll_length): the flank's
    outward normal through P; valid when the normal's foot lies on the flank's
    involute part; the foot's roll length r_b u [m].
    """
    dx, dy = px - cx, py - cy
    rho = math.hypot(dx, dy)
    if rho <= base_radius:
        return False, 0.0, 0.0, 0.0, 0.0
    pressure = math.acos(base_radius / rho)
    roll_p = math.tan(pressure)
    start_p = math.atan2(dy, dx) + roll_p - pressure
    gap = wrap_angle(start - start_p)
    roll_foot = roll_p + gap
    if roll_foot < 0.0:
        return False, 0.0, 0.0, 0.0, 0.0
    foot_radius = base_radius * math.sqrt(1.0 + roll_foot * roll_foot)
    if foot_radius < form_radius or foot_radius > tip_radius:
        return False, 0.0, 0.0, 0.0, 0.0
    tangent = start_p - roll_p
    return True, base_radius * gap, -math.sin(tangent), math.cos(tangent), base_radius * roll_foot


@numba.njit(cache=True)
def pair_contact(theta1, beta1, theta2, beta2, g):
    """Contact of one pinion tooth (centreline angle theta1) with one wheel tooth.

    Returns
    -------
    (kind, delta, qx, qy, nx, ny, h1x, h1y, h2x, h2y)
        Contact kind, penetration [m], contact point, unit direction of the force
        on the wheel tooth (the pinion gets the opposite), and both hinge points.
    """
    # two compiled copies: with the literal 0 the relief terms fold away, so unrelieved
    # flanks cost what they did before tip relief existed (the branches cost ~7 %)
    if g[RELIEF] > 0.0:
        return _pair_contact(theta1, beta1, theta2, beta2, g, g[RELIEF])
    return _pair_contact(theta1, beta1, theta2, beta2, g, 0.0)


@numba.njit(cache=True, inline="always")
def _pair_contact(theta1, beta1, theta2, beta2, g, relief):
    """:func:`pair_contact` with linear tip relief C_a = ``relief`` [m] on both gears."""
    c1x, c1y, g1, h1x, h1y, t1x, t1y = tooth_pose(
        0.0, 0.0, theta1, beta1, g[RF1], g[PSIB1], g[PSIA1], g[RA1]
    )
    c2x, c2y, g2, h2x, h2y, t2x, t2y = tooth_pose(
        g[CENTER], 0.0, theta2, beta2, g[RF2], g[PSIB2], g[PSIA2], g[RA2]
    )
    rb1, rb2 = g[RB1], g[RB2]
    # conjugate contact on the internal tangent of the displaced base circles
    dx, dy = c2x - c1x, c2y - c1y
    dist = math.hypot(dx, dy)
    if dist > rb1 + rb2:
        pressure = math.acos((rb1 + rb2) / dist)
        tau = math.atan2(dy, dx) - pressure
        ux, uy = -math.sin(tau), math.cos(tau)
        roll1 = wrap_angle(g1 - tau)
        roll2 = wrap_angle(g2 - tau - math.pi)
        if roll1 >= 0.0 and roll2 >= 0.0:
            s1, s2 = rb1 * roll1, rb2 * roll2
            r1sq, r2sq = rb1 * rb1 + s1 * s1, rb2 * rb2 + s2 * s2
            if g[RFORM1] ** 2 <= r1sq <= g[RA1] ** 2 and g[RFORM2] ** 2 <= r2sq <= g[RA2] ** 2:
                delta = s1 + s2 - dist * math.sin(pressure)
                if relief > 0.0:
                    delta -= relief_depth(s1, g[RELIEF_ROLL1], g[TIP_ROLL1], relief)
                    delta -= relief_depth(s2, g[RELIEF_ROLL2], g[TIP_ROLL2], relief)
                qx = c1x + rb1 * math.cos(tau) + s1 * ux
                qy = c1y + rb1 * math.sin(tau) + s1 * uy
                return CONJUGATE, delta, qx, qy, ux, uy, h1x, h1y, h2x, h2y
    # corner contacts: a tip against the mating flank
    kind = NO_CONTACT
    best = 0.0
    qx = qy = nx = ny = 0.0
    limit = 0.5 * g[BASE_PITCH]
    if relief > 0.0:
        # relieved tip corners: set back by C_a along their own flank's outward normal
        # (-sin t, cos t), t = flank start angle - tip roll angle
        tangent = g1 - g[TIP_ROLL1] / rb1
        t1x += relief * math.sin(tangent)
        t1y -= relief * math.cos(tangent)
        tangent = g2 - g[TIP_ROLL2] / rb2
        t2x += relief * math.sin(tangent)
        t2y -= relief * math.cos(tangent)
    ok, pen, fx, fy, foot = corner_on_flank(t1x, t1y, c2x, c2y, g2, rb2, g[RFORM2], g[RA2])
    if relief > 0.0:
        pen -= relief_depth(foot, g[RELIEF_ROLL2], g[TIP_ROLL2], relief)
    if ok and best < pen < limit:
        kind, best, qx, qy, nx, ny = PINION_TIP, pen, t1x, t1y, -fx, -fy
    ok, pen, fx, fy, foot = corner_on_flank(t2x, t2y, c1x, c1y, g1, rb1, g[RFORM1], g[RA1])
    if relief > 0.0:
        pen -= relief_depth(foot, g[RELIEF_ROLL1], g[TIP_ROLL1], relief)
    if ok and best < pen < limit:
        kind, best, qx, qy, nx, ny = WHEEL_TIP, pen, t2x, t2y, fx, fy
    return kind, best, qx, qy, nx, ny, h1x, h1y, h2x, h2y


@numba.njit(cache=True)
def contact_force(delta, delta_rate, stiffness, exponent, damping, rate_exponent, depth_exponent):
    """Penalty law F = k delta^m1 + c sign(d delta)|d delta|^m2 delta^m3 (>= 0) [N]."""
    if delta <= 0.0:
        return 0.0
    force = stiffness * delta**exponent
    if damping != 0.0 and delta_rate != 0.0:
        rate = abs(delta_rate) ** rate_exponent
        if delta_rate < 0.0:
            rate = -rate
        force += damping * rate * delta**depth_exponent
    return max(force, 0.0)


@numba.njit(cache=True)
def pair_moments(theta1, beta1, theta2, beta2, g, stiffness, exponent):
    """Static loads of one tooth pair under the elastic part of the penalty law.

    Returns
    -------
    (kind, delta, force, m_pinion, m_wheel, m_hinge1, m_hinge2)
        Moments [N m] of the contact force about the pinion centre, the wheel
        centre and both hinges (counter-clockwise positive).
    """
    kind, delta, qx, qy, nx, ny, h1x, h1y, h2x, h2y = pair_contact(theta1, beta1, theta2, beta2, g)
    if kind == NO_CONTACT or delta <= 0.0:
        return kind, delta, 0.0, 0.0, 0.0, 0.0, 0.0
    force = stiffness * delta**exponent
    fx, fy = force * nx, force * ny  # on the wheel tooth; the pinion tooth gets -f
    m_pinion = -(qx * fy - qy * fx)
    m_wheel = (qx - g[CENTER]) * fy - qy * fx
    m_hinge1 = -((qx - h1x) * fy - (qy - h1y) * fx)
    m_hinge2 = (qx - h2x) * fy - (qy - h2y) * fx
    return kind, delta, force, m_pinion, m_wheel, m_hinge1, m_hinge2
