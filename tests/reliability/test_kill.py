"""``kill -9`` of ``fuzzymbs run --executor processes:2`` leaves no process behind:
the workers watch their parent and end, and with them the resource tracker."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

HERE = Path(__file__).parent

STUDY = """
[study]
levels = 6
validation_runs = 0
[model]
name = "slow_closed_form:make"
[model.options]
delay = 0.3
[parameters]
x1 = {type = "triangular", modal = 2.0, spread = 0.1}
x2 = {type = "triangular", modal = 10.0, spread = 0.1}
[run]
chunk_size = 2
"""


def _alive(pid: int) -> bool:
    """Running (a zombie waiting for its reaper counts as ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False
    return state != "Z"


def _descendants(root: int) -> set[int]:
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except (FileNotFoundError, ProcessLookupError, IndexError):
                continue
            parents[int(entry.name)] = int(fields[1])
    found, frontier = set(), {root}
    while frontier:
        frontier = {pid for pid, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_kill_9_of_the_cli_leaves_no_worker_and_no_resource_tracker(tmp_path):
    study = tmp_path / "slow.toml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent / "study"), str(HERE)]))
    command = [sys.executable, "-m", "fuzzymbs.cli", "run", str(study), "--out", str(out)]
    command += ["-q", "--no-plots", "--allow-code", "--executor", "processes:2"]
    cli = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 90
        while not list((out / "chunks").glob("chunk-*.npz")):
            assert cli.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        children = _descendants(cli.pid)
        assert len(children) >= 2  # the two workers (and the resource tracker, if started)
        cli.send_signal(signal.SIGKILL)
        cli.wait(timeout=30)
        deadline = time.monotonic() + 20
        while any(_alive(pid) for pid in children) and time.monotonic() < deadline:
            time.sleep(0.1)
        survivors = [pid for pid in children if _alive(pid)]
    finally:
        if cli.poll() is None:
            cli.kill()
    for pid in survivors:  # leave nothing behind, even when the test fails
        os.kill(pid, signal.SIGKILL)
    assert survivors == []
