"""The first-order (KKT) check of the adaptive method's extrema (fuzzymbs.fuzzy.first_order)."""

import numpy as np
import pytest

from fuzzymbs.fuzzy.adaptive import AdaptiveTransformation
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.first_order import first_order_check, first_order_steps, open_gap
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import bump3, dense_truth
from fuzzymbs.models.closed_form.resonance import (
    polished_truth,
    sdof_resonance,
    sdof_truth,
    two_dof_resonance,
)

# f(u, v) = -(u - 0.3)^2 + v on [-1, 1]^2 as a Chebyshev series: u^2 = (T2(u) + T0) / 2,
# so f = -0.59 T0 + 0.6 T1(u) - 0.5 T2(u) + T1(v); its maximum is at (0.3, 1)
DEGREES = np.array([[0, 0], [1, 0], [2, 0], [0, 1]])
COEFFICIENTS = np.array([[-0.59], [0.6], [-0.5], [1.0]])
BOX = (np.array([[-1.0, -1.0]]), np.array([[1.0, 1.0]]))
MOVING = np.array([True, True])


def _value(u, v):
    return -((u - 0.3) ** 2) + v


def _check(run, gradient, maximum_at, scale=1.0, reported=None):
    units = np.array([run], dtype=float)
    values = np.array([[_value(*run)]])  # (N, E)
    slopes = np.array([[gradient]], dtype=float)  # (N, E, n)
    arg = np.array([[maximum_at]], dtype=float)  # (L, E, n)
    bounds = values if reported is None else np.array([[reported]])
    return first_order_check(
        (DEGREES, COEFFICIENTS, None),
        arg.copy(),
        arg.copy(),
        BOX,
        np.array([[scale]]),
        (units, values, slopes, np.array([True])),
        MOVING,
        0.02,
        (bounds, bounds),
    )


def test_the_gap_is_what_the_model_still_rises_with_its_gradient_at_an_active_bound():
    # the run at (0, 1) with the true gradient (0.6, 1): v is held by its upper bound (the
    # gradient points out), u is free; the quadratic model with the exact curvature -2 gains
    # f(0.3, 1) - f(0, 1) = 0.09 and steps to the maximum (rows: minimum, then maximum)
    check = _check((0.0, 1.0), (0.6, 1.0), (0.0, 1.0), scale=0.5)
    np.testing.assert_allclose(check.gap[1], 0.09 / 0.5, rtol=1e-6)
    np.testing.assert_allclose(check.step[1], [0.3, 1.0], atol=1e-6)
    # for the minimum the same run's gradient points up both ways: towards (-1, -1)
    assert check.gap[0] > 0.0 and check.run.tolist() == [0, 0]
    # a maximum already reported at the true 1.0 misses nothing: the run lies below it
    reported = _check((0.0, 1.0), (0.6, 1.0), (0.0, 1.0), scale=0.5, reported=1.0)
    assert reported.gap[1] == pytest.approx(0.0, abs=1e-9)


def test_a_kkt_point_has_no_gap_and_a_far_run_confirms_nothing():
    at_maximum = _check((0.3, 1.0), (0.0, 1.0), (0.3, 1.0))
    assert at_maximum.gap[1] == pytest.approx(0.0, abs=1e-12)
    far = _check((0.0, 0.0), (0.6, 1.0), (0.3, 1.0))  # the extremum 0.3 away from the run
    assert np.isnan(far.gap).all() and (far.run == -1).all()
    steps = first_order_steps(
        _check((0.0, 1.0), (0.6, 1.0), (0.0, 1.0)),
        np.array([[0.0, 1.0]]),
        MOVING,
        tolerance=0.01,
        near=0.02,
        limit=4,
    )
    np.testing.assert_allclose(steps[-1], [0.3, 1.0], atol=1e-6)


def test_a_step_that_ends_on_a_run_closes_its_gap():
    # from the run at (0, 1) the maximum's step ends at (0.3, 1), the minimum's elsewhere;
    # a gap stays open until a run lies at its step's end (that run's value is within the
    # reported bounds, widened to every run, so the predicted gain did not occur)
    check = _check((0.0, 1.0), (0.6, 1.0), (0.0, 1.0), scale=0.5)
    run, (to_minimum, to_maximum) = np.array([[0.0, 1.0]]), check.step
    assert open_gap(check, run, MOVING, 0.02) == np.nanmax(check.gap)
    near_maximum = np.concatenate((run, [to_maximum + 0.01]))
    assert open_gap(check, near_maximum, MOVING, 0.02) == check.gap[0]
    assert open_gap(check, np.concatenate((run, [to_minimum])), MOVING, 0.02) == check.gap[1]
    both = np.concatenate((run, [to_minimum, to_maximum]))
    assert open_gap(check, both, MOVING, 0.02) == 0.0
    far = np.concatenate((run, [to_maximum + 0.05]))  # beyond near: not taken
    assert open_gap(check, far, MOVING, 0.02) == np.nanmax(check.gap)


def _rounds(case, levels):
    engine = AdaptiveTransformation(
        triangular_numbers(case.triangles), np.linspace(0.0, 1.0, levels), 0.01, 2000, 20_000
    )
    while not engine.done:
        points = engine.next_batch()
        if len(points) == 0:
            break
        engine.add(points, *case.gradient(dict(zip(engine.names, points.T, strict=True))))
    return engine.outcome()


def _honest(outcome, truth):
    miss = max(band_miss(outcome.lower[k], outcome.upper[k], *truth[k]) for k in truth)
    # the tolerance (+0.1 %, the truth's resolution), or a report of at least half the miss
    return miss <= 0.011 or outcome.error >= 0.5 * miss


def test_with_gradients_the_ridge_at_five_percent_is_honest():
    case = sdof_resonance(0.05)
    outcome = _rounds(case, 4)
    assert outcome.converged and _honest(outcome, sdof_truth(case, np.linspace(0, 1, 4)))


@pytest.mark.slow
@pytest.mark.parametrize(
    "case",
    [
        *(sdof_resonance(z) for z in (0.005, 0.02, 0.05)),
        *(two_dof_resonance(z) for z in (0.02, 0.05)),
        bump3(),
    ],
    ids=lambda case: case.name,
)
def test_with_gradients_ridges_and_hard_cases_are_honest(case):
    # 6 levels, tolerance 1 %, against the closed form (one degree of freedom), the polished
    # dense grid (two) or the dense grid (bump3)
    levels = np.linspace(0.0, 1.0, 6)
    if case.name.startswith("sdof"):
        truth = sdof_truth(case, levels)
    elif case.name.startswith("2dof"):
        truth = polished_truth(case, levels)
    else:
        truth = dense_truth(case, levels)
    assert _honest(_rounds(case, 6), truth)
