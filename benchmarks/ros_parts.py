"""What one ROS34PW2 step of a brake block costs, part by part; prints one JSON line.

    python benchmarks/ros_parts.py

The calling thread, one block of ``LANES`` lanes (the nominal brake in its loaded steady
state, small random velocities), warm kernels. Per call, in milliseconds: a
right-hand side (``rhs_ms``; a step takes four), the Jacobian (``jacobian_ms``;
a step takes a tenth of one), the lanes' LU of the 41 x 41 stage matrix
(``lu_ms``, one per step) and one solve (``solve_ms``, four per step). The
figures behind docs/theory.md's and docs/benchmarks.md's split of a step.
"""

from __future__ import annotations

import json
import time

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels.jacobian import jacobian
from fuzzymbs.mbs.kernels.linalg import lu_factor_lanes, lu_solve_lanes
from fuzzymbs.mbs.kernels.rhs import make_work, rhs, set_lane
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.mbs.linearize import steady_state
from fuzzymbs.models.brake import DiscBrake

L = LANES


@nb.njit
def rhs_calls(count, x, dx, p, data, work):
    t = np.full(L, 1e-4)  # a time per lane, as the package's integrators pass it
    for _ in range(count):
        rhs(t, x, dx, p, data, work)


@nb.njit
def _jacobian_calls(count, x, dx, p, data, work, jq, jv):
    t = np.full(L, 1e-4)
    for _ in range(count):
        jacobian(t, x, p, data, work, dx, jq, jv)


@nb.njit
def _lu_calls(count, jq, jv, n, mat, piv):
    for _ in range(count):
        for e in range(n * n * L):
            mat[e] = -jv[e] - 1e-7 * jq[e]
        for i in range(n):
            for lane in range(L):
                mat[L * (n * i + i) + lane] += 1e7
        lu_factor_lanes(mat, n, piv)


@nb.njit
def _solve_calls(count, n, mat, piv, b):
    for _ in range(count):
        lu_solve_lanes(mat, n, piv, b)


def parts(repeats: int = 1) -> dict[str, float]:
    """Milliseconds per call of each part (``repeats`` scales the loop counts)."""
    compiled = DiscBrake(t_end=1e-4).compiled
    n = compiled.n_dofs
    state = np.concatenate([steady_state(compiled, {}).x[0], np.zeros(n)])
    state[n:] += 1e-3 * np.random.default_rng(0).normal(size=n)
    row = compiled.parameters.values({})[0]
    x, p = np.empty(2 * n * L), np.empty(row.size * L)
    for lane in range(L):
        set_lane(x, lane, state)
        set_lane(p, lane, row)
    work, dx = make_work(compiled.data), np.empty_like(x)
    jq, jv = np.empty(n * n * L), np.empty(n * n * L)
    mat, piv, b = np.empty(n * n * L), np.empty(n * L, np.int64), np.ones(n * L)
    calls = {
        "rhs_ms": (rhs_calls, (x, dx, p, compiled.data, work), 2000),
        "jacobian_ms": (_jacobian_calls, (x, dx, p, compiled.data, work, jq, jv), 300),
        "lu_ms": (_lu_calls, (jq, jv, n, mat, piv), 3000),
        "solve_ms": (_solve_calls, (n, mat, piv, b), 10000),
    }
    figures = {}
    for key, (function, args, count) in calls.items():
        function(1, *args)  # compile
        count = max(1, round(count * repeats))
        start = time.perf_counter()
        function(count, *args)  # a plain loop on this thread: no thread pool involved
        figures[key] = round((time.perf_counter() - start) / count * 1e3, 4)
    return figures


if __name__ == "__main__":
    print(json.dumps(parts()))
