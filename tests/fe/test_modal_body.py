"""The ModalBody produced by reduce_body and the on-disk cache."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import ElasticBody, box_mesh, mesh_nodes, nodes_in_region
from fuzzymbs.fe import cache as fe_cache
from fuzzymbs.fe.reduction import modal_truncation
from fuzzymbs.mbs.modal_body import ModalBody


def _pad_mesh():
    return box_mesh(0.06, 0.04, 0.015, 2, 2, 1)


def test_kept_nodes_carry_the_full_mode_shapes():
    mesh = _pad_mesh()
    body = ElasticBody(mesh, 10e9, 0.25, 2500.0, name="pad")
    reduced = body.reduce(5, node_sets={"contact": "bottom", "back": "top"}, cache=False)
    full = modal_truncation(body, 5)
    assert isinstance(reduced, ModalBody) and reduced.name == "pad"
    np.testing.assert_allclose(reduced.frequencies, full.frequencies)
    shapes = full.modes.reshape(body.n_nodes, 3, -1)[reduced.node_ids]
    # eigenvectors are defined up to sign (and rotation within repeated pairs): compare |.|
    np.testing.assert_allclose(np.abs(reduced.mode_shapes), np.abs(shapes), atol=1e-10)
    np.testing.assert_allclose(reduced.node_positions, mesh_nodes(mesh)[reduced.node_ids])
    assert reduced.node_sets["contact"].size == reduced.node_sets["back"].size == 25
    assert reduced.n_nodes == 50


def test_cache_second_call_loads_without_assembly(private_cache):
    mesh = _pad_mesh()
    contact = nodes_in_region(mesh, "bottom")
    options = {"method": "static", "interface": contact, "interface_components": (2,)}
    first = ElasticBody(mesh, 10e9, 0.25, 2500.0).reduce(4, **options)
    files = list((private_cache / "fe").glob("reduction-*.npz"))
    assert len(files) == 1
    again = ElasticBody(mesh, 10e9, 0.25, 2500.0, name="copy")
    second = again.reduce(4, **options)
    assert not again.is_assembled  # loaded from disk, no assembly or eigenproblem
    assert second.name == "copy"
    for field in ("frequencies", "mode_shapes", "gyroscopic", "centrifugal", "inertia_tensor"):
        np.testing.assert_array_equal(getattr(second, field), getattr(first, field))
    assert second.node_sets.keys() == first.node_sets.keys()
    # the file holds plain arrays only
    with np.load(files[0], allow_pickle=False) as data:
        assert "mode_shapes" in data.files


def test_cache_key_changes_with_every_input():
    mesh = _pad_mesh()
    body = ElasticBody(mesh, 10e9, 0.25, 2500.0)
    base = {"n_modes": 4, "method": "modal"}
    key = fe_cache.reduction_key(body, base)
    assert key == fe_cache.reduction_key(ElasticBody(mesh, 10e9, 0.25, 2500.0), base)
    assert key != fe_cache.reduction_key(body, {**base, "n_modes": 5})
    assert key != fe_cache.reduction_key(ElasticBody(mesh, 10e9, 0.25, 2501.0), base)
    assert key != fe_cache.reduction_key(ElasticBody(mesh, 10e9, 0.25, 2500.0, fixed="top"), base)
    moved = box_mesh(0.06, 0.04, 0.015, 2, 2, 1, origin=(0, 0, 1e-3))
    assert key != fe_cache.reduction_key(ElasticBody(moved, 10e9, 0.25, 2500.0), base)


def test_corrupt_cache_entry_is_recomputed(private_cache):
    mesh = _pad_mesh()
    reference = ElasticBody(mesh, 10e9, 0.25, 2500.0).reduce(3)
    (path,) = (private_cache / "fe").glob("reduction-*.npz")
    path.write_bytes(b"truncated")
    with pytest.warns(UserWarning, match="unreadable FE cache entry"):
        again = ElasticBody(mesh, 10e9, 0.25, 2500.0).reduce(3)
    np.testing.assert_allclose(again.frequencies, reference.frequencies, rtol=1e-12)
    assert fe_cache.clear() == 1


def test_reduce_body_errors():
    body = ElasticBody(_pad_mesh(), 10e9, 0.25, 2500.0)
    with pytest.raises(InvalidParameterError, match="method"):
        body.reduce(3, method="guyan")
    with pytest.raises(InvalidParameterError, match="interface"):
        body.reduce(3, method="craig_bampton")
    with pytest.raises(InvalidParameterError, match="face set"):
        body.reduce(3, face_sets={"bad": np.zeros((2, 5), dtype=int)})
    with pytest.raises(InvalidParameterError, match="max_frequency"):
        body.reduce(3, max_frequency=-1.0)
    with pytest.raises(InvalidParameterError, match="removes every mode"):
        body.reduce(3, max_frequency=1.0, cache=False)


def test_index_node_sets_keep_their_order():
    # spring pairs and polar grids rely on the order of explicit index arrays
    body = ElasticBody(_pad_mesh(), 10e9, 0.25, 2500.0)
    order = np.array([30, 2, 17, 5])
    reduced = body.reduce(3, node_sets={"pairs": order, "top": "top"}, cache=False)
    np.testing.assert_array_equal(reduced.node_ids[reduced.node_sets["pairs"]], order)
    assert np.all(np.diff(reduced.node_ids[reduced.node_sets["top"]]) > 0)
    with pytest.raises(InvalidParameterError, match="repeat"):
        body.reduce(3, node_sets={"pairs": [1, 1]}, cache=False)


def test_mode_signs_are_deterministic():
    # the largest-magnitude entry of every full-DOF mode is positive
    body = ElasticBody(_pad_mesh(), 10e9, 0.25, 2500.0)
    modes = modal_truncation(body, 5).modes
    largest = modes[np.argmax(np.abs(modes), axis=0), np.arange(5)]
    assert np.all(largest > 0)
