"""Online retransformation in a study (fuzzymbs.study.streaming, fuzzymbs.fuzzy.accumulate).

References: the in-memory retransformation of all sample outputs at once
(Plan.retransform, itself tested against closed forms in tests/fuzzy) -- the study's
chunk-by-chunk reduction must give the same bounds, nominal values, gain factors and
influence measures bit for bit, whatever the chunk size and arrival order; and
tracemalloc for the claim that memory does not grow with the number of runs.
"""

import tracemalloc
import warnings

import numpy as np
import pytest

from fuzzymbs import Study
from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.fuzzy.transform import plan as make_plan
from fuzzymbs.study import streaming
from fuzzymbs.study.evaluation import evaluate_chunk
from fuzzymbs.study.store import read_outputs
from fuzzymbs.study.streaming import ChunkFeed

TIME = np.linspace(0.0, 1.0, 41)


def signal_model(p):
    """A smooth signal, monotonic in a and b, non-monotonic in c around 1 (extended)."""
    a, b, c = p["a"][:, None], p["b"][:, None], p["c"][:, None]
    return {
        "y": a * np.sin(3.0 * TIME) + b * TIME**2 + (c - 1.0) ** 2,
        "peak": a[:, 0] * b[:, 0] + (c[:, 0] - 1.0) ** 2,
    }


signal_model.coords = {"time": TIME}
PARAMETERS = {
    "a": Triangular(0.8, 1.0, 1.3),
    "b": Triangular(1.5, 2.0, 2.2),
    "c": Triangular(0.7, 1.1, 1.2),
}


@pytest.mark.parametrize(
    ("method", "nonmonotonic"),
    [("reduced", None), ("extended", ["c"]), ("general", None), ("grid", None)],
)
@pytest.mark.parametrize("chunk_size", [1, 7, 4096])
def test_study_equals_in_memory_retransformation(method, nonmonotonic, chunk_size):
    study = Study(signal_model, PARAMETERS, method, 3, nonmonotonic=nonmonotonic, validation_runs=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reduced method warns about c: same in both
        result = study.run(progress=False, chunk_size=chunk_size, keep_raw=True).dataset
        plan = study.plan
        reference = plan.retransform(plan.evaluate(signal_model))
    for name in ("y", "peak"):
        np.testing.assert_array_equal(result[f"{name}_lower"].values, reference[name].lower)
        np.testing.assert_array_equal(result[f"{name}_upper"].values, reference[name].upper)
        np.testing.assert_array_equal(result[f"{name}_nominal"].values, reference[name].nominal)
        if method in ("reduced", "extended"):
            influence = reference[name].influence()
            np.testing.assert_array_equal(result[f"{name}_gain"].values, influence.gain)
            np.testing.assert_array_equal(
                result[f"{name}_relative_influence"].values, influence.relative
            )


def test_chunks_in_any_order_give_the_same_result():
    plan = make_plan(PARAMETERS, "reduced", 4)
    columns = plan.sample_columns()
    size = 5
    chunks = [
        evaluate_chunk(signal_model, {k: v[s : s + size] for k, v in columns.items()}, s, None)
        for s in range(0, len(plan), size)
    ]
    results = []
    for order in (range(len(chunks)), reversed(range(len(chunks)))):
        feed = ChunkFeed(plan, len(plan), size, (), None, keep_raw=False)
        for index in order:
            feed.add(index, chunks[index])
        assert feed.complete and feed.raw is None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results.append(feed.results())
    for name in ("y", "peak"):
        np.testing.assert_array_equal(results[0][name].lower, results[1][name].lower)
        np.testing.assert_array_equal(
            results[0][name].influence().gain, results[1][name].influence().gain
        )


def test_backlog_stops_submission():
    plan = make_plan(PARAMETERS, "reduced", 4)
    feed = ChunkFeed(plan, len(plan), 1, (), None)
    columns = plan.sample_columns()
    for index in range(1, streaming.BACKLOG_CHUNKS + 1):  # chunk 0 still missing
        feed.add(
            index,
            evaluate_chunk(
                signal_model, {k: v[index : index + 1] for k, v in columns.items()}, index, None
            ),
        )
    assert feed.backlog() == streaming.BACKLOG_CHUNKS and not feed.may_submit()


def test_raw_outputs_kept_below_the_limit_and_read_back_from_the_store(tmp_path, monkeypatch):
    study = Study(signal_model, PARAMETERS, "reduced", 3, validation_runs=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        small = study.run(progress=False).dataset  # default: 25 x 41 values are kept
        assert "y_samples" in small
        monkeypatch.setattr(streaming, "RAW_LIMIT_BYTES", 1000)
        big = study.run(progress=False, store=tmp_path / "chunks", chunk_size=4).dataset
        assert "y_samples" not in big and "y_lower" in big
        forced = study.run(progress=False, keep_raw=True).dataset
    np.testing.assert_array_equal(forced["y_samples"].values, small["y_samples"].values)
    outputs, failed = read_outputs(tmp_path / "chunks")
    np.testing.assert_array_equal(outputs["y"], small["y_samples"].values)
    assert not failed.any()


def test_failed_samples_stream_like_in_memory():
    def sometimes(p):
        out = signal_model(p)
        bad = p["a"] > 1.2  # the upper corners of the lowest level fail
        out["y"] = np.where(bad[:, None], np.nan, out["y"])
        return out

    study = Study(sometimes, PARAMETERS, "reduced", 4, validation_runs=0)
    result = study.run(progress=False, on_failure="partial", chunk_size=3).dataset
    plan = study.plan
    outputs = plan.evaluate(sometimes)
    failed = ~np.isfinite(outputs["y"]).all(axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reference = plan.retransform(outputs, failed=failed)
    np.testing.assert_array_equal(result["y_lower"].values, reference["y"].lower)
    np.testing.assert_array_equal(result["level_complete"].values, reference["y"].complete)
    assert not result["level_complete"].values.all()


def _peak_bytes(levels):
    study = Study(
        "damped-oscillator",
        {
            "mass": {"type": "triangular", "modal": 1.0, "spread": 0.05},
            "stiffness": {"type": "triangular", "modal": 1000.0, "spread": 0.1},
            "damping": {"type": "triangular", "modal": 3.0, "spread": 0.2},
        },
        "grid",
        levels,
        model_options={"time_steps": 2001},
        validation_runs=0,
    )
    tracemalloc.start()
    try:
        study.run(progress=False, keep_raw=False, chunk_size=256)
        return len(study.plan), tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_memory_does_not_grow_with_the_run_count():
    # 7^3 = 343 runs against 13^3 = 2197 runs of a 2001-point signal: the raw outputs
    # grow from 5.5 MB to 35 MB; the online reduction keeps the peak (chunks of 256
    # samples: 4 MB each, a few in flight, plus accumulators) about the same
    _peak_bytes(2)  # imports and first-call set-up are not part of the comparison
    small_runs, small_peak = _peak_bytes(3)
    large_runs, large_peak = _peak_bytes(6)
    assert (small_runs, large_runs) == (343, 2197)
    raw_large = large_runs * 2001 * 8
    assert large_peak < 1.25 * small_peak + 2e6, (small_peak, large_peak, raw_large)
    assert large_peak < raw_large  # less than the raw outputs alone
