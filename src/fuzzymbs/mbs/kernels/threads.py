"""Blocks of samples over threads: a thread pool calling kernels that release the GIL.

The kernels' parallel loops used to be Numba ``prange`` loops. Compiling such
a loop (the parfor pass and its generated function) took 7 s of the brake's
20 s cold start for a loop whose body is one call; a block integrates
thousands of steps, so the cost of starting it from Python is negligible.
Kernels called here are compiled with ``nogil=True`` and write disjoint parts
of their output arrays, so any order of the blocks gives the same results.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numba


def for_each_range(n_items: int, run: Callable[[int, int], None], tasks: int | None = None) -> None:
    """Call ``run(start, stop)`` on contiguous ranges that cover ``range(n_items)``.

    ``tasks`` ranges (default: one per item) are handed out to
    ``numba.get_num_threads()`` threads as they become free, so that long items
    balance themselves; with one thread or one range everything runs here.
    """
    threads = min(numba.get_num_threads(), n_items)
    tasks = n_items if tasks is None else max(1, min(tasks, n_items))
    bounds = [n_items * k // tasks for k in range(tasks + 1)]
    ranges = [(bounds[k], bounds[k + 1]) for k in range(tasks) if bounds[k + 1] > bounds[k]]
    if threads <= 1 or len(ranges) <= 1:
        for start, stop in ranges:
            run(start, stop)
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        # list() re-raises the first exception of a range
        list(pool.map(lambda r: run(*r), ranges))
