"""Command line: --version, the HTML report of a run, --no-report and ``fuzzymbs report``."""

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fuzzymbs
from fuzzymbs.cli import app

runner = CliRunner()


def test_version_option_prints_the_package_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"fuzzymbs {fuzzymbs.__version__}"


def _product_file(folder):
    from importlib import resources

    source = resources.files("fuzzymbs") / "demos" / "quickstart" / "01-product.toml"
    path = folder / "product.toml"
    path.write_bytes(source.read_bytes())
    return path


def test_run_writes_the_report_and_records_its_command(tmp_path):
    import xarray as xr

    study_file = _product_file(tmp_path)
    out = tmp_path / "out"
    result = runner.invoke(app, ["run", str(study_file), "--out", str(out), "-q", "--no-plots"])
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "report: " in result.output and "<h2>Checks</h2>" in page
    # recorded with the folder it ran in: the command runs as written from anywhere
    command = f"cd {shlex.quote(os.getcwd())} && fuzzymbs run {study_file} --out {out}"
    assert command.replace("&", "&amp;") in page
    with xr.open_dataset(out / "result.nc") as dataset:
        assert dataset.attrs["command"] == command
        assert dataset.attrs["fuzzymbs_version"] == fuzzymbs.__version__


def test_the_recorded_command_keeps_the_timeout(tmp_path):
    # a sample slower than --timeout fails, so the timeout is part of what gave the result
    import xarray as xr

    study_file = _product_file(tmp_path)
    out = tmp_path / "out"
    arguments = ["run", str(study_file), "--out", str(out), "--timeout", "30", "-q"]
    result = runner.invoke(app, [*arguments, "--no-plots", "--no-report"])
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out / "result.nc") as dataset:
        assert shlex.split(dataset.attrs["command"])[-2:] == ["--timeout", "30.0"]


def test_the_recorded_command_of_a_user_module_study_runs_as_written(tmp_path, monkeypatch):
    # examples/cantilever.toml's model is a module of the user's, found through
    # PYTHONPATH and with paths relative to the folder the command is typed in: the
    # recorded command must name that folder and set PYTHONPATH again
    import xarray as xr

    fuzzymbs_script = shutil.which("fuzzymbs", path=str(Path(sys.executable).parent))
    if fuzzymbs_script is None:
        pytest.skip("no fuzzymbs script beside the interpreter (not installed)")
    examples = Path(__file__).resolve().parents[1] / "examples"
    models = tmp_path / "models"
    models.mkdir()
    # a name of its own: another test imports examples/cantilever_model.py in this process
    shutil.copy(examples / "cantilever_model.py", models / "recorded_cantilever.py")
    study = (examples / "cantilever.toml").read_text(encoding="utf-8")
    study = study.replace('"cantilever_model:', '"recorded_cantilever:')
    (tmp_path / "cantilever.toml").write_text(study, encoding="utf-8")
    # the fuzzymbs under test after the user's folder, as a user's PYTHONPATH may hold it
    python_path = os.pathsep.join(["models", str(Path(fuzzymbs.__file__).resolve().parents[1])])
    monkeypatch.setenv("PYTHONPATH", python_path)
    monkeypatch.syspath_prepend(str(models))  # what PYTHONPATH does when Python starts
    monkeypatch.chdir(tmp_path)
    arguments = ["run", "cantilever.toml", "--out", "out", "--allow-code", "-q", "--no-plots"]
    result = runner.invoke(app, arguments)
    assert result.exit_code == 0, result.output
    with xr.open_dataset(tmp_path / "out" / "result.nc") as dataset:
        command = dataset.attrs["command"]
        first = dataset["tip_deflection_upper"].values
    words = shlex.split(command)
    assert words[:3] == ["cd", str(Path.cwd()), "&&"]
    assert words[3:5] == [f"PYTHONPATH={python_path}", "fuzzymbs"]
    assert command in (tmp_path / "out" / "report.html").read_text(encoding="utf-8").replace(
        "&amp;", "&"
    )
    # run as written from the folder it names, anew, with nothing of this process's
    # environment but PATH to the fuzzymbs script
    shutil.rmtree(tmp_path / "out")
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    environment["PATH"] = os.pathsep.join([str(Path(fuzzymbs_script).parent), os.defpath])
    done = subprocess.run(
        command,
        shell=True,
        cwd=words[1],
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(tmp_path / "out" / "result.nc") as dataset:
        assert (dataset["tip_deflection_upper"].values == first).all()
        assert dataset.attrs["command"] == command  # the same command, recorded again


def test_no_report_option_and_the_report_command(tmp_path):
    study_file = _product_file(tmp_path)
    out = tmp_path / "out"
    arguments = ["run", str(study_file), "--out", str(out), "-q", "--no-plots", "--no-report"]
    result = runner.invoke(app, arguments)
    assert result.exit_code == 0, result.output
    assert not (out / "report.html").exists()
    result = runner.invoke(app, ["report", str(out)])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == str(out / "report.html")
    assert "z = x1 * x2" in (out / "report.html").read_text(encoding="utf-8")
    elsewhere = tmp_path / "elsewhere.html"
    result = runner.invoke(app, ["report", str(out / "result.nc"), "--out", str(elsewhere)])
    assert result.exit_code == 0 and elsewhere.stat().st_size > 10_000


def test_report_command_refuses_what_is_not_a_result(tmp_path):
    result = runner.invoke(app, ["report", str(tmp_path)])
    assert result.exit_code == 1 and "result.nc: no such file" in result.output
    (tmp_path / "result.nc").write_text("not netcdf")
    result = runner.invoke(app, ["report", str(tmp_path)])
    assert result.exit_code == 1 and "not a readable result file" in result.output


def test_report_embeds_the_plot_files_and_pdf_is_written_only_when_asked(tmp_path):
    import base64
    import re

    study_file = _product_file(tmp_path)
    plain, both = tmp_path / "plain", tmp_path / "both"
    result = runner.invoke(app, ["run", str(study_file), "--out", str(plain), "-q"])
    assert result.exit_code == 0, result.output
    pngs = sorted(plain.glob("*.png"))
    assert pngs and not list(plain.glob("*.pdf"))  # PNG only by default
    page = (plain / "report.html").read_text(encoding="utf-8")
    embedded = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    # every figure of the page is a plot file, byte for byte: drawn once, not twice
    assert sorted(embedded) == sorted(base64.b64encode(p.read_bytes()).decode() for p in pngs)
    arguments = ["run", str(study_file), "--out", str(both), "-q", "--format", "pdf"]
    result = runner.invoke(app, [*arguments, "--format", "png"])
    assert result.exit_code == 0, result.output
    assert {p.stem for p in both.glob("*.pdf")} == {p.stem for p in pngs}
    assert all(p.read_bytes().startswith(b"%PDF") for p in both.glob("*.pdf"))
    # without PNG files the report draws its figures itself: the same images
    result = runner.invoke(app, [*arguments[:-2], "--fresh", "--format", "pdf"])
    assert result.exit_code == 0, result.output
    assert not list(both.glob("*.png"))
    page = (both / "report.html").read_text(encoding="utf-8")
    assert len(re.findall(r'src="data:image/png;base64,', page)) == len(pngs)


def test_unknown_plot_format_is_refused_before_the_run(tmp_path):
    study_file = _product_file(tmp_path)
    out = tmp_path / "out"
    result = runner.invoke(app, ["run", str(study_file), "--out", str(out), "--format", "gif"])
    assert result.exit_code == 1
    assert "--format ['gif']; allowed: png, pdf, svg" in result.output
    assert not (out / "result.nc").exists()
