"""Models that exit, hang, crash their worker or return what no model may: every one is
caught with a message naming the samples and the cause, and never gives a result."""

import numpy as np
import pytest
from fault_models import Faulty, Shaped

from fuzzymbs import Triangular
from fuzzymbs.errors import IncompleteResultError, ModelOutputError
from fuzzymbs.study.study import Study

PARAMETERS = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}


def _study(model, **options):
    return Study(model, PARAMETERS, levels=2, validation_runs=0, **options)


@pytest.mark.parametrize("fault", ["exit", "os_exit"])
def test_model_that_exits_fails_its_samples_inline(fault):
    with pytest.raises(IncompleteResultError) as caught:
        _study(Faulty(fault)).run(progress=False, chunk_size=4)
    message = str(caught.value)
    call = "sys.exit(0)" if fault == "exit" else "os._exit(0)"
    assert f"the model called {call}" in message and "sample" in message


def test_model_that_exits_on_a_process_worker_fails_its_samples():
    with pytest.raises(IncompleteResultError, match=r"the model called os\._exit\(0\)"):
        _study(Faulty("os_exit")).run(progress=False, chunk_size=4, executor="processes:1")


def test_model_that_kills_its_worker_is_one_error_naming_the_samples():
    with pytest.raises(IncompleteResultError, match=r"worker .* ended while evaluating samples"):
        _study(Faulty("kill")).run(progress=False, chunk_size=4, executor="processes:1")


@pytest.mark.parametrize("executor", [None, "processes:1"])
def test_sample_over_its_timeout_fails_and_the_rest_is_kept(executor):
    # levels=2 reduced: 9 samples, x1 = 3 (> 2.5) only at the mu = 0 upper corner points;
    # a chunk of 3 may take 3 x 0.2 s, then each of its samples 0.2 s
    result = _study(Faulty("hang")).run(
        progress=False, chunk_size=3, executor=executor, on_failure="partial", timeout=0.2
    )
    reasons = result.dataset["failure_reason"].values
    failed = result.dataset["sample_failed"].values.astype(bool)
    x1 = result.dataset["samples"].values[:, 0]
    assert failed.any() and np.array_equal(failed, x1 > 2.5)
    assert all("timed out after 0.2 s" in str(r) for r in reasons[failed])
    assert bool(result.dataset["level_complete"].values[-1])  # the core level stands


@pytest.mark.parametrize(
    ("fault", "pattern"),
    [
        ("string", "holds <U.* values, not numbers"),
        ("ragged", "not a numeric array"),
        ("empty", "returned no outputs"),
        ("reason_only", r"returned no outputs \(only 'failure_reason'\)"),
        ("bad_name", "cannot name a dataset variable and a plot file"),
    ],
)
def test_contract_breaking_returns_are_refused(fault, pattern):
    with pytest.raises(ModelOutputError, match=pattern):
        _study(Faulty(fault, everywhere=True)).run(progress=False)


@pytest.mark.parametrize("method", ["reduced", "sparse"])
def test_trailing_shape_change_between_chunks_is_refused(method):
    options = {"sparse_level": 2} if method == "sparse" else {}
    study = Study(Shaped("shape"), PARAMETERS, method=method, levels=2, **options)
    with pytest.raises(ModelOutputError, match=r"trailing shape \(1,\).*\(4,\)"):
        study.run(progress=False, chunk_size=1)


def test_output_appearing_between_chunks_is_refused():
    with pytest.raises(ModelOutputError, match=r"outputs differ between samples.*new \['extra'\]"):
        _study(Faulty("new_key")).run(progress=False, chunk_size=1)


def test_shape_change_in_the_validation_runs_is_refused():
    # the plan's samples have x1 on the cut ends 1, 1.5, 2, 2.5, 3 (levels=2); the model
    # below changes its output's shape only at other points: the validation runs
    class ValidationOnly(Shaped):
        def __call__(self, samples):
            x1 = np.asarray(samples["x1"], float)
            grid = np.isin(np.round(x1, 12), [1.0, 1.5, 2.0, 2.5, 3.0])
            z = np.asarray(samples["x1"]) * np.asarray(samples["x2"])
            if grid.all():
                return {"z": np.repeat(z[:, None], 4, axis=1)}
            return {"z": z[:, None]}

    study = Study(ValidationOnly("none"), PARAMETERS, levels=2, validation_runs=4)
    with pytest.raises(ModelOutputError, match="trailing shape"):
        study.run(progress=False, chunk_size=2)
