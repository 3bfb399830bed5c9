"""The study's own options: declared once (StudyOptions), and that declaration is the
study file's [study] keys, Study's keywords and what `fuzzymbs info` lists; bad options
are refused by name."""

import dataclasses
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from fuzzymbs.cli import app
from fuzzymbs.errors import InvalidParameterError, InvalidPlanError, StudyFileError
from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.study.study import Study
from fuzzymbs.study.studyfile import StudySection, load_study_file

NUMBERS = {"x1": Triangular(1.0, 2.0, 3.0), "x2": Triangular(9.0, 10.0, 11.0)}
#: a valid value other than the default for every option
OTHER = {
    "integration_tolerance": 0.02,
    "integration_runs": 3,
    "choose_integration": False,
    "shared_steps": False,
    "validation_runs": 5,
    "method_tolerance": 0.05,
    "widen_with_validation": True,
    "max_runs": 500,
}


def product(samples):
    return {"z": samples["x1"] * samples["x2"]}


def test_every_option_is_a_study_file_key_with_the_declared_default():
    section = StudySection()
    for declared in StudyOptions.options():
        assert declared.name in StudySection.model_fields
        assert getattr(section, declared.name) == declared.default


def test_every_option_is_a_study_keyword_and_a_field_of_the_options_object():
    names = {declared.name for declared in StudyOptions.options()}
    assert names == {field.name for field in dataclasses.fields(StudyOptions)}
    assert set(OTHER) | {"screening_rtol"} == names
    by_keyword = Study(product, NUMBERS, **OTHER)
    by_object = Study(product, NUMBERS, options=StudyOptions(**OTHER))
    assert by_keyword.options == by_object.options
    for name, value in OTHER.items():
        assert getattr(by_keyword.options, name) == value
    # a keyword replaces the object's value
    replaced = Study(product, NUMBERS, options=StudyOptions(**OTHER), max_runs=99)
    assert replaced.options.max_runs == 99


def test_a_study_file_gives_every_option(tmp_path):
    keys = "\n".join(
        f"{name} = {str(value).lower() if isinstance(value, bool) else value}"
        for name, value in OTHER.items()
    )
    path = tmp_path / "study.toml"
    path.write_text(
        f'[study]\n{keys}\n[model]\nname = "product"\n'
        '[parameters.x1]\ntype = "triangular"\nmodal = 2.0\nspread = 0.1\n'
    )
    options = load_study_file(path).study.options
    assert {name: getattr(options, name) for name in OTHER} == OTHER


def test_info_lists_every_option_with_its_default_and_help():
    result = CliRunner().invoke(app, ["info", "product"])
    assert result.exit_code == 0, result.output
    for declared in StudyOptions.options():
        assert f"  {declared.name} ({declared.default_text()}): {declared.help}" in result.output
    assert "integration_runs (default 8)" in result.output
    assert "choose_integration (default true)" in result.output


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ({"integration_runz": 3}, "unknown study option(s) 'integration_runz'; study options:"),
        ({"validation_runs": 1.5}, "validation_runs must be a whole number >= 0"),
        ({"validation_runs": -1}, "validation_runs must be a whole number >= 0"),
        ({"integration_tolerance": 0.0}, "integration_tolerance must be a positive number"),
        ({"integration_tolerance": float("nan")}, "integration_tolerance must be"),
        ({"integration_runs": True}, "integration_runs must be a whole number >= 1"),
        ({"choose_integration": 1}, "choose_integration must be true or false"),
        ({"max_runs": 0}, "max_runs must be a whole number >= 1"),
        ({"screening_rtol": -0.1}, "screening_rtol must be a finite number >= 0"),
    ],
)
def test_bad_options_are_refused_by_name(given, message):
    with pytest.raises(InvalidParameterError, match=re.escape(message)):
        Study(product, NUMBERS, **given)
    if "unknown" not in message:
        with pytest.raises(InvalidParameterError, match=next(iter(given))):
            StudyOptions(**given)


@pytest.mark.parametrize(
    ("line", "key"),
    [
        ("validation_runs = 1.5", "study.validation_runs"),
        ("choose_integration = 1", "study.choose_integration"),
        ("integration_tolerance = 0.0", "study.integration_tolerance"),
        ("integration_runz = 3", "study.integration_runz"),
    ],
)
def test_a_study_file_names_the_bad_key(tmp_path, line, key):
    path = tmp_path / "study.toml"
    path.write_text(
        f'[study]\n{line}\n[model]\nname = "product"\n'
        '[parameters.x1]\ntype = "triangular"\nmodal = 2.0\nspread = 0.1\n'
    )
    with pytest.raises(StudyFileError, match=f"key '{key}'"):
        load_study_file(path)


def test_a_method_option_by_name_reaches_the_method_or_is_refused_naming_its_methods():
    sparse = Study(product, NUMBERS, method="sparse", levels=2, sparse_level=2)
    assert sparse.plan.scheme.sparse_level == 2
    with pytest.raises(InvalidPlanError, match=r"sparse_level=2 is only used by method='sparse'"):
        Study(product, NUMBERS, method="reduced", sparse_level=2)


def test_the_defaults_that_depend_on_the_method_are_filled_in():
    fixed = Study(product, NUMBERS).options
    assert fixed.method_tolerance == 0.01 and fixed.screening_rtol is None
    adaptive = Study(product, NUMBERS, method="adaptive", levels=2, method_tolerance=0.05)
    assert adaptive.options.method_tolerance == adaptive.plan.scheme.method_tolerance == 0.05
    auto = Study(product, NUMBERS, method="extended", nonmonotonic="auto")
    assert auto.options.screening_rtol == pytest.approx(1e-6)
    assert np.isfinite(auto.options.screening_rtol)


def test_the_command_line_sets_any_option_by_name(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(
        '[study]\nvalidation_runs = 7\n[model]\nname = "product"\n'
        '[parameters.x1]\ntype = "triangular"\nmodal = 2.0\nspread = 0.1\n'
    )
    out = tmp_path / "out"
    arguments = ["run", str(path), "--out", str(out), "--no-plots", "--no-report", "-q"]
    given = ["--option", "validation_runs=0", "--option", "method_tolerance = 0.05"]
    result = CliRunner().invoke(app, [*arguments, *given])
    assert result.exit_code == 0, result.output
    import xarray as xr

    with xr.open_dataset(out / "result.nc") as dataset:
        assert "validation_runs" not in dataset.attrs  # the check is off
        assert "--option validation_runs=0" in dataset.attrs["command"]
    refused = CliRunner().invoke(app, [*arguments, "--option", "validation_runz=0"])
    assert refused.exit_code == 1
    assert "unknown study option(s) 'validation_runz'" in refused.output
    malformed = CliRunner().invoke(app, [*arguments, "--option", "validation_runs"])
    assert malformed.exit_code == 1 and "give NAME=VALUE" in malformed.output
