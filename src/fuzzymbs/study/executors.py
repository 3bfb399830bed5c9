"""Executors a study sends its chunks to (``concurrent.futures`` style).

- ``None`` / ``"inline"``: evaluate in this process, one chunk after another.
- ``"processes"`` / ``"processes:N"``: a local process pool (spawned workers).
- ``"dask://host:port"`` (or ``"tcp://..."``) or a ``distributed.Client``: a Dask cluster.
- any ``concurrent.futures.Executor`` instance is used as given.
- a :class:`KeptExecutor`: one of the above, started once and shared by several calls.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import Executor, Future
from dataclasses import dataclass, replace
from typing import Any

from fuzzymbs.errors import InvalidParameterError


class InlineExecutor(Executor):
    """Runs each submitted call immediately in the calling process."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # handed to the caller through the future
            future.set_exception(exc)
        return future


@dataclass
class ResolvedExecutor:
    """An executor plus what the runner needs to know about it."""

    executor: Executor
    label: str
    in_flight: int  # chunks kept submitted at a time
    close: Callable[[], None]
    #: compiled-kernel threads per task (Numba), so that the workers together use the
    #: machine's cores without oversubscribing them; None: Numba's default (inline)
    task_threads: int | None = None


#: seconds between a worker's checks that the process that started it still lives
PARENT_POLL_S = 0.5


def watch_parent(parent: int) -> None:
    """In a pool worker: end the worker as soon as ``parent`` is gone.

    A parent killed without a chance to shut its pool down (``kill -9``) would
    otherwise leave its workers, and with them the multiprocessing resource
    tracker whose pipe they hold, running for good.
    """
    import threading
    import time

    from fuzzymbs.study.evaluation import hard_exit

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        hard_exit(1)

    threading.Thread(target=watch, name="fuzzymbs-watch-parent", daemon=True).start()


def _nothing() -> None:
    return None


def _worker_count(executor: Any) -> int:
    workers = getattr(executor, "_max_workers", None)
    return int(workers) if workers else (os.cpu_count() or 1)


#: a process pool may have at most this many workers per core: more only adds memory
#: and start-up time, and a study file could otherwise ask for ``processes:100000``
MAX_WORKERS_PER_CORE = 4
#: executors a study file may name without ``--allow-code``: they run nothing but the model
LOCAL_EXECUTORS = ("inline", "processes")


def max_workers() -> int:
    """The largest worker count of a process pool on this machine (4 per core)."""
    return MAX_WORKERS_PER_CORE * (os.cpu_count() or 1)


def process_workers(spec: str) -> int | None:
    """The worker count of a ``"processes[:N]"`` specification (None for other executors).

    Raises
    ------
    InvalidParameterError
        A count that is not a whole number, below 1 or above :func:`max_workers`.
    """
    if not (spec == "processes" or spec.startswith("processes:")):
        return None
    count_text = spec.partition(":")[2]
    try:
        workers = int(count_text) if count_text else (os.cpu_count() or 1)
    except ValueError:
        raise InvalidParameterError(
            f"executor {spec!r}: the worker count after 'processes:' must be an integer"
        ) from None
    if workers < 1:
        raise InvalidParameterError(f"executor {spec!r}: need at least one worker")
    if workers > max_workers():
        raise InvalidParameterError(
            f"executor {spec!r}: at most {max_workers()} workers on this machine "
            f"({MAX_WORKERS_PER_CORE} per core, {os.cpu_count() or 1} cores); "
            "use a Dask cluster for more"
        )
    return workers


def is_remote(spec: str) -> bool:
    """True for a Dask scheduler address: connecting exchanges pickled data with it."""
    return spec.startswith(("dask://", "tcp://"))


def check_executor_spec(spec: Any) -> None:
    """Check an executor specification without starting anything (see :func:`resolve_executor`).

    Raises
    ------
    InvalidParameterError
        An unknown specification string, a bad worker count, or a Dask scheduler
        address without the ``distributed`` package installed.
    """
    if not isinstance(spec, str) or spec == "inline":
        return
    if is_remote(spec):
        try:  # a missing package fails here, before any run, not at the first chunk
            import distributed  # noqa: F401
        except ImportError as exc:
            raise InvalidParameterError(
                f"executor {spec!r} needs Dask's distributed package ({exc}); install it "
                "with: pip install 'fuzzymbs[dask]'"
            ) from None
        return
    if process_workers(spec) is None:
        raise InvalidParameterError(
            f"unknown executor {spec!r}; use 'inline', 'processes[:N]' or 'dask://host:port'"
        )


class KeptExecutor:
    """An executor specification resolved on first use and kept open until :meth:`close`.

    A study file's run passes one to :meth:`fuzzymbs.study.study.Study.run` as its
    executor, so that the figures drawn after the runs go to the same workers (a
    Dask cluster's or a process pool's) instead of the client, and nothing is
    started when every chunk comes from the store.

    Parameters
    ----------
    spec : None, str, concurrent.futures.Executor or distributed.Client
        See :func:`resolve_executor`.
    """

    def __init__(self, spec: Any = None) -> None:
        self.spec = spec
        self.started: ResolvedExecutor | None = None

    def resolve(self) -> ResolvedExecutor:
        """The resolved executor, started at the first call."""
        if self.started is None:
            self.started = resolve_executor(self.spec)
        return self.started

    def close(self) -> None:
        """Shut the executor down if it was started (and this object started it)."""
        if self.started is not None:
            self.started.close()
            self.started = None


def resolve_executor(spec: Any = None) -> ResolvedExecutor:
    """Turn an executor specification into a :class:`ResolvedExecutor`.

    Parameters
    ----------
    spec : None, str, concurrent.futures.Executor, distributed.Client or KeptExecutor
        See the module docstring; a :class:`KeptExecutor` gives its executor, which
        the caller's ``close`` then leaves open.

    Raises
    ------
    InvalidParameterError
        For an unknown specification string, a worker count above
        :func:`max_workers`, or a Dask scheduler that cannot be reached.
    """
    if spec is None or spec == "inline":
        return ResolvedExecutor(InlineExecutor(), "inline", 1, _nothing)
    if isinstance(spec, KeptExecutor):  # its owner closes it, not the run that uses it
        return replace(spec.resolve(), close=_nothing)
    if isinstance(spec, str):
        if spec == "processes" or spec.startswith("processes:"):
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            workers = process_workers(spec)
            assert workers is not None
            # spawn, not fork: the parent may run threads (progress bar, Dask, BLAS).
            pool = ProcessPoolExecutor(
                max_workers=workers,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=watch_parent,
                initargs=(os.getpid(),),
            )
            return ResolvedExecutor(
                pool,
                f"processes:{workers}",
                2 * workers,
                lambda: pool.shutdown(cancel_futures=True),
                task_threads=max(1, (os.cpu_count() or 1) // workers),
            )
        if spec.startswith(("dask://", "tcp://")):
            from distributed import Client

            address = "tcp://" + spec.split("://", 1)[1]
            try:
                client = Client(address, timeout="10s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise InvalidParameterError(
                    f"executor {spec!r}: cannot connect to the Dask scheduler at {address} "
                    f"({type(exc).__name__}: {exc}); check that it is running and reachable"
                ) from None
            return _from_client(client, spec, owned=True)
        raise InvalidParameterError(
            f"unknown executor {spec!r}; use 'inline', 'processes[:N]', 'dask://host:port', "
            "a distributed.Client or a concurrent.futures.Executor"
        )
    if hasattr(spec, "get_executor") and hasattr(spec, "scheduler_info"):
        return _from_client(spec, f"dask:{getattr(spec, 'scheduler', '')}", owned=False)
    if isinstance(spec, Executor):
        return ResolvedExecutor(spec, type(spec).__name__, 2 * _worker_count(spec), _nothing)
    raise InvalidParameterError(
        f"unknown executor {spec!r}; use 'inline', 'processes[:N]', 'dask://host:port', "
        "a distributed.Client or a concurrent.futures.Executor"
    )


def _task_threads(client: Any, workers: dict[str, Any]) -> int | None:
    """Kernel threads per task: each host's cores shared by the task threads it runs."""
    try:
        cores = client.run(os.cpu_count)  # {worker address: cores of its host}
    except Exception:  # an unreachable worker: leave Numba's default
        return None
    per_host: dict[str, int] = {}
    for info in workers.values():
        host = str(info.get("host", ""))
        per_host[host] = per_host.get(host, 0) + int(info.get("nthreads", 1))
    shares = [
        max(1, int(cores.get(address) or 1) // max(per_host[str(info.get("host", ""))], 1))
        for address, info in workers.items()
    ]
    return min(shares) if shares else None


def _from_client(client: Any, label: str, owned: bool) -> ResolvedExecutor:
    try:
        workers = dict(client.scheduler_info()["workers"])
        threads = sum(w.get("nthreads", 1) for w in workers.values())
    except Exception:  # scheduler_info layout differs across versions; a guess is fine here
        workers, threads = {}, 2
    executor = client.get_executor(pure=False)
    return ResolvedExecutor(
        executor,
        label,
        max(2, 2 * threads),
        client.close if owned else _nothing,
        task_threads=_task_threads(client, workers) if workers else None,
    )
