"""What RK4's brake step costs against its four right-hand sides; prints one JSON line.

    python benchmarks/rk4_parts.py [--steps 2000] [--repeats 5]

Warm kernels, the nominal brake from rest (every lane the same sample), dt = 1 us:

* ``advance_ms``: one block (``LANES`` samples) advanced ``--steps`` steps by
  :func:`fuzzymbs.mbs.kernels.rk4.advance_block` on the calling thread;
  ``four_rhs_ms``: ``4 x --steps`` right-hand sides of the same block at its state
  halfway through, in a compiled loop; their ratio is what a step adds to its stages.
* ``rk4_ms``: :func:`fuzzymbs.mbs.kernels.rk4.rk4` on 1, 2 and 4 blocks (the blocks over
  the Numba threads), so that one thread's rate can be set against two threads'.

The smallest wall time of ``--repeats`` counts. docs/benchmarks.md ("Flop share of the
Rosenbrock path and the sensitivities") reads these beside benchmarks/ros_flops.py.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from bench_common import best_time, load_average
from ros_parts import rhs_calls

from fuzzymbs.mbs.kernels.rk4 import advance_block, rk4, start_block
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.models.brake import DiscBrake


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    steps = args.steps
    compiled = DiscBrake(t_end=1e-5, integrator="rk4", dt=1e-6).compiled
    data, n = compiled.data, compiled.n_dofs
    row = compiled.parameters.values({})[0]
    out_w = np.zeros((1, 2 * n))
    out_w[0, 0] = 1.0
    bounds = np.full(1, np.inf)
    timing = (0.0, 1e-6, steps, 10)

    def batch(count: int) -> tuple:
        params, x0 = np.tile(row, (count, 1)), np.zeros((count, 2 * n))
        out = np.empty((count, 1, steps // 10 + 1))
        return params, x0, (out, np.zeros(count, np.int64), np.full(count, np.nan))

    params, x0, (out, status, fail) = batch(LANES)
    recording = (out_w, bounds, out, status, fail)

    def advance() -> None:
        state = start_block(data, params, x0, recording, 0, LANES)
        advance_block(data, timing, recording, 0, LANES, state, 0, steps)

    advance()  # compiles
    middle = start_block(data, params, x0, recording, 0, LANES)
    advance_block(data, timing, recording, 0, LANES, middle, 0, steps // 2)
    x, p, _, stages, work = middle
    rhs_calls(1, x, stages[0], p, data, work)  # compiles

    def four_rhs() -> None:
        rhs_calls(4 * steps, x, stages[0], p, data, work)

    figures: dict = {"load_average_start": load_average(), "steps": steps, "lanes": LANES}
    figures["advance_ms"] = 1e3 * best_time(advance, args.repeats)
    figures["four_rhs_ms"] = 1e3 * best_time(four_rhs, args.repeats)
    figures["advance_over_four_rhs"] = figures["advance_ms"] / figures["four_rhs_ms"]
    figures["rk4_ms"] = {}
    for blocks in (1, 2, 4):
        params_b, x0_b, (out_b, status_b, fail_b) = batch(blocks * LANES)
        recording_b = (out_w, bounds, out_b, status_b, fail_b)

        def call(p=params_b, x=x0_b, r=recording_b) -> None:
            rk4(data, p, x, timing, r, LANES)

        call()
        figures["rk4_ms"][f"{blocks} blocks"] = 1e3 * best_time(call, args.repeats)
    figures["load_average_end"] = load_average()
    return figures


if __name__ == "__main__":
    print(json.dumps(main()))
