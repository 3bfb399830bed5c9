"""Inverse fuzzy arithmetic (fuzzymbs.fuzzy.inverse) against independent references.

References: linear models, whose inverse is exact and closed form (a parameter's left
and right half-widths enter the outputs' deviations with the coefficients' magnitudes,
shared/THEORY.md 1b); monotonic nonlinear models, whose measured outputs are computed
here by exhaustive corner evaluation of known fuzzy parameters (exact for monotonic
models); and round trips: the forward transformation method (fuzzymbs.plan) with the
identified parameters reproduces the measured cuts.
"""

import numpy as np
import pytest

from fuzzymbs import plan
from fuzzymbs.errors import InverseMismatchError, InverseProblemError
from fuzzymbs.fuzzy.inverse import InverseWarning, inverse
from fuzzymbs.fuzzy.numbers import PiecewiseLinear, Trapezoidal, Triangular

LEVELS = np.linspace(0.0, 1.0, 5)


def linear_model(matrix, offset):
    matrix, offset = np.asarray(matrix, float), np.asarray(offset, float)

    def model(p):
        x = np.stack([p["a"], p["b"]], axis=1)
        z = x @ matrix.T + offset
        return {f"z{k + 1}": z[:, k] for k in range(len(matrix))}

    return model


def corner_outputs(model, parameters, levels=LEVELS):
    """Exact output cuts of a monotonic model: min/max over the 2^n corners of each cut."""
    names = list(parameters)
    cuts = {name: number.cuts(levels) for name, number in parameters.items()}
    lower, upper = {}, {}
    for j in range(len(levels)):
        corners = np.array(np.meshgrid(*[cuts[n][j] for n in names], indexing="ij"))
        columns = {n: corners[i].ravel() for i, n in enumerate(names)}
        for name, values in model(columns).items():
            lower.setdefault(name, []).append(values.min())
            upper.setdefault(name, []).append(values.max())
    return {name: PiecewiseLinear(levels, lower[name], upper[name]) for name in lower}


def assert_same_cuts(identified, expected, levels=LEVELS, rtol=1e-9):
    for name, number in expected.items():
        np.testing.assert_allclose(
            identified[name].cuts(levels), number.cuts(levels), rtol=rtol, atol=0, err_msg=name
        )


@pytest.mark.parametrize(
    "matrix",
    [
        [[1.0, 1.0], [1.0, -2.0]],  # a negative gain swaps b's halves in z2
        [[3.0, 0.5], [-1.0, 4.0]],
        [[2.0, 1.0], [1.0, 3.0], [0.5, -1.0]],  # overdetermined, consistent: exact
    ],
)
def test_linear_models_are_inverted_exactly(matrix):
    truth = {"a": Triangular(1.5, 2.0, 2.25), "b": Trapezoidal(0.5, 0.9, 1.1, 1.6)}
    model = linear_model(matrix, offset=[0.3] * len(matrix))
    measured = corner_outputs(model, truth)
    result = inverse(model, measured, {"a": 1.0, "b": 1.0}, LEVELS)
    # closed form: the linear system of half-widths is exact, one Newton step per cut
    assert_same_cuts(result.parameters, truth, rtol=1e-9)
    assert result.converged and result.max_residual < 1e-9
    assert result.method == "reduced" and result.screening["nonmonotonic"] == []
    assert np.all(result.iterations <= 1)


def test_nonlinear_monotonic_model_recovered_from_corner_outputs():
    # z1 = a b (increasing in both), z2 = a / b^2 (increasing in a, decreasing in b),
    # z3 = exp(a / 4) + b (extra output: least squares, consistent)
    def model(p):
        a, b = p["a"], p["b"]
        return {"z1": a * b, "z2": a / b**2, "z3": np.exp(a / 4.0) + b}

    truth = {"a": Triangular(1.0, 2.0, 3.5), "b": Triangular(0.8, 1.0, 1.1)}
    measured = corner_outputs(model, truth)
    result = inverse(model, measured, {"a": 1.0, "b": 2.0}, LEVELS, bounds={"b": (0.1, 10)})
    # Newton iterations converge to the tolerance 1e-3 of each output's width; the
    # parameters then agree to about that relative size
    assert result.converged and result.max_residual <= 1e-3
    assert_same_cuts(result.parameters, truth, rtol=2e-3)
    assert result.modal == pytest.approx({"a": 2.0, "b": 1.0}, rel=1e-9)


def test_round_trip_through_the_forward_transformation_method():
    def model(p):
        return {"stiffness": p["k1"] * p["k2"] / (p["k1"] + p["k2"]), "ratio": p["k1"] / p["k2"]}

    # springs in series and their ratio, measured cuts from known spring stiffnesses
    truth = {"k1": Triangular(0.8e6, 1e6, 1.3e6), "k2": Triangular(0.9e6, 1e6, 1.05e6)}
    measured = corner_outputs(model, truth)
    result = inverse(model, measured, {"k1": 2e6, "k2": 0.5e6}, LEVELS, tolerance=1e-6)
    forward = plan(result.parameters, "reduced", LEVELS)
    outputs = forward.retransform(forward.evaluate(model))
    for name, number in measured.items():
        low, high = number.alpha_cut(0.0)
        width = high - low
        cuts = np.stack([outputs[name].lower, outputs[name].upper], axis=1)
        # the reduced method is exact for this monotonic model; tolerance 1e-6 of the width
        np.testing.assert_allclose(cuts, number.cuts(LEVELS), rtol=0, atol=2e-6 * width)
    # cuts are nested and contain the modal values
    for number in result.parameters.values():
        cuts = number.cuts(LEVELS)
        assert np.all(np.diff(cuts[:, 0]) >= 0) and np.all(np.diff(cuts[:, 1]) <= 0)


def test_nonmonotonic_parameter_is_found_and_gets_interior_points():
    # z1 = (a - 1)^2 + b is not monotonic in a over a's support around 1.2; the measured
    # outputs come from the extended transformation method with a marked non-monotonic
    def model(p):
        return {"z1": (p["a"] - 1.0) ** 2 + p["b"], "z2": p["a"] + 0.5 * p["b"]}

    truth = {"a": Triangular(0.7, 1.2, 1.5), "b": Triangular(1.8, 2.0, 2.1)}
    forward = plan(truth, "extended", LEVELS, nonmonotonic=["a"])
    outputs = forward.retransform(forward.evaluate(model))
    measured = {
        name: PiecewiseLinear(LEVELS, outputs[name].lower, outputs[name].upper)
        for name in ("z1", "z2")
    }
    result = inverse(model, measured, {"a": 1.1, "b": 2.0}, LEVELS, tolerance=1e-4)
    assert result.nonmonotonic == ("a",) and result.method == "extended"
    assert result.converged
    check = plan(result.parameters, "extended", LEVELS, nonmonotonic=["a"])
    again = check.retransform(check.evaluate(model))
    for name in measured:
        low, high = measured[name].alpha_cut(0.0)
        width = high - low
        np.testing.assert_allclose(again[name].lower, outputs[name].lower, atol=1e-3 * width)
        np.testing.assert_allclose(again[name].upper, outputs[name].upper, atol=1e-3 * width)


def test_inconsistent_measurements_raise_with_the_residual():
    # z1 = a and z2 = 2 a: a spread of +-1 in z1 asks for +-2 in z2, not +-0.5
    def model(p):
        return {"z1": p["a"], "z2": 2.0 * p["a"]}

    measured = {"z1": Triangular(0.0, 1.0, 2.0), "z2": Triangular(1.5, 2.0, 2.5)}
    with pytest.raises(InverseMismatchError, match="cannot reproduce the measured") as raised:
        inverse(model, measured, {"a": 1.0}, LEVELS)
    best = raised.value.result
    assert not best.converged and best.max_residual > 0.1
    assert "at output" in str(raised.value) and "forward" in str(raised.value)
    with pytest.warns(InverseWarning):
        returned = inverse(model, measured, {"a": 1.0}, LEVELS, on_mismatch="warn")
    assert not returned.converged
    assert returned.residual["z1"].shape == (len(LEVELS), 2)


def test_measurements_that_need_a_negative_half_width_are_a_mismatch():
    # springs in series and their ratio: these spreads would need k1's lower half-width
    # below zero (found with on_mismatch="warn": 7e-4 of the width is the best fit)
    def model(p):
        return {"stiffness": p["k1"] * p["k2"] / (p["k1"] + p["k2"]), "ratio": p["k1"] / p["k2"]}

    measured = {"stiffness": Triangular(0.9e6, 1.0e6, 1.15e6), "ratio": Triangular(0.8, 1.0, 1.3)}
    with pytest.raises(InverseMismatchError, match="at output 'ratio', mu = 0, lower bound"):
        inverse(model, measured, {"k1": 1e6, "k2": 1e6}, LEVELS, tolerance=1e-4)


def test_uncertainty_beyond_the_bounds_is_a_mismatch():
    # a stiffness must stay positive: an output spread that needs a < 0 cannot be produced
    def model(p):
        return {"z": 1.0 / p["a"]}

    with pytest.raises(InverseMismatchError):
        inverse(model, {"z": Triangular(0.2, 1.0, 1.2)}, {"a": 1.0}, 2, bounds={"a": (0.9, 5)})


@pytest.mark.parametrize(
    ("arguments", "fragment"),
    [
        ({"measured": {"z1": Triangular(0, 1, 2)}}, "underdetermined: 1 measured output(s)"),
        ({"measured": {"z1": 1.0, "z2": Triangular(0, 1, 2)}}, "'z1' is a float, not a fuzzy"),
        ({"measured": {}}, "measured must be a non-empty mapping"),
        ({"modal": {"a": float("nan"), "b": 1.0}}, "modal start value of 'a' must be finite"),
        ({"modal": {"a": "x", "b": 1.0}}, "modal start value of 'a' must be a number"),
        ({"bounds": {"c": (0, 1)}}, "bounds name an unknown parameter 'c'"),
        ({"bounds": {"a": (2, 1)}}, "bounds of 'a' need lower < upper"),
        ({"bounds": {"a": (5, 6)}}, "modal start value 1.0 of 'a' lies outside its bounds"),
        ({"nonmonotonic": ["c"]}, "nonmonotonic names unknown parameter(s) ['c']"),
        ({"nonmonotonic": "all"}, "nonmonotonic must be 'auto' or a list"),
        ({"tolerance": 0.0}, "tolerance must be a positive number"),
        ({"on_mismatch": "ignore"}, "on_mismatch must be 'raise' or 'warn'"),
    ],
)
def test_bad_input_names_the_problem(arguments, fragment):
    base = {
        "model": linear_model([[1.0, 1.0], [1.0, -1.0]], [0.0, 0.0]),
        "measured": {"z1": Triangular(1.5, 2.0, 2.5), "z2": Triangular(-0.5, 0.0, 0.5)},
        "modal": {"a": 1.0, "b": 1.0},
    }
    base.update(arguments)
    with pytest.raises(InverseProblemError) as raised:
        inverse(base.pop("model"), base.pop("measured"), base.pop("modal"), **base)
    assert fragment in str(raised.value)
    assert isinstance(raised.value, ValueError)


def test_model_problems_are_named():
    measured = {"z1": Triangular(1.5, 2.0, 2.5), "z2": Triangular(-0.5, 0.0, 0.5)}
    start = {"a": 1.0, "b": 1.0}

    def signal(p):
        return {"z1": np.ones((len(p["a"]), 7)), "z2": p["b"]}

    with pytest.raises(InverseProblemError, match="needs scalar outputs"):
        inverse(signal, measured, start)
    with pytest.raises(InverseProblemError, match="returns no output 'z2'"):
        inverse(lambda p: {"z1": p["a"]}, measured, start)

    def fails(p):
        return {"z1": p["a"], "z2": np.full_like(p["a"], np.nan)}

    with pytest.raises(InverseProblemError, match=r"modal \(crisp\) solution failed.*model failed"):
        inverse(fails, measured, start)

    def raises(p):
        raise RuntimeError("licence server down")

    with pytest.raises(InverseProblemError, match="licence server down"):
        inverse(raises, measured, start)


def test_evaluations_are_counted_and_batched():
    calls = []
    model = linear_model([[1.0, 1.0], [1.0, -2.0]], [0.0, 0.0])

    def counted(p):
        calls.append(len(p["a"]))
        return model(p)

    truth = {"a": Triangular(1.5, 2.0, 2.25), "b": Triangular(0.75, 1.0, 1.5)}
    result = inverse(counted, corner_outputs(model, truth), {"a": 1.0, "b": 1.0}, LEVELS)
    assert result.evaluations == sum(calls)
    assert max(calls) >= 9  # a level's transformation-method points in one call (3 x 3)


def test_modal_value_at_a_bound_never_leaves_the_admissible_range():
    # the model is undefined below a = 1; a's modal value sits on that bound, so its cuts
    # can only grow upwards (closed form: z1 = a + b, z2 = a - b -> a in [1, 1.4])
    def model(p):
        if np.any(p["a"] < 1.0):
            raise ValueError("a below 1")
        return {"z1": p["a"] + p["b"], "z2": p["a"] - p["b"]}

    measured = {"z1": Triangular(2.0, 2.0, 2.6), "z2": Triangular(-0.2, 0.0, 0.4)}
    result = inverse(model, measured, {"a": 1.0, "b": 1.0}, 2, bounds={"a": (1.0, 5.0)})
    np.testing.assert_allclose(result.parameters["a"].alpha_cut(0.0), (1.0, 1.4), atol=1e-9)
    np.testing.assert_allclose(result.parameters["b"].alpha_cut(0.0), (1.0, 1.2), atol=1e-9)
