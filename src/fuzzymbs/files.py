"""Files written so that a reader never sees half of one."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

__all__ = ["save_npz_atomically"]


def save_npz_atomically(path: Path, arrays: Mapping[str, np.ndarray]) -> Path:
    """Write ``arrays`` as ``path`` (.npz) through a temporary file in the same folder and
    an atomic rename: a concurrent reader (another worker filling the same cache) sees
    the old file or the whole new one; an interrupted write leaves no partial file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".npz.tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            np.savez(stream, **arrays)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return path
