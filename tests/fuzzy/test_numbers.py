"""Fuzzy numbers: alpha-cuts, membership, validation, serialisation.

References are closed forms of the membership functions (stated per test).
"""

import math

import numpy as np
import pytest

from fuzzymbs.errors import InvalidFuzzyNumberError
from fuzzymbs.fuzzy.numbers import (
    FuzzyNumber,
    Gaussian,
    PiecewiseLinear,
    Trapezoidal,
    Triangular,
    triangular_numbers,
)

LEVELS = [0.0, 0.25, 0.5, 0.75, 1.0]


@pytest.mark.parametrize("mu", LEVELS)
def test_triangular_cut_closed_form(mu):
    # TFN(a, c, b): cut [a + mu (c - a), b - mu (b - c)] (definition of the linear branches)
    number = Triangular(1.0, 2.0, 4.0)
    low, high = number.alpha_cut(mu)
    assert low == pytest.approx(1.0 + mu, abs=1e-15)
    assert high == pytest.approx(4.0 - 2.0 * mu, abs=1e-15)


def test_triangular_support_core_modal_and_relative():
    number = Triangular.relative(200e3, 0.1)  # +-10 % of 200 kN/m
    assert number.support == pytest.approx((180e3, 220e3), rel=1e-15)
    assert number.core == (200e3, 200e3)
    assert number.modal == 200e3
    # negative modal value: spread is relative to |modal|
    negative = Triangular.relative(-2.0, 0.5)
    assert negative.support == (-3.0, -1.0)


def test_triangular_membership_inverts_cut():
    # membership(alpha_cut(mu)) == mu on both branches (inverse functions)
    number = Triangular(-1.0, 0.5, 3.0)
    mus = np.linspace(0.0, 1.0, 11)
    cuts = number.cuts(mus)
    np.testing.assert_allclose(number.membership(cuts[:, 0]), mus, atol=1e-14)
    np.testing.assert_allclose(number.membership(cuts[:, 1]), mus, atol=1e-14)
    assert number.membership(-1.5) == 0.0
    assert number.membership(3.5) == 0.0
    assert number.membership(np.array([[0.5]])).shape == (1, 1)


def test_crisp_triangular():
    number = Triangular(2.0, 2.0, 2.0)
    assert number.alpha_cut(0.3) == (2.0, 2.0)
    np.testing.assert_array_equal(number.membership([1.9, 2.0, 2.1]), [0.0, 1.0, 0.0])


@pytest.mark.parametrize("mu", LEVELS)
def test_trapezoidal_cut_and_membership(mu):
    # Trap(a, c1, c2, b): cut [a + mu (c1 - a), b - mu (b - c2)]
    number = Trapezoidal(0.0, 1.0, 2.0, 5.0)
    low, high = number.alpha_cut(mu)
    assert (low, high) == pytest.approx((mu, 5.0 - 3.0 * mu), abs=1e-15)
    assert number.membership(low) == pytest.approx(mu, abs=1e-14)
    assert number.membership(high) == pytest.approx(mu, abs=1e-14)
    assert number.modal == 1.5
    assert number.membership(1.7) == 1.0


@pytest.mark.parametrize("mu", LEVELS)
def test_gaussian_cut_formula(mu):
    # Derived: lifted bell (exp(-d^2/(2 s^2)) - e_t)/(1 - e_t) = mu
    #   => d = s sqrt(-2 ln(e_t + mu (1 - e_t))), e_t = exp(-t^2/2)
    mean, std, truncation = 10.0, 2.0, 3.0
    number = Gaussian(mean, std, truncation)
    floor = math.exp(-0.5 * truncation**2)
    half_width = std * math.sqrt(-2.0 * math.log(floor + mu * (1.0 - floor)))
    low, high = number.alpha_cut(mu)
    assert low == pytest.approx(mean - half_width, abs=1e-12)
    assert high == pytest.approx(mean + half_width, abs=1e-12)
    # the membership function returns mu at the cut bounds (round trip)
    assert number.membership(high) == pytest.approx(mu, abs=1e-12)


def test_gaussian_support_and_outside():
    number = Gaussian(0.0, 1.0, truncation=2.0)
    assert number.support == (-2.0, 2.0)
    assert number.core == (0.0, 0.0)
    np.testing.assert_array_equal(number.membership([-2.5, 2.5]), [0.0, 0.0])
    assert number.membership(0.0) == pytest.approx(1.0)


def test_piecewise_linear_interpolates_between_cuts():
    # linear in mu between the given cuts: mu = .25 halfway between levels 0 and .5
    number = PiecewiseLinear([0.0, 0.5, 1.0], [0.0, 2.0, 3.0], [10.0, 6.0, 3.0])
    assert number.alpha_cut(0.25) == (1.0, 8.0)
    assert number.alpha_cut(0.75) == (2.5, 4.5)
    np.testing.assert_allclose(
        number.membership([1.0, 2.5, 3.0, 8.0, 11.0]), [0.25, 0.75, 1.0, 0.25, 0.0]
    )


def test_piecewise_linear_vertical_segment_takes_highest_level():
    # lower bound stays at 2 from mu = .5 to 1: membership at x = 2 is 1 (upper semicontinuous)
    number = PiecewiseLinear([0.0, 0.5, 1.0], [0.0, 2.0, 2.0], [4.0, 4.0, 4.0])
    np.testing.assert_allclose(number.membership([2.0, 1.0, 4.0]), [1.0, 0.25, 1.0])


def test_piecewise_linear_reproduces_triangular():
    # a triangular number written as cuts gives the same cuts and memberships
    triangle = Triangular(1.0, 2.0, 4.0)
    mus = np.array(LEVELS)
    cuts = triangle.cuts(mus)
    copy = PiecewiseLinear(mus, cuts[:, 0], cuts[:, 1])
    x = np.linspace(0.0, 5.0, 41)
    np.testing.assert_allclose(copy.membership(x), triangle.membership(x), atol=1e-14)


@pytest.mark.parametrize(
    "number",
    [
        Triangular(1.0, 2.0, 3.0),
        Trapezoidal(0.0, 1.0, 2.0, 5.0),
        Gaussian(1.0, 0.5, 2.5),
        PiecewiseLinear([0.0, 0.5, 1.0], [0.0, 2.0, 3.0], [10.0, 6.0, 3.0]),
    ],
)
def test_to_dict_round_trip(number):
    import json

    data = json.loads(json.dumps(number.to_dict()))
    again = FuzzyNumber.from_dict(data)
    assert again == number
    assert type(again) is type(number)
    np.testing.assert_array_equal(again.cuts(LEVELS), number.cuts(LEVELS))


@pytest.mark.parametrize(
    ("factory", "fragment"),
    [
        (lambda: Triangular(2.0, 1.0, 3.0), "lower <= modal <= upper"),
        (lambda: Triangular(1.0, 3.0, 2.0), "lower <= modal <= upper"),
        (lambda: Triangular(float("nan"), 1.0, 2.0), "lower"),
        (lambda: Triangular(0.0, 1.0, float("inf")), "upper"),
        (lambda: Triangular(0.0, "x", 1.0), "modal"),
        (lambda: Triangular.relative(1.0, -0.1), "spread"),
        (lambda: Triangular.relative(1.0, float("nan")), "spread"),
        (lambda: Trapezoidal(0.0, 2.0, 1.0, 3.0), "core_lower"),
        (lambda: Gaussian(0.0, 0.0), "std"),
        (lambda: Gaussian(0.0, -1.0), "std"),
        (lambda: Gaussian(0.0, 1.0, truncation=0.0), "truncation"),
        (lambda: Gaussian(float("nan"), 1.0), "mean"),
        (lambda: PiecewiseLinear([0.0, 1.0], [0.0, 2.0], [3.0, 1.5]), "lower 2.0 > upper 1.5"),
        (lambda: PiecewiseLinear([0.0, 0.5, 1.0], [0, 2, 1], [5, 4, 3]), "not nested"),
        (lambda: PiecewiseLinear([0.0, 0.5, 1.0], [0, 1, 2], [5, 6, 3]), "not nested"),
        (lambda: PiecewiseLinear([0.0, 0.7, 0.5, 1.0], [0] * 4, [1] * 4), "increase strictly"),
        (lambda: PiecewiseLinear([0.1, 1.0], [0, 0], [1, 1]), "from 0 to 1"),
        (lambda: PiecewiseLinear([0.0, 1.0], [0, float("nan")], [1, 1]), "finite"),
        (lambda: PiecewiseLinear([0.0, 1.0], [0, 0, 0], [1, 1]), "equal length"),
        (lambda: FuzzyNumber.from_dict({"type": "lognormal"}), "unknown fuzzy number type"),
        (lambda: FuzzyNumber.from_dict({"lower": 1}), "'type'"),
        (lambda: FuzzyNumber.from_dict({"type": "triangular", "lower": 1}), "invalid keys"),
    ],
)
def test_invalid_definitions_raise_naming_the_value(factory, fragment):
    with pytest.raises(InvalidFuzzyNumberError, match=None) as info:
        factory()
    assert fragment in str(info.value)


@pytest.mark.parametrize("mu", [-0.1, 1.5, float("nan"), "high", None])
def test_alpha_cut_rejects_levels_outside_unit_interval(mu):
    with pytest.raises(InvalidFuzzyNumberError, match="mu"):
        Triangular(0.0, 1.0, 2.0).alpha_cut(mu)


def test_triangular_numbers_from_plain_triples():
    # what a model suggests as plain (lower, modal, upper) numbers, as fuzzy numbers
    numbers = triangular_numbers({"k": (0.8, 1.0, 1.2), "c": [1.5, 2.0, 2.5]})
    assert list(numbers) == ["k", "c"]
    assert numbers["k"].to_dict() == Triangular(0.8, 1.0, 1.2).to_dict()
    assert numbers["c"].alpha_cut(0.5) == Triangular(1.5, 2.0, 2.5).alpha_cut(0.5)
    with pytest.raises(InvalidFuzzyNumberError, match="expected \\(lower, modal, upper\\)"):
        triangular_numbers({"k": (0.8, 1.0)})
    with pytest.raises(InvalidFuzzyNumberError, match="expected \\(lower, modal, upper\\)"):
        triangular_numbers({"k": 1.0})
    with pytest.raises(InvalidFuzzyNumberError, match="lower <= modal <= upper"):
        triangular_numbers({"k": (1.2, 1.0, 0.8)})
