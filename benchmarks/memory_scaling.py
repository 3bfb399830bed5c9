"""Peak memory of a study against its run count (constant in the number of runs).

Each case runs in a fresh interpreter (``python memory_scaling.py --case LEVELS KEEP_RAW``)
and reports its peak resident set size (``ru_maxrss``) after the study, and the same
interpreter's peak after imports and a warm-up study of 27 runs (the baseline
of the same run: what Python, NumPy, xarray and the model cost before the study).
The study: the registered ``damped-oscillator`` (2001-point displacement signal) on the
full alpha-bound grid with three triangular parameters, levels m: (2m + 1)^3 runs --
11^3 = 1,331 (m = 5) and 25^3 = 15,625 (m = 12) (258 MB and 1.36 GB peak for a
retransformation that keeps every raw output). ``keep_raw=True`` puts every
sample's outputs into the result again (for comparison). Every study makes its
default method check (a fifth of its runs as validation runs, in four rounds).
``--cli``: instead, ``fuzzymbs run`` of the same two studies as study files, each
in a child process, peak resident set size of the child (the target: the large
study within 1.25 times the small one, end to end).

Usage::

    python benchmarks/memory_scaling.py [--quick] [--json] [--cli]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PARAMETERS = {
    "mass": {"type": "triangular", "modal": 1.0, "spread": 0.05},
    "stiffness": {"type": "triangular", "modal": 1000.0, "spread": 0.1},
    "damping": {"type": "triangular", "modal": 3.0, "spread": 0.2},
}


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def run_case(levels: int, keep_raw: bool) -> dict:
    """In this interpreter: warm up, then one study; peaks before and after [MB]."""
    import warnings

    from fuzzymbs import Study

    def study(m: int) -> Study:
        return Study(
            "damped-oscillator",
            PARAMETERS,
            "grid",
            m,
            model_options={"time_steps": 2001},
        )

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        study(1).run(progress=False)  # 27 runs: imports, first-call set-up
        baseline = _peak_mb()
        case = study(levels)
        started = time.perf_counter()
        result = case.run(progress=False, keep_raw=keep_raw, chunk_size=256)
        wall = time.perf_counter() - started
    return {
        "levels": levels,
        "runs": len(case.plan),
        "keep_raw": keep_raw,
        "raw_outputs_mb": len(case.plan) * 2001 * 8 / 1e6,
        "baseline_peak_mb": round(baseline, 1),
        "peak_mb": round(_peak_mb(), 1),
        "wall_s": round(wall, 2),
        "result_has_samples": "displacement_samples" in result.dataset,
    }


STUDY_FILE = """[study]
name = "memory-{levels}"
method = "grid"
levels = {levels}

[model]
name = "damped-oscillator"
[model.options]
time_steps = 2001

[parameters]
mass = {{ type = "triangular", modal = 1.0, spread = 0.05 }}
stiffness = {{ type = "triangular", modal = 1000.0, spread = 0.1 }}
damping = {{ type = "triangular", modal = 3.0, spread = 0.2 }}
"""


def measure_cli(levels: int) -> dict:
    """``fuzzymbs run`` of the study with its default method check (validation runs on),
    in a child process: its peak resident set size [MB] and wall time."""
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "study.toml"
        path.write_text(STUDY_FILE.format(levels=levels))
        command = [sys.executable, "-m", "fuzzymbs.cli", "run", str(path), "--out"]
        command += [str(Path(folder) / "out"), "--no-plots", "--no-report"]
        started = time.perf_counter()
        subprocess.run(command, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - started
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
        import xarray

        with xarray.open_dataset(Path(folder) / "out" / "result.nc") as result:
            validation = int(result.attrs.get("validation_runs", 0))
    return {
        "levels": levels,
        "runs": (2 * levels + 1) ** 3,
        "validation_runs": validation,
        "peak_mb": round(peak, 1),
        "wall_s": round(wall, 2),
    }


def measure(levels: int, keep_raw: bool) -> dict:
    """One case in a fresh interpreter."""
    out = subprocess.run(
        [sys.executable, str(Path(__file__)), "--case", str(levels), str(int(keep_raw))],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _fresh_cli(levels: int) -> dict:
    """:func:`measure_cli` from a fresh parent (RUSAGE_CHILDREN holds the largest child)."""
    out = subprocess.run(
        [sys.executable, str(Path(__file__)), "--cli-case", str(levels)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", nargs=2, type=int, metavar=("LEVELS", "KEEP_RAW"))
    parser.add_argument("--quick", action="store_true", help="m = 3 and 6 (343, 2197 runs)")
    parser.add_argument("--json", action="store_true")
    parser.add_argument(
        "--cli", action="store_true", help="only `fuzzymbs run` with the default checks"
    )
    parser.add_argument("--cli-case", type=int, metavar="LEVELS")
    args = parser.parse_args(argv)
    if args.case:
        print(json.dumps(run_case(args.case[0], bool(args.case[1]))))
        return 0
    if args.cli_case:
        print(json.dumps(measure_cli(args.cli_case)))
        return 0
    if args.cli:
        small, large = (3, 6) if args.quick else (5, 12)
        rows = [_fresh_cli(small), _fresh_cli(large)]
        print(
            json.dumps(
                {
                    "cli_rows": rows,
                    "cli_peak_ratio": round(rows[1]["peak_mb"] / rows[0]["peak_mb"], 3),
                }
            )
        )
        return 0
    small, large = (3, 6) if args.quick else (5, 12)
    rows = [measure(small, False), measure(large, False), measure(small, True)]
    if not args.quick:
        rows.append(measure(large, True))
    figures = {
        "rows": rows,
        # the target: the large case within 1.25 times the small one (streaming)
        "peak_ratio_large_to_small": round(rows[1]["peak_mb"] / rows[0]["peak_mb"], 3),
        "study_memory_ratio_large_to_small": round(
            (rows[1]["peak_mb"] - rows[1]["baseline_peak_mb"])
            / max(rows[0]["peak_mb"] - rows[0]["baseline_peak_mb"], 1.0),
            3,
        ),
    }
    if args.json:
        print(json.dumps(figures))
    else:
        for row in rows:
            print(
                f"{row['runs']:>6} runs keep_raw={row['keep_raw']!s:<5} raw "
                f"{row['raw_outputs_mb']:7.1f} MB  baseline {row['baseline_peak_mb']:6.1f} MB  "
                f"peak {row['peak_mb']:7.1f} MB  {row['wall_s']:6.2f} s"
            )
        print(json.dumps({k: v for k, v in figures.items() if k != "rows"}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
