"""The check of a study's bands against independent points (fuzzymbs.study.band_check)."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy import plan as make_plan
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.numbers import Triangular, triangular_numbers
from fuzzymbs.fuzzy.validation_points import validation_points
from fuzzymbs.models.closed_form import ProductModel
from fuzzymbs.models.closed_form.hard_cases import bump3, dense_truth
from fuzzymbs.study.band_check import (
    band_check_points,
    check_bands,
    check_study_bands,
    independent_model,
)
from fuzzymbs.study.study import Study

LEVELS = [0.0, 0.25, 0.5, 0.75, 1.0]
PRODUCT = {"x1": Triangular(1.0, 2.0, 3.0), "x2": Triangular(9.0, 10.0, 12.0)}


def exact_product_bands(plan) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    # closed form (Hanss 2005, ch. 5): for positive intervals the cut of x1 x2 is
    # [lo1 lo2, hi1 hi2]; independent of any sampling
    cuts = np.stack([plan.parameters[n].cuts(plan.levels) for n in plan.names], axis=1)
    return {"z": (cuts[:, 0, 0] * cuts[:, 1, 0], cuts[:, 0, 1] * cuts[:, 1, 1])}


def test_true_bands_hold_every_point():
    # reference: the exact cuts of the product; every point lies inside them, so no
    # level is missed at all (0 exactly: the product of the bounds is exact)
    plan = make_plan(PRODUCT, method="reduced", levels=LEVELS)
    bands = exact_product_bands(plan)
    check = check_bands(ProductModel(), plan, bands, count=16)
    assert check.runs == 32 and check.failed == 0
    assert check.error == 0.0 and check.worst is None
    # every point is in the support; the 0.5 box's (and some of the support's) in
    # the cuts up to 0.5; the crisp top level has no width
    assert check.points[0] == 32 and check.points[2] >= 16 and check.points[4] == 0
    assert np.isnan(check.misses["z"][4])
    assert np.all(check.misses["z"][:4] == 0.0)


def test_a_band_wrong_on_purpose_is_caught_by_the_amount_it_misses():
    # the exact support cut's upper bound pulled in by 30 % of its width and the exact
    # 0.5 cut's lower bound pushed up by 30 %: the miss at each level is the points'
    # largest excursion beyond the wrong bound over the cut width, recomputed here
    # from the points (round-off: 1e-12); the other levels stay untouched
    plan = make_plan(PRODUCT, method="reduced", levels=LEVELS)
    lower, upper = (v.copy() for v in exact_product_bands(plan)["z"])
    width = upper - lower
    upper[0] -= 0.3 * width[0]
    lower[2] += 0.3 * width[2]
    check = check_bands(ProductModel(), plan, {"z": (lower, upper)}, count=16)
    z = check.samples[:, 0] * check.samples[:, 1]
    box = np.array([PRODUCT[n].cuts([0.5])[0] for n in plan.names])
    in_half = np.all((check.samples >= box[:, 0]) & (check.samples <= box[:, 1]), axis=1)
    scale = upper - lower  # the wrong band's own widths (a scalar output)
    expected_0 = max(np.max(z - upper[0]), np.max(lower[0] - z)) / scale[0]
    expected_2 = max(np.max(lower[2] - z[in_half]), np.max(z[in_half] - upper[2])) / scale[2]
    assert check.misses["z"][0] == pytest.approx(expected_0, abs=1e-12)
    assert check.misses["z"][2] == pytest.approx(expected_2, abs=1e-12)
    assert check.misses["z"][0] > 0.1 and check.misses["z"][2] > 0.1
    assert check.misses["z"][1] == 0.0 and check.misses["z"][3] == 0.0
    assert check.error == max(check.misses["z"][0], check.misses["z"][2])
    assert check.worst is not None and check.worst["miss"] == check.error
    # each point's own largest miss: beyond the wrong upper bound of the support, and
    # for a point in the 0.5 box below the wrong lower bound of that cut
    above = np.maximum(z - upper[0], 0) / scale[0]
    below = np.where(in_half, np.maximum(lower[2] - z, 0) / scale[2], 0.0)
    assert check.point_misses == pytest.approx(np.maximum(above, below), abs=1e-12)
    assert np.nanmax(check.point_misses) == check.error


def test_the_reduced_method_on_a_bump_is_caught_and_never_over_the_true_miss():
    # bump3's maximum lies inside the boxes, which the reduced method (corners only)
    # misses. Reference: its dense-grid truth (resolved to about 0.1 % of the cut
    # width, hard_cases.py); a point's excursion is a part of the true miss, so the
    # check finds more than 1 % and at most the true miss + 0.2 %
    case = bump3()
    parameters = triangular_numbers(case.triangles)
    plan = make_plan(parameters, method="reduced", levels=LEVELS)
    runs = case.model({n: plan.samples[:, i] for i, n in enumerate(plan.names)})
    bands = plan.retransform(runs, check_monotonic=False)
    lower, upper = bands["z"].lower, bands["z"].upper
    check = check_bands(case.model, plan, {"z": (lower, upper)}, count=32)
    true_lower, true_upper = dense_truth(case, LEVELS)["z"]
    truth = band_miss(lower, upper, true_lower, true_upper)
    assert check.error > 0.01
    assert check.error <= truth + 0.002


def test_the_points_lie_in_their_boxes_and_are_none_of_the_studys_own():
    # the points of the mu = 0.5 box inside it; neither box's points among the plan's
    # or the validation runs' (another scrambling), nor scaled copies of each other
    parameters = triangular_numbers(bump3().triangles)
    plan = make_plan(parameters, method="reduced", levels=LEVELS)
    support = band_check_points(plan, 16, 0.0)
    half = band_check_points(plan, 16, 0.5)
    box = np.array([parameters[n].cuts([0.5])[0] for n in plan.names])
    assert np.all((half >= box[:, 0]) & (half < box[:, 1]))
    others = np.vstack([plan.samples, validation_points(plan, 32).samples])
    for points in (support, half):
        nearest = np.min(np.abs(points[:, None, :] - others[None, :, :]).max(axis=2), axis=1)
        assert nearest.min() > 1e-6
    modal = np.array([parameters[n].modal for n in plan.names])
    assert not np.allclose(half - modal, 0.5 * (support - modal))


def test_a_failed_or_non_finite_run_is_left_out():
    plan = make_plan(PRODUCT, method="reduced", levels=LEVELS)

    def model(samples):
        z = samples["x1"] * samples["x2"]
        z[0] = np.nan  # a run that failed without saying so
        return {"z": z, "failed": np.arange(len(z)) == 1}

    check = check_bands(model, plan, exact_product_bands(plan), count=8)
    assert check.failed == 2 and check.points[0] == 14 and check.error == 0.0
    assert np.isnan(check.point_misses[:2]).all() and np.all(check.point_misses[2:] == 0.0)


def test_a_finished_study_is_checked_on_its_own_model_and_bands():
    # a registered closed-form study: the reduced method is exact on the product
    # (monotonic), so no independent point leaves its bands; the product has no
    # time integration, so the check runs the model as it is
    study = Study("product", PRODUCT, method="reduced", levels=LEVELS)
    result = study.run(progress=False)
    check = check_study_bands(study, result, count=8)
    assert check.error == 0.0 and check.runs == 16
    assert check.time_integration == "" and np.isnan(check.rtol)
    wrong = result.dataset.copy(deep=True)
    wrong["z_upper"].values[0] -= 0.5 * (wrong["z_upper"].values[0] - wrong["z_lower"].values[0])
    assert check_study_bands(study, wrong, count=8).misses["z"][0] > 0.1


class _Stepped:
    """A stand-in for a time-integrated model: shared steps, tolerance, tightening."""

    def __init__(self, rtol: float, shared: bool, can_leave: bool = True) -> None:
        self.rtol, self.shares_steps = rtol, shared
        if can_leave:
            self.own_steps = lambda: _Stepped(rtol, False)

    def tightened(self, factor: float) -> _Stepped:
        return _Stepped(self.rtol / factor, self.shares_steps)


def test_the_independent_model_leaves_the_shared_steps_and_tightens_tenfold():
    model = independent_model(_Stepped(1e-3, shared=True))
    assert not model.shares_steps and model.rtol == pytest.approx(1e-4)
    assert independent_model(_Stepped(1e-3, shared=False), 4.0).rtol == pytest.approx(2.5e-4)
    with pytest.raises(InvalidParameterError, match="own_steps"):
        independent_model(_Stepped(1e-3, shared=True, can_leave=False))
    plain = ProductModel()
    assert independent_model(plain) is plain
