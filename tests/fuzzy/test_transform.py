"""Sampling plans of the transformation method: counts, points, bookkeeping, evaluation.

Counts are derived in docs/theory.md (section "Fuzzy engine") and restated per test.
"""

import itertools
import json

import numpy as np
import pytest

from fuzzymbs.errors import InvalidPlanError, ModelOutputError, UnsupportedOperationError
from fuzzymbs.fuzzy.numbers import Trapezoidal, Triangular
from fuzzymbs.fuzzy.transform import Plan, plan

SYMMETRIC = Triangular(-1.0, 0.0, 1.0)


def test_reduced_count_disc_brake_study():
    # THEORY.md: reduced count m 2^n + 1; n = 3, m = 4 gives 33 (disc-brake study)
    p = plan({"k": SYMMETRIC, "k_c": SYMMETRIC, "F_n": SYMMETRIC}, "reduced", 4)
    assert len(p) == 33
    assert p.points_without_reuse == 33  # corners never coincide across levels


@pytest.mark.parametrize(("n", "m"), [(1, 1), (2, 3), (4, 2), (8, 4)])
def test_reduced_count_formula(n, m):
    # m 2^n + 1 with non-degenerate cuts below the core
    p = plan({f"p{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(n)}, "reduced", m)
    assert len(p) == m * 2**n + 1


def test_grid_count_gear_study():
    # THEORY.md: triangular, m = 3: 7 points per parameter, 7^2 = 49 runs for n = 2
    p = plan({"k_con": Triangular(1.0, 2.0, 4.0), "k_t": Triangular(5.0, 6.0, 7.0)}, "grid", 3)
    assert len(p) == 49
    assert len(np.unique(p.samples[:, 0])) == 7
    # every level j uses the (2(m - j) + 1)^2 grid of the bounds at levels >= j
    np.testing.assert_array_equal(p.level_usage.sum(axis=1), [49, 25, 9, 1])


@pytest.mark.parametrize(("n", "m"), [(1, 4), (2, 4), (3, 4), (2, 3), (3, 2)])
def test_general_count_asymmetric_has_no_reuse(n, m):
    # Hanss: M_j = m + 1 - j points per parameter at level j, sum_k k^n runs without reuse.
    # For asymmetric triangles the midpoints never hit an earlier point (derived in
    # docs/theory.md), so deduplication saves nothing.
    parameters = {f"p{i}": Triangular(1.0, 2.0, 4.0) for i in range(n)}
    p = plan(parameters, "general", m)
    expected = sum(k**n for k in range(1, m + 2))
    assert p.points_without_reuse == expected
    assert len(p) == expected


@pytest.mark.parametrize(("n", "m"), [(1, 4), (2, 4), (3, 4), (2, 3), (4, 3)])
def test_general_count_symmetric_dyadic_dedup(n, m):
    # Derived (docs/theory.md): symmetric triangle, mu_j = j/m, points at level j are
    # c + h k/m with k = m-j, m-j-2, ..., -(m-j); so P_j contains P_(j+2) and the unique
    # points are P_0^n and P_1^n: (m+1)^n + m^n runs instead of sum_k k^n.
    # TFN(-1, 0, 1) keeps every coordinate a dyadic fraction, so equal points compare equal.
    p = plan({f"p{i}": SYMMETRIC for i in range(n)}, "general", m)
    assert p.points_without_reuse == sum(k**n for k in range(1, m + 2))
    assert len(p) == (m + 1) ** n + m**n


def test_general_points_per_level_follow_hanss_midpoints():
    # Hanss 2002: c_1 = a^(j), c_M = b^(j), inner points midpoints of level j+1 points
    x = Triangular(0.0, 1.0, 3.0)  # asymmetric: cuts [mu, 3 - 2 mu]
    p = plan({"x": x}, "general", 2)
    level1 = np.unique(p.samples[p.level_indices(1), 0])
    level0 = np.unique(p.samples[p.level_indices(0), 0])
    np.testing.assert_array_equal(level1, [0.5, 2.0])
    np.testing.assert_array_equal(level0, [0.0, 1.25, 3.0])
    np.testing.assert_array_equal(np.unique(p.samples[p.level_indices(2), 0]), [1.0])


def test_extended_adds_general_points_of_nonmonotonic_parameter_only():
    # extended: P_j for the named parameter, {a_j, b_j} for the others (docs/theory.md)
    # symmetric dyadic x: per-level counts (m + 1 - j) * 2 for j < m; unique total for m = 4
    # = x-values of P_0 u P_1 (9) times the corners of y at the level of each x value.
    p = plan({"x": SYMMETRIC, "y": SYMMETRIC}, "extended", 4, nonmonotonic=["x"])
    per_level = [len({tuple(row) for row in p.samples[p.level_indices(j)]}) for j in range(5)]
    assert per_level == [10, 8, 6, 4, 1]
    reduced = plan({"x": SYMMETRIC, "y": SYMMETRIC}, "reduced", 4)
    reduced_points = {tuple(row) for row in reduced.samples}
    assert reduced_points <= {tuple(row) for row in p.samples}
    # without nonmonotonic names the extended plan is the reduced plan
    same = plan({"x": SYMMETRIC, "y": SYMMETRIC}, "extended", 4)
    np.testing.assert_array_equal(same.samples, reduced.samples)


def test_samples_unique_and_nominal_first():
    for method in ("general", "reduced", "extended", "grid"):
        extra = {"nonmonotonic": ["b"]} if method == "extended" else {}
        p = plan(
            {"a": Triangular(1, 2, 4), "b": SYMMETRIC, "c": Trapezoidal(0, 1, 2, 3)},
            method,
            3,
            **extra,
        )
        rows = {tuple(row) for row in p.samples}
        assert len(rows) == len(p), method
        np.testing.assert_array_equal(p.samples[p.nominal_index], [2.0, 0.0, 1.5])
        assert p.nominal_index == 0
        # each level's points lie inside that level's cut box (nested bookkeeping)
        for j in range(len(p.levels)):
            points = p.samples[p.level_indices(j)]
            assert np.all(points >= p.cut_lower[j] - 0.0) and np.all(points <= p.cut_upper[j])


def test_trapezoidal_core_corners_in_reduced_plan():
    # core box corners at level m plus the modal point: 2^n + 1 points at the top level
    p = plan({"a": Trapezoidal(0, 1, 2, 3), "b": Trapezoidal(0, 1, 2, 3)}, "reduced", 2)
    top = {tuple(row) for row in p.samples[p.level_indices(2)]}
    assert top == {(1.0, 1.0), (1.0, 2.0), (2.0, 1.0), (2.0, 2.0), (1.5, 1.5)}
    assert len(p) == 3 * 4 + 1


def test_corner_pairs_differ_in_one_parameter():
    # corner s and s + 2^(n-1-i) differ only in parameter i (a_i then b_i)
    p = plan({"a": Triangular(1, 2, 4), "b": Triangular(5, 6, 7), "c": SYMMETRIC}, "reduced", 3)
    n = 3
    for j in range(3):
        corners = p.samples[p.corner_index[j]]
        for i in range(n):
            step = 2 ** (n - 1 - i)
            first = np.array([s for s in range(2**n) if not (s >> (n - 1 - i)) & 1])
            diff = corners[first + step] - corners[first]
            np.testing.assert_allclose(diff[:, i], p.cut_upper[j, i] - p.cut_lower[j, i])
            np.testing.assert_array_equal(np.delete(diff, i, axis=1), 0.0)


def test_levels_touched_propagates_downwards():
    # level j depends on every level >= j: a failed level-2 corner touches levels 0..2
    p = plan({"a": SYMMETRIC, "b": SYMMETRIC}, "reduced", 4)
    failed = np.zeros(len(p), dtype=bool)
    failed[p.corner_index[2, 1]] = True
    np.testing.assert_array_equal(p.levels_touched(failed), [True, True, True, False, False])
    failed[:] = False
    failed[p.nominal_index] = True
    assert p.levels_touched(failed).all()


def test_explicit_levels_and_sample_columns():
    p = plan({"a": Triangular(1, 2, 3)}, "reduced", [0.0, 0.1, 1.0])
    np.testing.assert_array_equal(p.levels, [0.0, 0.1, 1.0])
    columns = p.sample_columns()
    assert list(columns) == ["a"]
    np.testing.assert_allclose(sorted(columns["a"]), [1.0, 1.1, 2.0, 2.9, 3.0])


def test_evaluate_chunks_match_single_call():
    calls = []

    def model(samples):
        calls.append(len(samples["a"]))
        t = np.linspace(0.0, 1.0, 5)
        return {"z": samples["a"][:, None] * t + samples["b"][:, None], "s": samples["a"] * 2.0}

    p = plan({"a": Triangular(1, 2, 4), "b": SYMMETRIC}, "general", 3)
    whole = p.evaluate(model)
    chunked = p.evaluate(model, chunk_size=7)
    assert calls[0] == len(p) and max(calls[1:]) == 7 and sum(calls[1:]) == len(p)
    for key in ("z", "s"):
        np.testing.assert_array_equal(whole[key], chunked[key])
    assert whole["z"].shape == (len(p), 5)
    np.testing.assert_array_equal(whole["s"], 2.0 * p.samples[:, 0])


@pytest.mark.parametrize(
    ("model", "fragment"),
    [
        (lambda s: [1.0], "dict"),
        (lambda s: {}, "dict"),
        (lambda s: {"z": list(s["a"])}, "NumPy array"),
        (lambda s: {"z": np.float64(1.0)}, "NumPy array"),
        (lambda s: {"z": s["a"][:-1]}, "leading axis"),
        (lambda s: {"z": np.array(["x"] * len(s["a"]))}, "numeric"),
        (lambda s: {"z": s["a"], "failure_reason": np.full(len(s["a"]), "")}, "Study"),
    ],
)
def test_evaluate_rejects_bad_model_outputs(model, fragment):
    p = plan({"a": SYMMETRIC}, "reduced", 2)
    with pytest.raises(ModelOutputError, match=fragment):
        p.evaluate(model)


def test_evaluate_rejects_outputs_changing_between_chunks():
    state = {"n": 0}

    def model(s):
        state["n"] += 1
        return {"z": s["a"]} if state["n"] == 1 else {"w": s["a"]}

    with pytest.raises(ModelOutputError, match="changed between chunks"):
        plan({"a": SYMMETRIC}, "reduced", 2).evaluate(model, chunk_size=2)


@pytest.mark.parametrize("chunk_size", [0, -1, 1.5, True])
def test_evaluate_rejects_bad_chunk_size(chunk_size):
    with pytest.raises(InvalidPlanError, match="chunk_size"):
        plan({"a": SYMMETRIC}, "reduced", 2).evaluate(lambda s: {"z": s["a"]}, chunk_size)


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"method": "monte-carlo"}, "unknown method"),
        ({"levels": 0}, "levels"),
        ({"levels": [0.0, 0.6, 0.5, 1.0]}, "levels"),
        ({"levels": [0.1, 1.0]}, "levels"),
        ({"levels": [0.0, float("nan"), 1.0]}, "levels"),
        ({"levels": True}, "levels"),
        ({"levels": 2.0}, "levels must be an int >= 1"),
        ({"method": "extended", "nonmonotonic": ["zz"]}, "unknown parameters"),
        ({"method": "reduced", "nonmonotonic": ["a"]}, "only used by method='extended'"),
    ],
)
def test_plan_rejects_bad_settings(kwargs, fragment):
    with pytest.raises(InvalidPlanError, match=fragment):
        plan({"a": SYMMETRIC}, **kwargs)


@pytest.mark.parametrize(
    ("parameters", "fragment"),
    [({}, "non-empty"), ({"a": 1.0}, "FuzzyNumber"), ({"": SYMMETRIC}, "names"), ([], "mapping")],
)
def test_plan_rejects_bad_parameters(parameters, fragment):
    with pytest.raises(InvalidPlanError, match=fragment):
        plan(parameters)


def test_failed_mask_validated():
    p = plan({"a": SYMMETRIC}, "reduced", 2)
    with pytest.raises(InvalidPlanError, match="failed"):
        p.levels_touched(np.zeros(len(p) + 1, dtype=bool))
    with pytest.raises(InvalidPlanError, match="failed"):
        p.levels_touched(np.zeros(len(p)))


def test_corner_index_of_reduced_extended_and_grid_only():
    with pytest.raises(UnsupportedOperationError):
        _ = plan({"a": SYMMETRIC}, "general", 2).corner_index
    grid = plan({"a": SYMMETRIC, "b": Triangular(1, 2, 3)}, "grid", 2)
    # level 0 corners of the grid: the mu = 0 cut bounds, (a_lo, b_lo) ... (a_hi, b_hi)
    np.testing.assert_array_equal(
        grid.samples[grid.corner_index[0]], [[-1.0, 1.0], [-1.0, 3.0], [1.0, 1.0], [1.0, 3.0]]
    )


def test_to_dict_round_trip_and_fingerprint():
    p = plan({"a": Triangular(1, 2, 3), "b": SYMMETRIC}, "extended", 3, nonmonotonic=["b"])
    data = json.loads(json.dumps(p.to_dict()))
    again = Plan.from_dict(data)
    np.testing.assert_array_equal(again.samples, p.samples)
    assert again.fingerprint() == p.fingerprint()
    assert len(p.fingerprint()) == 64
    other = plan({"a": Triangular(1, 2, 3.5), "b": SYMMETRIC}, "extended", 3, nonmonotonic=["b"])
    assert other.fingerprint() != p.fingerprint()
    assert (
        plan({"a": SYMMETRIC}, "reduced", 3).fingerprint()
        != plan({"a": SYMMETRIC}, "general", 3).fingerprint()
    )
    with pytest.raises(InvalidPlanError):
        Plan.from_dict({"method": "reduced"})


def test_large_plans_build():
    # the performance requirement is measured in docs/theory.md; here only that they build
    eight = {f"p{i}": Triangular(i, i + 0.4, i + 1.0) for i in range(8)}
    assert len(plan(eight, "reduced", 4)) == 4 * 2**8 + 1
    five = dict(itertools.islice(eight.items(), 5))
    assert len(plan(five, "general", 4)) == sum(k**5 for k in range(1, 6))
