"""Gear geometry: cutter-generated fillet vs analytic involute, contact ratio, errors."""

import math

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import GearPair, SpurGear, involute

M = 4.5e-3
B = 20e-3


def test_fillet_meets_the_analytic_involute():
    # The fillet is generated from the rack cutter (envelope of the tip rounding);
    # its end point must lie on the involute psi(r) of THEORY.md (independent formula).
    for teeth, shift in ((20, 0.0), (40, 0.0), (18, 0.0), (14, 0.3), (25, -0.2)):
        gear = SpurGear(teeth, M, B, profile_shift=shift)
        end = gear.fillet(2)[-1]
        assert math.atan2(end[1], end[0]) == pytest.approx(
            gear.half_angle(np.hypot(*end)), abs=1e-12
        )
        # the form circle (start of the involute) is outside the base circle (no undercut)
        assert gear.form_radius >= gear.base_radius * (1 - 1e-12)
        # the fillet starts on the root circle
        assert np.hypot(*gear.fillet(3)[0]) == pytest.approx(gear.root_radius, rel=1e-12)


def test_straight_rack_flank_generates_the_involute():
    # Independent generation: a point of the straight rack flank at height h above the
    # rolling line touches the gear where the flank normal passes the pitch point; rolling
    # back to the gear frame must give a point on psi(r).
    gear = SpurGear(20, M, B, profile_shift=0.25)
    rp, alpha = gear.pitch_radius, gear.pressure_angle
    half_space = math.pi * M / 4 + 0.25 * M * math.tan(alpha)
    for depth in np.linspace(-0.8, 0.6, 7) * M:  # rack point at x = rp - depth
        # contact point on the line of action through (rp, 0) in direction (-sin a, -cos a)
        length = depth / math.sin(alpha)
        px, py = rp - length * math.sin(alpha), -length * math.cos(alpha)
        # the flank line at that x: y = half_space + (rp - x) tan a + r_p phi
        phi = (py - half_space - (rp - px) * math.tan(alpha)) / rp
        gx = math.cos(phi) * px + math.sin(phi) * py
        gy = -math.sin(phi) * px + math.cos(phi) * py
        radius = math.hypot(gx, gy)
        assert math.atan2(gy, gx) == pytest.approx(gear.half_angle(radius), abs=1e-12)


def test_contact_ratio_against_roll_angle_formula():
    # eps = [z1 (tan a_a1 - tan a_w) + z2 (tan a_a2 - tan a_w)] / (2 pi)  (textbook form)
    for z1, z2 in ((20, 40), (18, 60), (30, 30)):
        pair = GearPair(SpurGear(z1, M, B), SpurGear(z2, M, B))
        aw = pair.operating_pressure_angle
        tan_a1 = math.tan(math.acos(pair.pinion.base_radius / pair.pinion.tip_radius))
        tan_a2 = math.tan(math.acos(pair.wheel.base_radius / pair.wheel.tip_radius))
        expected = (z1 * (tan_a1 - math.tan(aw)) + z2 * (tan_a2 - math.tan(aw))) / (2 * math.pi)
        assert pair.contact_ratio == pytest.approx(expected, rel=1e-12)
    pair = GearPair(SpurGear(20, M, B), SpurGear(40, M, B))
    assert pair.center_distance == pytest.approx(M * 60 / 2, rel=1e-14)
    assert pair.operating_pressure_angle == pytest.approx(math.radians(20), rel=1e-14)
    assert pair.mesh_period(100.0) == pytest.approx(2 * math.pi / 20 / 100.0)
    # single-contact zone B-D has length (2 - eps) p_b
    s_b, s_d = pair.single_contact_zone()
    assert s_d - s_b == pytest.approx((2 - pair.contact_ratio) * pair.base_pitch, rel=1e-12)


def test_zero_backlash_center_distance_with_profile_shift():
    # At the zero-backlash distance the two tooth thicknesses on the operating pitch
    # circles fill the circular pitch there (independent of the inv(alpha_w) formula).
    pair = GearPair(SpurGear(18, M, B, profile_shift=0.3), SpurGear(41, M, B, profile_shift=0.2))
    aw = pair.operating_pressure_angle
    rw1 = pair.pinion.base_radius / math.cos(aw)
    rw2 = pair.wheel.base_radius / math.cos(aw)
    thick1 = 2 * rw1 * pair.pinion.half_angle(rw1)
    thick2 = 2 * rw2 * pair.wheel.half_angle(rw2)
    assert thick1 + thick2 == pytest.approx(2 * math.pi * rw1 / 18, rel=1e-10)


def test_tooth_area_matches_integrated_half_thickness():
    gear = SpurGear(20, M, B)
    mass, inertia = gear.tooth_mass_properties
    x0 = gear.fillet(2)[0][0]
    x = np.linspace(x0, gear.tip_radius * math.cos(gear.half_angle(gear.tip_radius)), 4001)
    area = np.trapezoid(2 * gear.half_thickness(x, points=4000), x)
    assert mass == pytest.approx(gear.density * B * area, rel=2e-3)
    # inertia about the hinge lies between a slender rod and a point mass at the centroid
    height = x[-1] - x0
    assert mass * (height / 2) ** 2 * 0.5 < inertia < mass * height**2


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"teeth": 4}, "teeth must be >= 5"),
        ({"teeth": 14}, "undercut"),
        ({"face_width": -1e-3}, "face_width"),
        ({"module": 0.0}, "module"),
        ({"poisson_ratio": 0.6}, "poisson_ratio"),
        (
            {"profile_shift": 1.2, "addendum": 1.2, "dedendum": 1.45, "tip_radius_factor": 0.2},
            "pointed",
        ),
        ({"tip_radius_factor": 0.9}, "tip_radius_factor"),
    ],
)
def test_invalid_gears_are_rejected(kwargs, match):
    base = {"teeth": 20, "module": M, "face_width": B}
    with pytest.raises(InvalidParameterError, match=match):
        SpurGear(**{**base, **kwargs})


def test_invalid_pairs_are_rejected():
    pinion, wheel = SpurGear(20, M, B), SpurGear(40, M, B)
    with pytest.raises(InvalidParameterError, match="jam"):
        GearPair(pinion, wheel, center_distance=0.134)
    with pytest.raises(InvalidParameterError, match="contact ratio"):
        GearPair(pinion, wheel, center_distance=0.139)
    with pytest.raises(InvalidParameterError, match="module"):
        GearPair(pinion, SpurGear(40, 5e-3, B))
    # large positive shifts at the zero-backlash distance eat the tip clearance
    with pytest.raises(InvalidParameterError, match="tip clearance"):
        GearPair(SpurGear(40, M, B, profile_shift=1.0), SpurGear(40, M, B, profile_shift=1.0))
    # a long wheel addendum reaches below the pinion's form circle (start of its involute)
    with pytest.raises(InvalidParameterError, match="interference"):
        GearPair(
            SpurGear(18, M, B),
            SpurGear(40, M, B, addendum=1.2, dedendum=1.45, tip_radius_factor=0.2),
        )


def test_involute_function():
    assert involute(math.radians(20)) == pytest.approx(0.014904383867336446, rel=1e-14)
