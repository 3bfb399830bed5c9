"""What the planar and the spatial engines share in building a mechanism.

Every element says what it is -- ``role``: ``"body"``, ``"joint"`` or ``"force"``
-- and which engine it belongs to (``engine``: ``"planar"`` or ``"spatial"``),
so :class:`Assembly` files it without a list of types: a new kind of joint or
force element is a new class (with its rows in the engine's kernels), not an
edit of the mechanism. :class:`JointBase` holds what every joint between two
markers checks and reports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from numba import types
from numba.core.ccallback import CFunc
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError

#: Largest joint residual the projection onto the joints leaves (both engines) [m, rad].
PROJECTION_TOLERANCE = 1e-10

#: Signature of a user force element, in both engines (``user_force`` compiles to it):
#: (element index, t, marker i's numbers, marker j's numbers, parameters, out) -> None.
USER_FORCE_SIGNATURE = types.void(
    types.int64,
    types.float64,
    types.float64[::1],
    types.float64[::1],
    types.float64[::1],
    types.float64[::1],
)


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
    """What every force element reports: its label (its ``name``, or its kind and markers).

    Subclasses set ``kind`` (the kernels' code), ``engine``, ``marker_type`` and, with a
    profile of time, ``profile_code``.
    """

    role = "force"
    engine = ""
    marker_type = object
    profile_code = -1

    def label(self) -> str:
        name = getattr(self, "name", "")
        if name:
            return name
        markers = [m.name for m in (self.marker_i, self.marker_j) if m is not None]
        return f"{type(self).__name__}({', '.join(markers)})"


def _check_markers(owner: str, marker_type: type, *markers: Any, optional: bool = False) -> None:
    for k, marker in enumerate(markers):
        if marker is None and optional and k > 0:
            continue
        if not isinstance(marker, marker_type):
            raise InvalidParameterError(f"{owner} needs a marker, got {marker!r}")


@dataclass(frozen=True, eq=False)
class PairLawBase(ForceBase):
    """A force law between two markers with a stiffness and a damping: the fields that
    springs and contacts share (their own follow)."""

    marker_i: Any
    marker_j: Any
    stiffness: float
    damping: float = 0.0


@dataclass(frozen=True, eq=False)
class SpringDamperBase(PairLawBase):
    """A linear spring and damper along the line between two markers: its numbers (the
    engine's ``SpringDamper`` checks and packs them).

    Parameters
    ----------
    marker_i, marker_j : Marker
    stiffness : float
        [N/m], >= 0.
    damping : float
        [N s/m], >= 0.
    free_length : float, optional
        [m]; None takes the initial distance.
    name : str
        The element's name for its outputs.
    """

    free_length: float | None = None
    name: str = ""


_COUNTS = {3: "three", 6: "six"}


@dataclass(frozen=True, eq=False)
class BushingBase(ForceBase):
    """A linear bushing between two markers: its springs' and dampers' numbers and their
    checks (the law is the engine's: see its ``Bushing``).

    Subclasses set ``marker_type``, ``size`` (the law's components, translations then
    rotations) and ``order`` (their names in the messages).

    Parameters
    ----------
    marker_i, marker_j : Marker
    stiffness : ``size`` values
        [N/m] and [N m/rad], each >= 0.
    damping : ``size`` values, optional
        [N s/m] and [N m s/rad], each >= 0; None: zeros.
    name : str
        The element's name for its outputs.
    """

    marker_i: Any
    marker_j: Any
    stiffness: Sequence[float]
    damping: Sequence[float] | None = None
    name: str = ""
    size = 0
    order = ""

    def __post_init__(self) -> None:
        _check_markers("Bushing", self.marker_type, self.marker_i, self.marker_j)
        if self.damping is None:
            object.__setattr__(self, "damping", (0.0,) * self.size)
        for what in ("stiffness", "damping"):
            values = np.asarray(getattr(self, what), dtype=float)
            if values.shape != (self.size,) or not (
                np.isfinite(values).all() and (values >= 0).all()
            ):
                raise InvalidParameterError(
                    f"Bushing {what} must be {_COUNTS[self.size]} finite numbers >= 0 "
                    f"({self.order}), got {getattr(self, what)!r}"
                )

    def law(self) -> list[float]:
        """[stiffness..., damping...]."""
        return [*np.asarray(self.stiffness, dtype=float), *np.asarray(self.damping, dtype=float)]


@dataclass(frozen=True, eq=False)
class ContactBase(PairLawBase):
    """Penalty contact of marker i's point with marker j's surface, with regularised
    Coulomb friction: the law's numbers and their checks (the surface's shape is the
    engine's: see its ``Contact``).

    Parameters
    ----------
    marker_i, marker_j : Marker
    stiffness : float
        Penalty stiffness [N/m], > 0.
    damping : float
        Normal damping [N s/m].
    friction : float
        Coulomb coefficient mu [-].
    regularization : float
        Slip speed eps of the regularised friction law [m/s], > 0.
    radius : float, optional
        The surface's radius [m] (a circle in the plane, a sphere in space); None for a
        flat surface.
    name : str
        The element's name for its outputs.
    """

    friction: float = 0.0
    regularization: float = 1e-3
    radius: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        _check_markers("Contact", self.marker_type, self.marker_i, self.marker_j)
        for field_name, low in (
            ("stiffness", "> 0"),
            ("damping", ">= 0"),
            ("friction", ">= 0"),
            ("regularization", "> 0"),
        ):
            value = getattr(self, field_name)
            if not (np.isfinite(value) and (value > 0 if low == "> 0" else value >= 0)):
                raise InvalidParameterError(
                    f"Contact {field_name} must be finite and {low}, got {value!r}"
                )
        if self.radius is not None and not (np.isfinite(self.radius) and self.radius > 0):
            raise InvalidParameterError(
                f"Contact radius must be finite and > 0, got {self.radius!r}"
            )

    def law(self) -> list[float]:
        """[stiffness, damping, friction, regularization, radius (0: flat)]."""
        radius = 0.0 if self.radius is None else float(self.radius)
        return [self.stiffness, self.damping, self.friction, self.regularization, radius]

    def pack(self, start_i: Any, start_j: Any) -> list[float]:
        """The element's numbers: :meth:`law` (the surface moves with marker j)."""
        return self.law()


@dataclass(frozen=True, eq=False)
class UserForceBase(ForceBase):
    """A force law of the user's own, compiled into the kernels: its checks and numbers."""

    marker_i: Any
    marker_j: Any
    function: object
    parameters: Any = ()
    name: str = ""

    def __post_init__(self) -> None:
        _check_markers("UserForce", self.marker_type, self.marker_i, self.marker_j, optional=True)
        if not isinstance(self.function, CFunc) or self.function._sig != USER_FORCE_SIGNATURE:
            raise InvalidParameterError(
                f"UserForce function must be compiled with fuzzymbs.mbs.{self.engine}.user_force, "
                f"got {self.function!r}"
            )
        values = np.asarray(self.parameters, dtype=float).ravel()
        if not np.isfinite(values).all():
            raise InvalidParameterError(
                f"UserForce parameters must be finite, got {self.parameters!r}"
            )

    def values(self) -> list[float]:
        """[count, parameters...]."""
        values = [float(v) for v in np.asarray(self.parameters, dtype=float).ravel()]
        return [float(len(values)), *values]

    def pack(self, start_i: Any, start_j: Any) -> list[float]:
        """The element's numbers: :meth:`values` (the law reads the markers' states)."""
        return self.values()


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

    def reduced_system(self, t: float, state: ArrayLike | None, step: float) -> tuple:
        """(reduced rate, free directions, step): what
        :func:`~fuzzymbs.mbs.planar.linearization.linearize` differentiates; each
        engine's ``Mechanism`` gives its own."""
        raise NotImplementedError(f"{type(self).__name__} cannot be linearised")

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
