"""What the method check can say: a fixed method's error from sampled validation runs is a
lower bound ("at least", never a plain OK); the adaptive method's certified error keeps its
wording."""

import re
import warnings

import numpy as np
import pytest
import xarray as xr

from fuzzymbs import Study, Triangular
from fuzzymbs.fuzzy import NonMonotonicWarning, plan
from fuzzymbs.fuzzy.band_scale import CERTIFIED, LOWER_BOUND
from fuzzymbs.fuzzy.validation import check_plan
from fuzzymbs.report import checks
from fuzzymbs.study.pipeline import run_study_file
from fuzzymbs.study.summary import method_error_bound

VALLEY = {"x1": Triangular(-1, 0, 1), "x2": Triangular(-1, 0, 1), "x3": Triangular(0, 1, 2)}


def valley(samples):
    """z = (x1 - x2 / 2)^2 + x3 / 2: the reduced corners miss 0.25 of the true mu = 0 cut
    [0, 3.25] (tests/study/test_method_check.py)."""
    return {"z": (samples["x1"] - 0.5 * samples["x2"]) ** 2 + 0.5 * samples["x3"]}


def product(samples):
    return {"z": samples["x1"] * samples["x2"]}


PRODUCT = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}


def _rows(page):
    """The report's checks table: name -> (row class, verdict cell, detail cell)."""
    found = re.findall(
        r'<tr class="(\w+)"><td>([^<]+)</td><td class="verdict">([^<]*)</td><td>([^<]*)</td>',
        page,
    )
    return {name: (kind, verdict, detail) for kind, name, verdict, detail in found}


@pytest.fixture(scope="module")
def fixed_study(tmp_path_factory):
    """The built-in product z = x1 x2 by the reduced method (monotonic: no miss to find),
    run from a study file into summary.txt, report.html and result.nc."""
    folder = tmp_path_factory.mktemp("fixed")
    path = folder / "product.toml"
    path.write_text(
        '[study]\nname = "product"\nmethod = "reduced"\nlevels = 4\n[model]\nname = "product"\n'
        "[parameters]\n"
        'x1 = { type = "triangular", lower = 1.0, modal = 2.0, upper = 3.0 }\n'
        'x2 = { type = "triangular", lower = 9.0, modal = 10.0, upper = 11.0 }\n'
    )
    out = folder / "out"
    run_study_file(path, out, progress=False, plots=False)
    return out


def test_fixed_method_records_a_lower_bound_in_the_dataset(fixed_study):
    with xr.open_dataset(fixed_study / "result.nc") as dataset:
        attrs = dict(dataset.attrs)
    assert attrs["method_error_bound"] == LOWER_BOUND == "lower"
    assert attrs["validation_runs"] == 24 and attrs["method_error"] < 1e-12


def test_fixed_method_summary_says_at_least_and_what_the_sample_showed(fixed_study):
    summary = (fixed_study / "summary.txt").read_text()
    line = next(text for text in summary.splitlines() if text.startswith("Method check"))
    assert re.fullmatch(
        r"Method check: method error at least \S+ % of the cut width "
        r"\(from 24 sampled validation runs\); no miss above the tolerance 1 % in 24 "
        r"sampled points \(a lower bound; the error can be larger\)",
        line,
    ), line
    # the old verdict, a plain "within the tolerance" from a sample, is gone
    assert "within" not in line and "OK" not in line


def test_fixed_method_report_gives_no_plain_ok_for_a_sampled_check(fixed_study):
    rows = _rows((fixed_study / "report.html").read_text(encoding="utf-8"))
    # the parser reads the table: the status row's verdict is a plain OK
    assert rows["status"][:2] == ("pass", "OK")
    kind, verdict, detail = rows["method error"]
    assert kind == "sampled" and verdict == "NO MISS FOUND" and verdict != "OK"
    assert detail.startswith("at least ") and "% of the cut width" in detail
    assert "(from 24 sampled validation runs)" in detail
    assert "no miss above the tolerance 1 % in 24 sampled points" in detail
    assert "(a lower bound; the error can be larger)" in detail


def test_a_sampled_miss_above_the_tolerance_fails_with_at_least():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonMonotonicWarning)
        result = Study(valley, VALLEY, "reduced", 4).run(progress=False)
    assert result.dataset.attrs["method_error_bound"] == "lower"
    assert result.provenance["method_check"]["bound"] == "lower"
    assert (
        "Method check: method error at least 7.69 % of the cut width (from 36 sampled "
        "validation runs), EXCEEDS the tolerance 1 % (output z, mu = 0, at x1=-0.5, x2=-1, x3=0)"
    ) in result.summary()
    check = {c.name: c for c in checks(result.dataset)}["method error"]
    assert check.verdict == "fail"
    # a result written before the attribute reads the same
    del result.dataset.attrs["method_error_bound"]
    assert {c.name: c for c in checks(result.dataset)}["method error"] == check
    assert check.text == (
        "at least 7.69 % of the cut width (from 36 sampled validation runs), "
        "EXCEEDS the tolerance 1 %"
    )


def test_failed_validation_runs_are_not_counted_as_sampled_points():
    def off_grid_fails(samples):
        # the reduced plan's x3 values are the cut bounds 0, 0.25, ..., 2; the validation
        # runs between them fail, the method's runs do not
        x3 = samples["x3"]
        off = np.abs(4.0 * x3 - np.round(4.0 * x3)) > 1e-9
        return {"z": np.where(off, np.nan, valley(samples)["z"])}

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonMonotonicWarning)
        result = Study(off_grid_fails, VALLEY, "reduced", 4).run(progress=False)
    lost = result.provenance["method_check"]["failed"]
    compared = result.dataset.attrs["validation_runs"] - lost
    assert 0 < lost and 0 < compared
    words = f"(from {compared} sampled validation runs; {lost} more failed)"
    assert words in {c.name: c for c in checks(result.dataset)}["method error"].text
    assert words in result.summary()


def test_the_validation_outcome_carries_its_bound():
    scheme = plan(VALLEY, method="reduced", levels=4)
    runs = scheme.evaluate(valley)
    z = scheme.retransform(runs["z"])
    outcome = check_plan(scheme, valley, runs, {"z": (z.lower, z.upper)})
    assert outcome.bound == LOWER_BOUND and outcome.error > 0.07


def test_results_without_the_attribute_read_as_before():
    # results written before method_error_bound: certified only for the adaptive method
    assert method_error_bound({"method_error": 0.0, "validation_runs": 24}) == LOWER_BOUND
    assert method_error_bound({"method_error": 0.0, "adaptive_runs": 21}) == CERTIFIED
    assert method_error_bound({"method_error_bound": "certified"}) == CERTIFIED


def test_adaptive_wording_is_unchanged_where_certified():
    study = Study(product, PRODUCT, method="adaptive", levels=4)
    result = study.run(progress=False)
    attrs = result.dataset.attrs
    assert attrs["method_error_bound"] == CERTIFIED == "certified"
    assert study.plan.outcome().bound == CERTIFIED
    runs, rounds = int(attrs["adaptive_runs"]), int(attrs["adaptive_rounds"])
    error = 100 * float(attrs["method_error"])
    assert attrs["method_converged"] == 1 and error <= 1.0
    # the wording before sampled checks were worded as lower bounds, character for character
    assert (
        f"Method check: adaptive, {runs} runs in {rounds} rounds; certified method error "
        f"{error:.3g} % of the cut's width, within the tolerance 1 %"
    ) in result.summary().splitlines()
    check = {c.name: c for c in checks(result.dataset)}["method error"]
    assert check.verdict == "pass"
    assert check.text == (
        f"{error:.3g} % of the cut's width certified by the adaptive method ({runs} runs, "
        f"{rounds} rounds); within the tolerance 1 %"
    )
    assert "at least" not in result.summary() and "sampled" not in check.text
