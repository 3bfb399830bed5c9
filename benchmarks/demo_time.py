"""The first ten minutes of a newcomer: ``fuzzymbs demo gear-ste`` timed as whole processes.

Three cases, each a fresh ``fuzzymbs`` process (the console script of the
environment this runs in), in a fresh working folder of its own:

* **first run**: ``NUMBA_CACHE_DIR`` points at an empty folder, so every kernel
  the demo touches is compiled (what the first run after an install pays);
* **second run**: the same command again into the same output folder (a resume:
  every run comes from the store, the figures from the folder's figure cache);
* **new folder**: the filled kernel cache, a new output folder and another
  working folder (every run and figure is computed again; only the compilation
  is saved);
* **default cache, another folder**: as the new folder, with Numba's cache in
  its default place (beside the package's source, as a user has it), run after a
  warm-up run from a different working folder.

With ``NUMBA_DEBUG_CACHE=1`` Numba says for each kernel whether it was loaded
from the cache or compiled and saved: the second and new-folder runs must load
every kernel and compile none (``kernels_compiled`` = 0), whatever the working
folder. Reports the median, minimum and maximum wall time of ``--repeat`` runs of
each case (the first run: ``--repeat`` fresh caches).

    python benchmarks/demo_time.py [--repeat 5]
    python benchmarks/demo_time.py --record-brake   # the brake demo's timing.json

``--record-brake`` times ``fuzzymbs demo brake`` once into a new folder (run it
once before, so that its kernels are cached) between two measurements of the
cost of a brake sample-step (:mod:`fuzzymbs.models.brake.calibration`), and
prints the figures ``fuzzymbs/demos/brake/timing.json`` holds: the demo then
announces the recorded time scaled by the cost measured where it runs.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DEMO = ["demo", "gear-ste", "--out", "demo-out", "-q"]


def _fuzzymbs() -> str:
    script = Path(sys.executable).with_name("fuzzymbs")
    if not script.exists():
        raise SystemExit(f"{script}: no fuzzymbs console script beside this Python")
    return str(script)


def _run(folder: Path, cache: Path | None) -> tuple[float, int, int]:
    """Wall time [s] of one demo in ``folder``, and the kernels loaded and compiled
    (``cache``: Numba's cache folder; None: its default, beside the package's source)."""
    environment = dict(os.environ, NUMBA_DEBUG_CACHE="1")
    environment.pop("NUMBA_CACHE_DIR", None)
    if cache is not None:
        environment["NUMBA_CACHE_DIR"] = str(cache)
    start = time.perf_counter()
    done = subprocess.run(
        [_fuzzymbs(), *DEMO], cwd=folder, env=environment, capture_output=True, text=True
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"the demo failed:\n{done.stderr[-2000:]}")
    text = done.stdout + done.stderr
    return wall, text.count("data loaded from"), text.count("data saved to")


def _summary(name: str, runs: list[tuple[float, int, int]]) -> str:
    walls = [wall for wall, _, _ in runs]
    loaded = max(count for _, count, _ in runs)
    compiled = max(count for _, _, count in runs)
    return (
        f"| {name} | {statistics.median(walls):.2f} s | {min(walls):.2f}-{max(walls):.2f} s "
        f"| {loaded} | {compiled} |"
    )


def record_brake() -> None:
    """The brake demo's wall time and the sample-step cost around it (timing.json)."""
    from fuzzymbs.models.brake.calibration import seconds_per_sample_step

    before = seconds_per_sample_step()
    with tempfile.TemporaryDirectory() as scratch:
        start = time.perf_counter()
        subprocess.run(
            [_fuzzymbs(), "demo", "brake", "--out", "demo-out", "-q"], cwd=scratch, check=True
        )
        wall = time.perf_counter() - start
    after = seconds_per_sample_step()
    print(f"sample-step before {before:.4g} s, after {after:.4g} s", file=sys.stderr)
    figures = {
        "seconds": round(wall, 1),
        "sample_step_seconds": float(f"{(before + after) / 2:.4g}"),
    }
    print(json.dumps({"date": time.strftime("%Y-%m-%d"), "calibration": "brake", **figures}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs of each case")
    parser.add_argument("--record-brake", action="store_true", help="time the brake demo")
    arguments = parser.parse_args()
    if arguments.record_brake:
        record_brake()
        return
    first, second, elsewhere, default = [], [], [], []
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        for index in range(arguments.repeat):
            cache, folder = root / f"cache-{index}", root / f"work-{index}"
            folder.mkdir()
            first.append(_run(folder, cache))
            second.append(_run(folder, cache))
            other = root / f"other-{index}"
            other.mkdir()
            elsewhere.append(_run(other, cache))
            if index:  # keep one filled cache; the others only cost disk
                shutil.rmtree(cache)
            warm_up, other = root / f"warm-up-{index}", root / f"default-{index}"
            warm_up.mkdir()
            other.mkdir()
            _run(warm_up, None)
            default.append(_run(other, None))
    print(f"fuzzymbs demo gear-ste, {arguments.repeat} runs of each case ({os.cpu_count()} cores)")
    print("| case | median wall | min-max | cache entries loaded | kernels compiled |")
    print("|---|---|---|---|---|")
    print(_summary("first run (empty kernel cache)", first))
    print(_summary("second run (same command, same folder)", second))
    print(_summary("new output and working folder (kernel cache filled)", elsewhere))
    print(_summary("the same, Numba's default cache place", default))


if __name__ == "__main__":
    main()
