"""Manufacturing tolerances of the MUBOCO-PR gear pair: centre-distance deviation and tip relief.

References (THEORY.md section 2b; ISO 21771 involute geometry):

* operating pressure angle cos(alpha_w) = (r_b1 + r_b2) / a_w; operating pitch radius of
  the pinion r_w1 = a_w z1 / (z1 + z2) (the pitch point divides a_w in the gear ratio);
* transverse contact ratio eps = (sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2)
  - a_w sin(alpha_w)) / p_b;
* normal backlash j_n = 2 (r_b1 + r_b2) (inv(alpha_w) - inv(alpha_w0)) (alpha_w0 at the
  zero-backlash centre distance a_0), circumferential backlash on the operating pitch
  circle j_wt = j_n / cos(alpha_w) ~ 2 (a_w - a_0) tan(alpha_w);
* linear tip relief (Harris 1958; Munro; Smith, *Gear Noise and Vibration*): unloaded, the
  transmission error of relieved gears is the relief of the pair that touches first; at
  the design load a long relief equal to the single-pair deflection flattens the STE, so
  the peak-to-peak STE over load (Harris map) has its minimum there; without relief it
  grows in proportion to the load.
"""

import math

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears import MubocoPR, gear_pair_dynamic_model, make_pair
from fuzzymbs.models.gears.features import contact_zones
from fuzzymbs.models.gears.flank_contact import (
    BASE_PITCH,
    CENTER,
    GEOMETRY_SIZE,
    PHI_REF2,
    PITCH1,
    PITCH2,
    THETA_REF1,
    pair_contact,
    sample_geometry,
)
from fuzzymbs.models.gears.geometry import involute
from fuzzymbs.models.gears.muboco import _solve_nested
from fuzzymbs.study.registry import get_model

UM = 1e-6
MM = 1e-3
TOLERANCES = ("center_distance_deviation", "tip_relief")


@pytest.fixture(scope="module")
def pair():
    return make_pair()  # z 20/40, m 4.5 mm, b 20 mm, x = 0: a = a_0 = 135 mm, eps 1.635


@pytest.fixture(scope="module")
def backlash_pair():
    # shifted teeth at a centre distance above their zero-backlash one (135.879 mm)
    return make_pair(pinion_profile_shift=0.3, wheel_profile_shift=-0.1, center_distance=136.1e-3)


@pytest.fixture(scope="module")
def model(pair):
    return MubocoPR(pair, torque=100.0, positions=60, reference=False)


def rigid_light(n, positions_model, **columns):
    """Rigid teeth, a very stiff contact and 1 N m: the rigid involute kinematics."""
    return positions_model.solve(
        {
            "tooth_stiffness": np.full(n, np.inf),
            "contact_stiffness": np.full(n, 1e11),
            "torque": np.full(n, 1.0),
            **columns,
        }
    )


def closed_form(pair, a_w):
    """alpha_w, eps_alpha and the normal backlash j_n of involute gears at a_w (ISO 21771)."""
    rb1, rb2 = pair.pinion.base_radius, pair.wheel.base_radius
    ra1, ra2 = pair.pinion.tip_radius, pair.wheel.tip_radius
    alpha_w = math.acos((rb1 + rb2) / a_w)
    eps = (
        math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - a_w * math.sin(alpha_w)
    ) / pair.base_pitch
    alpha_w0 = math.acos((rb1 + rb2) / pair.zero_backlash_center_distance)
    normal_backlash = 2.0 * (rb1 + rb2) * (involute(alpha_w) - involute(alpha_w0))
    return alpha_w, eps, normal_backlash


def geometry_row(model, deviation, relief=0.0):
    row = np.empty(GEOMETRY_SIZE)
    status = sample_geometry(model.geometry, deviation, relief, row)
    assert status == 0
    return row


# ---- 1. centre-distance deviation against the involute geometry --------------------------


@pytest.mark.parametrize("deviation", [0.0, 0.1 * MM, 0.3 * MM, 0.6 * MM, 1.0 * MM])
def test_contact_detection_gives_the_operating_pressure_angle_and_pitch_point(
    pair, model, deviation
):
    # The kernel's conjugate contact (internal tangent of the base circles, displaced
    # per sample) must run along the line of action at alpha_w and pass the centre line
    # at the operating pitch radius r_w1 = a_w z1/(z1 + z2); both closed form, to 1e-9.
    g = geometry_row(model, deviation)
    a_w = pair.center_distance + deviation
    assert g[CENTER] == pytest.approx(a_w, rel=1e-15)
    alpha_w, _, _ = closed_form(pair, a_w)

    def contact(position):
        theta = g[THETA_REF1] + position * g[PITCH1]
        phi = g[PHI_REF2] - position * g[PITCH2]
        return pair_contact(theta, 0.0, phi, 0.0, g)

    for position in (0.05, 0.3, 0.6):
        kind, delta, _, _, nx, ny, *_ = contact(position)
        assert kind == 1 and abs(delta) < 1e-12  # the kinematic pose of the sample touches
        assert math.atan2(nx, ny) == pytest.approx(alpha_w, abs=1e-12)
    low, high = 0.0, 1.0  # the contact point crosses the centre line (y = 0) at the pitch point
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if contact(mid)[3] < 0.0 else (low, mid)
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    assert contact(low)[2] == pytest.approx(a_w * z1 / (z1 + z2), rel=1e-9)


def test_double_contact_fraction_is_the_closed_form_contact_ratio(pair, backlash_pair):
    # Rigid kinematics (rigid teeth, k_con 1e11 N/m, 1 N m: penetration 2e-10 m): two pairs
    # carry load on the fraction eps - 1 of the mesh period. 400 positions: resolution
    # 1/400; a tip corner stays in contact sqrt(2 rho delta) ~ 2 um (rho ~ 10 mm the
    # relative curvature) past each end of the path, 1.5e-4 of the period per end.
    positions = 400
    cases = [
        (pair, [0.0, 0.1 * MM, 0.3 * MM, 0.6 * MM, 1.0 * MM]),
        (backlash_pair, [-0.2 * MM, 0.0, 0.4 * MM]),
    ]
    for gears, deviations in cases:
        model = MubocoPR(gears, positions=positions, reference=False)
        result = rigid_light(len(deviations), model, center_distance_deviation=np.array(deviations))
        assert np.all(result["status"] == 0)
        loaded = (result["pair_force"] > 0.0).sum(axis=2)
        assert loaded.min() >= 1 and loaded.max() <= 2
        kernel = 1.0 + (loaded == 2).mean(axis=1)
        for deviation, eps_kernel in zip(deviations, kernel, strict=True):
            _, eps, _ = closed_form(gears, gears.center_distance + deviation)
            assert abs(eps_kernel - eps) <= 1.0 / positions + 5e-4, (deviation, eps_kernel, eps)
        if gears is pair:  # +1 mm lowers the contact ratio by 0.21 (1.635 -> 1.421)
            assert kernel[0] - kernel[-1] == pytest.approx(0.2143, abs=2.0 / positions)


@pytest.mark.parametrize("which", ["tight", "backlash"])
def test_backlash_from_the_flank_contact(pair, backlash_pair, which):
    # Pinion tooth on the centre line, wheel tooth space symmetric about it: by symmetry
    # each flank pair has half the normal backlash as clearance, so the kernel's
    # drive-flank penetration there is -j_n / 2 (the wheel turns j_n / r_b2 from drive- to
    # back-flank contact with the pinion held). Against the involute-function closed form
    # to 1e-9, and the first-order growth 2 (a_w - a_0) tan(alpha_w) to its second-order
    # error (a_w - a_0) / (2 a tan^2 alpha) (j_n' = 2 sin alpha_w with alpha_w rising),
    # allowed twice over.
    gears = pair if which == "tight" else backlash_pair
    model = MubocoPR(gears, reference=False)
    z2 = gears.wheel.teeth
    deviations = [0.0, 0.05 * MM, 0.1 * MM, 0.3 * MM, 0.6 * MM]
    if which == "backlash":
        deviations.append(-0.2 * MM)
    reported = model.operating_geometry({"center_distance_deviation": np.array(deviations)})
    assert np.all(reported["status"] == 0)
    a_0 = gears.zero_backlash_center_distance
    for i, deviation in enumerate(deviations):
        g = geometry_row(model, deviation)
        # the drive-flank partner (the other candidate is a base pitch away)
        touching = [
            pair_contact(0.0, 0.0, math.pi + side * math.pi / z2, 0.0, g) for side in (-1, 1)
        ]
        (clearance,) = [c[1] for c in touching if c[0] == 1 and abs(c[1]) < 0.5 * g[BASE_PITCH]]
        normal_backlash = -2.0 * clearance
        a_w = gears.center_distance + deviation
        alpha_w, _, exact = closed_form(gears, a_w)
        assert normal_backlash == pytest.approx(exact, rel=1e-9, abs=1e-15)
        circumferential = normal_backlash / math.cos(alpha_w)
        first_order = 2.0 * (a_w - a_0) * math.tan(alpha_w)
        second_order = (a_w - a_0) / (2.0 * a_0 * math.tan(gears.pinion.pressure_angle) ** 2)
        assert circumferential == pytest.approx(first_order, rel=2.0 * second_order, abs=1e-15)
        assert circumferential <= first_order + 1e-15  # the first-order term overestimates
        assert reported["backlash"][i] == pytest.approx(circumferential, rel=1e-9, abs=1e-15)
        assert reported["wheel_backlash_angle"][i] == pytest.approx(
            normal_backlash / gears.wheel.base_radius, rel=1e-9, abs=1e-15
        )
        assert reported["operating_pressure_angle"][i] == pytest.approx(alpha_w, rel=1e-12)
    if which == "tight":  # +0.1 mm opens 73.05 um on the operating pitch circle (docs)
        assert reported["backlash"][2] == pytest.approx(73.05 * UM, abs=0.01 * UM)


def test_a_deviation_equals_the_pair_level_centre_distance(pair, model):
    # The per-sample deviation and a pair built at a_w (the `center_distance` option, the
    # pure-Python geometry) give the same STE; Newton tolerance 1e-9 of the torque.
    d1, d2 = model.relief_start_diameters
    for deviation in (0.1 * MM, 0.6 * MM):
        other = MubocoPR(
            make_pair(center_distance=pair.center_distance + deviation),
            positions=model.positions,
            reference=False,
            tooth_stiffness=model.defaults["tooth_stiffness"],
            contact_stiffness=model.defaults["contact_stiffness"],
            pinion_relief_start_diameter=d1,
            wheel_relief_start_diameter=d2,
        )
        for relief in (0.0, 5 * UM):
            here = model({"center_distance_deviation": [deviation], "tip_relief": [relief]})
            there = other({"tip_relief": [relief]})
            np.testing.assert_allclose(here["ste"], there["ste"], rtol=1e-8)


def test_samples_that_cannot_run_fail_with_a_reason(pair, backlash_pair, model):
    out = model(
        {
            "center_distance_deviation": [-0.05 * MM, 0.0, 3.5 * MM, 10.0 * MM, 0.2 * MM],
            "tip_relief": [0.0, 0.0, 0.0, 0.0, 2.0 * MM],
        }
    )
    assert out["failed"].tolist() == [True, False, True, True, True]
    reasons = out["failure_reason"]
    assert "jam" in reasons[0] and reasons[1] == ""
    assert "contact ratio < 1" in reasons[2]  # eps(a + 3.5 mm) = 0.92
    assert "do not mesh" in reasons[3]  # a_w = 145 mm > r_a1 + r_a2 = 144 mm
    assert "tip thickness" in reasons[4]
    assert np.isnan(out["ste"][[0, 2, 3, 4]]).all() and np.isfinite(out["ste"][1]).all()
    # with design backlash a shorter centre distance runs until the backlash is used up
    shifted = MubocoPR(backlash_pair, positions=20, reference=False)
    room = backlash_pair.center_distance - backlash_pair.zero_backlash_center_distance
    out = shifted({"center_distance_deviation": [-0.9 * room, -1.1 * room]})
    assert out["failed"].tolist() == [False, True] and "jam" in out["failure_reason"][1]


def test_tolerance_columns_are_validated(model):
    with pytest.raises(InvalidParameterError, match="tip_relief"):
        model({"tip_relief": [-1e-6]})
    with pytest.raises(InvalidParameterError, match="center_distance_deviation"):
        model({"center_distance_deviation": [np.nan]})
    with pytest.raises(InvalidParameterError, match="relief start diameter"):
        MubocoPR(make_pair(), pinion_relief_start_diameter=0.2, reference=False)


# ---- 2. tip relief -----------------------------------------------------------------------

#: STE [m] of this code before tolerances existed (commit 15734f9), 12 positions: default
#: pair at (k_t, k_con, T1) = (14732.9, 8.82418e8, 100) and (2e4, 6e8, 250); shifted pair
#: x 0.3/-0.1 at a = 136.1 mm, (1.5e4, 9e8, 100).
PREVIOUS_STE = {
    "default": [
        [5.513740345947998e-06, 5.422422787671379e-06, 5.365958801562931e-06,
         5.337466958083437e-06, 5.330882618253511e-06, 5.341760491038994e-06,
         5.367979225509526e-06, 5.410171118677409e-06, 6.578575311752396e-06,
         8.74135370616546e-06, 8.581487125073597e-06, 8.536480490096442e-06],
        [1.277148276400196e-05, 1.255230590511438e-05, 1.240296287976895e-05,
         1.231509286679366e-05, 1.228151667573293e-05, 1.229700906634494e-05,
         1.235899466983709e-05, 1.246802981162264e-05, 1.374958403619265e-05,
         2.101633015666148e-05, 2.072441919613298e-05, 2.064374394307247e-05],
    ],
    "shifted": [
        [5.378214448192721e-06, 5.334560244429463e-06, 5.320612940778778e-06,
         5.328125906365129e-06, 5.350547472633698e-06, 5.384188560895596e-06,
         5.429036367966033e-06, 8.901493416354688e-06, 8.596030665695395e-06,
         8.411428226671536e-06, 8.351215425026239e-06, 8.41962370013287e-06],
    ],
}  # fmt: skip


def test_zero_tolerances_reproduce_the_previous_ste(pair, backlash_pair):
    # Regression: zero deviation and zero relief leave the kernel's arithmetic unchanged
    # (sample_geometry copies the nominal vector; the relief terms fold away), so the STE
    # equals the stored values to round-off (bit for bit on the machine that stored them).
    default = MubocoPR(pair, positions=12, reference=False)
    samples = {
        "tooth_stiffness": [14732.9, 2.0e4],
        "contact_stiffness": [8.82418e8, 6e8],
        "torque": [100.0, 250.0],
    }
    for extra in ({}, {"center_distance_deviation": [0.0, 0.0], "tip_relief": [0.0, 0.0]}):
        out = default({**samples, **extra})
        np.testing.assert_allclose(out["ste"], PREVIOUS_STE["default"], rtol=1e-12)
    shifted = MubocoPR(backlash_pair, positions=12, reference=False)
    out = shifted({"tooth_stiffness": [1.5e4], "contact_stiffness": [9e8], "tip_relief": [0.0]})
    np.testing.assert_allclose(out["ste"], PREVIOUS_STE["shifted"], rtol=1e-12)


def test_unloaded_relief_is_the_kinematic_error_and_the_contact_ratio_drops_to_one(pair):
    # Rigid kinematics with the default long relief (from the HPSTC of each gear, relief
    # length l = (eps - 1) p_b on both): in the double-contact zone p in [0, eps - 1] the
    # leaving pair has pinion relief C_a (p p_b + e)/l (the pinion turns on by e = STE,
    # bringing pinion material from further up the flank to the line of action), the
    # entering pair wheel relief C_a (eps - 1 - p) p_b/l (the wheel is held). The pair whose
    # gap closes first carries the load alone: STE = min((delta + C_a p p_b/l)/(1 - C_a/l),
    # delta + C_a (eps - 1 - p) p_b/l), delta = F/k_con = 2.4e-10 m; one pair carries the
    # load over the whole period (contact ratio 1 instead of 1.635).
    positions = 200
    model = MubocoPR(pair, positions=positions, reference=False)
    relief = 10 * UM
    result = rigid_light(2, model, tip_relief=np.array([0.0, relief]))
    assert np.all(result["status"] == 0)
    loaded = (result["pair_force"] > 0.0).sum(axis=2)
    eps = pair.contact_ratio
    assert (loaded[0] == 2).mean() == pytest.approx(eps - 1.0, abs=1.0 / positions)
    assert (loaded[1] == 2).sum() <= 2  # at most the hand-over positions themselves
    p = model.positions
    p_b = pair.base_pitch
    length = (eps - 1.0) * p_b
    delta = 1.0 / pair.pinion.base_radius / 1e11  # F / k_con of one pair
    leaving = (delta + relief * p * p_b / length) / (1.0 - relief / length)
    entering = delta + relief * (eps - 1.0 - p) * p_b / length
    expected = np.where(p <= eps - 1.0, np.minimum(leaving, entering), delta)
    np.testing.assert_allclose(result["ste"][1], expected, rtol=1e-6, atol=1e-13)
    assert result["ste"][1].max() == pytest.approx(relief / 2.0, rel=2.0 / positions)


def test_relief_start_diameters_set_the_loaded_path(pair):
    # Unloaded, a relief far above the deflection leaves only the unrelieved path between
    # the two relief starts: contact ratio (s_p - s_w)/p_b with s_p, s_w their positions on
    # the line of action (s_p from the pinion start diameter, s_w from the wheel's).
    s_a, _ = pair.path_of_contact
    p_b = pair.base_pitch
    s_p, s_w = s_a + 1.45 * p_b, s_a + 0.15 * p_b  # loaded path 1.30 p_b
    d_pinion = 2.0 * math.hypot(pair.pinion.base_radius, s_p)
    d_wheel = 2.0 * math.hypot(pair.wheel.base_radius, pair.line_of_action_length - s_w)
    positions = 200
    model = MubocoPR(
        pair,
        positions=positions,
        reference=False,
        pinion_relief_start_diameter=d_pinion,
        wheel_relief_start_diameter=d_wheel,
    )
    result = rigid_light(1, model, tip_relief=np.array([20 * UM]))
    loaded = (result["pair_force"][0] > 0.0).sum(axis=1)
    assert 1.0 + (loaded == 2).mean() == pytest.approx(1.30, abs=1.0 / positions)


@pytest.fixture(scope="module")
def harris(pair):
    """Peak-to-peak STE [m] over torques for relief 0, the design relief and 1.5 of it."""
    model = MubocoPR(pair, positions=60, reference=False)
    single, _ = contact_zones(pair, model.positions)
    design = model({"torque": [100.0]})["ste"][0, single].mean()  # single-pair deflection
    torques = np.arange(10.0, 305.0, 5.0)
    reliefs = np.array([0.0, design, 1.5 * design])
    grid_r, grid_t = np.meshgrid(reliefs, torques, indexing="ij")
    out = model({"torque": grid_t.ravel(), "tip_relief": grid_r.ravel()})
    assert not out["failed"].any()
    ste = out["ste"].reshape(len(reliefs), len(torques), -1)
    zero = model({"torque": torques, "tip_relief": np.zeros(torques.size)})["ste"]
    return torques, reliefs, np.ptp(ste, axis=-1), zero[:, single].mean(axis=1)


def test_harris_map(harris):
    # Harris 1958 / Munro: a long linear relief equal to the single-pair deflection at the
    # design load (here 8.63 um at 100 N m) gives the least peak-to-peak STE near that
    # load; for constant mesh stiffness peak-to-peak = |F/k - C_a| / 2 (a V over load,
    # zero at F/k = C_a). The hinge model's pair stiffness varies along the path, so the
    # V's bottom is neither zero nor sharp: it is flat within 1 % over 105-115 N m and
    # below 30 % of the unrelieved value; the minimum is asked within 20 % of the design
    # load, the value at the design load within 15 % of the minimum. Without
    # relief peak-to-peak grows in proportion to the load (linear contact law), within
    # 10 %: the extended contact of loaded teeth grows with the load and rounds the step
    # (peak-to-peak per N m falls by 6 % from 10 to 300 N m).
    torques, reliefs, p2p, single = harris
    design_torque = 100.0
    assert reliefs[1] == pytest.approx(8.63 * UM, abs=0.01 * UM)  # docs/gears.md
    no_relief, matched, larger = p2p
    assert np.all(np.diff(no_relief) > 0.0)
    np.testing.assert_allclose(no_relief / torques, no_relief[18] / torques[18], rtol=0.1)
    best = torques[np.argmin(matched)]
    assert abs(best - design_torque) <= 0.2 * design_torque
    at_design = np.flatnonzero(torques == design_torque)[0]
    assert matched[at_design] <= 1.15 * matched.min()
    assert matched.min() < 0.3 * no_relief[at_design]
    # a V: at half and twice the design load peak-to-peak is at least twice the minimum
    for factor in (0.5, 2.0):
        assert matched[torques == factor * design_torque][0] > 2.0 * matched.min()
    # the larger relief is designed for a larger load: F/k = 1.5 C_a at 150 N m
    assert abs(torques[np.argmin(larger)] - 1.5 * design_torque) <= 0.2 * 1.5 * design_torque
    # far below the design load the V's closed form holds: (C_a - F/k)/2, F/k the
    # single-pair deflection at that torque; 10 N m, within 5 %
    light = 0
    for row, relief in ((matched, reliefs[1]), (larger, reliefs[2])):
        assert row[light] == pytest.approx((relief - single[light]) / 2.0, rel=0.05)


def test_nested_fallback_agrees_with_newton_and_solves_the_stalled_positions(pair):
    # Where the solution sits on a contact kink (the entering pair of a matched relief
    # just touches at the start of contact; a pair leaving contact mid-flank) Newton's line
    # search stalls; the nested solution (hinges per pair at a fixed lag, the lag by
    # bracketing) takes over. Check it against Newton where Newton converges, from a cold
    # start at every position (STE to 1e-13 m, Newton's tolerance ~1e-14 m), then run
    # samples that stalled Newton.
    model = MubocoPR(pair, positions=30, reference=False)
    k_con = model.defaults["contact_stiffness"]
    for relief, k_t in ((0.0, 1.4733e4), (6 * UM, 1.4733e4), (6 * UM, np.inf)):
        newton = model.solve({"tip_relief": [relief], "tooth_stiffness": [k_t]})
        assert newton["status"][0] == 0
        g = geometry_row(model, 0.0, relief)
        for j, position in enumerate(model.positions):
            beta1, beta2 = np.zeros(model.pairs.size), np.zeros(model.pairs.size)
            lag, status = _solve_nested(
                0.0, position * g[PITCH1], -position * g[PITCH2], beta1, beta2, model.pairs,
                g, 100.0, k_con, 1.0, k_t, k_t,
            )  # fmt: skip
            assert status == 0
            assert lag * pair.pinion.base_radius == pytest.approx(newton["ste"][0, j], abs=1e-13)
    stalled = MubocoPR(pair, positions=120, reference=False)
    out = stalled(
        {"tip_relief": [8.634 * UM, 20 * UM], "center_distance_deviation": [0.05 * MM, 0]}
    )
    assert not out["failed"].any() and np.isfinite(out["ste"]).all()


# ---- 3. batches mixing tolerances ----------------------------------------------------------


def test_a_mixed_batch_equals_one_sample_calls(model):
    samples = {
        "center_distance_deviation": np.array([0.0, 0.2, -0.03, 0.5, 0.0, 0.1]) * MM,
        "tip_relief": np.array([0.0, 0.0, 0.0, 8.0, 15.0, 5.0]) * UM,
        "torque": np.array([100.0, 80.0, 100.0, 150.0, 100.0, 60.0]),
        "tooth_stiffness": np.array([1.5e4, 1.2e4, 1.5e4, 1.8e4, 1.5e4, 1.4e4]),
    }
    batch = model(samples)
    assert batch["failed"].tolist() == [False, False, True, False, False, False]
    for i in range(len(samples["torque"])):
        one = model({name: values[i : i + 1] for name, values in samples.items()})
        np.testing.assert_array_equal(one["ste"][0], batch["ste"][i])
        assert one["failure_reason"][0] == batch["failure_reason"][i]


def test_dynamic_mode_takes_the_tolerances_per_sample():
    model = gear_pair_dynamic_model(
        dynamic={"speed_rpm": 1000, "mesh_periods": 3, "output_periods": 1}
    )
    samples = {
        "center_distance_deviation": np.array([0.0, 0.1, -0.05, 0.0]) * MM,
        "tip_relief": np.array([0.0, 0.0, 0.0, 8.0]) * UM,
    }
    batch = model(samples)
    assert batch["failed"].tolist() == [False, False, True, False]
    assert "jam" in batch["failure_reason"][2]
    for i in range(4):
        one = model({name: values[i : i + 1] for name, values in samples.items()})
        np.testing.assert_array_equal(one["dte"][0], batch["dte"][i])
    # the matched relief (8 um at 100 N m) calms the mesh-frequency excitation
    assert batch["dte_spectrum"][3, 0] < 0.5 * batch["dte_spectrum"][0, 0]


def test_registered_models_declare_the_tolerances():
    for name in ("gear-pair", "gear-pair-dynamic", "gear-ste-features"):
        parameters = get_model(name).parameters
        for tolerance in TOLERANCES:
            assert parameters[tolerance].unit == "m"
            assert parameters[tolerance].default == 0.0
        options = get_model(name).options
        assert "pinion_relief_start_diameter" in options
        assert "wheel_relief_start_diameter" in options
