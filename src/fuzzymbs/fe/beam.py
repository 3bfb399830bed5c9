"""Planar Euler-Bernoulli beams, reduced to modes for a floating frame.

A straight beam along the body's x axis from x = 0 to x = ``length``, meshed
with two-node elements: linear axial displacement u and cubic (Hermite)
transverse displacement w with the slope phi = w' as the third nodal degree of
freedom. Element matrices (any FE text, e.g. Przemieniecki, Theory of Matrix
Structural Analysis, ch. 5 and 11)::

    axial:   K = EA/h [[1, -1], [-1, 1]]          M = rho A h / 6 [[2, 1], [1, 2]]
    bending: K = EI/h^3 [[12, 6h, -12, 6h], ...]  M = rho A h / 420 [[156, 22h, 54, -13h], ...]

The modes are those of the beam held at ``support``: ``"clamped"`` holds the
root (u, w, phi at x = 0; the frame is the root's tangent frame, as for a
beam clamped to a hub or a pendulum whose frame turns with its root),
``"pinned-pinned"`` holds u and w at the root and w at the tip (the frame is
the chord, as for a connecting rod). The modes are mass-normalised.

Everything the floating-frame equations need is integrated here once, with
the same shape functions and a Gauss rule exact for them (the inertia shape
integrals, Shabana, Dynamics of Multibody Systems, ch. 5), and so is the
geometric stiffness of two unit load states (Schwertassek & Wallrapp,
Dynamik flexibler Mehrkoerpersysteme, ch. 6; Wallrapp's SID): the
centrifugal load of a unit frame angular velocity, N(x) = rho A (L^2 - x^2)/2,
a unit body-frame axial acceleration field, N(x) = rho A (L - x), and a unit
axial force at each node, N(x) = 1 between the root and the node. At run time
the engine scales them by omega^2, by the axial field (gravity less the
frame's acceleration) and by the axial forces of the joints and force
elements at the nodes, so a spinning, hanging or pushed beam stiffens (or
softens) as a geometrically nonlinear beam does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.modal_body import GeometricStiffening, ModalBody

#: Gauss-Legendre rule on [0, 1] with 4 points: exact to degree 7, enough for
#: products of two cubics (mass integrals) and of two quadratic slopes.
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)
_GAUSS_X = 0.5 * (_GAUSS_X + 1.0)
_GAUSS_W = 0.5 * _GAUSS_W

SUPPORTS = ("clamped", "pinned-pinned")


def _hermite(xi: NDArray[np.float64], h: float) -> tuple[NDArray, NDArray]:
    """Cubic Hermite shape functions and their x-derivatives at ``xi`` in [0, 1].

    Order: (w_i, phi_i, w_j, phi_j).
    """
    n = np.stack(
        [
            1 - 3 * xi**2 + 2 * xi**3,
            h * (xi - 2 * xi**2 + xi**3),
            3 * xi**2 - 2 * xi**3,
            h * (-(xi**2) + xi**3),
        ],
        axis=-1,
    )
    dn = (
        np.stack(
            [
                -6 * xi + 6 * xi**2,
                h * (1 - 4 * xi + 3 * xi**2),
                6 * xi - 6 * xi**2,
                h * (-2 * xi + 3 * xi**2),
            ],
            axis=-1,
        )
        / h
    )
    return n, dn


@dataclass(frozen=True)
class ReducedBeam:
    """A planar beam reduced to mass-normalised modes, with its inertia invariants.

    Attributes (body frame, SI units; m = mode count, k = node count)
    ------------------------------------------------------------------
    nodes : (k,) x of the nodes [m].
    node_modes : (k, 3, m) u, w, phi of each mode at each node [m, m, rad per unit q].
    frequencies : (m,) natural angular frequencies of the held beam [rad/s].
    mass : total mass [kg].
    first_moment : (2,) integral of rho A x_bar [kg m].
    inertia : integral of rho A |x_bar|^2 about the frame origin [kg m^2].
    modal_first_moment : (2, m) C1 = integral of rho A Phi [kg^0.5 m^0.5 ... per unit q].
    modal_position : (m,) a = integral of rho A Phi^T x_bar.
    modal_turned_position : (m,) b = integral of rho A Phi^T R x_bar, R the +90 deg rotation.
    modal_mass : (m, m) integral of rho A Phi^T Phi (identity for these modes).
    modal_gyroscopic : (m, m) integral of rho A Phi^T R Phi (skew).
    stiffness : (m, m) modal stiffness diag(omega^2) [1/s^2].
    geometric_spin : (m, m) geometric stiffness per unit omega^2 [-].
    geometric_axial : (m, m) geometric stiffness per unit axial acceleration [1/m].
    geometric_node : (k, m, m) geometric stiffness per unit axial tension between the root
        and each node (a force along the beam applied at that node) [1/kg].
    modal_mass_parts : (2, 2, m, m) integral of rho A phi_i phi_j^T per pair of components
        (i, j in x, y): the parts of ``modal_mass`` a spatial body needs.
    modal_position_parts : (2, 2, m) integral of rho A x_bar_i phi_j per pair of components.
    """

    nodes: NDArray[np.float64]
    node_modes: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    mass: float
    first_moment: NDArray[np.float64]
    inertia: float
    modal_first_moment: NDArray[np.float64]
    modal_position: NDArray[np.float64]
    modal_turned_position: NDArray[np.float64]
    modal_mass: NDArray[np.float64]
    modal_gyroscopic: NDArray[np.float64]
    stiffness: NDArray[np.float64]
    geometric_spin: NDArray[np.float64]
    geometric_axial: NDArray[np.float64]
    geometric_node: NDArray[np.float64]
    modal_mass_parts: NDArray[np.float64]
    modal_position_parts: NDArray[np.float64]

    @property
    def mode_count(self) -> int:
        return self.frequencies.size

    def stiffening(self) -> GeometricStiffening:
        """The beam's foreshortening for a spatial flexible body (axis x): K_a and K_s."""
        return GeometricStiffening(
            axis=np.array([1.0, 0.0, 0.0]),
            axial=self.geometric_axial.copy(),
            spin=self.geometric_spin.copy(),
            nodes=self.geometric_node.copy(),
        )

    def modal_body(self, name: str = "beam") -> ModalBody:
        """The beam as a spatial modal body: along x, bending in the x-y plane.

        Every inertia shape integral of :class:`~fuzzymbs.mbs.modal_body.ModalBody`
        follows from this beam's, with z components zero (Euler-Bernoulli: no rotary
        inertia of the section, so a line body with no inertia about its own axis --
        hold that rotation with a joint). Node sets ``"root"`` and ``"tip"``.
        """
        k, m = self.nodes.size, self.mode_count
        shapes = np.zeros((k, 3, m))
        shapes[:, :2] = self.node_modes[:, :2]
        parts = np.zeros((3, 3, m, m))
        parts[:2, :2] = self.modal_mass_parts
        position_parts = np.zeros((3, 3, m))
        position_parts[:2, :2] = self.modal_position_parts
        eye = np.eye(3)
        # E_i E_j v = e_j v_i - delta_ij v, E_i = skew(e_i): Psi^T M E_i E_j Psi and
        # Psi^T M E_i E_j x_bar from the component integrals
        centrifugal = np.einsum("jimn->ijmn", parts) - eye[:, :, None, None] * self.modal_mass
        centrifugal_load = position_parts - eye[:, :, None] * self.modal_position
        gyroscopic = np.zeros((3, m, m))
        gyroscopic[2] = self.modal_gyroscopic
        rotation_coupling = np.zeros((3, m))
        rotation_coupling[2] = self.modal_turned_position
        s0 = np.array([*self.first_moment, 0.0])
        return ModalBody(
            name=name,
            mass=float(self.mass),
            node_ids=np.arange(k),
            node_positions=np.column_stack([self.nodes, np.zeros(k), np.zeros(k)]),
            mode_shapes=shapes,
            frequencies=self.frequencies.copy(),
            first_moment=s0,
            # a line along x: integral of rho A (|x|^2 I - x x^T) = diag(0, J, J)
            inertia_tensor=np.diag([0.0, self.inertia, self.inertia]),
            translation_coupling=np.vstack([self.modal_first_moment, np.zeros((1, m))]),
            rotation_coupling=rotation_coupling,
            gyroscopic=gyroscopic,
            centrifugal=centrifugal,
            centrifugal_load=centrifugal_load,
            node_sets={"root": np.array([0]), "tip": np.array([k - 1])},
        )


@dataclass(frozen=True)
class PlanarBeam:
    """A uniform straight Euler-Bernoulli beam in the plane.

    Parameters
    ----------
    length : float
        L [m].
    youngs_modulus : float
        E [Pa].
    density : float
        rho [kg/m^3].
    area : float
        Cross-section area A [m^2].
    second_moment : float
        Second moment of area about the bending axis I [m^4].
    elements : int
        Number of elements (the default 16 puts the 6th clamped frequency within
        0.1 % of the converged mesh: docs/embs.md).
    support : {"clamped", "pinned-pinned"}
        How the beam is held for its modes (which frame the modes belong to).
    """

    length: float
    youngs_modulus: float
    density: float
    area: float
    second_moment: float
    elements: int = 16
    support: str = "clamped"

    def __post_init__(self) -> None:
        for name in ("length", "youngs_modulus", "density", "area", "second_moment"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InvalidParameterError(
                    f"PlanarBeam {name} must be finite and > 0, got {value!r}"
                )
        if int(self.elements) != self.elements or self.elements < 1:
            raise InvalidParameterError(
                f"PlanarBeam elements must be an integer >= 1, got {self.elements!r}"
            )
        if self.support not in SUPPORTS:
            raise InvalidParameterError(
                f"PlanarBeam support must be one of {SUPPORTS}, got {self.support!r}"
            )

    @property
    def mass_per_length(self) -> float:
        return self.density * self.area

    def matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Global mass and stiffness matrices, dofs (u, w, phi) per node, unsupported."""
        ne = int(self.elements)
        h = self.length / ne
        ea = self.youngs_modulus * self.area
        ei = self.youngs_modulus * self.second_moment
        mu = self.mass_per_length
        ka = ea / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
        ma = mu * h / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
        kb = (
            ei
            / h**3
            * np.array(
                [
                    [12, 6 * h, -12, 6 * h],
                    [6 * h, 4 * h**2, -6 * h, 2 * h**2],
                    [-12, -6 * h, 12, -6 * h],
                    [6 * h, 2 * h**2, -6 * h, 4 * h**2],
                ]
            )
        )
        mb = (
            mu
            * h
            / 420.0
            * np.array(
                [
                    [156, 22 * h, 54, -13 * h],
                    [22 * h, 4 * h**2, 13 * h, -3 * h**2],
                    [54, 13 * h, 156, -22 * h],
                    [-13 * h, -3 * h**2, -22 * h, 4 * h**2],
                ]
            )
        )
        n = 3 * (ne + 1)
        k = np.zeros((n, n))
        m = np.zeros((n, n))
        first = 3 * np.arange(ne)
        axial = np.stack([first, first + 3], axis=1)  # (element, local dof): global dof
        bend = np.stack([first + 1, first + 2, first + 4, first + 5], axis=1)
        # np.add.at sums shared nodes' entries element by element, in element order
        for dofs, stiffness, mass in ((axial, ka, ma), (bend, kb, mb)):
            rows, columns = dofs[:, :, None], dofs[:, None, :]
            np.add.at(k, (rows, columns), stiffness)
            np.add.at(m, (rows, columns), mass)
        return m, k

    def held_dofs(self) -> list[int]:
        """Degrees of freedom the support holds."""
        if self.support == "clamped":
            return [0, 1, 2]
        return [0, 1, 3 * int(self.elements) + 1]

    def reduce(self, modes: int) -> ReducedBeam:
        """The beam reduced to its ``modes`` lowest modes, with every invariant.

        Parameters
        ----------
        modes : int
            Number of modes kept (>= 0; 0 gives a rigid beam).
        """
        ne = int(self.elements)
        m_full, k_full = self.matrices()
        n = m_full.shape[0]
        held = self.held_dofs()
        free = np.setdiff1d(np.arange(n), held)
        if int(modes) != modes or not 0 <= modes <= free.size:
            raise InvalidParameterError(
                f"modes must be an integer from 0 to {free.size} for this mesh, got {modes!r}"
            )
        modes = int(modes)
        shapes = np.zeros((n, modes))
        omega = np.zeros(modes)
        if modes:
            values, vectors = scipy.linalg.eigh(
                k_full[np.ix_(free, free)],
                m_full[np.ix_(free, free)],
                subset_by_index=[0, modes - 1],
            )
            omega = np.sqrt(np.maximum(values, 0.0))
            shapes[free] = vectors
            # a deterministic sign: each mode's largest nodal displacement is positive
            for j in range(modes):
                big = np.argmax(np.abs(shapes[:, j]))
                if shapes[big, j] < 0:
                    shapes[:, j] *= -1.0
        h = self.length / ne
        mu = self.mass_per_length
        # quadrature of every invariant: all elements' Gauss points at once, axes
        # (element e, Gauss point g, mode m); the flattened point axis is p
        nodal = shapes.reshape(ne + 1, 3, modes)
        hn, hdn = _hermite(_GAUSS_X, h)
        bending = np.stack([nodal[:-1, 1], nodal[:-1, 2], nodal[1:, 1], nodal[1:, 2]], axis=1)
        ux = (1.0 - _GAUSS_X)[None, :, None] * nodal[:-1, None, 0] + _GAUSS_X[
            None, :, None
        ] * nodal[1:, None, 0]
        wy = np.einsum("gk,ekm->egm", hn, bending)
        slope = np.einsum("gk,ekm->egm", hdn, bending)
        weight = _GAUSS_W * h
        kg_node = np.zeros((ne + 1, modes, modes))
        np.cumsum(np.einsum("g,egi,egj->eij", weight, slope, slope), axis=0, out=kg_node[1:])
        x = ((np.arange(ne)[:, None] + _GAUSS_X) * h).ravel()
        w = np.tile(weight, ne)
        wg = w * mu
        points = x.size
        phi = np.stack([ux.reshape(points, modes), wy.reshape(points, modes)], axis=1)
        slope = slope.reshape(points, modes)
        xbar = np.stack([x, np.zeros_like(x)], axis=1)
        mass = wg.sum()
        s0 = wg @ xbar
        j0 = wg @ (x * x)
        c1 = np.einsum("p,pim->im", wg, phi)
        a = np.einsum("p,pim,pi->m", wg, phi, xbar)
        b = np.einsum("p,pm->m", wg * x, phi[:, 1])  # phi . (-xbar_y, xbar_x), xbar_y = 0
        mqq = np.einsum("p,pim,pin->mn", wg, phi, phi)
        gyro = np.einsum("p,pm,pn->mn", wg, phi[:, 1], phi[:, 0]) - np.einsum(
            "p,pm,pn->mn", wg, phi[:, 0], phi[:, 1]
        )
        mass_parts = np.einsum("p,pim,pjn->ijmn", wg, phi, phi)
        position_parts = np.einsum("p,pi,pjm->ijm", wg, xbar, phi)
        spin_force = 0.5 * mu * (self.length**2 - x**2)
        axial_force = mu * (self.length - x)
        kg_spin = np.einsum("p,pm,pn->mn", w * spin_force, slope, slope)
        kg_axial = np.einsum("p,pm,pn->mn", w * axial_force, slope, slope)
        return ReducedBeam(
            nodes=np.arange(ne + 1) * h,
            node_modes=shapes.reshape(ne + 1, 3, modes),
            frequencies=omega,
            mass=mass,
            first_moment=s0,
            inertia=j0,
            modal_first_moment=c1,
            modal_position=a,
            modal_turned_position=b,
            modal_mass=mqq,
            modal_gyroscopic=gyro,
            stiffness=np.diag(omega**2),
            geometric_spin=kg_spin,
            geometric_axial=kg_axial,
            geometric_node=kg_node,
            modal_mass_parts=mass_parts,
            modal_position_parts=position_parts,
        )
