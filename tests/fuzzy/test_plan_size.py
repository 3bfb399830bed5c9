"""Run counts in closed form (fuzzymbs.fuzzy.plan_size) against built plans, and the run limit.

Reference: ``len(plan(...))``, the unique sample points the builder keeps after
merging equal rows (an independent computation: it builds every level's points
and deduplicates them). The closed forms (docs/theory.md, "Counting runs
before building a plan") must equal it wherever no two points coincide except
by construction, and never fall below it.
"""

from __future__ import annotations

import itertools
import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzymbs.errors import InvalidPlanError, PlanTooLargeError
from fuzzymbs.fuzzy.methods.level_scheme import power_product_sum
from fuzzymbs.fuzzy.numbers import Gaussian, PiecewiseLinear, Trapezoidal, Triangular
from fuzzymbs.fuzzy.plan_size import (
    LEVEL_TABLE_FACTOR,
    check_run_limit,
    check_screening_run_limit,
    screening_run_count,
)
from fuzzymbs.fuzzy.screening import screening_samples
from fuzzymbs.fuzzy.sparse_grid import SparseGrid, node_count, nodes_1d
from fuzzymbs.fuzzy.transform import DEFAULT_MAX_RUNS, METHODS, Plan, plan, run_count

# every shape the counts distinguish; "recurs": the general method's midpoints of this
# number coincide across levels (symmetric about the core), so its count is a bound only
SHAPES = {
    "asymmetric": (Triangular(1.0, 1.3, 2.1), False),
    "symmetric": (Triangular(-1.0, 0.0, 1.0), True),
    "trapezoid": (Trapezoidal(1.0, 1.4, 1.7, 2.6), False),
    "point-core trapezoid": (Trapezoidal(1.0, 1.5, 1.5, 2.6), False),
    "flat left": (Triangular(1.0, 1.0, 2.3), False),
    "flat right": (Triangular(1.0, 2.2, 2.2), False),
    "flat-left trapezoid": (Trapezoidal(1.0, 1.0, 2.0, 2.7), False),
    "crisp": (Triangular(2.0, 2.0, 2.0), False),
    "crisp interval": (Trapezoidal(1.0, 1.0, 2.0, 2.0), True),
    "gaussian": (Gaussian(3.0, 0.2), True),
}


def _settings(names, method, m):
    """(kwargs for plan/run_count) of every variant of a method."""
    if method == "extended":
        return [{"nonmonotonic": [names[0]]}, {"nonmonotonic": [names[-1]]}, {}]
    if method == "sparse":
        return [{"sparse_level": level} for level in (1, 2, 3)]
    return [{}]


def _exact_expected(shapes, names, method, options) -> bool:
    """Whether the closed form must equal len(plan): no coincidences beyond construction."""
    if method in ("reduced", "grid", "sparse"):
        return True
    interior = set(names) if method == "general" else set(options.get("nonmonotonic", ()))
    recurring = any(SHAPES[s][1] for s, name in zip(shapes, names, strict=True) if name in interior)
    if not recurring:
        return True
    # another parameter whose values all differ between levels keeps the levels apart
    separated = [
        SHAPES[s][0]
        for s, name in zip(shapes, names, strict=True)
        if name not in interior
        and SHAPES[s][0].alpha_cut(0.0)[0] != SHAPES[s][0].core[0]
        and SHAPES[s][0].alpha_cut(0.0)[1] != SHAPES[s][0].core[1]
    ]
    return bool(separated)


def _check(shapes, m, method):
    names = [f"p{i}" for i in range(len(shapes))]
    parameters = {name: SHAPES[s][0] for name, s in zip(names, shapes, strict=True)}
    for options in _settings(names, method, m):
        built = len(plan(parameters, method, m, **options))
        counted = run_count(parameters, method, m, **options)
        assert built <= counted, (shapes, m, method, options)
        if _exact_expected(shapes, names, method, options):
            assert counted == built, (shapes, m, method, options)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("m", [1, 2, 3])
def test_count_equals_plan_for_one_and_two_parameters_of_every_shape(method, m):
    for count in (1, 2):
        for shapes in itertools.product(SHAPES, repeat=count):
            _check(shapes, m, method)


@pytest.mark.parametrize("method", METHODS)
def test_count_equals_plan_for_mixed_triples(method):
    # triangular, trapezoidal, crisp-core and flat shapes mixed, three parameters
    triples = [
        ("asymmetric", "trapezoid", "point-core trapezoid"),
        ("trapezoid", "trapezoid", "trapezoid"),
        ("symmetric", "symmetric", "symmetric"),
        ("symmetric", "asymmetric", "crisp"),
        ("flat left", "flat right", "crisp interval"),
        ("gaussian", "flat-left trapezoid", "trapezoid"),
    ]
    for shapes in triples:
        for m in (1, 4):
            _check(shapes, m, method)


def test_symmetric_general_count_is_the_plan_after_merging():
    # the closed form sum_k k^n counts the midpoints before they merge; the count is exact
    # (docs/theory.md: (m+1)^n + m^n after merging dyadic midpoints)
    three = {name: Triangular(-1.0, 0.0, 1.0) for name in "abc"}
    built = plan(three, "general", 4)
    assert built.points_without_reuse == 225
    assert run_count(three, "general", 4) == len(built) == 189


@pytest.mark.parametrize(
    ("parameters", "method", "levels", "expected"),
    [
        # the closed forms of the docstring, by hand
        ({f"p{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(12)}, "reduced", 4, 16_385),
        (
            {f"p{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(12)},
            "general",
            4,
            sum(k**12 for k in range(1, 6)),
        ),
        ({"a": Triangular(0, 1, 3), "b": Triangular(0, 2, 3)}, "grid", 3, 49),  # gear study
        (
            {"a": Trapezoidal(0, 1, 2, 4), "b": Triangular(0, 1, 3)},
            "reduced",
            4,
            4 * 4 + 2 + 1,  # m 2^n + 2^q + [q > 0]
        ),
        (
            {"a": Trapezoidal(0, 1, 2, 4), "b": Triangular(0, 1, 3)},
            "general",
            2,
            (1 * 2 + 2 * 3 + 3 * 4) + 1,  # sum (j+1)^p (j+2)^q + [p > 0 and q > 0]
        ),
        ({"a": Trapezoidal(0, 1, 2, 4), "b": Triangular(0, 1, 3)}, "grid", 2, 6 * 5 + 1),
    ],
)
def test_closed_forms_by_hand(parameters, method, levels, expected):
    assert run_count(parameters, method, levels) == expected
    if expected <= DEFAULT_MAX_RUNS:  # the twelve-parameter general plan is not built
        assert len(plan(parameters, method, levels)) == expected


@st.composite
def _numbers(draw):
    lower = draw(st.integers(-50, 50)) / 4.0
    widths = [
        draw(st.one_of(st.just(0.0), st.floats(0.05, 5.0, allow_nan=False))) for _ in range(3)
    ]
    kind = draw(st.sampled_from(["triangular", "trapezoidal"]))
    core_lower = lower + widths[0]
    if kind == "triangular":
        return Triangular(lower, core_lower, core_lower + widths[2])
    core_upper = core_lower + widths[1]
    return Trapezoidal(lower, core_lower, core_upper, core_upper + widths[2])


@st.composite
def _levels(draw):
    if draw(st.booleans()):
        return draw(st.integers(1, 5))
    # levels a rounding error apart (0.05 and 0.05000000000000001) give the same cut values,
    # so points recur: the exactness below holds only where no point recurs
    inner = draw(
        st.lists(st.floats(0.05, 0.95), min_size=0, max_size=4, unique_by=lambda mu: round(mu, 6))
    )
    return [0.0, *sorted(inner), 1.0]


@settings(max_examples=150, deadline=None)
@given(
    numbers=st.lists(_numbers(), min_size=1, max_size=4),
    levels=_levels(),
    method=st.sampled_from(METHODS),
    data=st.data(),
)
def test_count_never_below_the_plan_and_exact_where_no_point_recurs(numbers, levels, method, data):
    parameters = {f"p{i}": number for i, number in enumerate(numbers)}
    options: dict = {}
    if method == "extended":
        options["nonmonotonic"] = data.draw(st.lists(st.sampled_from(list(parameters)), max_size=2))
    if method == "sparse":
        options["sparse_level"] = data.draw(st.integers(1, 3))
    built = len(plan(parameters, method, levels, **options))
    counted = run_count(parameters, method, levels, **options)
    assert built <= counted
    if method in ("reduced", "grid", "sparse") or (
        method == "extended" and not options["nonmonotonic"]
    ):
        assert counted == built


def test_piecewise_number_with_a_vertical_step_is_bounded():
    # lower bound constant for mu in [0, 0.5]: not flat over all levels, so values recur
    # that the counts keep apart -- an upper bound
    stepped = PiecewiseLinear([0.0, 0.5, 1.0], [1.0, 1.0, 2.0], [4.0, 3.0, 2.0])
    for method in ("reduced", "grid", "general"):
        assert len(plan({"a": stepped, "b": Triangular(0, 1, 3)}, method, 4)) <= run_count(
            {"a": stepped, "b": Triangular(0, 1, 3)}, method, 4
        )


@pytest.mark.parametrize("p", range(4))
@pytest.mark.parametrize("q", range(4))
def testpower_product_sum_equals_the_direct_sum(p, q):
    for m in (0, 1, 2, 5, 9, 40):
        assert power_product_sum(m, p, q) == sum(
            (k + 1) ** p * (k + 2) ** q for k in range(1, m + 1)
        )


def test_sparse_node_count_equals_the_built_grid():
    for dimension in range(1, 6):
        for level in range(6):
            assert node_count(dimension, level) == len(SparseGrid(dimension, level))
    assert node_count(0, 3) == 1
    # the table of the sparse_grid module docstring (n = 2 and 3, levels 0..4)
    assert [node_count(2, k) for k in range(5)] == [1, 5, 13, 29, 65]
    assert [node_count(3, k) for k in range(5)] == [1, 7, 25, 69, 177]


def test_nodes_1d_are_the_grids_own_nodes_with_their_levels():
    for level in range(6):
        values, first = nodes_1d(level)
        np.testing.assert_array_equal(values, np.unique(SparseGrid(1, level).nodes[:, 0]))
        # a 1-D node of level i is in the grid of level i - 1 and not below
        for value, i in zip(values, first, strict=True):
            assert value in SparseGrid(1, i - 1).nodes[:, 0]
            if i > 1:
                assert value not in SparseGrid(1, i - 2).nodes[:, 0]


def test_screening_count_equals_the_screening_samples():
    for shapes in itertools.product(SHAPES, repeat=2):
        parameters = {f"p{i}": SHAPES[s][0] for i, s in enumerate(shapes)}
        for levels in (1, 3, [0.0, 0.3, 1.0]):
            assert screening_run_count(parameters, levels) == len(
                screening_samples(parameters, levels).samples
            )


# ---------------------------------------------------------------------------- the limit
TWELVE = {f"x{i}": Triangular.relative(1.0 + i, 0.1) for i in range(12)}


def _traced_peak(function):
    """(result or raised error, peak traced bytes) of a call."""
    tracemalloc.start()
    try:
        outcome = function()
    except Exception as error:  # returned for inspection
        outcome = error
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return outcome, peak


@pytest.mark.parametrize(
    ("method", "levels", "fragment"),
    [
        ("general", 4, "needs 260,917,841 model runs (2.6e+08), more than max_runs = 1,000,000"),
        ("general", 1_000_000, "up to about 7.7e+76 model runs"),
        ("reduced", 10**12, "more than max_runs = 1,000,000"),
        ("grid", 4, "282,429,536,481 model runs (2.8e+11)"),
        ("sparse", 1_000_000, "its level bookkeeping"),
    ],
)
def test_too_large_plans_are_refused_before_anything_is_allocated(method, levels, fragment):
    outcome, peak = _traced_peak(lambda: plan(TWELVE, method, levels))
    assert isinstance(outcome, PlanTooLargeError) and isinstance(outcome, InvalidPlanError)
    message = str(outcome)
    assert fragment in message and "\n" not in message
    # the counts of the cheaper methods, by the same closed forms
    assert "'reduced' 16,385" in message or "'reduced' 40,961" in message  # levels 4 or 10
    assert "'sparse' (sparse_level = 3) 2,649" in message
    assert outcome.max_runs == DEFAULT_MAX_RUNS and outcome.runs > 0
    # nothing of the plan's size was built: well under a megabyte traced
    assert peak < 2**20


def test_refusal_names_the_limit_to_set_and_that_limit_accepts_the_plan():
    five = {f"x{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(5)}
    with pytest.raises(PlanTooLargeError) as caught:
        plan(five, "general", 4, max_runs=1000)
    error = caught.value
    assert error.runs == error.needed == sum(k**5 for k in range(1, 6)) == 4425
    message = str(error)
    for fragment in (
        "The 'general' method with 5 fuzzy parameters and levels = 4",
        "4,425 model runs",
        "max_runs = 1,000",
        "'reduced' 129",
        "'extended' with one non-monotonic parameter 225",  # 1 + 2^4 (2 + 3 + 4 + 5)
        "max_runs=4425 (plan or Study)",
        "max_runs = 4425 under [study]",
        "fuzzymbs run --max-runs 4425",
    ):
        assert fragment in message, fragment
    assert len(plan(five, "general", 4, max_runs=error.needed)) == 4425
    assert len(plan(five, "general", 4, max_runs=None)) == 4425


def test_level_bookkeeping_limit_refuses_absurdly_fine_levels():
    one = {"k": Triangular(1.0, 2.0, 3.0)}
    # 101 runs on 51 levels: 5,151 level-usage entries > 10 x 200
    with pytest.raises(PlanTooLargeError) as caught:
        plan(one, "grid", 50, max_runs=200)
    message = str(caught.value)
    assert "101 model runs on 51 membership levels" in message
    assert f"more than {LEVEL_TABLE_FACTOR} x max_runs" in message
    assert "with levels = 10: 'grid' 21" in message
    assert caught.value.needed == math.ceil(51 * 101 / LEVEL_TABLE_FACTOR)
    assert len(plan(one, "grid", 50, max_runs=caught.value.needed)) == 101
    # absurd levels on one parameter
    outcome, peak = _traced_peak(lambda: plan(one, "reduced", 100_000))
    assert isinstance(outcome, PlanTooLargeError) and peak < 2**20
    assert "200,001 model runs on 100,001 membership levels" in str(outcome)


def test_absurd_sparse_level_is_refused_without_counting_it():
    outcome, peak = _traced_peak(lambda: plan(TWELVE, "sparse", 4, sparse_level=10**6))
    assert isinstance(outcome, PlanTooLargeError) and peak < 2**20
    assert "(sparse_level = 1000000) needs more than about" in str(outcome)


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "10"])
def test_max_runs_must_be_a_positive_int_or_none(bad):
    with pytest.raises(InvalidPlanError, match="max_runs must be an int >= 1"):
        plan({"a": Triangular(0, 1, 2)}, "reduced", 2, max_runs=bad)


def test_invalid_settings_are_refused_before_the_count():
    with pytest.raises(InvalidPlanError, match="unknown method"):
        run_count(TWELVE, "fast", 4)
    with pytest.raises(InvalidPlanError, match="levels must be an int >= 1"):
        run_count(TWELVE, "reduced", 0)
    with pytest.raises(InvalidPlanError, match="only used by method='extended'"):
        run_count(TWELVE, "reduced", 4, nonmonotonic=["x0"])
    with pytest.raises(InvalidPlanError, match="only used by method='sparse'"):
        run_count(TWELVE, "reduced", 4, sparse_level=2)
    with pytest.raises(InvalidPlanError, match="unknown parameters"):
        run_count(TWELVE, "extended", 4, nonmonotonic=["nope"])


def test_a_plan_rebuilt_from_its_description_is_not_limited_again():
    five = {f"x{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(5)}
    original = plan(five, "general", 4, max_runs=5000)
    assert len(Plan.from_dict(original.to_dict())) == len(original)
    with pytest.raises(PlanTooLargeError):
        Plan.from_dict(original.to_dict(), max_runs=1000)


def test_auto_screening_is_limited_by_its_screening_and_the_reduced_corners():
    outcome, peak = _traced_peak(lambda: check_screening_run_limit(TWELVE, 1_000_000))
    assert isinstance(outcome, PlanTooLargeError) and peak < 2**20
    message = str(outcome)
    assert "nonmonotonic = 'auto'" in message and "24,000,001 screening runs" in message
    assert check_screening_run_limit(TWELVE, 4) == screening_run_count(TWELVE, 4) == 1 + 12 * 8
    assert check_run_limit(TWELVE, "reduced", 4) == 16_385


def test_adaptive_count_is_its_budget_and_bounds_what_it_runs():
    # the adaptive method has no fixed count: run_count gives its budget max_runs, which
    # its rounds never pass (a budget too small for the tolerance stops them there)
    import warnings

    from fuzzymbs.fuzzy.numbers import triangular_numbers
    from fuzzymbs.models.closed_form.hard_cases import bump3

    case = bump3()
    numbers = triangular_numbers(case.triangles)
    assert run_count(numbers, "adaptive", 5) == 2000  # the documented default budget
    budget = run_count(numbers, "adaptive", 5, max_runs=60)
    assert budget == 60
    scheme = plan(numbers, method="adaptive", levels=5, max_runs=budget)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # AdaptiveWarning: stopped at the budget
        scheme.evaluate(case.model)
    assert 2 * 3 + 2 <= len(scheme) <= budget
    with pytest.raises(InvalidPlanError, match="max_runs"):
        run_count(numbers, "adaptive", 5, max_runs=7)  # below the first round, 2 n + 2
    with pytest.raises(InvalidPlanError, match="sparse_level"):
        run_count(numbers, "adaptive", 5, sparse_level=2)
    with pytest.raises(InvalidPlanError, match="max_runs=100 is only used by method='adaptive'"):
        run_count(numbers, "reduced", 5, max_runs=100)
    with pytest.raises(InvalidPlanError, match="levels"):
        run_count(numbers, "adaptive", 0)
