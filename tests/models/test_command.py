"""External programs as models (fuzzymbs.models.external.command), with real programs.

The main reference is examples/command/oscillator_solver.py, a stand-in simulator that
reads an input deck and writes the closed-form free response of a damped oscillator as
CSV: a study of it must equal the same closed form written as a NumPy callable, to
rounding (the program prints repr() values, which read back exactly). Failure cases use
small Python programs written by the tests.
"""

import re
import shutil
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fuzzymbs import Study
from fuzzymbs.errors import IncompleteResultError, InvalidParameterError, UntrustedCodeError
from fuzzymbs.models.external.command import CommandModel
from fuzzymbs.study.pipeline import run_study_file
from fuzzymbs.study.studyfile import load_study_file

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "command"
PARAMETERS = {
    "k": {"type": "triangular", "modal": 100.0, "spread": 0.1},
    "c": {"type": "triangular", "modal": 0.4, "spread": 0.25},
}
TIME = np.linspace(0.0, 0.25, 101)  # the deck's grid: duration 0.25 s, 101 points


def closed_form(samples):
    """The solver's response as a batched NumPy model (m = 1 kg, x0 = 0.01 m)."""
    k, c = samples["k"][:, None], samples["c"][:, None]
    sigma = c / 2.0
    wd = np.sqrt(k - sigma**2)
    t = TIME[None, :]
    return {"x": 0.01 * np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))}


closed_form.coords = {"time": TIME}


def solver_model(**options):
    return CommandModel(
        ["./oscillator_solver.py", "{input}", "{output}"],
        template="oscillator.deck",
        base_dir=EXAMPLE,
        **options,
    )


def program(folder: Path, body: str) -> list[str]:
    """A Python program in ``folder`` (run with this interpreter): its command list."""
    path = folder / "program.py"
    path.write_text("import sys\n" + textwrap.dedent(body))
    return [sys.executable, str(path)]


def test_study_equals_the_callable_to_rounding():
    study = Study(solver_model(), PARAMETERS, "reduced", 4, ["x"], validation_runs=0)
    result = study.run(progress=False, chunk_size=6)
    reference = Study(closed_form, PARAMETERS, "reduced", 4, ["x"], validation_runs=0)
    expected = reference.run(progress=False)
    # the coordinate comes from the program's 'time' column
    np.testing.assert_allclose(result.dataset["time"].values, TIME, rtol=0, atol=1e-16)
    for bound in ("x_lower", "x_upper"):
        # math vs NumPy transcendental functions: a few ulps of the 0.01 m amplitude
        np.testing.assert_allclose(
            result.dataset[bound].values, expected.dataset[bound].values, rtol=0, atol=1e-15
        )


def test_parameters_are_the_placeholders_and_values_keep_full_precision(tmp_path):
    model = solver_model(keep_runs=tmp_path / "runs")
    assert list(model.parameters) == ["c", "k"]
    value = 0.1 + 0.2  # 0.30000000000000004: needs 17 digits to read back
    out = model({"k": np.array([100.0]), "c": np.array([value])})
    assert not out["failed"][0]
    (run,) = (tmp_path / "runs").iterdir()
    deck = (run / "input.txt").read_text()
    written = float(re.search(r"^c = (.*)$", deck, re.MULTILINE).group(1))
    assert written == value  # bit for bit
    assert (run / "output.csv").is_file()


def test_exit_status_and_stderr_name_the_cause():
    out = solver_model()({"k": np.array([100.0, -5.0]), "c": np.array([0.4, 0.4])})
    np.testing.assert_array_equal(out["failed"], [False, True])
    reason = out["failure_reason"][1]
    assert reason.startswith(
        "oscillator_solver.py: exit status 2; stderr: error: need m > 0, k > 0"
    )
    assert np.isnan(out["x"][1]).all() and np.isfinite(out["x"][0]).all()


def test_failures_reach_the_study_and_the_policies_apply():
    parameters = {"k": {"type": "triangular", "modal": 1.0, "spread": 2.0}, "c": 0.4}
    study = Study(solver_model(), parameters, "reduced", 2, ["x"], validation_runs=0)
    with pytest.raises(IncompleteResultError, match="exit status 2"):
        study.run(progress=False)
    partial = study.run(progress=False, on_failure="partial")
    assert partial.failed.any() and not partial.failed.all()
    reasons = partial.dataset["failure_reason"].values[partial.failed]
    assert all("need m > 0, k > 0" in str(reason) for reason in reasons)


def test_timeout(tmp_path):
    command = [*program(tmp_path, "import time\ntime.sleep(30)\n"), "{output}", "{a}"]
    model = CommandModel(command, timeout=0.5)
    out = model({"a": np.array([1.0])})
    assert out["failed"][0]
    # the reason names the program (here the interpreter running program.py)
    assert out["failure_reason"][0] == f"{Path(sys.executable).name}: timed out after 0.5 s"


@pytest.mark.parametrize(
    ("written", "fragment"),
    [
        (None, "the program wrote no output file output.csv"),
        ("", "output file output.csv is empty"),
        ("time,y\n", "output file output.csv has a header but no data rows"),
        ("time,y\n0,1\n1,abc\n", "line 3, column 'y': 'abc' is not a number"),
        ("time,y\n0,1\n1\n", "line 3: 1 values for 2 columns"),
        ("time,y,y\n0,1,2\n", "has empty or repeated names"),
        ("time,y\n0,nan\n", "holds NaN or infinite values"),
        ("y\n1\n2\n", "has 2 rows but no coordinate column 'time'"),
    ],
)
def test_malformed_output_files(tmp_path, written, fragment):
    body = "" if written is None else f"open(sys.argv[1], 'w').write({written!r})\n"
    model = CommandModel([*program(tmp_path, body), "{output}", "{a}"])
    out = model({"a": np.array([1.0])})
    assert out["failed"][0]
    assert fragment in out["failure_reason"][0]


def test_arguments_are_never_given_to_a_shell(tmp_path):
    # a shell would run "touch" here; as a list argument it is text the program receives
    command = program(
        tmp_path,
        """
        assert sys.argv[2] == "; touch PWNED", sys.argv
        assert sys.argv[3] == "$(touch PWNED2) 2.5", sys.argv
        open(sys.argv[1], "w").write("received\\n1\\n")
        """,
    )
    model = CommandModel([*command, "{output}", "; touch PWNED", "$(touch PWNED2) {a}"])
    out = model({"a": np.array([2.5])})
    assert not out["failed"][0], out["failure_reason"][0]
    assert out["received"][0] == 1.0
    assert not list(tmp_path.rglob("PWNED*")) and not list(Path.cwd().glob("PWNED*"))


def test_single_row_gives_scalar_outputs_equal_to_the_callable(tmp_path):
    # peak velocity of the undamped oscillator x0 sqrt(k / m) (closed form), from a program
    command = program(
        tmp_path,
        """
        import math
        k, m = float(sys.argv[2]), float(sys.argv[3])
        open(sys.argv[1], "w").write(f"v_peak,omega\\n{0.01 * math.sqrt(k / m)!r},"
                                     f"{math.sqrt(k / m)!r}\\n")
        """,
    )
    model = CommandModel([*command, "{output}", "{k}", "{m}"])
    parameters = {
        "k": {"type": "triangular", "modal": 100.0, "spread": 0.1},
        "m": {"type": "triangular", "modal": 1.0, "spread": 0.05},
    }
    result = Study(model, parameters, "reduced", 3, ["v_peak"], validation_runs=0).run(
        progress=False
    )

    def reference(samples):
        return {"v_peak": 0.01 * np.sqrt(samples["k"] / samples["m"])}

    expected = Study(reference, parameters, "reduced", 3, validation_runs=0).run(progress=False)
    for bound in ("v_peak_lower", "v_peak_upper"):
        assert result.dataset[bound].dims == ("level",)
        np.testing.assert_allclose(
            result.dataset[bound].values, expected.dataset[bound].values, rtol=1e-15
        )


def test_runs_must_agree_on_columns_and_coordinate(tmp_path):
    command = program(
        tmp_path,
        """
        a = float(sys.argv[2])
        text = "time,y\\n0,1\\n1,2\\n" if a < 2 else "time,z\\n0,1\\n1,2\\n"
        text = text if a < 3 else "time,y\\n0,1\\n2,2\\n"
        open(sys.argv[1], "w").write(text)
        """,
    )
    out = CommandModel([*command, "{output}", "{a}"])({"a": np.array([1.0, 2.0, 3.0])})
    np.testing.assert_array_equal(out["failed"], [False, True, True])
    assert "output columns ['z'] differ from the first run's ['y']" in out["failure_reason"][1]
    assert "the 'time' column differs from the first run's" in out["failure_reason"][2]


def test_parameter_names_are_checked():
    with pytest.raises(InvalidParameterError, match="stiffness"):  # not a placeholder
        Study(solver_model(), {"stiffness": {"type": "triangular", "modal": 1.0, "spread": 0.1}})
    with pytest.raises(InvalidParameterError, match="'c'"):  # a placeholder without a value
        Study(solver_model(), {"k": {"type": "triangular", "modal": 100.0, "spread": 0.1}})


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"command": "solver {input}"}, "command must be a non-empty list of strings"),
        ({"command": []}, "command must be a non-empty list of strings"),
        ({"command": ["no-such-solver-xyz"]}, "program 'no-such-solver-xyz' not found"),
        ({"command": ["./missing.sh"]}, "program './missing.sh' not found"),
        ({"command": ["true"], "template": "missing.tpl"}, "template"),
        ({"command": ["true"], "timeout": -1.0}, "timeout must be a positive number"),
        ({"command": ["true"], "coordinate": ""}, "coordinate must be a column name"),
    ],
)
def test_bad_options(tmp_path, options, fragment):
    with pytest.raises(InvalidParameterError, match=re.escape(fragment)):
        CommandModel(base_dir=tmp_path, **options)


def test_study_file_needs_allow_code(tmp_path):
    folder = tmp_path / "example"
    shutil.copytree(EXAMPLE, folder)
    study_file = folder / "oscillator-command.toml"
    with pytest.raises(UntrustedCodeError) as refused:
        load_study_file(study_file)
    message = str(refused.value)
    assert f"the program '{folder / 'oscillator_solver.py'}'" in message
    assert "--allow-code" in message
    written = run_study_file(
        study_file, tmp_path / "out", progress=False, plots=False, allow_code=True
    )
    expected = Study(closed_form, PARAMETERS, "reduced", 4, ["x"], validation_runs=0)
    np.testing.assert_allclose(
        written.result.dataset["x_upper"].values,
        expected.run(progress=False).dataset["x_upper"].values,
        rtol=0,
        atol=1e-15,
    )
