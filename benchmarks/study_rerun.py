"""A brake study run again: finished, and after losing its last rounds; one JSON line.

    python benchmarks/study_rerun.py [--study 1 | --file STUDY.toml] [--lose 2] [--source DIR]

Runs the demo study file (``fuzzymbs run src/fuzzymbs/demos/brake/0N-studyN.toml
--no-plots --no-report``) as a user does, each time in a child process of its own,
into one output folder: ``fresh`` (``--fresh``), ``finished`` (the same command again:
every run in the store), and ``interrupted`` (the last ``--lose`` adaptive rounds and
the time-integration check's record removed from the store first, as a kill during the
study would leave it). For each: wall and CPU time of the child, the model runs the
study evaluated and took from the store (``result.nc``'s provenance), and whether its
result's data and attributes are those of the fresh run (bit for bit, the provenance
aside). ``--source DIR`` runs another checkout's ``src`` (on ``PYTHONPATH``), e.g. the
code before the judging runs were kept (docs/benchmarks.md, "The runs that judge a brake
study"). Its kernels should be compiled beforehand (a first run of that checkout).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr
from bench_common import REPO, load_average

STUDY_FILES = {1: "01-study1.toml", 2: "02-study2.toml"}


def _run(study: Path, out: Path, source: Path, fresh: bool) -> dict:
    """One ``fuzzymbs run`` in a child process: wall and CPU time [s]."""
    command = [sys.executable, "-m", "fuzzymbs.cli", "run", str(study), "--out", str(out)]
    command += ["--no-plots", "--no-report", "-q"] + (["--fresh"] if fresh else [])
    environment = dict(os.environ, PYTHONPATH=str(source))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, env=environment, capture_output=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2)}


def _outcome(result: Path, fresh: xr.Dataset | None) -> dict:
    """Runs evaluated and reused, and whether the result equals the fresh run's."""
    with xr.open_dataset(result) as dataset:
        dataset.load()
    provenance = json.loads(dataset.attrs["provenance"])
    figures = {"evaluated": provenance["evaluated"], "reused": provenance["reused_from_store"]}
    if fresh is not None:
        same_data = set(fresh.data_vars) == set(dataset.data_vars) and all(
            fresh[name].equals(dataset[name]) for name in fresh.data_vars
        )
        same_attrs = all(
            str(dataset.attrs.get(key)) == str(value)
            for key, value in fresh.attrs.items()
            if key != "provenance"
        )
        figures["same_as_fresh"] = bool(same_data and same_attrs)
    return figures


def rerun(study: Path, source: Path, lose: int) -> dict:
    """The three runs of ``study`` (a study file of the adaptive method) into one folder."""
    figures: dict = {"study": str(study), "source": str(source)}
    folder = Path(tempfile.mkdtemp(prefix="fuzzymbs-rerun-"))
    out = folder / "out"
    try:
        figures["fresh"] = _run(study, out, source, fresh=True)
        with xr.open_dataset(out / "result.nc") as dataset:
            fresh = dataset.load()
        figures["fresh"].update(_outcome(out / "result.nc", None))
        figures["finished"] = _run(study, out, source, fresh=False)
        figures["finished"].update(_outcome(out / "result.nc", fresh))
        rounds = sorted((out / "chunks").glob("adaptive-*"))
        figures["rounds"], figures["lost"] = len(rounds), min(lose, len(rounds))
        for lost in rounds[len(rounds) - figures["lost"] :]:
            shutil.rmtree(lost)
        for record in (out / "chunks" / "judging").glob("integration-check-*"):
            record.unlink()
        figures["interrupted"] = _run(study, out, source, fresh=False)
        figures["interrupted"].update(_outcome(out / "result.nc", fresh))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return figures


def main() -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=int, choices=sorted(STUDY_FILES), default=1)
    parser.add_argument("--file", type=Path, help="another study file (adaptive method)")
    parser.add_argument("--lose", type=int, default=2, help="adaptive rounds lost")
    parser.add_argument("--source", type=Path, default=REPO / "src")
    args = parser.parse_args()
    study = args.file or REPO / "src" / "fuzzymbs" / "demos" / "brake" / STUDY_FILES[args.study]
    start = load_average()
    figures = rerun(study.resolve(), args.source.resolve(), args.lose)
    figures["load_average_start"], figures["load_average_end"] = start, load_average()
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
