"""Every study checks its own fuzzy method: validation runs and method_error.

References: models whose exact alpha-cuts are known in closed form or by dense search
(a tensor grid of 81 points per parameter over each cut box).
"""

import textwrap
import warnings

import numpy as np
import pytest

from fuzzymbs import Study, Triangular
from fuzzymbs.errors import InvalidParameterError, StudyFileError
from fuzzymbs.fuzzy import NonMonotonicWarning
from fuzzymbs.study.studyfile import load_study_file

NUMBERS = {"x1": Triangular(-1, 0, 1), "x2": Triangular(-1, 0, 1), "x3": Triangular(0, 1, 2)}
POSITIVE = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11), "x3": Triangular(0, 1, 2)}


def valley(samples):
    """z = (x1 - x2 / 2)^2 + x3 / 2: non-monotonic in x1 with a vertex that moves with x2;
    the modal value 0.5 stays inside the corners' envelope [0.25, 3.25], so the
    retransformation's own monotonicity check cannot see the miss."""
    return {"z": (samples["x1"] - 0.5 * samples["x2"]) ** 2 + 0.5 * samples["x3"]}


def monotonic(samples):
    """z = x1 x2 + x3 on a positive box: increasing in every parameter."""
    return {"z": samples["x1"] * samples["x2"] + samples["x3"]}


def run(model, numbers, method="reduced", **kwargs):
    extra = {"nonmonotonic": ["x1"]} if method == "extended" else {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = Study(model, numbers, method, 4, **extra, **kwargs).run(progress=False)
    return result, [w for w in caught if issubclass(w.category, NonMonotonicWarning)]


def true_miss(model, numbers, dataset, output="z"):
    """Largest miss of the study's cuts against a dense search of each cut box, relative
    to the method's cut width (at least the miss on the true width, which method_error
    estimates from below)."""
    worst = 0.0
    for j, mu in enumerate(dataset["level"].values):
        axes = [np.linspace(*numbers[n].alpha_cut(mu), 81) for n in numbers]
        grid = np.meshgrid(*axes, indexing="ij")
        values = model(dict(zip(numbers, grid, strict=True)))[output]
        low, high = dataset[f"{output}_lower"].values[j], dataset[f"{output}_upper"].values[j]
        if high > low:
            worst = max(worst, (low - values.min()) / (high - low))
            worst = max(worst, (values.max() - high) / (high - low))
    return worst


@pytest.mark.parametrize("method", ["reduced", "extended", "general", "grid", "sparse"])
def test_monotonic_model_has_a_round_off_method_error(method):
    result, caught = run(monotonic, POSITIVE, method)
    error = result.dataset.attrs["method_error"]
    assert 0.0 <= error < 1e-12 and not caught
    assert result.dataset.attrs["validation_runs"] == result.provenance["method_check"]["runs"]


@pytest.mark.parametrize("method", ["reduced", "extended", "general"])
def test_missed_range_is_found_and_warned(method):
    # stated bound: at least half of the dense-search miss, never more than it (the
    # validation points lie in the boxes and method_error reads them on the width of the
    # cut they widen, which is at least the method's)
    result, caught = run(valley, NUMBERS, method)
    dataset = result.dataset
    truth = true_miss(valley, NUMBERS, dataset)
    error = dataset.attrs["method_error"]
    assert truth > 0.03
    assert 0.5 * truth <= error <= truth + 1e-12
    assert len(caught) == 1
    message = str(caught[0].message)
    worst = result.provenance["method_check"]["worst"]
    assert "output 'z'" in message and f"mu = {worst['level']:g}" in message
    assert all(f"{name}=" in message for name in NUMBERS)
    # the validation outputs are kept apart, never merged into the bounds
    levels = list(dataset["level"].values)
    index = [levels.index(mu) for mu in dataset["validation_level"].values]
    below = dataset["z_validation"].values < dataset["z_lower"].values[index] - 1e-12
    assert below.any() and dataset["z_validation"].dims == ("validation",)
    assert "Method check" in result.summary() and "EXCEEDS" in result.summary()


def test_reduced_method_misses_without_the_retransformation_noticing():
    # the modal point stays inside the corners' envelope, so the only
    # warning is the validation's
    result, caught = run(valley, NUMBERS, "reduced")
    retransformation = [t for t in result.provenance["warnings"] if "corner runs" in t]
    assert retransformation == [] and len(caught) == 1


def test_general_method_exact_for_a_model_non_monotonic_between_grid_points():
    # z = (x1 - 2)^2 x2, x2 > 0: the minimum 0 is at the modal x1 (every level reaches it
    # through the nested cuts) and the maximum at the box corners: the general method
    # is exact although z is not monotonic in x1; validation points must not warn
    def model(samples):
        return {"z": (samples["x1"] - 2.0) ** 2 * samples["x2"]}

    numbers = {"x1": Triangular(0, 2, 4), "x2": Triangular(1, 2, 3)}
    result, caught = run(model, numbers, "general")
    assert true_miss(model, numbers, result.dataset) < 1e-12
    assert result.dataset.attrs["method_error"] < 1e-12 and not caught


def test_time_signals_are_checked_per_element():
    # z(t) = t * valley: the cut widths and excursions scale with t, so the per-element
    # relative excursion is the scalar one at every t > 0 (and 0 at t = 0)
    times = np.linspace(0.0, 1.0, 5)

    class Signal:
        def __init__(self):
            self.coords = {"time": times}

        def __call__(self, samples):
            return {"z": valley(samples)["z"][:, None] * times[None, :]}

    scalar, _ = run(valley, NUMBERS)
    signal, caught = run(Signal(), NUMBERS)
    assert signal.dataset.attrs["method_error"] == pytest.approx(
        scalar.dataset.attrs["method_error"], rel=1e-12
    )
    assert signal.dataset["z_validation"].dims == ("validation", "time")
    assert "element" in str(caught[0].message)


def test_widen_with_validation_extends_every_cut_that_holds_a_point():
    plain, _ = run(valley, NUMBERS)
    widened, _ = run(valley, NUMBERS, widen_with_validation=True)
    ds = widened.dataset
    lower, upper = ds["z_lower"].values, ds["z_upper"].values
    levels = ds["level"].values
    for value, mu in zip(ds["z_validation"].values, ds["validation_level"].values, strict=True):
        held = levels <= mu + 1e-12
        assert np.all(lower[held] <= value + 1e-15) and np.all(upper[held] >= value - 1e-15)
    assert np.all(lower <= plain.dataset["z_lower"].values)
    assert np.all(np.diff(lower) >= -1e-15) and np.all(np.diff(upper) <= 1e-15)  # nested
    assert widened.provenance["method_check"]["widened"] is True
    assert "widened" in widened.summary()


def test_count_defaults_and_off_switch():
    # the rule: a fifth of the runs, at least 12 per parameter; a monotonic model
    # gives the search nothing to follow beyond its steps, and every round is made
    result, _ = run(monotonic, POSITIVE)  # 33 runs, 3 parameters: 36
    assert result.dataset.attrs["validation_runs"] == 36
    assert result.dataset.sizes["validation"] == 36
    assert sum(result.provenance["method_check"]["rounds"]) == 36
    small, _ = run(
        lambda s: {"z": s["x1"] * s["x2"]}, {"x1": POSITIVE["x1"], "x2": POSITIVE["x2"]}
    )  # 17 runs, 2 parameters: 24
    assert small.dataset.attrs["validation_runs"] == 24
    off, _ = run(valley, NUMBERS, validation_runs=0)
    assert "method_error" not in off.dataset.attrs and "z_validation" not in off.dataset
    assert "Method check" not in off.summary()
    several, _ = run(monotonic, POSITIVE, validation_runs=11)
    assert several.dataset.attrs["validation_runs"] == 11


def test_failed_validation_runs_are_reported_and_left_out():
    def fails_inside(samples):
        z = valley(samples)["z"]
        halton = (samples["x1"] % 0.25 != 0) | (samples["x2"] % 0.25 != 0)
        return {"z": np.where(halton, np.nan, z)}

    result, _ = run(fails_inside, NUMBERS)
    check = result.provenance["method_check"]
    assert check["failed"] > 0 and len(check["failure_reasons"]) == check["failed"]
    assert result.dataset["validation_failed"].values.sum() == check["failed"]
    assert np.isfinite(result.dataset.attrs["method_error"])  # from the runs that worked
    assert f"validation runs; {check['failed']} more failed)" in result.summary()


def test_validation_runs_are_stored_and_resumed(tmp_path):
    class Counting:
        calls = 0

        def __call__(self, samples):
            self.calls += len(samples["x1"])
            return valley(samples)

    first = Counting()
    done = Study(first, NUMBERS, levels=4).run(progress=False, store=tmp_path)
    runs = done.dataset.attrs["validation_runs"]
    assert first.calls == 33 + runs
    rounds = done.provenance["method_check"]["rounds"]
    assert len(rounds) == 4 and len(list(tmp_path.glob(f"validation-*-{36}-*"))) == 4
    # every round is stored: a rerun proposes the same points and evaluates nothing
    again = Counting()
    result = Study(again, NUMBERS, levels=4).run(progress=False, store=tmp_path)
    assert again.calls == 0
    assert result.provenance["method_check"]["reused_from_store"] == runs
    assert result.dataset.attrs["method_error"] == done.dataset.attrs["method_error"]
    # another number of validation runs starts its own folders, no store mismatch
    other = Counting()
    Study(other, NUMBERS, levels=4, validation_runs=4).run(progress=False, store=tmp_path)
    assert other.calls == 4 and len(list(tmp_path.glob("validation-*-4-*"))) == 4


def test_bad_options_are_refused():
    for bad in (-1, 2.5, True, "6"):
        with pytest.raises(InvalidParameterError, match="validation_runs"):
            Study(valley, NUMBERS, validation_runs=bad)
    for bad in (0.0, -0.01, float("nan")):
        with pytest.raises(InvalidParameterError, match="method_tolerance"):
            Study(valley, NUMBERS, method_tolerance=bad)


def test_study_file_options(tmp_path):
    text = """
        [study]
        method = "reduced"
        levels = 4
        validation_runs = {runs}
        method_tolerance = 0.2

        [model]
        name = "product"

        [parameters]
        x1 = {{ type = "triangular", modal = 2.0, spread = 0.5 }}
        x2 = {{ type = "triangular", modal = 10.0, spread = 0.1 }}
    """
    path = tmp_path / "study.toml"
    path.write_text(textwrap.dedent(text.format(runs=4)))
    study = load_study_file(path).study
    assert study.options.validation_runs == 4 and study.options.method_tolerance == 0.2
    path.write_text(textwrap.dedent(text.format(runs=-1)))
    with pytest.raises(StudyFileError, match="validation_runs"):
        load_study_file(path)


def test_validation_outputs_follow_the_raw_outputs():
    # the check's verdict never needs the validation outputs whole: without the raw
    # outputs they are reduced per chunk and left out of the result, with the same error
    kept = Study(valley, NUMBERS, levels=4).run(progress=False, keep_raw=True)
    reduced = Study(valley, NUMBERS, levels=4).run(progress=False, keep_raw=False)
    assert "z_validation" in kept.dataset and "z_validation" not in reduced.dataset
    assert reduced.dataset.attrs["method_error"] == kept.dataset.attrs["method_error"]
    np.testing.assert_array_equal(
        reduced.dataset["z_validation_excursion"].values,
        kept.dataset["z_validation_excursion"].values,
    )
    # the kept outputs give the same verdict: the largest part of the validation range
    # outside a cut, on the width of the cut widened by that range (a scalar output:
    # the floor of a tenth of the widest element is the width itself)
    levels = list(kept.dataset["level"].values)
    values = kept.dataset["z_validation"].values
    mu = kept.dataset["validation_level"].values
    lower, upper = kept.dataset["z_lower"].values, kept.dataset["z_upper"].values
    worst = 0.0
    for j in range(len(levels) - 1):
        inside = values[np.array([levels.index(m) for m in mu]) >= j]
        known = max(upper[j], inside.max()) - min(lower[j], inside.min())
        miss = max(lower[j] - inside.min(), 0.0) + max(inside.max() - upper[j], 0.0)
        worst = max(worst, miss / known)
    assert kept.dataset.attrs["method_error"] == pytest.approx(worst, rel=1e-12)


def test_an_interrupted_check_resumes_every_round_from_the_store(tmp_path):
    # interrupted in the second round: the plan and the first round come from the store,
    # the second round's finished chunks too, and the result equals an uninterrupted run
    class Counting:
        def __init__(self, limit=None):
            self.calls, self.limit = 0, limit

        def __call__(self, samples):
            self.calls += len(samples["x1"])
            if self.limit is not None and self.calls > self.limit:
                raise KeyboardInterrupt
            return valley(samples)

    with pytest.raises(KeyboardInterrupt):
        Study(Counting(33 + 9 + 4), NUMBERS, levels=4).run(
            progress=False, store=tmp_path, chunk_size=4
        )
    again = Counting()
    resumed = Study(again, NUMBERS, levels=4).run(progress=False, store=tmp_path, chunk_size=4)
    # stored: the plan's 33 runs, round 1's 9 and round 2's first chunk (a round of 9
    # in chunks of at most 4 goes out as 3 equal chunks of 3)
    assert again.calls == 36 - 9 - 3
    fresh = Study(valley, NUMBERS, levels=4).run(progress=False)
    assert resumed.dataset.attrs["method_error"] == fresh.dataset.attrs["method_error"]
    np.testing.assert_array_equal(
        resumed.dataset["validation_samples"].values, fresh.dataset["validation_samples"].values
    )
