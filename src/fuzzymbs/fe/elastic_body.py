"""Linear-elastic finite-element body: consistent mass and stiffness with scikit-fem.

Node ``j`` of the mesh (column ``j`` of ``mesh.doflocs``) carries the three
displacement DOFs ``3 j + c`` (c = 0, 1, 2 for x, y, z); this is scikit-fem's
own ordering for ``ElementVector`` bases, checked at assembly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from skfem import (
    Basis,
    BilinearForm,
    ElementHex1,
    ElementHex2,
    ElementTetP1,
    ElementTetP2,
    Mesh,
    MeshHex1,
    MeshHex2,
    MeshTet1,
    MeshTet2,
    asm,
)
from skfem.models.elasticity import lame_parameters

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.meshes import mesh_nodes, span_text
from fuzzymbs.fe.reduction import modal_truncation, reduce_body, rigid_body_basis
from fuzzymbs.fe.surfaces import boundary_nodes
from fuzzymbs.mbs.modal_body import ModalBody

__all__ = ["ElasticBody"]

# the Lagrange element whose nodes are the mesh's doflocs
_ELEMENTS = {
    MeshHex1: ElementHex1,
    MeshHex2: ElementHex2,
    MeshTet1: ElementTetP1,
    MeshTet2: ElementTetP2,
}

FixedSpec = str | Callable[[NDArray[np.float64]], NDArray[np.bool_]] | Sequence[int] | None


@BilinearForm
def _unit_density_mass(u: Any, v: Any, w: Any) -> Any:
    return u * v


def _gradient_product(a: int, b: int) -> BilinearForm:
    """Scalar form int dv/dx_a du/dx_b dV (test function v is the row, trial u the column)."""

    @BilinearForm
    def form(u: Any, v: Any, w: Any) -> Any:
        return v.grad[a] * u.grad[b]

    return form


class ElasticBody:
    """An isotropic linear-elastic body meshed with hexahedra or tetrahedra.

    The matrices are assembled lazily (first use of :attr:`stiffness` or
    :attr:`mass_matrix`), so a reduction loaded from the cache never assembles.

    Parameters
    ----------
    mesh
        scikit-fem mesh: ``MeshHex1``, ``MeshHex2`` (27-node, recommended for
        thin parts in bending), ``MeshTet1`` or ``MeshTet2``.
    youngs_modulus
        E [Pa], > 0.
    poisson_ratio
        nu [-], in (-1, 0.5).
    density
        rho [kg/m^3], > 0.
    fixed
        Clamped nodes (all three DOFs): a boundary name, a predicate on node
        coordinates ``x`` of shape (3, n) returning a boolean mask (use a
        tolerance on curved surfaces), an array of node indices, or ``None`` for a
        free-free body.
    name
        Label carried into the reduced body.
    """

    def __init__(
        self,
        mesh: Mesh,
        youngs_modulus: float,
        poisson_ratio: float,
        density: float,
        fixed: FixedSpec = None,
        name: str = "body",
    ) -> None:
        element = _ELEMENTS.get(type(mesh))
        if element is None:
            raise InvalidParameterError(
                f"mesh type {type(mesh).__name__} is not supported; use one of "
                f"{sorted(cls.__name__ for cls in _ELEMENTS)}"
            )
        youngs_modulus = float(youngs_modulus)
        poisson_ratio = float(poisson_ratio)
        density = float(density)
        if not (np.isfinite(youngs_modulus) and youngs_modulus > 0):
            raise InvalidParameterError(f"youngs_modulus must be > 0 [Pa], got {youngs_modulus!r}")
        if not (np.isfinite(poisson_ratio) and -1.0 < poisson_ratio < 0.5):
            raise InvalidParameterError(
                f"poisson_ratio must lie in (-1, 0.5), got {poisson_ratio!r}"
            )
        if not (np.isfinite(density) and density > 0):
            raise InvalidParameterError(f"density must be > 0 [kg/m^3], got {density!r}")
        self.mesh = mesh
        self.element = element()
        self.youngs_modulus = youngs_modulus
        self.poisson_ratio = poisson_ratio
        self.density = density
        self.name = str(name)
        self.nodes: NDArray[np.float64] = mesh_nodes(mesh)
        self.fixed_nodes: NDArray[np.int64] = self._resolve_fixed(fixed)
        self._stiffness: sp.csr_matrix | None = None
        self._mass: sp.csr_matrix | None = None

    # ------------------------------------------------------------------ geometry

    @property
    def n_nodes(self) -> int:
        """Number of nodes n."""
        return int(self.nodes.shape[0])

    @property
    def n_dofs(self) -> int:
        """Number of displacement DOFs, 3 n."""
        return 3 * self.n_nodes

    @property
    def is_free(self) -> bool:
        """True when no node is clamped (6 rigid-body modes)."""
        return self.fixed_nodes.size == 0

    @property
    def fixed_dofs(self) -> NDArray[np.int64]:
        """Sorted clamped DOF indices."""
        return (3 * self.fixed_nodes[:, None] + np.arange(3)).ravel()

    @property
    def free_dofs(self) -> NDArray[np.int64]:
        """Sorted unconstrained DOF indices."""
        mask = np.ones(self.n_dofs, dtype=bool)
        mask[self.fixed_dofs] = False
        return np.flatnonzero(mask)

    def node_set(self, spec: FixedSpec) -> NDArray[np.int64]:
        """Resolve a node specification to node indices.

        Boundary names and coordinate predicates give sorted indices; an index
        array is checked and returned in the order given (spring pairs, grids).
        """
        if spec is None:
            return np.zeros(0, dtype=np.int64)
        if isinstance(spec, str):
            return boundary_nodes(self.mesh, spec)
        if callable(spec):
            mask = np.asarray(spec(self.nodes.T), dtype=bool)
            if mask.shape != (self.n_nodes,):
                raise InvalidParameterError(
                    f"node predicate must return a boolean mask of shape ({self.n_nodes},), "
                    f"got {mask.shape}"
                )
            if not mask.any():
                name = getattr(spec, "__qualname__", None) or repr(spec)
                raise InvalidParameterError(
                    f"node predicate {name} selects no node of the mesh (it spans "
                    f"{span_text(self.nodes.T)}); check its coordinates, units [m] and tolerances"
                )
            return np.flatnonzero(mask).astype(np.int64)
        nodes = np.asarray(spec).reshape(-1)
        if nodes.size == 0:
            raise InvalidParameterError(f"node index list {spec!r} is empty")
        if (
            not np.issubdtype(nodes.dtype, np.integer)
            or nodes.min() < 0
            or nodes.max() >= self.n_nodes
        ):
            raise InvalidParameterError(
                f"node indices must be integers in [0, {self.n_nodes}), got {spec!r}"
            )
        if np.unique(nodes).size != nodes.size:
            raise InvalidParameterError(f"node indices must not repeat, got {spec!r}")
        return nodes.astype(np.int64)

    def _resolve_fixed(self, fixed: FixedSpec) -> NDArray[np.int64]:
        nodes = np.unique(self.node_set(fixed))
        if fixed is not None and nodes.size == 0:
            raise InvalidParameterError(f"fixed={fixed!r} selects no node")
        return nodes

    # ------------------------------------------------------------------ matrices

    def _assemble(self) -> None:
        """Assemble K and M from scalar scikit-fem forms (fast), interleaved as DOF 3 j + c.

        Isotropic linear elasticity, block (a, b) of the stiffness between
        components a and b (Lame parameters lambda, mu):

            K_ab = lambda D_ab + mu D_ba + mu delta_ab (D_00 + D_11 + D_22),
            D_ab[i, j] = int dN_i/dx_a dN_j/dx_b dV,

        and the consistent mass is rho int N_i N_j dV on each diagonal block. This
        equals assembling the vector form, at a ninth of the local matrix size.
        Hexahedra use full Gauss integration (2 or 3 points per direction).
        """
        basis = self.scalar_basis()
        if basis.N != self.n_nodes or not np.allclose(
            basis.doflocs, self.mesh.doflocs, rtol=0.0, atol=1e-12 * np.abs(self.nodes).max()
        ):  # pragma: no cover - guards the node-ordering assumption against skfem changes
            raise RuntimeError("scikit-fem basis nodes differ from mesh.doflocs")
        gradients = [
            [asm(_gradient_product(a, b), basis).tocoo() for b in range(3)] for a in range(3)
        ]
        scalar_mass = asm(_unit_density_mass, basis).tocoo()
        lam, mu = lame_parameters(self.youngs_modulus, self.poisson_ratio)
        laplace = sum(gradients[c][c] for c in range(3))
        rows, cols, k_values, m_rows, m_cols, m_values = [], [], [], [], [], []
        for a in range(3):
            for b in range(3):
                block = (lam * gradients[a][b] + mu * gradients[b][a]).tocoo()
                if a == b:
                    block = (block + mu * laplace).tocoo()
                rows.append(3 * block.row + a)
                cols.append(3 * block.col + b)
                k_values.append(block.data)
            m_rows.append(3 * scalar_mass.row + a)
            m_cols.append(3 * scalar_mass.col + a)
            m_values.append(self.density * scalar_mass.data)
        shape = (self.n_dofs, self.n_dofs)
        stiffness = sp.csr_matrix(
            (np.concatenate(k_values), (np.concatenate(rows), np.concatenate(cols))), shape=shape
        )
        mass = sp.csr_matrix(
            (np.concatenate(m_values), (np.concatenate(m_rows), np.concatenate(m_cols))),
            shape=shape,
        )
        # exact symmetry (assembly round-off) keeps eigsh and Cholesky-type solvers happy
        self._stiffness = ((stiffness + stiffness.T) * 0.5).tocsr()
        self._mass = ((mass + mass.T) * 0.5).tocsr()

    def scalar_basis(self) -> Basis:
        """The scalar scikit-fem basis of the mesh's Lagrange element; hexahedra with full
        Gauss integration (2 or 3 points per direction)."""
        if isinstance(self.mesh, MeshHex1):  # MeshHex2 is a subclass of MeshHex1
            order = 2 if isinstance(self.mesh, MeshHex2) else 1
            return Basis(self.mesh, self.element, intorder=2 * order)
        return Basis(self.mesh, self.element)

    def _assembled(self) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """(K, M), assembled on first use."""
        if self._stiffness is None or self._mass is None:
            self._assemble()
        assert self._stiffness is not None and self._mass is not None
        return self._stiffness, self._mass

    @property
    def stiffness(self) -> sp.csr_matrix:
        """Stiffness matrix K (3n x 3n) [N/m], without boundary conditions."""
        return self._assembled()[0]

    @property
    def mass_matrix(self) -> sp.csr_matrix:
        """Consistent mass matrix M (3n x 3n) [kg], without boundary conditions."""
        return self._assembled()[1]

    @property
    def is_assembled(self) -> bool:
        """Whether K and M have been assembled (False after a pure cache hit)."""
        return self._stiffness is not None

    # ------------------------------------------------------------------ analysis

    def rigid_body_modes(self) -> NDArray[np.float64]:
        """The six rigid-body displacement fields (3n x 6): translations x, y, z, rotations.

        Rotations are about the axes through the centre of mass, and the six
        columns are mass-orthonormalised (``R^T M R = I``).
        """
        return rigid_body_basis(self.nodes, self.mass_matrix)

    def natural_frequencies(self, n: int, include_rigid: bool = False) -> NDArray[np.float64]:
        """The n lowest natural frequencies f = omega / (2 pi) [Hz].

        Parameters
        ----------
        n
            Number of frequencies.
        include_rigid
            For a free-free body, whether to return the six (near-)zero
            rigid-body frequencies too (default: elastic frequencies only).
        """
        result = modal_truncation(
            self, n, rigid_body_modes="include" if include_rigid else "exclude"
        )
        return result.frequencies[:n] / (2.0 * np.pi)

    def static_deflection(self, loads: ArrayLike) -> NDArray[np.float64]:
        """Full-DOF static deflection u with K u = f of a clamped body [m].

        Parameters
        ----------
        loads
            Nodal forces, shape (3n,) or (3n, k) [N].
        """
        if self.is_free:
            raise InvalidParameterError(
                f"body {self.name!r} is free-free: K is singular, a static deflection needs "
                "a clamped body (use fixed=...)"
            )
        from scipy.sparse.linalg import splu

        f = np.asarray(loads, dtype=np.float64)
        if f.ndim not in (1, 2) or f.shape[0] != self.n_dofs:
            raise InvalidParameterError(
                f"loads must have shape ({self.n_dofs},) or ({self.n_dofs}, k) (3 per node), "
                f"got {f.shape}"
            )
        if not np.all(np.isfinite(f)):
            raise InvalidParameterError("loads must be finite (no NaN or inf)")
        free = self.free_dofs
        stiffness = self.stiffness[free][:, free].tocsc()
        u = np.zeros_like(f)
        u[free] = splu(stiffness, permc_spec="MMD_AT_PLUS_A").solve(np.ascontiguousarray(f[free]))
        return u

    def reduce(self, n_modes: int, **options: Any) -> ModalBody:
        """Modally reduce this body; see :func:`fuzzymbs.fe.reduction.reduce_body`."""
        import inspect

        allowed = list(inspect.signature(reduce_body).parameters)[2:]
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            raise InvalidParameterError(
                f"unknown reduction option(s) {unknown}; options: {', '.join(allowed)}"
            )
        return reduce_body(self, n_modes, **options)

    def __repr__(self) -> str:
        return (
            f"ElasticBody(name={self.name!r}, mesh={type(self.mesh).__name__}, "
            f"nodes={self.n_nodes}, E={self.youngs_modulus:g} Pa, nu={self.poisson_ratio:g}, "
            f"rho={self.density:g} kg/m^3, fixed_nodes={self.fixed_nodes.size})"
        )
