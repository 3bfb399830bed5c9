"""A study's judging runs (the integrator tolerance's pilot, the time-integration check)
are kept in its store: a rerun takes their outcomes instead of making them again, and
its result is bit for bit the uninterrupted run's."""

from __future__ import annotations

import json
import pickle
import shutil
import warnings
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from fuzzymbs.study.integration_check import ToleranceChoice, chosen_model
from fuzzymbs.study.judging_records import CHECK, CHOICE, DeferredModel, JudgingRecords
from fuzzymbs.study.study import Study
from fuzzymbs.study.summary import summarize

TIME = np.linspace(0.0, 1.0, 51)
FUZZY = {
    "a": {"type": "triangular", "modal": 2.0, "spread": 0.1},
    "b": {"type": "triangular", "modal": 0.5, "spread": 0.8},
}


class Shared:
    """``y = a e^-t + 0.1 sin(3 b) cos(2 pi t)`` with a made-up integration error that
    scales with the tolerance, ``c rtol^1.2 (a - a0) sin(pi t)`` on the modal sample's
    shared steps (a0 its ``a``) plus the reference's ``R sin(pi t)``, as
    :mod:`fuzzymbs.mbs.shared_steps` leaves it; its tenfold tighter model's own tighter
    one takes a sequence logged ahead (``logged_ahead``), so that the pilot may choose a
    hundredth built as a tenth's tenth. ``runs`` records every evaluation: (what, rtol,
    count); ``share_steps`` counts as the logging and reference runs."""

    runs: ClassVar[list[tuple[str, float, int]]] = []
    scalable_tolerance = True
    SLOPE, REFERENCE = 300.0, 2e-6

    def __init__(self, rtol: float, modal: float | None = None) -> None:
        self.rtol, self.modal = rtol, modal
        self.outputs = {"y": "m"}
        self.coords = {"time": TIME}
        self.output_dims = {"y": ("time",)}

    @property
    def time_integration(self) -> str:
        return f"closed form, rtol {self.rtol!r}" + (", shared" if self.modal else "")

    @property
    def shares_steps(self) -> bool:
        return self.modal is not None

    @property
    def reference_error(self):
        return None if self.modal is None else {"y": self.REFERENCE * np.sin(np.pi * TIME)}

    def share_steps(self, modal) -> Shared:
        Shared.runs.append(("reference and logging", self.rtol, 3))
        return type(self)(self.rtol, float(np.asarray(modal["a"])[0]))

    def tightened(self, factor: float = 10.0) -> Shared:
        return type(self)(self.rtol / factor, self.modal)

    def logged_ahead(self, factor: float = 10.0) -> bool:
        return self.modal is not None and factor == 10.0

    def deviations(self, samples):
        out = self._evaluate(samples, "pilot")
        out["y"] = out["y"] - self._outputs(np.array([self.modal]), np.array([0.5]))[0]
        return out

    def __call__(self, samples):
        return self._evaluate(samples, "run")

    def _outputs(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        a, b = a[:, None], b[:, None]
        y = a * np.exp(-TIME) + 0.1 * np.sin(3 * b) * np.cos(2 * np.pi * TIME)
        if self.modal is None:
            return y + 0.5 * self.rtol**0.88 * np.sin(np.pi * TIME)
        error = self.SLOPE * self.rtol**1.2 * (a - self.modal) + self.REFERENCE
        return y + error * np.sin(np.pi * TIME)

    def _evaluate(self, samples, what: str) -> dict:
        a = np.asarray(samples["a"], dtype=float)
        b = np.asarray(samples.get("b", np.full(a.shape, 0.5)), dtype=float)
        Shared.runs.append((what, self.rtol, len(a)))
        failed = np.zeros(len(a), dtype=bool)
        return {"y": self._outputs(a, b), "failed": failed, "failure_reason": np.full(len(a), "")}


def _run(store: Path | None, method: str = "adaptive", resume: bool = True, shared=True):
    Shared.runs.clear()
    study = Study(
        Shared(1e-2),
        FUZZY,
        method=method,
        levels=2,
        integration_tolerance=0.01,
        shared_steps=shared,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reduced method's non-monotonic b
        return study, study.run(progress=False, store=store, resume=resume).dataset


def _assert_same(first, second) -> None:
    assert set(first.data_vars) == set(second.data_vars)
    for name, values in first.data_vars.items():
        np.testing.assert_array_equal(values.values, second[name].values)
    for key, value in first.attrs.items():
        if key.startswith(("integration_", "time_integration")):
            assert str(second.attrs[key]) == str(value), key


@pytest.mark.parametrize("method", ["adaptive", "reduced"])
def test_a_finished_study_run_again_makes_no_run(tmp_path, method):
    # the pilot, the reference, the logging runs and the check are all in the store: the
    # rerun evaluates nothing, and its result is the first run's
    _, first = _run(tmp_path, method)
    assert any(what == "pilot" for what, *_ in Shared.runs)  # the first run judged itself
    assert first.attrs["integration_tolerance_factor"] == 100.0  # a tenth's tenth
    assert first.attrs["time_integration_runs"] > 0
    assert sorted(p.name.split("-")[1] for p in (tmp_path / "judging").iterdir()) == [
        "check",
        "choice",
    ]
    again, second = _run(tmp_path, method)
    assert Shared.runs == []
    assert isinstance(again.model, DeferredModel) and again.model._model is None  # never built
    _assert_same(first, second)
    # the result says what it took from the store
    assert json.loads(first.attrs["provenance"])["judging_from_store"] == []
    taken = ["integration-check", "integration-choice"]
    assert json.loads(second.attrs["provenance"])["judging_from_store"] == taken
    assert "From the store, not run again: integration check, integration choice" in (
        summarize(second)
    )


def test_a_choice_on_each_samples_own_steps_is_kept_too(tmp_path):
    # without shared steps the pilot tightens the model itself (rtol^0.88 error law): its
    # choice and the check are kept the same way, and the model is rebuilt by its factor
    _, first = _run(tmp_path, shared=False)
    factor = first.attrs["integration_tolerance_factor"]
    assert factor > 1.0 and first.attrs["integration_shared_steps"] == 0
    again, second = _run(tmp_path, shared=False)
    assert Shared.runs == [] and again.model._model is None
    _assert_same(first, second)
    assert again.model.built().rtol == 1e-2 / factor and not again.model.built().shares_steps


def test_an_interrupted_study_resumes_without_its_pilot(tmp_path):
    # the last rounds and the check lost (as a kill after the pilot would leave it): the
    # rerun builds the chosen model again (its reference and logging runs, no pilot
    # corners), runs the missing rounds and the check, and gives the same result
    _, first = _run(tmp_path)
    rounds = sorted(tmp_path.glob("adaptive-*"))
    assert len(rounds) >= 3
    for folder in rounds[2:]:
        shutil.rmtree(folder)
    for record in (tmp_path / "judging").glob("integration-check-*"):
        record.unlink()
    _, second = _run(tmp_path)
    made = {what for what, *_ in Shared.runs}
    assert "pilot" not in made and {"reference and logging", "run"} <= made
    _assert_same(first, second)


def test_fresh_runs_make_the_judging_runs_again(tmp_path):
    _run(tmp_path)
    _, again = _run(tmp_path, resume=False)
    assert any(what == "pilot" for what, *_ in Shared.runs)
    assert again.attrs["integration_tolerance_factor"] == 100.0


def test_an_unreadable_record_is_made_again(tmp_path, caplog):
    _, first = _run(tmp_path)
    for record in (tmp_path / "judging").iterdir():
        record.write_text("{not json", encoding="utf-8")
    with caplog.at_level("WARNING", logger="fuzzymbs.study.judging_records"):
        _, second = _run(tmp_path)
    assert "unreadable" in caplog.text
    assert any(what == "pilot" for what, *_ in Shared.runs)
    _assert_same(first, second)


def test_records_are_keyed_by_code_and_description(tmp_path):
    choice = ToleranceChoice(10.0, 0.02, 12, "m", shared_steps=True, recipe=(10.0,))
    records = JudgingRecords(tmp_path, True, {"fuzzymbs_version": "1"})
    records.save(CHOICE, {"identity": 1}, choice, {"identity": None})
    loaded, extras = records.load(CHOICE, {"identity": 1})
    assert repr(loaded) == repr(choice) and extras == {"identity": None}  # NaN fields too
    assert records.load(CHOICE, {"identity": 2}) is None
    assert records.load(CHECK, {"identity": 1}) is None
    assert (
        JudgingRecords(tmp_path, True, {"fuzzymbs_version": "2"}).load(CHOICE, {"identity": 1})
        is None
    )
    assert (
        JudgingRecords(tmp_path, False, {"fuzzymbs_version": "1"}).load(CHOICE, {"identity": 1})
        is None
    )
    assert JudgingRecords(None, True, {}).load(CHOICE, {"identity": 1}) is None
    (text,) = [p.read_text() for p in (tmp_path / "judging").iterdir()]
    assert json.loads(text)["record"]["recipe"] == [10.0]


def test_the_chosen_model_is_built_again_by_its_recipe():
    # a tenth's tenth of rtol 0.03 rounds otherwise than its hundredth: the recipe keeps
    # the chain, so the model built again is the chosen one to the last bit
    assert 0.03 / 10 / 10 != 0.03 / 100
    choice = ToleranceChoice(100.0, 0.1, 12, "m", shared_steps=True, recipe=(10.0, 10.0))
    built = chosen_model(Shared(0.03), {"a": np.array([2.0]), "b": np.array([0.5])}, choice)
    assert built.rtol == 0.03 / 10 / 10 and built.modal == 2.0
    own = ToleranceChoice(3.0, 0.1, 3, "m", recipe=(3.0,))
    assert chosen_model(Shared(0.03), {}, own).rtol == 0.01 and not Shared(0.01).shares_steps


def test_a_deferred_model_answers_without_building_and_pickles_as_the_model():
    method = "closed form, rtol 0.001, shared"
    choice = ToleranceChoice(10.0, 0.1, 12, method, shared_steps=True, recipe=(10.0,))
    Shared.runs.clear()
    deferred = DeferredModel(Shared(1e-2), {"a": np.array([2.0])}, choice)
    assert deferred.shares_steps and deferred.time_integration == choice.method
    assert deferred.outputs == {"y": "m"} and not hasattr(deferred, "identity")
    assert Shared.runs == []  # nothing built yet
    samples = {"a": np.array([1.9, 2.1]), "b": np.array([0.1, 0.9])}
    direct = Shared(1e-2).share_steps({"a": np.array([2.0])}).tightened(10.0)(samples)["y"]
    np.testing.assert_array_equal(deferred(samples)["y"], direct)
    copy = pickle.loads(pickle.dumps(deferred))
    assert type(copy) is Shared and copy.rtol == 1e-3
    named = DeferredModel(Shared(1e-2), {"a": np.array([2.0])}, choice, identity={"k": 1})
    assert named.identity() == {"k": 1}
