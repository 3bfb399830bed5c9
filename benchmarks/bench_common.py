"""Shared helpers of the benchmark scripts: timing, machine description, subprocesses.

Every figure a benchmark reports is a wall-clock time measured in this process
(after a warm-up call, so Numba compilation is excluded unless the figure is a
compile time) or a ratio of two such times measured in the same run.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

BENCH_DIR = Path(__file__).resolve().parent
REPO = BENCH_DIR.parent


def best_time(func: Callable[[], Any], repeat: int = 3, min_time: float = 0.0) -> float:
    """Smallest wall time [s] of ``repeat`` calls (at least one; more while under ``min_time``).

    The minimum is the figure least disturbed by other processes on the machine.
    """
    best = float("inf")
    total = 0.0
    count = 0
    while count < repeat or total < min_time:
        start = time.perf_counter()
        func()
        elapsed = time.perf_counter() - start
        best = min(best, elapsed)
        total += elapsed
        count += 1
        if count >= 50:
            break
    return best


def load_average() -> list[float]:
    """1, 5 and 15 minute load averages (other work on the machine skews every timing)."""
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:  # pragma: no cover - not on every platform
        return []


def _lscpu() -> dict[str, str]:
    try:
        text = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return {}
    keep = ("Model name", "CPU(s)", "Thread(s) per core", "L2 cache", "L3 cache", "Flags")
    info = {}
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() in keep:
            value = value.strip()
            if key.strip() == "Flags":  # only the vector extensions matter here
                wanted = ("avx", "avx2", "fma", "avx512f")
                value = " ".join(f for f in value.split() if f in wanted)
            info[key.strip()] = value
    return info


def _source_state() -> str:
    """Commit of the measured tree, '+dirty' when src/ has uncommitted changes."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", "src"], cwd=REPO, capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        return "unknown"
    return (head or "unknown") + ("+dirty" if dirty else "")


def machine() -> dict[str, Any]:
    """CPU, core count and the versions of everything the timings depend on."""
    import numba
    import numpy
    import scipy

    versions = {
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
    }
    for name in ("dask", "distributed", "exudyn"):
        try:
            module = __import__(name)
            versions[name] = getattr(module, "__version__", "?")
        except ImportError:
            versions[name] = None
    blas = "?"
    try:
        config = numpy.show_config(mode="dicts")
        blas_info = config["Build Dependencies"]["blas"]
        blas = f"{blas_info.get('name', '?')} {blas_info.get('version', '')}".strip()
    except Exception:  # layout differs between NumPy versions; the name is informative only
        pass
    return {
        "source": _source_state(),
        "platform": platform.platform(),
        "cpu": _lscpu(),
        "cpu_count": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
        "blas": blas,
        "versions": versions,
        "load_average_at_start": load_average(),
    }


def run_json_subprocess(
    code: str, env: dict[str, str] | None = None, timeout: float = 600.0
) -> dict[str, Any]:
    """Run Python ``code`` in a fresh interpreter; its last stdout line is a JSON object.

    The child sees ``src`` and ``benchmarks`` on its path, and ``env`` on top of
    this process's environment.
    """
    child_env = dict(os.environ)
    paths = [str(REPO / "src"), str(BENCH_DIR), child_env.get("PYTHONPATH", "")]
    child_env["PYTHONPATH"] = os.pathsep.join(p for p in paths if p)
    child_env.update(env or {})
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=child_env,
        timeout=timeout,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(
            f"benchmark subprocess failed ({done.returncode}):\n{done.stderr[-3000:]}"
        )
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    return json.loads(lines[-1])


def log(message: str) -> None:
    """Progress line on stderr (stdout's last line is reserved for the JSON)."""
    print(message, file=sys.stderr, flush=True)


def run_in_checkout(
    code: str, checkout: Path, env: dict[str, str] | None = None, timeout: float = 7200.0
) -> Any:
    """:func:`run_json_subprocess` with another checkout's ``src`` as the package (to
    measure two versions of fuzzymbs in the same run)."""
    paths = {"PYTHONPATH": str(Path(checkout) / "src"), **(env or {})}
    return run_json_subprocess(code, env=paths, timeout=timeout)


# ---- one brake sample through simulate (ros_accuracy.py, rodas_work_precision.py) ------
#: the brake's outputs compared: the pads' normal displacements (the accuracy criterion,
#: the first BRAKE_PADS rows) and the caliper's (reported apart)
BRAKE_OUTPUT_BODIES = ("lower_pad", "upper_pad", "caliper")
BRAKE_OUTPUT_NAMES = ("y_lpad", "y_upad", "y_cali")
BRAKE_PADS = 2
BRAKE_RECORD = 1e-5  # s
#: the nominal brake and the corner sample (k -10 %, k_c +10 %, F_n +1 %)
BRAKE_SAMPLES: dict[str, dict[str, float]] = {
    "nominal": {},
    "corner": {
        "pad_spring_stiffness": 180e3,
        "caliper_spring_stiffness": 1.1e3,
        "nodal_force": 16.16e3,
    },
}


def brake_outputs() -> dict[str, Any]:
    """BRAKE_OUTPUT_NAMES: the normal displacement of each of BRAKE_OUTPUT_BODIES."""
    from fuzzymbs.mbs.system import Coordinate

    return {
        name: Coordinate(body, 0)
        for name, body in zip(BRAKE_OUTPUT_NAMES, BRAKE_OUTPUT_BODIES, strict=True)
    }


def brake_run(
    compiled: Any,
    sample: dict[str, float],
    t_end: float,
    clock: Callable[[], float] = time.perf_counter,
    **options: Any,
) -> tuple[Any, float, Any]:
    """One sample of the brake alone in its block (kernel "samples"), recorded every
    BRAKE_RECORD: outputs (3, T) in BRAKE_OUTPUT_NAMES' order, the ``clock`` seconds of
    the :func:`fuzzymbs.mbs.integrate.simulate` call and its result; ``options`` go to
    ``simulate`` (dt, integrator, tolerance)."""
    import numpy as np

    from fuzzymbs.mbs.integrate import simulate

    outputs = brake_outputs()
    values = {name: np.array([value]) for name, value in sample.items()}
    start = clock()
    result = simulate(
        compiled,
        values,
        t_end=t_end,
        record_interval=BRAKE_RECORD,
        outputs=outputs,
        kernel="samples",
        **options,
    )
    seconds = clock() - start
    if result.failed.any():
        raise RuntimeError(f"{options} failed on {sample}")
    return np.array([result.outputs[name][0] for name in outputs]), seconds, result


def brake_errors(y: Any, reference: Any) -> dict[str, float]:
    """The largest deviation over time from ``reference``, relative to its peak: of the
    pads (the larger of the two, ``error``) and of the caliper (``error_y_cali``)."""
    from fuzzymbs.study.integration_check import peak_relative_deviation

    pads = range(BRAKE_PADS)
    return {
        "error": max(peak_relative_deviation(y[i], reference[i]) for i in pads),
        "error_y_cali": peak_relative_deviation(y[BRAKE_PADS], reference[BRAKE_PADS]),
    }
