"""Property tests (hypothesis) of the fuzzy engine.

References: nesting is the retransformation's defining property (Hanss 2002); for models
monotonic in every parameter the cut bounds are attained at box corners, so the reduced
method is exact and the closed forms below hold; interval arithmetic is exact for
expressions in which every variable occurs once (Moore), giving a second method.
"""

import warnings

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from fuzzymbs.fuzzy.numbers import Gaussian, Trapezoidal, Triangular
from fuzzymbs.fuzzy.transform import NonMonotonicWarning, plan

SETTINGS = settings(max_examples=40, deadline=None)
finite = st.floats(-100.0, 100.0, allow_nan=False, allow_infinity=False)
positive = st.floats(0.01, 100.0, allow_nan=False, allow_infinity=False)


@st.composite
def triangular(draw, low=finite):
    values = sorted(draw(st.lists(low, min_size=3, max_size=3)))
    return Triangular(*values)


@st.composite
def fuzzy_number(draw):
    kind = draw(st.sampled_from(["triangular", "trapezoidal", "gaussian"]))
    if kind == "triangular":
        return draw(triangular())
    if kind == "trapezoidal":
        return Trapezoidal(*sorted(draw(st.lists(finite, min_size=4, max_size=4))))
    return Gaussian(draw(finite), draw(positive), draw(st.floats(0.5, 4.0)))


@st.composite
def positive_triangular(draw):
    values = sorted(draw(st.lists(positive, min_size=3, max_size=3)))
    return Triangular(*values)


levels_strategy = st.one_of(
    st.integers(1, 5),
    st.lists(st.floats(0.01, 0.99), min_size=0, max_size=4, unique=True).map(
        lambda inner: [0.0, *sorted(inner), 1.0]
    ),
)


@SETTINGS
@given(
    numbers=st.lists(fuzzy_number(), min_size=1, max_size=3),
    method=st.sampled_from(["general", "reduced", "extended", "grid"]),
    levels=levels_strategy,
    coefficients=st.lists(st.floats(-3.0, 3.0), min_size=4, max_size=4),
)
def test_results_nested_for_any_model(numbers, method, levels, coefficients):
    parameters = {f"p{i}": number for i, number in enumerate(numbers)}
    extra = {"nonmonotonic": ["p0"]} if method == "extended" else {}
    p = plan(parameters, method, levels, **extra)
    x = p.samples
    c = coefficients
    # a non-monotonic model with a time-like trailing axis
    t = np.linspace(0.0, 1.0, 3)
    z = c[0] * np.sin(x[:, :1] * t) + c[1] * x[:, :1] ** 2 + c[2] * x.sum(axis=1, keepdims=True)
    z = z + c[3] * np.cos(x[:, -1:])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonMonotonicWarning)
        result = p.retransform(z)
    assert np.all(np.diff(result.lower, axis=0) >= 0.0)
    assert np.all(np.diff(result.upper, axis=0) <= 0.0)
    assert np.all(result.lower <= result.upper)
    # the nominal run lies in the core cut; every sample's output in the support cut
    assert np.all(result.lower[-1] <= result.nominal) and np.all(result.nominal <= result.upper[-1])
    assert np.all(z >= result.lower[0]) and np.all(z <= result.upper[0])
    # inner approximation: each bound is the output of a sample inside that level's cut box
    for j in range(len(p.levels)):
        inside = np.all((x >= p.cut_lower[j]) & (x <= p.cut_upper[j]), axis=1)
        assert np.all(np.any(z[inside] == result.lower[j], axis=0))
        assert np.all(np.any(z[inside] == result.upper[j], axis=0))


@SETTINGS
@given(
    numbers=st.lists(triangular(), min_size=1, max_size=4),
    coefficients=st.lists(st.floats(0.0, 10.0), min_size=4, max_size=4),
    levels=st.integers(1, 5),
)
def test_reduced_exact_for_positive_linear(numbers, coefficients, levels):
    # increasing in every parameter: cut = [sum c_i a_i^(j), sum c_i b_i^(j)]
    parameters = {f"p{i}": number for i, number in enumerate(numbers)}
    c = np.array(coefficients[: len(numbers)])
    p = plan(parameters, "reduced", levels)
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonMonotonicWarning)  # monotone: must not warn
        result = p.retransform(p.samples @ c)
    scale = 1e-12 * (1.0 + np.abs(p.cut_lower).max() + np.abs(p.cut_upper).max()) * (1 + c.sum())
    np.testing.assert_allclose(result.lower, p.cut_lower @ c, atol=scale)
    np.testing.assert_allclose(result.upper, p.cut_upper @ c, atol=scale)
    influence = result.influence()
    total = influence.relative.sum()
    assert total == 0.0 or abs(total - 1.0) < 1e-12


@SETTINGS
@given(
    numbers=st.lists(positive_triangular(), min_size=1, max_size=4),
    levels=st.integers(1, 5),
)
def test_reduced_exact_for_products_of_positive_inputs(numbers, levels):
    # product of positive inputs is increasing in each: cut = [prod a_i, prod b_i]
    parameters = {f"p{i}": number for i, number in enumerate(numbers)}
    p = plan(parameters, "reduced", levels)
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonMonotonicWarning)
        result = p.retransform(np.prod(p.samples, axis=1))
    np.testing.assert_allclose(result.lower, np.prod(p.cut_lower, axis=1), rtol=1e-13)
    np.testing.assert_allclose(result.upper, np.prod(p.cut_upper, axis=1), rtol=1e-13)


@SETTINGS
@given(x=positive_triangular(), y=positive_triangular(), z=triangular())
def test_interval_arithmetic_agrees_with_transformation_method(x, y, z):
    # x*y + z: each variable once, monotone for positive x, y: both methods are exact
    standard = x * y + z
    p = plan({"x": x, "y": y, "z": z}, "reduced", 4)
    s = p.sample_columns()
    result = p.retransform(s["x"] * s["y"] + s["z"])
    cuts = standard.cuts(p.levels)
    scale = 1e-12 * (1.0 + np.abs(cuts).max())
    np.testing.assert_allclose(cuts[:, 0], result.lower, atol=scale)
    np.testing.assert_allclose(cuts[:, 1], result.upper, atol=scale)


@SETTINGS
@given(number=fuzzy_number(), mu=st.floats(0.0, 1.0))
# branches one ulp wide, where the cut's formula rounds back to the support's end
# (membership 0; found by this test in a clean-clone run)
@example(number=Triangular(-100.0, -99.99999999999999, 0.0), mu=0.5)
@example(number=Triangular(0.0, 99.99999999999999, 100.0), mu=0.5)
def test_membership_of_cut_bounds_is_mu(number, mu):
    # membership is the inverse of the cut bounds (continuous branches)
    low, high = number.alpha_cut(mu)
    assert low <= high
    values = number.membership(np.array([low, high]))
    # upper semicontinuous membership: the cut bounds have membership >= mu (equal on a
    # sloped branch, 1 on a vertical one); tolerance for the Gaussian's exp/log round trip
    assert np.all(values >= mu - 1e-9)
    assert np.all(values <= 1.0)
