"""ISO 6336-1 method B stiffness against the ISO/TR 6336-30 worked example."""

import math

import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import inverse_involute
from fuzzymbs.models.gears.iso6336 import iso_tooth_stiffness


def transverse_contact_ratio_example_1():
    """eps_alpha of ISO/TR 6336-30 example 1 from its gear data.

    m_n 8 mm, z 17/103, x 0.145/0, beta 15.8 deg, alpha_n 20 deg; tip diameters
    d + 2 m_n (1 + x) and the zero-backlash centre distance (~500 mm) -- our
    reconstruction of the example's geometry (not printed in THEORY.md).
    """
    mn, z1, z2, x1, x2 = 8.0, 17, 103, 0.145, 0.0
    beta, alpha_n = math.radians(15.8), math.radians(20.0)
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    mt = mn / math.cos(beta)
    d1, d2 = mt * z1, mt * z2
    db1, db2 = d1 * math.cos(alpha_t), d2 * math.cos(alpha_t)
    inv_w = math.tan(alpha_t) - alpha_t + 2 * math.tan(alpha_n) * (x1 + x2) / (z1 + z2)
    alpha_w = inverse_involute(inv_w)
    a = (db1 + db2) / 2 / math.cos(alpha_w)
    da1, da2 = d1 + 2 * mn * (1 + x1), d2 + 2 * mn * (1 + x2)
    path = 0.5 * (math.sqrt(da1**2 - db1**2) + math.sqrt(da2**2 - db2**2)) - a * math.sin(alpha_w)
    return path / (math.pi * mt * math.cos(alpha_t))


def test_iso_tr_6336_30_example_1():
    # ISO/TR 6336-30 example 1 (values in THEORY.md): c'_th = 17.856, c' = 12.370,
    # c_gamma_alpha = 17.465 N/(mm um); tolerance = the printed rounding (5e-4 relative).
    eps = transverse_contact_ratio_example_1()
    result = iso_tooth_stiffness(
        (17, 103),
        (0.145, 0.0),
        eps,
        helix_angle=math.radians(15.8),
        dedendum_coefficient=1.4,
    )
    assert result.single_theoretical == pytest.approx(17.856, rel=5e-4)
    assert result.single == pytest.approx(12.370, rel=5e-4)
    assert result.basic_rack_factor == pytest.approx(0.9, rel=1e-12)
    assert result.mesh == pytest.approx(17.465, rel=5e-4)


def test_low_line_load_reduces_stiffness():
    # ISO 6336-1 method B: below F_t K_A / b = 100 N/mm, c' is scaled by (F_t K_A / b / 100)^0.25;
    # 50 N/mm gives 0.5^0.25 exactly (closed form, round-off tolerance)
    full = iso_tooth_stiffness((20, 40), (0, 0), 1.6)
    low = iso_tooth_stiffness((20, 40), (0, 0), 1.6, line_load=50.0)
    assert low.single / full.single == pytest.approx(0.5**0.25, rel=1e-12)


def test_invalid_input():
    with pytest.raises(InvalidParameterError, match="transverse_contact_ratio"):
        iso_tooth_stiffness((20, 40), (0, 0), 0.9)
    with pytest.raises(InvalidParameterError, match="teeth"):
        iso_tooth_stiffness((3, 40), (0, 0), 1.5)
