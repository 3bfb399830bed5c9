"""The machine's attainable float64 rate: NumPy matmul of large matrices, 1 and 2 threads.

A dense matrix product of n x n matrices costs 2 n^3 floating-point operations
and runs close to the CPU's fused-multiply-add peak, so it is the practical
upper bound ("flop bound") any float64 kernel on this machine can reach. The
BLAS thread count is fixed before NumPy loads, so each measurement runs in its
own interpreter with ``OPENBLAS_NUM_THREADS`` (and OMP/MKL) set.
"""

from __future__ import annotations

from typing import Any

from bench_common import run_json_subprocess

_CHILD = """
import json, time
import numpy as np
n = {size}
rng = np.random.default_rng(0)
a = rng.standard_normal((n, n))
b = rng.standard_normal((n, n))
c = a @ b  # warm-up (thread pool start, page faults)
best = float("inf")
for _ in range({repeat}):
    start = time.perf_counter()
    np.matmul(a, b, out=c)
    best = min(best, time.perf_counter() - start)
print(json.dumps({{"seconds": best, "gflops": 2.0 * n**3 / best / 1e9}}))
"""


def matmul_gflops(threads: int, size: int = 2000, repeat: int = 5) -> dict[str, Any]:
    """Best-of-``repeat`` float64 matmul rate [GFLOP/s] with ``threads`` BLAS threads.

    Parameters
    ----------
    threads : int
        BLAS threads (set through the environment of a fresh interpreter).
    size : int
        Matrix order n (2000: 16 GFLOP per product, ~0.5 s at 30 GFLOP/s).
    repeat : int
        Products timed; the fastest counts.
    """
    env = {name: str(threads) for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    env["MKL_NUM_THREADS"] = str(threads)
    result = run_json_subprocess(_CHILD.format(size=size, repeat=repeat), env=env)
    return {"threads": threads, "size": size, **result}


if __name__ == "__main__":
    import json

    print(json.dumps([matmul_gflops(1), matmul_gflops(2)]))
