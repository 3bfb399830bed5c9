"""Joints between two markers: revolute, prismatic and fixed, each optionally driven.

A joint holds marker ``j`` to marker ``i`` (either may be on the ground).
Its equations (Haug, Computer Aided Kinematics and Dynamics of Mechanical
Systems, ch. 3) and their rows in the kernels
(:func:`fuzzymbs.mbs.planar.kernels.joint_terms`):

- revolute: p_j = p_i (2 equations); with a drive, also
  angle_j - angle_i = f(t);
- prismatic: marker j stays on marker i's x axis and keeps its relative
  angle (2); with a drive, also the slide along the axis = f(t);
- fixed: p_j = p_i and the relative angle kept (3).

A marker's angle includes its node's elastic rotation on a flexible body.
"""

from __future__ import annotations

from dataclasses import dataclass

from fuzzymbs.mbs.assembly import JointBase
from fuzzymbs.mbs.planar import kernels
from fuzzymbs.mbs.planar.bodies import Marker
from fuzzymbs.mbs.planar.profiles import PROFILE_SIZE


@dataclass(frozen=True, eq=False)
class _Joint(JointBase):
    engine = "planar"
    marker_type = Marker
    base_equations = 0

    @property
    def equations(self) -> int:
        return self.base_equations + (self.drive is not None)

    def pack(self, relative_angle: float) -> list[float]:
        """[initial relative angle, drive profile (4)]."""
        drive = self.drive.pack() if self.drive is not None else [0.0] * PROFILE_SIZE
        return [relative_angle, *drive]


@dataclass(frozen=True, eq=False)
class Revolute(_Joint):
    """A pin: the markers' points coincide; a drive prescribes the relative angle [rad]."""

    kind = kernels.REVOLUTE
    base_equations = 2


@dataclass(frozen=True, eq=False)
class Prismatic(_Joint):
    """A slider along marker i's x axis; a drive prescribes the slide [m]."""

    kind = kernels.PRISMATIC
    base_equations = 2


@dataclass(frozen=True, eq=False)
class Fixed(_Joint):
    """A weld: the markers coincide and keep their relative angle."""

    kind = kernels.FIXED
    base_equations = 3
    drivable = False


Joint = Revolute | Prismatic | Fixed
