"""What modal reduction and its disk cache read from a finite-element body.

:class:`~fuzzymbs.fe.elastic_body.ElasticBody` meets :class:`ReducibleBody`;
:mod:`fuzzymbs.fe.reduction` and :mod:`fuzzymbs.fe.cache` are written against
it, so they need not import the body's module, and the body's convenience
methods (``reduce``, ``natural_frequencies``, ``rigid_body_modes``) can call the
reduction directly: imports point one way, elastic_body -> reduction -> cache.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from skfem import Mesh

__all__ = ["ReducibleBody"]


class ReducibleBody(Protocol):
    """An assembled linear-elastic body, as reduction and the reduction cache see it.

    Attributes
    ----------
    mesh : skfem.Mesh
        The mesh (node ``j`` carries DOFs ``3 j + c``, c = 0, 1, 2 for x, y, z).
    name : str
        Label carried into the reduced body.
    nodes : ndarray, shape (n, 3)
        Node coordinates [m].
    fixed_nodes : ndarray of int
        Sorted clamped nodes (all three DOFs).
    youngs_modulus, poisson_ratio, density : float
        E [Pa], nu [-], rho [kg/m^3].
    """

    mesh: Mesh
    name: str
    nodes: NDArray[np.float64]
    fixed_nodes: NDArray[np.int64]
    youngs_modulus: float
    poisson_ratio: float
    density: float

    @property
    def n_nodes(self) -> int:
        """Number of nodes n."""
        ...

    @property
    def n_dofs(self) -> int:
        """Number of displacement DOFs, 3 n."""
        ...

    @property
    def is_free(self) -> bool:
        """True when no node is clamped (six rigid-body modes)."""
        ...

    @property
    def free_dofs(self) -> NDArray[np.int64]:
        """Sorted unconstrained DOF indices."""
        ...

    @property
    def stiffness(self) -> sp.csr_matrix:
        """Stiffness matrix K (3n x 3n) [N/m], without boundary conditions."""
        ...

    @property
    def mass_matrix(self) -> sp.csr_matrix:
        """Consistent mass matrix M (3n x 3n) [kg], without boundary conditions."""
        ...

    def node_set(self, spec: Any) -> NDArray[np.int64]:
        """Node indices of a boundary name, a coordinate predicate or an index array."""
        ...

    def rigid_body_modes(self) -> NDArray[np.float64]:
        """Mass-orthonormal rigid-body displacement fields (3n x 6)."""
        ...
