"""A System in absolute coordinates: the same bodies and joints as a spatial Mechanism.

A :class:`~fuzzymbs.mbs.system.System` built from general bodies
(:class:`~fuzzymbs.mbs.spatial.FlexibleBody` on joints to the ground) runs in
minimal coordinates; :func:`as_mechanism` writes the same model for the
absolute-coordinate engine (:class:`~fuzzymbs.mbs.spatial.Mechanism`, Lagrange
multipliers, an explicit Runge-Kutta pair), element by element:

=====================================  ===========================================
System element                          spatial element
=====================================  ===========================================
``NodalForce`` (per node, inertial)     a ``MarkerLoad`` on each node
``Spring`` (node pairs or to ground)    a ``Bushing`` per pair, its stiffness along
                                        the spring's direction (or all three axes)
``PenaltyContact`` (a pass)             a ``SurfaceContact`` per slave node
=====================================  ===========================================

Parameters take the sample's values (or their defaults), a driven body starts
turning at its drive's speed. That makes the brake run on the general engine --
the second method its tests use -- and is the starting point for a model that
needs what the minimal form cannot hold (a floating caliper, a joint between
two moving bodies).
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.contact import PenaltyContact
from fuzzymbs.mbs.forces import NodalForce, Spring, resolve_nodes
from fuzzymbs.mbs.frame_motion import start_point
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.planar.profiles import ConstantRate, SpinUp
from fuzzymbs.mbs.spatial.bodies import frame_with_z, ground
from fuzzymbs.mbs.spatial.forces import Bushing, MarkerLoad, SurfaceContact
from fuzzymbs.mbs.spatial.system import Mechanism


def _value(scalar, sample: Mapping[str, float]) -> float:
    if isinstance(scalar, Parameter):
        return float(sample.get(scalar.name, scalar.default))
    return float(scalar)


def as_mechanism(system, sample: Mapping[str, float] | None = None) -> Mechanism:
    """The ``system`` as a :class:`~fuzzymbs.mbs.spatial.Mechanism` at one sample.

    Parameters
    ----------
    system : fuzzymbs.mbs.system.System
        Built from ``spatial.FlexibleBody`` objects and joints (frame motions given
        directly, ``FixedBody`` and its kin, are refused: they have no absolute form).
    sample : mapping of str to float, optional
        Values of the bound parameters (missing names take their defaults).

    Returns
    -------
    Mechanism
        New body objects (copies whose driven ones start at the drive's speed), the
        joints on them, and the elements of the module table.
    """
    sample = dict(sample or {})
    known = {p.name for p in _parameters(system) if isinstance(p, Parameter)}
    unknown = sorted(set(sample) - known)
    if unknown:
        raise InvalidParameterError(
            f"as_mechanism: unknown parameter(s) {unknown}; the system binds {sorted(known)}"
        )
    bodies = {}
    for name, body in system.bodies.items():
        if not hasattr(body, "coordinates"):
            raise InvalidParameterError(
                f"as_mechanism: body {name!r} is a {type(body).__name__}, a frame motion without "
                "an absolute form; build it as a spatial.FlexibleBody on a joint"
            )
        bodies[name] = copy.copy(body)
    mechanism = Mechanism().add(*bodies.values())

    def moved(marker):
        body = None if marker.body is None else bodies[marker.body.name]
        return dataclasses.replace(marker, body=body)

    for joint in system.joints:
        drive = joint.drive
        if isinstance(drive, SpinUp):  # starts from rest
            drive = SpinUp(_value(drive.speed, sample), drive.duration, drive.start)
        if isinstance(drive, ConstantRate):
            rate = _value(drive.rate, sample)
            drive = ConstantRate(rate, drive.start)
            turning = joint.marker_j.body or joint.marker_i.body
            axis = np.asarray(joint.marker_i.axes)[:, 2]
            sign = 1.0 if joint.marker_i.body is None else -1.0
            bodies[turning.name].angular_velocity = sign * rate * axis
        mechanism.add(
            dataclasses.replace(
                joint, marker_i=moved(joint.marker_i), marker_j=moved(joint.marker_j), drive=drive
            )
        )
    for element in system.elements:
        mechanism.add(*_elements(element, bodies, sample))
    return mechanism


def _parameters(system):
    for joint in system.joints:
        if isinstance(joint.drive, ConstantRate):
            yield joint.drive.rate
        elif isinstance(joint.drive, SpinUp):
            yield joint.drive.speed
    for e in system.elements:
        if isinstance(e, NodalForce):
            yield e.magnitude
        elif isinstance(e, Spring):
            yield e.stiffness
            yield e.damping
        elif isinstance(e, PenaltyContact):
            yield e.penalty
            yield e.friction


def _elements(element, bodies, sample):
    """The spatial elements of one System element (the module table)."""
    where = f"as_mechanism: element {element.name!r}"
    if isinstance(element, NodalForce):
        if element.profile is not None:
            raise InvalidParameterError(f"{where}: a NodalForce's TimeProfile has no spatial form")
        body = bodies[element.body]
        force = _value(element.magnitude, sample) * element.unit_direction()
        nodes = resolve_nodes(body.modal, element.nodes, where)
        return [MarkerLoad(body.node(int(k)), force=tuple(force)) for k in nodes]
    if isinstance(element, Spring):
        directions = element.directions()
        axes = np.eye(3) if len(directions) == 3 else frame_with_z(directions[0])
        along = (1.0, 1.0, 1.0) if len(directions) == 3 else (0.0, 0.0, 1.0)
        k = _value(element.stiffness, sample)
        c = _value(element.damping, sample)
        body_a = bodies[element.body_a]
        nodes_a = resolve_nodes(body_a.modal, element.nodes_a, where)
        if element.body_b is None:
            ends = [
                (node, ground.point(start_point(node), axes))
                for node in (body_a.node(int(a), axes=axes) for a in nodes_a)
            ]
        else:
            body_b = bodies[element.body_b]
            nodes_b = resolve_nodes(body_b.modal, element.nodes_b, where)
            ends = [
                (body_a.node(int(a), axes=axes), body_b.node(int(b), axes=axes))
                for a, b in zip(nodes_a, nodes_b, strict=True)
            ]
        return [
            Bushing(i, j, [k * s for s in along] + [0.0] * 3, [c * s for s in along] + [0.0] * 3)
            for i, j in ends
        ]
    if isinstance(element, PenaltyContact):
        slave = bodies[element.slave_body]
        master = bodies[element.master_body]
        return [
            SurfaceContact(
                slave.node(int(k)),
                master.point(),
                nodes=element.master_nodes,
                chart=element.chart,
                normal=element.normal,
                stiffness=_value(element.penalty, sample),
                damping=element.normal_damping,
                friction=_value(element.friction, sample),
                regularization=element.regularization_velocity,
                name=f"{element.name}[{k}]",
            )
            for k in resolve_nodes(slave.modal, element.slave_nodes, where)
        ]
    raise InvalidParameterError(f"{where}: no spatial form for {type(element).__name__}")
