"""Spatial force elements: springs and dampers between markers, applied loads."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.planar.profiles import PROFILE_SIZE, Profile
from fuzzymbs.mbs.spatial import kernels
from fuzzymbs.mbs.spatial.bodies import Marker


@dataclass(frozen=True, eq=False)
class SpringDamper:
    """A linear spring and damper along the line between two markers' points.

    Tension = stiffness (l - free_length) + damping l'; ``free_length`` None takes
    the initial distance.
    """

    marker_i: Marker
    marker_j: Marker
    stiffness: float
    damping: float = 0.0
    free_length: float | None = None
    kind = kernels.SPRING_DAMPER
    role = "force"
    engine = "spatial"
    profile_code = -1

    def __post_init__(self) -> None:
        for name in ("stiffness", "damping"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InvalidParameterError(
                    f"SpringDamper {name} must be finite and >= 0, got {value!r}"
                )

    def pack(self, initial_length: float) -> list[float]:
        if initial_length == 0.0:
            raise InvalidParameterError("SpringDamper between coincident markers has no direction")
        length = initial_length if self.free_length is None else float(self.free_length)
        return [self.stiffness, self.damping, length]


@dataclass(frozen=True, eq=False)
class MarkerLoad:
    """A force [N] and a torque [N m] (global frame) on a marker, times a profile of time."""

    marker_i: Marker
    force: Sequence[float] = (0.0, 0.0, 0.0)
    torque: Sequence[float] = (0.0, 0.0, 0.0)
    profile: Profile | None = None
    kind = kernels.MARKER_LOAD
    role = "force"
    engine = "spatial"
    marker_j = None

    def __post_init__(self) -> None:
        values = np.asarray([*self.force, *self.torque], dtype=float)
        if values.shape != (6,) or not np.isfinite(values).all():
            raise InvalidParameterError(
                "MarkerLoad force and torque must be three finite numbers each"
            )

    @property
    def profile_code(self) -> int:
        return -1 if self.profile is None else self.profile.code

    def pack(self, initial_length: float) -> list[float]:
        profile = self.profile.pack() if self.profile is not None else [0.0] * PROFILE_SIZE
        return [*self.force, *self.torque, *profile]


ForceElement = SpringDamper | MarkerLoad
