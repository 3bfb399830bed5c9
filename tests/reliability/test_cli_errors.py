"""Every error a user can cause is one line on stderr with exit status 1; ``--debug`` (or
FUZZYMBS_DEBUG=1) shows the traceback instead. Large plans are refused or built quickly."""

import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fuzzymbs import Triangular
from fuzzymbs.cli import app
from fuzzymbs.errors import PlanTooLargeError
from fuzzymbs.fuzzy.sparse_grid import SparseGrid, node_count
from fuzzymbs.study.study import Study

runner = CliRunner()
HERE = Path(__file__).parent

PRODUCT = """
[study]
levels = 2
[model]
name = "product"
[parameters]
x1 = {type = "triangular", modal = 2.0, spread = 0.1}
x2 = {type = "triangular", modal = 3.0, spread = 0.1}
"""

FAULTY = """
[study]
levels = 2
validation_runs = 0
[model]
name = "fault_models:make"
[model.options]
fault = "{fault}"
everywhere = {everywhere}
[parameters]
x1 = {{type = "triangular", lower = 1.0, modal = 2.0, upper = 3.0}}
x2 = {{type = "triangular", modal = 10.0, spread = 0.1}}
[run]
chunk_size = 1
"""


def _one_line_error(result, *needles):
    """Exit status 1 and one error line (warnings logged before it may precede it)."""
    assert result.exit_code == 1, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.output
    for needle in needles:
        assert needle in errors[0]


def _run(study, out, *extra):
    return runner.invoke(app, ["run", str(study), "--out", str(out), "-q", *extra])


def test_study_path_is_a_directory(tmp_path):
    _one_line_error(_run(tmp_path, tmp_path / "out"), "is a directory")


def test_study_file_not_utf8(tmp_path):
    study = tmp_path / "latin1.toml"
    study.write_bytes(PRODUCT.encode() + b"# caf\xe9\n")
    _one_line_error(_run(study, tmp_path / "out"), "not UTF-8")


def test_debug_shows_the_traceback(tmp_path, monkeypatch):
    result = runner.invoke(app, ["--debug", "run", str(tmp_path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 1 and "StudyFileError" in repr(result.exception)
    monkeypatch.setenv("FUZZYMBS_DEBUG", "1")
    result = _run(tmp_path, tmp_path / "o")
    assert result.exit_code == 1 and result.exception is not None
    assert "is a directory" in str(result.exception)


def test_empty_chunk_file_does_not_block_a_rerun(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(PRODUCT)
    out = tmp_path / "out"
    assert _run(study, out, "--chunk-size", "4", "--no-plots").exit_code == 0
    (out / "chunks" / "chunk-000001.npz").write_bytes(b"")
    result = _run(study, out, "--no-plots")
    assert result.exit_code == 0, result.output
    assert "Status: complete" in (out / "summary.txt").read_text()


@pytest.mark.parametrize(
    ("fault", "everywhere", "chunk", "needles"),
    [
        ("new_key", "false", "1", ["outputs differ between samples", "new ['extra']"]),
        ("ragged", "true", "9", ["not a numeric array"]),
        ("string", "true", "9", ["not numbers"]),
        ("bad_name", "true", "9", ["'../escape'", "cannot name a dataset variable"]),
    ],
)
def test_broken_model_outputs(tmp_path, fault, everywhere, chunk, needles):
    study = tmp_path / "f.toml"
    study.write_text(FAULTY.format(fault=fault, everywhere=everywhere))
    result = _run(study, tmp_path / "out", "--allow-code", "--chunk-size", chunk)
    _one_line_error(result, *needles)


def test_output_name_too_long_is_refused_at_the_first_chunk(tmp_path):
    class Long:
        calls = 0

        def __call__(self, samples):
            Long.calls += 1
            return {"z" * 150: samples["x"]}

    with pytest.raises(Exception, match="at most 100 characters"):
        Study(Long(), {"x": Triangular(1, 2, 3)}, levels=4).run(progress=False, chunk_size=1)
    assert Long.calls == 1  # refused at the first chunk, not after every sample ran


def test_worker_that_dies_is_one_line(tmp_path):
    study = tmp_path / "f.toml"
    study.write_text(FAULTY.format(fault="kill", everywhere="false"))
    result = _run(study, tmp_path / "out", "--allow-code", "--executor", "processes:1")
    _one_line_error(result, "ended while evaluating samples")


def test_model_that_exits_gives_a_nonzero_status(tmp_path):
    study = tmp_path / "f.toml"
    study.write_text(FAULTY.format(fault="os_exit", everywhere="false"))
    _one_line_error(_run(study, tmp_path / "out", "--allow-code"), "os._exit(0)")


def test_timeout_from_the_command_line(tmp_path):
    study = tmp_path / "f.toml"
    study.write_text(FAULTY.format(fault="hang", everywhere="false"))
    result = _run(study, tmp_path / "out", "--allow-code", "--timeout", "0.2")
    _one_line_error(result, "timed out after 0.2 s")
    _one_line_error(_run(study, tmp_path / "out", "--allow-code", "--timeout", "0"), "timeout")


@pytest.mark.slow  # Dask retries the connection for 10 s
def test_unreachable_dask_scheduler(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(PRODUCT)
    result = _run(study, tmp_path / "out", "--executor", "dask://127.0.0.1:1")
    _one_line_error(result, "cannot connect to the Dask scheduler")


def test_plan_of_ten_thousand_parameters_is_refused_quickly():
    parameters = {f"x{i}": Triangular(1, 2, 3) for i in range(10_000)}
    started = time.perf_counter()
    with pytest.raises(PlanTooLargeError, match="10000 fuzzy parameters"):
        Study(lambda s: {"z": s["x0"]}, parameters, levels=4)  # refused before any run
    # not a timing assertion of the package's speed: a guard against the quadratic refusal
    # message (minutes) coming back
    assert time.perf_counter() - started < 30


def test_sparse_grid_depth_does_not_grow_with_the_dimension(monkeypatch):
    # 300 parameters: deeper than this recursion limit and wider than np.meshgrid's 64 axes
    monkeypatch.setattr(sys, "getrecursionlimit", sys.getrecursionlimit)
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(250)
    try:
        grid = SparseGrid(300, 1)
    finally:
        sys.setrecursionlimit(limit)
    assert len(grid) == node_count(300, 1) == 601
    assert np.all((grid.nodes == 0.5).sum(axis=1) >= 299)  # one coordinate off the centre


def test_timeout_from_the_study_file(tmp_path):
    study = tmp_path / "f.toml"
    study.write_text(FAULTY.format(fault="hang", everywhere="false") + "timeout = 1\n")
    _one_line_error(_run(study, tmp_path / "out", "--allow-code"), "timed out after 1 s")
    study.write_text(FAULTY.format(fault="none", everywhere="false") + "timeout = 0\n")
    _one_line_error(_run(study, tmp_path / "out", "--allow-code"), "run.timeout")
