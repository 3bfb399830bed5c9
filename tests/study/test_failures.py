"""Failed samples: isolated, reported with reasons and touched levels, never bounded over."""

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.errors import IncompleteResultError, ModelOutputError
from fuzzymbs.study.study import Study


class RaisesAbove:
    """z = x1 * x2, but a batch containing x1 > limit raises (like a diverged solver)."""

    coords: dict = {}  # noqa: RUF012

    def __init__(self, limit):
        self.limit = limit
        self.calls = 0

    def __call__(self, samples):
        self.calls += 1
        if np.any(samples["x1"] > self.limit):
            raise FloatingPointError("integration diverged")
        return {"z": samples["x1"] * samples["x2"]}


def nan_above(samples):
    z = samples["x1"] * samples["x2"]
    return {"z": np.where(samples["x1"] > 2.7, np.nan, z)}


def flagged_above(samples):
    failed = samples["x1"] > 2.7
    return {
        "z": np.where(failed, np.nan, samples["x1"] * samples["x2"]),
        "failed": failed,
        "failure_reason": np.where(failed, "contact lost", ""),
    }


PARAMETERS = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}


def _expected(study, limit):
    failed = study.plan.samples[:, 0] > limit
    return failed, study.plan.levels_touched(failed)


@pytest.mark.parametrize(
    ("model", "reason"),
    [
        (RaisesAbove(2.7), "FloatingPointError: integration diverged"),
        (nan_above, "non-finite value (NaN or inf) in output 'z'"),
        (flagged_above, "contact lost"),
    ],
)
def test_partial_marks_failed_samples_and_levels(model, reason):
    study = Study(model, PARAMETERS, levels=4)
    failed, touched = _expected(study, 2.7)
    # x1 upper cut 3 - mu exceeds 2.7 for mu < 0.3: levels 0 and 0.25 are touched
    np.testing.assert_array_equal(touched, [True, True, False, False, False])
    result = study.run(progress=False, on_failure="partial", chunk_size=5)
    ds = result.dataset
    np.testing.assert_array_equal(result.failed, failed)
    assert set(ds["failure_reason"].values[failed]) == {reason}
    assert set(ds["failure_reason"].values[~failed]) == {""}
    np.testing.assert_array_equal(ds["level_complete"].values, ~touched)
    assert np.isnan(ds["z_lower"].values[touched]).all()
    # complete levels keep exact bounds: (1+mu)(9+mu), (3-mu)(11-mu) (THEORY.md oracle)
    mu = ds["level"].values[~touched]
    np.testing.assert_allclose(ds["z_lower"].values[~touched], (1 + mu) * (9 + mu), rtol=1e-14)
    np.testing.assert_allclose(ds["z_upper"].values[~touched], (3 - mu) * (11 - mu), rtol=1e-14)
    assert result.status == "partial" and ds.attrs["incomplete_levels"] == "[0.0, 0.25]"
    assert "z_relative_influence" not in ds  # influence needs all levels
    summary = result.summary()
    assert "PARTIAL" in summary and reason in summary


def test_raising_chunk_is_bisected_into_single_samples():
    model = RaisesAbove(2.7)
    study = Study(model, PARAMETERS, levels=4, validation_runs=0)  # counts the plan's calls
    failed, _ = _expected(study, 2.7)
    study.run(progress=False, on_failure="partial", chunk_size=len(study.plan))
    # one batched call that raised, then one call per sample
    assert model.calls == 1 + len(study.plan)
    assert failed.sum() == 4  # x1 = 3 and 2.75, each with x2 at both bounds


def test_default_raises_with_levels_and_reasons():
    study = Study(nan_above, PARAMETERS, levels=4)
    with pytest.raises(IncompleteResultError, match=r"4 of 17 samples.*mu = 0, 0\.25.*sample \d+"):
        study.run(progress=False)


def test_fail_fast_stops_at_first_failed_chunk():
    model = RaisesAbove(2.7)
    study = Study(model, PARAMETERS, levels=4)
    first_bad_chunk = int(np.flatnonzero(study.plan.samples[:, 0] > 2.7)[0] // 2)
    with pytest.raises(IncompleteResultError, match="fail-fast"):
        study.run(progress=False, on_failure="fail-fast", chunk_size=2)
    chunks_done = first_bad_chunk + 1
    # chunks before the failing one: 1 call each; the failing chunk: 1 + 2 single calls
    assert model.calls == chunks_done + 2


def test_failed_core_sample_leaves_nothing_to_bound():
    def broken_at_core(samples):
        return {"z": np.where(samples["x1"] == 2.0, np.inf, samples["x1"])}

    study = Study(broken_at_core, PARAMETERS, levels=2)
    with pytest.raises(IncompleteResultError, match=r"mu = 0, 0\.5, 1 .*no level can be"):
        study.run(progress=False, on_failure="partial")


def test_all_failed():
    def always(samples):
        raise RuntimeError("boom")

    with pytest.raises(IncompleteResultError, match=r"all 9 samples.*boom"):
        Study(always, PARAMETERS, levels=2).run(progress=False, on_failure="partial")


class WrongBatch:
    """Returns 3 rows whatever the batch size: a broken model, not a failed sample."""

    def __init__(self):
        self.calls = 0

    def __call__(self, samples):
        self.calls += 1
        return {"z": np.zeros(3)}


@pytest.mark.parametrize("on_failure", ["raise", "partial"])
def test_wrong_output_shape_is_a_model_error_not_a_failed_sample(on_failure):
    # the contract violation raises at once (no sample-by-sample retry, no "partial" result)
    # and names the batch the model was called with
    model = WrongBatch()
    study = Study(model, PARAMETERS, levels=1)
    with pytest.raises(ModelOutputError, match=r"shape \(3,\).*batch of 5 .*samples 0 to 4"):
        study.run(progress=False, on_failure=on_failure, chunk_size=5)
    assert model.calls == 1


def test_complex_output_is_reported_not_truncated():
    def spectrum(samples):
        return {"z": samples["x1"] * (1 + 1j)}

    with pytest.raises(ModelOutputError, match="output 'z' is complex"):
        Study(spectrum, PARAMETERS, levels=1).run(progress=False)
