"""Monotonicity screening: sample layout and decisions against closed-form functions."""

import numpy as np
import pytest

from fuzzymbs.errors import IncompleteResultError, InvalidPlanError, ModelOutputError
from fuzzymbs.fuzzy import NonMonotonicWarning, Trapezoidal, Triangular, plan
from fuzzymbs.fuzzy.screening import (
    ScreeningWarning,
    nonmonotonic_parameters,
    screening_samples,
)


def axis_values(screening, name):
    i = screening.names.index(name)
    return screening.samples[screening.axes[i], i]


def test_triangular_axes_hold_every_cut_bound_and_the_modal_value():
    # TFN(1, 2, 3) at mu = 0, .25, .5, .75, 1: cuts [1 + mu/... ] -> bounds 1, 1.25, ..., 3
    screening = screening_samples({"a": Triangular(1, 2, 3), "b": Triangular(10, 20, 30)}, 4)
    assert screening.names == ("a", "b")
    assert screening.samples.shape == (2 * 2 * 4 + 1, 2)  # n 2m + 1
    np.testing.assert_array_equal(screening.samples[0], [2.0, 20.0])
    np.testing.assert_array_equal(axis_values(screening, "a"), np.linspace(1, 3, 9))
    np.testing.assert_array_equal(axis_values(screening, "b"), np.linspace(10, 30, 9))
    # off its own column every axis point sits at the modal values
    np.testing.assert_array_equal(screening.samples[screening.axes[0], 1], 20.0)
    np.testing.assert_array_equal(screening.samples[screening.axes[1], 0], 2.0)
    assert 0 in screening.axes[0] and 0 in screening.axes[1]  # the shared modal point
    assert len(np.unique(screening.samples, axis=0)) == len(screening.samples)


def test_trapezoidal_axis_includes_core_bounds_and_the_plans_modal_point():
    # support [0, 4], core [1, 3]: cuts at mu = 0, .5, 1 are [0, 4], [.5, 3.5], [1, 3];
    # the plan's all-modal point takes the core midpoint 2
    numbers = {"t": Trapezoidal(0, 1, 3, 4), "c": Triangular(5, 6, 8)}
    screening = screening_samples(numbers, [0, 0.5, 1])
    np.testing.assert_array_equal(axis_values(screening, "t"), [0, 0.5, 1, 2, 3, 3.5, 4])
    reference = plan(numbers, "reduced", [0, 0.5, 1])
    np.testing.assert_array_equal(screening.samples[0], reference.samples[reference.nominal_index])


def test_bad_parameters_and_levels_are_named():
    with pytest.raises(InvalidPlanError, match="non-empty mapping"):
        screening_samples({}, 4)
    with pytest.raises(InvalidPlanError, match="'a' must be a FuzzyNumber"):
        screening_samples({"a": 1.0}, 4)
    with pytest.raises(InvalidPlanError, match="levels"):
        screening_samples({"a": Triangular(1, 2, 3)}, 0)


def evaluate(screening, function):
    columns = {name: screening.samples[:, i] for i, name in enumerate(screening.names)}
    return function(**columns)


def test_shifted_square_is_nonmonotonic_only_when_the_cut_contains_its_minimum():
    # z = (x1 - 2)^2 + x2. x1 = TFN(1, 2.5, 4) contains 2, x2 = TFN(0, 1, 2) enters linearly.
    screening = screening_samples({"x1": Triangular(1, 2.5, 4), "x2": Triangular(0, 1, 2)}, 4)
    z = evaluate(screening, lambda x1, x2: (x1 - 2) ** 2 + x2)
    report = nonmonotonic_parameters(screening, {"z": z})
    assert report["nonmonotonic"] == ["x1"]
    assert report["runs"] == 17 and report["excluded_samples"] == []
    # closed form of the reported reversal: x1-axis points 1, 1.375, ..., 4 with x2 = 1;
    # min (x1-2)^2 at 2.125 is 1/64, so the response falls 1 - 1/64 and rises 4 - 1/64;
    # the range over all points is 5 (x1 = 4) - 0.25 (x1 = 2.5, x2 = 0) = 4.75
    entry = report["parameters"]["x1"]
    assert entry["output"] == "z" and entry["index"] == [] and entry["elements"] == 1
    assert entry["violation"] == pytest.approx((1 - 1 / 64) / 4.75, rel=1e-14)
    assert report["parameters"]["x2"] == {
        "nonmonotonic": False,
        "points": 9,
        "excluded_points": 0,
        "elements": 0,
        "violation": 0.0,
        "output": None,
        "index": None,
    }
    # a cut right of the minimum: monotonic in both
    right = screening_samples({"x1": Triangular(2.5, 3, 4), "x2": Triangular(0, 1, 2)}, 4)
    z = evaluate(right, lambda x1, x2: (x1 - 2) ** 2 + x2)
    assert nonmonotonic_parameters(right, {"z": z})["nonmonotonic"] == []


def test_sine_across_its_maximum():
    # sin has its maximum at pi/2 = 1.5708: inside TFN(1, 1.5, 2.5), outside TFN(0, 0.5, 1.2)
    across = screening_samples({"x": Triangular(1, 1.5, 2.5)}, 4)
    assert nonmonotonic_parameters(across, {"z": np.sin(across.samples[:, 0])})["nonmonotonic"] == [
        "x"
    ]
    below = screening_samples({"x": Triangular(0, 0.5, 1.2)}, 4)
    assert nonmonotonic_parameters(below, {"z": np.sin(below.samples[:, 0])})["nonmonotonic"] == []


def test_monotonic_product_and_flat_outputs():
    numbers = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11), "x3": Triangular(-1, 0, 1)}
    screening = screening_samples(numbers, 4)
    x1, x2, _ = screening.samples.T
    outputs = {
        "product": x1 * x2,  # increasing in both (positive factors), constant in x3
        "constant": np.full(len(x1), 3.0),
        "zero": np.zeros(len(x1)),
        # flat up to round-off: 1 + a few ulps of noise (the roundoff floor ignores it)
        "noisy_one": 1.0 + 4e-16 * np.random.default_rng(0).standard_normal(len(x1)),
    }
    report = nonmonotonic_parameters(screening, outputs)
    assert report["nonmonotonic"] == []
    assert all(entry["violation"] == 0.0 for entry in report["parameters"].values())


def test_reversals_below_rtol_are_ignored_and_above_are_found():
    screening = screening_samples({"x": Triangular(1, 2, 3)}, 4)
    x = screening.samples[:, 0]
    # rises to a plateau at x >= 2 that carries noise of 1e-9 (range 1: 1e-9 relative)
    noise = 1e-9 * np.random.default_rng(1).standard_normal(len(x))
    plateau = np.minimum(x, 2.0) + np.where(x >= 2.0, noise, 0.0)
    assert nonmonotonic_parameters(screening, {"z": plateau})["nonmonotonic"] == []
    assert nonmonotonic_parameters(screening, {"z": plateau}, rtol=1e-12)["nonmonotonic"] == ["x"]
    # a rising line whose last step (2.75 -> 3) falls back by 2e-8 instead
    falling_back = np.where(x == 3.0, 2.75 - 2e-8, x)
    assert nonmonotonic_parameters(screening, {"z": falling_back})["nonmonotonic"] == []
    strict = nonmonotonic_parameters(screening, {"z": falling_back}, rtol=1e-9)
    assert strict["nonmonotonic"] == ["x"]
    # reversal min(fall 2e-8, rise 1.75) relative to the range 2.75 - 1
    assert strict["parameters"]["x"]["violation"] == pytest.approx(2e-8 / 1.75, rel=1e-7)


def test_time_signal_with_one_nonmonotonic_element():
    # z(t) = x1 t + x2 for every time step but t[3], where z = (x1 - 2)^2 + x2
    numbers = {"x1": Triangular(1, 2.5, 4), "x2": Triangular(0, 1, 2)}
    screening = screening_samples(numbers, 2)
    x1, x2 = screening.samples[:, :1], screening.samples[:, 1:]
    t = np.linspace(0.0, 1.0, 6)
    signal = x1 * t + x2
    signal[:, 3] = (x1[:, 0] - 2) ** 2 + x2[:, 0]
    grid = np.stack([signal, 2 * signal], axis=1)  # (k, 2, 6): a second element dimension
    report = nonmonotonic_parameters(screening, {"signal": signal, "grid": grid})
    assert report["nonmonotonic"] == ["x1"]
    entry = report["parameters"]["x1"]
    assert entry["elements"] == 3  # signal[3], grid[0, 3], grid[1, 3]
    assert entry["output"] == "signal" and entry["index"] == [3]  # first of equal violations
    only_grid = nonmonotonic_parameters(screening, {"grid": grid})["parameters"]["x1"]
    assert only_grid["index"] == [0, 3]
    # without the odd time step nothing reverses
    signal[:, 3] = x1[:, 0] * t[3] + x2[:, 0]
    assert nonmonotonic_parameters(screening, {"signal": signal})["nonmonotonic"] == []


def test_failed_samples_are_excluded_and_reported():
    screening = screening_samples({"x1": Triangular(1, 2.5, 4), "x2": Triangular(0, 1, 2)}, 4)
    z = evaluate(screening, lambda x1, x2: (x1 - 2) ** 2 + x2)
    lost = int(screening.axes[0][0])  # x1 = 1
    z[lost] = np.nan
    with pytest.warns(ScreeningWarning, match=rf"1 of 17 screening samples failed.*\[{lost}\]"):
        report = nonmonotonic_parameters(screening, {"z": z})
    assert report["nonmonotonic"] == ["x1"]  # x1 = 1.375 still lies left of the minimum
    assert report["excluded_samples"] == [lost]
    assert report["parameters"]["x1"]["excluded_points"] == 1
    assert report["parameters"]["x1"]["points"] == 8
    # a failure flagged by mask is excluded as well, even with finite values
    failed = np.zeros(len(z), dtype=bool)
    failed[int(screening.axes[0][1])] = True
    z[lost] = 1.0
    with pytest.warns(ScreeningWarning):
        report = nonmonotonic_parameters(screening, {"z": z}, failed=failed)
    assert report["excluded_samples"] == [int(screening.axes[0][1])]


def test_too_few_valid_points_on_an_axis_is_an_error():
    # levels = 1: each axis is (lower, modal, upper); losing one leaves 2 points
    screening = screening_samples({"x1": Triangular(1, 2, 3), "x2": Triangular(0, 1, 2)}, 1)
    z = screening.samples.sum(axis=1)
    z[screening.axes[1][2]] = np.inf
    with (
        pytest.warns(ScreeningWarning),
        pytest.raises(IncompleteResultError, match=r"parameter 'x2'.*leaving 2.*at least 3"),
    ):
        nonmonotonic_parameters(screening, {"z": z})
    with pytest.raises(IncompleteResultError, match="all 5 screening samples failed"):
        nonmonotonic_parameters(screening, {"z": np.full(5, np.nan)})


def test_bad_outputs_and_settings_are_named():
    screening = screening_samples({"x": Triangular(1, 2, 3)}, 1)
    with pytest.raises(ModelOutputError, match=r"'z' must have leading axis k=3"):
        nonmonotonic_parameters(screening, {"z": np.zeros(4)})
    with pytest.raises(ModelOutputError, match="non-empty dict"):
        nonmonotonic_parameters(screening, {})
    with pytest.raises(ModelOutputError, match="numeric"):
        nonmonotonic_parameters(screening, {"z": np.array(["a", "b", "c"])})
    with pytest.raises(InvalidPlanError, match="rtol must be a finite number >= 0"):
        nonmonotonic_parameters(screening, {"z": np.zeros(3)}, rtol=-1.0)
    with pytest.raises(InvalidPlanError, match="failed must be a bool array of shape"):
        nonmonotonic_parameters(screening, {"z": np.zeros(3)}, failed=[0, 1, 0])


def test_extended_with_detected_names_matches_general_where_reduced_is_too_narrow():
    # z = (x1 - 2)^2 + sin(x2) + x3: non-monotonic in x1 (minimum at 2 inside [0, 4]) and
    # x2 (maximum at pi/2 inside [1, 2.5]), linear in x3. The sum is separable and monotonic
    # in x3, so extended (general points for x1, x2; corners for x3) and general (general
    # points for all) take their min/max over the same values: equal up to round-off.
    numbers = {
        "x1": Triangular(0, 2, 4),
        "x2": Triangular(1, 1.5, 2.5),
        "x3": Triangular(0, 1, 2),
    }

    def model(samples):
        return {"z": (samples["x1"] - 2) ** 2 + np.sin(samples["x2"]) + samples["x3"]}

    screening = screening_samples(numbers, 4)
    columns = {name: screening.samples[:, i] for i, name in enumerate(screening.names)}
    detected = nonmonotonic_parameters(screening, model(columns))["nonmonotonic"]
    assert detected == ["x1", "x2"]

    results = {}
    for method, names in (("extended", detected), ("general", None), ("reduced", None)):
        p = plan(numbers, method, 4, nonmonotonic=names)
        results[method] = p.retransform(p.evaluate(model)["z"], check_monotonic=False)
    extended, general, reduced = results["extended"], results["general"], results["reduced"]
    np.testing.assert_allclose(extended.lower, general.lower, rtol=0, atol=1e-12)
    np.testing.assert_allclose(extended.upper, general.upper, rtol=0, atol=1e-12)
    assert len(plan(numbers, "extended", 4, nonmonotonic=detected)) < len(
        plan(numbers, "general", 4)
    )
    # closed form at mu = 0: min = 0 + sin(2.5) + 0 (x1 = 2, x2 = 2.5 as sin(2.5) < sin(1),
    # x3 = 0); the general points at mu = 0 include x1 = 2 and the support bounds
    assert general.lower[0] == pytest.approx(np.sin(2.5), abs=1e-14)
    # the reduced corners miss x1 = 2 and x2 near pi/2: the mu = 0 cut is too narrow
    assert reduced.lower[0] > general.lower[0] + 0.5
    assert reduced.upper[0] < general.upper[0] - 1e-3


def test_documented_limit_off_axis_reversal_is_missed_but_warned_after_the_fact():
    # z = x2 (1 - 4 (x1 - 1)^2), x1 = TFN(0, 1, 2), x2 = TFN(0, 0, 1): at the modal x2 = 0
    # the x1 axis is flat and at the modal x1 = 1 the x2 axis is linear, so the screening
    # sees nothing; off the axes (x2 = 1) z has an interior maximum 1 at x1 = 1 that the
    # corners (z = -3 or 0) miss. Closed form at mu = 0: max z = 1. (docs/fuzzy.md)
    numbers = {"x1": Triangular(0, 1, 2), "x2": Triangular(0, 0, 1)}

    def model(samples):
        return {"z": samples["x2"] * (1 - 4 * (samples["x1"] - 1) ** 2)}

    screening = screening_samples(numbers, 4)
    columns = {name: screening.samples[:, i] for i, name in enumerate(screening.names)}
    assert nonmonotonic_parameters(screening, model(columns))["nonmonotonic"] == []
    extended = plan(numbers, "extended", 4, nonmonotonic=[])
    with pytest.warns(NonMonotonicWarning, match="not monotonic in every parameter"):
        narrow = extended.retransform(extended.evaluate(model)["z"])
    # nested corner maximum: mu = 0.75 corner x1 = 0.75 or 1.25, x2 = 0.25: 0.25 (1 - 0.25)
    assert narrow.upper[0] == pytest.approx(0.1875, abs=1e-15)
    general = plan(numbers, "general", 4)
    assert general.retransform(general.evaluate(model)["z"]).upper[0] == pytest.approx(1.0)
