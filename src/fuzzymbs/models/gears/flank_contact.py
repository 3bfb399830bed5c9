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

Geometry vector (``pack_geometry``) indices are module constants below. World
frame and sign conventions are those of :mod:`fuzzymbs.models.gears.geometry`.
Contact kinds returned: 0 none, 1 conjugate, 2 pinion tip corner, 3 wheel tip corner.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fuzzymbs.models.gears.geometry import GearPair

RB1, RF1, RA1, RFORM1, PSIB1, PSIA1 = 0, 1, 2, 3, 4, 5
RB2, RF2, RA2, RFORM2, PSIB2, PSIA2 = 6, 7, 8, 9, 10, 11
CENTER, PITCH1, PITCH2, THETA_REF1, PHI_REF2, BASE_PITCH = 12, 13, 14, 15, 16, 17
GEOMETRY_SIZE = 18

NO_CONTACT, CONJUGATE, PINION_TIP, WHEEL_TIP = 0, 1, 2, 3


def pack_geometry(pair: GearPair) -> np.ndarray:
    """Flatten a gear pair into the float64 vector the kernels read.

    The reference phases put pair 0 at the start of the path of contact (point A)
    when the pinion angle and the wheel angle are both zero; pair k is k base
    pitches further along the line of action.
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
    return g


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

    Returns (valid, penetration, normal_x, normal_y): the flank's outward normal
    through P; valid when the normal's foot lies on the flank's involute part.
    """
    dx, dy = px - cx, py - cy
    rho = math.hypot(dx, dy)
    if rho <= base_radius:
        return False, 0.0, 0.0, 0.0
    pressure = math.acos(base_radius / rho)
    roll_p = math.tan(pressure)
    start_p = math.atan2(dy, dx) + roll_p - pressure
    gap = wrap_angle(start - start_p)
    roll_foot = roll_p + gap
    if roll_foot < 0.0:
        return False, 0.0, 0.0, 0.0
    foot_radius = base_radius * math.sqrt(1.0 + roll_foot * roll_foot)
    if foot_radius < form_radius or foot_radius > tip_radius:
        return False, 0.0, 0.0, 0.0
    tangent = start_p - roll_p
    return True, base_radius * gap, -math.sin(tangent), math.cos(tangent)


@numba.njit(cache=True)
def pair_contact(theta1, beta1, theta2, beta2, g):
    """Contact of one pinion tooth (centreline angle theta1) with one wheel tooth.

    Returns
    -------
    (kind, delta, qx, qy, nx, ny, h1x, h1y, h2x, h2y)
        Contact kind, penetration [m], contact point, unit direction of the force
        on the wheel tooth (the pinion gets the opposite), and both hinge points.
    """
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
                qx = c1x + rb1 * math.cos(tau) + s1 * ux
                qy = c1y + rb1 * math.sin(tau) + s1 * uy
                return CONJUGATE, delta, qx, qy, ux, uy, h1x, h1y, h2x, h2y
    # corner contacts: a tip against the mating flank
    kind = NO_CONTACT
    best = 0.0
    qx = qy = nx = ny = 0.0
    limit = 0.5 * g[BASE_PITCH]
    ok, pen, fx, fy = corner_on_flank(t1x, t1y, c2x, c2y, g2, rb2, g[RFORM2], g[RA2])
    if ok and best < pen < limit:
        kind, best, qx, qy, nx, ny = PINION_TIP, pen, t1x, t1y, -fx, -fy
    ok, pen, fx, fy = corner_on_flank(t2x, t2y, c1x, c1y, g1, rb1, g[RFORM1], g[RA1])
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
