"""MUBOCO-PR pseudo-rigid contact-based spur-gear pair.

Registers the models ``"gear-pair"``, ``"gear-pair-dynamic"``,
``"gear-ste-features"`` and the finite-element reference ``"gear-pair-fe"``
with the study runner. Their stiffness defaults are the
modal values identified for the default pair (z 20/40, m = 4.5 mm, b = 20 mm,
steel, T1 = 100 N m); the manufacturing tolerances ``center_distance_deviation``
and ``tip_relief`` default to 0; see docs/gears.md.
"""

from __future__ import annotations

import math
from typing import Any

from fuzzymbs.models.gears.geometry import GearPair, SpurGear
from fuzzymbs.models.gears.identification import identify
from fuzzymbs.models.gears.iso6336 import iso_mean_ste, iso_pair_stiffness, iso_tooth_stiffness
from fuzzymbs.models.gears.model import MubocoPR
from fuzzymbs.study.registry import ParameterInfo, register_model

__all__ = [
    "DEFAULT_PAIR_OPTIONS",
    "GearPair",
    "MubocoPR",
    "SpurGear",
    "gear_pair_dynamic_model",
    "gear_pair_model",
    "identify",
    "iso_mean_ste",
    "iso_pair_stiffness",
    "iso_tooth_stiffness",
    "make_pair",
]

#: Gear data of the default (demo) pair.
DEFAULT_PAIR_OPTIONS: dict[str, Any] = {
    "pinion_teeth": 20,
    "wheel_teeth": 40,
    "module": 4.5e-3,
    "face_width": 20e-3,
    "pressure_angle_deg": 20.0,
    "pinion_profile_shift": 0.0,
    "wheel_profile_shift": 0.0,
    "center_distance": None,
    "youngs_modulus": 2.1e11,
    "poisson_ratio": 0.3,
    "density": 7850.0,
}
DEFAULT_TORQUE = 100.0  # N m at the pinion


def make_pair(
    pinion_teeth: int = 20,
    wheel_teeth: int = 40,
    module: float = 4.5e-3,
    face_width: float = 20e-3,
    pressure_angle_deg: float = 20.0,
    pinion_profile_shift: float = 0.0,
    wheel_profile_shift: float = 0.0,
    center_distance: float | None = None,
    youngs_modulus: float = 2.1e11,
    poisson_ratio: float = 0.3,
    density: float = 7850.0,
) -> GearPair:
    """Gear pair from plain option values (SI units, pressure angle in degrees)."""
    common = {
        "module": module,
        "face_width": face_width,
        "pressure_angle": math.radians(pressure_angle_deg),
        "youngs_modulus": youngs_modulus,
        "poisson_ratio": poisson_ratio,
        "density": density,
    }
    return GearPair(
        SpurGear(pinion_teeth, profile_shift=pinion_profile_shift, **common),
        SpurGear(wheel_teeth, profile_shift=wheel_profile_shift, **common),
        center_distance=center_distance,
    )


def _pair_from_options(gear_options: dict[str, Any], valid_extra: list[str]) -> GearPair:
    from fuzzymbs.errors import InvalidParameterError

    unknown = set(gear_options) - set(DEFAULT_PAIR_OPTIONS)
    if unknown:
        raise InvalidParameterError(
            f"unknown gear-pair option(s) {sorted(unknown)}; valid: "
            f"{sorted([*DEFAULT_PAIR_OPTIONS, *valid_extra])}"
        )
    return make_pair(**{**DEFAULT_PAIR_OPTIONS, **gear_options})


#: Model options of the tip relief (sample parameter ``tip_relief``).
RELIEF_OPTIONS = ("pinion_relief_start_diameter", "wheel_relief_start_diameter")


def gear_pair_model(
    torque: float = DEFAULT_TORQUE,
    positions: int = 60,
    contact_exponent: float = 1.0,
    pinion_relief_start_diameter: float | None = None,
    wheel_relief_start_diameter: float | None = None,
    **gear_options: Any,
) -> MubocoPR:
    """Factory of the registered ``"gear-pair"`` model: quasi-static STE."""
    pair = _pair_from_options(
        gear_options, ["torque", "positions", "contact_exponent", *RELIEF_OPTIONS]
    )
    return MubocoPR(
        pair,
        torque=torque,
        positions=positions,
        contact_exponent=contact_exponent,
        pinion_relief_start_diameter=pinion_relief_start_diameter,
        wheel_relief_start_diameter=wheel_relief_start_diameter,
    )


def gear_pair_dynamic_model(
    torque: float = DEFAULT_TORQUE,
    contact_exponent: float = 1.0,
    damping: float = 3000.0,
    dynamic: dict[str, Any] | None = None,
    pinion_relief_start_diameter: float | None = None,
    wheel_relief_start_diameter: float | None = None,
    **gear_options: Any,
) -> MubocoPR:
    """Factory of the registered ``"gear-pair-dynamic"`` model: DTE and its harmonics."""
    pair = _pair_from_options(
        gear_options, ["torque", "contact_exponent", "damping", "dynamic", *RELIEF_OPTIONS]
    )
    return MubocoPR(
        pair,
        torque=torque,
        mode="dynamic",
        contact_exponent=contact_exponent,
        damping=damping,
        dynamic=dynamic,
        pinion_relief_start_diameter=pinion_relief_start_diameter,
        wheel_relief_start_diameter=wheel_relief_start_diameter,
    )


def _register() -> None:
    identified = identify(make_pair(**DEFAULT_PAIR_OPTIONS), DEFAULT_TORQUE)
    parameters = {
        "tooth_stiffness": ParameterInfo(
            "N m/rad",
            "rotational spring k_t of every tooth hinge (both gears)",
            round(identified.tooth_stiffness, 1),
        ),
        "contact_stiffness": ParameterInfo(
            "N/m",
            "penalty stiffness k_con of the flank contact (units N/m^m1)",
            float(f"{identified.contact_stiffness:.6g}"),
        ),
        "pinion_tooth_stiffness": ParameterInfo(
            "N m/rad", "k_t of the pinion teeth only (NaN: use tooth_stiffness)", math.nan
        ),
        "wheel_tooth_stiffness": ParameterInfo(
            "N m/rad", "k_t of the wheel teeth only (NaN: use tooth_stiffness)", math.nan
        ),
        "torque": ParameterInfo(
            "N m", "pinion drive torque T1 (NaN: the model's torque option)", math.nan
        ),
        "center_distance_deviation": ParameterInfo(
            "m",
            "operating minus nominal centre distance a_w - a (changes backlash, operating "
            "pressure angle, contact ratio; a jammed pair fails)",
            0.0,
        ),
        "tip_relief": ParameterInfo(
            "m",
            "linear tip relief C_a of both gears' teeth, from the relief-start diameter "
            "(default: HPSTC) to the tip",
            0.0,
        ),
    }
    gear_options = {
        "pinion_teeth": "z1 (default 20)",
        "wheel_teeth": "z2 (default 40)",
        "module": "module m [m] (default 4.5e-3)",
        "face_width": "face width b [m] (default 20e-3)",
        "pressure_angle_deg": "rack pressure angle [deg] (default 20)",
        "pinion_profile_shift": "x1 (default 0)",
        "wheel_profile_shift": "x2 (default 0)",
        "center_distance": "nominal operating centre distance a [m] (default: zero "
        "backlash; the sample parameter center_distance_deviation adds to it)",
        "youngs_modulus": "E [Pa] (default 2.1e11)",
        "poisson_ratio": "nu (default 0.3)",
        "density": "rho [kg/m^3] (default 7850)",
        "pinion_relief_start_diameter": "diameter where the pinion tip relief starts [m] "
        "(default: highest point of single tooth contact)",
        "wheel_relief_start_diameter": "diameter where the wheel tip relief starts [m] "
        "(default: highest point of single tooth contact)",
    }
    register_model(
        "gear-pair",
        gear_pair_model,
        parameters=parameters,
        outputs={"ste": "m"},
        description=(
            "MUBOCO-PR spur-gear pair (pseudo-rigid hinged teeth, flank contact): "
            "quasi-static transmission error over one mesh period"
        ),
        options={
            "torque": "design pinion torque T1 [N m] (identification, reference; default 100)",
            "positions": "number of mesh positions over one mesh period (default 60)",
            "contact_exponent": "m1 of the penalty law F = k delta^m1 (default 1)",
            **gear_options,
        },
    )
    register_model(
        "gear-ste-features",
        "fuzzymbs.models.gears.features:SteFeatureModel",
        parameters=parameters,
        outputs={
            "ste_mean": "m",
            "ste_peak_to_peak": "m",
            "ste_single": "m",
            "ste_double": "m",
        },
        description=(
            "MUBOCO-PR spur-gear pair, its STE reduced to scalar features: mean, "
            "peak-to-peak, single- and double-contact levels (inverse fuzzy arithmetic)"
        ),
        options={
            "torque": "design pinion torque T1 [N m] (default 100)",
            "positions": "mesh positions over one mesh period (default 120)",
            "contact_exponent": "m1 of the penalty law F = k delta^m1 (default 1)",
            "margin": "distance of the contact zones from the zone changes, of the period "
            "(default 0.08)",
            **gear_options,
        },
    )
    register_model(
        "gear-pair-dynamic",
        gear_pair_dynamic_model,
        parameters=parameters,
        outputs={"dte": "m", "dte_spectrum": "m"},
        description=(
            "MUBOCO-PR spur-gear pair in time: dynamic transmission error and its "
            "amplitudes at the mesh frequency and harmonics"
        ),
        options={
            "torque": "mean pinion torque T1 [N m] (identification; default 100)",
            "contact_exponent": "m1 of the penalty law (default 1)",
            "damping": "contact damping c [N s/m] (viscous while in contact; default 3000)",
            "dynamic": "table: speed_rpm, mesh_periods, output_periods, points_per_mesh, "
            "harmonics, pinion_inertia, wheel_inertia, load_torque, hinge_damping_ratio",
            **gear_options,
        },
    )
    register_model(
        "gear-pair-fe",
        "fuzzymbs.models.gears.fe_model:gear_pair_fe_model",
        parameters={
            "youngs_modulus": ParameterInfo(
                "Pa",
                "Young's modulus E of both gears; compliance scales with 1/E (NaN: the "
                "youngs_modulus option)",
                math.nan,
            ),
            "poisson_ratio": ParameterInfo(
                "-",
                "Poisson's ratio nu of both gears; a new FE table per value, cached (NaN: "
                "the poisson_ratio option)",
                math.nan,
            ),
            "torque": parameters["torque"],
            "center_distance_deviation": parameters["center_distance_deviation"],
            "tip_relief": parameters["tip_relief"],
        },
        outputs={"ste": "m", "load_share": "-"},
        description=(
            "FE reference of the spur-gear pair: loaded tooth contact analysis of both whole "
            "gears (2D quadratic triangles, Hertzian flattening, corner contact)"
        ),
        options={
            "torque": "pinion torque T1 [N m] when a sample carries none (default 100)",
            "positions": "number of mesh positions over one mesh period (default 60)",
            "analysis": "plane-strain (default) or plane-stress",
            "support": "bore boundary condition: clamped (default) or tangential",
            "mesh": "table: fine_size, coarse_size (multiples of the module; default 1/24, "
            "1/3), loaded_teeth (default 5), grid_points (default 24), reference_depth "
            "(default 0.15)",
            "edge_radius": "tip-corner rounding radius in corner contact [m] (default 0.05 m)",
            **gear_options,
        },
    )


_register()
