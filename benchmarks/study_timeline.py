"""Where a brake study's time goes: every integrator call of one run, timed; one JSON line.

    python benchmarks/study_timeline.py [--study 1] [--out DIR] [--serial-check]

Runs the demo study file (``fuzzymbs run src/fuzzymbs/demos/brake/0N-studyN.toml``,
without plots and report) in this interpreter with
:func:`fuzzymbs.mbs.integrate.simulate` wrapped: for each call its start and end
(seconds from the start), its samples, tolerances, whether it runs on a shared
step sequence or logs one, its thread, its purpose and the CPU time its kernels
took. The calls of one thread follow each other; calls in two threads overlap on
the two cores. Figures behind docs/brake.md ("Cost": where study 1's time goes).

A call's purpose is read off its call stack: ``reference`` (the modal sample's
reference pair, with the step sequence logged ahead in the same block),
``logging`` (a modal sample's logging run of a step sequence), ``pilot`` (the
corners the choice of tolerance compares), ``plan`` (the plan's runs, also those
run ahead while the reference finishes), ``check`` (the integration check's
re-runs at a tenth of the tolerance) and ``validation`` (the method check's runs).
Its CPU time is the thread CPU time of every thread working on its kernel calls
(:mod:`fuzzymbs.mbs.kernels.threads`), so calls that overlap are told apart;
``by_purpose`` sums them, ``other_cpu_s`` is the rest of the process's CPU time
(reading the study, the surrogate between rounds, writing the result).
``--serial-check`` makes the time-integration check's re-runs after the plan's
runs, as before they went on beside the method's last judgment (the same runs).

Where the cores wait: ``idle_core_s`` is the process's core-seconds left unused
(``numba.get_num_threads()`` times the wall time, less its CPU time), and
``kernel_free`` the intervals of at least 0.1 s in which no integrator call runs
(start-up, the adaptive method planning its next round, writing the result), with
their sum ``kernel_free_s``.
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
from collections import defaultdict
from pathlib import Path

import numba
import numpy as np
from bench_common import REPO, load_average

import fuzzymbs.mbs.integrate as integrate
import fuzzymbs.mbs.kernels.threads as threads
from fuzzymbs.cli import app
from fuzzymbs.study.extra_runs import StudyRuns

STUDY_FILES = {1: "01-study1.toml", 2: "02-study2.toml"}

#: innermost function on a call's stack -> the call's purpose (the first found, walking
#: outwards, decides; ``ahead``: a plan's runs made ahead in the background)
PURPOSES = {
    "_reference_runs": "reference",
    "_logged_run": "logging",
    "check_time_integration": "check",
    "_validate": "validation",
    "_choose_shared": "pilot",
    "choose_tolerance": "pilot",
    "ahead": "plan",
}


#: ids of the check's tighter models that run samples ahead (their runs ahead: ``check``)
CHECK_MODELS: set[int] = set()


def purpose_of_call() -> str:
    """The purpose of the integrator call being made (:data:`PURPOSES`; else ``plan``)."""
    frame = sys._getframe(2)
    while frame is not None:
        purpose = PURPOSES.get(frame.f_code.co_name)
        if purpose == "plan" and id(frame.f_locals.get("self")) in CHECK_MODELS:
            return "check"  # the check's re-runs made ahead (StudyRuns._start_check)
        if purpose is not None:
            return purpose
        frame = frame.f_back
    return "plan"


def label_check_runs_ahead() -> None:
    """Record the models the check's re-runs are made ahead on (:data:`CHECK_MODELS`)."""
    run_ahead = integrate.SimulationModel.run_ahead

    def recorded(self, samples, then=None, wrt=None):
        frame = sys._getframe(1)
        while frame is not None:
            if frame.f_code.co_name == "_start_check":
                CHECK_MODELS.add(id(self))
                break
            frame = frame.f_back
        return run_ahead(self, samples, then, wrt)

    integrate.SimulationModel.run_ahead = recorded


class KernelClock:
    """Thread CPU time of the kernel work of each integrator call (:func:`threads._share`
    wrapped: every thread that works on a call's kernels adds its CPU time to the call)."""

    def __init__(self) -> None:
        self.local = threading.local()
        self.lock = threading.Lock()
        self.share = threads._share

    def __enter__(self) -> KernelClock:
        share = self.share
        clock = self

        def timed_share(tasks, work):
            account = getattr(clock.local, "account", None)
            if account is None:
                return share(tasks, work)

            def measured() -> None:
                start = time.thread_time()
                try:
                    work()
                finally:
                    with clock.lock:
                        account[0] += time.thread_time() - start

            return share(tasks, measured)

        threads._share = timed_share
        return self

    def __exit__(self, *exc) -> None:
        threads._share = self.share


def kernel_free(calls: list[dict], wall: float, shortest: float = 0.1) -> list[list[float]]:
    """The intervals ``[from, to]`` (seconds from the start, at least ``shortest`` long)
    within ``[0, wall]`` in which none of ``calls`` (``start_s``, ``end_s``) runs."""
    free, covered = [], 0.0  # covered: the end of the calls merged so far
    for call in sorted(calls, key=lambda call: call["start_s"]):
        if call["start_s"] - covered >= shortest:
            free.append([round(covered, 2), round(call["start_s"], 2)])
        covered = max(covered, call["end_s"])
    if wall - covered >= shortest:
        free.append([round(covered, 2), round(wall, 2)])
    return free


def timeline(study: int, out: Path, serial_check: bool = False) -> dict:
    """The study run once through the command line, its integrator calls timed
    (``serial_check``: the check's re-runs none ahead, all after the plan's runs)."""
    if serial_check:
        StudyRuns._start_check = lambda self, samples: None
    label_check_runs_ahead()
    calls: list[dict] = []
    simulate = integrate.simulate
    origin = time.perf_counter()
    clock = KernelClock()

    def timed(system, samples=None, **options):
        purpose = purpose_of_call()
        account = [0.0]
        clock.local.account = account
        start = time.perf_counter()
        try:
            result = simulate(system, samples, **options)
        finally:
            clock.local.account = None
        tolerance = options.get("tolerance")
        rtol = None if tolerance is None else tolerance.rtol
        calls.append(
            {
                "start_s": round(start - origin, 2),
                "end_s": round(time.perf_counter() - origin, 2),
                "purpose": purpose,
                "cpu_s": round(account[0], 2),
                "samples": len(next(iter(samples.values()))) if samples else 1,
                "steps": None
                if result.step_counts is None
                else int(np.sum(result.step_counts[:, 0])),
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
            # this script's stdout: one JSON line
            with clock, contextlib.redirect_stdout(sys.stderr):
                app(arguments, standalone_mode=False)
        except SystemExit:
            pass
        wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    finally:
        integrate.simulate = simulate
    by_purpose: dict[str, dict] = defaultdict(lambda: {"calls": 0, "runs": 0, "cpu_s": 0.0})
    for call in calls:
        entry = by_purpose[call["purpose"]]
        entry["calls"] += 1
        entry["runs"] += call["samples"]
        entry["cpu_s"] += call["cpu_s"]
    kernel_cpu = sum(entry["cpu_s"] for entry in by_purpose.values())
    for entry in by_purpose.values():
        entry["cpu_s"] = round(entry["cpu_s"], 1)
        entry["share"] = round(entry["cpu_s"] / cpu, 3)
    free = kernel_free(calls, wall)
    return {
        "study": study,
        "serial_check": serial_check,
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "by_purpose": dict(by_purpose),
        "other_cpu_s": round(cpu - kernel_cpu, 1),
        "idle_core_s": round(numba.get_num_threads() * wall - cpu, 1),
        "kernel_free_s": round(sum(end - begin for begin, end in free), 1),
        "kernel_free": free,
        "calls": sorted(calls, key=lambda call: call["start_s"]),
    }


def main() -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=int, choices=sorted(STUDY_FILES), default=1)
    parser.add_argument("--out", type=Path, help="result folder (default: a temporary one)")
    parser.add_argument(
        "--serial-check", action="store_true", help="no re-runs of the check made ahead"
    )
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="fuzzymbs-timeline-"))
    figures = {"load_average_start": load_average()}
    try:
        figures.update(timeline(args.study, out, args.serial_check))
    finally:
        if args.out is None:
            shutil.rmtree(out, ignore_errors=True)
    figures["load_average_end"] = load_average()
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
