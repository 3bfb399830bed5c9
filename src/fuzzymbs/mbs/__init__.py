"""Multibody engine: modal bodies, force laws, contact, integrators, eigenvalues.

Public API (see docs/embs.md; a System's bodies and joints are
:mod:`fuzzymbs.mbs.spatial`'s ``FlexibleBody`` and ``Fixed``, ``Prismatic``,
``Revolute``)::

    from fuzzymbs.mbs import (System, FixedBody, TranslatingBody, RotatingBody,
                              NodalForce, Spring, PenaltyContact, symmetric_contact,
                              CartesianChart, PolarChart, Parameter, TimeProfile,
                              SpinUpProfile, StressStiffening,
                              NodeDisplacement, Coordinate, simulate, SimulationModel,
                              simulate_reference, steady_state, eigenanalysis,
                              rk4_step_stability, rk4_step_limit)

Names load lazily so that importing the package does not import Numba kernels.
"""

from __future__ import annotations

from fuzzymbs._lazy import lazy_exports

_LAZY: dict[str, str] = {
    "ModalBody": "fuzzymbs.mbs.modal_body",
    "FixedBody": "fuzzymbs.mbs.bodies",
    "TranslatingBody": "fuzzymbs.mbs.bodies",
    "RotatingBody": "fuzzymbs.mbs.bodies",
    "NodalForce": "fuzzymbs.mbs.forces",
    "Spring": "fuzzymbs.mbs.forces",
    "PenaltyContact": "fuzzymbs.mbs.contact",
    "symmetric_contact": "fuzzymbs.mbs.contact",
    "CartesianChart": "fuzzymbs.mbs.contact",
    "PolarChart": "fuzzymbs.mbs.contact",
    "Parameter": "fuzzymbs.mbs.parameters",
    "TimeProfile": "fuzzymbs.mbs.profiles",
    "SpinUpProfile": "fuzzymbs.mbs.profiles",
    "StressStiffening": "fuzzymbs.mbs.modal_body",
    "System": "fuzzymbs.mbs.system",
    "CompiledSystem": "fuzzymbs.mbs.system",
    "NodeDisplacement": "fuzzymbs.mbs.system",
    "Coordinate": "fuzzymbs.mbs.system",
    "simulate": "fuzzymbs.mbs.integrate",
    "simulate_reference": "fuzzymbs.mbs.integrate",
    "SimulationModel": "fuzzymbs.mbs.integrate",
    "SimulationResult": "fuzzymbs.mbs.integrate",
    "steady_state": "fuzzymbs.mbs.linearize",
    "eigenanalysis": "fuzzymbs.mbs.linearize",
    "rk4_step_stability": "fuzzymbs.mbs.step_stability",
    "rk4_step_limit": "fuzzymbs.mbs.step_stability",
    "StepStability": "fuzzymbs.mbs.step_stability",
    "lumped_modal_body": "fuzzymbs.mbs.lumped",
    "rigid_body": "fuzzymbs.mbs.lumped",
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_exports("fuzzymbs.mbs", globals(), _LAZY)
