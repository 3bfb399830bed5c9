"""Compile (cold) and cached start-up times, and peak memory, each in a fresh interpreter.

Cold: ``NUMBA_CACHE_DIR`` points at an empty temporary directory, so every
kernel the run touches is compiled. Cached: a second interpreter with the same,
now filled, directory loads them. The finite-element bodies come from the
fuzzymbs FE disk cache in both cases (that cache is not Numba's; its build time
is reported by the brake helper's docs). Peak memory is the child's maximum
resident set size (``resource.getrusage``) after the work, and the peak of
Python-level allocations (``tracemalloc``) during one brake study.
"""

from __future__ import annotations

import tempfile
from typing import Any

from bench_common import run_json_subprocess

_CHILD = """
import json, resource, time, warnings
import numpy as np
figures = {{}}
start = time.perf_counter()
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.models.gears import gear_pair_model
figures["import_seconds"] = time.perf_counter() - start
# the model source digest a study's store records, at a fresh process's first study
from fuzzymbs.study.code_version import source_digest
start = time.perf_counter()
source_digest(["fuzzymbs.models.brake.model"])
figures["brake_source_digest_seconds"] = time.perf_counter() - start

start = time.perf_counter()
gear = gear_pair_model(positions=10)
figures["gear_build_seconds"] = time.perf_counter() - start
start = time.perf_counter()
gear({{"tooth_stiffness": np.array([14732.9])}})
figures["gear_first_call_seconds"] = time.perf_counter() - start
start = time.perf_counter()
gear({{"tooth_stiffness": np.array([14732.9])}})
figures["gear_second_call_seconds"] = time.perf_counter() - start

if {brake}:
    start = time.perf_counter()
    brake = DiscBrake(t_end=2e-5)
    figures["brake_build_seconds"] = time.perf_counter() - start
    start = time.perf_counter()
    brake({{"nodal_force": np.array([16e3])}})
    figures["brake_first_call_seconds"] = time.perf_counter() - start
    start = time.perf_counter()
    brake({{"nodal_force": np.array([16e3])}})
    figures["brake_second_call_seconds"] = time.perf_counter() - start

if {memory}:
    import tracemalloc
    from brake_bench import brake_study
    from gear_bench import gear_study
    from fuzzymbs.fuzzy import NonMonotonicWarning
    warnings.simplefilter("ignore", NonMonotonicWarning)
    study = brake_study({end})
    study.run(progress=False)
    tracemalloc.start()
    study.run(progress=False)
    figures["brake_study_python_peak_mb"] = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    gear_study().run(progress=False)
    figures["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(figures))
"""


def startup(quick: bool = False) -> dict[str, Any]:
    """Cold-compile and cached start-up figures, and peak memory (see module docstring).

    Quick mode skips the cold compile (it alone takes 30 s to minutes on 2 cores)
    and times the start-up from the default Numba cache that the rest of the
    benchmark run has filled.
    """
    end = 5e-4 if quick else 1e-2
    with tempfile.TemporaryDirectory(prefix="fuzzymbs-numba-") as cache:
        env = {"NUMBA_CACHE_DIR": cache}
        cold = None
        if not quick:
            cold = run_json_subprocess(
                _CHILD.format(brake=True, memory=False, end=end), env=env, timeout=3600
            )
        # quick: every kernel comes from the default cache the benchmark run has filled
        cached = run_json_subprocess(
            _CHILD.format(brake=True, memory=True, end=end),
            env={} if quick else env,
            timeout=1800,
        )
    return {"cold": cold, "cached": cached, "memory_study_end_time_s": end}


if __name__ == "__main__":
    import json

    print(json.dumps(startup(quick=True)))
