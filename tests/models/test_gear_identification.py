"""Hinge lever arm, stiffness identification and the potential-energy reference."""

import math

import numpy as np
import pytest

from fuzzymbs.models.gears import make_pair
from fuzzymbs.models.gears.flank_contact import (
    PHI_REF2,
    PITCH1,
    PITCH2,
    THETA_REF1,
    pack_geometry,
    pair_contact,
)
from fuzzymbs.models.gears.geometry import involute
from fuzzymbs.models.gears.identification import (
    hinge_lever_arm,
    identify,
    weber_banaschek_approach,
)
from fuzzymbs.models.gears.potential_energy import reference_ste, tooth_compliance


def direct_lever_arms(pair, fractions):
    """Moment arms of the contact normal about both hinges from the contact geometry."""
    g = pack_geometry(pair)
    s_start, _ = pair.path_of_contact
    rows = []
    for p in fractions:
        theta = g[THETA_REF1] + p * g[PITCH1]
        phi = g[PHI_REF2] - p * g[PITCH2]
        kind, delta, qx, qy, nx, ny, h1x, h1y, h2x, h2y = pair_contact(theta, 0.0, phi, 0.0, g)
        assert kind == 1 and abs(delta) < 1e-12  # kinematic position: touching, on the LoA
        arm1 = abs((qx - h1x) * ny - (qy - h1y) * nx)
        arm2 = abs((qx - h2x) * ny - (qy - h2y) * nx)
        rows.append((s_start + p * pair.base_pitch, arm1, arm2))
    return np.array(rows).T


@pytest.mark.parametrize("shifts", [(0.0, 0.0), (0.3, -0.3), (0.4, 0.1)])
def test_hinge_lever_arm_formula_matches_contact_geometry(shifts):
    # THEORY.md marks d = r_b - r_f cos(alpha_1) as derived: check it against the moment
    # arm of the normal force about the hinge computed from positions and the normal.
    pair = make_pair(pinion_profile_shift=shifts[0], wheel_profile_shift=shifts[1])
    s, arm1, arm2 = direct_lever_arms(pair, np.linspace(1e-6, pair.contact_ratio - 1e-6, 25))
    np.testing.assert_allclose(hinge_lever_arm(pair.pinion, s), arm1, rtol=1e-9)
    np.testing.assert_allclose(
        hinge_lever_arm(pair.wheel, pair.line_of_action_length - s), arm2, rtol=1e-9
    )
    if shifts[0] != 0.0:
        # THEORY.md's alpha_2 = pi/(2z) + inv(alpha_0) omits 2 x tan(alpha)/z: wrong for x != 0
        gear = pair.pinion
        alpha_2 = math.pi / (2 * gear.teeth) + involute(gear.pressure_angle)
        theory = gear.base_radius - gear.root_radius * np.cos(s / gear.base_radius - alpha_2)
        assert np.max(np.abs(theory / arm1 - 1.0)) > 0.01


def test_identified_tooth_stiffness_fits_the_pe_model():
    pair = make_pair()
    ident = identify(pair, 100.0)
    # rule of thumb (THEORY.md): k_t ~ 0.25 E b m^2 = 2.1e4 N m/rad for this pair
    rule = 0.25 * 2.1e11 * 20e-3 * 4.5e-3**2
    for value in (ident.tooth_stiffness, ident.pinion_tooth_stiffness, ident.wheel_tooth_stiffness):
        assert 0.5 * rule < value < 1.5 * rule
    # least-squares optimality: perturbing 1/k_t either way worsens the fit
    lever = ident.lever_pinion**2 + ident.lever_wheel**2
    target = ident.pe_pinion + ident.pe_wheel

    def misfit(kt):
        return np.sum((lever / kt - target) ** 2)

    best = misfit(ident.tooth_stiffness)
    assert best < misfit(ident.tooth_stiffness * 1.01)
    assert best < misfit(ident.tooth_stiffness * 0.99)
    # the hinge model reproduces the PE compliance along the path within ~15 % RMS
    assert ident.fit_error < 0.15


def test_weber_banaschek_properties():
    # Weber-Banaschek: delta = 2 F (1 - nu^2) / (pi E b) [ln(2 h1 / b_H) + ln(2 h2 / b_H) - ...]
    # with the Hertz half-width b_H ~ sqrt(F): the log terms fall as F grows, so the approach
    # grows slightly slower than linearly (secant stiffness F/delta rises); doubling the face
    # width roughly halves it; k = F/delta lies within the Yang-Sun scale
    # pi E b / (4 (1 - nu^2)) to a factor 10 (line contact has no unique stiffness).
    force = np.array([500.0, 1000.0, 2000.0, 4000.0])
    args = ((0.015, 0.03), (4e-3, 4e-3), (2.1e11, 2.1e11), (0.3, 0.3))
    delta = weber_banaschek_approach(force, 0.02, *args)
    secant = force / delta
    assert np.all(np.diff(secant) > 0)  # stiffening
    yang_sun = math.pi * 2.1e11 * 0.02 / (4 * (1 - 0.09))
    assert np.all((secant > yang_sun / 10) & (secant < yang_sun))
    wide = weber_banaschek_approach(force, 0.04, *args)
    assert np.all((wide < delta) & (wide > 0.4 * delta))


def test_pe_compliance_parts_are_positive_and_bending_grows_towards_the_tip():
    # Bending dominates near the tip and grows towards the tip; all four parts positive.
    pair = make_pair()
    gear = pair.pinion
    s = np.linspace(*pair.path_of_contact, 9)
    parts = tooth_compliance(gear, s)
    for name in ("bending", "shear", "axial", "foundation"):
        assert np.all(parts[name] > 0)
    assert np.all(np.diff(parts["bending"]) > 0)
    assert parts["bending"][-1] > parts["shear"][-1]


def test_reference_ste_is_the_double_single_step():
    pair = make_pair()
    ident = identify(pair, 100.0)
    positions = np.linspace(0, 1, 50, endpoint=False)
    ste = reference_ste(pair, 100.0, positions, ident.contact_stiffness)
    frac = pair.contact_ratio - 1
    single = positions > frac
    assert ste[single].min() > 1.4 * ste[~single].max()


def test_pe_integration_is_converged_and_near_iso():
    pair = make_pair()
    s = np.linspace(*pair.path_of_contact, 7)
    coarse = tooth_compliance(pair.pinion, s)["total"]
    fine = tooth_compliance(pair.pinion, s, points=4000)["total"]
    np.testing.assert_allclose(coarse, fine, rtol=1e-4)  # trapezoidal rule, 600 points
    # independent empirical estimate: the PE mean STE lies within ISO's +-25 % spread
    from fuzzymbs.models.gears import iso_mean_ste

    ident = identify(pair, 100.0)
    positions = np.linspace(0, 1, 50, endpoint=False)
    mean_pe = np.mean(reference_ste(pair, 100.0, positions, ident.contact_stiffness))
    assert abs(mean_pe / iso_mean_ste(pair, 100.0) - 1.0) < 0.25
