"""Mechanisms built on the planar multibody engine (registered for studies).

- ``flexible-pendulum``: an FE beam on a revolute joint under gravity;
- ``spin-up-beam``: Kane, Ryan & Banerjee's beam spun up on a hub;
- ``slider-crank``: a driven rigid crank, a flexible connecting rod, a slider.

The factories are imported when a study builds the model, so that
``fuzzymbs info`` does not load the kernels.
"""

from __future__ import annotations

from fuzzymbs.study.registry import ParameterInfo, register_model

_INTEGRATOR = {
    "integrator": (
        'Runge-Kutta pair: "auto" (default: DOP853 with flexible bodies), "dop853" or "dopri5"'
    ),
}
_ENGINE_TOLERANCES = {
    "rtol": "relative tolerance of the step control (default 1e-6)",
    "atol": "absolute tolerance of the step control (default 1e-8)",
    **_INTEGRATOR,
}

register_model(
    "flexible-pendulum",
    "fuzzymbs.models.mechanisms.pendulum:flexible_pendulum",
    parameters={
        "length": ParameterInfo("m", "beam length L", 1.0),
        "youngs_modulus": ParameterInfo("Pa", "Young's modulus E", 2.1e11),
        "density": ParameterInfo("kg/m^3", "density rho", 7850.0),
        "width": ParameterInfo("m", "section width (in the bending axis)", 0.03),
        "height": ParameterInfo("m", "section height (bending plane)", 0.003),
        "initial_angle": ParameterInfo(
            "rad", "release angle from the vertical", 1.0471975511965976
        ),
    },
    outputs={"angle": "rad", "tip_deflection": "m"},
    description="flexible beam pendulum on a revolute joint under gravity (planar engine)",
    options={
        "duration": "simulated time [s] (default 4)",
        "time_steps": "number of output times (default 401)",
        "modes": "clamped modes of the beam (default 6, at most 8)",
        "elements": "beam elements (default 16)",
        **_ENGINE_TOLERANCES,
    },
)

register_model(
    "spin-up-beam",
    "fuzzymbs.models.mechanisms.spin_up_beam:spin_up_beam",
    parameters={
        "spin_speed": ParameterInfo("rad/s", "final hub speed Omega_s", 4.0),
        "spin_up_time": ParameterInfo("s", "spin-up time T_s", 15.0),
        "length": ParameterInfo("m", "beam length L", 8.0),
        "youngs_modulus": ParameterInfo("Pa", "Young's modulus E", 6.8952e10),
        "density": ParameterInfo("kg/m^3", "density rho", 2766.7),
        "area": ParameterInfo("m^2", "section area A", 7.2968e-5),
        "second_moment": ParameterInfo("m^4", "second moment of area I", 8.2189e-9),
    },
    outputs={"tip_deflection": "m"},
    description="Kane-Ryan-Banerjee spin-up beam with geometric stiffening (planar engine)",
    options={
        "duration": "simulated time [s] (default 20)",
        "time_steps": "number of output times (default 401)",
        "modes": "clamped modes of the beam (default 6)",
        "elements": "beam elements (default 16)",
        **_ENGINE_TOLERANCES,
    },
)

register_model(
    "slider-crank",
    "fuzzymbs.models.mechanisms.slider_crank:slider_crank",
    parameters={
        "crank_speed": ParameterInfo("rad/s", "crank speed after the spin-up", 150.0),
        "spin_up_time": ParameterInfo("s", "time the crank takes from rest to its speed", 0.02),
        "youngs_modulus": ParameterInfo("Pa", "connecting rod's Young's modulus E", 2.0e11),
        "rod_width": ParameterInfo("m", "connecting rod's section width", 0.01),
        "rod_height": ParameterInfo("m", "connecting rod's section height (bending plane)", 0.006),
        "slider_mass": ParameterInfo("kg", "slider mass", 0.1),
    },
    outputs={
        "midpoint_deflection": "m",
        "slider_position": "m",
        "slider_pin_force_x": "N",
        "slider_pin_force_y": "N",
        "crank_torque": "N m",
    },
    description=(
        "slider-crank with a flexible connecting rod, crank spun up to a constant speed "
        "(planar engine)"
    ),
    options={
        "duration": "simulated time [s] (default 0.1)",
        "time_steps": "number of output times (default 501)",
        "modes": "pinned-pinned modes of the rod (default 6: five bending, the first axial)",
        "elements": "rod elements, even (default 12)",
        "rtol": "relative tolerance of the step control (default 1e-5)",
        "atol": "absolute tolerance of the step control (default 1e-7)",
        **_INTEGRATOR,
    },
)
