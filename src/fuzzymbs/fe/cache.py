"""On-disk cache of reduced bodies, keyed by a hash of every input.

A reduction (assembly + eigenproblem + inertia integrals) runs once per
distinct input. The key is a SHA-256 over the mesh arrays (node coordinates,
connectivity, mesh type), the material, the clamped nodes, the reduction
options and a format version; the value is a ``.npz`` file holding the
:class:`~fuzzymbs.mbs.modal_body.ModalBody` arrays (plain arrays, read with
``allow_pickle=False``: nothing is ever unpickled).

Location: ``$FUZZYMBS_CACHE_DIR/fe`` or ``~/.cache/fuzzymbs/fe``. Files are
written atomically (temporary file + rename), so concurrent workers never read
a half-written entry; an unreadable entry is ignored and recomputed.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.fe.reducible import ReducibleBody
from fuzzymbs.files import save_npz_atomically
from fuzzymbs.mbs.modal_body import ModalBody, StressStiffening

__all__ = ["cache_dir", "clear", "load", "reduction_key", "store"]

#: bump when the stored layout or the numerics of the reduction change
FORMAT_VERSION = 2

_ARRAY_FIELDS = (
    "node_ids",
    "node_positions",
    "mode_shapes",
    "frequencies",
    "first_moment",
    "inertia_tensor",
    "translation_coupling",
    "rotation_coupling",
    "gyroscopic",
    "centrifugal",
    "centrifugal_load",
)


def cache_dir() -> Path:
    """Directory of the FE cache (created on first store)."""
    root = os.environ.get("FUZZYMBS_CACHE_DIR")
    base = Path(root) if root else Path.home() / ".cache" / "fuzzymbs"
    return base / "fe"


def _update(digest: Any, value: Any) -> None:
    """Feed a value into the hash with its type and shape, so different inputs never collide."""
    if isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value)
        digest.update(f"ndarray{array.dtype.str}{array.shape}".encode())
        digest.update(array.tobytes())
    elif isinstance(value, Mapping):
        digest.update(f"dict{len(value)}".encode())
        for key in sorted(value):
            digest.update(str(key).encode())
            _update(digest, value[key])
    elif isinstance(value, list | tuple):
        digest.update(f"list{len(value)}".encode())
        for item in value:
            _update(digest, item)
    else:
        digest.update(json.dumps(value).encode())


def reduction_key(body: ReducibleBody, options: Mapping[str, Any]) -> str:
    """SHA-256 key of a reduction: mesh, material, clamping and options."""
    digest = hashlib.sha256()
    _update(
        digest,
        {
            "format": FORMAT_VERSION,
            "mesh_type": type(body.mesh).__name__,
            "doflocs": np.asarray(body.mesh.doflocs, dtype=np.float64),
            "t": np.asarray(body.mesh.t, dtype=np.int64),
            "material": [body.youngs_modulus, body.poisson_ratio, body.density],
            "fixed_nodes": body.fixed_nodes,
            "options": {
                k: (np.asarray(v) if isinstance(v, np.ndarray) else v) for k, v in options.items()
            },
        },
    )
    return digest.hexdigest()


def _path(key: str) -> Path:
    return cache_dir() / f"reduction-{key}.npz"


def store(key: str, body: ModalBody) -> Path:
    """Write a reduced body atomically; returns the file path."""
    directory = cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, np.ndarray] = {name: getattr(body, name) for name in _ARRAY_FIELDS}
    arrays["mass"] = np.asarray(body.mass)
    arrays["format"] = np.asarray(FORMAT_VERSION)
    for name, value in body.node_sets.items():
        arrays[f"node_set.{name}"] = value
    for name, value in body.face_sets.items():
        arrays[f"face_set.{name}"] = value
    if body.stress_stiffening is not None:
        arrays["stress_stiffening.acceleration"] = body.stress_stiffening.acceleration
        arrays["stress_stiffening.spin"] = body.stress_stiffening.spin
    return save_npz_atomically(_path(key), arrays)


def load(key: str, name: str) -> ModalBody | None:
    """The cached reduced body for ``key`` (renamed ``name``), or None if absent or unreadable."""
    path = _path(key)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            if int(data["format"]) != FORMAT_VERSION:
                return None
            fields = {field: np.array(data[field]) for field in _ARRAY_FIELDS}
            node_sets = {
                k.removeprefix("node_set."): np.array(data[k])
                for k in data.files
                if k.startswith("node_set.")
            }
            face_sets = {
                k.removeprefix("face_set."): np.array(data[k])
                for k in data.files
                if k.startswith("face_set.")
            }
            mass = float(data["mass"])
            stiffening = None
            if "stress_stiffening.spin" in data.files:
                stiffening = StressStiffening(
                    acceleration=np.array(data["stress_stiffening.acceleration"]),
                    spin=np.array(data["stress_stiffening.spin"]),
                )
    except Exception as error:  # corrupt or truncated entry: recompute
        warnings.warn(f"ignoring unreadable FE cache entry {path}: {error}", stacklevel=2)
        return None
    return ModalBody(
        name=name,
        mass=mass,
        node_sets=node_sets,
        face_sets=face_sets,
        stress_stiffening=stiffening,
        **fields,
    )


def clear() -> int:
    """Delete every cached reduction; returns the number of files removed."""
    directory = cache_dir()
    removed = 0
    if directory.is_dir():
        for path in directory.glob("reduction-*.npz"):
            path.unlink(missing_ok=True)
            removed += 1
    return removed
