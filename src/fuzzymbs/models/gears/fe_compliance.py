"""Flank compliance (influence coefficients) of a whole gear from a 2D finite-element model.

The gear (:func:`~fuzzymbs.models.gears.fe_mesh.mesh_gear`) is discretised with
quadratic triangles (scikit-fem ``ElementTriP2``), thickness b, in plane strain
or plane stress, and supported at its bore (``"clamped"``: both displacement
components held, a shaft bonded to the bore; ``"tangential"``: only the
circumferential component held, the bore may widen). The stiffness matrix is
factorised once; unit forces at the influence grid of tooth 0's drive flank
give, by the gear's rotational symmetry, the coupling of any two loaded teeth.

Point loads make the surface displacement under the load infinite in 2D (it
grows like ln(1/h) with the mesh size h). The local part of the deformation is
therefore split off (the decomposition of Weber 1949 and of Andersson & Vedmar
2003): under its own load a flank point is represented by a *reference point*
at depth ``d_ref`` below it along the inward flank normal, whose displacement
the FE model resolves; the approach between the surface and the reference point
is added analytically from the half-plane solution under Hertzian pressure
(:mod:`fuzzymbs.models.gears.half_plane`). Loads on other teeth are far from
the measured point and use the surface displacement directly.

Every table is stored for E = 1 Pa (the compliance of a linear elastic body
scales with 1/E at fixed Poisson's ratio, so a fuzzy E needs no new
factorisation) and cached on disk, keyed by a SHA-256 of every input (gear data
except E and density, mesh options, analysis type, support, reference depth,
format version), in ``$FUZZYMBS_CACHE_DIR/fe`` like the reduced FE bodies.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import time
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.files import save_npz_atomically
from fuzzymbs.models.gears.fe_mesh import flank_point, mesh_gear
from fuzzymbs.models.gears.geometry import SpurGear

__all__ = [
    "ANALYSES",
    "SUPPORTS",
    "FlankCompliance",
    "MeshOptions",
    "compliance_key",
    "flank_compliance",
]

#: Plane analyses: thin gears (plane stress) or wide gears (plane strain).
ANALYSES = ("plane-strain", "plane-stress")
#: Bore boundary conditions.
SUPPORTS = ("clamped", "tangential")
#: bump when the stored layout or the numerics change
FORMAT_VERSION = 1


@dataclass(frozen=True)
class MeshOptions:
    """Discretisation of one gear, in multiples of the module m.

    Attributes
    ----------
    fine_size : float
        Boundary spacing on the loaded teeth / m (default 1/24: 0.19 mm at m = 4.5 mm).
    coarse_size : float
        Boundary spacing elsewhere and largest element edge / m (default 1/3).
    loaded_teeth : int
        Odd number of finely meshed teeth around the loaded tooth whose coupling is
        modelled (default 5: a tooth and two neighbours on each side).
    grid_points : int
        Influence-grid points on a drive flank (default 24).
    reference_depth : float
        Depth d_ref of the reference points below the flank / m (default 0.15).
    """

    fine_size: float = 1.0 / 24.0
    coarse_size: float = 1.0 / 3.0
    loaded_teeth: int = 5
    grid_points: int = 24
    reference_depth: float = 0.15

    def __post_init__(self) -> None:
        for name in ("fine_size", "coarse_size", "reference_depth"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
                raise InvalidParameterError(f"mesh option {name} must be positive, got {value!r}")
        if self.fine_size > self.coarse_size:
            raise InvalidParameterError(
                f"fine_size {self.fine_size} must not exceed coarse_size {self.coarse_size}"
            )
        teeth = self.loaded_teeth
        if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1 or teeth % 2 == 0:
            raise InvalidParameterError(
                f"mesh option loaded_teeth must be an odd integer >= 1, got {teeth!r}"
            )
        points = self.grid_points
        if isinstance(points, bool) or int(points) != points or points < 4:
            raise InvalidParameterError(
                f"mesh option grid_points must be an integer >= 4, got {points!r}"
            )
        if self.reference_depth < 2.0 * self.fine_size:
            raise InvalidParameterError(
                f"reference_depth {self.reference_depth} must be at least twice fine_size "
                f"{self.fine_size} (the FE model resolves the reference points)"
            )


@dataclass(frozen=True)
class FlankCompliance:
    """Influence coefficients of one gear's drive flanks, for E = 1 Pa [m/N * Pa].

    All vectors are in tooth-local frames (gear centre at the origin, the tooth's
    centreline on +x, drive flank at +y). Divide by E [Pa] for compliances [m/N].

    Attributes
    ----------
    grid_roll : ndarray (S,)
        Roll lengths s of the influence grid on the drive flank [m].
    tooth_offsets : ndarray (n,)
        Offsets d of the modelled teeth from the loaded one (d > 0 counter-clockwise).
    surface : ndarray (n, S, S, 2, 2)
        ``surface[d, i, j, a, c]``: displacement component a of grid point i of tooth d
        (tooth d's frame) under a unit force component c at grid point j of tooth 0.
        The entries of d = 0 near i = j hold the singular point-load field and are
        not used.
    reference : ndarray (S, 2, 2)
        Displacement of the reference point under grid point i (depth d_ref along the
        inward normal) under a unit force at grid point i.
    centreline : ndarray (S, 2, 2)
        Displacement of the point where the flank normal through grid point i crosses
        the tooth centreline, under a unit force at grid point i (Weber's tooth
        deflection; used to check the FE model against beam theory).
    reference_depth : float
        d_ref [m].
    analysis, support : str
    dofs : int
        Unknowns of the FE model after the support.
    seconds : float
        Time spent on meshing, assembly, factorisation and solves [s] (0 when loaded
        from the cache).
    """

    grid_roll: np.ndarray
    tooth_offsets: np.ndarray
    surface: np.ndarray
    reference: np.ndarray
    centreline: np.ndarray
    reference_depth: float
    analysis: str
    support: str
    dofs: int
    seconds: float = 0.0

    def offset_index(self, offset: int) -> int | None:
        """Row of tooth offset d in ``surface``, or None when the coupling is not modelled."""
        half = (len(self.tooth_offsets) - 1) // 2
        return offset + half if abs(offset) <= half else None


def _check(analysis: str, support: str) -> None:
    if analysis not in ANALYSES:
        raise InvalidParameterError(f"analysis must be one of {ANALYSES}, got {analysis!r}")
    if support not in SUPPORTS:
        raise InvalidParameterError(f"support must be one of {SUPPORTS}, got {support!r}")


def compliance_key(gear: SpurGear, options: MeshOptions, analysis: str, support: str) -> str:
    """SHA-256 key of a flank-compliance table: every input except E and density."""
    _check(analysis, support)
    neutral = dataclasses.replace(gear, youngs_modulus=1.0, density=1.0)
    text = repr((FORMAT_VERSION, neutral, options, analysis, support))
    return hashlib.sha256(text.encode()).hexdigest()


def _lame(poisson: float, analysis: str) -> tuple[float, float]:
    """Lame constants at E = 1; plane stress: lambda* = 2 lambda mu / (lambda + 2 mu)."""
    mu = 1.0 / (2.0 * (1.0 + poisson))
    if analysis == "plane-strain":
        return poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson)), mu
    return poisson / (1.0 - poisson**2), mu


def _support_map(basis, bore_facets: np.ndarray, support: str):
    """Sparse map T from the retained unknowns to all DOFs (u = T q)."""
    from scipy import sparse

    dofs = basis.get_dofs(facets=bore_facets)
    ux = np.concatenate((dofs.nodal["u^1"], dofs.facet["u^1"]))
    uy = np.concatenate((dofs.nodal["u^2"], dofs.facet["u^2"]))
    held = np.zeros(basis.N, dtype=bool)
    held[ux] = held[uy] = True
    free = np.flatnonzero(~held)
    rows = [free]
    cols = [np.arange(free.size)]
    vals = [np.ones(free.size)]
    columns = free.size
    if support == "tangential":
        # one radial unknown per bore node: (ux, uy) = (cos phi, sin phi) q_r
        angle = np.arctan2(basis.doflocs[1, ux], basis.doflocs[0, ux])
        radial = columns + np.arange(ux.size)
        rows += [ux, uy]
        cols += [radial, radial]
        vals += [np.cos(angle), np.sin(angle)]
        columns += ux.size
    return sparse.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(basis.N, columns),
    )


@dataclass
class _Assembly:
    """What a gear's FE model shares across Poisson's ratios and plane analyses.

    The stiffness is linear in the Lame constants, K = b (lambda K_lambda + mu K_mu):
    the mesh, the basis, the probe matrices and the two parts are reused, so a new
    Poisson's ratio costs only the combination, the factorisation and the solves.
    K_mu is assembled when a second (lambda, mu) is asked for; K_lambda then follows
    from the first full matrix.
    """

    mesh_data: Any
    basis: Any
    bore_facets: np.ndarray
    reference_probes: Any
    centreline_probes: Any
    first: tuple[float, float]
    first_matrix: Any
    mu_part: Any = None
    lambda_part: Any = None

    def stiffness(self, lam: float, mu: float) -> Any:
        """K / b at the Lame constants (lam, mu) [E = 1]."""
        from skfem import asm
        from skfem.models.elasticity import linear_elasticity

        if (lam, mu) == self.first:
            return self.first_matrix
        if self.mu_part is None:
            self.mu_part = asm(linear_elasticity(0.0, 1.0), self.basis)
            lam0, mu0 = self.first
            self.lambda_part = (self.first_matrix - mu0 * self.mu_part) / lam0
        return lam * self.lambda_part + mu * self.mu_part


#: the last assemblies of this process, by gear geometry and mesh options (a few)
_ASSEMBLIES: OrderedDict[str, _Assembly] = OrderedDict()
_KEEP_ASSEMBLIES = 2


def _assembly(gear: SpurGear, options: MeshOptions, lam: float, mu: float) -> _Assembly:
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri, asm
    from skfem.models.elasticity import linear_elasticity

    neutral = dataclasses.replace(gear, youngs_modulus=1.0, density=1.0, poisson_ratio=0.0)
    key = repr((neutral, options))
    if key in _ASSEMBLIES:
        _ASSEMBLIES.move_to_end(key)
        return _ASSEMBLIES[key]
    m = gear.module
    mesh_data = mesh_gear(
        gear,
        fine_size=options.fine_size * m,
        coarse_size=options.coarse_size * m,
        loaded_teeth=options.loaded_teeth,
        grid_points=options.grid_points,
    )
    mesh = MeshTri(mesh_data.points.T.copy(), mesh_data.triangles.T.copy())
    basis = Basis(mesh, ElementVector(ElementTriP2()))
    bore = np.zeros(mesh.p.shape[1], dtype=bool)
    bore[mesh_data.bore_vertices] = True
    boundary = mesh.boundary_facets()
    bore_facets = boundary[bore[mesh.facets[0, boundary]] & bore[mesh.facets[1, boundary]]]
    points, normals = flank_point(gear, mesh_data.grid_roll)
    # reference points at depth d_ref; Weber's deflection points, where the flank
    # normal through the grid point meets the tooth centreline
    reach = points[:, 1] / normals[:, 1]
    assembly = _Assembly(
        mesh_data=mesh_data,
        basis=basis,
        bore_facets=bore_facets,
        reference_probes=basis.probes((points - options.reference_depth * m * normals).T),
        centreline_probes=basis.probes((points - reach[:, None] * normals).T),
        first=(lam, mu),
        first_matrix=asm(linear_elasticity(lam, mu), basis),
    )
    _ASSEMBLIES[key] = assembly
    while len(_ASSEMBLIES) > _KEEP_ASSEMBLIES:
        _ASSEMBLIES.popitem(last=False)
    return assembly


def _compute(gear: SpurGear, options: MeshOptions, analysis: str, support: str) -> FlankCompliance:
    from scipy.sparse.linalg import splu

    start = time.perf_counter()
    lam, mu = _lame(gear.poisson_ratio, analysis)
    assembly = _assembly(gear, options, lam, mu)
    basis, mesh_data = assembly.basis, assembly.mesh_data
    stiffness = gear.face_width * assembly.stiffness(lam, mu)
    transform = _support_map(basis, assembly.bore_facets, support)
    reduced = (transform.T @ stiffness @ transform).tocsc()
    factor = splu(reduced, permc_spec="COLAMD")

    roll = mesh_data.grid_roll
    n_grid = roll.size
    # unit forces (x, y) at the grid vertices of tooth 0
    loaded = mesh_data.grid_vertices[(len(mesh_data.tooth_offsets) - 1) // 2]
    rhs = np.zeros((basis.N, 2 * n_grid))
    for c in range(2):
        rhs[basis.nodal_dofs[c, loaded], c * n_grid + np.arange(n_grid)] = 1.0
    solution = transform @ factor.solve(np.asarray(transform.T @ rhs))  # (N, 2S)
    solution = solution.reshape(basis.N, 2, n_grid)  # [dof, c, j]

    n_teeth = len(mesh_data.tooth_offsets)
    surface = np.empty((n_teeth, n_grid, n_grid, 2, 2))
    for row, offset in enumerate(mesh_data.tooth_offsets):
        vertices = mesh_data.grid_vertices[row]
        disp = np.stack([solution[basis.nodal_dofs[a, vertices]] for a in range(2)])  # a,i,c,j
        angle = offset * gear.angular_pitch
        c, s = math.cos(angle), math.sin(angle)
        local = np.stack((c * disp[0] + s * disp[1], -s * disp[0] + c * disp[1]))
        surface[row] = local.transpose(1, 3, 0, 2)  # i, j, a, c

    def own_load(probes: Any) -> np.ndarray:
        """Displacement at probe point i under the load at grid point i: (S, 2, 2)."""
        values = (probes @ solution.reshape(basis.N, -1)).reshape(2, n_grid, 2, n_grid)
        index = np.arange(n_grid)
        return values[:, index, :, index]  # (i, a, c)

    return FlankCompliance(
        grid_roll=roll,
        tooth_offsets=mesh_data.tooth_offsets,
        surface=surface,
        reference=own_load(assembly.reference_probes),
        centreline=own_load(assembly.centreline_probes),
        reference_depth=options.reference_depth * gear.module,
        analysis=analysis,
        support=support,
        dofs=int(reduced.shape[0]),
        seconds=time.perf_counter() - start,
    )


_FIELDS = ("grid_roll", "tooth_offsets", "surface", "reference", "centreline")


def cache_dir() -> Path:
    """The FE cache directory, ``$FUZZYMBS_CACHE_DIR/fe`` or ``~/.cache/fuzzymbs/fe``.

    The directory of :func:`fuzzymbs.fe.cache.cache_dir`, without importing
    ``fuzzymbs.fe`` (which loads scikit-fem: a warm model needs only NumPy).
    """
    root = os.environ.get("FUZZYMBS_CACHE_DIR")
    return (Path(root) if root else Path.home() / ".cache" / "fuzzymbs") / "fe"


def _path(key: str) -> Path:
    return cache_dir() / f"flank-compliance-{key}.npz"


def _store(key: str, table: FlankCompliance) -> None:
    directory = cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    arrays = {name: getattr(table, name) for name in _FIELDS}
    arrays["scalars"] = np.array([table.reference_depth, table.dofs, FORMAT_VERSION], dtype=float)
    save_npz_atomically(_path(key), arrays)


def _load(key: str, analysis: str, support: str) -> FlankCompliance | None:
    path = _path(key)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: np.array(data[name]) for name in _FIELDS}
            depth, dofs, version = data["scalars"]
    except Exception as error:  # corrupt or truncated entry: recompute
        warnings.warn(f"ignoring unreadable FE cache entry {path}: {error}", stacklevel=2)
        return None
    if int(version) != FORMAT_VERSION:
        return None
    return FlankCompliance(
        **arrays, reference_depth=float(depth), analysis=analysis, support=support, dofs=int(dofs)
    )


def flank_compliance(
    gear: SpurGear,
    options: MeshOptions | None = None,
    analysis: str = "plane-strain",
    support: str = "clamped",
    cache: bool = True,
) -> FlankCompliance:
    """Influence coefficients of a gear's drive flanks (E = 1 Pa), from the disk cache if there.

    Parameters
    ----------
    gear : SpurGear
        The gear (its E and density do not enter; its Poisson's ratio, bore radius
        ``rim_radius`` and face width do).
    options : MeshOptions, optional
        Discretisation (default :class:`MeshOptions`).
    analysis : {"plane-strain", "plane-stress"}
    support : {"clamped", "tangential"}
        Bore boundary condition.
    cache : bool
        Read and write the disk cache.

    Returns
    -------
    FlankCompliance
    """
    options = MeshOptions() if options is None else options
    key = compliance_key(gear, options, analysis, support)
    if cache:
        table = _load(key, analysis, support)
        if table is not None:
            return table
    table = _compute(gear, options, analysis, support)
    if cache:
        _store(key, table)
    return table
