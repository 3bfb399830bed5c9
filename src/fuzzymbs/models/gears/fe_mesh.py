"""Triangle meshes of whole spur gears from the package's own generated tooth profile.

The outline is the gear's generated profile (:class:`SpurGear`: trochoidal root
fillet + involute) repeated over all z teeth, closed by the tip and root arcs,
with a circular bore. Triangle (J. R. Shewchuk's constrained Delaunay mesher,
through the ``triangle`` package) fills it with quality triangles (minimum angle
30 deg) that grade from a fine boundary spacing on the loaded teeth to a coarse
one elsewhere.

The loaded teeth are the tooth at the +x axis (tooth 0) and its neighbours
``-(n-1)/2 .. (n-1)/2``; all of them are discretised identically (the same
points rotated), so that loads on tooth 0 measured at tooth ``d`` give the
coupling of any two teeth ``d`` apart. The drive (+y) flank of each loaded tooth
carries the influence grid as vertices: roll lengths ``s`` (distance from the
base-circle tangent point, r_b times the roll angle) from the form point to the
tip corner.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import SpurGear

__all__ = ["GearMesh", "flank_point", "mesh_gear"]


@dataclass(frozen=True)
class GearMesh:
    """A triangulated gear and where its influence grid lies.

    Attributes
    ----------
    points : ndarray (N, 2)
        Vertex coordinates [m], gear centre at the origin, tooth 0 on +x.
    triangles : ndarray (T, 3)
        Vertex indices, counter-clockwise.
    bore_vertices : ndarray (V,)
        Vertices on the bore circle.
    grid_roll : ndarray (S,)
        Roll lengths of the influence grid on the drive flank [m].
    grid_vertices : ndarray (n, S)
        Vertex of grid point i on loaded tooth d (row d + (n-1)/2).
    tooth_offsets : ndarray (n,)
        Tooth offsets d of the loaded teeth (rows of ``grid_vertices``).
    """

    points: np.ndarray
    triangles: np.ndarray
    bore_vertices: np.ndarray
    grid_roll: np.ndarray
    grid_vertices: np.ndarray
    tooth_offsets: np.ndarray


def flank_point(gear: SpurGear, roll: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drive-flank point and outward unit normal at roll length ``roll`` (tooth-local).

    Returns
    -------
    point, normal : ndarray (..., 2)
        The involute point r (cos psi, sin psi), r = sqrt(r_b^2 + s^2) [m], and the
        flank's outward normal (along the base tangent, -sin t, cos t with
        t = psi_b - s / r_b).
    """
    roll = np.asarray(roll, dtype=float)
    radius = np.hypot(gear.base_radius, roll)
    psi = gear.half_angle(radius)
    point = np.stack((radius * np.cos(psi), radius * np.sin(psi)), axis=-1)
    tangent = gear.base_half_angle - roll / gear.base_radius
    normal = np.stack((-np.sin(tangent), np.cos(tangent)), axis=-1)
    return point, normal


def _resample(curve: np.ndarray, spacing: float) -> np.ndarray:
    """Points along a polyline at about ``spacing`` (end points kept), by arc length."""
    steps = np.hypot(*np.diff(curve, axis=0).T)
    length = np.concatenate(([0.0], np.cumsum(steps)))
    count = max(math.ceil(length[-1] / spacing), 1)
    target = np.linspace(0.0, length[-1], count + 1)
    return np.column_stack(
        (np.interp(target, length, curve[:, 0]), np.interp(target, length, curve[:, 1]))
    )


def _arc(radius: float, start: float, stop: float, spacing: float) -> np.ndarray:
    count = max(math.ceil(radius * abs(stop - start) / spacing), 1)
    angle = np.linspace(start, stop, count + 1)
    return radius * np.column_stack((np.cos(angle), np.sin(angle)))


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def _tooth_outline(
    gear: SpurGear, spacing: float, grid_roll: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One tooth's outline, counter-clockwise from the -y fillet root to the +y fillet root.

    Returns the points and the indices of the influence grid (drive flank) among them.
    """
    fillet = _resample(gear.fillet(200), spacing)  # root -> form point, y >= 0
    # drive flank: the grid points, each interval split to the spacing
    flank = [flank_point(gear, grid_roll[:1])[0]]
    grid_index = [0]
    for lo, hi in itertools.pairwise(grid_roll):
        chord = float(np.hypot(*np.diff(flank_point(gear, np.array([lo, hi]))[0], axis=0)[0]))
        parts = max(math.ceil(chord / spacing), 1)
        roll = np.linspace(lo, hi, parts + 1)[1:]
        flank.append(flank_point(gear, roll)[0])
        grid_index.append(grid_index[-1] + parts)
    flank = np.vstack(flank)
    form_roll = math.sqrt(max(gear.form_radius**2 - gear.base_radius**2, 0.0))
    if grid_roll[0] > form_roll + 1e-12:  # involute between the form point and the grid
        lower = np.linspace(form_roll, grid_roll[0], 40)
        lower = _resample(flank_point(gear, lower)[0], spacing)[:-1]
        flank = np.vstack((lower, flank))
        grid_index = [i + len(lower) for i in grid_index]
    half = np.vstack((fillet[:-1], flank))  # root -> tip along +y
    grid_index = np.asarray(grid_index) + len(fillet) - 1
    psi_tip = float(gear.half_angle(gear.tip_radius))
    tip = _arc(gear.tip_radius, -psi_tip, psi_tip, spacing)[1:-1]
    lower_half = half[::-1] * np.array([1.0, -1.0])  # -y side, root -> tip is reversed
    lower_half = lower_half[::-1]
    outline = np.vstack((lower_half, tip, half[::-1]))
    # grid indices in the reversed +y half
    offset = len(lower_half) + len(tip)
    grid_in_outline = offset + (len(half) - 1 - grid_index)
    return outline, grid_in_outline


def mesh_gear(
    gear: SpurGear,
    fine_size: float,
    coarse_size: float,
    loaded_teeth: int = 5,
    grid_points: int = 24,
    bore_radius: float | None = None,
) -> GearMesh:
    """Mesh a whole gear with Triangle.

    Parameters
    ----------
    gear : SpurGear
    fine_size : float
        Boundary spacing on the loaded teeth and their root arcs [m].
    coarse_size : float
        Boundary spacing elsewhere (other teeth, bore) and the largest element edge [m].
    loaded_teeth : int
        Odd number n of teeth meshed finely around tooth 0 (offsets -(n-1)/2 .. (n-1)/2).
    grid_points : int
        Points S of the influence grid on the drive flank, from the lowest roll length
        that can carry contact (the form point) to the tip corner.
    bore_radius : float, optional
        Bore radius [m]; default the gear's ``rim_radius``.

    Returns
    -------
    GearMesh
    """
    import triangle

    if int(loaded_teeth) != loaded_teeth or loaded_teeth < 1 or loaded_teeth % 2 == 0:
        raise InvalidParameterError(
            f"loaded_teeth must be an odd integer >= 1, got {loaded_teeth!r}"
        )
    if loaded_teeth > gear.teeth:
        raise InvalidParameterError(
            f"loaded_teeth {loaded_teeth} exceeds the number of teeth {gear.teeth}"
        )
    if not 0.0 < fine_size <= coarse_size:
        raise InvalidParameterError(
            f"element sizes must satisfy 0 < fine_size <= coarse_size, got {fine_size!r}, "
            f"{coarse_size!r}"
        )
    if int(grid_points) != grid_points or grid_points < 4:
        raise InvalidParameterError(f"grid_points must be an integer >= 4, got {grid_points!r}")
    bore = gear.rim_radius if bore_radius is None else float(bore_radius)
    if not 0.0 < bore < gear.root_radius:
        raise InvalidParameterError(
            f"bore_radius {bore!r} m must lie between 0 and the root radius "
            f"{gear.root_radius:.6g} m"
        )
    form_roll = math.sqrt(max(gear.form_radius**2 - gear.base_radius**2, 0.0))
    tip_roll = math.sqrt(gear.tip_radius**2 - gear.base_radius**2)
    grid_roll = np.linspace(form_roll, tip_roll, int(grid_points))
    half_loaded = (loaded_teeth - 1) // 2
    pitch = gear.angular_pitch
    fine_tooth, fine_grid = _tooth_outline(gear, fine_size, grid_roll)
    coarse_tooth, _ = _tooth_outline(gear, coarse_size, grid_roll[[0, -1]])
    theta_f = gear.root_half_angle
    pieces = []
    grid_vertices = np.zeros((loaded_teeth, grid_points), dtype=np.int64)
    count = 0
    for tooth in range(gear.teeth):
        offset = tooth if tooth <= gear.teeth // 2 else tooth - gear.teeth
        fine = abs(offset) <= half_loaded
        # root arc after this tooth is fine when either neighbour is a loaded tooth
        next_offset = offset + 1
        fine_root = fine or abs(next_offset) <= half_loaded
        outline = _rotate(fine_tooth if fine else coarse_tooth, tooth * pitch)
        if fine:
            grid_vertices[offset + half_loaded] = count + fine_grid
        pieces.append(outline)
        count += len(outline)
        root = _arc(
            gear.root_radius,
            tooth * pitch + theta_f,
            (tooth + 1) * pitch - theta_f,
            fine_size if fine_root else coarse_size,
        )[1:-1]
        pieces.append(root)
        count += len(root)
    outer = np.vstack(pieces)
    n_outer = len(outer)
    n_bore = max(math.ceil(2.0 * math.pi * bore / coarse_size), 12)
    angle = np.arange(n_bore) * 2.0 * math.pi / n_bore
    inner = bore * np.column_stack((np.cos(angle), np.sin(angle)))
    vertices = np.vstack((outer, inner))
    outer_seg = np.column_stack((np.arange(n_outer), (np.arange(n_outer) + 1) % n_outer))
    inner_seg = n_outer + np.column_stack((np.arange(n_bore), (np.arange(n_bore) + 1) % n_bore))
    max_area = 0.5 * coarse_size**2
    result = triangle.triangulate(
        {
            "vertices": vertices,
            "segments": np.vstack((outer_seg, inner_seg)),
            "segment_markers": np.concatenate((np.ones(n_outer), np.full(n_bore, 2))).astype(
                np.int32
            )[:, None],
            "vertex_markers": np.concatenate((np.ones(n_outer), np.full(n_bore, 2))).astype(
                np.int32
            )[:, None],
            "holes": np.array([[0.0, 0.0]]),
        },
        f"pq30a{max_area:.12g}Q",
    )
    points = np.asarray(result["vertices"], dtype=float)
    triangles = np.asarray(result["triangles"], dtype=np.int64)
    # Triangle keeps the input vertices first and in order (no Steiner point on them)
    if not np.allclose(points[: len(vertices)], vertices):
        raise RuntimeError("Triangle reordered the input vertices")
    bore_vertices = np.flatnonzero(np.ravel(result["vertex_markers"]) == 2)
    return GearMesh(
        points=points,
        triangles=triangles,
        bore_vertices=bore_vertices,
        grid_roll=grid_roll,
        grid_vertices=grid_vertices,
        tooth_offsets=np.arange(-half_loaded, half_loaded + 1),
    )
