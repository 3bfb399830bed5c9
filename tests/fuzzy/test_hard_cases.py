"""Hard test models: their dense-grid truth, and the cut-width scale of a band's miss."""

import numpy as np
import pytest
from scipy.optimize import minimize

from fuzzymbs.fuzzy import plan
from fuzzymbs.fuzzy.band_scale import band_miss, width_relative
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import bump3, dense_truth, hard_cases, ringing3

LEVELS = np.linspace(0.0, 1.0, 6)
# the oscillating signal's dense truth and runs take about 5 s a test: the slow suite
_SLOW = {"ringing3": pytest.mark.slow}


@pytest.mark.parametrize(
    "case", [pytest.param(c, id=c.name, marks=_SLOW.get(c.name, ())) for c in hard_cases()]
)
def test_dense_truth_is_resolved_to_a_tenth_of_a_percent_of_the_cut_width(case):
    # halving the grid's spacing moves no bound by more than 0.1 % of the cut width
    coarse = dense_truth(case, LEVELS)
    fine = dense_truth(case, LEVELS, refine=2)
    for key, (lower, upper) in coarse.items():
        assert band_miss(lower, upper, *fine[key]) <= 1e-3


def test_bump_truth_matches_a_local_optimiser():
    # second method: scipy's bounded optimiser from the bump's centre (x3 = 1 at its
    # end since z grows with x3 there); the grid's maximum lies below it by at most
    # 0.1 % of the cut width (the grid's resolution)
    case = bump3()
    model = case.model

    def negative(x):
        return -model({"x1": x[:1], "x2": x[1:2], "x3": np.ones(1)})["z"][0]

    best = minimize(negative, [0.35, -0.25], bounds=[(-1, 1), (-1, 1)])
    lower, upper = dense_truth(case, [0.0])["z"]
    width = upper[0] - lower[0]
    assert -best.fun - 1e-3 * width <= upper[0] <= -best.fun + 1e-12


def test_ringing_starts_crisp_in_phase():
    # y(0) = A: its cut at level 0 is exactly A's support [0.9, 1.1]
    lower, upper = dense_truth(ringing3(), [0.0])["y"]
    np.testing.assert_allclose([lower[0, 0], upper[0, 0]], [0.9, 1.1], rtol=1e-12)


def test_band_miss_is_the_part_of_the_true_cut_outside_on_the_width_scale():
    true_lower = np.array([[0.0, 0.0]])
    true_upper = np.array([[1.0, 10.0]])
    # element 0 misses 0.2 of a width-1 cut, floored at a tenth of the widest (10): 0.2 / 1
    # element 1 misses 1 of 10: 0.1
    lower = np.array([[0.1, 1.0]])
    upper = np.array([[0.9, 10.0]])
    assert band_miss(lower, upper, true_lower, true_upper) == pytest.approx(0.2)
    # a computed cut that holds the true one misses nothing
    assert band_miss(true_lower - 1, true_upper + 1, true_lower, true_upper) == 0.0
    # the floor: a crisp element next to a wide one is read on a tenth of the widest
    ratio = width_relative(np.array([[0.5, 0.0]]), np.zeros((1, 2)), np.array([[0.0, 10.0]]))
    assert ratio[0, 0] == pytest.approx(0.5)


def test_reduced_method_misses_the_interior_extremum():
    # the reason these cases exist: corners cannot see the bump's maximum
    case = bump3()
    scheme = plan(triangular_numbers(case.triangles), "reduced", 6)
    with pytest.warns(UserWarning):
        cut = scheme.retransform(scheme.evaluate(case.model))["z"]
    truth = dense_truth(case, scheme.levels)["z"]
    assert band_miss(cut.lower, cut.upper, *truth) > 0.05  # measured 8.5 %
