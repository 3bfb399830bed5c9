"""Spatial joints between markers, built from Haug's primitive constraints.

Marker i's axes define the joint: the revolute, cylindrical and prismatic
joints turn or slide along marker i's z axis (which marker j's z axis must
match at the start); a universal joint's cross has its arms along the two
markers' z axes (perpendicular). Equations (Haug, Computer Aided Kinematics and
Dynamics of Mechanical Systems, ch. 9):

- spherical: p_i = p_j (3)
- revolute: spherical, z_i perpendicular to x_j and y_j (5); a drive adds the
  turn of x_j about z_i, sin(phi - f(t)) = 0
- universal: spherical, z_i perpendicular to z_j (4)
- cylindrical: p_j on z_i (x_i . d = y_i . d = 0), z_i perpendicular to x_j, y_j (4)
- prismatic: cylindrical, and x_i perpendicular to y_j (5)
- fixed: spherical, z_i perp. x_j, y_j, x_i perp. y_j (6)
"""

from __future__ import annotations

from dataclasses import dataclass

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar.profiles import PROFILE_SIZE, Profile
from fuzzymbs.mbs.spatial import kernels
from fuzzymbs.mbs.spatial.bodies import Marker


@dataclass(frozen=True, eq=False)
class _Joint:
    marker_i: Marker
    marker_j: Marker
    name: str = ""
    drive: Profile | None = None
    kind = -1
    equations = 0

    def __post_init__(self) -> None:
        for what, marker in (("first", self.marker_i), ("second", self.marker_j)):
            if not isinstance(marker, Marker):
                raise InvalidParameterError(
                    f"{type(self).__name__} needs two markers; its {what} is {marker!r}"
                )
        if self.marker_i.body is None and self.marker_j.body is None:
            raise InvalidParameterError(f"{type(self).__name__} joins two ground markers")
        if self.marker_i.body is self.marker_j.body:
            raise InvalidParameterError(
                f"{type(self).__name__} joins body {self.marker_i.body.name!r} to itself"
            )
        if self.drive is not None and self.kind != kernels.REVOLUTE:
            raise InvalidParameterError(f"{type(self).__name__} cannot be driven (a Revolute can)")
        if self.drive is not None and not hasattr(self.drive, "pack"):
            raise InvalidParameterError(f"Revolute drive must be a profile, got {self.drive!r}")

    @property
    def rows(self) -> int:
        return self.equations + (self.drive is not None)

    @property
    def drive_code(self) -> int:
        return -1 if self.drive is None else self.drive.code

    def pack(self) -> list[float]:
        return self.drive.pack() if self.drive is not None else [0.0] * PROFILE_SIZE

    def label(self) -> str:
        return self.name or f"{type(self).__name__}({self.marker_i.name}, {self.marker_j.name})"


@dataclass(frozen=True, eq=False)
class Spherical(_Joint):
    """A ball joint: the markers' points coincide."""

    kind = kernels.SPHERICAL
    equations = 3


@dataclass(frozen=True, eq=False)
class Revolute(_Joint):
    """A hinge about marker i's z axis; ``drive`` prescribes the turn of x_j about it [rad]."""

    kind = kernels.REVOLUTE
    equations = 5


@dataclass(frozen=True, eq=False)
class Universal(_Joint):
    """A Cardan joint whose cross arms are the markers' z axes."""

    kind = kernels.UNIVERSAL
    equations = 4


@dataclass(frozen=True, eq=False)
class Cylindrical(_Joint):
    """Turning about and sliding along marker i's z axis."""

    kind = kernels.CYLINDRICAL
    equations = 4


@dataclass(frozen=True, eq=False)
class Prismatic(_Joint):
    """Sliding along marker i's z axis, without turning."""

    kind = kernels.PRISMATIC
    equations = 5


@dataclass(frozen=True, eq=False)
class Fixed(_Joint):
    """A weld: the markers coincide with aligned axes."""

    kind = kernels.FIXED
    equations = 6


Joint = Spherical | Revolute | Universal | Cylindrical | Prismatic | Fixed
