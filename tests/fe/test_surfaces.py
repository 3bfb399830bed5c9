"""Boundary faces, contact regions and face shape functions."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import (
    ElasticBody,
    annulus_mesh,
    boundary_faces,
    box_mesh,
    face_shape_functions,
    faces_in_region,
    mesh_nodes,
    nodes_in_region,
)

# local coordinates of the face nodes in the documented order (fuzzymbs.fe.surfaces)
QUAD9 = [(-1, -1), (1, -1), (1, 1), (-1, 1), (0, -1), (1, 0), (0, 1), (-1, 0), (0, 0)]
TRI6 = [(0, 0), (1, 0), (0, 1), (0.5, 0), (0.5, 0.5), (0, 0.5)]


@pytest.mark.parametrize(
    ("n_nodes", "points"), [(4, QUAD9[:4]), (9, QUAD9), (3, TRI6[:3]), (6, TRI6)]
)
def test_shape_functions_interpolate_nodes_and_sum_to_one(n_nodes, points):
    # Lagrange property N_k(x_j) = delta_kj, and partition of unity at random points
    xi, eta = np.array(points, dtype=float).T
    np.testing.assert_allclose(face_shape_functions(xi, eta, n_nodes), np.eye(n_nodes), atol=1e-15)
    rng = np.random.default_rng(1)
    sample = rng.uniform(0.0, 0.5, size=(2, 20))
    np.testing.assert_allclose(face_shape_functions(*sample, n_nodes).sum(axis=-1), 1.0)


def test_faces_are_ordered_and_oriented_outwards():
    # outward unit normals of the box faces and of the annulus' curved outer face
    box = box_mesh(0.1, 0.1, 0.02, 2, 2, 1)
    nodes = mesh_nodes(box)
    for name, normal in (("top", [0, 0, 1]), ("bottom", [0, 0, -1]), ("left", [-1, 0, 0])):
        faces = boundary_faces(box, name)
        x = nodes[faces]
        computed = np.cross(x[:, 1] - x[:, 0], x[:, 3] - x[:, 0])
        computed /= np.linalg.norm(computed, axis=1, keepdims=True)
        np.testing.assert_allclose(computed, np.broadcast_to(normal, computed.shape), atol=1e-14)
        # the 9-node interpolation reproduces every face node (mid-edges, centre)
        shape = face_shape_functions(*np.array(QUAD9, dtype=float).T, 9)
        np.testing.assert_allclose(np.einsum("pk,fkd->fpd", shape, x), x, atol=1e-15)
    disc = annulus_mesh(0.1, 0.2, 0.01, 2, 16, 1)
    faces = boundary_faces(disc, "outer")
    x = mesh_nodes(disc)[faces]
    centre = x[:, 8]
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 3] - x[:, 0])
    radial = centre * [1, 1, 0]
    assert np.all(np.einsum("fd,fd->f", normal, radial) > 0)


def test_pad_face_has_a_five_by_five_contact_grid():
    # brake pad: 2 x 2 quadratic elements on the friction face give 25 contact nodes
    pad = box_mesh(0.06, 0.04, 0.015, 2, 2, 1)
    contact = nodes_in_region(pad, "bottom")
    assert contact.size == 25
    x = mesh_nodes(pad)[contact]
    assert np.unique(np.round(x[:, 0], 12)).size == 5 and np.unique(np.round(x[:, 1], 12)).size == 5
    assert faces_in_region(pad, "bottom").shape == (4, 9)


def test_disc_contact_patch_of_48_nodes_in_an_annular_sector():
    # disc patch: linear mesh (order 1), 4 radial x 12 circumferential nodes = 48 nodes,
    # with the 3 x 11 faces between them for master-surface interpolation
    disc = annulus_mesh(0.1, 0.2, 0.01, 6, 72, 1, order=1)

    def sector(x):
        radius, angle = np.hypot(x[0], x[1]), np.arctan2(x[1], x[0])
        return (radius >= 0.15 * (1 - 1e-9)) & (angle >= -1e-9) & (angle <= 11 * np.pi / 36 + 1e-9)

    patch = nodes_in_region(disc, "top", sector)
    assert patch.size == 48
    faces = faces_in_region(disc, "top", sector)
    assert faces.shape == (33, 4)
    assert set(np.unique(faces)) == set(patch)
    body = ElasticBody(disc, 210e9, 0.3, 7850.0, fixed="inner", name="disc")
    reduced = body.reduce(6, node_sets={"patch": patch}, face_sets={"patch": faces})
    # kept nodes = the patch; sets index into them and give back the mesh positions
    assert reduced.n_nodes == 48
    np.testing.assert_array_equal(reduced.node_ids[reduced.node_sets["patch"]], patch)
    np.testing.assert_allclose(
        reduced.node_positions[reduced.face_sets["patch"]], mesh_nodes(disc)[faces]
    )
    assert reduced.mode_shapes.shape == (48, 3, 6)


def test_region_errors():
    pad = box_mesh(0.06, 0.04, 0.015, 1, 1, 1)
    with pytest.raises(InvalidParameterError, match="unknown boundary"):
        nodes_in_region(pad, "friction")
    with pytest.raises(InvalidParameterError, match="one boolean per node"):
        nodes_in_region(pad, "top", lambda x: np.array([True]))
    with pytest.raises(InvalidParameterError, match="n_nodes"):
        face_shape_functions(0.0, 0.0, 8)
