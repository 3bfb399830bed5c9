"""The output folder: one run at a time, a result current or absent, unusable folders
refused before any sample runs (``fuzzymbs run``)."""

import errno
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import xarray as xr
from typer.testing import CliRunner

from fuzzymbs.cli import app
from fuzzymbs.study import pipeline

runner = CliRunner()
HERE = Path(__file__).parent

PRODUCT = """
[study]
name = "{name}"
levels = 2
[model]
name = "product"
[parameters]
x1 = {{type = "triangular", modal = 2.0, spread = 0.1}}
x2 = {{type = "triangular", modal = {x2}, spread = 0.1}}
"""

OSCILLATOR = """
[study]
name = "other"
levels = 2
[model]
name = "damped-oscillator"
[parameters]
stiffness = {type = "triangular", modal = 1000.0, spread = 0.1}
"""

FAULTY = """
[study]
name = "faulty"
levels = 2
validation_runs = 0
[model]
name = "fault_models:make"
[model.options]
fault = "{fault}"
[parameters]
x1 = {{type = "triangular", lower = 1.0, modal = 2.0, upper = 3.0}}
x2 = {{type = "triangular", modal = 10.0, spread = 0.1}}
"""


def _file(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def _run(study, out, *extra):
    return runner.invoke(app, ["run", str(study), "--out", str(out), "-q", *extra])


def test_second_run_into_a_busy_folder_stops_with_one_line(tmp_path):
    study = _file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0))
    out = tmp_path / "out"
    out.mkdir()
    with pipeline.locked_output_folder(out):  # another run holds the folder
        result = _run(study, out)
    assert result.exit_code == 1
    assert "is in use by another fuzzymbs run" in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not (out / "chunks").exists()  # nothing was computed or written
    assert _run(study, out).exit_code == 0  # the lock ends with the run that held it


@pytest.mark.slow
def test_concurrent_processes_one_runs_one_is_refused(tmp_path):
    study = _file(
        tmp_path,
        "slow.toml",
        '[study]\nlevels = 3\nvalidation_runs = 0\n[model]\nname = "slow_closed_form:make"\n'
        "[model.options]\ndelay = 0.1\n[parameters]\n"
        'x1 = {type = "triangular", modal = 2.0, spread = 0.1}\n'
        'x2 = {type = "triangular", modal = 10.0, spread = 0.1}\n[run]\nchunk_size = 2\n',
    )
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent / "study"), str(HERE)]))
    command = [sys.executable, "-m", "fuzzymbs.cli", "run", str(study), "--out", str(out)]
    command += ["-q", "--no-plots", "--allow-code"]
    first = subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not list((out / "chunks").glob("chunk-*.npz")):
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.02)
        second = subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)
        assert second.returncode == 1
        assert "in use by another fuzzymbs run" in second.stderr
        assert first.wait(timeout=120) == 0
    finally:
        if first.poll() is None:
            first.kill()
    with xr.open_dataset(out / "result.nc") as result:
        assert float(result["z_upper"].values[0]) == pytest.approx(2.2 * 11.0)


def test_failed_rerun_leaves_no_result_that_looks_current(tmp_path):
    out = tmp_path / "out"
    assert _run(_file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0)), out).exit_code == 0
    plots = {p.name for p in out.glob("*.png")}
    assert plots and (out / "result.nc").exists()
    failing = _file(tmp_path, "f.toml", FAULTY.format(fault="exit"))
    result = _run(failing, out, "--allow-code", "--fresh")  # another study: refused by the store
    assert result.exit_code == 1
    assert not (out / "result.nc").exists()
    assert (out / "previous-result.nc").exists()
    assert not any((out / name).exists() for name in plots)
    summary = (out / "summary.txt").read_text()
    assert "Status: FAILED" in summary and "previous-result.nc" in summary


def test_failing_model_run_marks_the_folder_failed(tmp_path):
    out = tmp_path / "out"
    result = _run(_file(tmp_path, "f.toml", FAULTY.format(fault="exit")), out, "--allow-code")
    assert result.exit_code == 1
    assert "the model called sys.exit(0)" in result.output
    assert "Status: FAILED" in (out / "summary.txt").read_text()
    assert not (out / "result.nc").exists()


@pytest.mark.slow
def test_plots_of_an_earlier_study_are_removed(tmp_path):
    out = tmp_path / "out"
    assert _run(_file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0)), out).exit_code == 0
    assert (out / "z_membership.png").exists()
    (out / "mine.png").write_bytes(b"a user's own file")
    import shutil

    shutil.rmtree(out / "chunks")  # the store would refuse another study
    assert _run(_file(tmp_path, "b.toml", OSCILLATOR), out).exit_code == 0
    assert not (out / "z_membership.png").exists()  # the product's output
    assert (out / "mine.png").exists()  # only the plots a run wrote are removed
    assert not (out / "previous-result.nc").exists()  # the new run succeeded


@pytest.mark.parametrize("case", ["below_a_file", "dangling_link", "not_writable"])
def test_unusable_output_folder_is_refused_before_any_sample(tmp_path, case, monkeypatch):
    study = _file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0))
    if case == "below_a_file":
        (tmp_path / "file").write_text("")
        out = tmp_path / "file" / "out"
    elif case == "dangling_link":
        out = tmp_path / "link"
        out.symlink_to(tmp_path / "nowhere")
    else:
        out = tmp_path / "out"
        out.mkdir()

        def refuse(*args, **kwargs):
            raise PermissionError(13, "Permission denied")

        monkeypatch.setattr(pipeline.tempfile, "TemporaryFile", refuse)  # root writes anyway
    result = _run(study, out)
    assert result.exit_code == 1
    assert len(result.output.strip().splitlines()) == 1
    assert f"output folder {out}" in result.output
    assert not (tmp_path / "nowhere").exists()


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes anywhere")
def test_read_only_output_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    out.chmod(0o555)
    try:
        result = _run(_file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0)), out)
    finally:
        out.chmod(0o755)
    assert result.exit_code == 1 and "cannot be written" in result.output


def test_full_disk_while_writing_the_result_leaves_no_result_and_no_temporary(
    tmp_path, monkeypatch
):
    def full_disk(self, target, **kwargs):
        Path(target).write_bytes(b"CDF partial")
        raise OSError(errno.ENOSPC, "No space left on device", str(target))

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full_disk)
    out = tmp_path / "out"
    result = _run(_file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0)), out)
    assert result.exit_code == 1 and "No space left on device" in result.output
    assert "Traceback" not in result.output
    assert not (out / "result.nc").exists()
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]
    assert "Status: FAILED" in (out / "summary.txt").read_text()


def test_temporary_files_of_an_ended_run_are_removed(tmp_path):
    ended = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    out = tmp_path / "out"
    out.mkdir()
    orphan = out / f".result.nc.{int(ended.stdout)}.x1y2z3.tmp"
    orphan.write_bytes(b"partial")
    assert _run(_file(tmp_path, "a.toml", PRODUCT.format(name="a", x2=3.0)), out).exit_code == 0
    assert not orphan.exists()
