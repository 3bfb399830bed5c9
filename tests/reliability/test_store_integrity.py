"""A stored chunk is used only if it is what was computed; a store never mixes code.

Tampered, truncated and empty chunks are evaluated again (with a warning) and
the result equals a clean run; temporary files of a writer that died (a full
disk, a kill) are removed; an edited user model never reuses the old chunks.
"""

import errno
import importlib
import logging
import os
import subprocess
import sys

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.errors import StoreMismatchError
from fuzzymbs.study import store as store_module
from fuzzymbs.study.study import Study

PARAMETERS = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}


class Counting:
    """z = x1 * x2, counting the samples it evaluates."""

    def __init__(self):
        self.samples = 0

    def __call__(self, samples):
        self.samples += len(samples["x1"])
        return {"z": samples["x1"] * samples["x2"]}


def _study(model):
    return Study(model, PARAMETERS, levels=2, validation_runs=0)  # 9 samples


def _bounds(result):
    return result.dataset["z_lower"].values, result.dataset["z_upper"].values


@pytest.fixture
def stored(tmp_path):
    """A store of the 9-sample study in chunks of 3, and the clean result's bounds."""
    clean = _study(Counting()).run(store=tmp_path, chunk_size=3, progress=False)
    return tmp_path, _bounds(clean)


def test_tampered_chunk_values_are_recomputed_with_a_warning(stored, caplog):
    path, clean = stored
    chunk = path / "chunk-000001.npz"
    with np.load(chunk, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    arrays["output__z"] = arrays["output__z"] * 100.0  # values overwritten, digest kept
    np.savez(chunk, **arrays)
    model = Counting()
    with caplog.at_level(logging.WARNING, logger="fuzzymbs.study.store"):
        again = _study(model).run(store=path, chunk_size=3, progress=False)
    assert model.samples == 3  # only the tampered chunk
    assert "digest does not match" in caplog.text
    np.testing.assert_array_equal(_bounds(again)[0], clean[0])
    np.testing.assert_array_equal(_bounds(again)[1], clean[1])


@pytest.mark.parametrize("damage", ["empty", "truncated"])
def test_empty_or_truncated_chunk_never_blocks_resume(stored, damage):
    path, clean = stored
    chunk = path / "chunk-000002.npz"
    chunk.write_bytes(b"" if damage == "empty" else chunk.read_bytes()[:40])
    model = Counting()
    again = _study(model).run(store=path, chunk_size=3, progress=False)
    assert model.samples == 3
    np.testing.assert_array_equal(_bounds(again)[1], clean[1])


def test_chunk_without_a_digest_is_not_trusted(stored):
    path, _ = stored
    chunk = path / "chunk-000000.npz"
    with np.load(chunk, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files if key != "digest"}
    np.savez(chunk, **arrays)
    model = Counting()
    _study(model).run(store=path, chunk_size=3, progress=False)
    assert model.samples == 3


def test_failed_write_leaves_no_temporary_file(tmp_path, monkeypatch):
    """A full disk, simulated by a writer that fails half way."""

    def full_disk(handle, **arrays):
        handle.write(b"PK partial")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(store_module.np, "savez", full_disk)
    with pytest.raises(OSError, match="No space left"):
        _study(Counting()).run(store=tmp_path, chunk_size=3, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["manifest.json"]


def test_temporary_files_of_an_ended_writer_are_removed_on_the_next_run(tmp_path):
    _study(Counting()).run(store=tmp_path, chunk_size=3, progress=False)
    ended = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    dead_pid = int(ended.stdout)
    orphan = tmp_path / f".chunk-000001.npz.{dead_pid}.abc123.tmp"
    orphan.write_bytes(b"partial")
    alive = tmp_path / f".chunk-000002.npz.{os.getppid()}.def456.tmp"  # a running writer
    alive.write_bytes(b"partial")
    _study(Counting()).run(store=tmp_path, chunk_size=3, progress=False)
    assert not orphan.exists() and alive.exists()


def test_edited_user_model_does_not_reuse_old_chunks(tmp_path, monkeypatch):
    module = tmp_path / "user_model_edit.py"
    module.write_text("def model(s):\n    return {'z': s['x1'] * s['x2']}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    loaded = importlib.import_module("user_model_edit")
    store = tmp_path / "store"
    _study(loaded.model).run(store=store, progress=False)
    module.write_text("def model(s):\n    return {'z': 2 * s['x1'] * s['x2']}\n")
    importlib.reload(loaded)
    with pytest.raises(StoreMismatchError, match="model's source code changed"):
        _study(loaded.model).run(store=store, progress=False)
    fresh = _study(loaded.model).run(store=store, progress=False, resume=False)
    assert fresh.dataset["z_upper"].values[0] == pytest.approx(2 * 3 * 11)
