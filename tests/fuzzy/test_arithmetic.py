"""Standard fuzzy arithmetic: closed-form cuts and the dependency problem (THEORY.md)."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidFuzzyNumberError, UnsupportedOperationError
from fuzzymbs.fuzzy.arithmetic import apply_monotone
from fuzzymbs.fuzzy.numbers import PiecewiseLinear, Trapezoidal, Triangular
from fuzzymbs.fuzzy.transform import plan

MU = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
X = Triangular(-1.0, 0.0, 1.0)


def test_product_of_independent_numbers_exact():
    # THEORY.md oracle: TFN(1,2,3) * TFN(2,3,4) = [(1+mu)(2+mu), (3-mu)(4-mu)]
    z = Triangular(1, 2, 3) * Triangular(2, 3, 4)
    assert isinstance(z, PiecewiseLinear)
    cuts = z.cuts(MU)
    np.testing.assert_allclose(cuts[:, 0], (1 + MU) * (2 + MU), rtol=1e-14)
    np.testing.assert_allclose(cuts[:, 1], (3 - MU) * (4 - MU), rtol=1e-14)


def test_dependency_problem_square():
    # THEORY.md: x * x with x = TFN(-1,0,1) gives lower -(1-mu)^2 (exact: 0), while the
    # transformation method (general) gives the exact [0, (1-mu)^2]
    cuts = (X * X).cuts(MU)
    np.testing.assert_allclose(cuts[:, 0], -((1 - MU) ** 2), atol=1e-15)
    np.testing.assert_allclose(cuts[:, 1], (1 - MU) ** 2, atol=1e-15)
    p = plan({"x": X}, "general", 4)
    exact = p.retransform(p.samples[:, 0] ** 2)
    np.testing.assert_allclose(exact.lower, 0.0)
    # x ** 2 is a one-operand function and exact
    np.testing.assert_allclose(
        (X**2).cuts(MU), np.column_stack([0 * MU, (1 - MU) ** 2]), atol=1e-15
    )


def test_dependency_problem_difference():
    # THEORY.md: x - x gives [-2, 2] at mu = 0, i.e. [-2(1-mu), 2(1-mu)], instead of 0
    cuts = (X - X).cuts(MU)
    np.testing.assert_allclose(cuts, np.column_stack([-2 * (1 - MU), 2 * (1 - MU)]), atol=1e-15)


def test_scalar_operations_and_negation():
    # affine maps of TFN(1,2,3): 2x + 1 = TFN(3,5,7); 1 - x = TFN(-2,-1,0); -x = TFN(-3,-2,-1)
    x = Triangular(1, 2, 3)
    np.testing.assert_allclose((2 * x + 1).cuts(MU), Triangular(3, 5, 7).cuts(MU), rtol=1e-15)
    np.testing.assert_allclose((1 - x).cuts(MU), Triangular(-2, -1, 0).cuts(MU), atol=1e-15)
    np.testing.assert_allclose((-x).cuts(MU), Triangular(-3, -2, -1).cuts(MU), atol=1e-15)
    np.testing.assert_allclose((x / 2).cuts(MU), Triangular(0.5, 1, 1.5).cuts(MU), rtol=1e-15)


def test_division_and_reciprocal():
    # 1 / TFN(1,2,3) = [1/(3 - mu), 1/(1 + mu)] (reciprocal is decreasing on (0, inf))
    cuts = (1 / Triangular(1, 2, 3)).cuts(MU)
    np.testing.assert_allclose(cuts, np.column_stack([1 / (3 - MU), 1 / (1 + MU)]), rtol=1e-14)
    with pytest.raises(InvalidFuzzyNumberError, match="contains 0"):
        _ = 1 / X


def test_powers():
    x = Triangular(1, 2, 3)
    # odd power increasing: [(1+mu)^3, (3-mu)^3]; negative power: [(3-mu)^-2, (1+mu)^-2]
    np.testing.assert_allclose((x**3).cuts(MU)[:, 0], (1 + MU) ** 3, rtol=1e-14)
    np.testing.assert_allclose((x**-2).cuts(MU)[:, 1], (1 + MU) ** -2, rtol=1e-14)
    np.testing.assert_allclose((x**0.5).cuts(MU)[:, 1], np.sqrt(3 - MU), rtol=1e-14)
    np.testing.assert_allclose((X**3).cuts(MU)[:, 0], -((1 - MU) ** 3), atol=1e-15)
    np.testing.assert_array_equal((x**0).cuts(MU), 1.0)
    with pytest.raises(InvalidFuzzyNumberError, match="negative power"):
        _ = X**-1
    with pytest.raises(InvalidFuzzyNumberError, match="non-integer"):
        _ = X**0.5
    with pytest.raises(UnsupportedOperationError, match="exponent"):
        _ = x**x


def test_apply_monotone_exp_and_decreasing():
    # exp is increasing: exp(Trap(0,1,2,3)) = [exp(mu), exp(3 - mu)]
    z = apply_monotone(np.exp, Trapezoidal(0, 1, 2, 3))
    np.testing.assert_allclose(z.cuts(MU), np.column_stack([np.exp(MU), np.exp(3 - MU)]))
    w = apply_monotone(lambda v: -v, Triangular(1, 2, 3), increasing=False)
    np.testing.assert_allclose(w.cuts(MU), Triangular(-3, -2, -1).cuts(MU), atol=1e-15)
    with pytest.raises(InvalidFuzzyNumberError, match="not increasing"):
        apply_monotone(lambda v: -v, Triangular(1, 2, 3))
    with pytest.raises(UnsupportedOperationError):
        apply_monotone(np.exp, 1.0)


def test_piecewise_linear_operand_levels_kept():
    # a piecewise-linear operand's own levels are kept in the result's level set
    y = PiecewiseLinear([0.0, 0.3, 1.0], [0.0, 1.0, 2.0], [5.0, 4.0, 2.0])
    z = y + 1.0
    assert 0.3 in z.levels
    assert z.alpha_cut(0.3) == (2.0, 5.0)


@pytest.mark.parametrize("other", ["a", None, [1.0], True])
def test_unsupported_operands(other):
    with pytest.raises(UnsupportedOperationError):
        _ = X + other
    with pytest.raises(InvalidFuzzyNumberError):
        _ = X * float("nan")
