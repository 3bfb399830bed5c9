"""The run count equals the plan the builder makes, for every method; counting is cheap.

``run_count`` and the limit check count the distinct points of the builder's
own value sets (reduced, extended, general, grid) or the Smolyak node count
(sparse), so the count a plan is refused for is the number of samples it would
have.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fuzzymbs.errors import InvalidPlanError, PlanTooLargeError
from fuzzymbs.fuzzy import Trapezoidal, Triangular, plan, run_count
from fuzzymbs.fuzzy.methods import METHODS, method_named
from fuzzymbs.fuzzy.methods.base import CountRequest, NumberShape
from fuzzymbs.fuzzy.plan_size import check_run_limit
from fuzzymbs.study.planning import build_plan

SHAPES = {
    "symmetric": Triangular(-1.0, 0.0, 1.0),
    "asymmetric": Triangular(1.0, 1.3, 2.1),
    "symmetric trapezoid": Trapezoidal(0.0, 1.0, 2.0, 3.0),
    "flat left": Triangular(1.0, 1.0, 2.3),
    "crisp": Triangular(2.0, 2.0, 2.0),
}

# every pair of shapes, and triples and quadruples mixing symmetric and asymmetric numbers
COMBINATIONS = [
    *[(kind,) for kind in SHAPES],
    *itertools.combinations_with_replacement(SHAPES, 2),
    ("symmetric", "symmetric", "symmetric"),
    ("symmetric", "asymmetric", "symmetric trapezoid"),
    ("asymmetric", "flat left", "crisp"),
    ("symmetric", "symmetric", "symmetric", "symmetric"),
    ("symmetric", "asymmetric", "symmetric trapezoid", "crisp"),
]


def _variants(method: str, names: list[str]) -> list[dict]:
    if method == "extended":
        return [{"nonmonotonic": [names[0]]}, {"nonmonotonic": names}]
    if method == "sparse":
        return [{"sparse_level": level} for level in (1, 2, 3)]
    return [{}]


@pytest.mark.parametrize("method", ["reduced", "extended", "general", "grid", "sparse"])
def test_count_equals_the_unique_samples_the_builder_makes(method):
    for kinds in COMBINATIONS:
        names = [f"p{i}" for i in range(len(kinds))]
        parameters = {name: SHAPES[kind] for name, kind in zip(names, kinds, strict=True)}
        for levels in (1, 2, 3) if method != "sparse" else (2,):  # 2 to 4 membership levels
            for options in _variants(method, names):
                built = plan(parameters, method=method, levels=levels, max_runs=None, **options)
                unique = len({tuple(row) for row in built.samples.tolist()})
                assert unique == len(built)
                count = run_count(parameters, method, levels, **options)
                assert count == len(built), (kinds, method, levels, options)


@pytest.mark.parametrize("name", [n for n, cls in METHODS.items() if not cls.runs_in_rounds])
def test_every_registered_method_counts_from_the_sets_it_builds(name):
    # the method object itself, as the registry makes it: a method added to the registry is
    # held to count == len(plan) here without a line of this test changing
    for kinds in COMBINATIONS:
        names = tuple(f"p{i}" for i in range(len(kinds)))
        parameters = {n: SHAPES[kind] for n, kind in zip(names, kinds, strict=True)}
        scheme = method_named(name).checked(names)
        for levels in (1, 2, 4):
            request = CountRequest(
                names,
                [NumberShape.of(number) for number in parameters.values()],
                tuple(parameters.values()),
                levels,
                levels,
            )
            count, exact = scheme.count(request)
            built = plan(parameters, method=scheme, levels=levels, max_runs=None)
            assert exact and count == len(built), (kinds, name, levels)
            assert scheme.closed_form(request) >= count  # the cheap count never undercounts


def test_symmetric_general_plan_is_counted_as_built_and_limited_by_its_own_size():
    three = {name: Triangular(-1.0, 0.0, 1.0) for name in "abc"}
    built = plan(three, "general", 4, max_runs=189)
    assert run_count(three, "general", 4) == len(built) == 189
    assert built.points_without_reuse == 225
    with pytest.raises(PlanTooLargeError, match=r"needs 189 model runs"):
        plan(three, "general", 4, max_runs=188)


@pytest.mark.slow  # the plan's table is 20,001 x 10,000 floats (1.6 GB): 8 to 24 s to fill
def test_ten_thousand_parameters_sparse_level_one_is_counted_and_built():
    # integer supports: the centre of every support is its modal value, a node
    parameters = {f"x{i}": Triangular(float(i), i + 1.0, i + 2.0) for i in range(10_000)}
    assert run_count(parameters, "sparse", 2, sparse_level=1) == 20_001
    built = plan(parameters, method="sparse", levels=2, sparse_level=1)
    assert len(built) == 20_001
    assert built.nominal_index == 0
    np.testing.assert_array_equal(built.samples[0], np.arange(10_000) + 1.0)
    # every other sample moves one parameter to a support bound (the last parameter first)
    moved = built.samples[1:] != built.samples[0]
    assert np.all(moved.sum(axis=1) == 1) and np.all(moved.sum(axis=0) == 2)
    assert built.samples[1, -1] == 9_999.0 and built.samples[2, -1] == 10_001.0
    assert built.samples[-2, 0] == 0.0 and built.samples[-1, 0] == 2.0


def test_ten_thousand_parameters_sparse_level_two_is_refused_before_building():
    parameters = {f"x{i}": Triangular(float(i), i + 1.0, i + 2.0) for i in range(10_000)}
    with pytest.raises(PlanTooLargeError, match=r"200,020,001 model runs"):
        check_run_limit(parameters, "sparse", 2, sparse_level=2)


def test_a_study_refuses_a_sparse_plan_whose_bounds_cannot_be_searched():
    sixteen = {f"x{i}": Triangular(float(i), i + 1.0, i + 2.0) for i in range(16)}
    with pytest.raises(InvalidPlanError, match=r"at most 15 fuzzy parameters"):
        build_plan(sixteen, "sparse", 2, None, method_options={"sparse_level": 1})
    built = plan(sixteen, method="sparse", levels=2, sparse_level=1)  # the plan itself builds
    with pytest.raises(InvalidPlanError, match=r"3\^16"):
        built.retransform(built.samples.sum(axis=1))
