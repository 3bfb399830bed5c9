"""A study file is data, and so is a result file: neither reaches beyond what its user allowed."""

import json
import shutil
from pathlib import Path
from typing import ClassVar

import pytest
import xarray as xr
from typer.testing import CliRunner

from fuzzymbs import Triangular
from fuzzymbs.cli import app
from fuzzymbs.errors import ModelOutputError, StudyFileError, UntrustedCodeError
from fuzzymbs.study.study import Study
from fuzzymbs.study.studyfile import load_study_file

runner = CliRunner()

STUDY = """
[study]
levels = 2
[model]
name = "product"
[parameters]
x1 = {{type = "triangular", modal = 2.0, spread = 0.1}}
x2 = {{type = "triangular", modal = 3.0, spread = 0.1}}
[run]
executor = "{executor}"
"""


def _study_file(tmp_path, executor):
    path = tmp_path / "study.toml"
    path.write_text(STUDY.format(executor=executor))
    return path


@pytest.mark.parametrize("address", ["dask://127.0.0.1:1", "tcp://127.0.0.1:1"])
def test_dask_scheduler_in_a_study_file_needs_allow_code(tmp_path, address):
    path = _study_file(tmp_path, address)
    with pytest.raises(UntrustedCodeError, match=r"connects to a Dask scheduler.*--allow-code"):
        load_study_file(path)
    result = runner.invoke(app, ["run", str(path), "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 1 and "--allow-code" in result.output
    assert not (tmp_path / "out").exists()  # refused before anything was connected or written
    # the command line's own executor replaces the file's: nothing to refuse
    result = runner.invoke(
        app, ["run", str(path), "--out", str(tmp_path / "out"), "-q", "--executor", "inline"]
    )
    assert result.exit_code == 0, result.output


def test_worker_count_is_capped(tmp_path):
    path = _study_file(tmp_path, "processes:100000")
    with pytest.raises(StudyFileError, match=r"at most .* workers on this machine"):
        load_study_file(path)
    path = _study_file(tmp_path, "inline")
    result = runner.invoke(
        app, ["run", str(path), "--out", str(tmp_path / "o"), "--executor", "processes:100000"]
    )
    assert result.exit_code == 1 and "at most" in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", ["../../elsewhere", "/tmp", "quickstart/../quickstart", ""])
def test_demo_runs_only_shipped_demos(tmp_path, name, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.copy(_study_file(tmp_path, "inline"), elsewhere / "evil.toml")
    monkeypatch.chdir(tmp_path / "elsewhere")
    result = runner.invoke(app, ["demo", name, "--out", str(tmp_path / "out"), "-q"])
    assert result.exit_code == 1 and "unknown demo" in result.output
    assert not (tmp_path / "out").exists()


def test_unsafe_declared_output_name_is_refused_before_any_sample():
    class Declared:
        outputs: ClassVar[dict[str, str]] = {"../escape": "m"}
        calls = 0

        def __call__(self, samples):
            Declared.calls += 1
            return {"../escape": samples["x"]}

    with pytest.raises(ModelOutputError, match="cannot name a dataset variable"):
        Study(Declared(), {"x": Triangular(1, 2, 3)})
    assert Declared.calls == 0


@pytest.fixture(scope="module")
def result_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("result")
    path = folder / "study.toml"
    path.write_text(STUDY.format(executor="inline"))
    result = runner.invoke(app, ["run", str(path), "--out", str(folder / "out"), "-q"])
    assert result.exit_code == 0, result.output
    return folder / "out" / "result.nc"


def _crafted(result_file, tmp_path, edit):
    with xr.open_dataset(result_file) as dataset:
        crafted = dataset.load()
    edited = edit(crafted)
    crafted = edited if isinstance(edited, xr.Dataset) else crafted
    path = tmp_path / "crafted.nc"
    crafted.to_netcdf(path)
    return path


@pytest.mark.parametrize("name", ["../../escape", "/tmp/escape", "sub/escape", "x" * 200])
def test_plot_never_writes_outside_out(result_file, tmp_path, name):
    def rename(dataset):
        renamed = dataset.rename({f"z_{s}": f"{name}_{s}" for s in ("lower", "upper")})
        renamed.attrs["outputs"] = json.dumps([name])
        renamed.attrs["influence_outputs"] = "[]"
        return renamed

    if "/" in name:  # NetCDF refuses "/" in variable names: only the attribute says so

        def rename(dataset):
            dataset.attrs["outputs"] = json.dumps([name])
            return dataset

    crafted = _crafted(result_file, tmp_path, rename)
    out = tmp_path / "plots" / "deep"
    before = set(Path(tmp_path).rglob("*"))
    result = runner.invoke(app, ["plot", str(crafted), "--out", str(out)])
    assert result.exit_code == 1
    assert "cannot name a dataset variable and a plot file" in result.output
    assert set(Path(tmp_path).rglob("*")) == before  # nothing written anywhere
    assert not Path("/tmp/escape.png").exists()


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda d: d.attrs.__setitem__("outputs", "{not json"), "not valid JSON"),
        (lambda d: d.attrs.__setitem__("plots", "[1, 2"), "'plots' is not valid JSON"),
        (lambda d: d.attrs.__setitem__("plots", '{"membership": [{"output": "q"}]}'), "invalid"),
        (lambda d: d.drop_vars("z_lower"), "missing variables"),
        (lambda d: d.attrs.pop("outputs"), "no 'outputs' attribute"),
    ],
)
def test_plot_of_a_damaged_result_is_one_line(result_file, tmp_path, damage, message):
    crafted = _crafted(result_file, tmp_path, damage)
    result = runner.invoke(app, ["plot", str(crafted), "--out", str(tmp_path / "p")])
    assert result.exit_code == 1
    assert message in result.output and len(result.output.strip().splitlines()) == 1


def test_plot_of_corrupted_bytes_is_one_line(result_file, tmp_path):
    damaged = tmp_path / "damaged.nc"
    damaged.write_bytes(result_file.read_bytes()[:300])
    result = runner.invoke(app, ["plot", str(damaged), "--out", str(tmp_path / "p")])
    assert result.exit_code == 1 and "not a readable result file" in result.output
    assert len(result.output.strip().splitlines()) == 1
