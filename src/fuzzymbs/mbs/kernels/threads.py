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
background thread beside its pilot) share the cores. Each thread that works
on a call holds one of ``numba.get_num_threads()`` cores (the caller's
setting): the calling thread always works, and up to that many helpers join it
as cores are free, also while the call runs (when another call ends).
Without it, the pilot's two threads and the reference's one ran on two cores,
and the reference -- the longest run, which the study waits for -- got two
thirds of a core (the brake's study 1: 42.7 s against 36 s alone).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba

#: threads working on kernel calls now (over all Python threads), and its guard
_held = 0
_cores = threading.Condition()


def held_threads() -> int:
    """Threads working on the kernel calls running now (in any Python thread)."""
    return _held


def _join(limit: int, force: bool, stop: threading.Event | None = None) -> bool:
    """Hold a core: at once with ``force``, else once fewer than ``limit`` are held;
    False if ``stop`` is set first."""
    global _held
    with _cores:
        while not force and _held >= limit:
            if stop is not None and stop.is_set():
                return False
            _cores.wait()
        _held += 1
    return True


def _leave() -> None:
    global _held
    with _cores:
        _held -= 1
        _cores.notify_all()


def _share(tasks: int, work: Callable[[], None]) -> None:
    """Run ``work`` (it takes tasks from a queue until none is left) in this thread and
    in up to ``min(numba.get_num_threads(), tasks) - 1`` helpers, each of which starts
    once a core is free (or leaves without work when this thread is done)."""
    limit = numba.get_num_threads()  # the caller's setting (Numba keeps one per thread)
    helpers = min(limit, tasks) - 1
    if helpers <= 0:
        _join(limit, True)
        try:
            work()
        finally:
            _leave()
        return
    stop = threading.Event()

    def helper() -> None:
        if _join(limit, False, stop):
            try:
                work()
            finally:
                _leave()

    with ThreadPoolExecutor(max_workers=helpers) as pool:
        futures = [pool.submit(helper) for _ in range(helpers)]
        _join(limit, True)
        try:
            work()
        finally:
            _leave()
            stop.set()
            with _cores:
                _cores.notify_all()  # helpers still waiting for a core leave
        for future in futures:
            future.result()  # re-raises a helper's exception


def for_each_range(n_items: int, run: Callable[[int, int], None], tasks: int | None = None) -> None:
    """Call ``run(start, stop)`` on contiguous ranges that cover ``range(n_items)``.

    ``tasks`` ranges (default: one per item) are handed out to the threads of
    :func:`_share` as they become free, so that long items balance themselves;
    with one thread or one range everything runs here, in order.
    """
    tasks = n_items if tasks is None else max(1, min(tasks, n_items))
    bounds = [n_items * k // tasks for k in range(tasks + 1)]
    queue = deque((bounds[k], bounds[k + 1]) for k in range(tasks) if bounds[k + 1] > bounds[k])
    lock = threading.Lock()

    def work() -> None:
        while True:
            with lock:
                if not queue:
                    return
                start, stop = queue.popleft()
            run(start, stop)

    _share(len(queue), work)


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
    the threads of :func:`_share` take blocks from its front. Blocks of equal
    cost therefore finish together, within a slice: with 9 blocks on 2 threads a
    whole-block split leaves one thread the ninth block alone (5 against 4), slices
    share it (4.5 each). With one thread, each block runs whole, in order.
    """
    if min(numba.get_num_threads(), n_blocks) <= 1:

        def whole() -> None:
            for block in range(n_blocks):
                advance(block, start(block), 0, n_steps)

        _share(1, whole)
        return
    queue = deque((block, None, 0) for block in range(n_blocks))
    lock = threading.Lock()

    def work() -> None:
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

    _share(n_blocks, work)
