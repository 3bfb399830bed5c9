"""Identification files and ``fuzzymbs identify`` (fuzzymbs.study.inverse_file).

Reference: measured outputs computed by exhaustive corner evaluation of known fuzzy
spring stiffnesses (exact for this monotonic model); the identification must give them
back (to the identification's tolerance) and write files a study can use.
"""

import tomllib

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from fuzzymbs.cli import app
from fuzzymbs.errors import InverseMismatchError, StudyFileError, UntrustedCodeError
from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.study.inverse_file import load_identification_file, run_identification_file
from fuzzymbs.study.parameters import fuzzy_number_from_definition

LEVELS = [0.0, 0.25, 0.5, 0.75, 1.0]
TRUTH = {"k1": Triangular(0.8e6, 1e6, 1.3e6), "k2": Triangular(0.9e6, 1e6, 1.05e6)}


@pytest.fixture(autouse=True)
def importable_model(monkeypatch):
    monkeypatch.syspath_prepend(str(__import__("pathlib").Path(__file__).parent))


def measured_cuts():
    """Cuts of series stiffness and ratio at LEVELS from the corners of TRUTH's cuts."""
    from springs_model import make_springs

    model = make_springs()
    cuts = {name: number.cuts(LEVELS) for name, number in TRUTH.items()}
    out = {"series": ([], []), "ratio": ([], [])}
    for j in range(len(LEVELS)):
        k1, k2 = np.meshgrid(cuts["k1"][j], cuts["k2"][j])
        values = model({"k1": k1.ravel(), "k2": k2.ravel()})
        for name, (low, high) in out.items():
            low.append(float(values[name].min()))
            high.append(float(values[name].max()))
    return out


def write_file(folder, measured=None, levels=LEVELS):
    measured = measured or measured_cuts()
    lines = [
        "[identify]",
        'name = "springs"',
        f"levels = {levels}",
        "tolerance = 1e-5",
        "",
        "[model]",
        'name = "springs_model:make_springs"',
        "",
        "[modal]",
        "k1 = 2e6",
        "k2 = 0.5e6",
        "",
        "[bounds]",
        "k1 = [1.0, 1e9]",
        "k2 = [1.0, 1e9]",
        "",
        "[measured]",
    ]
    for name, (low, high) in measured.items():
        lines.append(
            f'{name} = {{ type = "piecewise", levels = {levels}, lower = {low}, upper = {high} }}'
        )
    path = folder / "identify.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_identification_file_recovers_the_springs_and_writes_a_study_table(tmp_path):
    path = write_file(tmp_path)
    written = run_identification_file(path, tmp_path / "out", allow_code=True)
    result = written.result
    assert result.converged and result.max_residual <= 1e-5
    for name, number in TRUTH.items():
        # the residual tolerance 1e-5 of the output widths bounds the parameter error
        np.testing.assert_allclose(
            result.parameters[name].cuts(LEVELS), number.cuts(LEVELS), rtol=1e-4
        )
    # identified.toml is a [parameters] table a study file accepts, with the same cuts
    table = tomllib.loads(written.toml_path.read_text())["parameters"]
    for name in TRUTH:
        number = fuzzy_number_from_definition(table[name], name)
        np.testing.assert_array_equal(number.cuts(LEVELS), result.parameters[name].cuts(LEVELS))
    dataset = xr.open_dataset(written.result_path)
    assert dataset["parameter_lower"].dims == ("level", "parameter")
    assert dataset.attrs["converged"] == 1 and dataset.attrs["method"] == "reduced"
    assert "converged" in written.summary_path.read_text()
    assert {p.name for p in written.plots} == {"parameters.png", "outputs.png"}


def test_cli_identify_and_its_refusals(tmp_path):
    path = write_file(tmp_path)
    refused = CliRunner().invoke(app, ["identify", str(path), "--out", str(tmp_path / "o1")])
    assert refused.exit_code == 1
    assert "fuzzymbs identify --allow-code" in refused.output
    allowed = CliRunner().invoke(
        app, ["identify", "--allow-code", str(path), "--out", str(tmp_path / "o2"), "--no-plots"]
    )
    assert allowed.exit_code == 0, allowed.output
    assert "converged" in allowed.output and (tmp_path / "o2" / "identified.toml").is_file()


def test_inconsistent_measurements_write_the_best_fit_then_fail(tmp_path):
    measured = {"series": ([4.5e5, 5e5], [5.75e5, 5e5]), "ratio": ([0.8, 1.0], [1.3, 1.0])}
    path = write_file(tmp_path, measured, levels=[0.0, 1.0])
    with pytest.raises(InverseMismatchError, match="cannot reproduce"):
        run_identification_file(path, tmp_path / "out", allow_code=True, plots=False)
    assert "NOT converged" in (tmp_path / "out" / "summary.txt").read_text()
    result = CliRunner().invoke(
        app, ["identify", "--allow-code", str(path), "--out", str(tmp_path / "o"), "-q"]
    )
    assert result.exit_code == 1 and "cannot reproduce the measured uncertainty" in result.output


@pytest.mark.parametrize(
    ("edit", "fragment"),
    [
        (
            lambda t: t.replace("[identify]", "[identify]\nlevel = 3"),
            "unknown key 'identify.level'",
        ),
        (lambda t: t.replace("k1 = 2e6\n", ""), "'bounds.k1': not a parameter in [modal]"),
        (lambda t: t.replace("k1 = [1.0, 1e9]", "k1 = [1.0]"), "expected [lower, upper]"),
        (lambda t: t + "\n[parameters]\nk1 = 3.0\n", "are both identified"),
        (lambda t: t.replace("series = {", "series = 3.0\nx = {"), "expected a fuzzy number"),
        (lambda t: t.replace('type = "piecewise"', 'type = "blob"', 1), "measured.series"),
        (lambda t: t.replace("k2 = 0.5e6", 'k2 = "a"'), "modal.k2"),
        (lambda t: "nonsense = [", "not valid TOML"),
    ],
)
def test_malformed_files_name_the_key(tmp_path, edit, fragment):
    path = write_file(tmp_path)
    path.write_text(edit(path.read_text()))
    with pytest.raises(StudyFileError) as raised:
        load_identification_file(path, allow_code=True)
    assert fragment in str(raised.value) and str(path) in str(raised.value)


def test_module_reference_needs_permission(tmp_path):
    with pytest.raises(UntrustedCodeError, match="springs_model:make_springs"):
        load_identification_file(write_file(tmp_path))
