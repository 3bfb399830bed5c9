"""Nodes and faces of named boundaries, and the shape functions of the faces.

Node indices are columns of ``mesh.doflocs`` (see :mod:`fuzzymbs.fe.meshes`).
A face is a row of node indices in a fixed local order, so that a contact
algorithm can interpolate the surface with :func:`face_shape_functions`:

- quadrilateral faces (hexahedral meshes): corners 0-3 counter-clockwise seen
  from outside (the outward normal follows the right-hand rule 0 -> 1 -> 2), at
  local coordinates (xi, eta) = (-1, -1), (1, -1), (1, 1), (-1, 1); for 27-node
  hexahedra then the mid-edge nodes of edges 0-1, 1-2, 2-3, 3-0 at (0, -1),
  (1, 0), (0, 1), (-1, 0) and the face centre at (0, 0) (9 columns);
- triangular faces (tetrahedral meshes): corners 0-2 counter-clockwise seen
  from outside at area coordinates (xi, eta) = (0, 0), (1, 0), (0, 1); for
  10-node tetrahedra then the mid-edge nodes of 0-1, 1-2, 2-0 (6 columns).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from skfem import Mesh

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.meshes import span_text

__all__ = [
    "boundary_faces",
    "boundary_nodes",
    "face_shape_functions",
    "faces_in_region",
    "nodes_in_region",
]

NodeTest = Callable[[NDArray[np.float64]], NDArray[np.bool_]]


def _predicate_label(predicate: NodeTest) -> str:
    return getattr(predicate, "__qualname__", None) or repr(predicate)


def _no_match(
    mesh: Mesh,
    boundary: str,
    predicate: NodeTest,
    selecting: str,
    candidates: NDArray[np.int64],
    keep: NDArray[np.bool_],
) -> InvalidParameterError:
    """Error for a predicate selection that matched nothing, with what the user needs to see why.

    ``candidates`` are the boundary's node indices (repeated per face for face
    selections) and ``keep`` the predicate's answer for each.
    """
    nodes = np.unique(candidates)
    passing = np.unique(candidates[keep])
    where = f"boundary {boundary!r} (nodes span {span_text(mesh.doflocs[:, nodes])})"
    if passing.size:  # faces only: some nodes pass, but no face has all of them
        reason = (
            f"{passing.size} of its {nodes.size} nodes pass (spanning "
            f"{span_text(mesh.doflocs[:, passing])}), but no face has all its nodes passing; "
            "a face is selected only when every one of its nodes passes"
        )
    else:
        reason = f"the predicate rejects all {nodes.size} of its nodes"
        try:  # diagnosis only: does it accept nodes elsewhere (a wrong boundary name)?
            everywhere = np.asarray(predicate(mesh.doflocs), dtype=bool)
        except Exception:  # a predicate written for boundary nodes only may fail here
            everywhere = None
        if everywhere is not None and everywhere.shape == (mesh.doflocs.shape[1],):
            elsewhere = np.flatnonzero(everywhere)
            reason += (
                f"; it accepts {elsewhere.size} nodes elsewhere in the mesh "
                f"({span_text(mesh.doflocs[:, elsewhere])}), so check the boundary name"
                if elsewhere.size
                else "; it accepts no node of the mesh at all"
            )
    return InvalidParameterError(
        f"predicate {_predicate_label(predicate)} selects no {selecting} on {where}: {reason}. "
        f"The mesh spans {span_text(mesh.doflocs)}; check the predicate's coordinates, units [m] "
        "and tolerances."
    )


def _boundary_facets(mesh: Mesh, boundary: str) -> NDArray[np.int64]:
    boundaries = mesh.boundaries or {}
    if boundary not in boundaries:
        raise InvalidParameterError(
            f"unknown boundary {boundary!r}; this mesh has {sorted(boundaries)}"
        )
    facets = np.asarray(boundaries[boundary], dtype=np.int64)
    if facets.size == 0:
        raise InvalidParameterError(
            f"boundary {boundary!r} of this mesh holds no facet (the mesh spans "
            f"{span_text(mesh.doflocs)}); define it with with_named_boundaries or use another "
            f"of {sorted(name for name, f in boundaries.items() if np.size(f))}"
        )
    return facets


def _is_quadratic(mesh: Mesh) -> bool:
    return mesh.doflocs.shape[1] > mesh.nvertices


def _edge_lookup(mesh: Mesh) -> Callable[[NDArray, NDArray], NDArray[np.int64]]:
    """Function (vertex a, vertex b) -> edge index, vectorised."""
    n = mesh.nvertices
    edges = np.sort(mesh.edges, axis=0)
    keys = edges[0].astype(np.int64) * n + edges[1]
    order = np.argsort(keys)
    sorted_keys = keys[order]

    def lookup(first: NDArray, second: NDArray) -> NDArray[np.int64]:
        low, high = np.minimum(first, second), np.maximum(first, second)
        query = low.astype(np.int64) * n + high
        position = np.searchsorted(sorted_keys, query)
        if np.any(position >= sorted_keys.size) or np.any(sorted_keys[position] != query):
            raise RuntimeError("face edge not found in mesh edges")  # pragma: no cover
        return order[position]

    return lookup


def boundary_faces(mesh: Mesh, boundary: str) -> NDArray[np.int64]:
    """Faces of a named boundary as rows of node indices in the module's local order.

    Parameters
    ----------
    mesh
        scikit-fem hexahedral or tetrahedral mesh (order 1 or 2).
    boundary
        Name in ``mesh.boundaries``.

    Returns
    -------
    ndarray, shape (n_faces, 4 | 9 | 3 | 6)
        Node indices per face, corners counter-clockwise about the outward normal.

    Raises
    ------
    InvalidParameterError
        If the mesh has no boundary of that name, or it holds no facet.
    """
    facets = _boundary_facets(mesh, boundary)
    corners = mesh.facets[:, facets].T.copy()  # (n_faces, 3|4), any cyclic or sorted order
    points = mesh.p.T
    n_corners = corners.shape[1]
    if n_corners == 4:
        # sort the four corners by angle about the face centroid in the face plane
        xyz = points[corners]  # (f, 4, 3)
        centre = xyz.mean(axis=1, keepdims=True)
        # any three corners of a non-degenerate quad span its plane
        normal = np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0])
        u = xyz[:, 0] - centre[:, 0]
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        v = np.cross(normal, u)
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        rel = xyz - centre
        angle = np.arctan2(np.einsum("fkd,fd->fk", rel, v), np.einsum("fkd,fd->fk", rel, u))
        corners = np.take_along_axis(corners, np.argsort(angle, axis=1), axis=1)
    # orient outwards: normal (right-hand rule over corners 0, 1, 2) away from the element
    xyz = points[corners]
    normal = np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0])
    element = mesh.f2t[0, facets]
    element_centre = points[mesh.t[:, element].T].mean(axis=1)
    inward = np.einsum("fd,fd->f", normal, element_centre - xyz.mean(axis=1)) > 0
    corners[inward] = corners[inward][:, ::-1]
    if not _is_quadratic(mesh):
        return corners
    lookup = _edge_lookup(mesh)
    following = np.roll(corners, -1, axis=1)
    mid_edges = mesh.nvertices + lookup(corners, following)
    columns = [corners, mid_edges]
    if n_corners == 4:  # 27-node hexahedra carry a face-centre node
        columns.append((mesh.nvertices + mesh.nedges + facets)[:, None])
    return np.hstack(columns).astype(np.int64)


def boundary_nodes(mesh: Mesh, boundary: str) -> NDArray[np.int64]:
    """Sorted indices of all nodes on a named boundary (errors as :func:`boundary_faces`)."""
    return np.unique(boundary_faces(mesh, boundary))


def nodes_in_region(
    mesh: Mesh, boundary: str, predicate: NodeTest | None = None
) -> NDArray[np.int64]:
    """Nodes of a named boundary whose coordinates pass ``predicate``.

    Parameters
    ----------
    mesh
        scikit-fem mesh with named boundaries.
    boundary
        Name in ``mesh.boundaries`` (e.g. ``"top"``).
    predicate
        ``predicate(x)`` with node coordinates x of shape (3, k) [m] returns a
        boolean array (k,). Use tolerances, not float equality. ``None``: all.

    Returns
    -------
    ndarray
        Sorted node indices, at least one.

    Raises
    ------
    InvalidParameterError
        Unknown or empty boundary, a predicate answer of the wrong shape, or no
        node passing: the message names the predicate and boundary, the
        boundary's and the mesh's bounding boxes, and whether the predicate
        accepts nodes elsewhere in the mesh.
    """
    nodes = boundary_nodes(mesh, boundary)
    if predicate is None:
        return nodes
    keep = np.asarray(predicate(mesh.doflocs[:, nodes]), dtype=bool)
    if keep.shape != nodes.shape:
        raise InvalidParameterError(
            f"predicate must return one boolean per node ({nodes.size}), got shape {keep.shape}"
        )
    if not keep.any():
        raise _no_match(mesh, boundary, predicate, "node", nodes, keep)
    return nodes[keep]


def faces_in_region(
    mesh: Mesh, boundary: str, predicate: NodeTest | None = None
) -> NDArray[np.int64]:
    """Faces of a named boundary all of whose nodes pass ``predicate`` (rows of node indices).

    Parameters and errors as :func:`nodes_in_region`; no face passing is an
    error that also says how many of the boundary's nodes pass and where they lie.
    """
    faces = boundary_faces(mesh, boundary)
    if predicate is None:
        return faces
    keep = np.asarray(predicate(mesh.doflocs[:, faces.ravel()]), dtype=bool)
    if keep.shape != (faces.size,):
        raise InvalidParameterError(
            f"predicate must return one boolean per node ({faces.size}), got shape {keep.shape}"
        )
    selected = keep.reshape(faces.shape).all(axis=1)
    if not selected.any():
        raise _no_match(mesh, boundary, predicate, "face", faces.ravel(), keep)
    return faces[selected]


def face_shape_functions(xi: ArrayLike, eta: ArrayLike, n_nodes: int) -> NDArray[np.float64]:
    """Shape functions of a face in the module's node order.

    Parameters
    ----------
    xi, eta
        Local coordinates (broadcast together): in [-1, 1]^2 for quadrilaterals,
        area coordinates (xi, eta >= 0, xi + eta <= 1) for triangles.
    n_nodes
        4 (bilinear quad), 9 (biquadratic quad), 3 (linear) or 6 (quadratic triangle).

    Returns
    -------
    ndarray, shape (..., n_nodes)
        N_k(xi, eta); a surface point is ``sum_k N_k x_k``.
    """
    xi, eta = np.broadcast_arrays(
        np.asarray(xi, dtype=np.float64), np.asarray(eta, dtype=np.float64)
    )
    if n_nodes == 4:
        return 0.25 * np.stack(
            [
                (1 - xi) * (1 - eta),
                (1 + xi) * (1 - eta),
                (1 + xi) * (1 + eta),
                (1 - xi) * (1 + eta),
            ],
            axis=-1,
        )
    if n_nodes == 9:
        # 1D quadratic Lagrange polynomials at -1, 0, 1
        def lagrange(s: NDArray) -> tuple[NDArray, NDArray, NDArray]:
            return 0.5 * s * (s - 1), 1 - s * s, 0.5 * s * (s + 1)

        lx, ly = lagrange(xi), lagrange(eta)
        # (index in x, index in y) of nodes: corners, mid-edges, centre
        pattern = [(0, 0), (2, 0), (2, 2), (0, 2), (1, 0), (2, 1), (1, 2), (0, 1), (1, 1)]
        return np.stack([lx[i] * ly[j] for i, j in pattern], axis=-1)
    if n_nodes == 3:
        return np.stack([1 - xi - eta, xi, eta], axis=-1)
    if n_nodes == 6:
        l0, l1, l2 = 1 - xi - eta, xi, eta
        return np.stack(
            [
                l0 * (2 * l0 - 1),
                l1 * (2 * l1 - 1),
                l2 * (2 * l2 - 1),
                4 * l0 * l1,
                4 * l1 * l2,
                4 * l2 * l0,
            ],
            axis=-1,
        )
    raise InvalidParameterError(f"n_nodes must be 3, 4, 6 or 9, got {n_nodes!r}")
