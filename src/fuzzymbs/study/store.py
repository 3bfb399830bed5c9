"""Chunk store: a directory of per-chunk ``.npz`` files and a JSON manifest.

Each finished chunk is written atomically (a temporary file of a name no other
writer uses, then ``os.replace``) before the runner moves on, so a run killed
at any moment leaves only whole chunks behind and a rerun evaluates only the
missing ones; the temporary files of a writer that died (a full disk, a kill)
are removed when the store is opened again. Files hold data only; they are
read with ``allow_pickle=False``.

Each chunk carries the SHA-256 of its arrays (``digest``), checked when it is
read: a chunk that is truncated, empty, unreadable or was altered is never
used; it is evaluated again, with a warning.

Layout::

    STORE/manifest.json        identity of the study, code version, sample count, chunk size
    STORE/chunk-000000.npz     start, stop, failed, failure_reason, output__<name>, digest
                               (and gradient__<name> where the model was asked for them)

The manifest's ``code`` record (fuzzymbs version, model source digest, see
:mod:`fuzzymbs.study.code_version`) keeps chunks of different code apart: a
store written by other code is only reopened with ``resume=False``, which
discards its chunks and records the running code.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError, StoreMismatchError
from fuzzymbs.study.evaluation import ChunkResult

logger = logging.getLogger(__name__)

FORMAT = "fuzzymbs-chunk-store"
VERSION = 1
_OUTPUT_PREFIX = "output__"
#: prefix of coordinate arrays a model returned while running (e.g. an external program's time)
_COORD_PREFIX = "coord__"
#: prefix of the gradients of an output (a chunk of a study that asked for them): a resumed
#: run gets them back with the outputs
_GRADIENT_PREFIX = "gradient__"


def json_safe(value: Any) -> Any:
    """Plain JSON data: NaN and infinities become the strings "nan", "inf", "-inf".

    NaN is a legitimate parameter default (e.g. "not set"), but NaN != NaN would
    make two identical study identities compare unequal, and strict JSON has no NaN.
    """
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    return value


def _normalised(value: Any) -> Any:
    """JSON round trip, so identities compare equal to what a manifest holds."""
    return json.loads(json.dumps(json_safe(value), sort_keys=True, allow_nan=False))


def _describe_code(code: Any) -> str:
    """E.g. "fuzzymbs 0.1.0, model source 3f2a9c0b1d4e" (digest shortened to 12 hex digits)."""
    code = code if isinstance(code, dict) else {}
    digest = code.get("model_source")
    source = f"model source {digest[:12]}" if isinstance(digest, str) else "no model source digest"
    return f"fuzzymbs {code.get('fuzzymbs_version', 'unknown')}, {source}"


def _code_mismatch(path: Path, stored: Any, running: dict[str, Any]) -> str:
    """Message for a store whose chunks were computed by other code."""
    stored = stored if isinstance(stored, dict) else {}
    changed = []
    if stored.get("fuzzymbs_version") != running.get("fuzzymbs_version"):
        changed.append("the fuzzymbs version")
    if stored.get("model_source") != running.get("model_source"):
        changed.append("the model's source code")
    what = " and ".join(changed) or "its code record"
    return (
        f"store {path} holds chunks computed by other code ({what} changed): "
        f"stored chunks by {_describe_code(stored)}; this run is {_describe_code(running)}. "
        "Results of different code are not mixed: rerun with resume=False (CLI: --fresh) "
        "to discard the stored chunks and recompute them in this directory, or choose a "
        "new store directory to keep the old ones."
    )


_DIGEST_KEY = "digest"
_TEMPORARY_SUFFIX = ".tmp"


def chunk_digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 (hex) of a chunk's arrays: names, dtypes, shapes and bytes, in name order."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        values = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}\0{values.dtype.str}\0{values.shape}\0".encode())
        digest.update(values.tobytes())
    return digest.hexdigest()


def _write_atomic(path: Path, write: Any) -> None:
    """Write ``path`` through a temporary file no other writer uses, then rename it.

    The temporary name holds the writer's process id (``.NAME.PID.RANDOM.tmp``),
    so that :func:`remove_orphans` knows whether its writer still runs; a failed
    write (a full disk) removes its temporary file.
    """
    handle_fd, name = tempfile.mkstemp(
        prefix=f".{path.name}.{os.getpid()}.", suffix=_TEMPORARY_SUFFIX, dir=path.parent
    )
    temporary = Path(name)
    try:
        with os.fdopen(handle_fd, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def _process_alive(pid: int) -> bool:
    if os.name != "posix":  # os.kill(pid, 0) would end the process on Windows: keep the file
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def remove_orphans(folder: Path) -> int:
    """Remove the temporary files in ``folder`` whose writing process has ended.

    Returns the number removed. Files of running writers (another run, or this
    process) are left alone.
    """
    removed = 0
    for temporary in folder.glob(f".*{_TEMPORARY_SUFFIX}"):
        parts = temporary.name.split(".")
        pid = next((int(part) for part in parts[2:-1] if part.isdigit()), None)
        if pid is None or pid == os.getpid() or _process_alive(pid):
            continue
        try:
            temporary.unlink()
            removed += 1
        except OSError:
            continue
    if removed:
        logger.info("removed %d temporary files left by an ended run in %s", removed, folder)
    return removed


def _write_manifest(path: Path, manifest: dict[str, Any]) -> None:
    text = json.dumps(manifest, indent=2, sort_keys=True)
    _write_atomic(path, lambda handle: handle.write(text.encode()))


class ChunkStore:
    """A directory holding the finished chunks of one study.

    Use :meth:`open` to create or reopen one.
    """

    def __init__(self, path: Path, identity: dict[str, Any], n_samples: int, chunk_size: int):
        self.path = path
        self.identity = identity
        self.n_samples = n_samples
        self.chunk_size = chunk_size

    @classmethod
    def open(
        cls,
        path: str | Path,
        identity: dict[str, Any],
        n_samples: int,
        chunk_size: int,
        resume: bool = True,
        code: dict[str, Any] | None = None,
    ) -> ChunkStore:
        """Create the store, or reopen it if it was made for the same study and code.

        Parameters
        ----------
        path : str or Path
            Store directory (created if missing).
        identity : dict
            JSON-able identity of the study (plan fingerprint, model, options, ...).
        n_samples : int
            Number of samples of the plan.
        chunk_size : int
            Samples per chunk for a new store; a reopened store keeps its own.
        resume : bool
            If False, the chunks of a matching store are discarded (also when they
            were computed by other code; the manifest then records ``code``).
        code : dict, optional
            What code computes the chunks, e.g. ``{"fuzzymbs_version": "0.1.0",
            "model_source": "<sha256>" or None}``; default: the running fuzzymbs
            version only. A store without this record (written before it existed)
            is reopened with a warning and gets the record.

        Raises
        ------
        StoreMismatchError
            If the directory holds a store of a different study (or not a store),
            or, with ``resume=True``, chunks computed by other code (the message
            names both code versions).
        """
        from fuzzymbs.study.code_version import fuzzymbs_version

        path = Path(path)
        identity = _normalised(identity)
        code = _normalised(code if code is not None else {"fuzzymbs_version": fuzzymbs_version()})
        manifest_path = path / "manifest.json"
        if manifest_path.exists():
            try:
                manifest = json.loads(manifest_path.read_text())
            except (OSError, json.JSONDecodeError) as exc:
                raise StoreMismatchError(
                    f"store {path}: manifest.json is unreadable ({exc}); "
                    "delete the directory or choose another store"
                ) from None
            if manifest.get("format") != FORMAT or manifest.get("version") != VERSION:
                raise StoreMismatchError(
                    f"store {path}: not a {FORMAT} version {VERSION} store; "
                    "choose another directory"
                )
            stored = manifest.get("identity", {})
            differing = sorted(
                key for key in set(stored) | set(identity) if stored.get(key) != identity.get(key)
            )
            stored_code = manifest.get("code")
            if differing or manifest.get("n_samples") != n_samples:
                also = (
                    f" It was also written by other code ({_describe_code(stored_code)}; "
                    f"this run is {_describe_code(code)})."
                    if stored_code is not None and stored_code != code
                    else ""
                )
                raise StoreMismatchError(
                    f"store {path} belongs to a different study (differs in: "
                    f"{', '.join(differing) or 'n_samples'}); its chunks are not reused. "
                    f"Delete the store directory or choose another one.{also}"
                )
            if stored_code is None:
                logger.warning(
                    "store %s does not record the code that computed its chunks (written "
                    "before fuzzymbs recorded it); assuming %s",
                    path,
                    _describe_code(code),
                )
            elif stored_code != code:
                if resume:
                    raise StoreMismatchError(_code_mismatch(path, stored_code, code))
                logger.info(
                    "store %s: discarding chunks computed by %s (resume=False)",
                    path,
                    _describe_code(stored_code),
                )
            remove_orphans(path)
            store = cls(path, identity, n_samples, int(manifest["chunk_size"]))
            if store.chunk_size != chunk_size:
                logger.info(
                    "store %s keeps its chunk size %d (requested %d)",
                    path,
                    store.chunk_size,
                    chunk_size,
                )
            if not resume:
                store.clear()
            if stored_code != code:  # record the code that computes the chunks from now on
                manifest["code"] = code
                _write_manifest(manifest_path, manifest)
            return store
        if path.exists() and any(path.glob("chunk-*.npz")):
            raise StoreMismatchError(
                f"store {path} has chunk files but no manifest.json; choose another directory"
            )
        path.mkdir(parents=True, exist_ok=True)
        remove_orphans(path)
        manifest = {
            "format": FORMAT,
            "version": VERSION,
            "identity": identity,
            "code": code,
            "n_samples": n_samples,
            "chunk_size": chunk_size,
        }
        _write_manifest(manifest_path, manifest)
        return cls(path, identity, n_samples, chunk_size)

    def chunk_path(self, index: int) -> Path:
        return self.path / f"chunk-{index:06d}.npz"

    def clear(self) -> None:
        """Remove every stored chunk (the manifest stays)."""
        for chunk in self.path.glob("chunk-*.npz"):
            chunk.unlink()

    def write(self, index: int, chunk: ChunkResult) -> None:
        """Store chunk ``index`` atomically."""
        arrays = {
            "start": np.array(chunk.start),
            "stop": np.array(chunk.stop),
            "failed": np.asarray(chunk.failed, dtype=bool),
            "failure_reason": np.asarray(chunk.reasons, dtype=str),
        }
        for name, values in chunk.outputs.items():
            arrays[_OUTPUT_PREFIX + name] = values
        for dim, values in chunk.coords.items():
            arrays[_COORD_PREFIX + dim] = values
        for name, values in chunk.gradients.items():
            arrays[_GRADIENT_PREFIX + name] = values
        arrays[_DIGEST_KEY] = np.array(chunk_digest(arrays))
        _write_atomic(self.chunk_path(index), lambda handle: np.savez(handle, **arrays))

    def read(self, index: int) -> ChunkResult | None:
        """Load chunk ``index``, or None if it is missing or unreadable."""
        path = self.chunk_path(index)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {key: data[key] for key in data.files}
            stored_digest = str(arrays.pop(_DIGEST_KEY))
            if stored_digest != chunk_digest(arrays):
                raise ValueError("its digest does not match its contents (altered or damaged)")
            start, stop = int(arrays["start"]), int(arrays["stop"])
            outputs = {
                key[len(_OUTPUT_PREFIX) :]: values
                for key, values in arrays.items()
                if key.startswith(_OUTPUT_PREFIX)
            }
            coords = {
                key[len(_COORD_PREFIX) :]: values
                for key, values in arrays.items()
                if key.startswith(_COORD_PREFIX)
            }
            gradients = {
                key[len(_GRADIENT_PREFIX) :]: values
                for key, values in arrays.items()
                if key.startswith(_GRADIENT_PREFIX)
            }
            failed = arrays["failed"].astype(bool)
            reasons = arrays["failure_reason"].astype(str)
        except KeyError as exc:
            logger.warning(
                "stored chunk %s lacks %s (damaged, or written without a digest); it is "
                "evaluated again",
                path,
                exc,
            )
            return None
        except Exception as exc:  # any damage (empty, truncated, not a zip): never used
            logger.warning("stored chunk %s is unreadable (%s); it is evaluated again", path, exc)
            return None
        expected_start = index * self.chunk_size
        expected_stop = min(expected_start + self.chunk_size, self.n_samples)
        if (start, stop) != (expected_start, expected_stop) or failed.shape != (stop - start,):
            logger.warning("stored chunk %s has the wrong extent; it is evaluated again", path)
            return None
        return ChunkResult(start, stop, outputs, failed, reasons, coords, gradients)

    def finished(self) -> list[int]:
        """Indices of the chunk files present (not yet validated)."""
        indices = []
        for chunk in self.path.glob("chunk-*.npz"):
            try:
                indices.append(int(chunk.stem.split("-")[1]))
            except ValueError:
                continue
        return sorted(indices)


def open_chunks(
    store: str | Path | None,
    identity: dict[str, Any],
    count: int,
    size: int,
    resume: bool,
    code: dict[str, Any] | None,
    load: bool = True,
) -> tuple[ChunkStore | None, int, int, dict[int, ChunkResult], list[int], int]:
    """Open (or skip, without ``store``) the chunk store of a table of ``count`` samples.

    Returns the store (or None), the chunk size in force (a resumed store keeps
    its own), the chunk count, the chunks already stored, the missing chunk
    indices and the number of samples reused. ``load=False``: the stored chunks
    are checked but kept without their outputs (read again when needed).
    """
    chunk_store = None
    if store is not None:
        chunk_store = ChunkStore.open(store, identity, count, size, resume=resume, code=code)
        size = chunk_store.chunk_size
    chunk_count = math.ceil(count / size)
    results = stored_chunks(chunk_store, chunk_count, load)
    missing = [i for i in range(chunk_count) if i not in results]
    reused = sum(results[i].size for i in results)
    return chunk_store, size, chunk_count, results, missing, reused


def stored_chunks(
    chunk_store: ChunkStore | None, chunk_count: int, load: bool = True
) -> dict[int, ChunkResult]:
    """The readable chunks ``0 .. chunk_count - 1`` of a store (none without one);
    without ``load``, without their outputs."""
    results: dict[int, ChunkResult] = {}
    if chunk_store is not None:
        for index in chunk_store.finished():
            if index < chunk_count:
                stored = chunk_store.read(index)
                if stored is not None:
                    results[index] = stored if load else stored.without_outputs()
    return results


def read_outputs(
    store: str | Path, outputs: list[str] | None = None
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Every sample's outputs from a study's chunk store (``OUT/chunks`` of ``fuzzymbs run``).

    A study keeps only the reduced outputs in memory (and in result.nc above a
    size, see :data:`fuzzymbs.study.streaming.RAW_LIMIT_BYTES`); the chunks keep
    every sample. This reads them back, in sample order.

    Returns
    -------
    outputs : dict of str to (N, ...) ndarray
        NaN rows for failed samples.
    failed : (N,) bool

    Raises
    ------
    InvalidParameterError
        No manifest (not a chunk store), or chunks missing (an unfinished run).
    """
    path = Path(store)
    manifest_path = path / "manifest.json"
    if not manifest_path.is_file():
        raise InvalidParameterError(f"{path} is not a chunk store (no manifest.json)")
    manifest = json.loads(manifest_path.read_text())
    count, size = int(manifest["n_samples"]), int(manifest["chunk_size"])
    chunk_store = ChunkStore(path, manifest.get("identity", {}), count, size)
    chunk_count = math.ceil(count / size)
    failed = np.zeros(count, dtype=bool)
    merged: dict[str, np.ndarray] = {}
    for index in range(chunk_count):
        chunk = chunk_store.read(index)
        if chunk is None:
            raise InvalidParameterError(
                f"{path}: chunk {index} of {chunk_count} is missing; finish the run first"
            )
        failed[chunk.start : chunk.stop] = chunk.failed
        for name, values in chunk.outputs.items():
            if outputs is not None and name not in outputs:
                continue
            if name not in merged:
                merged[name] = np.full((count, *values.shape[1:]), np.nan)
            merged[name][chunk.start : chunk.stop] = values
    return merged, failed
