"""Spatial rigid bodies and markers.

A body's frame sits at its centre of mass; its orientation is a rotation
matrix on input and Euler parameters in the state (never singular). A marker
is a point and three axes fixed in a body (or in the ground); joints and forces
act between markers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError


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
    """A point and axes (columns of ``axes``) in a body's frame, or the ground's."""

    body: RigidBody | None
    position: NDArray[np.float64]
    axes: NDArray[np.float64]

    def pack(self) -> list[float]:
        return [*self.position, *self.axes.ravel()]

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
    """A rigid body, its frame at its centre of mass.

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

    def pack(self) -> list[float]:
        return [self.mass, *np.asarray(self.inertia).ravel()]

    def initial_state(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(r, p) and (r', w in the body frame)."""
        q = np.concatenate([self.position, euler_parameters(self.orientation)])
        v = np.concatenate([self.velocity, self.orientation.T @ self.angular_velocity])
        return q, v
