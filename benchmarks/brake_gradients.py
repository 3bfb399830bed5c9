"""The brake demo's studies with the model's gradients against without; prints one JSON line.

    python benchmarks/brake_gradients.py [--studies 1 2] [--gradients true false]
        [--keep DIR]

Each study file (``src/fuzzymbs/demos/brake/0N-studyN.toml``: the adaptive method,
ROS34PW2 on shared steps at the tolerance the study chooses) runs as a user runs it,
``fuzzymbs run FILE --out DIR --fresh --option gradients=...`` in a child process with
its figures and report, once per setting, study by study in the order given. Per run:
wall and CPU time of the process (its children included: ``RUSAGE_CHILDREN``), the
plan's runs and rounds, the certified method error, whether it converged, the judging
runs (the time-integration choice's pilot, the check's re-runs), the time-integration
error, and per round its runs and the certified error after it (from the study's log).
The ratios with / without gradients: runs, CPU.

Kernels (with and without sensitivities, own and shared steps) are compiled (cached on
disk) by a warm-up before the first timed run. ``--keep DIR`` keeps each run's folder
(its store and ``result.nc``) under DIR for a later look at the rounds.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from bench_common import load_average, log
from brake_targets import FILES, run_file

_WARM_UP = """
from fuzzymbs.models.brake import DiscBrake
brake = DiscBrake(t_end=2e-5)
names = ["pad_spring_stiffness", "caliper_spring_stiffness", "nodal_force", "disc_speed"]
samples = {"pad_spring_stiffness": [2e5, 2.1e5]}
for model in (brake, brake.share_steps({"pad_spring_stiffness": [2e5]})):
    model(samples)
    model(samples, wrt=names[:3])
    model(samples, wrt=names[:2] + names[3:])
"""
_ROUND = re.compile(r"adaptive round (\d+), (\d+) runs")
_ERROR = re.compile(r"certified error after round (\d+): ([0-9.eE+-]+|nan|inf) of the cut")
#: result attributes reported as they are
_ATTRS = (
    "adaptive_rounds",
    "adaptive_status",
    "method_converged",
    "adaptive_gradients",
    "time_integration_runs",
    "integration_pilot_runs",
    "time_integration",
    "integration_choice_note",
)


def study_run(path: Path, out: Path, gradients: str) -> dict[str, Any]:
    """One ``fuzzymbs run`` of ``path`` with ``gradients``: :func:`brake_targets.run_file`'s
    figures, the attributes in ``_ATTRS`` and the rounds (runs, certified error after)."""
    import xarray

    lines: list[str] = []
    figures = run_file(path, out, ("--option", f"gradients={gradients}"), log=lines)
    (result,) = out.rglob("result.nc")
    with xarray.open_dataset(result) as data:
        for name in _ATTRS:
            value = data.attrs.get(name)
            figures[name] = value.item() if hasattr(value, "item") else value
    runs = {int(m[1]): int(m[2]) for m in map(_ROUND.search, lines) if m}
    errors = {int(m[1]): float(m[2]) for m in map(_ERROR.search, lines) if m}
    figures["rounds"] = [
        {"round": k, "runs": runs[k], "error_after": errors.get(k)} for k in sorted(runs)
    ]
    return figures


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", type=int, nargs="+", default=[1, 2], choices=[1, 2])
    parser.add_argument(
        "--gradients", nargs="+", default=["true", "false"], choices=["true", "false"]
    )
    parser.add_argument("--keep", type=Path, default=None)
    args = parser.parse_args(argv)
    figures: dict[str, Any] = {"load_average_start": load_average()}
    subprocess.run([sys.executable, "-c", _WARM_UP], check=True)
    with tempfile.TemporaryDirectory() as folder:
        root = args.keep or Path(folder)
        for study in args.studies:
            found = {}
            for setting in args.gradients:
                name = f"study{study}_gradients_{setting}"
                log(f"{name} ...")
                found[setting] = study_run(FILES[study]["default"], root / name, setting)
                log(f"{name}: {json.dumps(found[setting])}")
                figures[name] = found[setting]
            if {"true", "false"} <= found.keys():
                with_, without = found["true"], found["false"]
                figures[f"study{study}_runs_with_over_without"] = round(
                    with_["runs"] / without["runs"], 3
                )
                figures[f"study{study}_cpu_with_over_without"] = round(
                    with_["cpu_s"] / without["cpu_s"], 3
                )
    figures["load_average_end"] = load_average()
    return figures


if __name__ == "__main__":
    print(json.dumps(main()))
