"""The run limit in studies: Study(max_runs=...), build_plan, [study] max_runs, the CLI override.

A refused study must fail before any sample array exists: the tests check the
traced allocations of the refusal (the plans refused here would need from
gigabytes to far beyond any memory).
"""

from __future__ import annotations

import tracemalloc

import pytest

from fuzzymbs.errors import PlanTooLargeError, StudyFileError
from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.fuzzy.transform import DEFAULT_MAX_RUNS
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.study.planning import build_plan
from fuzzymbs.study.study import Study
from fuzzymbs.study.studyfile import load_study_file


def total(samples):
    """A batched model of any parameters: their sum."""
    return {"y": sum(samples.values())}


TWELVE = {f"x{i}": Triangular.relative(1.0 + i, 0.1) for i in range(12)}


def _refusal(function):
    tracemalloc.start()
    try:
        with pytest.raises(PlanTooLargeError) as caught:
            function()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 4 * 2**20  # megabytes at most: no sample table was built
    return caught.value


def test_study_default_limit_is_the_engines():
    assert StudyOptions().max_runs == DEFAULT_MAX_RUNS
    assert Study(total, {"x1": Triangular(1.0, 2.0, 3.0)}).options.max_runs == DEFAULT_MAX_RUNS


def test_study_refuses_the_issues_plans_before_building_them():
    error = _refusal(lambda: Study(total, TWELVE, method="general", levels=4))
    assert "needs 260,917,841 model runs" in str(error) and "'reduced' 16,385" in str(error)
    error = _refusal(lambda: Study(total, TWELVE, method="reduced", levels=1_000_000))
    assert "with levels = 10: 'reduced' 40,961" in str(error)
    # "auto": the screening and the reduced corners the extended plan holds at least
    error = _refusal(
        lambda: Study(total, TWELVE, method="extended", nonmonotonic="auto", levels=1_000_000)
    )
    assert "nonmonotonic = 'auto'" in str(error)


def test_study_max_runs_raises_or_lowers_the_limit():
    five = dict(list(TWELVE.items())[:5])
    with pytest.raises(PlanTooLargeError, match="more than max_runs = 100"):
        Study(total, five, method="reduced", levels=4, max_runs=100)  # 129 runs
    assert len(Study(total, five, method="reduced", levels=4, max_runs=129).plan) == 129
    assert len(Study(total, five, method="general", levels=4, max_runs=None).plan) <= 4425
    with pytest.raises(PlanTooLargeError):
        Study(total, five, method="extended", nonmonotonic="auto", levels=4, max_runs=100)


def test_build_plan_passes_the_limit():
    five = dict(list(TWELVE.items())[:5])
    plan, _, _ = build_plan(five, "reduced", 4, None, StudyOptions(max_runs=129))
    assert plan is not None and len(plan) == 129
    with pytest.raises(PlanTooLargeError):
        build_plan(five, "reduced", 4, None, StudyOptions(max_runs=128))


PRODUCT = """
[study]
method = "reduced"
levels = 4
{extra}

[model]
name = "product"

[parameters]
x1 = {{ type = "triangular", modal = 2.0, spread = 0.1 }}
x2 = {{ type = "triangular", modal = 10.0, spread = 0.1 }}
"""


def test_study_file_max_runs_and_its_override(tmp_path):
    path = tmp_path / "small-limit.toml"
    path.write_text(PRODUCT.format(extra="max_runs = 10"))  # the plan needs 17 runs
    with pytest.raises(StudyFileError) as caught:
        load_study_file(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: [study]: The 'reduced' method with 2 fuzzy parameters")
    assert "17 model runs" in message and "max_runs = 10" in message
    assert "fuzzymbs run --max-runs 17" in message
    assert len(load_study_file(path, max_runs=17).study.plan) == 17
    path.write_text(PRODUCT.format(extra="max_runs = 0"))
    with pytest.raises(StudyFileError, match=r"study\.max_runs"):
        load_study_file(path)
    path.write_text(PRODUCT.format(extra='levels_ = 1\nmax_runs = "many"'))
    with pytest.raises(StudyFileError, match="max_runs"):
        load_study_file(path)
    path.write_text(PRODUCT.format(extra="").replace("levels = 4", "levels = 1000000"))
    with pytest.raises(StudyFileError, match="4,000,001 model runs"):
        load_study_file(path)
