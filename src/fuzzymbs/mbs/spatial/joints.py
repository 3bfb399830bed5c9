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

from fuzzymbs.mbs.assembly import JointBase
from fuzzymbs.mbs.planar.profiles import PROFILE_SIZE
from fuzzymbs.mbs.spatial import kernels
from fuzzymbs.mbs.spatial.bodies import Marker


@dataclass(frozen=True, eq=False)
class _Joint(JointBase):
    engine = "spatial"
    marker_type = Marker
    drivable = False
    equations = 0

    @property
    def rows(self) -> int:
        return self.equations + (self.drive is not None)

    def pack(self) -> list[float]:
        return self.drive.pack() if self.drive is not None else [0.0] * PROFILE_SIZE


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
    drivable = True


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
