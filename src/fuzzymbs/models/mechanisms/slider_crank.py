"""A slider-crank with a flexible connecting rod.

A rigid steel crank of 0.15 m turns about the origin, driven by a revolute
joint from rest along +x up to ``crank_speed`` in ``spin_up_time`` (the
smooth spin-up of :class:`fuzzymbs.mbs.planar.SpinUp`), then at that constant
speed; a steel connecting rod of
0.3 m and rectangular section (Euler-Bernoulli, 12 elements, pinned-pinned
modes in the chord frame) joins it to a slider of ``slider_mass`` on the x
axis. The rod's geometric stiffness follows its axial force (the slider's
inertia and the rod's own), which at the default speed reaches about a
fifth of its buckling load. Outputs: the rod midpoint's deflection across
the chord [m], the slider position [m], the pin force on the slider along
and across the slide [N] and the torque driving the crank [N m].
Checked against a co-rotational beam model in tests/models/test_mechanisms.py.

Why the spin-up: started at full speed, the undamped rod rings at its axial
frequencies (26 and 80 krad/s) for ever, and the pin force and crank torque
are that ringing: 4, 8 and 12 modes disagree by 50 to 120 % of their peaks.
Spun up in 20 ms the same outputs agree within 0.04 % from 4 modes on
(docs/mechanisms.md).
"""

from __future__ import annotations

import numpy as np

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.mechanism_model import MechanismModel
from fuzzymbs.mbs.planar import (
    FlexibleBody,
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    SpinUp,
    ground,
)
from fuzzymbs.models.mechanisms.outputs import deflection_in_frame
from fuzzymbs.tolerance import Tolerance

CRANK_LENGTH = 0.15
ROD_LENGTH = 0.3
STEEL_DENSITY = 7870.0
CRANK_SECTION = (0.02, 0.01)
#: Default parameters (SI).
PARAMETERS = {
    "crank_speed": 150.0,
    "spin_up_time": 0.02,
    "youngs_modulus": 2.0e11,
    "rod_width": 0.01,
    "rod_height": 0.006,
    "slider_mass": 0.1,
}
#: Pinned-pinned modes kept (docs/mechanisms.md has the convergence measurement).
MODES = 6
ELEMENTS = 12
#: Step-control tolerance. Looser than the engine's default (rtol 1e-6, atol 1e-8):
#: the rod's stiffest mode, not the tolerance, sets DOP853's step here (one step per
#: output time from rtol 1e-5 on), and on a 64-sample fuzzy study's bands every output
#: stays within 1e-3 of its band width of a run at rtol 1e-10 (as it does up to rtol
#: 1e-3), 3 to 2,000 times below the mode count's error (docs/mechanisms.md, "Numerical
#: defaults").
TOLERANCE = Tolerance(rtol=1e-5, atol=1e-7)


def build(p: dict[str, float], modes: int = MODES, elements: int = ELEMENTS) -> Mechanism:
    """The slider-crank for one parameter set ``p`` (see :data:`PARAMETERS`)."""
    crank_mass = STEEL_DENSITY * CRANK_LENGTH * CRANK_SECTION[0] * CRANK_SECTION[1]
    crank = RigidBody(
        "crank",
        mass=crank_mass,
        inertia=crank_mass * CRANK_LENGTH**2 / 12.0,
        center=(CRANK_LENGTH / 2, 0.0),
    )
    beam = PlanarBeam(
        length=ROD_LENGTH,
        youngs_modulus=p["youngs_modulus"],
        density=STEEL_DENSITY,
        area=p["rod_width"] * p["rod_height"],
        second_moment=p["rod_width"] * p["rod_height"] ** 3 / 12.0,
        elements=elements,
        support="pinned-pinned",
    ).reduce(modes)
    rod = FlexibleBody("rod", beam=beam, position=(CRANK_LENGTH, 0.0))
    slider = RigidBody(
        "slider",
        mass=p["slider_mass"],
        inertia=p["slider_mass"] * 1e-4,
        position=(CRANK_LENGTH + ROD_LENGTH, 0.0),
    )
    mechanism = Mechanism()
    mechanism.add(
        crank,
        rod,
        slider,
        Revolute(
            ground.point(),
            crank.point(),
            drive=SpinUp(p["crank_speed"], p["spin_up_time"]),
            name="crank",
        ),
        Revolute(crank.point(CRANK_LENGTH, 0.0), rod.node(0), name="crank_pin"),
        Revolute(rod.tip(), slider.point(), name="slider_pin"),
        Prismatic(ground.point(), slider.point(), name="slide"),
    )
    mechanism.mark("midpoint", rod.node(elements // 2))
    return mechanism


def slider_crank(
    duration: float = 0.1,
    time_steps: int = 501,
    modes: int = MODES,
    elements: int = ELEMENTS,
    rtol: float = TOLERANCE.rtol,
    atol: float = TOLERANCE.atol,
    integrator: str = "auto",
) -> MechanismModel:
    """The registered ``slider-crank`` model (``integrator``: the Runge-Kutta pair,
    :func:`fuzzymbs.mbs.planar.simulate`'s ``method``)."""
    if int(elements) % 2:
        raise ValueError(
            f"slider-crank needs an even element count (a node at the midpoint), got {elements}"
        )
    return MechanismModel(
        lambda p: build(p, modes, elements),
        parameters=PARAMETERS,
        outputs={
            "midpoint_deflection": (lambda r: deflection_in_frame(r, "rod", "midpoint"), "m"),
            "slider_position": (lambda r: r.coordinates("slider")[..., 0], "m"),
            "slider_pin_force_x": (lambda r: r.reaction("slider_pin")[..., 0], "N"),
            "slider_pin_force_y": (lambda r: r.reaction("slider_pin")[..., 1], "N"),
            "crank_torque": (lambda r: r.reaction("crank")[..., 2], "N m"),
        },
        times=np.linspace(0.0, duration, int(time_steps)),
        method=integrator,
        tolerance=TOLERANCE.with_values(rtol, atol),
    )
