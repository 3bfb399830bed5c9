"""Gain factors and influence measures against closed forms (THEORY.md section 1)."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.fuzzy.transform import plan

MU = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
SYMMETRIC = Triangular(-1.0, 0.0, 1.0)


def _influence(parameters, model, method="reduced", weights="membership", **kwargs):
    p = plan(parameters, method, 4, **kwargs)
    return p.retransform(model(p.sample_columns())).influence(weights)


@pytest.mark.parametrize("method", ["reduced", "extended"])
def test_linear_oracle_gain_and_relative(method):
    # THEORY.md oracle: z = 2 x1 + x2, x1, x2 = TFN(-1,0,1): eta = (2, 1) on every level,
    # rho = (2/3, 1/3)
    extra = {"nonmonotonic": ["x2"]} if method == "extended" else {}
    inf = _influence(
        {"x1": SYMMETRIC, "x2": SYMMETRIC}, lambda s: 2 * s["x1"] + s["x2"], method, **extra
    )
    np.testing.assert_allclose(inf.gain[:, :4], [[2.0] * 4, [1.0] * 4], rtol=1e-15)
    # zero-width core cut: gain undefined (0/0), reported as NaN (docs/theory.md)
    assert np.isnan(inf.gain[:, 4]).all()
    np.testing.assert_allclose(inf.mean_gain, [2.0, 1.0], rtol=1e-15)
    np.testing.assert_allclose(inf.relative, [2 / 3, 1 / 3], rtol=1e-15)
    # Derived: kappa_1 = sum mu_j 2 * 2(1 - mu_j) / sum mu_j = 4 * 0.625 / 2.5 = 1.0
    np.testing.assert_allclose(inf.absolute, [1.0, 0.5], rtol=1e-15)


def test_linear_oracle_uniform_and_explicit_weights():
    # Derived: uniform w: kappa_1 = sum_j 2 * 2 (1 - mu_j) / 5 = 4 * 2.5 / 5 = 2
    model = lambda s: 2 * s["x1"] + s["x2"]  # noqa: E731
    parameters = {"x1": SYMMETRIC, "x2": SYMMETRIC}
    uniform = _influence(parameters, model, weights="uniform")
    np.testing.assert_allclose(uniform.absolute, [2.0, 1.0], rtol=1e-15)
    np.testing.assert_array_equal(uniform.weights, np.ones(5))
    # only level 0 weighted: kappa_1 = 2 * 2 = 4 (the support width times the gain)
    support_only = _influence(parameters, model, weights=[1, 0, 0, 0, 0])
    np.testing.assert_allclose(support_only.absolute, [4.0, 2.0], rtol=1e-15)
    np.testing.assert_allclose(support_only.mean_gain, [2.0, 1.0], rtol=1e-15)


def test_product_oracle_gain():
    # THEORY.md oracle: z = x1 x2, x1 = TFN(1,2,3), x2 = TFN(9,10,11): eta = (10, 2)
    # (pairs average the other parameter's two bounds, which are symmetric about its mode)
    inf = _influence(
        {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}, lambda s: s["x1"] * s["x2"]
    )
    np.testing.assert_allclose(inf.gain[:, :4], [[10.0] * 4, [2.0] * 4], rtol=1e-14)
    np.testing.assert_allclose(inf.mean_gain, [10.0, 2.0], rtol=1e-14)


def test_asymmetric_product_level_dependent_gain():
    # Derived: x1 = TFN(1,2,4) has cuts [1 + mu, 4 - 2 mu]; for z = x1 x2 the gain of x2 at
    # level j is the mean of x1's bounds, (5 - mu_j)/2; the gain of x1 is x2's mean, 10.
    # Mean gain with mu-weights over the levels j < m (level m has zero width).
    inf = _influence(
        {"x1": Triangular(1, 2, 4), "x2": Triangular(9, 10, 11)}, lambda s: s["x1"] * s["x2"]
    )
    np.testing.assert_allclose(inf.gain[1, :4], (5 - MU[:4]) / 2, rtol=1e-14)
    np.testing.assert_allclose(inf.gain[0, :4], 10.0, rtol=1e-14)
    expected = np.sum(MU[:4] * (5 - MU[:4]) / 2) / np.sum(MU[:4])
    assert inf.mean_gain[1] == pytest.approx(expected, rel=1e-14)


def test_three_parameter_linear_gains_are_coefficients():
    # a linear model's gains are its coefficients at every level (checks the corner pairing
    # for n = 3 with distinct coefficients and unequal widths)
    coefficients = np.array([3.0, -0.5, 7.25])
    parameters = {
        "a": Triangular(0.0, 1.0, 3.0),
        "b": Triangular(-2.0, 0.0, 0.5),
        "c": Triangular(10.0, 10.5, 11.0),
    }
    inf = _influence(parameters, lambda s: 3.0 * s["a"] - 0.5 * s["b"] + 7.25 * s["c"])
    np.testing.assert_allclose(inf.gain[:, :4], np.repeat(coefficients[:, None], 4, 1), rtol=1e-12)
    # rho_i proportional to |coefficient_i| * support-weighted width; widths scale as (1 - mu)
    widths = np.array([3.0, 2.5, 1.0])
    kappa = np.abs(coefficients) * widths
    np.testing.assert_allclose(inf.relative, kappa / kappa.sum(), rtol=1e-12)


def test_time_resolved_influence():
    # Derived: z(t) = a sin t + b with a = TFN(1,2,3), b = TFN(-1,0,1): eta_a = sin t,
    # eta_b = 1 at every level and equal widths, so rho_a(t) = |sin t| / (|sin t| + 1)
    t = np.linspace(0.0, 2 * np.pi, 33)
    inf = _influence(
        {"a": Triangular(1, 2, 3), "b": SYMMETRIC},
        lambda s: s["a"][:, None] * np.sin(t) + s["b"][:, None],
    )
    assert inf.gain.shape == (2, 5, 33)
    np.testing.assert_allclose(inf.gain[0, :4], np.tile(np.sin(t), (4, 1)), atol=1e-14)
    sin = np.abs(np.sin(t))
    np.testing.assert_allclose(inf.relative[0], sin / (sin + 1), atol=1e-14)
    np.testing.assert_allclose(inf.relative.sum(axis=0), 1.0, rtol=1e-14)
    dataset = inf.to_xarray("z", dims=["time"], coords={"time": t})
    assert dataset["z_gain"].dims == ("parameter", "level", "time")
    assert dataset["z_relative_influence"].dims == ("parameter", "time")
    assert list(dataset["parameter"].values) == ["a", "b"]


def test_constant_output_zero_over_zero_gives_zero():
    # every kappa is 0: rho is defined as 0 (not NaN) for all parameters (docs/theory.md)
    inf = _influence({"a": SYMMETRIC, "b": SYMMETRIC}, lambda s: 0.0 * s["a"] + 5.0)
    np.testing.assert_array_equal(inf.relative, [0.0, 0.0])
    np.testing.assert_array_equal(inf.absolute, [0.0, 0.0])


def test_failed_corner_gives_nan_not_an_average():
    p = plan({"a": SYMMETRIC, "b": SYMMETRIC}, "reduced", 4)
    z = p.samples @ np.array([2.0, 1.0])
    failed = np.zeros(len(p), dtype=bool)
    failed[p.corner_index[1, 2]] = True
    z[failed] = np.nan
    inf = p.retransform(z, failed).influence()
    assert np.isnan(inf.gain[:, 1]).all()
    np.testing.assert_allclose(inf.gain[:, 2:4], [[2.0, 2.0], [1.0, 1.0]])
    assert np.isnan(inf.mean_gain).all() and np.isnan(inf.relative).all()


@pytest.mark.parametrize(
    ("weights", "fragment"),
    [
        ("linear", "membership"),
        ([1.0, 1.0], "one value per level"),
        ([0, 0, 0, 0, 0], "not all zero"),
        ([1, -1, 1, 1, 1], ">= 0"),
        ([1, np.nan, 1, 1, 1], "finite"),
        (["a"] * 5, "numbers"),
    ],
)
def test_bad_weights(weights, fragment):
    p = plan({"a": SYMMETRIC}, "reduced", 4)
    result = p.retransform(p.samples[:, 0].copy())
    with pytest.raises(InvalidParameterError, match=fragment):
        result.influence(weights)
