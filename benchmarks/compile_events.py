"""What Numba compiles while some tests run, from its compile events; one JSON line.

    python benchmarks/compile_events.py [NODE_ID ...] [--cache DIR] [--top 15]

Runs pytest on the node ids (default: the multibody engine's ``KERNELS_FIRST`` group of
tests/conftest.py, the tests that first call the right-hand side, the Jacobian, RK4 and
the Rosenbrock kernels) in one child process (``-n0``) with ``NUMBA_CACHE_DIR`` an empty
temporary directory (or ``--cache``), so that every kernel they touch is compiled, and
this module loaded as a pytest plugin that listens to Numba's ``numba:compile`` events.
Reports the number of compilations, their CPU-side seconds (wall time of the outermost
compilations: nested ones, a callee compiled for its caller, are inside their caller's),
each fuzzymbs function's compilations and self time (its own time less its callees'),
and the functions compiled more than once with their signatures: docs/contributing.md,
"Which process compiles what", is measured with it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from bench_common import BENCH_DIR, REPO, load_average

_RECORDS = "FUZZYMBS_COMPILE_EVENTS_OUT"


# ---- the plugin side (in the pytest child, loaded with -p compile_events) ----------------
def _install() -> None:
    import atexit

    import numba.core.event as event

    stack: list[list] = []
    records: list[dict] = []

    class Listener(event.Listener):
        def on_start(self, ev):
            function = ev.data["dispatcher"].py_func
            name = f"{function.__module__}.{function.__qualname__}"
            stack.append([name, str(ev.data["args"])[:300], time.perf_counter(), 0.0])

        def on_end(self, ev):
            name, args, start, children = stack.pop()
            took = time.perf_counter() - start
            if stack:
                stack[-1][3] += took
            records.append(
                {"name": name, "args": args, "seconds": took, "self": took - children,
                 "outermost": not stack}
            )  # fmt: skip

    event.register("numba:compile", Listener())
    atexit.register(lambda: Path(os.environ[_RECORDS]).write_text(json.dumps(records)))


if os.environ.get(_RECORDS):  # imported by pytest as a plugin in the child
    _install()


# ---- the runner ---------------------------------------------------------------------------
def _engine_group() -> list[str]:
    sys.path.insert(0, str(REPO / "tests"))
    from conftest import KERNELS_FIRST

    return list(KERNELS_FIRST[1])


def summarise(records: list[dict], top: int) -> dict:
    """Counts, seconds, the costliest fuzzymbs functions and those compiled twice."""
    per_function: dict[str, dict] = defaultdict(lambda: {"count": 0, "self_s": 0.0, "args": []})
    for record in records:
        if not record["name"].startswith("fuzzymbs."):
            continue
        entry = per_function[record["name"]]
        entry["count"] += 1
        entry["self_s"] += record["self"]
        entry["args"].append(record["args"])
    ranked = sorted(per_function.items(), key=lambda item: -item[1]["self_s"])
    return {
        "compilations": len(records),
        "seconds": round(sum(r["seconds"] for r in records if r["outermost"]), 1),
        "fuzzymbs_compilations": sum(entry["count"] for entry in per_function.values()),
        "top": [
            {"function": name, "count": entry["count"], "self_s": round(entry["self_s"], 2)}
            for name, entry in ranked[:top]
        ],
        # functions generated per overload (``<locals>``) share a name: not one compiled twice
        "compiled_more_than_once": {
            name: entry["args"]
            for name, entry in ranked
            if entry["count"] > 1 and "<locals>" not in name
        },
    }


def run(node_ids: list[str], cache: str | None, top: int) -> dict:
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "records.json"
        env = dict(os.environ, NUMBA_CACHE_DIR=cache or str(Path(scratch) / "cache"))
        env[_RECORDS] = str(out)
        env["PYTHONPATH"] = os.pathsep.join(
            [str(BENCH_DIR), str(REPO / "src"), env.get("PYTHONPATH", "")]
        )
        start = time.perf_counter()
        done = subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-n0", "-p", "compile_events",
             "-p", "no:cacheprovider", "-m", "slow or not slow", *node_ids],
            cwd=REPO, env=env, capture_output=True, text=True,
        )  # fmt: skip
        wall = time.perf_counter() - start
        if done.returncode != 0:
            raise SystemExit(f"pytest failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
        records = json.loads(out.read_text())
    return {
        "tests": node_ids,
        "wall_s": round(wall, 1),
        "load_average": load_average(),
        **summarise(records, top),
    }


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("node_ids", nargs="*", help="pytest node ids (default: engine group)")
    parser.add_argument("--cache", default=None, help="NUMBA_CACHE_DIR (default: empty)")
    parser.add_argument("--top", type=int, default=15, help="costliest functions listed")
    args = parser.parse_args(argv)
    result = run(args.node_ids or _engine_group(), args.cache, args.top)
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
