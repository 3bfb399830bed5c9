"""Force elements between markers: springs and dampers, applied loads, user laws.

Every element acts on marker i, and with the opposite force and torque on
marker j when it has one. Gravity is a property of the mechanism
(:class:`fuzzymbs.mbs.planar.system.Mechanism`), applied to every body with
its modal part.

A user force element is a Numba ``cfunc`` with the signature
:data:`fuzzymbs.mbs.assembly.USER_FORCE_SIGNATURE`, made with
:func:`user_force`: it runs inside the batched kernels, so a tyre, a bearing
or a friction law costs no Python call per step::

    @user_force
    def cubic_spring(element, t, marker_i, marker_j, parameters, out):
        # marker_* = x, y, angle, vx, vy, angular velocity (global frame)
        stretch = marker_j[0] - marker_i[0]
        out[0] = parameters[0] * stretch + parameters[1] * stretch**3  # force on i, N
        out[1] = 0.0
        out[2] = 0.0  # torque on i, N m
"""

from __future__ import annotations

import pickle
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.assembly import (
    USER_FORCE_SIGNATURE,
    BushingBase,
    ContactBase,
    ForceBase,
    SpringDamperBase,
    UserForceBase,
)
from fuzzymbs.mbs.planar import kernels
from fuzzymbs.mbs.planar.bodies import Marker
from fuzzymbs.mbs.planar.profiles import Profile, ProfiledLoad


def user_force(function: Callable) -> object:
    """Compile ``function`` as a user force element (a Numba cfunc).

    Defined in a module file, it is cached like the kernels; defined where
    Numba cannot cache it (an interactive session, ``exec``: no file to cache
    beside, or globals that cannot be pickled), it is compiled without a cache.
    """
    try:
        return nb.cfunc(USER_FORCE_SIGNATURE, cache=True)(function)
    except (RuntimeError, TypeError, pickle.PicklingError):
        return nb.cfunc(USER_FORCE_SIGNATURE)(function)


def _check_marker(owner: str, marker: Marker | None, optional: bool = False) -> None:
    if marker is None and optional:
        return
    if not isinstance(marker, Marker):
        raise InvalidParameterError(f"{owner} needs a marker, got {marker!r}")


def _non_negative(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not (np.isfinite(value) and value >= 0):
            raise InvalidParameterError(f"{owner} {name} must be finite and >= 0, got {value!r}")


class _PlanarForce(ForceBase):
    """The planar engine's force elements: their engine and markers."""

    engine = "planar"
    marker_type = Marker


@dataclass(frozen=True, eq=False)
class SpringDamper(_PlanarForce, SpringDamperBase):
    """A linear spring and damper along the line between two markers.

    Tension = stiffness (l - free_length) + damping l' on marker i towards j.
    ``free_length`` None takes the initial distance (fields:
    :class:`~fuzzymbs.mbs.assembly.SpringDamperBase`).
    """

    kind = kernels.SPRING_DAMPER

    def __post_init__(self) -> None:
        _check_marker("SpringDamper", self.marker_i)
        _check_marker("SpringDamper", self.marker_j)
        _non_negative("SpringDamper", stiffness=self.stiffness, damping=self.damping)
        if self.free_length is not None:
            _non_negative("SpringDamper", free_length=self.free_length)

    def pack(self, start_i: NDArray[np.float64], start_j: NDArray[np.float64]) -> list[float]:
        initial_length = float(np.hypot(*(start_j[:2] - start_i[:2])))
        length = initial_length if self.free_length is None else self.free_length
        if initial_length == 0.0:
            raise InvalidParameterError(
                "SpringDamper between coincident markers has no direction; use a bushing "
                "(two springs) or a RotationalSpringDamper"
            )
        return [self.stiffness, self.damping, length]


@dataclass(frozen=True, eq=False)
class RotationalSpringDamper(_PlanarForce):
    """A torsion spring and damper on the relative angle of two markers.

    Torque on marker i = stiffness (angle_j - angle_i - free_angle) + damping
    (angular velocity_j - angular velocity_i); ``free_angle`` None takes the
    initial relative angle.
    """

    marker_i: Marker
    marker_j: Marker
    stiffness: float
    damping: float = 0.0
    free_angle: float | None = None
    name: str = ""
    kind = kernels.ROTATIONAL_SPRING_DAMPER

    def __post_init__(self) -> None:
        _check_marker("RotationalSpringDamper", self.marker_i)
        _check_marker("RotationalSpringDamper", self.marker_j)
        _non_negative("RotationalSpringDamper", stiffness=self.stiffness, damping=self.damping)

    def pack(self, start_i: NDArray[np.float64], start_j: NDArray[np.float64]) -> list[float]:
        initial_angle = float(start_j[2] - start_i[2])
        angle = initial_angle if self.free_angle is None else float(self.free_angle)
        return [self.stiffness, self.damping, angle]


@dataclass(frozen=True, eq=False)
class MarkerLoad(ProfiledLoad, _PlanarForce):
    """A force (fx, fy) [N] and a torque [N m] on one marker, times a profile of time.

    ``in_marker_frame`` turns the force with the marker (a follower load).
    """

    marker_i: Marker
    force: Sequence[float] = (0.0, 0.0)
    torque: float = 0.0
    profile: Profile | None = None
    in_marker_frame: bool = False
    name: str = ""
    kind = kernels.MARKER_LOAD
    marker_j = None

    def __post_init__(self) -> None:
        _check_marker("MarkerLoad", self.marker_i)
        values = np.asarray([*self.force, self.torque], dtype=float)
        if values.shape != (3,) or not np.isfinite(values).all():
            raise InvalidParameterError(
                f"MarkerLoad force must be two finite numbers and torque one, got {self.force!r}, "
                f"{self.torque!r}"
            )

    def pack(self, start_i: NDArray[np.float64], start_j: NDArray[np.float64]) -> list[float]:
        return [*self.force, self.torque, float(self.in_marker_frame), *self.profile_values()]


@dataclass(frozen=True, eq=False)
class UserForce(_PlanarForce, UserForceBase):
    """A force law written by the user, compiled into the kernels.

    Parameters
    ----------
    marker_i, marker_j : Marker
        The markers it acts on (j may be None).
    function : cfunc
        Made with :func:`user_force`. It receives the element's index, t, both
        markers' states (x, y, angle, vx, vy, angular velocity) and
        ``parameters``, and writes (fx, fy, torque) on marker i into ``out``.
    parameters : sequence of float
        Numbers the law reads (stiffnesses, coefficients), per sample.
    """

    kind = kernels.USER_FORCE


@dataclass(frozen=True, eq=False)
class Contact(_PlanarForce, ContactBase):
    """Penalty contact of a point (marker i) with a surface (marker j), with friction.

    The surface is marker j's x axis, its outward normal marker j's y axis (a
    straight edge, a floor, a guide) or, with ``radius``, the circle of that
    radius about marker j (a roller, a cam, a pin in a slot's end). Its points
    move with marker j's body frame (on a flexible body: the frame, not the
    modes); marker i may be any marker, a beam node too.

    Normal force f_N = stiffness max(0, -g) - damping g' (never pulling; g the
    gap), friction -friction f_N v_t / sqrt(v_t^2 + regularization^2) against
    the slip v_t (regularised Coulomb, as the brake's contact). For a node set,
    add one Contact per node (:func:`contacts`).

    Parameters: those of :class:`~fuzzymbs.mbs.assembly.ContactBase`; ``radius``
    the circle's [m] (None: the straight surface).
    """

    kind = kernels.CONTACT


@dataclass(frozen=True, eq=False)
class Bushing(_PlanarForce, BushingBase):
    """A linear bushing: springs and dampers on marker j's position and angle relative to
    marker i, in marker i's frame, about their relative place at the start.

    With d the offset of marker j from marker i in marker i's axes and phi their relative
    angle (d0, phi0 at the start), marker j receives the force
    -A_i (diag(kx, ky) (d - d0) + diag(cx, cy) d') and the torque
    -(k_angle (phi - phi0) + c_angle phi'); marker i receives the opposite force and the
    torque that keeps the pair's moment (the potential energy is
    1/2 (kx dx^2 + ky dy^2 + k_angle phi^2) about the start). A rubber mount, a bearing's
    stiffness, a flexible coupling; markers that coincide at the start are the usual case.

    Parameters
    ----------
    marker_i, marker_j : Marker
    stiffness : (kx, ky, k_angle)
        [N/m, N/m, N m/rad], each >= 0.
    damping : (cx, cy, c_angle), optional
        [N s/m, N s/m, N m s/rad], each >= 0 (default zeros).
    name : str
        The element's name for its outputs.
    """

    kind = kernels.BUSHING
    size = 3
    order = "x, y, angle"

    def pack(self, start_i: NDArray[np.float64], start_j: NDArray[np.float64]) -> list[float]:
        c, s = np.cos(start_i[2]), np.sin(start_i[2])
        dx, dy = start_j[0] - start_i[0], start_j[1] - start_i[1]
        return [
            *self.law(),
            c * dx + s * dy,
            -s * dx + c * dy,
            float(start_j[2] - start_i[2]),
        ]


def contacts(markers: Sequence[Marker], surface: Marker, **law: float) -> list[Contact]:
    """One :class:`Contact` per marker of a node set against one surface."""
    return [Contact(marker, surface, **law) for marker in markers]


ForceElement = SpringDamper | RotationalSpringDamper | MarkerLoad | UserForce | Contact | Bushing
