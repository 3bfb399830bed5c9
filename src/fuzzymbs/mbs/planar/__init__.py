"""Planar multibody systems: rigid and flexible bodies in floating frames, joints, forces.

Public API (see docs/mechanisms.md)::

    from fuzzymbs.mbs.planar import (Mechanism, RigidBody, FlexibleBody, ground,
                                     Revolute, Prismatic, Fixed,
                                     SpringDamper, RotationalSpringDamper, MarkerLoad,
                                     UserForce, user_force, Contact, contacts, Bushing,
                                     ConstantRate, SpinUp, Harmonic,
                                     simulate, PlanarResult, linearize, MechanismModel)
"""

from __future__ import annotations

from fuzzymbs._lazy import lazy_exports

_LAZY: dict[str, str] = {
    "Mechanism": "fuzzymbs.mbs.planar.system",
    "pack_batch": "fuzzymbs.mbs.planar.system",
    "RigidBody": "fuzzymbs.mbs.planar.bodies",
    "FlexibleBody": "fuzzymbs.mbs.planar.bodies",
    "Marker": "fuzzymbs.mbs.planar.bodies",
    "ground": "fuzzymbs.mbs.planar.bodies",
    "Revolute": "fuzzymbs.mbs.planar.joints",
    "Prismatic": "fuzzymbs.mbs.planar.joints",
    "Fixed": "fuzzymbs.mbs.planar.joints",
    "SpringDamper": "fuzzymbs.mbs.planar.forces",
    "RotationalSpringDamper": "fuzzymbs.mbs.planar.forces",
    "MarkerLoad": "fuzzymbs.mbs.planar.forces",
    "UserForce": "fuzzymbs.mbs.planar.forces",
    "user_force": "fuzzymbs.mbs.planar.forces",
    "Contact": "fuzzymbs.mbs.planar.forces",
    "Bushing": "fuzzymbs.mbs.planar.forces",
    "contacts": "fuzzymbs.mbs.planar.forces",
    "ConstantRate": "fuzzymbs.mbs.planar.profiles",
    "SpinUp": "fuzzymbs.mbs.planar.profiles",
    "Harmonic": "fuzzymbs.mbs.planar.profiles",
    "simulate": "fuzzymbs.mbs.planar.simulation",
    "PlanarResult": "fuzzymbs.mbs.planar.simulation",
    "linearize": "fuzzymbs.mbs.planar.linearization",
    "MechanismModel": "fuzzymbs.mbs.mechanism_model",
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_exports("fuzzymbs.mbs.planar", globals(), _LAZY)
