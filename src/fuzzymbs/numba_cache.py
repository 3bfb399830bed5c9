"""Drop Numba's cached kernels when a source file they may have compiled in changed.

Numba keys a cached function by its own source file only: a kernel that calls a
function of another module keeps that function's old machine code when only the
other module changes (numba/numba#1833; "Cache invalidation fails to recognize changes
in functions defined in a different file", Numba's documentation). After a ``git
pull`` or ``git checkout`` in an editable install, a kernel could so run with an old
helper: wrong numbers, or writes past an array sized by the new code (seen: an
enlarged work array, its old allocation compiled into a caller: ``free(): invalid
size``). A release installed by pip rewrites every file, so Numba's own check
suffices there.

:func:`drop_stale_kernel_caches` runs once per process when :mod:`fuzzymbs` is
imported. It keeps, beside the cache, the size and modification time of every source
file of the package; where a file that holds cached kernels (``cache=True``) changed,
appeared or went, it deletes every cached kernel of the package in that cache, so that
each is compiled again from the current sources. Other edits only update the record.
It costs about 3 ms (one ``stat`` per file) and never imports Numba unless it
deletes under ``NUMBA_CACHE_DIR``. A cache it cannot write is left to Numba.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
from collections.abc import Iterator
from pathlib import Path

__all__ = ["drop_stale_kernel_caches"]

#: what marks a source file that holds cached kernels: a jit or cfunc with cache=True
CACHED_KERNEL = re.compile(rb"(?:jit|cfunc)\([^)]*cache=True")
#: Numba's index and data files
CACHE_SUFFIXES = (".nbi", ".nbc")


def drop_stale_kernel_caches(
    package_dir: Path | None = None, cache_dir: str | os.PathLike | None = None
) -> bool:
    """Delete the package's cached kernels if a file with cached kernels changed.

    Parameters
    ----------
    package_dir : the package's folder (default: this package's).
    cache_dir : Numba's ``NUMBA_CACHE_DIR`` (default: the environment's); None or ""
        for the caches in the sources' ``__pycache__`` folders.

    Returns
    -------
    True where cached kernels were deleted (or none existed yet to check against).
    """
    # the folder as Numba names it (os.path.abspath, not a resolved path)
    package = Path(package_dir or Path(os.path.abspath(__file__)).parent)
    if cache_dir is None:
        cache_dir = os.environ.get("NUMBA_CACHE_DIR", "")
    root = Path(cache_dir) if cache_dir else package / "__pycache__"
    digest = hashlib.sha1(str(package).encode()).hexdigest()[:12]
    record_path = root / f"fuzzymbs-kernel-sources-{digest}.json"
    try:
        root.mkdir(parents=True, exist_ok=True)
        with _locked(root / f"fuzzymbs-kernel-sources-{digest}.lock"):
            sources = _source_stats(package)
            recorded = _read_record(record_path)
            stale = _kernels_changed(package, sources, recorded)
            if stale:
                _delete_caches(package, sources, cache_dir)
            if stale or sources != recorded.get("sources"):
                kernels = sorted(p for p in sources if _holds_kernels(package / p))
                _write_record(record_path, {"sources": sources, "kernels": kernels})
            return stale
    except OSError:
        return False  # a cache we cannot write: Numba falls back to its own


def _source_stats(package: Path) -> dict[str, list[int]]:
    """``{relative path: [size, mtime_ns]}`` of every ``.py`` file of the package."""
    stats = {}
    for folder, subfolders, files in os.walk(package):
        subfolders[:] = [name for name in subfolders if name != "__pycache__"]
        relative = Path(folder).relative_to(package)
        for name in files:
            if name.endswith(".py"):
                info = os.stat(os.path.join(folder, name))
                stats[(relative / name).as_posix()] = [info.st_size, info.st_mtime_ns]
    return stats


def _kernels_changed(package: Path, sources: dict, recorded: dict) -> bool:
    """Whether a file with cached kernels changed, appeared or went since the record
    (no record: True, the caches' sources are unknown)."""
    if "sources" not in recorded:
        return True
    old, kernels = recorded["sources"], set(recorded.get("kernels", ()))
    for path in set(old) | set(sources):
        if old.get(path) == sources.get(path):
            continue
        if path in kernels or (path in sources and _holds_kernels(package / path)):
            return True
    return False


def _holds_kernels(path: Path) -> bool:
    try:
        return CACHED_KERNEL.search(path.read_bytes()) is not None
    except OSError:
        return False


def _delete_caches(package: Path, sources: dict, cache_dir: str | os.PathLike) -> None:
    """Delete Numba's cached files of every folder holding the package's ``sources``."""
    folders = {package / Path(p).parent for p in sources}
    if cache_dir:
        from numba.core.caching import UserProvidedCacheLocator

        targets = [
            Path(cache_dir) / UserProvidedCacheLocator.get_suitable_cache_subpath(str(f / "x.py"))
            for f in folders
        ]
    else:
        targets = [f / "__pycache__" for f in folders]
    for target in targets:
        if not target.is_dir():
            continue
        for entry in target.iterdir():
            if entry.suffix in CACHE_SUFFIXES:
                with contextlib.suppress(FileNotFoundError):
                    entry.unlink()


def _read_record(path: Path) -> dict:
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return record if isinstance(record, dict) else {}


def _write_record(path: Path, record: dict) -> None:
    partial = path.with_suffix(f".{os.getpid()}.tmp")
    partial.write_text(json.dumps(record))
    partial.replace(path)  # atomic: a reader sees the old record or the new one


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` where the system has ``fcntl`` (processes that
    start together, such as pytest-xdist's, check one after the other)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
