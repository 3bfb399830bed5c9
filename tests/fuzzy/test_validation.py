"""Validation points and excursions of a transformation-method plan (fuzzy engine)."""

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy import plan
from fuzzymbs.fuzzy.validation import default_validation_count, excursions, validation_points

NUMBERS = {"x1": Triangular(-1, 0, 1), "x2": Triangular(-1, 0, 1), "x3": Triangular(0, 1, 2)}


def valley(samples):
    """z = (x1 - x2 / 2)^2 + x3 / 2: a valley inside the box that the corners straddle."""
    return {"z": (samples["x1"] - 0.5 * samples["x2"]) ** 2 + 0.5 * samples["x3"]}


def test_default_count_is_a_fifth_or_n_plus_one():
    # the rule: a fifth of the runs for studies of 30 runs or more, else n + 1
    assert default_validation_count(33, 3) == 6
    assert default_validation_count(189, 3) == 37
    assert default_validation_count(17, 2) == 3
    assert default_validation_count(30, 9) == 10  # never fewer than n + 1


def test_points_lie_in_the_box_of_their_level_and_are_reproducible():
    scheme = plan(NUMBERS, "reduced", 4)
    points = validation_points(scheme, 40)
    again = validation_points(scheme, 40)
    np.testing.assert_array_equal(points.samples, again.samples)
    assert points.samples.shape == (40, 3) and set(points.kind) == {"halton"}
    cuts = np.stack([NUMBERS[n].cuts(scheme.levels) for n in scheme.names], axis=1)
    for sample, level in zip(points.samples, points.level, strict=True):
        assert np.all(sample >= cuts[level, :, 0]) and np.all(sample <= cuts[level, :, 1])
        if level + 1 < len(scheme.levels):  # the highest such level
            inside_next = (sample >= cuts[level + 1, :, 0]) & (sample <= cuts[level + 1, :, 1])
            assert not inside_next.all()
    # space filling: inner boxes get points in proportion to their volume (some, not all)
    assert 0 < np.count_nonzero(points.level > 0) < 40


def test_edge_probes_start_from_the_runs_that_bound_the_cuts():
    scheme = plan(NUMBERS, "reduced", 4)
    outputs = scheme.evaluate(valley)
    points = validation_points(scheme, 6, outputs)
    assert list(points.kind) == ["edge"] * 3 + ["halton"] * 3
    # level 0's smallest corner value (x1 - x2/2)^2 = 1/4 is at x1 = x2 = -1 (first of
    # the two); its first probe moves x1 half-way to 0: the valley floor, z = 0
    np.testing.assert_allclose(points.samples[0], [-0.5, -1.0, 0.0])
    assert valley({k: points.samples[:1, i] for i, k in enumerate(NUMBERS)})["z"][0] == 0.0


def test_count_is_checked():
    scheme = plan(NUMBERS, "reduced", 2)
    assert len(validation_points(scheme, 0)) == 0
    for bad in (-1, 2.5, True):
        with pytest.raises(InvalidPlanError, match="validation runs"):
            validation_points(scheme, bad)


def test_excursions_against_hand_values():
    # cuts of two levels: [0, 10] and [2, 4]; points checked at level 0 and 1
    lower = np.array([0.0, 2.0])
    upper = np.array([10.0, 4.0])
    values = np.array([11.0, 3.0, 1.0, np.nan])
    level = np.array([0, 1, 1, 1])
    # 1 beyond a width of 10; inside; 1 below a width of 2; failed
    np.testing.assert_allclose(
        excursions(lower, upper, values, level), [0.1, 0.0, 0.5, np.nan], equal_nan=True
    )
    # elements where every run agrees (width 0) do not turn round-off into ratios
    signal = excursions(
        np.array([[0.0, 0.0]]), np.array([[0.0, 2.0]]), np.array([[1e-20, 3.0]]), np.array([0])
    )
    assert signal[0, 0] < 1e-9 and signal[0, 1] == pytest.approx(0.5)
