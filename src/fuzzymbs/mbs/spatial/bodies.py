"""Spatial bodies and markers.

Every body has one kinematic description: a floating frame (position r and
orientation, a rotation matrix on input and Euler parameters in the state: never
singular) carrying small elastic deformation in r modal coordinates. A
:class:`RigidBody` is the case r = 0 with its frame at its centre of mass; a
:class:`FlexibleBody` takes its frame, modes and inertia shape integrals from a
:class:`~fuzzymbs.mbs.modal_body.ModalBody` (:mod:`fuzzymbs.fe`). A marker is a
point and three axes of a body (or of the ground); on a flexible body its point
may follow a node or the average of a node set (an RBE3-like interface point),
while its axes follow the frame. Joints and forces act between markers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.forces import resolve_nodes
from fuzzymbs.mbs.modal_body import GeometricStiffening, ModalBody, StressStiffening

#: The kernels' stiffening codes (the bodies table's last column): none; a beam whose
#: nodes foreshorten (its markers carry G(x_k)); stress stiffening only (no marker data).
NOT_STIFFENED, FORESHORTENED_NODES, STRESS_ONLY = 0, 1, 2


def _vector(value: ArrayLike, what: str) -> NDArray[np.float64]:
    array = np.asarray(value, dtype=float)
    if array.shape != (3,) or not np.isfinite(array).all():
        raise InvalidParameterError(f"{what} must be three finite numbers, got {value!r}")
    return array


def _rotation(value: ArrayLike | None, what: str) -> NDArray[np.float64]:
    if value is None:
        return np.eye(3)
    matrix = np.asarray(value, dtype=float)
    if matrix.shape != (3, 3) or not np.isfinite(matrix).all():
        raise InvalidParameterError(
            f"{what} must be a finite 3 x 3 rotation matrix, got shape {matrix.shape}"
        )
    if np.abs(matrix.T @ matrix - np.eye(3)).max() > 1e-9 or np.linalg.det(matrix) < 0:
        raise InvalidParameterError(
            f"{what} is not a rotation matrix (orthonormal, determinant +1)"
        )
    return matrix


def frame_with_z(direction: ArrayLike) -> NDArray[np.float64]:
    """A rotation matrix whose third column (z axis) is the unit vector along ``direction``."""
    z = _vector(direction, "direction")
    norm = np.linalg.norm(z)
    if norm == 0:
        raise InvalidParameterError("direction must not be zero")
    z = z / norm
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def euler_parameters(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit quaternion (p0, p1, p2, p3) of a rotation matrix (Shepperd's method)."""
    trace = np.trace(matrix)
    candidates = [trace, matrix[0, 0], matrix[1, 1], matrix[2, 2]]
    k = int(np.argmax(candidates))
    if k == 0:
        p0 = 0.5 * np.sqrt(1.0 + trace)
        p = [
            p0,
            (matrix[2, 1] - matrix[1, 2]) / (4 * p0),
            (matrix[0, 2] - matrix[2, 0]) / (4 * p0),
            (matrix[1, 0] - matrix[0, 1]) / (4 * p0),
        ]
    else:
        i = k - 1
        j, m = (i + 1) % 3, (i + 2) % 3
        pi = 0.5 * np.sqrt(1.0 + 2 * matrix[i, i] - trace)
        p = [0.0, 0.0, 0.0, 0.0]
        p[0] = (matrix[m, j] - matrix[j, m]) / (4 * pi)
        p[1 + i] = pi
        p[1 + j] = (matrix[j, i] + matrix[i, j]) / (4 * pi)
        p[1 + m] = (matrix[m, i] + matrix[i, m]) / (4 * pi)
    p = np.array(p)
    return p / np.linalg.norm(p)


@dataclass(frozen=True, eq=False)
class Marker:
    """A point and axes (columns of ``axes``) in a body's frame, or the ground's.

    ``shape`` (3, r): how the point moves with a flexible body's modal coordinates
    (None: it is fixed in the frame); ``foreshortening`` (r, r): G of the point on a
    stiffened body (it moves back along the axis by 1/2 q^T G q; None: zero).
    """

    body: RigidBody | FlexibleBody | None
    position: NDArray[np.float64]
    axes: NDArray[np.float64]
    shape: NDArray[np.float64] | None = None
    foreshortening: NDArray[np.float64] | None = None

    def pack(self) -> list[float]:
        modes = 0 if self.body is None else self.body.mode_count
        shape = np.zeros((3, modes)) if self.shape is None else self.shape
        packed = [*self.position, *self.axes.ravel(), *shape.ravel()]
        if self.body is not None and self.body.stiffening_code == FORESHORTENED_NODES:
            fore = np.zeros((modes, modes)) if self.foreshortening is None else self.foreshortening
            packed.extend(np.ravel(fore))
        return packed

    @property
    def name(self) -> str:
        owner = "ground" if self.body is None else self.body.name
        return f"{owner} point {tuple(self.position)}"


class Ground:
    """The inertial frame."""

    name = "ground"

    def point(self, position: ArrayLike = (0.0, 0.0, 0.0), axes: ArrayLike | None = None) -> Marker:
        """A fixed marker at ``position`` [m] with ``axes`` (columns; default the global axes)."""
        return Marker(
            None, _vector(position, "ground point"), _rotation(axes, "ground marker axes")
        )


ground = Ground()


@dataclass(eq=False)
class RigidBody:
    """A rigid body, its frame at its centre of mass (a floating frame without modes).

    Parameters
    ----------
    name : str
    mass : float
        m [kg], > 0.
    inertia : (3, 3) or (3,)
        Inertia tensor about the centre of mass in the body frame [kg m^2]
        (symmetric positive definite), or its principal values.
    position : (3,)
        Initial centre of mass [m].
    orientation : (3, 3)
        Initial rotation matrix (body axes as columns).
    velocity : (3,)
        Initial velocity of the centre of mass [m/s].
    angular_velocity : (3,)
        Initial angular velocity in the global frame [rad/s].
    """

    name: str
    mass: float = 1.0
    inertia: ArrayLike = (1.0, 1.0, 1.0)
    position: ArrayLike = (0.0, 0.0, 0.0)
    orientation: ArrayLike | None = None
    velocity: ArrayLike = (0.0, 0.0, 0.0)
    angular_velocity: ArrayLike = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"a body needs a non-empty name, got {self.name!r}")
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise InvalidParameterError(
                f"body {self.name!r} mass must be finite and > 0, got {self.mass!r}"
            )
        inertia = np.asarray(self.inertia, dtype=float)
        if inertia.shape == (3,):
            inertia = np.diag(inertia)
        if (
            inertia.shape != (3, 3)
            or not np.isfinite(inertia).all()
            or np.abs(inertia - inertia.T).max() > 0
        ):
            raise InvalidParameterError(
                f"body {self.name!r} inertia must be a symmetric 3 x 3 tensor or 3 values"
            )
        values = np.linalg.eigvalsh(inertia)
        if values[0] <= 0 or values[0] + values[1] < values[2] * (1 - 1e-12):
            raise InvalidParameterError(
                f"body {self.name!r} inertia is singular or not physical (principal values "
                f"{values}: each "
                "must be > 0 and at most the sum of the other two)"
            )
        self.inertia = inertia
        self.position = _vector(self.position, f"body {self.name!r} position")
        self.orientation = _rotation(self.orientation, f"body {self.name!r} orientation")
        self.velocity = _vector(self.velocity, f"body {self.name!r} velocity")
        self.angular_velocity = _vector(
            self.angular_velocity, f"body {self.name!r} angular_velocity"
        )

    def point(self, position: ArrayLike = (0.0, 0.0, 0.0), axes: ArrayLike | None = None) -> Marker:
        """A marker at ``position`` in the body frame [m] with ``axes`` (columns, body frame)."""
        return Marker(
            self, _vector(position, f"point on {self.name!r}"), _rotation(axes, "marker axes")
        )

    mode_count = 0
    stiffened = False
    stiffening_code = NOT_STIFFENED
    role = "body"
    engine = "spatial"

    def pack(self) -> list[float]:
        """Mass, first moment about the frame origin (zero: the centre of mass), inertia."""
        return [self.mass, 0.0, 0.0, 0.0, *np.asarray(self.inertia).ravel()]

    def initial_state(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(r, p) and (r', w in the body frame)."""
        q = np.concatenate([self.position, euler_parameters(self.orientation)])
        v = np.concatenate([self.velocity, self.orientation.T @ self.angular_velocity])
        return q, v


@dataclass(eq=False)
class FlexibleBody:
    """A modally reduced elastic body in a floating frame of reference.

    The frame is the one the :class:`~fuzzymbs.mbs.modal_body.ModalBody` is
    written in (its node positions, modes and inertia shape integrals); the modes
    are mass-normalised, with modal damping ``2 zeta omega``.

    Parameters
    ----------
    name : str
    modal : ModalBody
        From :mod:`fuzzymbs.fe` (a reduced FE mesh), ``ReducedBeam.modal_body()`` or
        :func:`fuzzymbs.mbs.lumped.lumped_modal_body`.
    position : (3,)
        Initial frame origin [m].
    orientation : (3, 3)
        Initial frame rotation (body axes as columns).
    velocity : (3,)
        Initial velocity of the frame origin [m/s].
    angular_velocity : (3,)
        Initial angular velocity in the global frame [rad/s].
    damping_ratio : float or (r,)
        Modal damping ratios zeta [-], >= 0.
    coordinates, rates : (r,), optional
        Initial modal coordinates and their rates (default zero: undeformed, at rest
        in the frame).
    stiffening : GeometricStiffening, optional
        A slender body's foreshortening (``ReducedBeam.stiffening()``): its first moment
        and inertia carry it, so that spin about a perpendicular axis, gravity and frame
        acceleration along the axis stiffen (or soften) the modes, energy-conserving, as
        in the planar engine; node markers carry their node's foreshortening, so forces
        along the beam at its nodes stiffen it too. A body reduced from FE with
        ``stress_stiffening=True`` needs none: its ``ModalBody.stress_stiffening`` (the
        prestress of unit body forces and spins) enters the same way by itself.
    """

    name: str
    modal: ModalBody
    position: ArrayLike = (0.0, 0.0, 0.0)
    orientation: ArrayLike | None = None
    velocity: ArrayLike = (0.0, 0.0, 0.0)
    angular_velocity: ArrayLike = (0.0, 0.0, 0.0)
    damping_ratio: float | ArrayLike = 0.0
    coordinates: ArrayLike | None = None
    rates: ArrayLike | None = None
    stiffening: GeometricStiffening | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"a body needs a non-empty name, got {self.name!r}")
        if self.stiffening is not None:
            r = self.modal.n_modes if isinstance(self.modal, ModalBody) else -1
            st = self.stiffening
            if (
                not isinstance(st, GeometricStiffening)
                or np.shape(st.axial) != (r, r)
                or np.shape(st.spin) != (r, r)
                or np.shape(st.axis) != (3,)
                or abs(np.linalg.norm(st.axis) - 1.0) > 1e-9
            ):
                raise InvalidParameterError(
                    f"body {self.name!r}: stiffening must be a GeometricStiffening with a unit "
                    f"axis and {r} x {r} matrices (ReducedBeam.stiffening()), got {st!r}"
                )
        if (
            self.stiffening is not None
            and getattr(self.modal, "stress_stiffening", None) is not None
        ):
            raise InvalidParameterError(
                f"body {self.name!r}: its modal body carries its own stress stiffening; a "
                "beam's stiffening on top would count it twice"
            )
        if not isinstance(self.modal, ModalBody):
            raise InvalidParameterError(
                f"body {self.name!r}: modal must be a ModalBody, got {type(self.modal).__name__}"
            )
        if not (np.isfinite(self.modal.mass) and self.modal.mass > 0):
            raise InvalidParameterError(
                f"body {self.name!r} mass must be finite and > 0, got {self.modal.mass!r}"
            )
        r = self.modal.n_modes
        zeta = np.broadcast_to(np.asarray(self.damping_ratio, dtype=float), (r,)).copy()
        if not np.isfinite(zeta).all() or np.any(zeta < 0):
            raise InvalidParameterError(
                f"body {self.name!r}: damping ratios must be finite and >= 0, "
                f"got {self.damping_ratio!r}"
            )
        self.damping_ratio = zeta
        for field_name in ("coordinates", "rates"):
            value = getattr(self, field_name)
            array = np.zeros(r) if value is None else np.asarray(value, dtype=float)
            if array.shape != (r,) or not np.isfinite(array).all():
                raise InvalidParameterError(
                    f"body {self.name!r} {field_name} must be {r} finite numbers, got {value!r}"
                )
            setattr(self, field_name, array)
        self.position = _vector(self.position, f"body {self.name!r} position")
        self.orientation = _rotation(self.orientation, f"body {self.name!r} orientation")
        self.velocity = _vector(self.velocity, f"body {self.name!r} velocity")
        self.angular_velocity = _vector(
            self.angular_velocity, f"body {self.name!r} angular_velocity"
        )

    role = "body"
    engine = "spatial"

    @property
    def mode_count(self) -> int:
        return self.modal.n_modes

    @property
    def mass(self) -> float:
        return float(self.modal.mass)

    def point(self, position: ArrayLike = (0.0, 0.0, 0.0), axes: ArrayLike | None = None) -> Marker:
        """A marker at ``position`` fixed in the frame [m] (it does not deform)."""
        return Marker(
            self, _vector(position, f"point on {self.name!r}"), _rotation(axes, "marker axes")
        )

    def node(self, index: int, axes: ArrayLike | None = None) -> Marker:
        """A marker on kept node ``index``: its point moves with the modes, its axes with
        the frame (exact where the modes do not turn the node, e.g. at a clamped
        interface)."""
        if not (isinstance(index, int | np.integer) and 0 <= index < self.modal.n_nodes):
            raise InvalidParameterError(
                f"body {self.name!r} has nodes 0 to {self.modal.n_nodes - 1}, got {index!r}"
            )
        return Marker(
            self,
            self.modal.node_positions[index].copy(),
            _rotation(axes, "marker axes"),
            self.modal.mode_shapes[index].copy(),
            self._foreshortening([index]),
        )

    def nodes(self, which: str | ArrayLike, axes: ArrayLike | None = None) -> Marker:
        """A marker at the mean of a node set (a name in ``modal.node_sets`` or indices):
        the interface point of an RBE3 element with equal weights; axes as :meth:`node`."""
        index = resolve_nodes(self.modal, which, f"body {self.name!r} nodes")
        return Marker(
            self,
            self.modal.node_positions[index].mean(axis=0),
            _rotation(axes, "marker axes"),
            self.modal.mode_shapes[index].mean(axis=0),
            self._foreshortening(index),
        )

    def _foreshortening(self, index: ArrayLike) -> NDArray[np.float64] | None:
        """The mean G of the nodes ``index`` on a stiffened body (None otherwise)."""
        if self.stiffening is None or self.stiffening.nodes is None:
            return None
        return np.asarray(self.stiffening.nodes)[np.asarray(index, dtype=np.int64)].mean(axis=0)

    def pack(self) -> list[float]:
        """Mass, first moment, inertia about the frame origin, then the shape integrals,
        the modal stiffness omega^2 and damping 2 zeta omega (layout in
        :mod:`fuzzymbs.mbs.spatial.kernels`)."""
        b = self.modal
        omega = np.asarray(b.frequencies, dtype=float)
        # a = integral of rho xbar . Psi: -1/2 the trace of c_ij (E_i E_i = e_i e_i^T - I)
        a = -0.5 * np.einsum("iim->m", b.centrifugal_load)
        return [
            b.mass,
            *b.first_moment,
            *np.asarray(b.inertia_tensor).ravel(),
            *b.translation_coupling.ravel(),
            *b.rotation_coupling.ravel(),
            *b.gyroscopic.ravel(),
            *b.centrifugal.ravel(),
            *b.centrifugal_load.ravel(),
            *a,
            *omega**2,
            *(2.0 * self.damping_ratio * omega),
            *self._stiffening_data(),
        ]

    @property
    def stiffened(self) -> bool:
        return self.stiffening is not None or self.modal.stress_stiffening is not None

    @property
    def stiffening_code(self) -> int:
        """:data:`FORESHORTENED_NODES` for a beam's stiffening (its node markers carry the
        foreshortening), :data:`STRESS_ONLY` for an FE body's, else :data:`NOT_STIFFENED`."""
        if self.stiffening is not None:
            return FORESHORTENED_NODES
        return STRESS_ONLY if self.stiffened else NOT_STIFFENED

    def _stiffening_data(self) -> list[float]:
        """K_i (3 r r), K_ij (9 r r) and a beam's axis (3; zero otherwise), or nothing."""
        stress = self.stress_stiffening
        if stress is None:
            return []
        axis = self.stiffening.axis if self.stiffening is not None else np.zeros(3)
        return [*np.ravel(stress.acceleration), *np.ravel(stress.spin), *axis]

    @property
    def stress_stiffening(self) -> StressStiffening | None:
        """The stiffening the kernels carry: a beam's (``stiffening``), else the modal
        body's own (``ModalBody.stress_stiffening``), else None."""
        if self.stiffening is not None:
            return self.stiffening.stress()
        return self.modal.stress_stiffening

    def initial_state(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(r, p, q) and (r', w in the body frame, q')."""
        q = np.concatenate([self.position, euler_parameters(self.orientation), self.coordinates])
        v = np.concatenate([self.velocity, self.orientation.T @ self.angular_velocity, self.rates])
        return q, v


Body = RigidBody | FlexibleBody
