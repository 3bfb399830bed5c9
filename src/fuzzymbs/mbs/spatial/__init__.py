"""Spatial (3D) mechanisms: rigid and flexible bodies in floating frames (Euler parameters),
joints, springs, loads.

Public API (see docs/mechanisms.md, "Spatial mechanisms")::

    from fuzzymbs.mbs.spatial import (Mechanism, RigidBody, FlexibleBody, ground, frame_with_z,
                                      Spherical, Revolute, Universal, Cylindrical,
                                      Prismatic, Fixed, SpringDamper, MarkerLoad, UserForce,
                                      user_force, Contact, contacts, SurfaceContact,
                                      surface_contacts, CartesianChart, PolarChart,
                                      Bushing, simulate,
                                      ConstantRate, SpinUp, Harmonic, MechanismModel,
                                      linearize)
"""

from __future__ import annotations

from fuzzymbs._lazy import lazy_exports

_LAZY: dict[str, str] = {
    "Mechanism": "fuzzymbs.mbs.spatial.system",
    "SpatialResult": "fuzzymbs.mbs.spatial.system",
    "simulate": "fuzzymbs.mbs.spatial.system",
    "RigidBody": "fuzzymbs.mbs.spatial.bodies",
    "FlexibleBody": "fuzzymbs.mbs.spatial.bodies",
    "Marker": "fuzzymbs.mbs.spatial.bodies",
    "ground": "fuzzymbs.mbs.spatial.bodies",
    "frame_with_z": "fuzzymbs.mbs.spatial.bodies",
    "Spherical": "fuzzymbs.mbs.spatial.joints",
    "Revolute": "fuzzymbs.mbs.spatial.joints",
    "Universal": "fuzzymbs.mbs.spatial.joints",
    "Cylindrical": "fuzzymbs.mbs.spatial.joints",
    "Prismatic": "fuzzymbs.mbs.spatial.joints",
    "Fixed": "fuzzymbs.mbs.spatial.joints",
    "SpringDamper": "fuzzymbs.mbs.spatial.forces",
    "MarkerLoad": "fuzzymbs.mbs.spatial.forces",
    "UserForce": "fuzzymbs.mbs.spatial.forces",
    "user_force": "fuzzymbs.mbs.spatial.forces",
    "Contact": "fuzzymbs.mbs.spatial.forces",
    "Bushing": "fuzzymbs.mbs.spatial.forces",
    "contacts": "fuzzymbs.mbs.spatial.forces",
    "SurfaceContact": "fuzzymbs.mbs.spatial.forces",
    "surface_contacts": "fuzzymbs.mbs.spatial.forces",
    "CartesianChart": "fuzzymbs.mbs.contact",
    "PolarChart": "fuzzymbs.mbs.contact",
    "MechanismModel": "fuzzymbs.mbs.mechanism_model",
    "linearize": "fuzzymbs.mbs.planar.linearization",
    "ConstantRate": "fuzzymbs.mbs.planar.profiles",
    "SpinUp": "fuzzymbs.mbs.planar.profiles",
    "Harmonic": "fuzzymbs.mbs.planar.profiles",
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_exports("fuzzymbs.mbs.spatial", globals(), _LAZY)
