"""Spatial force elements: springs and dampers between markers, applied loads, penalty
contact with friction, and force laws of the user's own compiled into the kernels."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.assembly import (
    BushingBase,
    ContactBase,
    ForceBase,
    SpringDamperBase,
    UserForceBase,
)
from fuzzymbs.mbs.bodies import unit_vector
from fuzzymbs.mbs.contact import Patch, build_patch, lookup_constants
from fuzzymbs.mbs.forces import resolve_nodes
from fuzzymbs.mbs.planar.forces import user_force
from fuzzymbs.mbs.planar.profiles import Profile, ProfiledLoad
from fuzzymbs.mbs.spatial import elements
from fuzzymbs.mbs.spatial.bodies import Marker

#: A marker's position (3,) and axes (3, 3: columns) at the start.
MarkerStart = tuple[NDArray[np.float64], NDArray[np.float64]]


class _SpatialForce(ForceBase):
    """The spatial engine's force elements: their engine and markers."""

    engine = "spatial"
    marker_type = Marker


@dataclass(frozen=True, eq=False)
class SpringDamper(_SpatialForce, SpringDamperBase):
    """A linear spring and damper along the line between two markers' points.

    Tension = stiffness (l - free_length) + damping l'; ``free_length`` None takes
    the initial distance (fields: :class:`~fuzzymbs.mbs.assembly.SpringDamperBase`).
    """

    kind = elements.SPRING_DAMPER

    def __post_init__(self) -> None:
        for name in ("stiffness", "damping"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InvalidParameterError(
                    f"SpringDamper {name} must be finite and >= 0, got {value!r}"
                )

    def pack(self, start_i: MarkerStart, start_j: MarkerStart) -> list[float]:
        initial_length = float(np.linalg.norm(start_j[0] - start_i[0]))
        if initial_length == 0.0:
            raise InvalidParameterError("SpringDamper between coincident markers has no direction")
        length = initial_length if self.free_length is None else float(self.free_length)
        return [self.stiffness, self.damping, length]


@dataclass(frozen=True, eq=False)
class MarkerLoad(ProfiledLoad, _SpatialForce):
    """A force [N] and a torque [N m] (global frame) on a marker, times a profile of time."""

    marker_i: Marker
    force: Sequence[float] = (0.0, 0.0, 0.0)
    torque: Sequence[float] = (0.0, 0.0, 0.0)
    profile: Profile | None = None
    name: str = ""
    kind = elements.MARKER_LOAD
    marker_j = None

    def __post_init__(self) -> None:
        values = np.asarray([*self.force, *self.torque], dtype=float)
        if values.shape != (6,) or not np.isfinite(values).all():
            raise InvalidParameterError(
                "MarkerLoad force and torque must be three finite numbers each"
            )

    def pack(self, start_i: MarkerStart, start_j: MarkerStart) -> list[float]:
        return [*self.force, *self.torque, *self.profile_values()]


@dataclass(frozen=True, eq=False)
class UserForce(_SpatialForce, UserForceBase):
    """A force law written by the user, compiled into the kernels.

    Parameters
    ----------
    marker_i, marker_j : Marker
        The markers it acts on (j may be None).
    function : cfunc
        Made with :func:`user_force` (the planar engine's decorator: the same
        signature). It receives the element's index, t, both markers' states
        (:data:`fuzzymbs.mbs.spatial.elements.USER_STATE_SIZE` numbers each: position,
        velocity, angular velocity, then the axes x, y, z, all global; zeros for a
        missing marker j) and ``parameters``, and writes the force and the torque on
        marker i (global) into ``out`` (6). Marker j receives their opposites, at its
        own point.
    parameters : sequence of float
        Numbers the law reads, per sample.
    """

    kind = elements.USER_FORCE


@dataclass(frozen=True, eq=False)
class Contact(_SpatialForce, ContactBase):
    """Penalty contact of a point (marker i) with a surface (marker j), with friction.

    The surface is the plane through marker j normal to its z axis (outward: +z), or,
    with ``radius``, the sphere of that radius about marker j. Its points move with
    marker j's body frame (on a flexible body: the frame, not the modes); marker i
    may be any marker, a node of a flexible body too. Normal force
    f_N = stiffness max(0, -g) - damping g' (never pulling; g the gap), friction
    -friction f_N v_t / sqrt(|v_t|^2 + regularization^2) against the slip v_t
    (regularised Coulomb, as in the plane and the brake). For a node set, add one
    Contact per node (:func:`contacts`).

    Parameters: those of :class:`~fuzzymbs.mbs.assembly.ContactBase`; ``radius``
    the sphere's [m] (None: the plane).
    """

    kind = elements.CONTACT


@dataclass(frozen=True, eq=False)
class Bushing(_SpatialForce, BushingBase):
    """A linear bushing: springs and dampers on marker j's position and small relative
    rotation with respect to marker i, in marker i's axes, about their relative place at
    the start.

    With d the offset of marker j from marker i in marker i's axes less its start value,
    and theta the rotation vector of marker j's turn relative to marker i since the start
    (1/2 vee(D - D^T) with D = R R0^T, R = A_i^T A_j: the rotation angle's sine along the
    axis, so the law is linear for small turns), the potential energy is
    1/2 d^T K d + 1/2 theta^T K_angle theta. Marker j receives the force -A_i (K d + C d')
    and the torque -A_i J^T (K_angle theta + C_angle theta') with J = d theta / d phi (the
    energy's own torque, so the element conserves it); marker i the opposite force and the
    torque that keeps the pair's moment. A rubber mount, a bearing's stiffness, a flexible
    coupling; markers that coincide at the start are the usual case. Relative turns beyond
    90 degrees leave the law's range (theta shrinks again).

    Parameters
    ----------
    marker_i, marker_j : Marker
    stiffness : (kx, ky, kz, kx_angle, ky_angle, kz_angle)
        [N/m] and [N m/rad], each >= 0.
    damping : six values, optional
        [N s/m] and [N m s/rad], each >= 0 (default zeros).
    name : str
        The element's name for its outputs.
    """

    kind = elements.BUSHING
    size = 6
    order = "x, y, z, then the angles"

    def pack(self, start_i: MarkerStart, start_j: MarkerStart) -> list[float]:
        (p_i, axes_i), (p_j, axes_j) = start_i, start_j
        return [
            *self.law(),
            *(axes_i.T @ (p_j - p_i)),
            *(axes_i.T @ axes_j).ravel(),
        ]


@dataclass(frozen=True, eq=False)
class SurfaceContact(_SpatialForce, ContactBase):
    """Penalty contact of a point (marker i, usually a node of another body) with a meshed
    surface of a flexible body, which deforms with that body's modes: the brake's
    node-to-surface contact, on bodies in any frame motion.

    The surface is the master body's nodes ``nodes`` (a node-set name or indices),
    arranged as a tensor grid in ``chart`` (:class:`~fuzzymbs.mbs.contact.CartesianChart`
    or :class:`~fuzzymbs.mbs.contact.PolarChart`, in the master body's frame); marker j
    is any marker of the master body (only its body is read). The point is looked up in
    the chart (the chart moves with the frame), the cell's four nodes give the surface
    point by their bilinear weights, deformed, and the cell's undeformed normal turns
    with the frame -- as in :mod:`fuzzymbs.mbs.contact`. Normal force
    f_N = stiffness max(0, -g) - damping g', friction as :class:`Contact`; the
    reaction acts on the surface's material point (the four nodes, weighted). Off the
    patch there is no force. For a node set, add one per node
    (:func:`surface_contacts`). ``normal`` (master frame) says which side of the patch
    the point is on, as for :class:`~fuzzymbs.mbs.contact.PenaltyContact` (default:
    towards the point's start). Not on a stiffened beam (its nodes' foreshortening is not
    carried).
    """

    nodes: object = None
    chart: object = None
    normal: object = None
    kind = elements.SURFACE_CONTACT

    def __post_init__(self) -> None:
        super().__post_init__()
        master = self.marker_j.body
        if master is None or not hasattr(master, "modal"):
            raise InvalidParameterError(
                f"SurfaceContact {self.label()}: the surface needs a flexible body's nodes; "
                "marker j is on "
                + ("the ground" if master is None else f"rigid body {master.name!r}")
            )
        if master.stiffening is not None:
            raise InvalidParameterError(
                f"SurfaceContact {self.label()}: body {master.name!r} is a stiffened beam; "
                "its surface nodes would miss their foreshortening"
            )
        if not hasattr(self.chart, "frame"):
            raise InvalidParameterError(
                f"SurfaceContact {self.label()}: chart must be a CartesianChart or "
                f"PolarChart, got {self.chart!r}"
            )
        if self.radius is not None:
            raise InvalidParameterError(f"SurfaceContact {self.label()} takes no radius")

    def patch(self, start_i: MarkerStart) -> Patch:
        """The surface's grid of the master body's nodes (its normals towards ``normal``
        or the point's start)."""
        body = self.marker_j.body
        modal = body.modal
        nodes = resolve_nodes(modal, self.nodes, f"SurfaceContact {self.label()} nodes")
        kind, frame = self.chart.frame()
        start = body.orientation.T @ (start_i[0] - body.position)  # the point, master frame
        side = None if self.normal is None else unit_vector(self.normal, "SurfaceContact normal")
        return build_patch(
            self.label(), kind, frame, modal.node_positions, nodes, start[None, :], side
        )

    def pack(self, start_i: MarkerStart, start_j: MarkerStart) -> list[float]:
        patch = self.patch(start_i)
        modal = self.marker_j.body.modal
        kind, frame = self.chart.frame()
        nodes = patch.grid.reshape(-1)
        return [
            *self.law()[:4],
            float(kind),
            float(patch.periodic),
            float(patch.u.size),
            float(patch.v.size),
            *frame,
            *lookup_constants(patch),
            *patch.u,
            *patch.v,
            *patch.normals.ravel(),
            *modal.node_positions[nodes].ravel(),
            *modal.mode_shapes[nodes].ravel(),
        ]


def surface_contacts(
    body, nodes, surface: Marker, surface_nodes, chart, **law
) -> list[SurfaceContact]:
    """One :class:`SurfaceContact` per node of ``body``'s node set ``nodes`` against the
    surface ``surface_nodes`` of marker ``surface``'s body; ``law``: the contact's numbers
    (stiffness, damping, friction, regularization, normal)."""
    index = resolve_nodes(body.modal, nodes, f"body {body.name!r} nodes")
    return [
        SurfaceContact(body.node(int(k)), surface, nodes=surface_nodes, chart=chart, **law)
        for k in index
    ]


def contacts(markers: Sequence[Marker], surface: Marker, **law: float) -> list[Contact]:
    """One :class:`Contact` per marker of a node set against one surface."""
    return [Contact(marker, surface, **law) for marker in markers]


__all__ = [
    "Bushing",
    "Contact",
    "MarkerLoad",
    "SpringDamper",
    "SurfaceContact",
    "UserForce",
    "contacts",
    "surface_contacts",
    "user_force",
]

ForceElement = SpringDamper | MarkerLoad | UserForce | Contact | Bushing | SurfaceContact
