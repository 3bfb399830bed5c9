"""Dask scaling of a large gear study: two single-thread workers against one core.

    python benchmarks/dask_scaling.py [--quick] [--repeat N] [--chunk-sizes 64,256,1024,4096]
                                      [--no-diagnostics] [--only PREFIX,...]
                                      [--src CHECKOUT/src] [--json] [--out FILE]
    python benchmarks/dask_scaling.py --cli [--quick] [--repeat N] [--no-figures]
                                      [--quiet-workers] [--ready-workers]
                                      [--src CHECKOUT/src] [--out FILE]

``--cli``: end to end, as a user measures it, the same study as a study file through
``fuzzymbs run`` in a child process (fresh store, the default plots and report;
``--no-figures``: neither), inline with one Numba thread
against ``--executor dask://`` on a LocalCluster of two single-thread workers
started and warmed up by the benchmark, alternating; ratios of the study's own wall
time (``wall_time_s`` in the result: plan, runs and method check; the dataset is
assembled after it) and of the child's (with interpreter start and writing result.nc).
``--quiet-workers`` adds, in each round, a third run on a cluster whose workers
run without Dask's statistical profiler (:data:`QUIET_WORKERS`);
``--ready-workers`` one on a cluster whose workers also import what the figure tasks
need as they start (:data:`READY_WORKERS`: the preload
:mod:`fuzzymbs.study.worker_preload`; the setting docs/studies.md recommends).

Full run about 7 min on 2 cores (``--no-diagnostics``: 3.5 min); ``--src`` measures
another checkout's ``src`` (a ``git archive`` of a commit), workers included.

The study: ``"gear-pair"`` (MUBOCO-PR, quasi-static STE over 60 mesh positions)
with five triangular parameters -- ``pinion_tooth_stiffness`` and
``wheel_tooth_stiffness`` (+-20 %), ``contact_stiffness`` (+-30 %), ``torque``
(80-100-120 N m) and ``tooth_stiffness`` (+-10 %; the model lets the two
per-gear stiffnesses override it, so it changes the run count, not the
outputs) -- on the full alpha-bound grid (``method="grid"``, ``levels=3``):
7**5 = **16,807 runs**, then the method check's validation runs (the default
count 3,361 at most, in rounds; 870 made: 840 + 30, where the search runs out
of starts on the grid's points), then the retransformation. ``--quick``:
``levels=1`` (3**5 = 243 runs), 12 positions, chunk 32, one round (a smoke
test: ~12 s, 9 s with ``--no-diagnostics``).

Timed in one process, ``--repeat`` rounds (medians; the machine may be shared,
so the load average of each run and the CPU times are reported too). Each round
runs the inline variants, then each cluster in turn -- started, warmed up, its
variants run, closed: one cluster alive at a time (an idle cluster's scheduler,
nannies and workers take CPU from the one measured):

* ``inline_1_thread`` -- **the baseline**: inline executor, ``numba.set_num_threads(1)``;
* ``inline_default`` -- inline with every Numba thread (2 on the 2-core machine);
* ``dask_1_worker`` / ``dask_2_workers`` -- ``distributed.LocalCluster(n_workers=1 | 2,
  threads_per_worker=1, processes=True)``, ``NUMBA_NUM_THREADS=1`` in the workers;
* ``fix_quiet_dask_config`` -- ``dask_2_workers`` with Dask's periodic monitors slowed
  down (:data:`QUIET_DASK`);
* diagnostics, first round only (``--no-diagnostics`` skips them):
  ``dask_2_workers_numba_default`` (the cluster without ``NUMBA_NUM_THREADS=1``: each
  worker's Numba starts a thread per core, 2 x 2 threads on 2 cores), the fixes
  ``fix_task_numba_threads``, ``fix_balanced_chunks`` and ``fix_scatter_all_in_flight``
  (below), and the chunk-size sweep ``dask_2_workers_chunk_<n>``.

Every ratio is baseline wall time / variant wall time from the same run (> 1:
faster). Every result is compared bit for bit with the baseline's dataset
(all data variables and coordinates). Fresh workers are warmed up with
``client.run`` (import, unpickling of the model, Numba cache load) before any
timing; that cold cost is reported per worker (``cold_worker_warm_up``).

Where the time goes on Dask (per variant in the JSON, summed up in the text table):

* client-side serial work: the run's wall time outside the two evaluation phases
  (plan, validation points, retransformation, dataset) -- Amdahl's share;
* per phase, from Dask's task stream: worker compute time, start latency, gaps
  between consecutive tasks on a worker, and the tail (a worker idle while the
  other finishes the phase);
* CPU time per thread (psutil): each worker's task thread and its other threads
  (event loop, profiler, monitors; with Numba's default threads also the second Numba
  thread), the client's main thread (the runner) and its other threads (the event
  loop with the scheduler, the in-process nannies and the client's communication);
* sizes: the pickled model, one task's pickled arguments, one pickled ``ChunkResult``
  per chunk size;
* warm-up of fresh workers (``client.run``): import + unpickling of the model, first
  and second model call;
* the chunk-size sweep (``--chunk-sizes``) on the 2-worker cluster.

Fixes demonstrated without touching ``src/``:

* ``fix_quiet_dask_config``: :data:`QUIET_DASK` set while the cluster starts and runs;
* ``fix_task_numba_threads``: on the cluster without ``NUMBA_NUM_THREADS=1``, each task
  calls ``numba.set_num_threads(1)`` in the thread that runs it (an executor wrapper);
* ``fix_balanced_chunks``: ``open_chunks`` patched so each phase's chunk size is
  ``ceil(count / tasks)`` with ``tasks = workers * ceil(count / (chunk * workers))``
  (equal chunks, a multiple of the worker count);
* ``fix_scatter_all_in_flight``: a ``concurrent.futures.Executor`` around the client
  that scatters the model once (``client.scatter(broadcast=True)``) and keeps every
  chunk submitted (no refill round trip).

Measured on commit 15734f9 (``--src`` of its ``git archive``), 2 cores, 2026-11-25:
inline 1 thread 17.5 s; 2 Dask workers 1.68x (median of 3, other jobs on the
machine, load 1.5-2) and 1.83x (one run, quiet machine); Numba's default threads in
the workers 1.65x; results bit-identical everywhere.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import statistics
import sys
import time
import warnings
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

import numpy as np

BENCH_DIR = Path(__file__).resolve().parent
if str(BENCH_DIR) not in sys.path:
    sys.path.insert(0, str(BENCH_DIR))

from bench_common import load_average, log  # noqa: E402

MODAL_TOOTH_STIFFNESS = 14732.9  # N m/rad (the demo gear-ste study's modal values)
MODAL_CONTACT_STIFFNESS = 8.82418e8  # N/m
FULL = {"levels": 3, "positions": 60, "chunk": 256, "sweep": (64, 256, 1024, 4096)}
QUICK = {"levels": 1, "positions": 12, "chunk": 32, "sweep": (16, 64)}


# ---------------------------------------------------------------------------- the study
def gear_study(levels: int, positions: int) -> Any:
    """The 5-parameter grid study: (2 levels + 1)**5 runs (16,807 at ``levels=3``)."""
    from fuzzymbs.fuzzy.numbers import Triangular
    from fuzzymbs.study.study import Study

    kt, kc = MODAL_TOOTH_STIFFNESS, MODAL_CONTACT_STIFFNESS
    return Study(
        "gear-pair",
        {
            "pinion_tooth_stiffness": Triangular(0.8 * kt, kt, 1.2 * kt),
            "wheel_tooth_stiffness": Triangular(0.8 * kt, kt, 1.2 * kt),
            "contact_stiffness": Triangular(0.7 * kc, kc, 1.3 * kc),
            "torque": Triangular(80.0, 100.0, 120.0),
            "tooth_stiffness": Triangular(0.9 * kt, kt, 1.1 * kt),
        },
        method="grid",
        levels=levels,
        outputs=["ste"],
        model_options={"torque": 100.0, "positions": positions},
        name="gear-dask-scaling",
    )


def differing(dataset: Any, reference: Any) -> list[str]:
    """Names of the data variables and coordinates that are not bit-identical."""
    names = sorted(set(dataset.variables) | set(reference.variables))
    bad = []
    for name in names:
        if name not in dataset.variables or name not in reference.variables:
            bad.append(name)
            continue
        a, b = dataset[name].values, reference[name].values
        if a.shape != b.shape or a.dtype != b.dtype:
            bad.append(name)
        elif a.dtype.kind in "fc":
            if not np.array_equal(a, b, equal_nan=True):
                bad.append(name)
        elif not np.array_equal(a, b):
            bad.append(name)
    return bad


# ------------------------------------------------------------- client-side instrumentation
class PhaseTimer:
    """Wraps ``evaluate_chunks`` where the study calls it (every table of runs goes through
    :mod:`fuzzymbs.study.extra_runs`): epoch start/stop of each evaluation phase (the
    plan's runs, then each round of the validation runs), client side only."""

    def __init__(self) -> None:
        import fuzzymbs.study.extra_runs as extra

        self.original = extra.evaluate_chunks
        self.phases: list[tuple[float, float, int, float]] = []

        def timed(*args: Any, **kwargs: Any) -> int:
            start, cpu = time.time(), time.process_time()
            evaluated = self.original(*args, **kwargs)
            self.phases.append((start, time.time(), int(evaluated), time.process_time() - cpu))
            return evaluated

        extra.evaluate_chunks = timed

    def take(self) -> list[tuple[float, float, int, float]]:
        phases, self.phases = self.phases, []
        return phases


class BalancedChunks:
    """Fix demo: each phase in equal chunks, a multiple of the worker count, none larger
    than the requested size (``open_chunks`` patched in the study module; no store)."""

    def __init__(self) -> None:
        import fuzzymbs.study.study as module

        self.module = module
        self.original = module.open_chunks
        self.workers = 0  # 0: off

    def __enter__(self) -> BalancedChunks:
        def balanced(store: Any, identity: Any, count: int, size: int, *args: Any, **kw: Any):
            if self.workers and store is None and count > 0:
                size = balanced_size(count, size, self.workers)
            return self.original(store, identity, count, size, *args, **kw)

        self.module.open_chunks = balanced
        return self

    def __exit__(self, *exc: Any) -> None:
        self.module.open_chunks = self.original


def balanced_size(count: int, requested: int, workers: int) -> int:
    """Chunk size giving equal tasks, a multiple of ``workers``, none above ``requested``."""
    tasks = workers * math.ceil(math.ceil(count / requested) / workers)
    return math.ceil(count / tasks)


class ScatteringExecutor(Executor):
    """Fix demo: the model travels once (``client.scatter(broadcast=True)``); each task
    carries its future. ``_max_workers`` sets the runner's in-flight count (2x it)."""

    def __init__(self, client: Any, in_flight: int) -> None:
        self._client = client
        self._inner = client.get_executor(pure=False)
        self._max_workers = max(1, in_flight // 2)
        self._scattered: dict[int, tuple[Any, Any]] = {}
        self.scatter_seconds = 0.0

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future:
        model, rest = args[0], args[1:]
        entry = self._scattered.get(id(model))
        if entry is None:
            start = time.perf_counter()
            future = self._client.scatter(model, broadcast=True, hash=False)
            self.scatter_seconds += time.perf_counter() - start
            entry = self._scattered[id(model)] = (model, future)
        return self._inner.submit(fn, entry[1], *rest, **kwargs)


def _with_numba_threads(threads: int, fn: Any, /, *args: Any, **kwargs: Any) -> Any:
    """Run ``fn`` with ``threads`` Numba threads in the calling (worker task) thread;
    ``numba.set_num_threads`` is thread-local, so ``client.run`` could not do this."""
    import numba

    previous = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    try:
        return fn(*args, **kwargs)
    finally:
        numba.set_num_threads(previous)


class TaskThreadsExecutor(Executor):
    """Fix demo: every task runs with ``threads`` Numba threads on a cluster started
    without ``NUMBA_NUM_THREADS`` (what ``evaluate_chunks`` could do for any Dask client)."""

    def __init__(self, client: Any, threads: int = 1) -> None:
        self._inner = client.get_executor(pure=False)
        self._threads = threads
        nthreads = sum(w["nthreads"] for w in client.scheduler_info()["workers"].values())
        self._max_workers = max(1, nthreads)  # the runner's in-flight count, as for a client

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future:
        return self._inner.submit(_with_numba_threads, self._threads, fn, *args, **kwargs)


# ------------------------------------------------------------------------------ workers
def _worker_numba_threads() -> dict[str, Any]:
    import numba

    import fuzzymbs

    return {"numba_threads": numba.get_num_threads(), "fuzzymbs": fuzzymbs.__file__}


def _worker_cpu() -> float:
    return time.process_time()


def _threads_cpu() -> dict[int, float]:
    """CPU seconds of each thread of this process (psutil; native thread ids)."""
    import psutil

    return {t.id: t.user_time + t.system_time for t in psutil.Process().threads()}


def _split_threads(before: dict[int, float], after: dict[int, float], main: int | None):
    """(CPU of thread ``main`` -- or of the busiest thread --, CPU of all the others)."""
    deltas = {k: v - before.get(k, 0.0) for k, v in after.items()}
    if not deltas:
        return 0.0, 0.0
    key = main if main in deltas else max(deltas, key=deltas.__getitem__)
    return deltas[key], sum(v for k, v in deltas.items() if k != key)


def _worker_warm_up(model_bytes: bytes, columns: dict[str, np.ndarray]) -> dict[str, float]:
    """On a fresh worker: import + unpickling of the model, first and second model call."""
    import cloudpickle

    start = time.perf_counter()
    model = cloudpickle.loads(model_bytes)
    loaded = time.perf_counter()
    model(columns)
    first = time.perf_counter()
    model(columns)
    second = time.perf_counter()
    return {
        "import_and_unpickle_s": loaded - start,
        "first_call_s": first - loaded,
        "second_call_s": second - first,
    }


#: Fix: Dask's periodic work, which on a 2-core box runs on the cores the workers use
#: (defaults: event-loop tick 20 ms, system monitor 500 ms, worker profiler sampling
#: every 10 ms, memory monitor 100 ms, cluster repr 500 ms). Measured idle cost of a
#: 2-worker LocalCluster (client/scheduler process + nannies + workers): 0.13 of a core
#: with the defaults, 0.017 with these.
QUIET_DASK = {
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.profile.enabled": False,
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.deploy.cluster-repr-interval": "10s",
}
#: The worker setting docs/studies.md recommends for a fuzzymbs cluster: no statistical
#: profiler (it samples every thread's stack every 10 ms, for the dashboard only).
QUIET_WORKERS = {"distributed.worker.profile.enabled": False}
#: and the worker preload docs/studies.md recommends (imports at the worker's start)
READY_WORKERS = {**QUIET_WORKERS, "distributed.worker.preload": ["fuzzymbs.study.worker_preload"]}
#: name -> (workers, NUMBA_NUM_THREADS=1 in the workers, Dask configuration)
CLUSTERS: dict[str, tuple[int, bool, dict[str, Any]]] = {
    "w1": (1, True, {}),
    "w2": (2, True, {}),
    "w2_quiet": (2, True, QUIET_DASK),
    "w2_numba_default": (2, False, {}),
}


def start_cluster(workers: int, numba_one_thread: bool, src: str | None) -> tuple[Any, Any, float]:
    """A LocalCluster of ``workers`` single-thread worker processes and its client
    (under the Dask configuration in force: the nannies hand it to the workers)."""
    from distributed import Client, LocalCluster

    env = {"NUMBA_NUM_THREADS": "1"} if numba_one_thread else {}
    if src:
        env["PYTHONPATH"] = os.environ.get("PYTHONPATH", src)
    start = time.perf_counter()
    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        env=env,
    )
    client = Client(cluster)
    client.wait_for_workers(workers)
    return cluster, client, time.perf_counter() - start


# --------------------------------------------------------------------------------- runs
class Variant:
    """One way of running the study: the cluster it needs (None: inline), how to call
    ``Study.run`` on it, and its timed runs."""

    def __init__(
        self,
        name: str,
        cluster: str | None = None,
        threads: int | None = None,
        chunk: int | None = None,
        executor: Any = None,
        balanced: int = 0,
        once: bool = False,
    ) -> None:
        self.name, self.cluster, self.threads, self.chunk = name, cluster, threads, chunk
        self.executor = executor  # None: the client itself; else executor(client)
        self.balanced, self.once = balanced, once
        self.runs: list[dict[str, Any]] = []
        self.result: Any = None


def run_once(
    study: Any, variant: Variant, client: Any, timer: PhaseTimer, balance: BalancedChunks
) -> dict[str, Any]:
    """One timed ``study.run``; wall, client CPU, worker CPU, phases, task stream."""
    import numba

    numba.set_num_threads(variant.threads or numba.config.NUMBA_NUM_THREADS)
    executor = None
    if client is not None:
        executor = client if variant.executor is None else variant.executor(client)
    worker_cpu = client.run(_worker_cpu) if client is not None else None
    worker_threads = client.run(_threads_cpu) if client is not None else None
    client_threads = _threads_cpu()
    stream = None
    timer.take()
    balance.workers = variant.balanced
    if client is not None:
        from distributed import get_task_stream

        stream = get_task_stream(client)
        stream.__enter__()
    wall0, cpu0, epoch0 = time.perf_counter(), time.process_time(), time.time()
    try:
        result = study.run(executor=executor, chunk_size=variant.chunk, progress=False)
    finally:
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        if stream is not None:
            stream.__exit__(None, None, None)
        balance.workers = 0
    import threading

    main_cpu, other_cpu = _split_threads(
        client_threads, _threads_cpu(), threading.main_thread().native_id
    )
    record: dict[str, Any] = {
        "wall_s": wall,
        "client_cpu_s": cpu,
        # the client's main thread (the runner; inline: also the kernel's first thread)
        # and its other threads (Dask: event loop with scheduler, nannies, client comm)
        "client_main_thread_cpu_s": main_cpu,
        "client_other_threads_cpu_s": other_cpu,
        "load_average": load_average(),
    }
    phases = timer.take()
    record["phases"] = [(a - epoch0, b - epoch0, n) for a, b, n, _ in phases]
    record["evaluation_s"] = sum(b - a for a, b, _, _ in phases)
    record["serial_client_s"] = wall - record["evaluation_s"]
    # client CPU during the evaluation phases (inline: the kernel; Dask: client thread,
    # scheduler, communication) and outside them (plan, retransformation, dataset)
    record["client_cpu_in_phases_s"] = sum(c for _, _, _, c in phases)
    record["serial_client_cpu_s"] = cpu - record["client_cpu_in_phases_s"]
    if client is not None:
        after = client.run(_worker_cpu)
        record["worker_cpu_s"] = sum(after[w] - worker_cpu.get(w, after[w]) for w in after)
        # each worker's busiest thread runs the tasks; its other threads are Dask's
        # (event loop, profiler, monitors, communication)
        threads_after = client.run(_threads_cpu)
        split = [_split_threads(worker_threads[w], threads_after[w], None) for w in threads_after]
        record["worker_task_thread_cpu_s"] = sum(a for a, _ in split)
        record["worker_other_threads_cpu_s"] = sum(b for _, b in split)
        record["tasks"] = task_stream_summary(stream.data, record["phases"], epoch0)
        if isinstance(executor, ScatteringExecutor):
            record["scatter_s"] = executor.scatter_seconds
    variant.result = result
    return record


def task_stream_summary(
    data: list[dict[str, Any]], phases: list[tuple[float, float, int]], epoch0: float
) -> dict[str, Any]:
    """Busy time and idle time of the workers in each phase, from Dask's task stream."""
    computes = []
    other = {"transfer": 0.0, "deserialize": 0.0, "disk-read": 0.0, "disk-write": 0.0}
    for task in data:
        for part in task.get("startstops", ()):
            if part["action"] == "compute":
                computes.append((task["worker"], part["start"] - epoch0, part["stop"] - epoch0))
            elif part["action"] in other:
                other[part["action"]] += part["stop"] - part["start"]
    workers = sorted({w for w, _, _ in computes})
    out: dict[str, Any] = {"count": len(computes), "workers": len(workers), "other_s": other}
    rows = []
    for start, stop, _ in phases:
        inside = [(w, a, b) for w, a, b in computes if a >= start - 1e-3 and b <= stop + 1e-3]
        row = {"wall_s": stop - start, "tasks": len(inside), "compute_s": 0.0}
        lead = gaps = tail = 0.0
        longest = 0.0
        for worker in workers:
            mine = sorted((a, b) for w, a, b in inside if w == worker)
            if not mine:
                lead += stop - start
                continue
            row["compute_s"] += sum(b - a for a, b in mine)
            lead += mine[0][0] - start
            gaps += sum(mine[i + 1][0] - mine[i][1] for i in range(len(mine) - 1))
            tail += stop - mine[-1][1]
            longest = max(longest, max(b - a for a, b in mine))
        row.update(
            {
                "start_latency_s": lead,
                "gaps_between_tasks_s": gaps,
                "tail_s": tail,
                "largest_task_s": longest,
                "idle_worker_s": len(workers) * (stop - start) - row["compute_s"],
            }
        )
        rows.append(row)
    out["phases"] = rows
    return out


def median(values: list[float]) -> float:
    return float(statistics.median(values)) if values else float("nan")


def summarise(variant: Variant, baseline: float) -> dict[str, Any]:
    """Medians of a variant's warm runs and its ratio against the baseline's median."""
    runs = variant.runs
    row: dict[str, Any] = {
        "runs": len(runs),
        "wall_s": [round(r["wall_s"], 3) for r in runs],
        "wall_median_s": median([r["wall_s"] for r in runs]),
        "client_cpu_median_s": median([r["client_cpu_s"] for r in runs]),
        "evaluation_median_s": median([r["evaluation_s"] for r in runs]),
        "serial_client_median_s": median([r["serial_client_s"] for r in runs]),
        "client_cpu_in_phases_median_s": median([r["client_cpu_in_phases_s"] for r in runs]),
        "serial_client_cpu_median_s": median([r["serial_client_cpu_s"] for r in runs]),
        "load_average_1min": [r["load_average"][0] for r in runs if r["load_average"]],
        "client_main_thread_cpu_median_s": median([r["client_main_thread_cpu_s"] for r in runs]),
        "client_other_threads_cpu_median_s": median(
            [r["client_other_threads_cpu_s"] for r in runs]
        ),
    }
    row["speedup_vs_inline_1_thread"] = baseline / row["wall_median_s"]
    if runs and "worker_cpu_s" in runs[0]:
        row["worker_cpu_median_s"] = median([r["worker_cpu_s"] for r in runs])
        for key in ("worker_task_thread_cpu_s", "worker_other_threads_cpu_s"):
            row[key.replace("_s", "_median_s")] = median([r[key] for r in runs])
        phases = [r["tasks"]["phases"] for r in runs]
        keys = ("wall_s", "compute_s", "start_latency_s", "gaps_between_tasks_s", "tail_s")
        keys += ("idle_worker_s", "largest_task_s")
        row["phases"] = [
            {"tasks": p["tasks"], **{k: median([q[i][k] for q in phases]) for k in keys}}
            for i, p in enumerate(phases[0])
        ]
    return row


# ------------------------------------------------------------------------------- sizes
def sizes(study: Any, chunk_sizes: tuple[int, ...]) -> dict[str, Any]:
    """Pickled sizes and (de)serialisation times of the model, a task, a chunk result."""
    import cloudpickle

    from fuzzymbs.study.evaluation import ChunkResult, evaluate_chunk

    model = study.model
    blob = cloudpickle.dumps(model)
    loops = 50
    start = time.perf_counter()
    for _ in range(loops):
        cloudpickle.dumps(model)
    dumps = (time.perf_counter() - start) / loops
    start = time.perf_counter()
    for _ in range(loops):
        cloudpickle.loads(blob)
    loads = (time.perf_counter() - start) / loops
    chunk = evaluate_chunk(model, study.columns(0, min(64, len(study.plan))), 0, study.outputs)
    per: dict[str, Any] = {}
    for size in chunk_sizes:
        columns = study.columns(0, min(size, len(study.plan)))
        task = cloudpickle.dumps((evaluate_chunk, model, columns, 0, study.outputs))
        reps = math.ceil(size / chunk.size)
        result = ChunkResult(
            0,
            size,
            {k: np.tile(v, (reps,) + (1,) * (v.ndim - 1))[:size] for k, v in chunk.outputs.items()},
            np.tile(chunk.failed, reps)[:size],
            np.tile(chunk.reasons, reps)[:size],
        )
        per[str(size)] = {
            "task_pickle_bytes": len(task),
            "chunk_result_pickle_bytes": len(pickle.dumps(result, protocol=5)),
        }
    return {
        "model_pickle_bytes": len(blob),
        "model_dumps_ms": dumps * 1e3,
        "model_loads_ms": loads * 1e3,
        "per_chunk_size": per,
    }


# -------------------------------------------------------------------------------- main
def main(
    quick: bool = False,
    repeat: int | None = None,
    chunk_sizes: tuple[int, ...] | None = None,
    src: str | None = None,
    diagnostics: bool = True,
    only: tuple[str, ...] = (),
) -> dict[str, Any]:
    """Run every variant; return the figures (JSON-ready)."""
    import numba

    from fuzzymbs.fuzzy import NonMonotonicWarning

    setting = QUICK if quick else FULL
    repeat = repeat or (1 if quick else 3)
    sweep = tuple(chunk_sizes or setting["sweep"])
    chunk = setting["chunk"]
    started = time.perf_counter()
    figures: dict[str, Any] = {"load_average_at_start": load_average()}
    study = gear_study(setting["levels"], setting["positions"])
    runs = len(study.plan)
    figures["study"] = {
        "model": "gear-pair",
        "method": "grid",
        "levels": setting["levels"],
        "positions": setting["positions"],
        "parameters": list(study.plan.names),
        "runs": runs,
        "validation_runs": study.validation_count(),
        "chunk_size": chunk,
        "numba_threads_inline_default": numba.config.NUMBA_NUM_THREADS,
    }
    log(f"dask_scaling: {runs} runs + {figures['study']['validation_runs']} validation runs")
    timer = PhaseTimer()
    balance = BalancedChunks()
    warnings.simplefilter("ignore", NonMonotonicWarning)
    # compile or load the Numba cache, and import what the retransformation and the
    # dataset use (scipy.stats, xarray: ~2 s), with a small study, before any timing
    gear_study(1, setting["positions"]).run(progress=False)

    figures["sizes"] = sizes(study, sweep)
    every = 2 * math.ceil(runs / chunk)
    variants = [
        Variant("inline_1_thread", None, 1, chunk),
        Variant("inline_default", None, None, chunk),
        Variant("dask_1_worker", "w1", None, chunk),
        Variant("dask_2_workers", "w2", None, chunk),
        Variant("fix_quiet_dask_config", "w2_quiet", None, chunk),
    ]
    if diagnostics:
        variants += [
            Variant("dask_2_workers_numba_default", "w2_numba_default", None, chunk, once=True),
            Variant(
                "fix_task_numba_threads",
                "w2_numba_default",
                None,
                chunk,
                executor=lambda client: TaskThreadsExecutor(client, 1),
                once=True,
            ),
            Variant("fix_balanced_chunks", "w2", None, chunk, balanced=2, once=True),
            Variant(
                "fix_scatter_all_in_flight",
                "w2",
                None,
                chunk,
                executor=lambda client: ScatteringExecutor(client, every),
                once=True,
            ),
        ]
        variants += [
            Variant(f"dask_2_workers_chunk_{size}", "w2", None, size, once=True)
            for size in sweep
            if size != chunk
        ]
    if only:
        keep = ("inline_1_thread", *only)
        variants = [v for v in variants if v.name.startswith(keep)]
    import cloudpickle
    import dask

    figures["cold_worker_warm_up"] = {}
    figures["cluster_startup_s"] = {}
    figures["worker_numba_threads"] = {}
    for round_ in range(repeat):
        # one cluster alive at a time (an idle cluster's scheduler, nannies and workers
        # take CPU from the one measured); inline first, then each cluster in turn
        for key in [None, *CLUSTERS]:
            todo = [v for v in variants if v.cluster == key and (round_ == 0 or not v.once)]
            if not todo:
                continue
            cluster = client = None
            config = CLUSTERS[key][2] if key else {}
            with dask.config.set(config):
                try:
                    if key is not None:
                        workers, one, _ = CLUSTERS[key]
                        cluster, client, startup = start_cluster(workers, one, src)
                        figures["cluster_startup_s"].setdefault(key, []).append(startup)
                        # what the first task on each fresh worker pays (import and
                        # unpickling of the model, Numba cache load), paid before timing
                        warm = client.run(
                            _worker_warm_up, cloudpickle.dumps(study.model), study.columns(0, 1)
                        )
                        figures["cold_worker_warm_up"].setdefault(key, []).extend(warm.values())
                        figures["worker_numba_threads"][key] = sorted(
                            {v["numba_threads"] for v in client.run(_worker_numba_threads).values()}
                        )
                        figures["worker_fuzzymbs"] = sorted(
                            {v["fuzzymbs"] for v in client.run(_worker_numba_threads).values()}
                        )
                    for variant in todo:
                        record = run_once(study, variant, client, timer, balance)
                        variant.runs.append(record)
                        log(
                            f"dask_scaling: round {round_ + 1} {variant.name}: "
                            f"{record['wall_s']:.2f} s (load {record['load_average'][:1]})"
                        )
                finally:
                    if client is not None:
                        client.close()
                        cluster.close()

    reference = variants[0].result.dataset
    baseline = median([r["wall_s"] for r in variants[0].runs])
    figures["variants"] = {}
    for variant in variants:
        row = summarise(variant, baseline)
        row["chunk_size"] = variant.chunk
        bad = differing(variant.result.dataset, reference)
        row["identical_to_inline_1_thread"] = not bad
        if bad:
            row["differing"] = bad[:10]
        if variant.runs and "scatter_s" in variant.runs[0]:
            row["scatter_s"] = variant.runs[0]["scatter_s"]
        figures["variants"][variant.name] = row
    figures["load_average_at_end"] = load_average()
    figures["benchmark_wall_seconds"] = time.perf_counter() - started
    return figures


GEAR_STUDY_FILE = """[study]
name = "gear-dask-scaling"
method = "grid"
levels = {levels}
outputs = ["ste"]

[model]
name = "gear-pair"
[model.options]
torque = 100.0
positions = {positions}

[parameters]
pinion_tooth_stiffness = {{ type = "triangular", modal = {kt}, spread = 0.2 }}
wheel_tooth_stiffness = {{ type = "triangular", modal = {kt}, spread = 0.2 }}
contact_stiffness = {{ type = "triangular", modal = {kc}, spread = 0.3 }}
torque = {{ type = "triangular", lower = 80.0, modal = 100.0, upper = 120.0 }}
tooth_stiffness = {{ type = "triangular", modal = {kt}, spread = 0.1 }}
"""


def _cli_run(
    path: Path, out: Path, executor: str | None, chunk: int, plots: bool = True
) -> dict[str, Any]:
    """One ``fuzzymbs run`` of the study file in a child process (fresh store; with the
    default plots and report unless ``plots`` is False); the child's wall time and the
    study's own (``wall_time_s``)."""
    import subprocess

    import xarray

    env = dict(os.environ)
    command = [sys.executable, "-m", "fuzzymbs.cli", "run", str(path), "--out", str(out)]
    command += ["--fresh", "--chunk-size", str(chunk)]
    if not plots:
        command += ["--no-plots", "--no-report"]
    if executor is None:
        env["NUMBA_NUM_THREADS"] = "1"  # the baseline: one inline core
    else:
        command += ["--executor", executor]
    load = load_average()
    start = time.perf_counter()
    subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    with xarray.open_dataset(out / "result.nc") as result:
        provenance = json.loads(result.attrs["provenance"])
        bounds = {k: result[k].values.copy() for k in ("ste_lower", "ste_upper")}
        excursion = result["ste_validation_excursion"].values.copy()
        validation = int(result.attrs["validation_runs"])
        error = float(result.attrs["method_error"])
    return {
        "process_wall_s": wall,
        "study_wall_s": float(provenance["wall_time_s"]),
        "validation_runs": validation,
        "rounds": provenance["method_check"].get("rounds"),
        "method_error": error,
        "load_average": load,
        "arrays": {**bounds, "excursion": excursion},
    }


def cli_main(
    quick: bool = False,
    repeat: int | None = None,
    plots: bool = True,
    quiet_workers: bool = False,
    ready_workers: bool = False,
) -> dict[str, Any]:
    """``fuzzymbs run`` of the gear study: inline with one Numba thread against two
    single-thread Dask workers (a LocalCluster started here, warmed up before timing),
    default method check on, with the default plots and report unless ``plots`` is
    False; alternating, ``repeat`` rounds, medians."""
    import tempfile

    setting = QUICK if quick else FULL
    repeat = repeat or (1 if quick else 3)
    kt, kc = MODAL_TOOTH_STIFFNESS, MODAL_CONTACT_STIFFNESS
    values = {"positions": setting["positions"], "kt": kt, "kc": kc}
    workers = {"dask": {}}
    if quiet_workers:
        workers["dask_quiet_workers"] = QUIET_WORKERS
    if ready_workers:
        workers["dask_ready_workers"] = READY_WORKERS
    figures: dict[str, Any] = {"load_average_at_start": load_average(), "inline": []}
    figures.update({key: [] for key in workers})
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        path = root / "gear.toml"
        warm = root / "warm.toml"
        path.write_text(GEAR_STUDY_FILE.format(levels=setting["levels"], **values))
        warm.write_text(GEAR_STUDY_FILE.format(levels=1, **values))
        _cli_run(warm, root / "warm", None, setting["chunk"])  # Numba cache, imports
        for round_ in range(repeat):
            inline = _cli_run(path, root / f"inline{round_}", None, setting["chunk"], plots)
            figures["inline"].append(inline)
            log(f"dask_scaling --cli: round {round_ + 1} inline {inline['study_wall_s']:.2f} s")
            for key, config in workers.items():
                dask = _cli_dask_run(path, root / f"{key}{round_}", setting, config, plots)
                figures[key].append(dask)
                log(
                    f"dask_scaling --cli: round {round_ + 1} {key} {dask['study_wall_s']:.2f} s"
                    f" (process {dask['process_wall_s']:.2f} s)"
                )
    reference = figures["inline"][0]["arrays"]
    runs = [run for key in ("inline", *workers) for run in figures[key]]
    identical = all(
        np.array_equal(run["arrays"][k], reference[k], equal_nan=True)
        for run in runs
        for k in reference
    )
    for run in runs:
        run.pop("arrays")
    for key in ("study_wall_s", "process_wall_s"):
        inline_median = median([r[key] for r in figures["inline"]])
        figures[f"inline_median_{key}"] = inline_median
        for name in workers:
            dask_median = median([r[key] for r in figures[name]])
            suffix = "" if name == "dask" else name.removeprefix("dask")
            figures[f"ratio_{key}{suffix}"] = inline_median / dask_median
            figures[f"{name}_median_{key}"] = dask_median
    figures["identical"] = identical
    figures["load_average_at_end"] = load_average()
    return figures


def _cli_dask_run(
    path: Path, out: Path, setting: dict[str, Any], config: dict[str, Any], plots: bool
) -> dict[str, Any]:
    """:func:`_cli_run` on a fresh, warmed-up LocalCluster of two single-thread workers
    started under the Dask configuration ``config`` (the nannies hand it to the workers)."""
    import dask
    import distributed  # noqa: F401  (its defaults loaded: leaving the set() below keeps them)

    with dask.config.set(config):
        cluster, client, _ = start_cluster(2, True, None)
    try:
        study = gear_study(1, setting["positions"])
        client.run(_worker_warm_up, _pickled(study.model), study.columns(0, 1))
        address = cluster.scheduler_address.replace("tcp://", "dask://")
        return _cli_run(path, out, address, setting["chunk"], plots)
    finally:
        client.close()
        cluster.close()


def _pickled(model: Any) -> bytes:
    import cloudpickle

    return cloudpickle.dumps(model)


def table(figures: dict[str, Any]) -> str:
    """The ratio table and the Dask breakdown in text."""
    lines = [
        f"{figures['study']['runs']} runs + {figures['study']['validation_runs']} validation "
        f"runs, chunk {figures['study']['chunk_size']}",
        "ratio = inline_1_thread median wall / variant median wall; cpu = client + workers; "
        "serial = wall (cpu) of the client outside the evaluation phases",
        f"{'variant':30s} {'chunk':>5s} {'runs':>4s} {'median s':>8s} {'ratio':>6s} "
        f"{'cpu s':>6s} {'serial s':>12s} {'client cpu':>10s} {'same':>5s}",
    ]
    for name, row in figures["variants"].items():
        cpu = row["client_cpu_median_s"] + row.get("worker_cpu_median_s", 0.0)
        serial = f"{row['serial_client_median_s']:.2f} ({row['serial_client_cpu_median_s']:.2f})"
        lines.append(
            f"{name:30s} {row['chunk_size']:5d} {row['runs']:4d} {row['wall_median_s']:8.2f} "
            f"{row['speedup_vs_inline_1_thread']:6.2f} {cpu:6.2f} {serial:>12s} "
            f"{row['client_cpu_in_phases_median_s']:10.2f} "
            f"{row['identical_to_inline_1_thread']!s:>5s}"
        )
    for name, row in figures["variants"].items():
        if "worker_task_thread_cpu_median_s" in row:
            lines.append(
                f"  {name} CPU: workers' task threads {row['worker_task_thread_cpu_median_s']:.2f}"
                f" s, workers' other threads {row['worker_other_threads_cpu_median_s']:.2f} s, "
                f"client main thread {row['client_main_thread_cpu_median_s']:.2f} s, client "
                f"other threads {row['client_other_threads_cpu_median_s']:.2f} s"
            )
    for key, rows in figures.get("cold_worker_warm_up", {}).items():
        text = ", ".join(
            f"{r['import_and_unpickle_s']:.2f} + {r['first_call_s']:.2f} s" for r in rows
        )
        lines.append(f"cold worker warm-up {key} (import+unpickle + first call): {text}")
    for name, row in figures["variants"].items():
        for i, phase in enumerate(row.get("phases", [])):
            lines.append(
                f"  {name} phase {i}: {phase['tasks']} tasks, wall {phase['wall_s']:.2f} s, "
                f"compute {phase['compute_s']:.2f} s, idle {phase['idle_worker_s']:.2f} "
                f"(start {phase['start_latency_s']:.2f}, gaps {phase['gaps_between_tasks_s']:.2f}"
                f", tail {phase['tail_s']:.2f}), largest task {phase['largest_task_s']:.2f} s"
            )
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="243-run smoke test")
    parser.add_argument("--repeat", type=int, default=None, help="rounds (default 3, quick 1)")
    parser.add_argument("--chunk-sizes", default=None, help="sweep, e.g. 64,256,1024,4096")
    parser.add_argument("--src", default=None, help="a checkout's src/ to measure instead")
    parser.add_argument(
        "--no-diagnostics",
        action="store_true",
        help="only the repeated table (no Numba-default cluster, balanced/scatter demos, sweep)",
    )
    parser.add_argument(
        "--only", default="", help="comma-separated name prefixes (the baseline always runs)"
    )
    parser.add_argument("--json", action="store_true", help="print only the JSON line")
    parser.add_argument("--out", default=None, help="also write the JSON to this file")
    parser.add_argument(
        "--cli",
        action="store_true",
        help="end to end: `fuzzymbs run` inline (1 thread) against 2 Dask workers",
    )
    parser.add_argument(
        "--no-figures",
        action="store_true",
        help="with --cli: `fuzzymbs run --no-plots --no-report` (the study and result.nc only)",
    )
    parser.add_argument(
        "--quiet-workers",
        action="store_true",
        help="with --cli: also a cluster whose workers run without Dask's profiler",
    )
    parser.add_argument(
        "--ready-workers",
        action="store_true",
        help="with --cli: also a cluster of quiet workers started with fuzzymbs's worker preload",
    )
    args = parser.parse_args()
    if args.src:
        source = str(Path(args.src).resolve())
        sys.path.insert(0, source)
        os.environ["PYTHONPATH"] = os.pathsep.join(
            p for p in (source, os.environ.get("PYTHONPATH", "")) if p
        )
    if args.cli:
        figures = cli_main(
            args.quick, args.repeat, not args.no_figures, args.quiet_workers, args.ready_workers
        )
        figures_line = json.dumps(figures, default=float)
        print(figures_line)
        if args.out:
            Path(args.out).write_text(figures_line + "\n")
        sys.exit(0)
    sizes_arg = tuple(int(s) for s in args.chunk_sizes.split(",")) if args.chunk_sizes else None
    only = tuple(n for n in args.only.split(",") if n)
    result = main(args.quick, args.repeat, sizes_arg, args.src, not args.no_diagnostics, only)
    from bench_common import machine

    result["machine"] = machine()
    if not args.json:
        print(table(result))
    line = json.dumps(result, default=float)
    print(line)
    if args.out:
        Path(args.out).write_text(line + "\n")
