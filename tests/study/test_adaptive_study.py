"""Adaptive studies: rounds through executors and the store, resume, study files."""

import shutil

import numpy as np
import pytest
from same_results import assert_identical, local_dask_client

from fuzzymbs import Study
from fuzzymbs.errors import IncompleteResultError
from fuzzymbs.fuzzy import Triangular
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import bump3, dense_truth


def _study(**options):
    case = bump3()
    return Study(
        case.model, triangular_numbers(case.triangles), method="adaptive", levels=5, **options
    )


def test_rounds_resume_from_the_store_and_agree_across_executors(tmp_path):
    store = tmp_path / "store"
    first = _study().run(store=store, progress=False)
    rounds = sorted(p.name for p in store.iterdir() if p.name.startswith("adaptive-"))
    assert len(rounds) == first.dataset.attrs["adaptive_rounds"]
    # the last round lost (as after kill -9 before it was written): only it is run again
    shutil.rmtree(store / rounds[-1])
    again = _study().run(store=store, progress=False)
    last = len(again.dataset["sample"]) - again.provenance["reused_from_store"]
    assert 0 < last == again.provenance["evaluated"]
    pooled = _study().run(executor="processes:2", chunk_size=7, progress=False)
    for other in (again, pooled):  # bit-identical bounds
        np.testing.assert_array_equal(first.dataset["z_lower"], other.dataset["z_lower"])
        np.testing.assert_array_equal(first.dataset["z_upper"], other.dataset["z_upper"])
    # its certification is its check: no validation runs; the result is within 1 %
    # (+0.1 %, dense_truth's resolution) of the dense-grid truth
    attrs = first.dataset.attrs
    assert "validation_runs" not in attrs and attrs["method_error"] <= 0.01
    truth = dense_truth(bump3(), first.dataset["level"].values)["z"]
    assert band_miss(first.dataset["z_lower"], first.dataset["z_upper"], *truth) <= 0.011
    assert "certified method error" in first.summary()


def test_a_failed_run_stops_an_adaptive_study():
    def fails(s):
        z = s["x1"] * s["x2"]
        return {"z": np.where(s["x1"] > 1.9, np.nan, z)}

    study = Study(
        fails, {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}, method="adaptive", levels=3
    )
    with pytest.raises(IncompleteResultError, match="adaptive round"):
        study.run(progress=False)


def test_study_file_takes_the_adaptive_method(tmp_path):
    from fuzzymbs.study.studyfile import load_study_file

    path = tmp_path / "study.toml"
    path.write_text(
        '[study]\nmethod = "adaptive"\nlevels = 3\nmethod_tolerance = 0.02\nmax_runs = 500\n'
        '[model]\nname = "product"\n'
        '[parameters.x1]\ntype = "triangular"\nlower = 1.0\nmodal = 2.0\nupper = 3.0\n'
        '[parameters.x2]\ntype = "triangular"\nlower = 9.0\nmodal = 10.0\nupper = 11.0\n'
    )
    definition = load_study_file(path)
    plan = definition.study.plan
    assert (plan.method, plan.method_tolerance, plan.max_runs) == ("adaptive", 0.02, 500)


def test_adaptive_rounds_on_dask_are_bit_identical_to_inline():
    # every round's points follow from the earlier rounds' outputs alone, so a Dask
    # cluster (here one in-process worker of two threads, as in test_executors.py) with
    # another chunking must give the same runs, bounds and certified error bit for bit
    inline = _study().run(progress=False, chunk_size=16)
    with local_dask_client() as (_, client):
        by_dask = _study().run(executor=client, chunk_size=7, progress=False)
    assert by_dask.provenance["executor"] != inline.provenance["executor"]
    assert_identical(by_dask.dataset, inline.dataset)
    for key in ("method_error", "adaptive_runs", "adaptive_rounds"):
        assert by_dask.dataset.attrs[key] == inline.dataset.attrs[key]
