"""Where the brake kernels spend their time, function by function, under Linux ``perf``.

    perf record -k CLOCK_MONOTONIC -e cpu-clock -o kernels.data \\
        python benchmarks/kernel_profile.py [--path rk4|ros] [--repeats 60]
    perf report -i kernels.data --time T0, --sort sym

Runs one brake block (four samples, one thread) on the chosen path -- RK4 at 1 us for
2,000 steps from rest, or ROS34PW2 at rtol 1e-3 on the first four of study 1's eight
corners over 1 ms -- ``--repeats`` times after a warm-up, and prints ``T0`` (the
monotonic clock where the timed part starts: ``perf report --time T0,`` leaves
compiling out). Numba's code has
no symbols for ``perf``, so the script writes ``/tmp/perf-PID.map`` (the format ``perf``
reads for JIT code) with the address range of every function compiled in this process.
The kernels must be compiled here, not loaded from Numba's cache (loaded code carries
no function table): run it with an empty ``NUMBA_CACHE_DIR``. docs/benchmarks.md
("Where RK4's time goes, function by function") reads such profiles.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time

import numpy as np
from numba.core.codegen import JITCodeLibrary
from ros_flops import corners as study1_corners

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels.rk4 import advance_block, start_block
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance


def write_perf_map() -> int:
    """``/tmp/perf-PID.map``: start, size and name of every compiled function."""
    entries, seen = [], set()
    for library in gc.get_objects():
        # the type, not isinstance: a dead weak proxy among the objects raises on isinstance
        if not issubclass(type(library), JITCodeLibrary):
            continue
        module = getattr(library, "_final_module", None)
        if module is None:
            continue
        for function in module.functions:
            if function.is_declaration or function.name in seen:
                continue
            address = library._codegen._engine.get_function_address(function.name)
            if address:
                seen.add(function.name)
                entries.append((address, function.name))
    entries.sort()
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as out:
        for k, (address, name) in enumerate(entries):
            following = entries[k + 1][0] if k + 1 < len(entries) else address + 4096
            out.write(f"{address:x} {min(following - address, 1 << 20):x} {name}\n")
    return len(entries)


def rk4_workload(steps: int = 2000):
    compiled = DiscBrake(t_end=1e-5, integrator="rk4", dt=1e-6).compiled
    data, n = compiled.data, compiled.n_dofs
    row = compiled.parameters.values({})[0]
    out_w = np.zeros((1, 2 * n))
    out_w[0, 0] = 1.0
    params, x0 = np.tile(row, (LANES, 1)), np.zeros((LANES, 2 * n))
    out = np.empty((LANES, 1, steps // 10 + 1))
    status, fail = np.zeros(LANES, np.int64), np.full(LANES, np.nan)
    recording = (out_w, np.full(1, np.inf), out, status, fail)

    def run() -> None:
        state = start_block(data, params, x0, recording, 0, LANES)
        advance_block(data, (0.0, 1e-6, steps, 10), recording, 0, LANES, state, 0, steps)

    return run


def ros_workload(t_end: float = 1e-3):
    corners = {name: values[:LANES] for name, values in study1_corners().items()}
    compiled = DiscBrake(t_end=t_end, record_interval=1e-5).compiled
    common = {
        "t_end": t_end,
        "dt": 1e-6,  # the first step
        "record_interval": 1e-5,
        "integrator": "ros34pw2",
        "tolerance": Tolerance(1e-3),
        "outputs": {"y": Coordinate("lower_pad", 0)},
    }

    def run() -> None:
        simulate(compiled, corners, **common)

    return run


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--path", choices=("rk4", "ros"), default="rk4")
    parser.add_argument("--repeats", type=int, default=60)
    args = parser.parse_args(argv)
    run = rk4_workload() if args.path == "rk4" else ros_workload()
    run()  # compiles
    print(f"functions {write_perf_map()}", file=sys.stderr)
    # the compiler's objects stay out of the timed part's garbage collections
    gc.collect()
    gc.freeze()
    print(f"T0 {time.monotonic():.6f}", file=sys.stderr)
    cpu = time.process_time()
    for _ in range(args.repeats):
        run()
    print(f"cpu per run {(time.process_time() - cpu) / args.repeats * 1e3:.1f} ms", file=sys.stderr)


if __name__ == "__main__":
    main()
