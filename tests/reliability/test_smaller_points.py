"""Smaller points: plain numbers in messages, zero-width influence, command-model files
relative to the study file."""

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.errors import InvalidFuzzyNumberError
from fuzzymbs.fuzzy.transform import Plan, run_count
from fuzzymbs.models.external.command import CommandModel
from fuzzymbs.study.pipeline import run_study_file
from fuzzymbs.study.study import Study

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "command"


@pytest.mark.parametrize(
    ("make", "text"),
    [
        (lambda: Triangular(1, 2, 3) / Triangular(np.float64(-2), -1, 1), "[-2.0, 1.0]"),
        (lambda: Triangular(np.float64(3), np.float64(2), np.float64(1)), "lower=3.0"),
        (lambda: Triangular(1, 2, np.float64(np.nan)), "got nan"),
    ],
)
def test_messages_show_plain_numbers(make, text):
    with pytest.raises(InvalidFuzzyNumberError) as caught:
        make()
    assert text in str(caught.value) and "np.float64" not in str(caught.value)


def test_zero_width_output_has_zero_influence_for_scalars_and_signals():
    def constant(samples):
        ones = np.ones_like(samples["x1"])
        return {"z": ones, "signal": ones[:, None] * np.ones(3)}

    constant.coords = {"t": np.arange(3.0)}
    study = Study(
        constant, {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}, validation_runs=0
    )
    result = study.run(progress=False)
    summary = result.summary()
    assert "relative influence rho: x1 0, x2 0" in summary
    assert "absolute influence: x1 0, x2 0" in summary and "nan" not in summary.split("t (3)")[1]


def test_command_script_argument_is_found_beside_the_study_file(tmp_path):
    """The docs' pattern ["python", "run_solver.py", "{input}", "{output}"]."""
    folder = tmp_path / "study"
    shutil.copytree(EXAMPLE, folder)
    (folder / "oscillator_solver.py").rename(folder / "run_solver.py")
    text = (folder / "oscillator-command.toml").read_text()
    start = text.index("command = ")
    end = text.index("\n", start)
    command = f'command = ["{sys.executable}", "run_solver.py", "{{input}}", "{{output}}"]'
    (folder / "oscillator-command.toml").write_text(text[:start] + command + text[end:])
    written = run_study_file(
        folder / "oscillator-command.toml",
        tmp_path / "out",
        progress=False,
        plots=False,
        allow_code=True,
    )
    assert int(written.result.dataset["sample_failed"].values.sum()) == 0


def test_command_file_arguments_are_part_of_the_identity(tmp_path):
    script = tmp_path / "run_solver.py"
    script.write_text("print('v1')\n")
    model = CommandModel([sys.executable, "run_solver.py", "{study_dir}"], base_dir=tmp_path)
    assert model.command[1] == str(script)
    before = model.identity()
    script.write_text("print('v2')\n")
    assert model.identity() != before
    assert "study_dir" not in model.parameters  # a path, not a parameter


@pytest.mark.parametrize(("n", "m", "hanss"), [(2, 5, 61), (3, 10, 2331), (3, 4, 189)])
def test_general_method_count_equals_hanss_formula(n, m, hanss):
    # Hanss (2002): 1 + sum_{k=1..m} ((k+1)^n - (k-1)^n) runs for symmetric triangles
    assert hanss == 1 + sum((k + 1) ** n - (k - 1) ** n for k in range(1, m + 1))
    for numbers in (Triangular(1, 2, 3), Triangular(-1e-6, 0, 1e-6), Triangular(1e5, 2e5, 3e5)):
        parameters = {f"x{i}": numbers for i in range(n)}
        assert len(Plan(parameters, "general", m)) == hanss


def test_general_method_keeps_distinct_points_of_asymmetric_numbers():
    parameters = {"a": Triangular(1.0, 1.3, 2.1), "b": Triangular(-1, 0, 1)}
    built = Plan(parameters, "general", 5)
    assert len(built) == run_count(parameters, "general", 5)  # the asymmetric a separates levels
    assert len(np.unique(built.samples, axis=0)) == len(built)
