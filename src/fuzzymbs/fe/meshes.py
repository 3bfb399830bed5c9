"""Structured hexahedral meshes with named boundaries, and mesh import.

Every mesh is a scikit-fem mesh (``MeshHex1`` for ``order=1``, ``MeshHex2``
for ``order=2``). A *node* of a mesh is one column of ``mesh.doflocs``: the
vertices come first, then (order 2) the edge, face and element-centre nodes of
the 27-node hexahedron. Node ``j`` carries the displacement DOFs ``3 j + c``
(``c = 0, 1, 2`` for x, y, z) in :class:`fuzzymbs.fe.elastic_body.ElasticBody`.

Curved (annulus) meshes are isoparametric: every node, including the
mid-edge and mid-face nodes, lies on the exact cylinder, so the quadratic
mesh represents the circular edges to O(h^3).

Named boundaries are sets of boundary facets (``mesh.boundaries[name]``),
selected on the facet's vertex coordinates with a relative tolerance, never
with exact float equality (a vertex at ``r = b`` computed from ``cos``/``sin``
has ``hypot(x, y) != b`` in floating point).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from skfem import Mesh, MeshHex1, MeshHex2

from fuzzymbs.errors import InvalidParameterError

__all__ = [
    "BOUNDARY_TOLERANCE",
    "annulus_mesh",
    "box_mesh",
    "bridge_mesh",
    "mesh_nodes",
    "read_mesh",
    "span_text",
    "transform_mesh",
    "with_named_boundaries",
]

#: relative tolerance used to decide that a vertex lies on a boundary surface
BOUNDARY_TOLERANCE = 1e-9

CoordinateTest = Callable[[NDArray[np.float64]], NDArray[np.bool_]]


def mesh_nodes(mesh: Mesh) -> NDArray[np.float64]:
    """Node coordinates of a mesh, shape (n_nodes, 3) [m] (vertices first)."""
    return np.ascontiguousarray(mesh.doflocs.T, dtype=np.float64)


# --------------------------------------------------------------------------- checks


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0.0:
        raise InvalidParameterError(f"{name} must be a finite number > 0, got {value!r}")
    return value


def _count(name: str, value: int, minimum: int = 1) -> int:
    if isinstance(value, bool) or int(value) != value or int(value) < minimum:
        raise InvalidParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _order(order: int) -> int:
    if order not in (1, 2):
        raise InvalidParameterError(
            f"order must be 1 (8-node) or 2 (27-node hexahedra), got {order!r}"
        )
    return int(order)


# --------------------------------------------------------------------------- boundaries


def span_text(x: NDArray[np.float64]) -> str:
    """Bounding box of points as text for error messages.

    Parameters
    ----------
    x : ndarray, shape (3, k)
        Coordinates [m] of k points.

    Returns
    -------
    str
        E.g. ``"x [0, 0.06], y [0, 0.02], z [0, 0.01] m"``.
    """
    bounds = zip("xyz", x.min(axis=1), x.max(axis=1), strict=True)
    return ", ".join(f"{axis} [{low:.6g}, {high:.6g}]" for axis, low, high in bounds) + " m"


def _facets_where(mesh: Mesh, name: str, test: CoordinateTest) -> NDArray[np.int64]:
    """Boundary facets all of whose vertices pass ``test`` (coordinates (3, k) -> bool (k,)).

    Raises
    ------
    InvalidParameterError
        If the test's answer has the wrong shape, or no facet passes: the
        message names the boundary and the test, the bounding box of the
        mesh's boundary vertices and of the vertices that do pass, if any.
    """
    facets = mesh.boundary_facets()
    vertices = mesh.facets[:, facets]  # (n_vertices_per_facet, n_facets)
    coordinates = mesh.p[:, vertices.ravel()]
    inside = np.asarray(test(coordinates), dtype=bool)
    if inside.shape != (vertices.size,):
        raise InvalidParameterError(
            f"test of boundary {name!r} must return one boolean per vertex ({vertices.size}), "
            f"got shape {inside.shape}"
        )
    selected = inside.reshape(vertices.shape).all(axis=0)
    if not selected.any():
        label = getattr(test, "__qualname__", None) or repr(test)
        candidates = np.unique(vertices)
        passing = np.unique(vertices.ravel()[inside])
        found = (
            f"{passing.size} of the {candidates.size} boundary vertices pass (spanning "
            f"{span_text(mesh.p[:, passing])}), but no boundary facet has all its vertices "
            "passing; a facet belongs to the boundary only when every vertex passes"
            if passing.size
            else f"it rejects all {candidates.size} boundary vertices"
        )
        raise InvalidParameterError(
            f"boundary {name!r} (test {label}) selects no boundary facet: {found}. The "
            f"boundary vertices span {span_text(mesh.p[:, candidates])}; check the test's "
            "coordinates, units [m] and tolerance (relative, e.g. r <= a (1 + 1e-9) on "
            "curved surfaces)."
        )
    return np.asarray(facets[selected], dtype=np.int64)


def with_named_boundaries(mesh: Mesh, tests: Mapping[str, CoordinateTest]) -> Mesh:
    """Return ``mesh`` with extra named boundaries.

    Parameters
    ----------
    mesh
        A scikit-fem mesh.
    tests
        ``name -> test``; ``test(x)`` gets vertex coordinates of shape (3, k) [m]
        and returns a boolean array (k,). A boundary facet belongs to ``name``
        when all its vertices pass. Use a tolerance in the test on curved surfaces.

    Returns
    -------
    Mesh
        A new mesh whose ``boundaries`` hold the previous and the new names.

    Raises
    ------
    InvalidParameterError
        If a test selects no boundary facet (the message names the boundary,
        the test and the bounding boxes needed to see why).
    """
    boundaries = dict(mesh.boundaries or {})
    for name, test in tests.items():
        boundaries[name] = _facets_where(mesh, name, test)
    return mesh.with_boundaries(boundaries)


def _box_tests(lower: NDArray[np.float64], upper: NDArray[np.float64]) -> dict[str, CoordinateTest]:
    """Tests for the six faces of an axis-aligned bounding box, tolerance relative to its size."""
    tolerance = BOUNDARY_TOLERANCE * float(np.max(upper - lower))
    tests: dict[str, CoordinateTest] = {}
    for axis, letter in enumerate("xyz"):
        low, high = float(lower[axis]), float(upper[axis])
        tests[f"{letter}_min"] = lambda x, a=axis, v=low: x[a] <= v + tolerance
        tests[f"{letter}_max"] = lambda x, a=axis, v=high: x[a] >= v - tolerance
    aliases = {
        "left": "x_min",
        "right": "x_max",
        "front": "y_min",
        "back": "y_max",
        "bottom": "z_min",
        "top": "z_max",
    }
    for alias, name in aliases.items():
        tests[alias] = tests[name]
    return tests


# --------------------------------------------------------------------------- box & bridge


def _structured_hex(
    x_grid: NDArray[np.float64],
    y_grid: NDArray[np.float64],
    z_grid: NDArray[np.float64],
    keep_cell: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None,
    order: int,
) -> Mesh:
    """Tensor-product hexahedra, optionally without the cells whose centroid fails ``keep_cell``."""
    mesh: Mesh = MeshHex1.init_tensor(x_grid, y_grid, z_grid)
    if keep_cell is not None:
        centroids = mesh.p[:, mesh.t].mean(axis=1)
        drop = np.flatnonzero(~np.asarray(keep_cell(centroids), dtype=bool))
        if drop.size:
            mesh = mesh.remove_elements(drop)
    if order == 2:
        mesh = MeshHex2.from_mesh(mesh)  # straight edges: mid-nodes at exact midpoints
    return mesh


def box_mesh(
    length_x: float,
    length_y: float,
    length_z: float,
    n_x: int,
    n_y: int,
    n_z: int,
    order: int = 2,
    origin: ArrayLike = (0.0, 0.0, 0.0),
) -> Mesh:
    """Structured hexahedral mesh of the box ``origin + [0, Lx] x [0, Ly] x [0, Lz]``.

    Parameters
    ----------
    length_x, length_y, length_z
        Edge lengths [m].
    n_x, n_y, n_z
        Number of elements along each edge.
    order
        1: 8-node hexahedra, 2: 27-node hexahedra (use for thin or bending parts).
    origin
        Corner with the smallest coordinates [m].

    Returns
    -------
    Mesh
        ``MeshHex1``/``MeshHex2`` with boundaries ``x_min, x_max, y_min, y_max,
        z_min, z_max`` and the aliases ``left, right, front, back, bottom, top``.
    """
    lengths = np.array(
        [
            _positive("length_x", length_x),
            _positive("length_y", length_y),
            _positive("length_z", length_z),
        ]
    )
    counts = [_count("n_x", n_x), _count("n_y", n_y), _count("n_z", n_z)]
    order = _order(order)
    lower = np.asarray(origin, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(lower)):
        raise InvalidParameterError(f"origin must be 3 finite coordinates [m], got {origin!r}")
    grids = [np.linspace(lower[i], lower[i] + lengths[i], counts[i] + 1) for i in range(3)]
    mesh = _structured_hex(*grids, keep_cell=None, order=order)
    return with_named_boundaries(mesh, _box_tests(lower, lower + lengths))


def bridge_mesh(
    width: float,
    jaw_thickness: float,
    gap: float,
    jaw_height: float,
    bridge_thickness: float,
    n_width: int = 4,
    n_jaw: int = 1,
    n_gap: int = 2,
    n_height: int = 3,
    n_bridge: int = 1,
    order: int = 2,
    origin: ArrayLike = (0.0, 0.0, 0.0),
) -> Mesh:
    """Caliper-like bridge: two jaws joined by a bridge (a U of boxes, open towards -z).

    Local layout (``origin`` at the smallest corner)::

        z ^   +-----------------------------+   bridge: z in [H, H + t_b]
          |   |            bridge           |
          |   +------+-------------+--------+
          |   | jaw  |    slot     |  jaw   |   jaws: z in [0, H]
          |   +------+-------------+--------+--> y
              0      t_j           t_j + g   2 t_j + g

    and ``x`` in ``[0, width]``. The slot (where the disc and pads sit) is open at
    ``z = 0`` and at both ``x`` ends.

    Parameters
    ----------
    width
        Extent along x [m].
    jaw_thickness, gap
        Jaw thickness t_j and slot width g along y [m].
    jaw_height, bridge_thickness
        Jaw height H and bridge thickness t_b along z [m].
    n_width, n_jaw, n_gap, n_height, n_bridge
        Element counts along width, each jaw's thickness, the slot, the jaw height
        and the bridge thickness.
    order
        1 or 2 (8- or 27-node hexahedra).
    origin
        Smallest corner [m].

    Returns
    -------
    Mesh
        Boundaries: the bounding-box faces ``x_min ... z_max`` (``y_min``/``y_max``
        are the outer faces of the jaws), ``slot_lower`` (inner face of the jaw at
        small y), ``slot_upper`` (inner face of the other jaw) and ``slot_top`` (the
        bridge's underside inside the slot).
    """
    width = _positive("width", width)
    jaw_thickness = _positive("jaw_thickness", jaw_thickness)
    gap = _positive("gap", gap)
    jaw_height = _positive("jaw_height", jaw_height)
    bridge_thickness = _positive("bridge_thickness", bridge_thickness)
    counts = {
        "n_width": n_width,
        "n_jaw": n_jaw,
        "n_gap": n_gap,
        "n_height": n_height,
        "n_bridge": n_bridge,
    }
    n = {k: _count(k, v) for k, v in counts.items()}
    order = _order(order)
    o = np.asarray(origin, dtype=np.float64).reshape(3)

    x_grid = o[0] + np.linspace(0.0, width, n["n_width"] + 1)
    y_breaks = np.cumsum([0.0, jaw_thickness, gap, jaw_thickness])
    y_counts = [n["n_jaw"], n["n_gap"], n["n_jaw"]]
    y_grid = o[1] + np.unique(
        np.concatenate(
            [np.linspace(y_breaks[i], y_breaks[i + 1], y_counts[i] + 1) for i in range(3)]
        )
    )
    z_grid = o[2] + np.unique(
        np.concatenate(
            [
                np.linspace(0.0, jaw_height, n["n_height"] + 1),
                np.linspace(jaw_height, jaw_height + bridge_thickness, n["n_bridge"] + 1),
            ]
        )
    )
    slot_low, slot_high = o[1] + jaw_thickness, o[1] + jaw_thickness + gap
    slot_top = o[2] + jaw_height

    def keep_cell(c: NDArray[np.float64]) -> NDArray[np.bool_]:
        in_slot = (c[1] > slot_low) & (c[1] < slot_high) & (c[2] < slot_top)
        return ~in_slot

    mesh = _structured_hex(x_grid, y_grid, z_grid, keep_cell, order)
    extent = np.array([width, 2 * jaw_thickness + gap, jaw_height + bridge_thickness])
    tests = _box_tests(o, o + extent)
    for alias in ("left", "right", "front", "back", "bottom", "top"):
        tests.pop(alias)
    tol = BOUNDARY_TOLERANCE * float(extent.max())
    tests["slot_lower"] = lambda x: (np.abs(x[1] - slot_low) <= tol) & (x[2] <= slot_top + tol)
    tests["slot_upper"] = lambda x: (np.abs(x[1] - slot_high) <= tol) & (x[2] <= slot_top + tol)
    tests["slot_top"] = lambda x: (
        (np.abs(x[2] - slot_top) <= tol) & (x[1] >= slot_low - tol) & (x[1] <= slot_high + tol)
    )
    return with_named_boundaries(mesh, tests)


# --------------------------------------------------------------------------- annulus

_AXIS_ROTATIONS = {
    # proper rotations (det = +1) taking the local disc axis z to the requested axis
    "z": np.eye(3),
    "y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),  # (x,y,z)->(x,z,-y)
    "x": np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),  # (x,y,z)->(z,y,-x)
}


def annulus_mesh(
    inner_radius: float,
    outer_radius: float,
    thickness: float,
    n_radial: int,
    n_circumferential: int,
    n_thickness: int,
    order: int = 2,
    angle_range: tuple[float, float] | None = None,
    axis: str = "z",
) -> Mesh:
    """Structured hexahedral mesh of an annular disc or an annular sector.

    In the local frame the disc axis is z and the faces are ``z = 0``
    (``bottom``) and ``z = thickness`` (``top``); ``axis`` rotates the
    local z onto the requested global axis (``"y"``: local (x, y, z) -> global
    (x, z, -y), so ``top`` lies at global y = thickness).

    Parameters
    ----------
    inner_radius, outer_radius
        Radii a < b [m].
    thickness
        Axial thickness h [m].
    n_radial, n_circumferential, n_thickness
        Element counts. A full disc needs ``n_circumferential >= 3``.
    order
        1 (8-node) or 2 (27-node, isoparametric: all nodes on the exact circles).
    angle_range
        ``(theta_start, theta_end)`` [rad] for a sector, measured in the local
        x-y plane from local x towards local y; ``None`` for the full disc.
    axis
        ``"x"``, ``"y"`` or ``"z"``: the global axis of the disc.

    Returns
    -------
    Mesh
        Boundaries ``inner`` (r = a), ``outer`` (r = b), ``bottom``, ``top`` and,
        for a sector, ``start`` (theta_start) and ``end`` (theta_end).
    """
    a = _positive("inner_radius", inner_radius)
    b = _positive("outer_radius", outer_radius)
    if not a < b:
        raise InvalidParameterError(
            f"inner_radius ({a!r}) must be smaller than outer_radius ({b!r})"
        )
    h = _positive("thickness", thickness)
    n_r = _count("n_radial", n_radial)
    n_z = _count("n_thickness", n_thickness)
    order = _order(order)
    if axis not in _AXIS_ROTATIONS:
        raise InvalidParameterError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
    full = angle_range is None
    if full:
        n_c = _count("n_circumferential", n_circumferential, minimum=3)
        theta_start, theta_end = 0.0, 2.0 * np.pi
    else:
        n_c = _count("n_circumferential", n_circumferential)
        theta_start, theta_end = (float(v) for v in angle_range)
        span = theta_end - theta_start
        if not (np.isfinite(span) and 0.0 < span <= 2.0 * np.pi):
            raise InvalidParameterError(
                "angle_range must be (start, end) [rad] with 0 < end - start <= 2 pi, "
                f"got {angle_range!r}"
            )
        if span / n_c >= np.pi:
            raise InvalidParameterError(
                f"n_circumferential={n_c} gives elements spanning >= pi rad; use more elements"
            )

    # structured grid in the parameter space (r, theta, z); vertices by integer index
    r_grid = np.linspace(a, b, n_r + 1)
    theta_grid = np.linspace(theta_start, theta_end, n_c + 1)
    z_grid = np.linspace(0.0, h, n_z + 1)
    n_theta_vertices = n_c if full else n_c + 1  # full disc: theta_end is theta_start

    ir, ith, iz = np.meshgrid(
        np.arange(n_r + 1), np.arange(n_theta_vertices), np.arange(n_z + 1), indexing="ij"
    )
    ir, ith, iz = ir.ravel(), ith.ravel(), iz.ravel()

    def vertex(i: NDArray[np.int64], j: NDArray[np.int64], k: NDArray[np.int64]) -> NDArray:
        j = j % n_c if full else j
        return (i * n_theta_vertices + j) * (n_z + 1) + k

    # hexahedra in the reference ordering of MeshHex1.init_tensor (x=r, y=theta, z=z)
    er, eth, ez = np.meshgrid(np.arange(n_r), np.arange(n_c), np.arange(n_z), indexing="ij")
    er, eth, ez = er.ravel(), eth.ravel(), ez.ravel()
    reference = MeshHex1.init_tensor(
        np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([0.0, 1.0])
    )
    corners = reference.p[:, reference.t[:, 0]].round().astype(np.int64)  # (3, 8) of 0/1
    t = np.vstack(
        [vertex(er + corners[0, c], eth + corners[1, c], ez + corners[2, c]) for c in range(8)]
    )
    param = np.vstack([r_grid[ir], theta_grid[ith], z_grid[iz]])  # (r, theta, z) per vertex

    def to_cartesian(r: NDArray, theta: NDArray, z: NDArray) -> NDArray[np.float64]:
        local = np.vstack([r * np.cos(theta), r * np.sin(theta), z])
        return _AXIS_ROTATIONS[axis] @ local

    mesh: Mesh = MeshHex1(to_cartesian(*param), t)
    if order == 2:
        straight = MeshHex2.from_mesh(mesh)
        # doflocs = [vertices, edge mid-nodes, face centres, element centres]; put each
        # higher-order node at the image of its entity's parameter-space centre, so it
        # lies on the exact circle (angles averaged as unit vectors: no 2 pi wrap issue)
        groups = [straight.edges, straight.facets, straight.t]
        centres = [param]
        for group in groups:
            r_mean = param[0, group].mean(axis=0)
            z_mean = param[2, group].mean(axis=0)
            unit = np.exp(1j * param[1, group]).mean(axis=0)
            centres.append(np.vstack([r_mean, np.angle(unit), z_mean]))
        doflocs = to_cartesian(*np.hstack(centres))
        if doflocs.shape != straight.doflocs.shape:  # pragma: no cover - skfem layout changed
            raise RuntimeError("unexpected MeshHex2 node layout in scikit-fem")
        mesh = MeshHex2(doflocs, straight.t)

    rotation = _AXIS_ROTATIONS[axis]
    tol = BOUNDARY_TOLERANCE

    def local(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return rotation.T @ x

    def radius(x: NDArray[np.float64]) -> NDArray[np.float64]:
        xl = local(x)
        return np.hypot(xl[0], xl[1])

    tests: dict[str, CoordinateTest] = {
        "inner": lambda x: radius(x) <= a * (1.0 + tol),
        "outer": lambda x: radius(x) >= b * (1.0 - tol),
        "bottom": lambda x: local(x)[2] <= h * tol,
        "top": lambda x: local(x)[2] >= h * (1.0 - tol),
    }
    if not full:

        def on_ray(theta: float) -> CoordinateTest:
            direction = np.array([np.cos(theta), np.sin(theta)])

            def test(x: NDArray[np.float64]) -> NDArray[np.bool_]:
                xl = local(x)
                off_plane = np.abs(-direction[1] * xl[0] + direction[0] * xl[1])
                along = direction[0] * xl[0] + direction[1] * xl[1]
                return (off_plane <= b * tol) & (along > 0.0)

            return test

        tests["start"] = on_ray(theta_start)
        tests["end"] = on_ray(theta_end)
    return with_named_boundaries(mesh, tests)


# --------------------------------------------------------------------------- transforms & IO


def transform_mesh(
    mesh: Mesh, rotation: ArrayLike | None = None, translation: ArrayLike | None = None
) -> Mesh:
    """Rigidly move a mesh: ``x -> rotation @ x + translation``, keeping its boundaries.

    Parameters
    ----------
    mesh
        A scikit-fem mesh.
    rotation
        Proper rotation matrix (3, 3), orthonormal with determinant +1 (a
        reflection would turn the elements inside out).
    translation
        Shift (3,) [m].
    """
    matrix = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    shift = np.zeros(3) if translation is None else np.asarray(translation, dtype=np.float64)
    if matrix.shape != (3, 3) or not np.allclose(matrix.T @ matrix, np.eye(3), atol=1e-12):
        raise InvalidParameterError("rotation must be an orthonormal 3 x 3 matrix")
    if np.linalg.det(matrix) <= 0.0:
        raise InvalidParameterError("rotation must have determinant +1 (no reflections)")
    if shift.shape != (3,) or not np.all(np.isfinite(shift)):
        raise InvalidParameterError(
            f"translation must be 3 finite numbers [m], got {translation!r}"
        )
    doflocs = matrix @ mesh.doflocs + shift[:, None]
    moved = type(mesh)(doflocs, mesh.t)
    return moved.with_boundaries(dict(mesh.boundaries)) if mesh.boundaries else moved


def read_mesh(path: str | Path, boundaries: Mapping[str, CoordinateTest] | None = None) -> Mesh:
    """Read a volume mesh with meshio (any format meshio reads) into scikit-fem.

    Supported cells: ``hexahedron``, ``hexahedron27``, ``tetra``, ``tetra10``.
    Named boundaries stored in the file (cell sets of boundary faces, e.g. gmsh
    physical groups) are kept; ``boundaries`` adds more from coordinate tests
    (see :func:`with_named_boundaries`).

    Parameters
    ----------
    path
        Mesh file.
    boundaries
        Optional ``name -> test`` on vertex coordinates.

    Returns
    -------
    Mesh
        A scikit-fem volume mesh.
    """
    import meshio
    from skfem.io.meshio import from_meshio

    path = Path(path)
    if not path.is_file():
        raise InvalidParameterError(f"mesh file {str(path)!r} does not exist")
    try:
        raw = meshio.read(path)
    except (Exception, SystemExit) as error:  # meshio raises many types, even SystemExit
        raise InvalidParameterError(
            f"mesh file {str(path)!r} could not be read by meshio: {error}"
        ) from error
    volume_types = {"hexahedron", "hexahedron27", "tetra", "tetra10"}
    if not volume_types & set(raw.cells_dict):
        raise InvalidParameterError(
            f"mesh file {str(path)!r} holds no volume cells; found {sorted(raw.cells_dict)}, "
            f"supported are {sorted(volume_types)}"
        )
    try:
        mesh = from_meshio(raw)
    except Exception as error:
        raise InvalidParameterError(
            f"mesh file {str(path)!r} could not be converted to a scikit-fem mesh: {error}"
        ) from error
    if boundaries:
        mesh = with_named_boundaries(mesh, boundaries)
    return mesh
