"""The data a multibody simulation needs of one modally reduced elastic body.

Produced by :mod:`fuzzymbs.fe` (modal truncation, Craig-Bampton), consumed by
the floating-frame-of-reference equations in :mod:`fuzzymbs.mbs`. Plain arrays
only, so a body pickles cheaply to a Dask worker.

Kinematics (Schwertassek, Wallrapp & Shabana 1999): the position of kept node k is

    r_k = r_R + A (xbar_k + Psi_k q)

with body-frame reference position ``r_R``, rotation ``A``, undeformed node
position ``xbar_k`` and mass-normalised mode shapes ``Psi_k`` (3 x r).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class ModalBody:
    """A modally reduced elastic body (mass-normalised reduced basis).

    The reduced basis is orthonormalised so that ``Psi^T M Psi = I`` and
    ``Psi^T K Psi = diag(omega^2)``: the elastic equations are diagonal.
    All inertia shape integrals are evaluated with the consistent FE mass
    matrix ``M``; ``E_i`` below applies ``skew(e_i)`` node by node.

    Attributes
    ----------
    name : str
        Label used in messages and outputs.
    mass : float
        Total mass m [kg].
    node_ids : ndarray, shape (k,)
        Indices of the kept nodes in the parent FE mesh.
    node_positions : ndarray, shape (k, 3)
        Undeformed positions xbar of the kept nodes in the body frame [m].
    mode_shapes : ndarray, shape (k, 3, r)
        Psi at the kept nodes (mass-normalised) [m / (kg^0.5 m)].
    frequencies : ndarray, shape (r,)
        Angular eigenfrequencies omega of the reduced basis [rad/s], ascending.
    first_moment : ndarray, shape (3,)
        ``int rho xbar dV`` [kg m].
    inertia_tensor : ndarray, shape (3, 3)
        ``int rho (|xbar|^2 I - xbar xbar^T) dV`` about the body-frame origin [kg m^2].
    translation_coupling : ndarray, shape (3, r)
        ``C_t = int rho Psi dV`` (zero for free-free elastic modes).
    rotation_coupling : ndarray, shape (3, r)
        ``C_r = int rho skew(xbar) Psi dV``.
    gyroscopic : ndarray, shape (3, r, r)
        ``G_i = Psi^T M E_i Psi`` (skew-symmetric in the last two axes).
    centrifugal : ndarray, shape (3, 3, r, r)
        ``C_ij = Psi^T M E_i E_j Psi``.
    centrifugal_load : ndarray, shape (3, 3, r)
        ``c_ij = Psi^T M E_i E_j xbar`` (the centrifugal force on the modes).
    node_sets : dict[str, ndarray]
        Named sets of indices into the kept nodes (e.g. ``"contact"``).
    face_sets : dict[str, ndarray]
        Named surface faces as rows of indices into the kept nodes
        (quadrilateral faces: 4 or 8/9 columns), used to interpolate a master
        surface with its shape functions.
    stress_stiffening : StressStiffening, optional
        The geometric stiffness of a clamped body's prestress under its own inertia
        loads (:mod:`fuzzymbs.fe.stress_stiffening`; ``reduce_body(...,
        stress_stiffening=True)``), None when not computed. Both engines use it.
    """

    name: str
    mass: float
    node_ids: NDArray[np.int64]
    node_positions: NDArray[np.float64]
    mode_shapes: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    first_moment: NDArray[np.float64]
    inertia_tensor: NDArray[np.float64]
    translation_coupling: NDArray[np.float64]
    rotation_coupling: NDArray[np.float64]
    gyroscopic: NDArray[np.float64]
    centrifugal: NDArray[np.float64]
    centrifugal_load: NDArray[np.float64]
    node_sets: dict[str, NDArray[np.int64]] = field(default_factory=dict)
    face_sets: dict[str, NDArray[np.int64]] = field(default_factory=dict)
    stress_stiffening: StressStiffening | None = None

    @property
    def n_modes(self) -> int:
        """Number r of reduced coordinates."""
        return int(self.frequencies.shape[0])

    @property
    def n_nodes(self) -> int:
        """Number k of kept nodes."""
        return int(self.node_positions.shape[0])


@dataclass(frozen=True)
class StressStiffening:
    """The geometric stiffness of a body's prestress under its own inertia loads, on its
    modes (body frame, about the frame origin).

    A body force b per unit mass (gravity less the frame's acceleration) and a spin w
    stress the body; that stress stiffens it by ``sum_i b_i K_i + sum_ij w_i w_j K_ij``.
    The spatial engine carries it energy-consistently: the first moment gains
    ``-1/2 sum_i (q^T K_i q) e_i`` and the inertia ``-(q^T K_ij q)_ij``, so gravity,
    frame acceleration and spin stiffen through the equations of motion themselves.

    Attributes
    ----------
    acceleration : ndarray, shape (3, r, r)
        K_i: that of a unit body force per unit mass along e_i.
    spin : ndarray, shape (3, 3, r, r)
        K_ij (symmetric in i, j): that of the centrifugal unit state w_i w_j,
        ``delta_ij x - (x_i e_j + x_j e_i) / 2`` per unit mass.
    """

    acceleration: NDArray[np.float64]
    spin: NDArray[np.float64]


@dataclass(frozen=True)
class GeometricStiffening:
    """The foreshortening of a slender body (a beam) along its ``axis``, for the geometric
    stiffening of a spatial flexible body.

    A point at x along the axis moves back by u_f = -1/2 q^T G(x) q; integrated with the
    mass, this gives ``axial`` K_a = int rho G(x) (the geometric stiffness of a unit axial
    acceleration field) and ``spin`` K_s = int rho x G(x) (that of a unit spin about a
    perpendicular axis) -- :class:`fuzzymbs.fe.beam.ReducedBeam`'s ``geometric_axial`` and
    ``geometric_spin``.

    Attributes
    ----------
    axis : ndarray, shape (3,)
        Unit vector of the beam's axis in the body frame.
    axial, spin : ndarray, shape (r, r)
        K_a and K_s.
    nodes : ndarray, shape (k, r, r), optional
        G(x_k) at the kept nodes: a node moves back by 1/2 q^T G(x_k) q, so that forces
        at the node stiffen (tension) or soften (compression) the modes.
    """

    axis: NDArray[np.float64]
    axial: NDArray[np.float64]
    spin: NDArray[np.float64]
    nodes: NDArray[np.float64] | None = None

    def stress(self) -> StressStiffening:
        """The same as a :class:`StressStiffening`: a body force along the axis stretches
        the beam (K_i = e_i K_a), a spin across it too (K_ij = (delta_ij - e_i e_j) K_s)."""
        e = np.asarray(self.axis, dtype=float)
        across = np.eye(3) - np.outer(e, e)
        return StressStiffening(
            acceleration=np.einsum("i,xy->ixy", e, self.axial),
            spin=np.einsum("ij,xy->ijxy", across, self.spin),
        )
