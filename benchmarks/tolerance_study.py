"""The 117,649-run gear tolerance study: inline and on a local Dask cluster.

Runs ``examples/gear_tolerances_117649.toml`` (full grid, levels 3 over six
parameters) in a fresh interpreter per executor -- inline (Numba's default
threads) and a ``LocalCluster`` of 2 single-thread worker processes -- and
reports the study's wall time, the interpreter's peak resident set size (the
client's, on Dask), and whether the Dask result equals the inline one bit for bit
(bounds, gain factors, raw outputs). ``--quick``: levels = 1 (3^6 = 729 runs).

Usage::

    python benchmarks/tolerance_study.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

STUDY = Path(__file__).resolve().parents[1] / "examples" / "gear_tolerances_117649.toml"
COMPARED = ("ste_lower", "ste_upper", "ste_gain", "ste_samples")


def run_case(executor: str, levels: int | None, out: str) -> dict:
    """In this interpreter: one run of the study file; wall time and peak RSS."""
    from fuzzymbs.study.pipeline import run_study_file
    from fuzzymbs.study.studyfile import load_study_file

    client = cluster = None
    spec: object = None
    if executor == "dask":
        from distributed import Client, LocalCluster

        cluster = LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = Client(cluster)
        client.run(lambda: __import__("fuzzymbs.models.gears"))  # imports before timing
        spec = client
    path = STUDY
    if levels is not None:  # the quick variant: the same file with fewer levels
        text = STUDY.read_text().replace("levels = 3", f"levels = {levels}")
        path = Path(out) / "study.toml"
        path.write_text(text)
    runs = len(load_study_file(path).study.plan)
    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        written = run_study_file(
            path, Path(out) / "result", executor=spec, progress=False, plots=False, resume=False
        )
    wall = time.perf_counter() - started
    if client is not None:
        client.close()
        cluster.close()
    return {
        "executor": executor,
        "runs": runs,
        "wall_s": round(wall, 2),
        "peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
        "result": str(written.result_path),
        "failed": int(written.result.dataset["sample_failed"].sum()),
    }


def measure(executor: str, levels: int | None, out: Path) -> dict:
    """One case in a fresh interpreter."""
    command = [sys.executable, __file__, "--case", executor, str(out)]
    if levels is not None:
        command += ["--levels", str(levels)]
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def identical(first: str, second: str) -> bool:
    import numpy as np
    import xarray

    with xarray.open_dataset(first) as a, xarray.open_dataset(second) as b:
        return all(
            np.array_equal(a[name].values, b[name].values, equal_nan=True)
            for name in COMPARED
            if name in a
        )


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", nargs=2, metavar=("EXECUTOR", "OUT"))
    parser.add_argument("--levels", type=int)
    parser.add_argument("--quick", action="store_true", help="levels = 1: 729 runs")
    args = parser.parse_args(argv)
    if args.case:
        print(json.dumps(run_case(args.case[0], args.levels, args.case[1])))
        return {}
    levels = 1 if args.quick else None
    with tempfile.TemporaryDirectory() as scratch:
        rows = []
        for executor in ("inline", "dask"):
            folder = Path(scratch) / executor
            folder.mkdir()
            rows.append(measure(executor, levels, folder))
        figures = {
            "rows": [{k: v for k, v in row.items() if k != "result"} for row in rows],
            "dask_identical_to_inline": identical(rows[0]["result"], rows[1]["result"]),
        }
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    main()
