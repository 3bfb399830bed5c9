"""Master-slave node-to-surface penalty contact with regularised Coulomb friction.

A slave node x_s is looked up on a *structured master patch*: master nodes that
form a tensor grid in a chart of the master body frame -- Cartesian ``(u, v)``
for a flat patch or polar ``(r, theta)`` about an axis for an annular sector of
a disc. Lookup is O(1): the chart coordinates of the slave point (for a
rotating master the material angle is ``theta - Omega t``, obtained by rotating
the slave point back into the master frame) give the cell directly, and the
bilinear shape functions of that cell interpolate the master's position and
velocity (rigid motion, rotation and elastic deformation included).

    g   = n . (x_s - x_m)                          gap (n: master cell normal)
    f_N = max(0, -c_p g - d_n dg/dt)               normal force (penalty + optional damping)
    f_T = -mu f_N v_t / sqrt(|v_t|^2 + eps^2)      regularised Coulomb friction

v_t is the tangential part of the relative velocity ``v_s - v_m``. The force
``f_N n + f_T`` acts on the slave node; its opposite is spread over the four
master nodes with the same shape functions, then both are mapped to modal
coordinates with the mode shapes (``Psi_k^T A^T F``).

The normal of a cell is taken from the undeformed geometry and rotates with the
master frame (small elastic rotations of the face are neglected, consistent
with the linear modal kinematics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import unit_vector
from fuzzymbs.mbs.forces import NodeRef
from fuzzymbs.mbs.kernels import layout as K
from fuzzymbs.mbs.parameters import Scalar

CARTESIAN = 0
POLAR = 1


@dataclass(frozen=True, eq=False)
class CartesianChart:
    """Flat-patch chart: ``u = u_axis . (p - origin)``, ``v = v_axis . (p - origin)``."""

    u_axis: ArrayLike | str = "x"
    v_axis: ArrayLike | str = "z"
    origin: ArrayLike = (0.0, 0.0, 0.0)

    def frame(self) -> tuple[int, NDArray[np.float64]]:
        a1 = unit_vector(self.u_axis, "CartesianChart u_axis")
        a2 = unit_vector(self.v_axis, "CartesianChart v_axis")
        if abs(a1 @ a2) > 1e-12:
            raise InvalidParameterError("CartesianChart u_axis and v_axis must be orthogonal")
        return CARTESIAN, np.concatenate([np.asarray(self.origin, float), a1, a2])


@dataclass(frozen=True, eq=False)
class PolarChart:
    """Annular-patch chart about ``axis`` through ``origin``: radius r and angle theta.

    theta is measured from ``reference`` (projected onto the plane normal to the
    axis) towards ``axis x reference``, in (-pi, pi]. A sector patch must not
    straddle theta = +-pi: choose ``reference`` inside the sector (a full annulus
    is detected as periodic and is fine).
    """

    axis: ArrayLike | str = "y"
    reference: ArrayLike | str = "x"
    origin: ArrayLike = (0.0, 0.0, 0.0)

    def frame(self) -> tuple[int, NDArray[np.float64]]:
        e = unit_vector(self.axis, "PolarChart axis")
        ref = unit_vector(self.reference, "PolarChart reference")
        a1 = ref - (ref @ e) * e
        if np.linalg.norm(a1) < 1e-9:
            raise InvalidParameterError("PolarChart reference must not be parallel to the axis")
        a1 /= np.linalg.norm(a1)
        a2 = np.cross(e, a1)
        return POLAR, np.concatenate([np.asarray(self.origin, float), a1, a2])


Chart = CartesianChart | PolarChart


@dataclass(frozen=True, eq=False)
class PenaltyContact:
    """One pass of node-to-surface contact: slave nodes against a master patch.

    Parameters
    ----------
    name : str
        Element name.
    slave_body : str
        Body whose ``slave_nodes`` are checked.
    slave_nodes : node reference
        Node set name or indices.
    master_body : str
        Body carrying the surface.
    master_nodes : node reference
        Nodes of the master patch; they must form a full tensor grid in ``chart``.
    chart : CartesianChart or PolarChart
        Coordinates of the patch in the master body frame.
    penalty : float or Parameter
        Penalty stiffness c_p per slave node [N/m], > 0.
    friction : float or Parameter
        Coulomb coefficient mu [-], >= 0.
    regularization_velocity : float
        eps [m/s] of the regularised friction law, > 0: below |v_t| ~ eps the law is
        viscous (slope mu f_N / eps); for |v_t| >> eps the force is
        ``mu f_N (1 - eps^2 / (2 |v_t|^2))``.
    normal_damping : float
        Contact damping d_n [N s/m] acting only while in contact, >= 0.
    normal : axis name or 3-vector, optional
        Which side of the master patch the slave is on (master frame): cell normals
        are oriented with ``n . normal > 0``. Default: towards the slave nodes'
        reference positions (needs them off the patch plane).
    """

    name: str
    slave_body: str
    slave_nodes: NodeRef
    master_body: str
    master_nodes: NodeRef
    chart: Chart
    penalty: Scalar
    friction: Scalar = 0.0
    regularization_velocity: float = 1e-3
    normal_damping: float = 0.0
    normal: ArrayLike | str | None = None

    table = "contacts"

    def _ends(self, ctx):
        """(slave body, master body, slave nodes, master nodes), checked."""
        sb = ctx.body(self.slave_body, f"contact {self.name!r} slave_body")
        mb = ctx.body(self.master_body, f"contact {self.name!r} master_body")
        if sb is mb:
            raise InvalidParameterError(
                f"contact {self.name!r}: slave and master are the same body"
            )
        sn = ctx.nodes(sb, self.slave_nodes, f"contact {self.name!r} slave_nodes")
        mn = ctx.nodes(mb, self.master_nodes, f"contact {self.name!r} master_nodes")
        return sb, mb, sn, mn

    def track(self, ctx) -> None:
        """The kernels follow every slave and master node of the pass."""
        sb, mb, sn, mn = self._ends(ctx)
        ctx.tracked[sb.name].update(sn.tolist())
        ctx.tracked[mb.name].update(mn.tolist())

    def compile(self, ctx) -> None:
        """Rows ``ci`` (layout ``C_*``) and ``cf`` (chart frame, eps, normal damping, the
        cell look-up constants) of the pass; the master patch as a tensor grid."""
        sb, mb, sn, mn = self._ends(ctx)
        kind, frame = self.chart.frame()
        slave_ref = sb.origin + sb.modal.node_positions[sn] - mb.origin  # master frame, t = 0
        side = (
            None
            if self.normal is None
            else unit_vector(self.normal, f"contact {self.name!r} normal")
        )
        patch = build_patch(self.name, kind, frame, mb.modal.node_positions, mn, slave_ref, side)
        grid_tracked = np.vectorize(lambda n, name=mb.name: ctx.tracked_id[(name, int(n))])(
            patch.grid
        )
        slave_tracked = [ctx.tracked_id[(sb.name, int(n))] for n in sn]
        pools = ctx.pools
        row = np.zeros(14, dtype=np.int64)
        row[K.C_SBODY] = ctx.index[sb.name]
        row[K.C_MBODY] = ctx.index[mb.name]
        row[K.C_SLAVE0] = pools.addi(slave_tracked)
        row[K.C_NSLAVE] = len(slave_tracked)
        row[K.C_KIND] = kind
        row[K.C_NU] = patch.u.size
        row[K.C_NV] = patch.v.size
        row[K.C_U0] = pools.addf(patch.u)
        row[K.C_V0] = pools.addf(patch.v)
        row[K.C_GRID0] = pools.addi(grid_tracked)
        row[K.C_NORMAL0] = pools.addf(patch.normals)
        row[K.C_PEN] = ctx.table.add(self.penalty, f"contact {self.name!r} penalty", 0.0)
        row[K.C_MU] = ctx.table.add(self.friction, f"contact {self.name!r} friction", 0.0)
        row[K.C_PERIODIC] = int(patch.periodic)
        floats = np.concatenate(
            [
                frame,
                [self.regularization_velocity, self.normal_damping],
                lookup_constants(patch),
            ]
        )
        ctx.rows[self.table].append((row, floats))

    def __post_init__(self) -> None:
        if not (np.isfinite(self.regularization_velocity) and self.regularization_velocity > 0):
            raise InvalidParameterError(
                f"contact {self.name!r}: regularization_velocity must be > 0 m/s, got "
                f"{self.regularization_velocity!r}"
            )
        if not (np.isfinite(self.normal_damping) and self.normal_damping >= 0):
            raise InvalidParameterError(
                f"contact {self.name!r}: normal_damping must be >= 0, got {self.normal_damping!r}"
            )


def symmetric_contact(
    name: str,
    body_a: str,
    nodes_a: NodeRef,
    chart_a: Chart,
    body_b: str,
    nodes_b: NodeRef,
    chart_b: Chart,
    penalty: Scalar,
    friction: Scalar = 0.0,
    regularization_velocity: float = 1e-3,
    normal_damping: float = 0.0,
    normal_a: ArrayLike | str | None = None,
    normal_b: ArrayLike | str | None = None,
) -> tuple[PenaltyContact, PenaltyContact]:
    """Two-pass contact: a's nodes against b's patch, and b's nodes against a's patch.

    Both passes use the same penalty per node, so a pressed patch carries the load
    on the slave and master nodes together (about half the penetration of a
    single pass when both sides have similar node counts; see docs/embs.md).
    ``normal_a`` / ``normal_b`` orient the normals of a's and b's patches (their own frames).
    """
    common = {
        "penalty": penalty,
        "friction": friction,
        "regularization_velocity": regularization_velocity,
        "normal_damping": normal_damping,
    }
    return (
        PenaltyContact(
            f"{name}[a->b]", body_a, nodes_a, body_b, nodes_b, chart_b, **common, normal=normal_b
        ),
        PenaltyContact(
            f"{name}[b->a]", body_b, nodes_b, body_a, nodes_a, chart_a, **common, normal=normal_a
        ),
    )


def chart_coordinates(kind: int, frame: NDArray[np.float64], p: NDArray[np.float64]):
    """Chart coordinates (u, v) of points p (n, 3) in the master body frame."""
    d = p - frame[0:3]
    a = d @ frame[3:6]
    b = d @ frame[6:9]
    if kind == CARTESIAN:
        return a, b
    return np.hypot(a, b), np.arctan2(b, a)


def _cluster(values: NDArray[np.float64], tol: float) -> NDArray[np.float64]:
    s = np.sort(values)
    groups = [[s[0]]]
    for v in s[1:]:
        if v - groups[-1][-1] <= tol:
            groups[-1].append(v)
        else:
            groups.append([v])
    return np.array([np.mean(g) for g in groups])


@dataclass(frozen=True)
class Patch:
    """A master patch as a tensor grid: grid[i, j] is the master node at (u_i, v_j)."""

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    grid: NDArray[np.int64]  # (nu, nv) node indices of the master body
    normals: NDArray[np.float64]  # (nu-1 or nu, nv-1 or nv, 3) in the master frame
    periodic: bool


def build_patch(
    name: str,
    kind: int,
    frame: NDArray[np.float64],
    positions: NDArray[np.float64],
    nodes: NDArray[np.int64],
    slave_positions: NDArray[np.float64],
    side: NDArray[np.float64] | None = None,
) -> Patch:
    """Arrange master ``nodes`` into a tensor grid of chart coordinates.

    ``positions`` are the master's undeformed node positions (body frame);
    ``slave_positions`` (master frame, reference configuration) orient the cell
    normals towards the slave side, unless ``side`` (a vector, master frame) is given.

    Raises
    ------
    InvalidParameterError
        If the nodes do not form a full grid (every (u_i, v_j) exactly once) of
        at least 2 x 2 nodes.
    """
    p = positions[nodes]
    u, v = chart_coordinates(kind, frame, p)
    size = max(np.ptp(p, axis=0).max(), 1e-300)
    tol_u = 1e-6 * size
    tol_v = 1e-6 * (1.0 if kind == CARTESIAN else 1.0 / max(u.max(), 1e-300)) * size
    if kind == POLAR:
        tol_v = 1e-6  # rad
    ug = _cluster(u, tol_u)
    vg = _cluster(v, tol_v)
    grid = -np.ones((ug.size, vg.size), dtype=np.int64)
    iu = np.abs(u[:, None] - ug[None, :]).argmin(axis=1)
    iv = np.abs(v[:, None] - vg[None, :]).argmin(axis=1)
    for n, i, j in zip(nodes, iu, iv, strict=True):
        if grid[i, j] >= 0:
            raise InvalidParameterError(
                f"contact {name!r}: master nodes {grid[i, j]} and {n} share chart cell "
                f"({ug[i]:.6g}, {vg[j]:.6g}); the master patch must be a tensor grid"
            )
        grid[i, j] = n
    if ug.size < 2 or vg.size < 2 or (grid < 0).any():
        raise InvalidParameterError(
            f"contact {name!r}: the {nodes.size} master nodes do not form a full "
            f"{ug.size} x {vg.size} grid in the chart (need every (u_i, v_j), at least 2 x 2)"
        )
    periodic = False
    if kind == POLAR and vg.size > 2:
        dv = np.diff(vg)
        if np.allclose(dv, dv[0], rtol=1e-6) and abs(vg.size * dv[0] - 2 * np.pi) < 1e-6:
            periodic = True
    ncu = ug.size - 1
    ncv = vg.size if periodic else vg.size - 1
    normals = np.zeros((ncu, ncv, 3))
    centre_slave = slave_positions.mean(axis=0)
    for i in range(ncu):
        for j in range(ncv):
            j1 = (j + 1) % vg.size
            a, b = positions[grid[i, j]], positions[grid[i + 1, j]]
            c, d = positions[grid[i + 1, j1]], positions[grid[i, j1]]
            n = np.cross(c - a, d - b)
            if np.linalg.norm(n) == 0:
                raise InvalidParameterError(f"contact {name!r}: degenerate master cell ({i}, {j})")
            n /= np.linalg.norm(n)
            towards = centre_slave - 0.25 * (a + b + c + d) if side is None else side
            dot = n @ towards
            if abs(dot) <= 1e-9 * np.linalg.norm(towards) or not np.isfinite(dot):
                raise InvalidParameterError(
                    f"contact {name!r}: cannot tell which side of master cell ({i}, {j}) the "
                    "slave is on (slave nodes lie in the patch plane); pass normal=..."
                )
            if dot < 0:
                n = -n
            normals[i, j] = n
    return Patch(ug, vg, grid, normals, periodic)


def is_uniform_grid(grid: NDArray[np.float64], cells: int) -> bool:
    """True if the first ``cells`` intervals of ``grid`` are equal to 1e-12 relative."""
    h = (grid[cells] - grid[0]) / cells
    return bool(np.all(np.abs(np.diff(grid[: cells + 1]) - h) <= 1e-12 * abs(h)))


def lookup_constants(patch: Patch) -> list[float]:
    """Scales and uniformity flags of the O(1) cell look-up (the brake kernels'
    CF_USCALE...CF_VUNIFORM; the spatial SurfaceContact's data).

    Index scale = cells / span of each grid direction; a periodic angle grid spans 2 pi
    and is uniform only if its wrap-around cell has the width of the others.
    """
    u = patch.u
    v = patch.v
    u_scale = (u.size - 1) / (u[-1] - u[0])
    u_uniform = is_uniform_grid(u, u.size - 1)
    if patch.periodic:
        v_scale = v.size / (2.0 * np.pi)
        wrap = v[0] + 2.0 * np.pi - v[-1]
        v_uniform = is_uniform_grid(v, v.size - 1) and abs(wrap - (v[1] - v[0])) < 1e-9
    else:
        v_scale = (v.size - 1) / (v[-1] - v[0])
        v_uniform = is_uniform_grid(v, v.size - 1)
    return [u_scale, float(u_uniform), v_scale, float(v_uniform)]
