"""Study API: exact cuts and influence of closed forms, parameters, dataset layout."""

import json

import numpy as np
import pytest

import fuzzymbs
from fuzzymbs import Triangular
from fuzzymbs.errors import InvalidFuzzyNumberError, InvalidParameterError
from fuzzymbs.study.result import StudyResult
from fuzzymbs.study.study import Study


def product_study(**kwargs):
    return Study(
        "product", {"x1": Triangular(1, 2, 3), "x2": Triangular(2, 3, 4)}, levels=4, **kwargs
    )


def test_product_cuts_match_closed_form():
    # THEORY.md sec. 1 oracle: z = x*y, x = TFN(1,2,3), y = TFN(2,3,4):
    # exact cuts [(1+mu)(2+mu), (3-mu)(4-mu)]; reduced method exact (monotonic), rtol 1e-14.
    result = product_study().run(progress=False)
    ds = result.dataset
    mu = ds["level"].values
    np.testing.assert_allclose(mu, [0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(ds["z_lower"].values, (1 + mu) * (2 + mu), rtol=1e-14)
    np.testing.assert_allclose(ds["z_upper"].values, (3 - mu) * (4 - mu), rtol=1e-14)
    assert ds["z_nominal"].item() == 6.0
    lo, hi = result.alpha_cut("z", 0.3)  # between levels: the next level up (0.5)
    assert (lo, hi) == (1.5 * 2.5, 2.5 * 3.5)
    assert result.status == "complete" and not result.failed.any()
    assert len(ds["sample"]) == 4 * 2**2 + 1  # m 2^n + 1 (Hanss, reduced method)


def test_product_influence_matches_gain_factors():
    # THEORY.md sec. 1 oracle: z = x1 x2, x1 = TFN(1,2,3), x2 = TFN(9,10,11): eta = (10, 2);
    # equal widths, so kappa is proportional to |eta| and rho = (5/6, 1/6).
    study = Study("product", {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)})
    ds = study.run(progress=False).dataset
    np.testing.assert_allclose(ds["z_mean_gain"].values, [10.0, 2.0], rtol=1e-12)
    np.testing.assert_allclose(ds["z_relative_influence"].values, [5 / 6, 1 / 6], rtol=1e-12)
    assert list(ds["parameter"].values) == ["x1", "x2"]


def test_definitions_crisp_values_and_defaults():
    study = Study(
        "damped-oscillator",
        {"mass": {"type": "triangular", "modal": 1.0, "spread": 0.1}, "damping": 5.0},
        levels=2,
        model_options={"time_steps": 11},
    )
    assert study.plan.names == ("mass",)
    assert study.constants == {"damping": 5.0, "stiffness": 1000.0}  # stiffness: the default
    columns = study.columns(0, 3)
    np.testing.assert_array_equal(columns["damping"], [5.0, 5.0, 5.0])
    np.testing.assert_array_equal(columns["mass"], study.plan.samples[:3, 0])


def test_unknown_parameter_lists_valid_ones():
    with pytest.raises(InvalidParameterError, match=r"\['mas'\].*mass \[kg\], stiffness \[N/m\]"):
        Study("damped-oscillator", {"mas": Triangular(0.9, 1, 1.1)})


def test_unknown_output_and_option_and_model():
    with pytest.raises(InvalidParameterError, match=r"unknown output.*'zz'.*outputs: z"):
        Study("product", {"x1": Triangular(1, 2, 3)}, outputs=["zz"])
    with pytest.raises(InvalidParameterError, match=r"no option.*'speed'"):
        Study("product", {"x1": Triangular(1, 2, 3)}, model_options={"speed": 1})
    with pytest.raises(InvalidParameterError, match="unknown model 'nope'"):
        Study("nope", {"x1": Triangular(1, 2, 3)})


def test_invalid_fuzzy_definition():
    with pytest.raises(InvalidFuzzyNumberError, match="x1"):
        Study("product", {"x1": {"type": "triangular", "lower": 3, "modal": 2, "upper": 1}})
    with pytest.raises(InvalidFuzzyNumberError, match=r"'x1'.*not one of"):
        Study("product", {"x1": {"type": "triangle", "modal": 2, "spread": 0.1}})


def test_plain_callable_model_and_lazy_export():
    assert fuzzymbs.Study is Study

    def model(samples):
        return {"y": 2 * samples["a"] + samples["b"]}

    # THEORY.md sec. 1 oracle: z = 2 x1 + x2, both TFN(-1, 0, 1): rho = (2/3, 1/3)
    study = fuzzymbs.Study(model, {"a": Triangular(-1, 0, 1), "b": Triangular(-1, 0, 1)})
    ds = study.run(progress=False).dataset
    np.testing.assert_allclose(ds["y_relative_influence"].values, [2 / 3, 1 / 3], rtol=1e-12)
    np.testing.assert_allclose(ds["y_lower"].values, -3 * (1 - ds["level"].values), atol=1e-15)


def test_signal_dataset_layout_and_netcdf_roundtrip(tmp_path):
    study = Study(
        "damped-oscillator",
        {"stiffness": Triangular.relative(1000.0, 0.02)},
        levels=2,
        model_options={"time_steps": 21, "duration": 0.05},
        name="osc",
    )
    result = study.run(progress=False)
    ds = result.dataset
    assert ds["displacement_lower"].dims == ("level", "time")
    assert ds["natural_frequency_lower"].dims == ("level",)
    assert ds["displacement_reference"].dims == ("time",)
    np.testing.assert_array_equal(ds["time"].values, study.model.coords["time"])
    assert ds["displacement_lower"].attrs["units"] == "m"
    # natural frequency sqrt(k/m)/(2 pi) is monotonic in k: cuts are exact (rtol 1e-14)
    k_lo = 1000.0 * (1 - 0.02 * (1 - ds["level"].values))
    np.testing.assert_allclose(
        ds["natural_frequency_lower"].values, np.sqrt(k_lo) / (2 * np.pi), rtol=1e-14
    )
    provenance = result.provenance
    for key in ("versions", "plan", "wall_time_s", "evaluated", "model", "plan_fingerprint"):
        assert key in provenance
    assert provenance["evaluated"] == len(study.plan) and provenance["plan"]["method"] == "reduced"
    assert json.loads(ds.attrs["outputs"]) == ["displacement", "natural_frequency"]
    path = result.to_netcdf(tmp_path / "r.nc")
    reopened = StudyResult.open(path)
    assert reopened.dataset.identical(ds)
    assert "complete" in result.summary()


def test_output_subset():
    study = Study(
        "damped-oscillator",
        {"mass": Triangular.relative(1.0, 0.1)},
        levels=1,
        outputs=["natural_frequency"],
        model_options={"time_steps": 5},
    )
    ds = study.run(progress=False).dataset
    assert json.loads(ds.attrs["outputs"]) == ["natural_frequency"]
    assert "displacement_lower" not in ds


@pytest.mark.parametrize("method", ["general", "grid"])
def test_general_and_grid_bounds_and_influence(method):
    # product of positive TFNs: every scheme that includes the cut corners is exact here
    result = product_study(method=method).run(progress=False)
    ds = result.dataset
    mu = ds["level"].values
    np.testing.assert_allclose(ds["z_lower"].values, (1 + mu) * (2 + mu), rtol=1e-14)
    np.testing.assert_allclose(ds["z_upper"].values, (3 - mu) * (4 - mu), rtol=1e-14)
    if method == "general":
        assert "z_relative_influence" not in ds
        assert "influence" not in result.summary()
    else:
        # the grid's corner runs give the reduced method's gains: for z = x1 x2 with
        # x1 = TFN(1, 2, 3), x2 = TFN(2, 3, 4) the pairs average to eta = (3, 2) on the 4
        # level below the core (closed form: mean of the other factor's cut bounds)
        gain = ds["z_gain"].values  # (parameter, level)
        np.testing.assert_allclose(gain[:, :-1], [[3.0] * 4, [2.0] * 4], rtol=1e-14)
        assert np.isnan(gain[:, -1]).all()  # zero-width core: no gain


def test_netcdf3_fallback_roundtrip(tmp_path, monkeypatch):
    # a minimal install has neither h5py nor netCDF4: SciPy's NetCDF-3 writer must do
    import fuzzymbs.study.result as result_module

    monkeypatch.setattr(result_module, "netcdf_engine", lambda: "scipy")
    study = Study(
        "damped-oscillator",
        {"mass": Triangular(-0.2, 1.0, 1.5)},
        levels=3,
        model_options={"time_steps": 11},
    )
    result = study.run(progress=False, on_failure="partial")  # with failure reasons (strings)
    path = result.to_netcdf(tmp_path / "r.nc")
    assert path.read_bytes()[:3] == b"CDF"  # NetCDF classic format
    reopened = StudyResult.open(path)
    assert reopened.dataset.identical(result.dataset)
    assert reopened.failed.any() and reopened.status == "partial"


@pytest.mark.parametrize("chunk_size", [0, -3, 1.5, True, "4"])
def test_bad_chunk_size_is_named(chunk_size):
    study = Study("product", {"x1": Triangular(1, 2, 3)}, levels=1)
    with pytest.raises(InvalidParameterError, match="chunk_size must be a positive int"):
        study.run(progress=False, chunk_size=chunk_size)


def test_chunk_size_one_equals_one_chunk():
    # the same samples in 1-sample chunks or in one chunk give bit-identical bounds
    study = Study("product", {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}, levels=2)
    single = study.run(progress=False, chunk_size=1).dataset
    whole = study.run(progress=False, chunk_size=len(study.plan)).dataset
    np.testing.assert_array_equal(single["z_lower"].values, whole["z_lower"].values)
    np.testing.assert_array_equal(single["z_upper"].values, whole["z_upper"].values)


def test_alpha_cut_of_unknown_output_or_bad_level_is_named():
    result = product_study().run(progress=False)
    with pytest.raises(InvalidParameterError, match=r"no output 'w'; outputs: z"):
        result.alpha_cut("w", 0.5)
    with pytest.raises(InvalidParameterError, match=r"mu must lie in \[0, 1\]"):
        result.alpha_cut("z", 1.5)


def test_invalid_definition_names_a_short_parameter_name():
    # a one-letter name occurs in almost any message: it must still be named explicitly
    from fuzzymbs.study.parameters import fuzzy_number_from_definition

    with pytest.raises(InvalidFuzzyNumberError, match=r"parameter 'a': .*spread must be >= 0"):
        fuzzy_number_from_definition({"type": "triangular", "modal": 1.0, "spread": -0.1}, "a")


def test_output_names_that_would_overwrite_dataset_variables_are_refused():
    from fuzzymbs.errors import ModelOutputError

    # "parameter_lower" holds the input cuts: an output "parameter" silently lost its bounds
    def named_parameter(samples):
        return {"parameter": 2.0 * samples["x"]}

    with pytest.raises(ModelOutputError, match=r"'parameter'.*'parameter_lower'"):
        Study(named_parameter, {"x": Triangular(1, 2, 3)}, levels=1).run(progress=False)

    # declared outputs are checked before anything is evaluated
    class Declared:
        outputs = {"z": "m", "z_mean": "m"}  # noqa: RUF012 - z_mean_gain is also z's mean gain

        def __call__(self, samples):
            raise AssertionError("must not be evaluated")

    with pytest.raises(ModelOutputError, match=r"'z_mean_gain'.*output 'z'"):
        Study(Declared(), {"x": Triangular(1, 2, 3)}, levels=1)
