"""Files written so that a reader never sees half of one."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import BinaryIO

import numpy as np

__all__ = ["save_npz_atomically", "write_bytes_atomically"]


def _write_atomically(path: Path, suffix: str, write: Callable[[BinaryIO], object]) -> Path:
    """``write(stream)`` into a temporary file beside ``path`` (a hidden name), then an
    atomic rename to ``path``: a concurrent reader sees the old file or the whole new
    one; an interrupted write leaves no partial file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=suffix)
    try:
        with os.fdopen(handle, "wb") as stream:
            write(stream)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return path


def save_npz_atomically(path: Path, arrays: Mapping[str, np.ndarray]) -> Path:
    """Write ``arrays`` as ``path`` (.npz) atomically (another worker filling the same
    cache sees the old file or the whole new one)."""
    return _write_atomically(path, ".npz.tmp", lambda stream: np.savez(stream, **arrays))


def write_bytes_atomically(path: Path, data: bytes) -> Path:
    """Write ``data`` as ``path`` atomically."""
    return _write_atomically(path, ".tmp", lambda stream: stream.write(data))
