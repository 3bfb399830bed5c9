"""The spin-up beam of Kane, Ryan & Banerjee (J. Guidance Control Dyn. 10 (1987) 139).

A uniform beam clamped to a hub (radius 0) whose angle is prescribed: the
speed rises smoothly from 0 to ``spin_speed`` in ``spin_up_time``, then stays
constant. Output: the tip's deflection across the hub frame's x axis, in
the plane of rotation [m] (negative: the tip lags). Geometric stiffening is
on: without it the beam diverges above its first bending frequency
(2.91 rad/s). Checked against a geometrically nonlinear co-rotational beam
in tests/models/test_mechanisms.py.
"""

from __future__ import annotations

import numpy as np

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.mechanism_model import ENGINE_TOLERANCE, MechanismModel
from fuzzymbs.mbs.planar import FlexibleBody, Mechanism, Revolute, SpinUp, ground
from fuzzymbs.models.mechanisms.outputs import deflection_in_frame

#: Kane, Ryan & Banerjee's data (SI) at the speed 4 rad/s of their figures.
PARAMETERS = {
    "spin_speed": 4.0,
    "spin_up_time": 15.0,
    "length": 8.0,
    "youngs_modulus": 6.8952e10,
    "density": 2766.7,
    "area": 7.2968e-5,
    "second_moment": 8.2189e-9,
}
#: Clamped modes kept (docs/mechanisms.md has the convergence measurement).
MODES = 6
ELEMENTS = 16


def build(p: dict[str, float], modes: int = MODES, elements: int = ELEMENTS) -> Mechanism:
    """The spin-up beam for one parameter set ``p`` (see :data:`PARAMETERS`)."""
    beam = PlanarBeam(
        length=p["length"],
        youngs_modulus=p["youngs_modulus"],
        density=p["density"],
        area=p["area"],
        second_moment=p["second_moment"],
        elements=elements,
    ).reduce(modes)
    body = FlexibleBody("beam", beam=beam)
    hub = Revolute(
        ground.point(), body.node(0), drive=SpinUp(p["spin_speed"], p["spin_up_time"]), name="hub"
    )
    mechanism = Mechanism().add(body, hub)
    mechanism.mark("tip", body.tip())
    return mechanism


def spin_up_beam(
    duration: float = 20.0,
    time_steps: int = 401,
    modes: int = MODES,
    elements: int = ELEMENTS,
    rtol: float | None = None,
    atol: float | None = None,
    integrator: str = "auto",
) -> MechanismModel:
    """The registered ``spin-up-beam`` model."""
    return MechanismModel(
        lambda p: build(p, modes, elements),
        parameters=PARAMETERS,
        outputs={"tip_deflection": (lambda r: deflection_in_frame(r, "beam", "tip"), "m")},
        times=np.linspace(0.0, duration, int(time_steps)),
        method=integrator,
        tolerance=ENGINE_TOLERANCE.with_values(rtol, atol),
    )
