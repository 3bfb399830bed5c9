"""What the planar and the spatial engines share in building a mechanism.

Every element says what it is -- ``role``: ``"body"``, ``"joint"`` or ``"force"``
-- and which engine it belongs to (``engine``: ``"planar"`` or ``"spatial"``),
so :class:`Assembly` files it without a list of types: a new kind of joint or
force element is a new class (with its rows in the engine's kernels), not an
edit of the mechanism. :class:`JointBase` holds what every joint between two
markers checks and reports.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError


@dataclass(frozen=True, eq=False)
class JointBase:
    """A joint holding marker ``j`` to marker ``i`` (either may be on the ground).

    Subclasses set ``kind`` (the kernels' code), ``engine``, ``marker_type`` and
    whether they can be ``drivable`` (a drive is a profile prescribing the joint's
    coordinate).
    """

    marker_i: Any
    marker_j: Any
    drive: Any = None
    name: str = ""
    kind = -1
    role = "joint"
    engine = ""
    marker_type = object
    drivable = True

    def __post_init__(self) -> None:
        kind = type(self).__name__
        for what, marker in (("first", self.marker_i), ("second", self.marker_j)):
            if not isinstance(marker, self.marker_type):
                raise InvalidParameterError(f"{kind} needs two markers; its {what} is {marker!r}")
        if self.marker_i.body is None and self.marker_j.body is None:
            raise InvalidParameterError(
                f"{kind} joins two ground markers ({self.marker_i.name}, {self.marker_j.name})"
            )
        if self.marker_i.body is self.marker_j.body:
            raise InvalidParameterError(f"{kind} joins body {self.marker_i.body.name!r} to itself")
        if self.drive is not None:
            if not self.drivable:
                raise InvalidParameterError(f"{kind} cannot be driven")
            if not hasattr(self.drive, "pack"):
                raise InvalidParameterError(f"{kind} drive must be a profile, got {self.drive!r}")

    @property
    def drive_code(self) -> int:
        """The drive profile's kernel code, -1 without a drive."""
        return -1 if self.drive is None else self.drive.code

    def label(self) -> str:
        """The joint's name, or its kind and markers."""
        return self.name or f"{type(self).__name__}({self.marker_i.name}, {self.marker_j.name})"


class ForceBase:
    """What every force element reports: its label (its ``name``, or its kind and markers)."""

    role = "force"

    def label(self) -> str:
        name = getattr(self, "name", "")
        if name:
            return name
        markers = [m.name for m in (self.marker_i, self.marker_j) if m is not None]
        return f"{type(self).__name__}({', '.join(markers)})"


class Assembly:
    """Bodies, joints, force elements and named markers of one engine, with gravity.

    Subclasses set ``engine``, ``dimension`` (2 or 3: gravity's components) and
    ``marker_type``.
    """

    engine = ""
    dimension = 0
    marker_type: type = object

    def __init__(self, gravity: ArrayLike) -> None:
        g = np.asarray(gravity, dtype=float)
        if g.shape != (self.dimension,) or not np.isfinite(g).all():
            raise InvalidParameterError(
                f"gravity must be {self.dimension} finite numbers [m/s^2], got {gravity!r}"
            )
        self.gravity: NDArray[np.float64] = g
        self.bodies: list[Any] = []
        self.joints: list[Any] = []
        self.forces: list[Any] = []
        self.named_markers: dict[str, Any] = {}

    def add(self, *elements: Any) -> Self:
        """Add bodies, joints and force elements (in any order); returns self."""
        lists = {"body": self.bodies, "joint": self.joints, "force": self.forces}
        for element in elements:
            role = getattr(element, "role", None)
            if role not in lists or getattr(element, "engine", None) != self.engine:
                raise InvalidParameterError(
                    f"a {self.engine} Mechanism holds {self.engine} bodies, joints and force "
                    f"elements, got {element!r}"
                )
            if role == "body" and any(b.name == element.name for b in self.bodies):
                raise InvalidParameterError(f"two bodies are named {element.name!r}")
            lists[role].append(element)
        return self

    def mark(self, name: str, marker: Any) -> Any:
        """Name a marker whose motion a result reports; returns the marker."""
        if not isinstance(marker, self.marker_type):
            raise InvalidParameterError(f"mark needs a Marker, got {marker!r}")
        if name in self.named_markers:
            raise InvalidParameterError(f"two markers are named {name!r}")
        self.named_markers[name] = marker
        return marker

    def body(self, name: str) -> Any:
        """The body named ``name``."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise InvalidParameterError(
            f"no body named {name!r}; bodies: {[b.name for b in self.bodies]}"
        )

    def joint(self, name: str) -> Any:
        """The joint labelled ``name`` (its name, or its kind and markers)."""
        for j in self.joints:
            if j.label() == name:
                return j
        raise InvalidParameterError(
            f"no joint named {name!r}; joints: {[j.label() for j in self.joints]}"
        )

    def force(self, name: str) -> Any:
        """The force element labelled ``name`` (its name, or its kind and markers)."""
        for f in self.forces:
            if f.label() == name:
                return f
        raise InvalidParameterError(
            f"no force element named {name!r}; force elements: {[f.label() for f in self.forces]}"
        )

    def markers(self) -> list[Any]:
        """Every marker a joint or force uses, then the named ones: the kernels' order."""
        found: list[Any] = []
        pairs = [(e.marker_i, e.marker_j) for e in [*self.joints, *self.forces]]
        for pair in [*pairs, tuple(self.named_markers.values())]:
            for marker in pair:
                if marker is not None and not any(marker is m for m in found):
                    found.append(marker)
        return found
