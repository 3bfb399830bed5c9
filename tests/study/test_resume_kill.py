"""A run killed with SIGKILL resumes from its store and ends bit-identical to a clean run.

A real subprocess runs ``fuzzymbs run`` on a slow closed-form model referenced
as "slow_closed_form:make" (tests/study on PYTHONPATH) and is SIGKILLed after
some chunks were stored; the resumed run and a clean run then run in-process.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import xarray as xr
from same_results import assert_identical

from fuzzymbs.study.pipeline import run_study_file
from fuzzymbs.study.studyfile import load_study_file

HERE = Path(__file__).parent
CHUNK_SIZE = 4

STUDY = """
[study]
name = "{name}"
{method}

[model]
name = "slow_closed_form:make"
[model.options]
delay = {delay}

[parameters.x1]
type = "triangular"
lower = 1.0
modal = 2.0
upper = 3.0

[parameters.x2]
type = "triangular"
modal = 10.0
spread = 0.1

[run]
chunk_size = {chunk_size}
"""
REDUCED = """method = "reduced"
levels = 10
validation_runs = 0  # the calls counted are the method's own"""
ADAPTIVE = """method = "adaptive"
levels = 4"""


def _command(study: Path, out: Path) -> list[str]:
    return [
        sys.executable,
        "-m",
        "fuzzymbs.cli",
        "run",
        str(study),
        "--out",
        str(out),
        "-q",
        "--no-plots",
        "--allow-code",  # the study names a test module (fuzzymbs.study.trust)
    ]


def _environment(log: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(HERE), env.get("PYTHONPATH", "")])
    env["FUZZYMBS_TEST_CALL_LOG"] = str(log)
    return env


def _logged_calls(log: Path) -> list[list[float]]:
    if not log.exists():
        return []
    return [json.loads(line) for line in log.read_text().splitlines()]


def _kill_after_stored(study: Path, out: Path, log: Path, pattern: str) -> None:
    """Run ``fuzzymbs run`` in a subprocess and SIGKILL it once 3 files match
    ``pattern`` in its store; the run must not have written a result."""
    store = out / "chunks"
    process = subprocess.Popen(_command(study, out), env=_environment(log))
    try:
        deadline = time.monotonic() + 60
        while len(list(store.glob(pattern))) < 3:
            assert process.poll() is None, "the run ended before it could be killed"
            assert time.monotonic() < deadline, "no chunks were stored within 60 s"
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == -signal.SIGKILL
    assert not (out / "result.nc").exists()


@pytest.mark.slow
def test_killed_run_resumes_and_matches_uninterrupted(tmp_path, monkeypatch):
    study = tmp_path / "slow.toml"
    study.write_text(
        STUDY.format(name="slow-product", method=REDUCED, delay=0.15, chunk_size=CHUNK_SIZE)
    )
    plan = load_study_file(study, allow_code=True).study.plan
    count = len(plan)  # 10 * 2^2 + 1 = 41 samples
    chunks = [plan.samples[i : i + CHUNK_SIZE, 0].tolist() for i in range(0, count, CHUNK_SIZE)]
    assert count == 41 and len(chunks) == 11

    out = tmp_path / "interrupted"
    store = out / "chunks"
    _kill_after_stored(study, out, tmp_path / "first.log", "chunk-*.npz")
    stored = sorted(int(p.stem.split("-")[1]) for p in store.glob("chunk-*.npz"))
    assert 3 <= len(stored) < len(chunks)

    # resume (in this process): only the chunks missing from the store are evaluated
    monkeypatch.syspath_prepend(str(HERE))
    second_log = tmp_path / "second.log"
    monkeypatch.setenv("FUZZYMBS_TEST_CALL_LOG", str(second_log))
    run_study_file(study, out, progress=False, plots=False, allow_code=True)
    resumed_calls = _logged_calls(second_log)
    missing = [chunks[i] for i in range(len(chunks)) if i not in stored]
    assert sorted(resumed_calls) == sorted(missing)

    # an uninterrupted run of the same study into a fresh folder
    clean = tmp_path / "clean"
    monkeypatch.setenv("FUZZYMBS_TEST_CALL_LOG", str(tmp_path / "clean.log"))
    run_study_file(study, clean, progress=False, plots=False, allow_code=True)
    assert len(_logged_calls(tmp_path / "clean.log")) == len(chunks)

    with (
        xr.open_dataset(out / "result.nc") as resumed,
        xr.open_dataset(clean / "result.nc") as fresh,
    ):
        assert_identical(resumed, fresh)
        provenance = json.loads(resumed.attrs["provenance"])
        assert provenance["reused_from_store"] == sum(
            min(CHUNK_SIZE, count - i * CHUNK_SIZE) for i in stored
        )
        assert provenance["evaluated"] == count - provenance["reused_from_store"]


@pytest.mark.slow
def test_killed_adaptive_run_resumes_its_rounds_and_matches_uninterrupted(tmp_path, monkeypatch):
    # the adaptive method's rounds are stored chunk by chunk under
    # STORE/adaptive-<round>-<fingerprint>/; a SIGKILL inside a round loses only the
    # chunks not yet written, and the resumed run replays the stored rounds bit for bit
    study = tmp_path / "slow-adaptive.toml"
    study.write_text(
        STUDY.format(
            name="slow-product-adaptive", method=ADAPTIVE, delay=0.3, chunk_size=CHUNK_SIZE
        )
    )

    # an uninterrupted run first (in this process): its calls, chunk by chunk
    monkeypatch.syspath_prepend(str(HERE))
    clean = tmp_path / "clean"
    clean_log = tmp_path / "clean.log"
    monkeypatch.setenv("FUZZYMBS_TEST_CALL_LOG", str(clean_log))
    run_study_file(study, clean, progress=False, plots=False, allow_code=True)
    clean_calls = _logged_calls(clean_log)
    rounds = sorted(p.name for p in (clean / "chunks").glob("adaptive-*"))
    assert len(rounds) >= 3 and len(clean_calls) >= 6  # measured: 3 rounds, 7 chunks

    out = tmp_path / "interrupted"
    store = out / "chunks"
    _kill_after_stored(study, out, tmp_path / "first.log", "adaptive-*/chunk-*.npz")
    stored = list(store.glob("adaptive-*/chunk-*.npz"))
    assert 3 <= len(stored) < len(clean_calls)

    # resume: only the chunks missing from the store are evaluated, the same ones a
    # clean run evaluates there
    resumed_log = tmp_path / "resumed.log"
    monkeypatch.setenv("FUZZYMBS_TEST_CALL_LOG", str(resumed_log))
    run_study_file(study, out, progress=False, plots=False, allow_code=True)
    resumed_calls = _logged_calls(resumed_log)
    assert len(resumed_calls) == len(clean_calls) - len(stored)
    assert all(call in clean_calls for call in resumed_calls)
    assert sorted(p.name for p in store.glob("adaptive-*")) == rounds

    with (
        xr.open_dataset(out / "result.nc") as resumed,
        xr.open_dataset(clean / "result.nc") as fresh,
    ):
        assert_identical(resumed, fresh)
        assert resumed.attrs["adaptive_rounds"] == fresh.attrs["adaptive_rounds"] == len(rounds)
        provenance = json.loads(resumed.attrs["provenance"])
        assert provenance["evaluated"] == sum(len(call) for call in resumed_calls)
        total = resumed.sizes["sample"]
        assert provenance["reused_from_store"] == total - provenance["evaluated"] > 0
