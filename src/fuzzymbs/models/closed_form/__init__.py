"""Closed-form models (registered for demos and tests).

- ``product``: z = x1 * x2 (exact cuts known, THEORY.md section 1).
- ``damped-oscillator``: free vibration of a damped single-degree-of-freedom
  oscillator, a fuzzy time signal with a numerical reference curve.
"""

from __future__ import annotations

from fuzzymbs.models.closed_form.oscillator import (
    DEFAULT_DAMPING,
    DEFAULT_MASS,
    DEFAULT_STIFFNESS,
    DampedOscillator,
    make_damped_oscillator,
)
from fuzzymbs.models.closed_form.product import ProductModel, make_product
from fuzzymbs.study.registry import ParameterInfo, register_model

__all__ = ["DampedOscillator", "ProductModel", "make_damped_oscillator", "make_product"]

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
