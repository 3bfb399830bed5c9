"""A flexible pendulum: an FE beam of rectangular section on a revolute joint under gravity.

The beam (Euler-Bernoulli, 16 elements, clamped modes in the frame at the
pin) hangs from a pin at the origin and is released from rest at
``initial_angle`` from the vertical. Outputs: the joint angle from the
vertical [rad] and the tip's transverse deflection in the body frame [m].
Its small-amplitude rigid frequency and its first elastic frequency are
checked against closed forms in tests/models/test_mechanisms.py.
"""

from __future__ import annotations

import numpy as np

from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.mechanism_model import ENGINE_TOLERANCE, MechanismModel
from fuzzymbs.mbs.planar import FlexibleBody, Mechanism, Revolute, ground
from fuzzymbs.models.mechanisms.outputs import deflection_in_frame

#: Default parameters (SI): a 1 m steel strip of 30 mm x 3 mm released at 60 degrees.
PARAMETERS = {
    "length": 1.0,
    "youngs_modulus": 2.1e11,
    "density": 7850.0,
    "width": 0.03,
    "height": 0.003,
    "initial_angle": np.pi / 3,
}
GRAVITY = 9.81
#: Clamped modes kept (docs/mechanisms.md: 6 modes are within 1 % of 8 on the tip deflection;
#: above 8 the clamped modes of a pinned beam nearly reproduce the frame rotation).
MODES = 6
ELEMENTS = 16


def build(p: dict[str, float], modes: int = MODES, elements: int = ELEMENTS) -> Mechanism:
    """The pendulum for one parameter set ``p`` (see :data:`PARAMETERS`)."""
    beam = PlanarBeam(
        length=p["length"],
        youngs_modulus=p["youngs_modulus"],
        density=p["density"],
        area=p["width"] * p["height"],
        second_moment=p["width"] * p["height"] ** 3 / 12.0,
        elements=elements,
    ).reduce(modes)
    body = FlexibleBody("beam", beam=beam, angle=-np.pi / 2 + p["initial_angle"])
    mechanism = Mechanism(gravity=(0.0, -GRAVITY))
    # the ground marker points down: the joint angle is the angle from the vertical
    mechanism.add(body, Revolute(ground.point(angle=-np.pi / 2), body.node(0), name="pin"))
    mechanism.mark("root", body.node(0))
    mechanism.mark("tip", body.tip())
    return mechanism


def joint_angle(result) -> np.ndarray:
    root = result.marker("root")
    return root[..., 2] + np.pi / 2


def flexible_pendulum(
    duration: float = 4.0,
    time_steps: int = 401,
    modes: int = MODES,
    elements: int = ELEMENTS,
    rtol: float | None = None,
    atol: float | None = None,
    integrator: str = "auto",
) -> MechanismModel:
    """The registered ``flexible-pendulum`` model."""
    return MechanismModel(
        lambda p: build(p, modes, elements),
        parameters=PARAMETERS,
        outputs={
            "angle": (joint_angle, "rad"),
            "tip_deflection": (lambda r: deflection_in_frame(r, "beam", "tip"), "m"),
        },
        times=np.linspace(0.0, duration, int(time_steps)),
        method=integrator,
        tolerance=ENGINE_TOLERANCE.with_values(rtol, atol),
    )
