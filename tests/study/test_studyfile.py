"""Study files: valid files load; every mistake names the file, the key and what is allowed."""

import textwrap

import numpy as np
import pytest

from fuzzymbs.errors import StudyFileError
from fuzzymbs.study.studyfile import load_study_file, study_file_name

VALID = """
[study]
name = "demo"
method = "reduced"
levels = [0, 0.5, 1]

[model]
name = "damped-oscillator"
[model.options]
time_steps = 11

[parameters.mass]
type = "triangular"
lower = 0.9
modal = 1.0
upper = 1.2

[parameters.stiffness]
type = "triangular"
modal = 1000.0
spread = 0.1

[parameters.damping]
type = "gaussian"
mean = 3.0
std = 0.1

[run]
executor = "processes:2"
chunk_size = 16
on_failure = "partial"

[[plots.membership]]
output = "displacement"
coord = "time"
value = 0.5
"""


def write(tmp_path, text, name="study.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_valid_file(tmp_path):
    definition = load_study_file(write(tmp_path, VALID))
    study = definition.study
    assert definition.name == "demo" and study.name == "demo"
    np.testing.assert_array_equal(study.plan.levels, [0, 0.5, 1])
    assert study.plan.names == ("mass", "stiffness", "damping")
    assert study.plan.parameters["stiffness"].support == pytest.approx((900.0, 1100.0))
    assert study.model.time_steps == 11
    assert (definition.executor, definition.chunk_size, definition.on_failure) == (
        "processes:2",
        16,
        "partial",
    )
    assert definition.membership_plots == [
        {"output": "displacement", "coord": "time", "value": 0.5}
    ]


def test_name_defaults_to_file_stem_and_crisp_values(tmp_path):
    text = """
    [model]
    name = "product"
    [parameters]
    x2 = 4.0
    [parameters.x1]
    type = "trapezoidal"
    lower = 1
    core_lower = 2
    core_upper = 3
    upper = 4
    """
    definition = load_study_file(write(tmp_path, text, "my-study.toml"))
    assert definition.name == "my-study"
    assert definition.study.constants == {"x2": 4.0}


BAD_CASES = {
    "toml syntax": ("[model\nname = 1", r"not valid TOML"),
    "typo in section key": (
        VALID.replace('method = "reduced"', 'methd = "reduced"'),
        r"unknown key 'study\.methd' in \[study\]; allowed keys: name, description, method",
    ),
    "unknown section": (VALID + "\n[output]\nx = 1\n", r"unknown key 'output'.*allowed keys"),
    "wrong method": (
        VALID.replace('method = "reduced"', 'method = "reducd"'),
        r"key 'study\.method'.*'general', 'reduced', 'extended', 'grid', 'sparse' or 'adaptive'",
    ),
    "wrong type": (
        VALID.replace("chunk_size = 16", 'chunk_size = "many"'),
        r"key 'run\.chunk_size'.*integer",
    ),
    "negative chunk size": (VALID.replace("chunk_size = 16", "chunk_size = 0"), r"run\.chunk_size"),
    "bad executor": (
        VALID.replace('"processes:2"', '"threads"'),
        r"key 'run\.executor'.*'inline', 'processes\[:N\]' or 'dask://host:port'",
    ),
    "levels not increasing": (
        VALID.replace("levels = [0, 0.5, 1]", "levels = [0, 0.7, 0.5, 1]"),
        r"key 'study\.levels'.*strictly increasing",
    ),
    # TOML values are typed: a boolean or a string is not a count (pydantic would coerce them)
    "levels as boolean": (
        VALID.replace("levels = [0, 0.5, 1]", "levels = true"),
        r"key 'study\.levels'.*int >= 1 \(e\.g\. 4\) or an increasing list",
    ),
    "levels as string": (
        VALID.replace("levels = [0, 0.5, 1]", 'levels = "4"'),
        r"key 'study\.levels'.*int >= 1 \(e\.g\. 4\) or an increasing list",
    ),
    "levels fractional": (
        VALID.replace("levels = [0, 0.5, 1]", "levels = 4.5"),
        r"key 'study\.levels'.*int >= 1 \(e\.g\. 4\) or an increasing list",
    ),
    "chunk size as boolean": (
        VALID.replace("chunk_size = 16", "chunk_size = true"),
        r"key 'run\.chunk_size'.*valid integer",
    ),
    "chunk size as string": (
        VALID.replace("chunk_size = 16", 'chunk_size = "16"'),
        r"key 'run\.chunk_size'.*valid integer",
    ),
    "missing model": (
        VALID.replace('name = "damped-oscillator"', ""),
        r"missing required key 'model\.name'",
    ),
    "unknown model": (
        VALID.replace('"damped-oscillator"', '"gear-pear"'),
        r"unknown model 'gear-pear'; registered models are: .*damped-oscillator",
    ),
    "unknown parameter": (
        VALID.replace("[parameters.mass]", "[parameters.masss]"),
        r"study\.toml: unknown parameter\(s\) \['masss'\].*valid parameters: mass \[kg\]",
    ),
    "unknown fuzzy type": (
        VALID.replace('type = "gaussian"', 'type = "normal"'),
        r"key 'parameters\.damping\.type': 'normal' is not allowed; allowed: triangular, "
        r"trapezoidal, gaussian, piecewise",
    ),
    "unknown fuzzy key": (
        VALID.replace("std = 0.1", "sigma = 0.1"),
        r"unknown key\(s\) parameters\.damping\.sigma for type 'gaussian'; allowed: type, mean",
    ),
    "fuzzy value not a number": (
        VALID.replace("modal = 1000.0", 'modal = "1e3"'),
        r"key 'parameters\.stiffness\.modal': expected a number",
    ),
    "invalid fuzzy number": (
        VALID.replace("lower = 0.9", "lower = 1.1"),
        r"study\.toml: \[parameters\]: invalid fuzzy number: .*mass",
    ),
    "negative spread": (
        VALID.replace("spread = 0.1", "spread = -0.1"),
        r"invalid fuzzy number: .*stiffness",
    ),
    "spread and bounds": (
        VALID.replace("spread = 0.1", "spread = 0.1\nlower = 1.0"),
        r"either modal \+ spread or lower \+ modal \+ upper",
    ),
    "parameter as string": (VALID + '\n[parameters]\nx = "a"\n', r"parameters"),
    "unknown option": (
        VALID.replace("time_steps = 11", "steps = 11"),
        r"no option\(s\) \['steps'\]; its options: duration, time_steps",
    ),
    "unknown plot output": (
        VALID.replace('output = "displacement"', 'output = "velocity"'),
        r"key 'plots\.membership\.0\.output': unknown output 'velocity'",
    ),
    "unknown plot coordinate": (
        VALID.replace('coord = "time"', 'coord = "position"'),
        r"plots\.membership\.0\.coord.*no coordinate 'position'; its coordinates: time",
    ),
    "nonmonotonic without extended": (
        VALID.replace("levels = [0, 0.5, 1]", 'levels = 2\nnonmonotonic = ["mass"]'),
        r"\[study\]: .*only used by method='extended'",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_files_name_file_key_and_allowed(tmp_path, case):
    text, pattern = BAD_CASES[case]
    path = write(tmp_path, text)
    with pytest.raises(StudyFileError, match=pattern) as caught:
        load_study_file(path)
    assert str(path) in str(caught.value)


def test_missing_file(tmp_path):
    with pytest.raises(StudyFileError, match="not found"):
        load_study_file(tmp_path / "nothing.toml")


def test_literal_choices_match_the_engine():
    # pydantic needs literal types; they must list exactly what the engine and runner accept
    from typing import get_args

    from fuzzymbs.fuzzy.transform import ALL_METHODS
    from fuzzymbs.study.study import ON_FAILURE
    from fuzzymbs.study.studyfile import RunSection, StudySection

    assert get_args(StudySection.model_fields["method"].annotation) == ALL_METHODS
    assert get_args(RunSection.model_fields["on_failure"].annotation) == ON_FAILURE


def test_study_file_name_without_building_the_model(tmp_path):
    # the name load_study_file gives, read without building the model (the demo's folders)
    assert study_file_name(write(tmp_path, VALID)) == load_study_file(write(tmp_path, VALID)).name
    nameless = VALID.replace('name = "demo"\n', "")
    assert study_file_name(write(tmp_path, nameless, "my-study.toml")) == "my-study"
    # a malformed file is refused as load_study_file refuses it
    with pytest.raises(StudyFileError, match="not valid TOML"):
        study_file_name(write(tmp_path, "[model\nname = 1", "bad.toml"))
    with pytest.raises(StudyFileError, match=r"unknown key 'study\.methd'"):
        study_file_name(write(tmp_path, VALID.replace("method =", "methd ="), "typo.toml"))
