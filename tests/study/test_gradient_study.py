"""Adaptive studies with the model's gradients: the protocol, the option, the store."""

import shutil

import numpy as np
import pytest
from same_results import assert_identical

from fuzzymbs import Study
from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidParameterError,
    InvalidPlanError,
    ModelOutputError,
    StudyFileError,
)
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.differentiable import CaseModel
from fuzzymbs.models.closed_form.hard_cases import bump3, dense_truth
from fuzzymbs.models.closed_form.resonance import sdof_resonance, sdof_truth
from fuzzymbs.study.evaluation import evaluate_chunk

BUMP = triangular_numbers(bump3().triangles)


def _bump_study(**options):
    return Study("bump3", BUMP, method="adaptive", levels=3, **options)


def test_case_models_return_gradients_in_wrt_order():
    # the registered model's gradients are the case's analytic ones, columns in wrt order
    model = CaseModel("bump3")
    samples = {"x1": np.array([0.1, -0.4]), "x2": np.array([0.3, 0.2]), "x3": np.array([0.5, 1.0])}
    _, reference = bump3().gradient(samples)
    out = model(samples, wrt=["x3", "x1"])
    np.testing.assert_array_equal(out["gradients"]["z"], reference["z"][:, [2, 0]])
    np.testing.assert_array_equal(out["z"], model(samples)["z"])
    assert model.differentiable == ("x1", "x2", "x3")
    with pytest.raises(InvalidParameterError, match="x9"):
        model(samples, wrt=["x9"])


def test_gradients_halve_the_runs_and_the_bands_stay_honest():
    # bump3 through a study (the registered model, levels 0, 1/3, 2/3, 1): 196 runs
    # without gradients, 60 with (measured); against dense-grid truth the bands miss at
    # most the tolerance (+0.1 %, the truth's resolution)
    with_gradients = _bump_study().run(progress=False)
    attrs = with_gradients.dataset.attrs
    assert attrs["adaptive_gradients"] == "x1, x2, x3"
    assert attrs["method_converged"] and attrs["adaptive_runs"] <= 196 // 2
    truth = dense_truth(bump3(), with_gradients.dataset["level"].values)["z"]
    miss = band_miss(with_gradients.dataset["z_lower"], with_gradients.dataset["z_upper"], *truth)
    assert miss <= 0.011 and attrs["method_error"] <= 0.01
    assert "with the model's gradients (x1, x2, x3)" in with_gradients.summary()


def test_resonance_with_gradients_is_honest_against_the_closed_form():
    # the forced oscillator's ridge at 5 % damping, 4 levels: true miss within the
    # tolerance or a reported error of at least half the miss
    case = sdof_resonance(0.05)
    result = Study(
        "sdof-resonance", triangular_numbers(case.triangles), method="adaptive", levels=3
    ).run(progress=False)
    data = result.dataset
    assert data.attrs["adaptive_gradients"] == "stiffness, mass, damping_ratio"
    truth = sdof_truth(case, data["level"].values)["amplitude"]
    miss = band_miss(data["amplitude_lower"], data["amplitude_upper"], *truth)
    assert miss <= 0.01 or data.attrs["method_error"] >= 0.5 * miss


def test_option_off_is_todays_value_only_study_bit_for_bit():
    # gradients = false on a differentiable model: the rounds of a model without gradients
    case = sdof_resonance(0.05)
    numbers = triangular_numbers(case.triangles)
    plain = Study(case.model, numbers, method="adaptive", levels=3).run(progress=False)
    off = Study("sdof-resonance", numbers, method="adaptive", levels=3, gradients=False).run(
        progress=False
    )
    assert_identical(off.dataset, plain.dataset)
    for key in ("method_error", "adaptive_runs", "adaptive_rounds"):
        assert off.dataset.attrs[key] == plain.dataset.attrs[key]
    assert off.dataset.attrs["adaptive_gradients"] == "none"
    assert "gradients" not in off.summary()


def test_a_resumed_study_gets_its_gradients_back(tmp_path):
    store = tmp_path / "store"
    numbers = triangular_numbers(sdof_resonance(0.05).triangles)

    def study(**options):
        return Study("sdof-resonance", numbers, method="adaptive", levels=2, **options)

    first = study().run(store=store, progress=False)
    rounds = sorted(p for p in store.iterdir() if p.name.startswith("adaptive-"))
    assert all(p.name.endswith("-gradients") for p in rounds)
    with np.load(rounds[0] / "chunk-000000.npz") as chunk:
        assert chunk["gradient__amplitude"].shape == (len(chunk["failed"]), 3)
    shutil.rmtree(rounds[-1])  # the last round lost, as after kill -9
    again = study().run(store=store, progress=False)
    assert 0 < again.provenance["evaluated"] < again.provenance["reused_from_store"]
    assert_identical(again.dataset, first.dataset)
    assert again.dataset.attrs["method_error"] == first.dataset.attrs["method_error"]
    # the same store without gradients: rounds of their own, never the chunks with them
    off = study(gradients=False).run(store=store, progress=False)
    assert off.provenance["reused_from_store"] == 0


class _Partial:
    """Differentiates with respect to x1 only."""

    differentiable = ("x1",)

    def __call__(self, samples, wrt=None):
        out = {"z": samples["x1"] * samples["x2"]}
        if wrt is not None:
            out["gradients"] = {"z": samples["x2"][:, None] * np.ones((1, len(wrt)))}
        return out


def test_true_names_the_parameters_the_model_cannot_differentiate():
    numbers = triangular_numbers({"x1": (1.0, 2.0, 3.0), "x2": (9.0, 10.0, 11.0)})
    with pytest.raises(InvalidParameterError, match=r"x2 \(it declares only x1\)"):
        Study(_Partial(), numbers, method="adaptive", levels=2, gradients=True)
    with pytest.raises(InvalidParameterError, match=r"x1, x2 \(it declares none"):
        Study("product", numbers, method="adaptive", levels=2, gradients=True)
    # auto: not every fuzzy parameter is differentiable, so no gradients are asked for
    auto = Study(_Partial(), numbers, method="adaptive", levels=2)
    assert auto.gradient_parameters() == ()
    # a fixed method takes no such option
    with pytest.raises(InvalidPlanError, match="only used by method='adaptive'"):
        Study("bump3", BUMP, method="reduced", gradients=True)


class _Faulty:
    """Differentiable model whose gradients go wrong in the way ``fault`` says."""

    differentiable = ("x1", "x2", "x3")

    def __init__(self, fault):
        self.fault = fault

    def __call__(self, samples, wrt=None):
        out = CaseModel("bump3")(samples, wrt)
        if wrt is None:
            return out
        slope = out["gradients"]["z"]
        if self.fault == "nan":
            slope[samples["x3"] > 0.9] = np.nan
        elif self.fault == "shape":
            out["gradients"]["z"] = slope[:, :2]
        elif self.fault == "missing":
            del out["gradients"]
        return out


def test_nan_gradients_fail_their_runs_and_wrong_shapes_are_errors():
    with pytest.raises(IncompleteResultError, match=r"non-finite gradient .* with respect to"):
        Study(_Faulty("nan"), BUMP, method="adaptive", levels=2).run(progress=False)
    with pytest.raises(ModelOutputError, match=r"shape \(\d+, 3\)"):
        Study(_Faulty("shape"), BUMP, method="adaptive", levels=2).run(progress=False)
    with pytest.raises(ModelOutputError, match="returned no gradients"):
        Study(_Faulty("missing"), BUMP, method="adaptive", levels=2).run(progress=False)


def test_a_chunk_evaluated_sample_by_sample_keeps_its_gradients():
    # a batched call that raises is re-run one sample at a time: the gradients of the
    # samples that succeed come back, the failing one is marked failed
    def model(samples, wrt=None):
        if len(samples["x1"]) > 1:
            raise RuntimeError("batch")
        if samples["x1"][0] > 0.5:
            raise RuntimeError("diverged")
        return CaseModel("bump3")(samples, wrt)

    columns = {"x1": np.array([0.0, 0.9, -0.3]), "x2": np.zeros(3), "x3": np.full(3, 0.5)}
    chunk = evaluate_chunk(model, columns, 0, wrt=("x1", "x2", "x3"))
    np.testing.assert_array_equal(chunk.failed, [False, True, False])
    assert (
        np.isnan(chunk.gradients["z"][1]).all() and np.isfinite(chunk.gradients["z"][[0, 2]]).all()
    )


def test_study_file_option(tmp_path):
    from fuzzymbs.study.studyfile import load_study_file

    text = (
        '[study]\nmethod = "adaptive"\nlevels = 2\ngradients = {value}\n'
        '[model]\nname = "sdof-resonance"\n'
        '[parameters.stiffness]\ntype = "triangular"\nlower = 900.0\nmodal = 1000.0\n'
        "upper = 1100.0\n"
    )
    path = tmp_path / "study.toml"
    for value, expected in (("false", ()), ('"auto"', ("stiffness",)), ("true", ("stiffness",))):
        path.write_text(text.format(value=value))
        assert load_study_file(path).study.gradient_parameters() == expected
    path.write_text(text.format(value='"yes"'))
    with pytest.raises(StudyFileError, match="gradients"):
        load_study_file(path)


@pytest.mark.slow
def test_gradient_rounds_agree_across_executors():
    # the gradients travel with the chunks: a process pool and a Dask cluster with other
    # chunkings give the inline study's bounds, runs and certified error bit for bit
    from same_results import local_dask_client

    inline = _bump_study().run(progress=False, chunk_size=16)
    pooled = _bump_study().run(executor="processes:2", chunk_size=7, progress=False)
    with local_dask_client() as (_, client):
        by_dask = _bump_study().run(executor=client, chunk_size=5, progress=False)
    for other in (pooled, by_dask):
        assert_identical(other.dataset, inline.dataset)
        for key in ("method_error", "adaptive_runs", "adaptive_gradients"):
            assert other.dataset.attrs[key] == inline.dataset.attrs[key]


class _PricedCase:
    """A differentiable model whose gradients cost ``cost`` of a run per parameter."""

    differentiable = ("a", "b", "c")

    def __init__(self, cost: float | None) -> None:
        if cost is not None:
            self.gradient_cost = cost


def test_auto_asks_for_gradients_only_where_they_cost_less_than_the_runs_they_save():
    # the rule of fuzzymbs.study.gradients: 1 + n x gradient_cost <= AUTO_MAX_RUN_COST, within
    # the harmonic means of the measured savings (1.27 to 1.52)
    from fuzzymbs.study.gradients import AUTO_MAX_RUN_COST, gradient_parameters

    names = ("a", "b", "c")
    assert AUTO_MAX_RUN_COST == 1.4
    assert gradient_parameters(_PricedCase(None), names, "auto", "m") == names  # free
    assert gradient_parameters(_PricedCase(0.13), names, "auto", "m") == names  # 1.39 runs
    assert gradient_parameters(_PricedCase(0.14), names, "auto", "m") == ()  # 1.42 runs
    assert gradient_parameters(_PricedCase(0.72), names, "auto", "m") == ()  # the brake: 3.16
    assert gradient_parameters(_PricedCase(0.72), names, True, "m") == names  # asked for


def test_the_brake_studies_run_without_gradients_by_default():
    # the brake's three-parameter studies: its sensitivities cost 0.72 of a run per
    # parameter with ROS34PW2 (docs/benchmarks.md, "Forward sensitivities"), 3.2 runs in all
    from fuzzymbs.models.brake import DiscBrake
    from fuzzymbs.study.gradients import gradient_parameters

    brake = DiscBrake(t_end=1e-4)
    names = ("pad_spring_stiffness", "caliper_spring_stiffness", "nodal_force")
    assert set(names) <= set(brake.differentiable)
    assert gradient_parameters(brake, names, "auto", "brake") == ()
    assert gradient_parameters(brake, names[:1], "auto", "brake") == ()  # one: 1.72 runs
    assert gradient_parameters(brake, names, True, "brake") == names  # asked for


def test_command_line_option_reaches_the_method(tmp_path):
    # fuzzymbs run --option gradients=false: a method's option overrides the file's
    from fuzzymbs.study.studyfile import load_study_file

    path = tmp_path / "study.toml"
    path.write_text(
        '[study]\nmethod = "adaptive"\nlevels = 2\n[model]\nname = "sdof-resonance"\n'
        '[parameters.stiffness]\ntype = "triangular"\nlower = 900.0\nmodal = 1000.0\n'
        "upper = 1100.0\n"
    )
    assert load_study_file(path).study.gradient_parameters() == ("stiffness",)
    loaded = load_study_file(path, study_options={"gradients": False})
    assert loaded.study.gradient_parameters() == ()
    with pytest.raises(StudyFileError, match="gradients"):
        load_study_file(path, study_options={"gradients": "yes"})
