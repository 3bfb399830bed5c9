"""Where a brake study's time goes: every integrator call of one run, timed; one JSON line.

    python benchmarks/study_timeline.py [--study 1] [--out DIR]

Runs the demo study file (``fuzzymbs run src/fuzzymbs/demos/brake/0N-studyN.toml``,
without plots and report) in this interpreter with
:func:`fuzzymbs.mbs.integrate.simulate` wrapped: for each call its start and end
(seconds from the start), its samples, tolerances, whether it runs on a shared
step sequence or logs one, and its thread. The calls of one thread follow each
other; calls in two threads overlap on the two cores. Figures behind
docs/brake.md ("Cost": where study 1's time goes).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from bench_common import REPO, load_average

import fuzzymbs.mbs.integrate as integrate
from fuzzymbs.cli import app

STUDY_FILES = {1: "01-study1.toml", 2: "02-study2.toml"}


def timeline(study: int, out: Path) -> dict:
    """The study run once through the command line, its integrator calls timed."""
    calls: list[dict] = []
    simulate = integrate.simulate
    origin = time.perf_counter()

    def timed(system, samples=None, **options):
        start = time.perf_counter()
        result = simulate(system, samples, **options)
        tolerance = options.get("tolerance")
        rtol = None if tolerance is None else tolerance.rtol
        calls.append(
            {
                "start_s": round(start - origin, 2),
                "end_s": round(time.perf_counter() - origin, 2),
                "samples": len(next(iter(samples.values()))) if samples else 1,
                "rtol": np.atleast_1d(rtol).tolist() if rtol is not None else None,
                "shared_sequence": options.get("step_sequence") is not None,
                "logs_steps": options.get("log_steps", False) is not False,
                "thread": threading.current_thread().name,
            }
        )
        return result

    integrate.simulate = timed
    try:
        path = REPO / "src" / "fuzzymbs" / "demos" / "brake" / STUDY_FILES[study]
        start_cpu, start = time.process_time(), time.perf_counter()
        arguments = ["run", str(path), "--out", str(out), "--fresh", "--no-plots", "--no-report"]
        try:
            with contextlib.redirect_stdout(sys.stderr):  # this script's stdout: one JSON line
                app(arguments, standalone_mode=False)
        except SystemExit:
            pass
        wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    finally:
        integrate.simulate = simulate
    return {
        "study": study,
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "calls": sorted(calls, key=lambda call: call["start_s"]),
    }


def main() -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=int, choices=sorted(STUDY_FILES), default=1)
    parser.add_argument("--out", type=Path, help="result folder (default: a temporary one)")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="fuzzymbs-timeline-"))
    figures = {"load_average_start": load_average()}
    try:
        figures.update(timeline(args.study, out))
    finally:
        if args.out is None:
            shutil.rmtree(out, ignore_errors=True)
    figures["load_average_end"] = load_average()
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
