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
