"""Chunk store: resume, refusal of another study's store, data-only files."""

import json

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.errors import StoreMismatchError
from fuzzymbs.study.study import Study


class Counting:
    """z = x1 * x2 that counts calls and can be told to stop (KeyboardInterrupt)."""

    coords: dict = {}  # noqa: RUF012

    def __init__(self, interrupt_after=None):
        self.calls = 0
        self.interrupt_after = interrupt_after

    def __call__(self, samples):
        if self.interrupt_after is not None and self.calls >= self.interrupt_after:
            raise KeyboardInterrupt
        self.calls += 1
        return {"z": samples["x1"] * samples["x2"]}


PARAMETERS = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}


def _study(model, **kwargs):
    # 25 samples; the calls counted are the method's own (validation runs:
    # tests/study/test_method_check.py)
    kwargs.setdefault("validation_runs", 0)
    return Study(model, PARAMETERS, levels=6, name="counting", **kwargs)


def test_interrupt_then_resume_evaluates_only_missing_chunks(tmp_path):
    store = tmp_path / "store"
    with pytest.raises(KeyboardInterrupt):
        _study(Counting(interrupt_after=3)).run(store=store, chunk_size=4, progress=False)
    assert sorted(p.name for p in store.glob("chunk-*.npz")) == [
        "chunk-000000.npz",
        "chunk-000001.npz",
        "chunk-000002.npz",
    ]
    manifest = json.loads((store / "manifest.json").read_text())
    assert manifest["n_samples"] == 25 and manifest["chunk_size"] == 4

    model = Counting()
    resumed = _study(model).run(store=store, chunk_size=4, progress=False)
    assert model.calls == 7 - 3  # ceil(25 / 4) = 7 chunks, 3 stored
    assert resumed.provenance["reused_from_store"] == 12
    assert resumed.provenance["evaluated"] == 13

    clean = _study(Counting()).run(chunk_size=4, progress=False)
    for name in clean.dataset.data_vars:
        np.testing.assert_array_equal(resumed.dataset[name], clean.dataset[name], strict=True)

    # a third run finds every chunk stored; a different requested chunk size keeps the stored one
    model = Counting()
    _study(model).run(store=store, chunk_size=10, progress=False)
    assert model.calls == 0


def test_resume_false_discards_chunks(tmp_path):
    _study(Counting()).run(store=tmp_path, chunk_size=10, progress=False)
    model = Counting()
    _study(model).run(store=tmp_path, chunk_size=10, progress=False, resume=False)
    assert model.calls == 3


def test_store_of_another_study_is_refused(tmp_path):
    _study(Counting()).run(store=tmp_path, progress=False)
    other = Study(Counting(), {"x1": Triangular(1, 2, 3.5), "x2": PARAMETERS["x2"]}, levels=6)
    with pytest.raises(StoreMismatchError, match=r"different study.*plan_fingerprint"):
        other.run(store=tmp_path, progress=False)
    crisp = Study("product", {"x1": Triangular(1, 2, 3), "x2": 10.0}, levels=6)
    with pytest.raises(StoreMismatchError, match="different study"):
        crisp.run(store=tmp_path, progress=False)
    # and the store is still usable by its own study
    assert _study(Counting()).run(store=tmp_path, progress=False).status == "complete"


def test_options_are_part_of_the_identity(tmp_path):
    parameters = {"stiffness": Triangular.relative(1000.0, 0.1)}
    Study("damped-oscillator", parameters, levels=1, model_options={"time_steps": 5}).run(
        store=tmp_path, progress=False
    )
    with pytest.raises(StoreMismatchError, match="model_options"):
        Study("damped-oscillator", parameters, levels=1, model_options={"time_steps": 6}).run(
            store=tmp_path, progress=False
        )


def test_unreadable_chunk_is_evaluated_again(tmp_path):
    _study(Counting()).run(store=tmp_path, chunk_size=10, progress=False)
    (tmp_path / "chunk-000001.npz").write_bytes(b"not a zip file")
    model = Counting()
    _study(model).run(store=tmp_path, chunk_size=10, progress=False)
    assert model.calls == 1


def test_chunk_files_hold_data_only(tmp_path):
    _study(Counting()).run(store=tmp_path, chunk_size=10, progress=False)
    with np.load(tmp_path / "chunk-000000.npz", allow_pickle=False) as data:
        assert set(data.files) == {
            "start",
            "stop",
            "failed",
            "failure_reason",
            "output__z",
            "digest",
        }
        assert all(data[key].dtype != object for key in data.files)


def test_directory_with_foreign_content_is_refused(tmp_path):
    (tmp_path / "manifest.json").write_text('{"format": "something-else"}')
    with pytest.raises(StoreMismatchError, match="not a fuzzymbs-chunk-store"):
        _study(Counting()).run(store=tmp_path, progress=False)


class WithUnsetDefault:
    """A model whose parameter default is NaN ("not set"), like the gear model's overrides."""

    from fuzzymbs.study.registry import ParameterInfo

    parameters = {  # noqa: RUF012
        "x1": ParameterInfo("1", "factor", 2.0),
        "override": ParameterInfo("1", "NaN: use x1", float("nan")),
    }
    coords: dict = {}  # noqa: RUF012

    def __call__(self, samples):
        factor = np.where(np.isnan(samples["override"]), samples["x1"], samples["override"])
        return {"z": 2.0 * factor}


def test_nan_defaults_do_not_break_resume(tmp_path):
    def study():
        return Study(WithUnsetDefault(), {"x1": Triangular(1, 2, 3)}, levels=2)

    first = study().run(store=tmp_path, progress=False)
    assert '"override": "nan"' in first.dataset.attrs["provenance"]
    again = study().run(store=tmp_path, progress=False)  # no StoreMismatchError
    assert again.provenance["reused_from_store"] == len(again.dataset["sample"])
    assert again.provenance["constants"] == {"override": "nan"}
    json_text = (tmp_path / "manifest.json").read_text()
    assert "NaN" not in json_text  # strict JSON


def test_complete_store_needs_no_executor(tmp_path):
    _study(Counting()).run(store=tmp_path, progress=False)
    # an unreachable cluster is never contacted when every chunk is stored
    result = _study(Counting()).run(store=tmp_path, executor="dask://127.0.0.1:1", progress=False)
    assert result.provenance["executor"].startswith("none")


class Scaled:
    """z = scale * x1 * x2, identified by its scale through identity()."""

    coords: dict = {}  # noqa: RUF012

    def __init__(self, scale):
        self.scale = scale

    def identity(self):
        return {"scale": self.scale}

    def __call__(self, samples):
        return {"z": self.scale * samples["x1"] * samples["x2"]}


def test_model_identity_hook_keeps_differently_configured_objects_apart(tmp_path):
    Study(Scaled(1.0), PARAMETERS, levels=2).run(store=tmp_path, progress=False)
    with pytest.raises(StoreMismatchError, match="model_identity"):
        Study(Scaled(2.0), PARAMETERS, levels=2).run(store=tmp_path, progress=False)
    again = Study(Scaled(1.0), PARAMETERS, levels=2).run(store=tmp_path, progress=False)
    assert again.provenance["evaluated"] == 0


def test_oscillator_object_settings_are_part_of_the_identity(tmp_path):
    from fuzzymbs.models.closed_form import make_damped_oscillator

    parameters = {"stiffness": Triangular.relative(1000.0, 0.1), "mass": 1.0, "damping": 3.0}
    Study(make_damped_oscillator(time_steps=5), parameters, levels=1).run(
        store=tmp_path, progress=False
    )
    with pytest.raises(StoreMismatchError, match="model_identity"):
        Study(make_damped_oscillator(time_steps=6), parameters, levels=1).run(
            store=tmp_path, progress=False
        )
