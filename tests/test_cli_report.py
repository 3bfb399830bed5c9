"""Command line: --version, the HTML report of a run, --no-report and ``fuzzymbs report``."""

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
    command = f"fuzzymbs run {study_file} --out {out}"
    assert command in page
    with xr.open_dataset(out / "result.nc") as dataset:
        assert dataset.attrs["command"] == command
        assert dataset.attrs["fuzzymbs_version"] == fuzzymbs.__version__


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
