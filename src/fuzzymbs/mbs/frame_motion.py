"""Minimal coordinates for a flexible body held to the ground by one joint.

A :class:`~fuzzymbs.mbs.system.System` is built from the general engine's
vocabulary -- a :class:`~fuzzymbs.mbs.spatial.FlexibleBody` and a
:mod:`~fuzzymbs.mbs.spatial` joint between it and the ground -- and solved in
minimal coordinates, as Neweul-M2 solves a kinematic tree: the joint's free
coordinates (none, a slide, or a prescribed turn) and the modes, no multipliers.
This module turns each (body, joint) pair into the frame motion the
minimal-coordinate kernels read:

=============================================  ==========================  ===============
joint to the ground                            frame motion                 coordinates
=============================================  ==========================  ===============
:class:`~fuzzymbs.mbs.spatial.Fixed`           fixed in space               modes
:class:`~fuzzymbs.mbs.spatial.Prismatic`       slides along marker i's z     slide, modes
:class:`~fuzzymbs.mbs.spatial.Revolute` with   turns about marker i's z at  modes
``drive=ConstantRate(rate)`` or                the prescribed speed (Kane's
``SpinUp(speed, duration)``                    ramp exact in the kernels)
=============================================  ==========================  ===============

(:class:`~fuzzymbs.mbs.bodies.FixedBody`, :class:`~fuzzymbs.mbs.bodies.TranslatingBody`
and :class:`~fuzzymbs.mbs.bodies.RotatingBody` are these frame motions; a
``TranslatingBody`` may also slide along two or three axes at once.) The same body
and joint objects run in absolute coordinates through
:class:`fuzzymbs.mbs.spatial.Mechanism`, which the tests use as the second method.
What the minimal form cannot hold is refused by name: a free (undriven) turn, a
joint between two moving bodies, a frame not parallel to the global axes at the
start (the modal data are read in global axes), markers that do not meet.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import FixedBody, RotatingBody, TranslatingBody
from fuzzymbs.mbs.parameters import scalar_default
from fuzzymbs.mbs.planar.profiles import ConstantRate, SpinUp
from fuzzymbs.mbs.profiles import SpinUpProfile

#: How far a joint's markers may miss each other at the start, relative to the body's
#: size (the general engine's start check uses the same scale of round-off).
MEET_TOLERANCE = 1e-9

FrameMotion = FixedBody | TranslatingBody | RotatingBody


def start_point(marker) -> NDArray[np.float64]:
    """A marker's global point at the start (the body's frame parallel to the global axes)."""
    point = np.asarray(marker.position, dtype=float)
    if marker.body is None:
        return point
    if marker.shape is not None:
        point = point + marker.shape @ marker.body.coordinates
    return marker.body.position + point


def _size(body) -> float:
    """A length scale of the body (its node cloud's extent, at least 1 m)."""
    nodes = np.asarray(body.modal.node_positions, dtype=float).reshape(-1, 3)
    extent = float(np.ptp(nodes, axis=0).max()) if nodes.size else 0.0
    return max(1.0, extent, float(np.abs(body.position).max()))


def frame_motion(body, joint) -> FrameMotion:
    """The frame motion of ``body`` held to the ground by ``joint`` (see the module table).

    Parameters
    ----------
    body : fuzzymbs.mbs.spatial.FlexibleBody
        Its orientation must be the identity (the frame parallel to the global axes).
    joint : fuzzymbs.mbs.spatial.Fixed, Prismatic or Revolute
        Between one of the body's markers and a ground marker; a Revolute needs
        ``drive=ConstantRate(rate)`` or ``SpinUp(speed, duration)`` with start 0 (the
        rate or speed may be a :class:`~fuzzymbs.mbs.parameters.Parameter`).

    Returns
    -------
    FixedBody, TranslatingBody or RotatingBody
        Named as the body, with its modal damping.
    """
    kind = type(joint).__name__
    where = f"body {body.name!r} on joint {joint.label()}"
    if np.abs(np.asarray(body.orientation) - np.eye(3)).max() > 1e-12:
        raise InvalidParameterError(
            f"{where}: a System reads modal data in global axes, so the body's orientation "
            "must be the identity at the start (rotate the FE data instead, or build a "
            "spatial.Mechanism)"
        )
    on_body = [m for m in (joint.marker_i, joint.marker_j) if m.body is body]
    on_ground = [m for m in (joint.marker_i, joint.marker_j) if m.body is None]
    if len(on_body) != 1 or len(on_ground) != 1:
        raise InvalidParameterError(
            f"{where}: a System holds each body to the ground; a joint between two moving "
            "bodies needs spatial.Mechanism"
        )
    ground_marker, body_marker = on_ground[0], on_body[0]
    miss = np.linalg.norm(start_point(ground_marker) - start_point(body_marker))
    if miss > MEET_TOLERANCE * _size(body):
        raise InvalidParameterError(
            f"{where}: its markers are {miss:.3g} m apart at the start; place them together"
        )
    z_i = np.asarray(joint.marker_i.axes, dtype=float)[:, 2]
    z_j = np.asarray(joint.marker_j.axes, dtype=float)[:, 2]
    common = dict(origin=body.position, damping_ratio=body.damping_ratio, name=body.name)
    if kind == "Fixed":
        if np.abs(np.asarray(joint.marker_i.axes) - np.asarray(joint.marker_j.axes)).max() > 1e-9:
            raise InvalidParameterError(f"{where}: a Fixed joint's marker axes must line up")
        _at_rest(body, where, allowed=None)
        return FixedBody(body.modal, **common)
    if np.abs(z_i - z_j).max() > 1e-9:
        raise InvalidParameterError(f"{where}: the markers' z axes must line up at the start")
    # marker i's z is the joint's axis; with the ground as marker j the body's turn is
    # the opposite of the drive's (the drive turns x_j about z_i)
    axis = z_i if joint.marker_i is ground_marker else -z_i
    if kind == "Prismatic":
        if joint.drive is not None:
            raise InvalidParameterError(f"{where}: a System does not drive a slide")
        _at_rest(body, where, allowed=axis)
        return TranslatingBody(body.modal, [z_i], **common)
    if kind == "Revolute":
        drive = joint.drive
        if not isinstance(drive, ConstantRate | SpinUp) or drive.start != 0.0:
            raise InvalidParameterError(
                f"{where}: a System turns a body at a prescribed speed, "
                "drive=ConstantRate(rate) or SpinUp(speed, duration) with start 0; a free "
                "turn needs spatial.Mechanism"
            )
        off_axis = np.cross(body.position - start_point(ground_marker), axis)
        if np.linalg.norm(off_axis) > MEET_TOLERANCE * _size(body):
            raise InvalidParameterError(
                f"{where}: the body's frame origin must lie on the joint's axis (the "
                "minimal form turns the frame about its origin)"
            )
        if isinstance(drive, SpinUp):  # from rest, Kane's ramp exact in the kernels
            speed, profile, spin = drive.speed, SpinUpProfile(drive.duration), 0.0 * axis
        else:
            speed, profile = drive.rate, None
            spin = scalar_default(drive.rate) * axis
        _at_rest(body, where, allowed=None, spin=spin)
        # a beam's foreshortening or the FE body's own prestress: the same spin stiffening
        stiffening = getattr(body, "stress_stiffening", None)
        return RotatingBody(
            body.modal, axis, speed, profile=profile, stiffening=stiffening, **common
        )
    raise InvalidParameterError(
        f"{where}: a System holds a body by Fixed, Prismatic or a driven Revolute, not {kind}"
    )


def _at_rest(
    body,
    where: str,
    allowed: NDArray[np.float64] | None,
    spin: NDArray[np.float64] | None = None,
) -> None:
    """The frame's initial velocity must be one the joint allows: a slide along
    ``allowed``; no turn, or the drive's ``spin`` (which the System sets anyway)."""
    velocity = np.asarray(body.velocity, dtype=float)
    if allowed is not None:
        velocity = velocity - (velocity @ allowed) * allowed
    turn = np.asarray(body.angular_velocity, dtype=float)
    if spin is not None and np.abs(turn - spin).max() <= 1e-12 * np.abs(spin).max():
        turn = turn - spin
    if np.abs(velocity).max() > 0 or np.abs(turn).max() > 0:
        raise InvalidParameterError(
            f"{where}: the body's initial frame velocity is one its joint does not allow "
            "(a driven turn starts at the drive's speed)"
        )


def frame_motions(bodies: Mapping[str, object], joints: Sequence[object]) -> dict[str, FrameMotion]:
    """Each general body's frame motion from its one joint to the ground; frame motions
    given directly (``FixedBody`` ...) pass through."""
    held: dict[str, list] = {name: [] for name in bodies}
    for joint in joints:
        ends = [m.body for m in (joint.marker_i, joint.marker_j) if m.body is not None]
        if len(ends) == 2:
            raise InvalidParameterError(
                f"joint {joint.label()} joins bodies {ends[0].name!r} and {ends[1].name!r}: a "
                "System holds each body to the ground; two moving bodies need spatial.Mechanism"
            )
        for end in ends:
            if end.name not in bodies or bodies[end.name] is not end:
                raise InvalidParameterError(
                    f"joint {joint.label()}: its body {end.name!r} was not added to the System"
                )
            held[end.name].append(joint)
    motions: dict[str, FrameMotion] = {}
    for name, body in bodies.items():
        if isinstance(body, FixedBody | TranslatingBody | RotatingBody):
            if held[name]:
                raise InvalidParameterError(
                    f"body {name!r} already has its frame motion; it takes no joint"
                )
            motions[name] = body
            continue
        if len(held[name]) != 1:
            raise InvalidParameterError(
                f"body {name!r} has {len(held[name])} joints; a System holds each flexible "
                "body to the ground by exactly one (Fixed, Prismatic or a driven Revolute)"
            )
        motions[name] = frame_motion(body, held[name][0])
    return motions


def initial_coordinates(body, motion: FrameMotion) -> tuple[NDArray, NDArray]:
    """(coordinates, rates) of a general body in its frame motion's minimal coordinates."""
    if not hasattr(body, "coordinates"):  # a frame motion given directly starts at rest
        return np.zeros(motion.n_dofs), np.zeros(motion.n_dofs)
    slide = []
    slide_rate = []
    if isinstance(motion, TranslatingBody):
        slide = [0.0]
        slide_rate = [float(np.asarray(body.velocity) @ motion.axes[0])]
    return (
        np.concatenate([slide, body.coordinates]),
        np.concatenate([slide_rate, body.rates]),
    )
