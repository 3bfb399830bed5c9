"""Blocks of samples over threads: a thread pool calling kernels that release the GIL.

:func:`for_each_range` splits independent items (states to differentiate) into
ranges; :func:`round_robin` advances long blocks (time integration) a slice of
steps at a time, so that the threads finish together.

The kernels' parallel loops used to be Numba ``prange`` loops. Compiling such
a loop (the parfor pass and its generated function) took 7 s of the brake's
20 s cold start for a loop whose body is one call; a block integrates
thousands of steps, so the cost of starting it from Python is negligible.
Kernels called here are compiled with ``nogil=True`` and write disjoint parts
of their output arrays, so any order of the blocks gives the same results.

Calls from several Python threads at once (a study's reference run in a
background thread beside its pilot) share the cores: a call takes
``numba.get_num_threads()`` threads less those the calls already running hold,
at least one. Without it, the pilot's two threads and the reference's one ran
on two cores, and the reference -- the longest run, which the study waits for
-- got two thirds of a core (the brake's study 1: 42.7 s against 36 s alone).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba

#: threads the kernel calls running now hold (over all Python threads)
_held = 0
_held_lock = threading.Lock()


def _take(wanted: int) -> int:
    """Hold up to ``wanted`` threads: the configured ones less those held, at least 1."""
    global _held
    with _held_lock:
        threads = max(1, min(wanted, numba.get_num_threads() - _held))
        _held += threads
    return threads


def _give(threads: int) -> None:
    global _held
    with _held_lock:
        _held -= threads


def held_threads() -> int:
    """Threads held by the kernel calls running now (in any Python thread)."""
    return _held


def for_each_range(n_items: int, run: Callable[[int, int], None], tasks: int | None = None) -> None:
    """Call ``run(start, stop)`` on contiguous ranges that cover ``range(n_items)``.

    ``tasks`` ranges (default: one per item) are handed out to
    ``numba.get_num_threads()`` threads (less those other calls hold) as they
    become free, so that long items balance themselves; with one thread or one
    range everything runs here.
    """
    tasks = n_items if tasks is None else max(1, min(tasks, n_items))
    bounds = [n_items * k // tasks for k in range(tasks + 1)]
    ranges = [(bounds[k], bounds[k + 1]) for k in range(tasks) if bounds[k + 1] > bounds[k]]
    threads = _take(len(ranges))
    try:
        if threads <= 1:
            for start, stop in ranges:
                run(start, stop)
            return
        with ThreadPoolExecutor(max_workers=threads) as pool:
            # list() re-raises the first exception of a range
            list(pool.map(lambda r: run(*r), ranges))
    finally:
        _give(threads)


def round_robin(
    n_blocks: int,
    n_steps: int,
    slice_steps: int,
    start: Callable[[int], Any],
    advance: Callable[[int, Any, int, int], bool],
) -> None:
    """Advance ``n_blocks`` blocks through steps ``0 .. n_steps - 1``, a slice at a time.

    ``start(b)`` returns block b's state; ``advance(b, state, begin, end)`` takes
    steps ``begin .. end - 1`` and returns False once the block is done. A block
    goes back to the end of a queue after each slice of ``slice_steps`` steps, and
    ``numba.get_num_threads()`` threads (less those other calls hold) take blocks
    from its front. Blocks of equal
    cost therefore finish together, within a slice: with 9 blocks on 2 threads a
    whole-block split leaves one thread the ninth block alone (5 against 4), slices
    share it (4.5 each). With one thread or one block, each block runs whole, in order.
    """
    threads = _take(n_blocks)
    try:
        _advance_all(n_blocks, n_steps, slice_steps, start, advance, threads)
    finally:
        _give(threads)


def _advance_all(n_blocks, n_steps, slice_steps, start, advance, threads: int) -> None:
    """:func:`round_robin` on ``threads`` threads."""
    if threads <= 1:
        for block in range(n_blocks):
            advance(block, start(block), 0, n_steps)
        return
    queue = deque((block, None, 0) for block in range(n_blocks))
    lock = threading.Lock()

    def worker() -> None:
        while True:
            with lock:
                if not queue:
                    return  # the blocks left are in other threads' hands
                block, state, begin = queue.popleft()
            if state is None:
                state = start(block)
            end = min(begin + slice_steps, n_steps)
            if advance(block, state, begin, end) and end < n_steps:
                with lock:
                    queue.append((block, state, end))

    with ThreadPoolExecutor(max_workers=threads) as pool:
        # result() re-raises a worker's exception
        for future in [pool.submit(worker) for _ in range(threads)]:
            future.result()
