"""Bodies of a planar mechanism: rigid, or flexible (a reduced beam) in a floating frame.

Every body has the same kinematic description (Shabana, Dynamics of
Multibody Systems, ch. 5): a frame at position r = (x, y) turned by the
angle theta, and for a flexible body modal coordinates q, so a material
point is at r + A(theta) (u_bar + Phi q). A fixed, sliding or spinning body
is this body with a joint (and a drive) to the ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.beam import ReducedBeam


def _pair(value: ArrayLike, what: str) -> NDArray[np.float64]:
    array = np.asarray(value, dtype=float)
    if array.shape != (2,) or not np.isfinite(array).all():
        raise InvalidParameterError(f"{what} must be two finite numbers, got {value!r}")
    return array


def _finite(value: float, what: str) -> float:
    value = float(value)
    if not np.isfinite(value):
        raise InvalidParameterError(f"{what} must be finite, got {value!r}")
    return value


@dataclass(frozen=True, eq=False)
class Marker:
    """A point with an orientation on a body (or on the ground).

    ``body`` is None for the ground. ``position`` and ``angle`` are in the
    body frame [m, rad]; ``node`` is the beam node the marker follows (its
    elastic displacement and rotation), or None for a point fixed in the frame.
    """

    body: RigidBody | FlexibleBody | None
    position: NDArray[np.float64]
    angle: float = 0.0
    node: int | None = None

    def modes(self) -> NDArray[np.float64]:
        """(3, m): x and y displacement and rotation of the marker per unit modal coordinate."""
        body = self.body
        count = body.mode_count if body is not None else 0
        if self.node is None or count == 0:
            return np.zeros((3, count))
        return body.beam.node_modes[self.node]

    def geometric(self) -> NDArray[np.float64]:
        """(m, m) geometric stiffness per unit axial tension at the marker's node."""
        body = self.body
        count = body.mode_count if body is not None else 0
        if self.node is None or count == 0:
            return np.zeros((count, count))
        return body.beam.geometric_node[self.node]

    def pack(self) -> list[float]:
        shapes = self.modes()
        return [
            *self.position,
            self.angle,
            *shapes[0],
            *shapes[1],
            *shapes[2],
            *self.geometric().ravel(),
        ]

    @property
    def name(self) -> str:
        owner = "ground" if self.body is None else self.body.name
        where = f"node {self.node}" if self.node is not None else f"point {tuple(self.position)}"
        return f"{owner} {where}"


class Ground:
    """The inertial frame; its markers are fixed points."""

    name = "ground"

    def point(self, x: float = 0.0, y: float = 0.0, angle: float = 0.0) -> Marker:
        """A fixed point (x, y) [m] with the orientation ``angle`` [rad]."""
        return Marker(None, _pair([x, y], "ground point"), _finite(angle, "ground point angle"))


ground = Ground()


@dataclass(eq=False)
class _Body:
    role = "body"
    engine = "planar"
    name: str
    position: ArrayLike = (0.0, 0.0)
    angle: float = 0.0
    velocity: ArrayLike = (0.0, 0.0)
    angular_velocity: float = 0.0

    def _check_motion(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"a body needs a non-empty name, got {self.name!r}")
        self.position = _pair(self.position, f"body {self.name!r} position")
        self.velocity = _pair(self.velocity, f"body {self.name!r} velocity")
        self.angle = _finite(self.angle, f"body {self.name!r} angle")
        self.angular_velocity = _finite(
            self.angular_velocity, f"body {self.name!r} angular_velocity"
        )

    def point(self, x: float = 0.0, y: float = 0.0, angle: float = 0.0) -> Marker:
        """A marker fixed in the body frame at (x, y) [m], turned by ``angle`` [rad]."""
        return Marker(
            self, _pair([x, y], f"point on {self.name!r}"), _finite(angle, "marker angle")
        )


@dataclass(eq=False)
class RigidBody(_Body):
    """A rigid body; its frame origin is the point ``position`` refers to.

    Parameters
    ----------
    name : str
    mass : float
        m [kg], > 0.
    inertia : float
        Moment of inertia about the centre of mass [kg m^2], > 0.
    center : (2,)
        Centre of mass in the body frame [m].
    position, angle, velocity, angular_velocity
        Initial frame position [m], angle [rad] and their rates.
    """

    mass: float = 1.0
    inertia: float = 1.0
    center: ArrayLike = (0.0, 0.0)
    mode_count = 0
    geometric_stiffening = False

    def __post_init__(self) -> None:
        self._check_motion()
        for what in ("mass", "inertia"):
            value = getattr(self, what)
            if not (np.isfinite(value) and value > 0):
                raise InvalidParameterError(
                    f"body {self.name!r} {what} must be finite and > 0 (a massless body makes the "
                    f"mass matrix singular), got {value!r}"
                )
        self.center = _pair(self.center, f"body {self.name!r} center")

    def pack(self) -> list[float]:
        c = self.center
        return [self.mass, self.mass * c[0], self.mass * c[1], self.inertia + self.mass * c @ c]

    def initial_modes(self) -> NDArray[np.float64]:
        return np.zeros(0)


@dataclass(eq=False)
class FlexibleBody(_Body):
    """A flexible body: a reduced beam in a floating frame at its root.

    Parameters
    ----------
    name : str
    beam : ReducedBeam
        The beam's modes and invariants (:meth:`fuzzymbs.fe.beam.PlanarBeam.reduce`).
    damping_ratio : float
        Modal damping ratio of every mode [-] (0 <= zeta < 1).
    geometric_stiffening : bool
        Add the geometric stiffness of the centrifugal and gravity loads
        (on by default: without it a beam spun above its first bending
        frequency diverges).
    position, angle, velocity, angular_velocity
        Initial frame motion; the beam starts undeformed and at rest in the frame.
    """

    beam: ReducedBeam | None = None
    damping_ratio: float = 0.0
    geometric_stiffening: bool = True

    def __post_init__(self) -> None:
        self._check_motion()
        if not isinstance(self.beam, ReducedBeam):
            raise InvalidParameterError(
                f"body {self.name!r} needs a ReducedBeam, got {self.beam!r}"
            )
        if not (np.isfinite(self.damping_ratio) and 0.0 <= self.damping_ratio < 1.0):
            raise InvalidParameterError(
                f"body {self.name!r} damping_ratio must be in [0, 1), got {self.damping_ratio!r}"
            )

    @property
    def mode_count(self) -> int:
        return self.beam.mode_count

    def node(self, index: int, angle: float = 0.0) -> Marker:
        """The marker that follows beam node ``index`` (negative counts from the tip)."""
        count = self.beam.nodes.size
        if not -count <= index < count:
            raise InvalidParameterError(
                f"body {self.name!r} has nodes 0 to {count - 1}, got {index}"
            )
        index %= count
        return Marker(
            self, np.array([self.beam.nodes[index], 0.0]), _finite(angle, "marker angle"), index
        )

    def tip(self) -> Marker:
        return self.node(-1)

    def pack(self) -> list[float]:
        b = self.beam
        damping = np.diag(2.0 * self.damping_ratio * b.frequencies)
        return [
            b.mass,
            *b.first_moment,
            b.inertia,
            *b.modal_position,
            *b.modal_turned_position,
            *b.modal_first_moment[0],
            *b.modal_first_moment[1],
            *b.modal_mass.ravel(),
            *b.modal_gyroscopic.ravel(),
            *b.stiffness.ravel(),
            *damping.ravel(),
            *b.geometric_spin.ravel(),
            *b.geometric_axial.ravel(),
        ]

    def initial_modes(self) -> NDArray[np.float64]:
        return np.zeros(self.mode_count)


Body = RigidBody | FlexibleBody
