"""Elastic multibody disc brake (THEORY section 4, docs/brake.md).

Registers the model ``"brake"`` (time signals of the pads and the caliper)
with the study runner. Building a model meshes and reduces the bodies once
(cached on disk); a model object is small and picklable.
"""

from __future__ import annotations

from typing import Any

from fuzzymbs.models.brake.geometry import BrakeBodies, BrakeDesign, Material, build_bodies
from fuzzymbs.models.brake.model import (
    CONTACT_TREATMENTS,
    DEFAULTS,
    OUTPUTS,
    PARAMETERS,
    DiscBrake,
    brake_system,
)
from fuzzymbs.models.brake.stability import (
    BrakeStability,
    StabilityResult,
    growth_rate,
    stability_analysis,
)
from fuzzymbs.study.registry import register_model
from fuzzymbs.tolerance import ATOL_PER_RTOL, DEFAULT_TOLERANCE

__all__ = [
    "CONTACT_TREATMENTS",
    "DEFAULTS",
    "BrakeBodies",
    "BrakeDesign",
    "BrakeStability",
    "DiscBrake",
    "Material",
    "StabilityResult",
    "brake_model",
    "brake_stability_model",
    "brake_system",
    "build_bodies",
    "growth_rate",
    "stability_analysis",
]

OPTIONS = {
    "t_end": "end time [s] (default 0.01)",
    "dt": "RK4's step with integrator = 'rk4', ROS34PW2's first step [s] (default 1e-6)",
    "record_interval": "output interval [s] (default 5e-6)",
    "contact": "'two-pass' (default) or 'single-pass'",
    "regularization_velocity": "eps of the regularised friction law [m/s] (default 1e-3)",
    "modal_damping_ratio": "damping ratio of every elastic mode [-] (default 0)",
    "velocities": "also output v_lpad, v_upad, v_cali [m/s] (default false)",
    "displacement_bound": "|y| above this [m] flags a sample failed (default 1e-3)",
    "chunk_size": "samples per compiled call (default 64)",
    "kernel": 'lanes: "auto" = "lanes" (4 samples per SIMD vector, default) or "samples"'
    " (a block per sample)",
    "integrator": '"ros34pw2" (default: error control at rtol; dt: first step), "rodas4" '
    '(order 4, error control at rtol, a fresh Jacobian every step) or "rk4" '
    "(the paper's fixed step dt, not converged at 1 us)",
    "rtol": f"ROS34PW2 relative tolerance (default {DEFAULT_TOLERANCE.rtol:g})",
    "atol": f"ROS34PW2 absolute tolerance [m, m/s] (default {ATOL_PER_RTOL:g} rtol)",
    "design": "table of BrakeDesign fields (sizes, mode counts, max_frequency)",
}


STABILITY_OPTIONS = {
    "contact": OPTIONS["contact"],
    "regularization_velocity": OPTIONS["regularization_velocity"],
    "modal_damping_ratio": OPTIONS["modal_damping_ratio"],
    "n_modes": "number of least stable eigenvalue pairs reported (default 6)",
    "pad_participation": "pad-translation share that makes a mode a pad mode (default 0.1)",
    "design": OPTIONS["design"],
}


def _design(design: dict[str, Any] | None) -> BrakeDesign:
    from fuzzymbs.errors import InvalidParameterError

    fields = set(BrakeDesign.__dataclass_fields__)
    bad = set(design or {}) - fields
    if bad:
        raise InvalidParameterError(
            f"unknown brake design field(s) {sorted(bad)}; valid: {sorted(fields)}"
        )
    values = dict(design or {})
    for name in ("disc_material", "pad_material", "caliper_material"):
        if isinstance(values.get(name), dict):
            values[name] = Material(**values[name])
    return BrakeDesign(**values)


def _check_options(options: dict[str, Any], valid: dict[str, str], model: str) -> None:
    from fuzzymbs.errors import InvalidParameterError

    unknown = set(options) - set(valid)
    if unknown:
        raise InvalidParameterError(
            f"unknown {model} option(s) {sorted(unknown)}; valid: {sorted(valid)}"
        )


def brake_model(design: dict[str, Any] | None = None, **options: Any) -> DiscBrake:
    """Factory of the registered ``"brake"`` model (study-file options)."""
    _check_options(options, OPTIONS, "brake")
    return DiscBrake(_design(design), **options)


def brake_stability_model(design: dict[str, Any] | None = None, **options: Any) -> BrakeStability:
    """Factory of the registered ``"brake-stability"`` model (study-file options)."""
    _check_options(options, STABILITY_OPTIONS, "brake-stability")
    return BrakeStability(_design(design), **options)


register_model(
    "brake",
    brake_model,
    parameters=PARAMETERS,
    outputs=OUTPUTS,
    description="elastic disc brake (disc, 2 pads, caliper; FE + modal reduction), "
    "pad and caliper displacements over time",
    options=OPTIONS,
)

register_model(
    "brake-stability",
    brake_stability_model,
    parameters=PARAMETERS,
    outputs={
        "max_real_part": "1/s",
        "least_stable_frequency": "Hz",
        "unstable_modes": "-",
        "pad_max_real_part": "1/s",
        "pad_mode_frequency": "Hz",
        "rk4_max_step": "s",
        "real_parts": "1/s",
        "frequencies": "Hz",
    },
    description="complex eigenvalues of the brake linearised about steady sliding: "
    "real parts and frequencies of the least stable modes",
    options=STABILITY_OPTIONS,
)
