"""Closed-form models (registered for demos and tests).

- ``product``: z = x1 * x2 (exact cuts known, THEORY.md section 1).
- ``damped-oscillator``: free vibration of a damped single-degree-of-freedom
  oscillator, a fuzzy time signal with a numerical reference curve.
- ``bump3``, ``ringing3``, ``valley4``, ``sdof-resonance``, ``2dof-resonance``: the
  non-monotonic test cases (:mod:`~fuzzymbs.models.closed_form.hard_cases`,
  :mod:`~fuzzymbs.models.closed_form.resonance`), which also return their analytic
  gradients when a study asks (:mod:`~fuzzymbs.models.closed_form.differentiable`).
"""

from __future__ import annotations

from fuzzymbs.models.closed_form.differentiable import CASE_MODELS, CaseModel
from fuzzymbs.models.closed_form.oscillator import (
    DEFAULT_DAMPING,
    DEFAULT_MASS,
    DEFAULT_STIFFNESS,
    DampedOscillator,
    make_damped_oscillator,
)
from fuzzymbs.models.closed_form.product import ProductModel, make_product
from fuzzymbs.study.registry import ParameterInfo, register_model

__all__ = [
    "CaseModel",
    "DampedOscillator",
    "ProductModel",
    "make_damped_oscillator",
    "make_product",
]

register_model(
    "product",
    make_product,
    parameters={
        "x1": ParameterInfo("1", "first factor", 2.0),
        "x2": ParameterInfo("1", "second factor", 10.0),
    },
    outputs={"z": "1"},
    description="closed form z = x1 * x2 (exact alpha-cuts known)",
)

register_model(
    "damped-oscillator",
    make_damped_oscillator,
    parameters={
        "mass": ParameterInfo("kg", "oscillating mass m", DEFAULT_MASS),
        "stiffness": ParameterInfo("N/m", "spring stiffness k", DEFAULT_STIFFNESS),
        "damping": ParameterInfo("N s/m", "viscous damping coefficient c", DEFAULT_DAMPING),
    },
    outputs={"displacement": "m", "natural_frequency": "Hz"},
    description="closed-form free vibration x(t) of a damped 1-DOF oscillator",
    options={
        "duration": "simulated time span [s] (default 1.0)",
        "time_steps": "number of output time points (default 401)",
        "initial_displacement": "x(0) [m] (default 0.01)",
    },
)

#: the factory of each differentiable test case, by its registered name
_FACTORIES = {
    "bump3": "bump3_model",
    "ringing3": "ringing3_model",
    "valley4": "valley4_model",
    "sdof-resonance": "sdof_resonance_model",
    "2dof-resonance": "two_dof_resonance_model",
}
for _name, (_, _units, _outputs) in CASE_MODELS.items():
    _triangles = CaseModel(_name).suggested()
    register_model(
        _name,
        f"fuzzymbs.models.closed_form.differentiable:{_FACTORIES[_name]}",
        parameters={
            key: ParameterInfo(
                _units[key], f"test-case parameter (suggested {low:g} to {high:g})", modal
            )
            for key, (low, modal, high) in _triangles.items()
        },
        outputs=_outputs,
        description=f"closed-form test case {_name} with analytic gradients (non-monotonic)",
    )
