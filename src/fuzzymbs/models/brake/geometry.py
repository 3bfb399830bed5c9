"""Geometry, materials and finite-element bodies of the disc brake.

Layout (SI units, global frame = every body frame in the reference configuration):

* The disc rotates about the global y axis; its friction faces are the planes
  ``y = 0`` (lower face) and ``y = disc_thickness`` (upper face). It is clamped
  at its inner radius (the bolted hat), so its modes are those of a clamped
  annular plate.
* Each pad is an annular sector over the friction ring, centred on the +x axis;
  the lower pad touches the lower disc face from below, the upper pad the upper
  face from above. The pads translate in y (plus their free-free elastic modes).
* The caliper is a steel U (two jaws joined by a bridge beyond the disc rim)
  translating in y; its jaws sit behind the pads' back faces.

Contact grids (the numbers of the study):

* pad: the 25 *contact nodes* are the inner 5 x 5 nodes of the 7 x 7 nodes of
  its friction face; the full 7 x 7 face is the pad's master surface for the
  second contact pass;
* disc: on each face a 48-node annular-sector patch, 4 radii x 12 angles.

The sizes are chosen so that every pad contact node lies inside the disc patch
and every disc patch node lies inside the pad face, with a margin of half a
node spacing (more than the 0.011 rad the disc turns in 10 ms at 1.1 rad/s):
with a two-pass contact all 25 + 48 = 73 points carry load (see docs/brake.md).

Default materials (room temperature, handbook values):

* disc: grey cast iron EN-GJL-250: E = 110 GPa, nu = 0.26, rho = 7200 kg/m^3;
* pads: friction lining on a steel back plate, modelled as one homogeneous
  material of equivalent stiffness (lining E ~ 10 GPa over 10 mm in series with
  5 mm of steel) -- E = 15 GPa, nu = 0.25, rho = 2800 kg/m^3;
* caliper: steel, E = 210 GPa, nu = 0.3, rho = 7850 kg/m^3.

Default geometry: a solid passenger-car disc of 300 mm diameter and 22 mm
thickness clamped at 150 mm diameter; pads 45 mm x 49.5 deg (about 103 mm long at
the mean radius), 15 mm thick; caliper 130 mm wide, 6.2 kg.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment
from skfem import Mesh

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.elastic_body import ElasticBody
from fuzzymbs.fe.meshes import annulus_mesh, bridge_mesh, mesh_nodes, transform_mesh
from fuzzymbs.fe.surfaces import boundary_nodes
from fuzzymbs.mbs.modal_body import ModalBody

__all__ = ["BrakeBodies", "BrakeDesign", "Material", "build_bodies"]


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material.

    Attributes
    ----------
    youngs_modulus : float
        E [Pa].
    poisson_ratio : float
        nu [-].
    density : float
        rho [kg/m^3].
    """

    youngs_modulus: float
    poisson_ratio: float
    density: float


GREY_CAST_IRON = Material(110e9, 0.26, 7200.0)
PAD_EQUIVALENT = Material(15e9, 0.25, 2800.0)
STEEL = Material(210e9, 0.30, 7850.0)


@dataclass(frozen=True)
class BrakeDesign:
    """Everything that defines the finite-element bodies (the FE cache key follows from it).

    Attributes
    ----------
    disc_inner_radius, disc_outer_radius, disc_thickness : float
        Clamped (hat) radius, rim radius and thickness of the solid disc [m].
    disc_radial_elements, disc_circumferential_elements : int
        27-node hexahedra of the disc mesh (one through the thickness). The
        radial node spacing must give the 4 patch radii (see module docstring).
    disc_clamp : {"inner", "hat"}
        ``"inner"``: the whole inner cylinder r = disc_inner_radius is clamped
        (mirror-symmetric about the disc mid-plane). ``"hat"``: only its edge on
        the lower face (y = 0) is clamped, a crude model of a hat joined to the
        friction ring on one side; it breaks the mirror symmetry.
    pad_thickness : float
        Pad thickness (lining + back plate) [m].
    caliper_width, caliper_jaw_thickness, caliper_bridge_thickness : float
        Caliper extent along the disc tangent, jaw thickness (y) and bridge
        thickness (x) [m].
    caliper_clearance : float
        Radial gap between the disc rim and the caliper bridge [m].
    disc_material, pad_material, caliper_material : Material
    disc_modes, pad_modes, caliper_modes : int
        Elastic modes kept by modal truncation (lowest first).
    max_frequency : float
        Modes above this frequency [Hz] are dropped (explicit RK4 at dt = 1e-6 s is
        stable up to omega dt = 2.8, i.e. 445 kHz; the limit keeps the kernel cheap).
    """

    disc_inner_radius: float = 0.075
    disc_outer_radius: float = 0.150
    disc_thickness: float = 0.022
    disc_radial_elements: int = 3
    disc_circumferential_elements: int = 48
    pad_thickness: float = 0.015
    caliper_width: float = 0.130
    caliper_jaw_thickness: float = 0.025
    caliper_bridge_thickness: float = 0.025
    caliper_clearance: float = 0.010
    disc_clamp: str = "inner"
    disc_material: Material = field(default=GREY_CAST_IRON)
    pad_material: Material = field(default=PAD_EQUIVALENT)
    caliper_material: Material = field(default=STEEL)
    disc_modes: int = 16
    pad_modes: int = 8
    caliper_modes: int = 6
    max_frequency: float = 40e3

    def to_dict(self) -> dict:
        """Plain dictionary (JSON-able) of the design."""
        return asdict(self)

    # ------------------------------------------------------------------ derived grid sizes

    @property
    def disc_radial_spacing(self) -> float:
        """Radial node spacing of the quadratic disc mesh [m]."""
        span = self.disc_outer_radius - self.disc_inner_radius
        return span / (2 * self.disc_radial_elements)

    @property
    def disc_angular_spacing(self) -> float:
        """Angular node spacing of the quadratic disc mesh [rad]."""
        return np.pi / self.disc_circumferential_elements

    @property
    def patch_radii(self) -> NDArray[np.float64]:
        """The 4 radii of the disc contact patch: the outermost 4 node radii inside the rim."""
        n_rows = 2 * self.disc_radial_elements + 1
        rows = np.arange(n_rows - 5, n_rows - 1)
        return self.disc_inner_radius + rows * self.disc_radial_spacing

    @property
    def patch_angles(self) -> NDArray[np.float64]:
        """The 12 angles of the disc contact patch, symmetric about the +x axis [rad]."""
        return (np.arange(-6, 6) + 0.5) * self.disc_angular_spacing

    @property
    def pad_node_spacing(self) -> tuple[float, float]:
        """(radial [m], angular [rad]) node spacing of the pad face.

        The 5 x 5 contact nodes span 4 spacings, the disc patch 5, the pad face 6:
        each grid lies half a spacing inside the next.
        """
        radii = self.patch_radii
        angles = self.patch_angles
        return (radii[-1] - radii[0]) / 5.0, (angles[-1] - angles[0]) / 5.0

    @property
    def pad_radii(self) -> tuple[float, float]:
        """Inner and outer radius of the pads [m]."""
        dr, _ = self.pad_node_spacing
        return float(self.patch_radii[0] - 0.5 * dr), float(self.patch_radii[-1] + 0.5 * dr)

    @property
    def pad_half_angle(self) -> float:
        """Half the angular extent of the pads [rad]."""
        _, dth = self.pad_node_spacing
        return 3.0 * dth

    def validate(self) -> None:
        """Check the sizes; raises InvalidParameterError naming the offending field."""
        positive = {
            k: v
            for k, v in self.to_dict().items()
            if isinstance(v, float) and not isinstance(v, bool)
        }
        for name, value in positive.items():
            if not (np.isfinite(value) and value > 0):
                raise InvalidParameterError(f"brake design {name} must be > 0, got {value!r}")
        if not self.disc_inner_radius < self.disc_outer_radius:
            raise InvalidParameterError(
                "brake design disc_inner_radius must be smaller than disc_outer_radius"
            )
        if self.disc_radial_elements < 3:
            raise InvalidParameterError(
                "brake design disc_radial_elements must be >= 3 (the patch needs 4 radii "
                f"inside the rim), got {self.disc_radial_elements}"
            )
        if self.disc_circumferential_elements < 24:
            raise InvalidParameterError(
                "brake design disc_circumferential_elements must be >= 24 (a 12-angle patch "
                f"over less than a half disc), got {self.disc_circumferential_elements}"
            )
        for name in ("disc_modes", "pad_modes", "caliper_modes"):
            if int(getattr(self, name)) < 1:
                raise InvalidParameterError(f"brake design {name} must be >= 1")
        if self.disc_clamp not in ("inner", "hat"):
            raise InvalidParameterError(
                f"brake design disc_clamp must be 'inner' or 'hat', got {self.disc_clamp!r}"
            )
        if self.pad_radii[0] <= self.disc_inner_radius:
            raise InvalidParameterError("brake design: the pads reach the clamped hat radius")


@dataclass(frozen=True)
class BrakeBodies:
    """The four reduced bodies and the frequencies they keep.

    Node sets (indices into each ModalBody's kept nodes):

    * disc: ``patch_upper``, ``patch_lower`` (48 each);
    * pads: ``contact`` (25 face nodes), ``face`` (49: the master surface),
      ``back`` (25 back-face nodes carrying the nodal forces and the springs);
    * caliper: ``upper_jaw``, ``lower_jaw`` (25 each, paired with the pads' back
      nodes), ``ground`` (4 nodes on the lower jaw's outer face).
    """

    disc: ModalBody
    lower_pad: ModalBody
    upper_pad: ModalBody
    caliper: ModalBody


# ---------------------------------------------------------------------------- meshes


def _polar(nodes: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Radius and chart angle about y (angle from +x towards -z), as in PolarChart('y', 'x')."""
    return np.hypot(nodes[:, 0], nodes[:, 2]), np.arctan2(-nodes[:, 2], nodes[:, 0])


def _grid_nodes(
    nodes: NDArray[np.float64],
    candidates: NDArray[np.int64],
    radii: NDArray[np.float64],
    angles: NDArray[np.float64],
    what: str,
) -> NDArray[np.int64]:
    """The candidate nodes at every (radius, angle) of a polar grid, in grid order."""
    r, th = _polar(nodes[candidates])
    scale = float(radii.max())
    picked = []
    for radius in radii:
        for angle in angles:
            hit = candidates[(np.abs(r - radius) <= 1e-7 * scale) & (np.abs(th - angle) <= 1e-7)]
            if hit.size != 1:
                raise InvalidParameterError(
                    f"{what}: expected one mesh node at r = {radius:.6g} m, theta = "
                    f"{angle:.6g} rad, found {hit.size}; check the brake design sizes"
                )
            picked.append(int(hit[0]))
    return np.array(picked, dtype=np.int64)


def disc_mesh(design: BrakeDesign) -> Mesh:
    """Full annulus about y, faces y = 0 and y = thickness, node angles at (k + 1/2) spacing."""
    mesh = annulus_mesh(
        design.disc_inner_radius,
        design.disc_outer_radius,
        design.disc_thickness,
        design.disc_radial_elements,
        design.disc_circumferential_elements,
        1,
        order=2,
        axis="y",
    )
    # turn by half a node spacing so that the 12-angle patch is symmetric about +x
    half = 0.5 * design.disc_angular_spacing
    c, s = np.cos(half), np.sin(half)
    rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # about +y
    return transform_mesh(mesh, rotation=rotation)


def pad_mesh(design: BrakeDesign, side: str) -> Mesh:
    """Annular-sector pad; ``side`` "lower" (below y = 0) or "upper" (above the disc)."""
    inner, outer = design.pad_radii
    half = design.pad_half_angle
    mesh = annulus_mesh(
        inner, outer, design.pad_thickness, 3, 3, 1, order=2, angle_range=(-half, half), axis="y"
    )
    shift = -design.pad_thickness if side == "lower" else design.disc_thickness
    return transform_mesh(mesh, translation=(0.0, shift, 0.0))


def caliper_mesh(design: BrakeDesign) -> Mesh:
    """Steel U around the disc rim: jaws behind the pads, bridge beyond the rim."""
    inner, _ = design.pad_radii
    gap = design.disc_thickness + 2 * design.pad_thickness
    jaw_tip = inner - 0.005  # jaws reach 5 mm below the pads' inner edge
    jaw_height = design.disc_outer_radius + design.caliper_clearance - jaw_tip
    mesh = bridge_mesh(
        design.caliper_width,
        design.caliper_jaw_thickness,
        gap,
        jaw_height,
        design.caliper_bridge_thickness,
        n_width=6,
        n_jaw=1,
        n_gap=2,
        n_height=4,
        n_bridge=1,
        order=2,
    )
    # local (width x, slot y, height z) -> global (-z, y, x): a proper rotation
    rotation = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    origin = (
        jaw_tip,
        -design.pad_thickness - design.caliper_jaw_thickness,
        0.5 * design.caliper_width,
    )
    return transform_mesh(mesh, rotation=rotation, translation=origin)


# ---------------------------------------------------------------------------- node sets


def _pad_sets(design: BrakeDesign, mesh: Mesh, side: str) -> dict[str, NDArray[np.int64]]:
    nodes = mesh_nodes(mesh)
    inner, _ = design.pad_radii
    dr, dth = design.pad_node_spacing
    face_radii = inner + dr * np.arange(7)
    face_angles = dth * (np.arange(7) - 3.0)
    # annulus_mesh "bottom" is local z = 0 -> the lower global y of the sector
    face_name, back_name = ("top", "bottom") if side == "lower" else ("bottom", "top")
    face_nodes = boundary_nodes(mesh, face_name)
    back_nodes = boundary_nodes(mesh, back_name)
    what = f"{side} pad"
    return {
        "face": _grid_nodes(nodes, face_nodes, face_radii, face_angles, what + " face"),
        "contact": _grid_nodes(nodes, face_nodes, face_radii[1:6], face_angles[1:6], what),
        "back": _grid_nodes(nodes, back_nodes, face_radii[1:6], face_angles[1:6], what + " back"),
    }


def _nearest_distinct(
    targets: NDArray[np.float64], nodes: NDArray[np.float64], candidates: NDArray[np.int64]
) -> NDArray[np.int64]:
    """For each target (x, z) a distinct candidate node, minimising the summed distance."""
    d = np.hypot(
        targets[:, None, 0] - nodes[None, candidates, 0],
        targets[:, None, 2] - nodes[None, candidates, 2],
    )
    rows, cols = linear_sum_assignment(d)
    out = np.empty(targets.shape[0], dtype=np.int64)
    out[rows] = candidates[cols]
    return out


def _caliper_sets(
    design: BrakeDesign, mesh: Mesh, pad_back: dict[str, NDArray[np.float64]]
) -> dict[str, NDArray[np.int64]]:
    nodes = mesh_nodes(mesh)
    sets = {
        "lower_jaw": _nearest_distinct(
            pad_back["lower"], nodes, boundary_nodes(mesh, "slot_lower")
        ),
        "upper_jaw": _nearest_distinct(
            pad_back["upper"], nodes, boundary_nodes(mesh, "slot_upper")
        ),
    }
    # ground springs: the four corners of the lower jaw's outer face (y_min)
    outer = boundary_nodes(mesh, "y_min")
    xz = nodes[outer][:, [0, 2]]
    corners = []
    for sx in (-1.0, 1.0):
        for sz in (-1.0, 1.0):
            corners.append(int(outer[np.argmax(sx * xz[:, 0] + sz * xz[:, 1])]))
    sets["ground"] = np.array(corners, dtype=np.int64)
    return sets


# ---------------------------------------------------------------------------- bodies


def _reduce(body: ElasticBody, n_modes: int, design: BrakeDesign, sets: dict) -> ModalBody:
    """Modal truncation keeping the node sets in the (grid, spring-pair) order given."""
    modal = body.reduce(n_modes, method="modal", node_sets=sets, max_frequency=design.max_frequency)
    for name, nodes in sets.items():  # springs pair nodes by position in the set
        if not np.array_equal(modal.node_ids[modal.node_sets[name]], nodes):
            raise RuntimeError(f"node set {name!r} of body {body.name!r} lost its order")
    return modal


def _disc_clamp(design: BrakeDesign) -> str | Callable[[NDArray[np.float64]], NDArray[np.bool_]]:
    """Clamped disc nodes: the inner cylinder, or (``"hat"``) its lower-face edge only."""
    if design.disc_clamp == "inner":
        return "inner"
    limit = design.disc_inner_radius * (1.0 + 1e-9)  # tolerance: nodes from cos/sin
    height = 1e-9 * design.disc_thickness

    def lower_edge(x: NDArray[np.float64]) -> NDArray[np.bool_]:
        return (np.hypot(x[0], x[2]) <= limit) & (x[1] <= height)

    return lower_edge


def build_bodies(design: BrakeDesign | None = None) -> BrakeBodies:
    """Mesh, assemble and reduce the four bodies (cached on disk by :mod:`fuzzymbs.fe.cache`).

    Parameters
    ----------
    design : BrakeDesign, optional
        Sizes, materials and mode counts (default: the documented brake).

    Returns
    -------
    BrakeBodies
        Mass-normalised modal bodies (free-free pads and caliper without their
        rigid-body modes; the disc clamped at its inner radius).
    """
    design = design or BrakeDesign()
    design.validate()

    dmesh = disc_mesh(design)
    dnodes = mesh_nodes(dmesh)
    radii, angles = design.patch_radii, design.patch_angles
    disc_sets = {
        "patch_upper": _grid_nodes(dnodes, boundary_nodes(dmesh, "top"), radii, angles, "disc"),
        "patch_lower": _grid_nodes(dnodes, boundary_nodes(dmesh, "bottom"), radii, angles, "disc"),
    }
    m = design.disc_material
    disc = ElasticBody(
        dmesh,
        m.youngs_modulus,
        m.poisson_ratio,
        m.density,
        fixed=_disc_clamp(design),
        name="disc",
    )

    pads = {}
    back_positions = {}
    m = design.pad_material
    for side in ("lower", "upper"):
        pmesh = pad_mesh(design, side)
        sets = _pad_sets(design, pmesh, side)
        back_positions[side] = mesh_nodes(pmesh)[sets["back"]]
        body = ElasticBody(pmesh, m.youngs_modulus, m.poisson_ratio, m.density, name=f"{side}_pad")
        pads[side] = _reduce(body, design.pad_modes, design, sets)

    cmesh = caliper_mesh(design)
    m = design.caliper_material
    caliper = ElasticBody(cmesh, m.youngs_modulus, m.poisson_ratio, m.density, name="caliper")
    caliper_sets = _caliper_sets(design, cmesh, back_positions)
    return BrakeBodies(
        disc=_reduce(disc, design.disc_modes, design, disc_sets),
        lower_pad=pads["lower"],
        upper_pad=pads["upper"],
        caliper=_reduce(caliper, design.caliper_modes, design, caliper_sets),
    )
