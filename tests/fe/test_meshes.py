"""Structured meshes, named boundaries and mesh import."""

from __future__ import annotations

import meshio
import numpy as np
import pytest
from skfem import Basis, ElementHex1, ElementHex2, MeshHex1, MeshHex2
from skfem.io.meshio import to_meshio

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import (
    ElasticBody,
    annulus_mesh,
    box_mesh,
    bridge_mesh,
    mesh_nodes,
    read_mesh,
    transform_mesh,
)


def _volume(mesh) -> float:
    element = ElementHex2() if isinstance(mesh, MeshHex2) else ElementHex1()
    return float(Basis(mesh, element).dx.sum())


def test_annulus_nodes_lie_on_exact_circles_and_volume_converges():
    a, b, h = 0.1, 0.2, 0.01
    mesh = annulus_mesh(a, b, h, 4, 32, 2)
    radius = np.hypot(*mesh_nodes(mesh)[:, :2].T)
    grid = np.linspace(a, b, 9)  # 4 quadratic elements: 9 node radii
    assert np.abs(radius[:, None] - grid[None, :]).min(axis=1).max() < 1e-15
    # closed form pi (b^2 - a^2) h; isoparametric error ~ (element angle)^4, measured -3.1e-6
    assert _volume(mesh) == pytest.approx(np.pi * (b**2 - a**2) * h, rel=5e-6)
    assert {len(mesh.boundaries[k]) for k in ("inner", "outer")} == {32 * 2}
    assert len(mesh.boundaries["top"]) == len(mesh.boundaries["bottom"]) == 4 * 32
    # full disc is closed: no boundary facet other than inner/outer/top/bottom
    named = np.concatenate([mesh.boundaries[k] for k in ("inner", "outer", "top", "bottom")])
    assert np.array_equal(np.sort(named), np.sort(mesh.boundary_facets()))


def test_annular_sector_and_axis_rotation():
    a, b, h = 0.1, 0.2, 0.01
    mesh = annulus_mesh(a, b, h, 2, 6, 1, angle_range=(0.0, np.pi / 3), axis="y")
    assert isinstance(mesh, MeshHex2)
    assert _volume(mesh) == pytest.approx(np.pi * (b**2 - a**2) * h / 6, rel=1e-5)
    nodes = mesh_nodes(mesh)
    # axis y: local (x, y, z) -> global (x, z, -y); the top face lies at global y = h
    top = np.unique(mesh.facets[:, mesh.boundaries["top"]])
    np.testing.assert_allclose(nodes[top, 1], h, atol=1e-15)
    assert set(mesh.boundaries) >= {"inner", "outer", "top", "bottom", "start", "end"}
    assert len(mesh.boundaries["start"]) == len(mesh.boundaries["end"]) == 2


def test_box_and_bridge_volumes_and_boundaries():
    box = box_mesh(0.3, 0.2, 0.1, 3, 2, 1, order=1, origin=(1.0, 0.0, 0.0))
    assert isinstance(box, MeshHex1)
    assert _volume(box) == pytest.approx(0.006, rel=1e-12)
    assert len(box.boundaries["left"]) == 2 and len(box.boundaries["top"]) == 6
    bridge = bridge_mesh(0.1, 0.02, 0.04, 0.05, 0.02)
    # U of boxes: bounding box minus the slot, 0.1 (0.08 x 0.07 - 0.04 x 0.05)
    assert _volume(bridge) == pytest.approx(0.1 * (0.08 * 0.07 - 0.04 * 0.05), rel=1e-12)
    for name in ("slot_lower", "slot_upper", "slot_top", "y_min", "y_max", "z_max"):
        assert len(bridge.boundaries[name]) > 0
    nodes = mesh_nodes(bridge)
    lower = np.unique(bridge.facets[:, bridge.boundaries["slot_lower"]])
    np.testing.assert_allclose(nodes[lower, 1], 0.02, atol=1e-15)


def test_transform_keeps_boundaries_and_rejects_reflections():
    mesh = box_mesh(0.1, 0.1, 0.1, 1, 1, 1)
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    moved = transform_mesh(mesh, rotation, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(mesh_nodes(moved), mesh_nodes(mesh) @ rotation.T + [1, 2, 3])
    assert set(moved.boundaries) == set(mesh.boundaries)
    with pytest.raises(InvalidParameterError, match="determinant"):
        transform_mesh(mesh, np.diag([1.0, 1.0, -1.0]))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: annulus_mesh(0.2, 0.1, 0.01, 2, 8, 1), "smaller"),
        (lambda: annulus_mesh(0.1, 0.2, 0.01, 2, 2, 1), "n_circumferential"),
        (lambda: annulus_mesh(0.1, 0.2, 0.01, 2, 8, 1, order=3), "order"),
        (lambda: annulus_mesh(0.1, 0.2, 0.01, 2, 8, 1, angle_range=(1.0, 0.5)), "angle_range"),
        (lambda: annulus_mesh(0.1, 0.2, 0.01, 2, 8, 1, axis="w"), "axis"),
        (lambda: box_mesh(0.1, -0.1, 0.1, 1, 1, 1), "length_y"),
        (lambda: box_mesh(0.1, 0.1, 0.1, 0, 1, 1), "n_x"),
    ],
)
def test_bad_mesh_inputs_are_named(call, message):
    with pytest.raises(InvalidParameterError, match=message):
        call()


def test_read_mesh_round_trip_gives_the_same_frequencies(tmp_path):
    # reference: the same body built from the in-memory mesh
    mesh = box_mesh(0.2, 0.02, 0.02, 10, 1, 1, order=1)
    path = tmp_path / "beam.vtu"
    meshio.write(path, to_meshio(mesh))  # scikit-fem's writer maps to VTK node order
    loaded = read_mesh(path, boundaries={"clamp": lambda x: x[0] <= 1e-12})
    assert isinstance(loaded, MeshHex1)
    original = ElasticBody(mesh, 70e9, 0.33, 2700.0, fixed="x_min").natural_frequencies(3)
    imported = ElasticBody(loaded, 70e9, 0.33, 2700.0, fixed="clamp").natural_frequencies(3)
    np.testing.assert_allclose(imported, original, rtol=1e-10)


def test_read_mesh_errors_name_the_file(tmp_path):
    with pytest.raises(InvalidParameterError, match="does not exist"):
        read_mesh(tmp_path / "missing.vtu")
    garbage = tmp_path / "garbage.vtu"
    garbage.write_text("not a mesh")
    with pytest.raises(InvalidParameterError, match=r"garbage\.vtu"):
        read_mesh(garbage)
    flat = tmp_path / "flat.vtu"
    meshio.write(
        flat,
        meshio.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), [("triangle", [[0, 1, 2]])]),
    )
    with pytest.raises(InvalidParameterError, match="no volume cells"):
        read_mesh(flat)


def test_imported_quadratic_tetrahedra_beam_matches_euler_bernoulli(tmp_path):
    # 10-node tetrahedra from a file; cantilever 0.2 x 0.02 x 0.02 m, first bending
    # frequency f = 1.8751^2 / (2 pi) sqrt(E I / (rho A L^4)) = 417.8 Hz (Blevins table 8-1);
    # L/h = 10, shear lowers it ~1 %, the 3D clamp stiffens it; measured +0.3 %, tolerance 2 %
    from skfem import MeshTet, MeshTet2

    from fuzzymbs.fe import boundary_faces

    linear = MeshTet.init_tensor(
        np.linspace(0, 0.2, 11), np.linspace(0, 0.02, 3), np.linspace(0, 0.02, 3)
    )
    path = tmp_path / "beam10.vtu"
    meshio.write(path, to_meshio(MeshTet2.from_mesh(linear)))
    mesh = read_mesh(path, boundaries={"clamp": lambda x: x[0] <= 1e-12})
    body = ElasticBody(mesh, 210e9, 0.3, 7850.0, fixed="clamp")
    second_moment, area, length = 0.02**4 / 12, 0.02**2, 0.2
    reference = (
        1.87510407**2 / (2 * np.pi) * np.sqrt(210e9 * second_moment / (7850.0 * area * length**4))
    )
    first, second = body.natural_frequencies(2)  # two equal bending directions
    assert first == pytest.approx(reference, rel=0.02)
    assert second == pytest.approx(reference, rel=0.02)
    assert boundary_faces(mesh, "clamp").shape[1] == 6  # 6-node triangles
