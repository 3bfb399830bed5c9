"""Study(method="extended", nonmonotonic="auto"): screening, plan, provenance, store, files."""

import textwrap
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidParameterError,
    InvalidPlanError,
    StudyFileError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy import plan
from fuzzymbs.study.study import Study
from fuzzymbs.study.studyfile import load_study_file

# z = (x1 - 2)^2 + sin(x2) + x3: non-monotonic in x1 (minimum at 2 inside [0, 4]) and in x2
# (maximum of sin at pi/2 inside [1, 2.5]), linear in x3
NUMBERS = {"x1": Triangular(0, 2, 4), "x2": Triangular(1, 1.5, 2.5), "x3": Triangular(0, 1, 2)}


class CountingModel:
    """The closed form above; counts the samples it evaluates and the threads it ran on."""

    def __init__(self, fail_where=None):
        self.samples = 0
        self.threads = set()
        self.fail_where = fail_where

    def __call__(self, samples):
        self.samples += len(samples["x1"])
        self.threads.add(threading.current_thread().name)
        z = (samples["x1"] - 2) ** 2 + np.sin(samples["x2"]) + samples["x3"]
        if self.fail_where is not None:
            z = np.where(self.fail_where(samples), np.nan, z)
        return {"z": z}


def auto_study(model, **kwargs):
    # the screening and the plan are counted here; validation runs: test_method_check.py
    kwargs.setdefault("validation_runs", 0)
    return Study(model, NUMBERS, method="extended", levels=4, nonmonotonic="auto", **kwargs)


def test_auto_study_detects_names_and_matches_general():
    model = CountingModel()
    result = auto_study(model).run(progress=False)
    screening = result.provenance["screening"]
    assert screening["nonmonotonic"] == ["x1", "x2"]
    assert result.provenance["plan"]["nonmonotonic"] == ["x1", "x2"]
    # 3 parameters x 2m = 8 cut bounds off the modal point + the modal point
    assert screening["runs"] == 25 and screening["evaluated"] == 25
    # closed-form violations: along x1 (x2 = 1.5, x3 = 1) z falls by 4 to x1 = 2 and rises
    # by 4; along x2 it rises sin(1.5) - sin(1) (x2 = 1.5 is the largest point) and falls
    # sin(1.5) - sin(2.5). Range over all points: max 4 + sin(1.5) + 1 (x1 = 0 or 4), min
    # sin(1.5) + 0 (x3 = 0), i.e. 5.
    parameters = screening["parameters"]
    assert parameters["x1"]["violation"] == pytest.approx(4 / 5, rel=1e-12)
    assert parameters["x2"]["violation"] == pytest.approx(
        (np.sin(1.5) - np.sin(1.0)) / 5, rel=1e-12
    )
    assert parameters["x3"]["nonmonotonic"] is False and parameters["x3"]["violation"] == 0.0
    assert model.samples == 25 + result.provenance["samples"]
    # the same bounds as the extended plan with the names given, and as the general method
    dataset = result.dataset
    for method, names in (("extended", ["x1", "x2"]), ("general", None)):
        reference = plan(NUMBERS, method, 4, nonmonotonic=names)
        fuzzy = reference.retransform(reference.evaluate(CountingModel())["z"])
        np.testing.assert_allclose(dataset["z_lower"].values, fuzzy.lower, rtol=0, atol=1e-12)
        np.testing.assert_allclose(dataset["z_upper"].values, fuzzy.upper, rtol=0, atol=1e-12)
    assert not any("not monotonic" in text for text in result.provenance["warnings"])
    assert "Screening: 25 runs along each parameter's axis; non-monotonic: x1, x2" in (
        result.summary()
    )


def test_auto_needs_extended_and_rtol_only_with_auto():
    with pytest.raises(InvalidPlanError, match=r"nonmonotonic='auto' is only used by method="):
        Study(CountingModel(), NUMBERS, method="reduced", nonmonotonic="auto")
    with pytest.raises(InvalidPlanError, match=r"screening_rtol=0\.1 is only used with"):
        Study(CountingModel(), NUMBERS, method="extended", screening_rtol=0.1)
    with pytest.raises(InvalidParameterError, match="screening_rtol must be a finite number >= 0"):
        auto_study(CountingModel(), screening_rtol=-1.0)
    with pytest.raises(UnsupportedOperationError, match="only a study with nonmonotonic='auto'"):
        Study(CountingModel(), NUMBERS, method="extended", nonmonotonic=["x1"]).screen()


def test_plan_is_known_after_screen_and_screen_runs_once():
    model = CountingModel()
    study = auto_study(model)
    assert "not screened yet" in repr(study)
    with pytest.raises(UnsupportedOperationError, match=r"call study\.screen\(\) or study\.run"):
        study.plan  # noqa: B018
    report = study.screen()
    assert report["nonmonotonic"] == ["x1", "x2"] and model.samples == 25
    assert study.plan.nonmonotonic == ("x1", "x2")
    assert len(study.plan) == len(plan(NUMBERS, "extended", 4, nonmonotonic=["x1", "x2"]))
    assert study.screen() is report and model.samples == 25  # not evaluated again
    study.run(progress=False)
    assert model.samples == 25 + len(study.plan)


def test_large_rtol_treats_a_small_reversal_as_monotonic():
    # rtol 0.05 ignores steps up to 0.05 * 5 = 0.25: every step of sin along x2 is below
    # 0.19 (sin(2.25) - sin(2.5)), while x1's steps reach 1.75 both ways
    report = auto_study(CountingModel(), screening_rtol=0.05).screen()
    assert report["nonmonotonic"] == ["x1"]


def test_resumed_auto_study_reuses_its_chunks(tmp_path):
    store = tmp_path / "store"
    first = auto_study(CountingModel()).run(progress=False, store=store, chunk_size=8)
    assert (store / "screening" / "manifest.json").exists()
    model = CountingModel()
    again = auto_study(model).run(progress=False, store=store, chunk_size=8)
    assert model.samples == 0  # neither the screening nor the plan is evaluated again
    provenance = again.provenance
    assert provenance["evaluated"] == 0 and provenance["reused_from_store"] == provenance["samples"]
    assert provenance["screening"]["reused_from_store"] == 25
    assert provenance["screening"]["nonmonotonic"] == ["x1", "x2"]
    np.testing.assert_array_equal(again.dataset["z_lower"], first.dataset["z_lower"])
    np.testing.assert_array_equal(again.dataset["z_upper"], first.dataset["z_upper"])
    # an interrupted run: one screening chunk and one plan chunk missing
    (store / "screening" / "chunk-000001.npz").unlink()
    (store / "chunk-000003.npz").unlink()
    model = CountingModel()
    resumed = auto_study(model).run(progress=False, store=store, chunk_size=8)
    assert model.samples == 16
    np.testing.assert_array_equal(resumed.dataset["z_lower"], first.dataset["z_lower"])
    # resume=False evaluates both again
    model = CountingModel()
    auto_study(model).run(progress=False, store=store, resume=False)
    assert model.samples == 25 + provenance["samples"]


def test_screening_runs_on_the_studys_executor():
    model = CountingModel()
    with ThreadPoolExecutor(max_workers=2, thread_name_prefix="worker") as pool:
        result = auto_study(model).run(progress=False, executor=pool, chunk_size=4)
    assert model.threads and all(name.startswith("worker") for name in model.threads)
    inline = auto_study(CountingModel()).run(progress=False)
    np.testing.assert_array_equal(result.dataset["z_lower"], inline.dataset["z_lower"])
    assert result.provenance["screening"]["nonmonotonic"] == ["x1", "x2"]


def test_failed_screening_samples_are_left_out_and_recorded():
    # fails only at the screening point x1 = 0.5 (others modal); the extended plan has
    # x3 = 1 only at the core level, where x1 = 2, so the plan itself does not fail
    def fails(samples):
        return (samples["x1"] == 0.5) & (samples["x3"] == 1.0) & (samples["x2"] == 1.5)

    result = auto_study(CountingModel(fails)).run(progress=False)
    screening = result.provenance["screening"]
    assert screening["nonmonotonic"] == ["x1", "x2"]
    assert len(screening["excluded_samples"]) == 1
    assert screening["parameters"]["x1"]["excluded_points"] == 1
    assert next(iter(screening["failure_reasons"].values()))  # a reason is recorded
    assert any("screening samples failed" in text for text in screening["warnings"])
    with pytest.raises(IncompleteResultError, match=r"fail-fast.*screening.*x1=0\.5"):
        auto_study(CountingModel(fails)).run(progress=False, on_failure="fail-fast")


def test_too_many_failed_screening_samples_is_an_error():
    # levels = 1: the x3 axis is (0, 1, 2); two failures leave one point
    def fails(samples):
        return (samples["x3"] != 1.0) & (samples["x1"] == 2.0) & (samples["x2"] == 1.5)

    study = Study(CountingModel(fails), NUMBERS, method="extended", levels=1, nonmonotonic="auto")
    with pytest.raises(IncompleteResultError, match=r"parameter 'x3'.*leaving 1.*x3=0"):
        study.run(progress=False)


STUDY_FILE = """
[study]
method = "extended"
levels = 2
outputs = ["{output}"]
nonmonotonic = {nonmonotonic}

[model]
name = "damped-oscillator"
[model.options]
time_steps = 21

[parameters.mass]
type = "triangular"
modal = 1.0
spread = 0.1

[parameters.stiffness]
type = "triangular"
modal = 1000.0
spread = 0.1
"""


def write(tmp_path, output, nonmonotonic):
    path = tmp_path / "study.toml"
    path.write_text(textwrap.dedent(STUDY_FILE.format(output=output, nonmonotonic=nonmonotonic)))
    return path


def test_study_file_auto(tmp_path):
    from fuzzymbs.study.pipeline import run_study_file

    # f = sqrt(k / m) / (2 pi) is monotonic in both: nothing detected, the reduced corners
    definition = load_study_file(write(tmp_path, "natural_frequency", '"auto"'))
    assert definition.study.screen()["nonmonotonic"] == []
    assert len(definition.study.plan) == 2 * 2**2 + 1
    # the displacement's phase omega t moves by about +-1.6 rad over the stiffness and mass
    # cuts at t = 1 s (omega = 31.6 rad/s, +-5 %), so x(t) passes an extremum along both axes
    path = write(tmp_path, "displacement", '"auto"')
    output = run_study_file(path, tmp_path / "out", progress=False, plots=False)
    assert output.result.provenance["screening"]["nonmonotonic"] == ["mass", "stiffness"]
    assert (tmp_path / "out" / "chunks" / "screening" / "manifest.json").exists()
    again = run_study_file(path, tmp_path / "out", progress=False, plots=False)
    assert again.result.provenance["evaluated"] == 0
    assert again.result.provenance["screening"]["evaluated"] == 0


@pytest.mark.parametrize(
    ("value", "pattern"),
    [
        ('"automatic"', r"key 'study\.nonmonotonic'.*list of parameter names.*or \"auto\""),
        ("3", r"key 'study\.nonmonotonic'.*list of parameter names"),
        ('["mass", 2]', r"key 'study\.nonmonotonic'.*list of parameter names"),
    ],
)
def test_study_file_bad_nonmonotonic_values(tmp_path, value, pattern):
    path = write(tmp_path, "displacement", value)
    with pytest.raises(StudyFileError, match=pattern) as caught:
        load_study_file(path)
    assert str(path) in str(caught.value)


def test_study_file_auto_needs_extended(tmp_path):
    path = write(tmp_path, "displacement", '"auto"')
    path.write_text(path.read_text().replace('method = "extended"', 'method = "reduced"'))
    with pytest.raises(StudyFileError, match=r"\[study\]: nonmonotonic='auto' is only used by"):
        load_study_file(path)
