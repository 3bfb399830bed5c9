"""method="sparse": sparse-grid interpolant searched per cut box (Klimke & Wohlmuth 2005)."""

import textwrap

import numpy as np
import pytest
from scipy.optimize import minimize

from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidPlanError,
    StudyFileError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy import Plan, Trapezoidal, Triangular, plan
from fuzzymbs.fuzzy.grids import cartesian
from fuzzymbs.fuzzy.retransform import points_per_parameter
from fuzzymbs.study.study import Study
from fuzzymbs.study.studyfile import load_study_file

MU = np.linspace(0.0, 1.0, 5)


def test_product_oracle_exact():
    # THEORY.md section 1: z = x y, x = TFN(1,2,3), y = TFN(2,3,4): [(1+mu)(2+mu), (3-mu)(4-mu)];
    # total degree 2 <= sparse_level, so the interpolant is z itself and the box corners are
    # search points
    p = plan({"x": Triangular(1, 2, 3), "y": Triangular(2, 3, 4)}, method="sparse", levels=4)
    assert len(p) == 29  # 29 Smolyak nodes for n = 2, level 3; the modal point is one of them
    result = p.retransform(p.samples[:, 0] * p.samples[:, 1])
    np.testing.assert_allclose(result.lower, (1 + MU) * (2 + MU), rtol=0, atol=1e-10)
    np.testing.assert_allclose(result.upper, (3 - MU) * (4 - MU), rtol=0, atol=1e-10)
    assert result.nominal == pytest.approx(6.0, abs=1e-14)


def test_square_oracle_exact():
    # THEORY.md: z = x^2, x = TFN(-1,0,1): exact [0, (1-mu)^2] (standard arithmetic gives
    # lower -(1-mu)^2; the reduced method gives lower (1-mu)^2 > 0, from the corners only)
    p = plan({"x": Triangular(-1, 0, 1)}, method="sparse", levels=4)
    result = p.retransform(p.samples[:, 0] ** 2)
    np.testing.assert_allclose(result.lower, 0.0, atol=1e-10)
    np.testing.assert_allclose(result.upper, (1 - MU) ** 2, rtol=0, atol=1e-10)


PARAMETERS = {
    "a": Triangular(0.0, 1.4, 3.0),
    "b": Triangular(-1.0, 0.2, 1.0),
    "c": Triangular(0.5, 1.0, 2.0),
    "d": Triangular(-0.5, 0.0, 0.8),
    "e": Triangular(1.0, 2.0, 2.5),
}


def smooth_nonmonotonic(x):
    """Smooth, non-monotonic in a (sin peaks inside), b (cos(b c)) and d (minimum at 0.3)."""
    a, b, c, d, e = np.atleast_2d(x).T
    return np.sin(a) + np.cos(b * c) + (d - 0.3) ** 2 + 0.3 * a * e - 0.2 * e**2 + 0.1 * b * d


def reference_bounds(p):
    """Independent reference: the TRUE function on a dense 13^5 grid of each cut box, polished
    by L-BFGS-B from the three best grid points (optimum of the true function, not the
    interpolant)."""
    lower, upper = [], []
    for j in range(len(p.levels)):
        low, high = p.cut_lower[j], p.cut_upper[j]
        points = cartesian([np.linspace(low[i], high[i], 13) for i in range(5)])
        values = smooth_nonmonotonic(points)
        found = []
        for sign in (1.0, -1.0):
            starts = points[np.argsort(sign * values)[:3]]
            local = [
                minimize(
                    lambda x, s=sign: s * smooth_nonmonotonic(x)[0],
                    x0,
                    method="L-BFGS-B",
                    bounds=list(zip(low, high, strict=True)),
                ).fun
                for x0 in starts
            ]
            found.append(sign * min(min(local), np.min(sign * values)))
        lower.append(found[0])
        upper.append(found[1])
    return np.array(lower), np.array(upper)


def test_smooth_nonmonotonic_five_parameters_against_dense_reference():
    sparse = plan(PARAMETERS, method="sparse", levels=4, sparse_level=4)
    result = sparse.retransform(smooth_nonmonotonic(sparse.samples))
    lower, upper = reference_bounds(sparse)
    # output range at mu = 0 is [-1.70, 3.01]; measured errors (sparse_level 4, 802 runs):
    # at most 3.0e-4 (levels 0.25 and 0.5), below 1e-6 at the others
    np.testing.assert_allclose(result.lower, lower, rtol=0, atol=1e-3)
    np.testing.assert_allclose(result.upper, upper, rtol=0, atol=1e-3)
    general = plan(PARAMETERS, method="general", levels=4)
    general_result = general.retransform(smooth_nonmonotonic(general.samples))
    # run counts: 802 sparse against 4425 general, and the general method (error up to
    # 2.2e-2 here, measured) is the less accurate one
    assert len(sparse) == 802 and len(general) == 4425
    general_error = max(
        np.abs(general_result.lower - lower).max(), np.abs(general_result.upper - upper).max()
    )
    sparse_error = max(np.abs(result.lower - lower).max(), np.abs(result.upper - upper).max())
    assert sparse_error < general_error / 10


def test_default_level_is_cheaper_still_and_converges():
    # level 3 (default, 242 runs): measured error 5.5e-3; level 5 (2434 runs) 5.0e-6
    default = plan(PARAMETERS, method="sparse", levels=[0, 0.5, 1])
    assert default.sparse_level == 3 and len(default) == 242
    result = default.retransform(smooth_nonmonotonic(default.samples))
    full = plan(PARAMETERS, method="sparse", levels=4)  # its levels contain 0, 0.5 and 1
    lower, upper = reference_bounds(full)
    np.testing.assert_allclose(result.lower, lower[[0, 2, 4]], atol=1e-2)
    np.testing.assert_allclose(result.upper, upper[[0, 2, 4]], atol=1e-2)


def test_time_signal_grid_search_matches_scalar_elements_within_grid_error():
    # a trailing axis takes the grid search (no local polish); each element is a scalar model
    # z_t = (x - t)^2 + y with its exact minimum y_lo where t is inside the x cut and the
    # grid spacing bound (h/2)^2 otherwise (h = spacing of the search grid)
    p = plan(
        {"x": Triangular(0.0, 0.5, 1.0), "y": Triangular(1.0, 2.0, 3.0)},
        method="sparse",
        levels=2,
        search_points=400,
    )
    times = np.array([0.13, 0.5, 0.77])
    outputs = (p.samples[:, :1] - times) ** 2 + p.samples[:, 1:]
    result = p.retransform(outputs)
    assert result.lower.shape == (3, 3)
    k = points_per_parameter(400, 2)
    assert k == 20
    for j, mu in enumerate([0.0, 0.5, 1.0]):
        x_low, x_high = 0.5 * mu, 1.0 - 0.5 * mu
        y_low, y_high = 1.0 + mu, 3.0 - mu
        nearest = np.clip(times, x_low, x_high)
        exact_lower = (nearest - times) ** 2 + y_low
        exact_upper = np.maximum((x_low - times) ** 2, (x_high - times) ** 2) + y_high
        spacing = (x_high - x_low) / (k - 1)
        assert np.all(result.lower[j] >= exact_lower - 1e-10)
        assert np.all(result.lower[j] <= exact_lower + (spacing / 2) ** 2 + 1e-10)
        np.testing.assert_allclose(result.upper[j], exact_upper, atol=1e-10)  # at corners


def test_asymmetric_modal_point_is_sample_zero_and_nominal():
    parameters = {"x": Triangular(1.0, 2.0, 4.0), "y": Trapezoidal(0.0, 1.0, 1.5, 3.0)}
    p = plan(parameters, method="sparse", levels=3, sparse_level=2)
    np.testing.assert_array_equal(p.samples[0], [2.0, 1.25])
    assert p.nominal_index == 0
    # the CC midpoint of the support (2.5, 1.5) is a separate sample: 13 nodes + the modal point
    assert len(p) == 14
    np.testing.assert_array_equal(p.samples[p.node_index[0]], [2.5, 1.5])
    z = p.samples[:, 0] ** 2 - p.samples[:, 1]  # degree 2 = sparse_level: interpolated exactly
    result = p.retransform(z)
    assert result.nominal == pytest.approx(4.0 - 1.25, abs=1e-14)
    # every sample serves every level; the core of y is an interval [1, 1.5], searched on the
    # interpolant (exact here): x^2 - y over {2} x [1, 1.5] is [2.5, 3]
    assert p.level_usage.all()
    np.testing.assert_allclose([result.lower[-1], result.upper[-1]], [2.5, 3.0], atol=1e-10)
    # mu = 0: x in [1, 4], y in [0, 3]: [1 - 3, 16 - 0]
    np.testing.assert_allclose([result.lower[0], result.upper[0]], [-2.0, 16.0], atol=1e-10)


def test_interpolate_reproduces_samples_and_rejects_outside_points():
    p = plan({"x": Triangular(1, 2, 4), "y": Triangular(0, 1, 3)}, method="sparse", levels=2)
    values = np.column_stack((p.samples.sum(axis=1), p.samples.prod(axis=1)))
    nodes = p.samples[p.node_index]
    np.testing.assert_allclose(p.interpolate(values, nodes), values[p.node_index], atol=1e-12)
    with pytest.raises(InvalidPlanError, match="support box"):
        p.interpolate(values, [[0.5, 1.0]])
    with pytest.raises(UnsupportedOperationError, match="sparse"):
        plan({"x": Triangular(1, 2, 4)}, method="reduced").interpolate(values, nodes)


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"sparse_level": 0}, "sparse_level must be an int >= 1"),
        ({"sparse_level": 2.0}, "sparse_level must be an int >= 1"),
        ({"sparse_level": True}, "sparse_level must be an int >= 1"),
        ({"search_points": 8}, "search_points must be an int >= 3\\^n = 9"),
        ({"search_points": 100.0}, "search_points must be an int"),
    ],
)
def test_bad_sparse_options_raise(kwargs, fragment):
    parameters = {"x": Triangular(1, 2, 3), "y": Triangular(2, 3, 4)}
    with pytest.raises(InvalidPlanError, match=fragment):
        plan(parameters, method="sparse", **kwargs)


def test_sparse_options_with_other_method_raise():
    with pytest.raises(InvalidPlanError, match="only used by method='sparse'"):
        plan({"x": Triangular(1, 2, 3)}, method="general", sparse_level=2)


def test_influence_raises():
    p = plan({"x": Triangular(1, 2, 3), "y": Triangular(2, 3, 4)}, method="sparse", levels=2)
    with pytest.raises(UnsupportedOperationError, match="method='sparse'"):
        p.retransform(p.samples.sum(axis=1)).influence()


def test_failed_samples_raise_and_touch_every_level():
    p = plan({"x": Triangular(1, 2, 3), "y": Triangular(2, 3, 4)}, method="sparse", levels=2)
    values = p.samples.sum(axis=1)
    failed = np.zeros(len(p), dtype=bool)
    failed[5] = True
    values[5] = np.nan
    assert p.levels_touched(failed).all()
    with pytest.raises(IncompleteResultError, match="interpolant needs every sample"):
        p.retransform(values, failed=failed)


def test_to_dict_round_trip_and_fingerprint():
    p = plan(
        {"x": Triangular(1, 2, 3), "y": Triangular(2, 3, 4)},
        method="sparse",
        levels=3,
        sparse_level=2,
        search_points=50,
    )
    description = p.to_dict()
    assert description["sparse_level"] == 2 and description["search_points"] == 50
    again = Plan.from_dict(description)
    np.testing.assert_array_equal(again.samples, p.samples)
    assert again.fingerprint() == p.fingerprint()
    other = plan(p.parameters, method="sparse", levels=3, sparse_level=2, search_points=60)
    assert other.fingerprint() != p.fingerprint()  # same samples, different search
    assert "sparse_level" not in plan(p.parameters).to_dict()


def test_study_runs_sparse_on_registered_product_model():
    study = Study(
        "product",
        {"x1": Triangular(1, 2, 3), "x2": Triangular(2, 3, 4)},
        method="sparse",
        levels=4,
        sparse_level=2,
    )
    result = study.run(progress=False)
    dataset = result.dataset
    assert dataset.attrs["method"] == "sparse"
    assert len(study.plan) == 13  # 13 nodes for n = 2, level 2
    np.testing.assert_allclose(dataset["z_lower"], (1 + MU) * (2 + MU), atol=1e-10)
    np.testing.assert_allclose(dataset["z_upper"], (3 - MU) * (4 - MU), atol=1e-10)
    assert "z_absolute_influence" not in dataset


def test_study_with_failed_sample_reports_every_level():
    def failing_product(samples):
        z = samples["x1"] * samples["x2"]
        return {"z": np.where(samples["x1"] > 2.9, np.nan, z)}

    study = Study(
        failing_product,
        {"x1": Triangular(1, 2, 3), "x2": Triangular(2, 3, 4)},
        method="sparse",
        levels=2,
    )
    with pytest.raises(IncompleteResultError, match="core level"):
        study.run(progress=False, on_failure="partial")


def test_study_file_with_sparse_method(tmp_path):
    path = tmp_path / "sparse.toml"
    text = """
        [study]
        method = "sparse"
        levels = 4
        sparse_level = 2
        search_points = 400

        [model]
        name = "product"

        [parameters.x1]
        type = "triangular"
        lower = 1.0
        modal = 2.0
        upper = 3.0

        [parameters.x2]
        type = "triangular"
        lower = 2.0
        modal = 3.0
        upper = 4.0
        """
    path.write_text(textwrap.dedent(text))
    study = load_study_file(path).study
    assert study.plan.method == "sparse"
    assert (study.plan.sparse_level, study.plan.search_points) == (2, 400)
    dataset = study.run(progress=False).dataset
    np.testing.assert_allclose(dataset["z_lower"], (1 + MU) * (2 + MU), atol=1e-10)
    path.write_text(textwrap.dedent(text).replace("search_points = 400", "search_points = 4"))
    with pytest.raises(StudyFileError, match="search_points"):
        load_study_file(path)
    path.write_text(textwrap.dedent(text).replace('method = "sparse"', 'method = "general"'))
    with pytest.raises(StudyFileError, match="only used by method='sparse'"):
        load_study_file(path)


def test_study_rejects_sparse_options_with_auto_screening():
    with pytest.raises(InvalidPlanError, match="only used by method='sparse'"):
        Study(
            "product",
            {"x1": Triangular(1, 2, 3), "x2": Triangular(2, 3, 4)},
            method="extended",
            nonmonotonic="auto",
            sparse_level=2,
        )
