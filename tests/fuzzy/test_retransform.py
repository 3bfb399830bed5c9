"""Retransformation against closed-form fuzzy outputs (THEORY.md section 1 oracles)."""

import warnings

import numpy as np
import pytest

from fuzzymbs.errors import (
    InvalidFuzzyNumberError,
    InvalidPlanError,
    ModelOutputError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy.numbers import Gaussian, Trapezoidal, Triangular
from fuzzymbs.fuzzy.retransform import FuzzyResult
from fuzzymbs.fuzzy.transform import NonMonotonicWarning, plan

MU = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
SYMMETRIC = Triangular(-1.0, 0.0, 1.0)


@pytest.mark.parametrize("method", ["general", "reduced", "extended", "grid"])
def test_product_exact_cuts(method):
    # THEORY.md oracle: x = TFN(1,2,3), y = TFN(2,3,4), z = x y has the exact cuts
    # [(1 + mu)(2 + mu), (3 - mu)(4 - mu)] (monotonic in both for positive inputs)
    p = plan({"x": Triangular(1, 2, 3), "y": Triangular(2, 3, 4)}, method, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonMonotonicWarning)
        result = p.retransform(p.evaluate(lambda s: {"z": s["x"] * s["y"]}))["z"]
    np.testing.assert_allclose(result.lower, (1 + MU) * (2 + MU), rtol=1e-14)
    np.testing.assert_allclose(result.upper, (3 - MU) * (4 - MU), rtol=1e-14)
    assert result.complete.all()
    assert result.nominal == 6.0


def test_square_general_method_exact():
    # THEORY.md oracle: z = x x, x = TFN(-1,0,1): exact [0, (1 - mu)^2]; the general
    # method hits x = 0 at the even levels, nesting carries it to the odd ones
    p = plan({"x": SYMMETRIC}, "general", 4)
    result = p.retransform(p.samples[:, 0] ** 2)
    np.testing.assert_allclose(result.lower, 0.0, atol=0.0)
    np.testing.assert_allclose(result.upper, (1 - MU) ** 2, rtol=1e-15)


def test_square_reduced_warns_nonmonotonic():
    # the core point x = 0 gives z = 0 below the corner outputs (1 - mu)^2 > 0:
    # a non-monotonic model, the reduced scheme must say so
    p = plan({"x": SYMMETRIC, "y": SYMMETRIC}, "reduced", 4)
    with pytest.warns(NonMonotonicWarning, match="'z'.*too narrow"):
        p.retransform({"z": p.samples[:, 0] ** 2 + p.samples[:, 1]})


def test_monotone_linear_model_does_not_warn_on_round_off():
    # inexact decimal coefficients: outputs at the core differ from the corner range only
    # by round-off, which the relative tolerance must absorb
    parameters = {
        "k": Triangular.relative(200e3, 0.1),
        "k_c": Triangular.relative(1e3, 0.1),
        "F_n": Triangular.relative(16e3, 0.01),
    }
    p = plan(parameters, "reduced", 4)
    s = p.sample_columns()
    z = 0.1 * s["k"] + 0.3 * s["k_c"] - 0.7 * s["F_n"] + 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonMonotonicWarning)
        p.retransform(z)


def test_time_signal_exact_per_time_step():
    # Derived: z(t) = a sin(t) + b, a = TFN(1,2,3), b = TFN(-1,0,1): monotonic in a with the
    # sign of sin t, so the cut is [a_lo sin t + b_lo, a_hi sin t + b_hi] for sin t >= 0 and
    # with a_lo/a_hi swapped for sin t < 0 (a_lo = 1 + mu, a_hi = 3 - mu, b = +-(1 - mu))
    t = np.linspace(0.0, 2 * np.pi, 50)
    p = plan({"a": Triangular(1, 2, 3), "b": SYMMETRIC}, "reduced", 4)
    outputs = p.evaluate(lambda s: {"z": s["a"][:, None] * np.sin(t) + s["b"][:, None]})
    result = p.retransform(outputs)["z"]
    assert result.lower.shape == (5, 50)
    sin = np.sin(t)[None, :]
    a_lo, a_hi, b_half = (1 + MU)[:, None], (3 - MU)[:, None], (1 - MU)[:, None]
    lower = np.where(sin >= 0, a_lo * sin, a_hi * sin) - b_half
    upper = np.where(sin >= 0, a_hi * sin, a_lo * sin) + b_half
    np.testing.assert_allclose(result.lower, lower, atol=1e-14)
    np.testing.assert_allclose(result.upper, upper, atol=1e-14)
    np.testing.assert_allclose(result.nominal, 2.0 * np.sin(t), atol=1e-15)


def test_trapezoidal_input_exp():
    # Derived: x = Trap(0, 1, 2, 3), cuts [mu, 3 - mu]; exp is increasing, so
    # z = exp(x) has cuts [exp(mu), exp(3 - mu)]; the core is [e, e^2], not one point
    p = plan({"x": Trapezoidal(0, 1, 2, 3)}, "reduced", 4)
    result = p.retransform(np.exp(p.samples[:, 0]))
    np.testing.assert_allclose(result.lower, np.exp(MU), rtol=1e-15)
    np.testing.assert_allclose(result.upper, np.exp(3 - MU), rtol=1e-15)
    assert result.nominal == pytest.approx(np.exp(1.5))


def test_gaussian_input_identity():
    # identity model: output cuts are the input's cuts (Gaussian closed form in test_numbers)
    x = Gaussian(5.0, 0.5, 2.0)
    p = plan({"x": x}, "reduced", 4)
    result = p.retransform(p.samples[:, 0].copy())
    np.testing.assert_array_equal(np.column_stack([result.lower, result.upper]), x.cuts(MU))


def test_failed_samples_give_nan_on_touched_levels():
    # a failed corner at level 2 invalidates levels 0..2 (they nest over level 2);
    # levels 3 and 4 stay exact (z = a + b: [-2 (1 - mu), 2 (1 - mu)])
    p = plan({"a": SYMMETRIC, "b": SYMMETRIC}, "reduced", 4)
    z = p.samples.sum(axis=1)
    failed = np.zeros(len(p), dtype=bool)
    failed[p.corner_index[2, 0]] = True
    z[failed] = np.nan
    result = p.retransform(z, failed=failed)
    np.testing.assert_array_equal(result.complete, [False, False, False, True, True])
    assert np.isnan(result.lower[:3]).all() and np.isnan(result.upper[:3]).all()
    np.testing.assert_allclose(result.upper[3:], 2 * (1 - MU[3:]), atol=1e-15)
    assert result.nominal == 0.0


def test_failed_nominal_gives_nan_everywhere():
    p = plan({"a": SYMMETRIC}, "reduced", 2)
    failed = np.zeros(len(p), dtype=bool)
    failed[p.nominal_index] = True
    result = p.retransform(p.samples[:, 0].copy(), failed)
    assert not result.complete.any()
    assert np.isnan(result.nominal)


def test_nan_without_failed_mask_is_an_error():
    p = plan({"a": SYMMETRIC}, "reduced", 2)
    z = p.samples[:, 0].copy()
    z[1] = np.nan
    with pytest.raises(ModelOutputError, match="not marked failed"):
        p.retransform(z)


@pytest.mark.parametrize(
    "outputs",
    [np.zeros(3), np.float64(1.0), np.array(["a"] * 5)],
)
def test_bad_outputs_rejected(outputs):
    p = plan({"a": SYMMETRIC}, "reduced", 2)  # 5 samples
    with pytest.raises(ModelOutputError):
        p.retransform(outputs)


def test_alpha_cut_between_levels_takes_next_level_up():
    p = plan({"a": SYMMETRIC}, "reduced", 4)
    result = p.retransform(p.samples[:, 0].copy())
    # mu = .3 lies between .25 and .5: the .5 cut [-.5, .5]
    assert result.alpha_cut(0.3) == (-0.5, 0.5)
    assert result.alpha_cut(0.25) == (-0.75, 0.75)
    assert result.alpha_cut(0.25 + 1e-14) == (-0.75, 0.75)
    assert result.alpha_cut(1.0) == (0.0, 0.0)
    with pytest.raises(InvalidFuzzyNumberError):
        result.alpha_cut(1.2)


def test_to_xarray_labels():
    t = np.linspace(0.0, 1.0, 4)
    p = plan({"a": Triangular(1, 2, 3)}, "reduced", 2)
    result = p.retransform(p.samples[:, :1] * t)
    dataset = result.to_xarray("y_pad", dims=["time"], coords={"time": t})
    assert dataset["y_pad_lower"].dims == ("level", "time")
    np.testing.assert_array_equal(dataset["level"], [0.0, 0.5, 1.0])
    np.testing.assert_array_equal(dataset["y_pad_upper"].values, result.upper)
    np.testing.assert_array_equal(dataset["time"], t)
    with pytest.raises(UnsupportedOperationError):
        result.to_xarray("y", dims=["a", "b"])
    with pytest.raises(UnsupportedOperationError):
        result.to_xarray("y", dims=["time"], coords={"time": t[:2]})


def test_influence_unsupported_for_general_and_bare_results():
    p = plan({"a": SYMMETRIC}, "general", 2)
    with pytest.raises(UnsupportedOperationError, match="reduced"):
        p.retransform(p.samples[:, 0].copy()).influence()
    bare = FuzzyResult([0.0, 1.0], [[0.0], [1.0]], [[2.0], [1.0]])
    with pytest.raises(UnsupportedOperationError):
        bare.influence()


def test_bad_failed_mask():
    p = plan({"a": SYMMETRIC}, "reduced", 2)
    with pytest.raises(InvalidPlanError, match="failed"):
        p.retransform(p.samples[:, 0].copy(), failed=[0, 1, 0, 0, 0])


def test_fuzzy_result_validates_shapes():
    with pytest.raises(InvalidFuzzyNumberError, match="shape"):
        FuzzyResult([0.0, 1.0], [0.0, 1.0, 2.0], [0.0, 1.0, 2.0])
    with pytest.raises(InvalidFuzzyNumberError, match="complete"):
        FuzzyResult([0.0, 1.0], [0.0, 1.0], [2.0, 1.0], complete=[True])


def test_extended_guard_tests_only_declared_monotonic_parameters():
    # z = x^2 + y with x declared nonmonotonic: monotonic in y, so no warning; the
    # exact bounds [-(1 - mu), (1 - mu)^2 + (1 - mu)] hold at the levels whose points
    # include x = 0 or the x-bounds (even levels for m = 4: mu = 0, .5, 1)
    p = plan({"x": SYMMETRIC, "y": SYMMETRIC}, "extended", 4, nonmonotonic=["x"])
    s = p.sample_columns()
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonMonotonicWarning)
        result = p.retransform(s["x"] ** 2 + s["y"])
    even = [0, 2, 4]
    np.testing.assert_allclose(result.lower[even], -(1 - MU[even]), atol=1e-15)
    np.testing.assert_allclose(result.upper, (1 - MU) ** 2 + (1 - MU), atol=1e-15)
    # z = x + y^2: y is treated as monotonic but is not -> warned
    with pytest.warns(NonMonotonicWarning, match="not named nonmonotonic"):
        p.retransform(s["x"] + s["y"] ** 2)


@pytest.mark.parametrize("m", [4, 8, 16])
def test_general_method_error_bound_for_interior_minimum(m):
    # Derived: z = (x - 0.3)^2, x = TFN(-1,0,1). Exact lower bound of the cut at mu is 0 while
    # 0.3 lies in [-(1-mu), 1-mu], else (1-mu - 0.3)^2. The general points of level j are
    # k/m, k = -(m-j), -(m-j)+2, ..., so the nearest point is within 1/m of 0.3 and the
    # lower bound errs by at most (1/m)^2 (it can only be too high: an inner approximation).
    p = plan({"x": SYMMETRIC}, "general", m)
    result = p.retransform((p.samples[:, 0] - 0.3) ** 2)
    half_width = 1.0 - p.levels
    exact_lower = np.where(half_width >= 0.3, 0.0, (half_width - 0.3) ** 2)
    assert np.all(result.lower >= exact_lower - 1e-15)
    assert np.all(result.lower - exact_lower <= 1.0 / m**2 + 1e-15)
    # the upper bound is attained at the cut bound x = -(1 - mu): exact
    np.testing.assert_allclose(result.upper, (half_width + 0.3) ** 2, rtol=1e-14)


def test_grid_influence_is_the_reduced_methods_from_its_corners():
    # a grid holds every level's cut-box corners, so its gain factors are the reduced
    # method's (Hanss); reference: the reduced plan of the same parameters
    # (THEORY.md 1 oracle: z = 2 x1 + x2 has eta = (2, 1) on every level)
    parameters = {"x1": SYMMETRIC, "x2": Triangular(-1.0, 0.0, 2.0), "x3": Triangular(1, 2, 3)}

    def model(x):
        return 2.0 * x[:, 0] + x[:, 1] + x[:, 0] * x[:, 2] ** 2

    reduced, grid = plan(parameters, "reduced", 3), plan(parameters, "grid", 3)
    expected = reduced.retransform(model(reduced.samples)).influence()
    found = grid.retransform(model(grid.samples)).influence()
    np.testing.assert_allclose(found.gain, expected.gain, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(found.relative, expected.relative, rtol=1e-12, atol=1e-12)
