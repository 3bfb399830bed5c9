"""Force elements, drives and joints of the planar engine against closed forms, and the
errors a mechanism that cannot be right gets."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs.mechanism_model import MechanismModel
from fuzzymbs.mbs.planar import (
    Fixed,
    FlexibleBody,
    Harmonic,
    MarkerLoad,
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    RotationalSpringDamper,
    SpringDamper,
    UserForce,
    ground,
    linearize,
    simulate,
)

from .user_forces import linear_spring_x

# slow: the planar kernels take about 25 s to compile, which the README's pytest (5 min on a
# fresh clone of 2 cores) cannot spare in every test process; CI runs these with -m slow
pytestmark = pytest.mark.slow


def mass_on_slide(**extra):
    block = RigidBody("block", mass=2.0, inertia=0.1, position=(1.0, 0.0), **extra)
    mechanism = Mechanism().add(block, Prismatic(ground.point(), block.point(), name="slide"))
    return block, mechanism


def test_spring_damper_oscillator_matches_the_closed_form():
    # m x'' + c x' + k (x - l0) = 0, released 0.1 m from rest: x = l0 + 0.1 e^(-zeta w t) (cos wd t
    # + zeta w / wd sin wd t) (any vibration text, e.g. Rao, sec. 2.6)
    block, mechanism = mass_on_slide()
    mechanism.add(
        SpringDamper(ground.point(), block.point(), stiffness=800.0, damping=4.0, free_length=0.9)
    )
    t = np.linspace(0.0, 1.0, 201)
    x = simulate(mechanism, t, rtol=1e-9, atol=1e-12).coordinates("block")[0, :, 0]
    w = np.sqrt(800.0 / 2.0)
    zeta = 4.0 / (2 * np.sqrt(800.0 * 2.0))
    wd = w * np.sqrt(1 - zeta**2)
    exact = 0.9 + 0.1 * np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))
    np.testing.assert_allclose(x, exact, atol=1e-8)


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_both_runge_kutta_pairs_follow_the_closed_form_oscillator(method):
    # the closed form above; DOP853's coefficients are SciPy's transcription of Hairer's
    # code: a wrong one would cost it its order, which the step count below shows too
    block, mechanism = mass_on_slide()
    mechanism.add(SpringDamper(ground.point(), block.point(), stiffness=800.0, free_length=0.9))
    t = np.linspace(0.0, 1.0, 11)
    result = simulate(mechanism, t, rtol=1e-10, atol=1e-13, method=method)
    exact = 0.9 + 0.1 * np.cos(np.sqrt(400.0) * t)
    # measured 1.4e-10 m (Dormand-Prince 5(4)) and 4.2e-11 m (DOP853)
    np.testing.assert_allclose(result.coordinates("block")[0, :, 0], exact, atol=1e-9)
    # 20 rad/s over 1 s at rtol 1e-10: measured 479 (order 5) and 61 (order 8) steps
    assert result.accepted[0] < (600 if method == "dopri5" else 80)


def test_auto_pair_is_dop853_with_flexible_bodies_and_dopri5_without():
    block, rigid = mass_on_slide()
    rigid.add(SpringDamper(ground.point(), block.point(), stiffness=800.0, free_length=0.9))
    beam = PlanarBeam(
        length=1.0, youngs_modulus=2e11, density=7850.0, area=1e-4, second_moment=1e-9, elements=4
    )
    rod = FlexibleBody("rod", beam=beam.reduce(2), angle=-np.pi / 3)
    flexible = Mechanism(gravity=(0.0, -9.81)).add(rod, Revolute(ground.point(), rod.node(0)))
    t = np.linspace(0.0, 0.05, 6)
    for mechanism, pair in ((rigid, "dopri5"), (flexible, "dop853")):
        auto = simulate(mechanism, t)
        chosen = simulate(mechanism, t, method=pair)
        other = simulate(mechanism, t, method="dop853" if pair == "dopri5" else "dopri5")
        assert auto.accepted[0] == chosen.accepted[0] != other.accepted[0]
        np.testing.assert_array_equal(auto.states, chosen.states)
    with pytest.raises(InvalidParameterError, match="unknown integration method 'rk45'"):
        simulate(rigid, t, method="rk45")


def test_user_force_equals_the_built_in_spring():
    # the same linear spring as a compiled user law and as a SpringDamper: the same motion
    t = np.linspace(0.0, 0.5, 51)
    block, with_user = mass_on_slide(velocity=(0.3, 0.0))
    with_user.add(
        UserForce(block.point(), ground.point(), linear_spring_x, parameters=(500.0, -1.0))
    )
    block, built_in = mass_on_slide(velocity=(0.3, 0.0))
    built_in.add(SpringDamper(ground.point(), block.point(), stiffness=500.0, free_length=1.0))
    a = simulate(with_user, t).coordinates("block")[0, :, 0]
    b = simulate(built_in, t).coordinates("block")[0, :, 0]
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert np.ptp(a) > 0.01


def test_harmonic_load_drives_a_mass_as_newton_says():
    # F = F0 sin(w t) on a free mass from rest: x = F0 / (m w^2) (w t - sin w t)
    block, mechanism = mass_on_slide()
    mechanism.add(MarkerLoad(block.point(), force=(3.0, 0.0), profile=Harmonic(1.0, 5.0)))
    t = np.linspace(0.0, 2.0, 101)
    x = simulate(mechanism, t, rtol=1e-9, atol=1e-12).coordinates("block")[0, :, 0]
    np.testing.assert_allclose(x - 1.0, 3.0 / (2.0 * 25.0) * (5.0 * t - np.sin(5.0 * t)), atol=1e-9)


def test_prismatic_drive_prescribes_the_slide():
    block = RigidBody("block", mass=1.0, inertia=0.1, position=(0.0, 0.0))
    mechanism = Mechanism(gravity=(0.0, -9.81)).add(
        block,
        Prismatic(
            ground.point(angle=np.pi / 4), block.point(angle=np.pi / 4), drive=Harmonic(0.2, 3.0)
        ),
    )
    t = np.linspace(0.0, 1.0, 51)
    result = simulate(mechanism, t)
    frame = result.coordinates("block")[0]
    slide = 0.2 * np.sin(3.0 * t)
    np.testing.assert_allclose(frame[:, 0], slide / np.sqrt(2), atol=1e-9)
    np.testing.assert_allclose(frame[:, 1], slide / np.sqrt(2), atol=1e-9)


def test_fixed_joint_welds_a_flexible_beam_as_a_clamp():
    # a cantilever welded to the ground at its root: the linearisation has the clamped
    # Euler-Bernoulli frequencies 1.8751^2 sqrt(EI / (rho A L^4)) and 4.6941^2 (Blevins)
    beam = PlanarBeam(
        length=1.0, youngs_modulus=7e10, density=2700.0, area=1e-4, second_moment=1e-9
    )
    body = FlexibleBody("beam", beam=beam.reduce(4))
    mechanism = Mechanism().add(body, Fixed(ground.point(), body.node(0)))
    ref = np.sqrt(7e10 * 1e-9 / (2700.0 * 1e-4))
    np.testing.assert_allclose(
        linearize(mechanism).frequencies()[:2],
        np.array([1.87510407, 4.69409113]) ** 2 * ref,
        rtol=1e-4,
    )


def test_torsion_spring_pendulum_frequency():
    # a disc on a pin with a torsion spring: w = sqrt(k / J)
    disc = RigidBody("disc", mass=1.0, inertia=0.02)
    mechanism = Mechanism().add(
        disc,
        Revolute(ground.point(), disc.point()),
        RotationalSpringDamper(ground.point(), disc.point(), stiffness=8.0),
    )
    assert linearize(mechanism).frequencies()[0] == pytest.approx(20.0, rel=1e-7)


# -- refusals ------------------------------------------------------------------------


def test_joint_whose_markers_do_not_meet_is_refused_by_name():
    rod = RigidBody("rod", mass=1.0, inertia=0.1, position=(0.5, 0.0))
    mechanism = Mechanism().add(rod, Revolute(ground.point(), rod.point(), name="pin"))
    with pytest.raises(InvalidParameterError, match=r"joint pin is violated at the start by 0\.5"):
        mechanism.check()


def test_redundant_joint_is_refused_by_name():
    rod = RigidBody("rod", mass=1.0, inertia=0.1)
    mechanism = Mechanism().add(
        rod,
        Fixed(ground.point(), rod.point(), name="weld"),
        Revolute(ground.point(), rod.point(), name="pin"),
    )
    with pytest.raises(InvalidParameterError, match="joint pin is redundant"):
        mechanism.check()


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: RigidBody("rod", mass=0.0), "mass must be finite and > 0"),
        (lambda: RigidBody("rod", inertia=-1.0), "inertia must be finite and > 0"),
        (lambda: RigidBody("rod", position=(np.nan, 0)), "position"),
        (lambda: SpringDamper(ground.point(), ground.point(1, 0), stiffness=-1.0), "stiffness"),
        (lambda: Revolute(ground.point(), ground.point()), "two ground markers"),
        (lambda: Mechanism(gravity=(0, 0, -9.81)), "gravity"),
    ],
)
def test_bad_elements_are_refused_by_name(make, match):
    with pytest.raises(InvalidParameterError, match=match):
        make()


def test_body_not_added_is_refused():
    rod = RigidBody("rod")
    other = RigidBody("other")
    mechanism = Mechanism().add(rod, Revolute(ground.point(), other.point()))
    with pytest.raises(InvalidParameterError, match="'other', which was not added"):
        mechanism.pack()


def test_model_refuses_unknown_parameters_and_markers():
    def build(p):
        rod = RigidBody("rod", mass=p["mass"], inertia=0.1)
        mechanism = Mechanism().add(rod, Revolute(ground.point(), rod.point()))
        mechanism.mark("tip", rod.point(1.0, 0.0))
        return mechanism

    model = MechanismModel(
        build, {"mass": 1.0}, {"x": (lambda r: r.marker("nose")[..., 0], "m")}, [0.0, 0.1]
    )
    with pytest.raises(InvalidParameterError, match=r"unknown parameter\(s\) \['mas'\]"):
        model({"mas": [1.0]})
    with pytest.raises(
        InvalidParameterError, match="no marker named 'nose'; named markers: \\['tip'\\]"
    ):
        model({"mass": [1.0]})


def test_samples_with_another_structure_are_refused():
    from fuzzymbs.mbs.planar import pack_batch

    def pendulum(modes):
        body = FlexibleBody("beam", beam=PlanarBeam(1.0, 7e10, 2700.0, 1e-4, 1e-9).reduce(modes))
        return Mechanism().add(body, Revolute(ground.point(), body.node(0)))

    with pytest.raises(InvalidParameterError, match="sample 1's mechanism has another structure"):
        pack_batch([pendulum(2), pendulum(3)])
