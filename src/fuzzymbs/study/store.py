"""Chunk store: a directory of per-chunk ``.npz`` files and a JSON manifest.

Each finished chunk is written atomically (temporary file, then ``os.replace``)
before the runner moves on, so a run killed at any moment leaves only whole
chunks behind and a rerun evaluates only the missing ones. Files hold data
only; they are read with ``allow_pickle=False``.

Layout::

    STORE/manifest.json        identity of the study, sample count, chunk size
    STORE/chunk-000000.npz     start, stop, failed, failure_reason, output__<name>
"""

from __future__ import annotations

import json
import logging
import math
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import StoreMismatchError
from fuzzymbs.study.evaluation import ChunkResult

logger = logging.getLogger(__name__)

FORMAT = "fuzzymbs-chunk-store"
VERSION = 1
_OUTPUT_PREFIX = "output__"


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


def _write_atomic(path: Path, write: Any) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with temporary.open("wb") as handle:
        write(handle)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(temporary, path)


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
    ) -> ChunkStore:
        """Create the store, or reopen it if it was made for the same study.

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
            If False, the chunks of a matching store are discarded.

        Raises
        ------
        StoreMismatchError
            If the directory holds a store of a different study (or not a store).
        """
        path = Path(path)
        identity = _normalised(identity)
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
            if differing or manifest.get("n_samples") != n_samples:
                raise StoreMismatchError(
                    f"store {path} belongs to a different study (differs in: "
                    f"{', '.join(differing) or 'n_samples'}); its chunks are not reused. "
                    "Delete the store directory or choose another one."
                )
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
            return store
        if path.exists() and any(path.glob("chunk-*.npz")):
            raise StoreMismatchError(
                f"store {path} has chunk files but no manifest.json; choose another directory"
            )
        path.mkdir(parents=True, exist_ok=True)
        manifest = {
            "format": FORMAT,
            "version": VERSION,
            "identity": identity,
            "n_samples": n_samples,
            "chunk_size": chunk_size,
        }
        _write_atomic(
            manifest_path,
            lambda handle: handle.write(json.dumps(manifest, indent=2, sort_keys=True).encode()),
        )
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
        _write_atomic(self.chunk_path(index), lambda handle: np.savez(handle, **arrays))

    def read(self, index: int) -> ChunkResult | None:
        """Load chunk ``index``, or None if it is missing or unreadable."""
        path = self.chunk_path(index)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                start, stop = int(data["start"]), int(data["stop"])
                outputs = {
                    key[len(_OUTPUT_PREFIX) :]: data[key]
                    for key in data.files
                    if key.startswith(_OUTPUT_PREFIX)
                }
                failed = data["failed"].astype(bool)
                reasons = data["failure_reason"].astype(str)
        except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
            logger.warning("stored chunk %s is unreadable (%s); it is evaluated again", path, exc)
            return None
        expected_start = index * self.chunk_size
        expected_stop = min(expected_start + self.chunk_size, self.n_samples)
        if (start, stop) != (expected_start, expected_stop) or failed.shape != (stop - start,):
            logger.warning("stored chunk %s has the wrong extent; it is evaluated again", path)
            return None
        return ChunkResult(start, stop, outputs, failed, reasons)

    def finished(self) -> list[int]:
        """Indices of the chunk files present (not yet validated)."""
        indices = []
        for chunk in self.path.glob("chunk-*.npz"):
            try:
                indices.append(int(chunk.stem.split("-")[1]))
            except ValueError:
                continue
        return sorted(indices)
