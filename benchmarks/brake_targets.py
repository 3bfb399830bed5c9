"""The certified brake studies against the paper's, end to end; prints one JSON line.

    python benchmarks/brake_targets.py [--rounds 2] [--studies 1 2] [--variants default rodas4]
        [--tolerances 0.05 0.02]

Each study runs as a user runs it, ``fuzzymbs run FILE --out DIR --fresh`` in a child
process with its figures and report: the demo's certified study
(``src/fuzzymbs/demos/brake/0N-studyN.toml``: the adaptive method, ROS34PW2 on shared
steps at the tolerance the study chooses, the time-integration check) and the paper's
setting (``examples/brake_studyN_paper.toml``: the reduced method, RK4 at 1 us, with
its own check runs). ``--variants rodas4`` adds the demo's study with
``integrator = "rodas4"`` in its model options; ``--tolerances`` adds the demo's study
certified to a looser share of the cut width (its ``method_tolerance`` and
``integration_tolerance``, variants ``tol0.05`` ...: what a user screening design
variants would run). The variants alternate, ``--rounds``
times; per variant the smallest wall time of the process, with its CPU time (the
child's user + system) and the study's own figures from ``result.nc`` (runs, method
and time-integration error on the cut-width scale). The ratios certified / paper are
the issue's targets (study 1 at most 2, study 2 at most 3).

Kernels are compiled (cached on disk) by a warm-up call of each integrator before
the first timed run, so no timed run compiles.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench_common import REPO, load_average

DEMOS = REPO / "src" / "fuzzymbs" / "demos" / "brake"
FILES = {
    1: {
        "default": DEMOS / "01-study1.toml",
        "paper": REPO / "examples" / "brake_study1_paper.toml",
    },
    2: {
        "default": DEMOS / "02-study2.toml",
        "paper": REPO / "examples" / "brake_study2_paper.toml",
    },
}
_WARM_UP = """
from fuzzymbs.models.brake import DiscBrake
for settings in ({"integrator": "rk4", "dt": 1e-6}, {}, {"integrator": "rodas4"}):
    DiscBrake(t_end=2e-5, **settings)({"pad_spring_stiffness": [2e5, 2.1e5]})
"""


def with_integrator(path: Path, integrator: str, folder: Path) -> Path:
    """A copy of the study file with ``integrator`` in its model options (the file has
    no ``[model.options]`` table)."""
    text = path.read_text()
    if "[model.options]" in text:
        raise ValueError(f"{path} already has model options")
    copy = folder / f"{path.stem}-{integrator}.toml"
    copy.write_text(text + f'\n[model.options]\nintegrator = "{integrator}"\n')
    return copy


def with_tolerance(path: Path, tolerance: float, folder: Path) -> Path:
    """A copy of the adaptive study file whose method and time-integration tolerances
    (of the cut width) are ``tolerance``: its rounds stop there, and its pilot chooses
    the integrator's tolerance for it."""
    text = path.read_text()
    line = 'method = "adaptive"\n'
    if text.count(line) != 1 or "_tolerance" in text:
        raise ValueError(f"{path} is not an adaptive study file without tolerances")
    copy = folder / f"{path.stem}-tol{tolerance:g}.toml"
    added = f"method_tolerance = {tolerance!r}\nintegration_tolerance = {tolerance!r}\n"
    copy.write_text(text.replace(line, line + added))
    return copy


def run_file(
    path: Path,
    out: Path,
    arguments: tuple[str, ...] = (),
    log: list[str] | None = None,
    program: tuple[str, ...] = (sys.executable, "-m", "fuzzymbs.cli"),
) -> dict[str, Any]:
    """One ``fuzzymbs run`` of ``path`` (with ``arguments``) in a child process: wall, CPU
    (the child's and its own children's), the study's figures; the child's log lines are
    appended to ``log`` when given. ``program``: what takes the command line's arguments
    (another that does what ``fuzzymbs`` does, e.g. with the method patched)."""
    import xarray

    command = [*program, "run", str(path), "--out", str(out), "--fresh"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = load_average()
    start = time.perf_counter()
    # a wide terminal keeps the log's lines whole (the CLI logs through rich)
    env = {**os.environ, "COLUMNS": "400"}
    done = subprocess.run(command + list(arguments), capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    if log is not None:
        log.extend((done.stdout + done.stderr).splitlines())
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    (result,) = out.rglob("result.nc")
    with xarray.open_dataset(result) as data:
        attrs = dict(data.attrs)
        samples = int(data.sizes.get("sample", -1))  # the plan's runs (a fixed method)
    return {
        "wall_s": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "runs": int(attrs.get("adaptive_runs", samples)),
        "rounds": int(attrs.get("adaptive_rounds", 0)),  # 0: not the adaptive method
        "validation_runs": int(attrs.get("validation_runs", 0)),
        "method_error": float(attrs.get("method_error", float("nan"))),
        "time_integration_error": float(attrs.get("time_integration_error", float("nan"))),
        "time_integration": str(attrs.get("time_integration", "")),
        "load_average": load,
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--studies", type=int, nargs="+", default=[1, 2], choices=[1, 2])
    parser.add_argument("--variants", nargs="+", default=["default"], choices=["default", "rodas4"])
    parser.add_argument(
        "--tolerances", type=float, nargs="*", default=[], help="also the demo at these"
    )
    args = parser.parse_args(argv)
    figures: dict[str, Any] = {"load_average_start": load_average()}
    subprocess.run([sys.executable, "-c", _WARM_UP], check=True)
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        sides: dict[str, Path] = {}
        for study in args.studies:
            sides[f"study{study}_paper"] = FILES[study]["paper"]
            if "default" in args.variants:
                sides[f"study{study}_default"] = FILES[study]["default"]
            if "rodas4" in args.variants:
                sides[f"study{study}_rodas4"] = with_integrator(
                    FILES[study]["default"], "rodas4", root
                )
            for tolerance in args.tolerances:
                sides[f"study{study}_tol{tolerance:g}"] = with_tolerance(
                    FILES[study]["default"], tolerance, root
                )
        runs: dict[str, list[dict]] = {name: [] for name in sides}
        for _ in range(args.rounds):
            for name, path in sides.items():
                runs[name].append(run_file(path, root / name))
    best = {name: min(found, key=lambda r: r["wall_s"]) for name, found in runs.items()}
    figures["runs"] = runs
    figures["best"] = best
    for study in args.studies:
        paper = best[f"study{study}_paper"]
        for variant in [*args.variants, *(f"tol{tol:g}" for tol in args.tolerances)]:
            mine = best[f"study{study}_{variant}"]
            figures[f"study{study}_{variant}_over_paper"] = round(
                mine["wall_s"] / paper["wall_s"], 2
            )
            figures[f"study{study}_{variant}_over_paper_cpu"] = round(
                mine["cpu_s"] / paper["cpu_s"], 2
            )
    figures["load_average_end"] = load_average()
    return figures


if __name__ == "__main__":
    print(json.dumps(main()))
