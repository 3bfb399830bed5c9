"""General bodies and joints in a System (minimal coordinates).

* A System built from spatial FlexibleBody objects and joints to the ground compiles to
  exactly the kernel arrays of the same system written with the frame motions directly
  (FixedBody, TranslatingBody, RotatingBody): bit for bit, so results are unchanged.
* The second method: the same body and joint objects run in absolute coordinates with
  Lagrange multipliers (spatial.Mechanism, its own derivation and kernels). A flexible body
  turning at a prescribed rate (gyroscopic, spin-softening and centrifugal terms) and one
  sliding on a prismatic joint (the slide's coupling to the modes through C_t) agree.
* What the minimal form cannot hold is refused by name.
"""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import FixedBody, RotatingBody, TranslatingBody
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import simulate_reference
from fuzzymbs.mbs.lumped import lumped_modal_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.spatial import (
    ConstantRate,
    Fixed,
    FlexibleBody,
    Mechanism,
    Prismatic,
    Revolute,
    Spherical,
    frame_with_z,
    ground,
)
from fuzzymbs.mbs.system import Coordinate, System

Y = frame_with_z((0.0, 1.0, 0.0))


def cluster(name="cluster"):
    """Five point masses on axial springs, node 0 held by the frame: modes that move the
    centre of mass and turn the body (C_t, C_r and the gyroscopic matrices non-zero)."""
    positions = np.array(
        [[0.0, 0.0, 0.0], [0.4, 0.05, 0.0], [0.0, 0.3, 0.1], [0.1, 0.0, 0.35], [0.3, 0.1, 0.4]]
    )
    masses = np.array([0.5, 0.8, 0.6, 0.7, 0.9])
    k = np.zeros((15, 15))
    for i in range(5):
        for j in range(i + 1, 5):
            n = positions[j] - positions[i]
            n = n / np.linalg.norm(n)
            block = 2e3 * np.outer(n, n)
            for a, b, sign in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
                k[3 * a : 3 * a + 3, 3 * b : 3 * b + 3] += sign * block
    return lumped_modal_body(
        name, positions, masses, k, free_dofs=np.arange(3, 15), node_sets={"tip": [4]}
    )


def general_system():
    speed = Parameter("omega", 3.0)
    system = System()
    disc = system.add_body(FlexibleBody("disc", cluster("disc"), damping_ratio=0.01))
    system.add_joint(Revolute(ground.point(axes=Y), disc.point(axes=Y), ConstantRate(speed)))
    pad = system.add_body(FlexibleBody("pad", cluster("pad"), position=(0.0, 1.0, 0.0)))
    system.add_joint(Prismatic(ground.point((0.0, 1.0, 0.0), Y), pad.point(axes=Y)))
    base = system.add_body(FlexibleBody("base", cluster("base"), position=(0.0, 2.0, 0.0)))
    system.add_joint(Fixed(ground.point((0.0, 2.0, 0.0)), base.point()))
    return system


def add_forces(system):
    system.add(NodalForce("press", "pad", "tip", "-y", Parameter("force", 10.0)))
    system.add(Spring("link", "pad", [0], "base", [0], stiffness=Parameter("k", 1e3)))
    return system


def test_general_bodies_compile_to_the_frame_motions_bit_for_bit():
    general = add_forces(general_system()).compile()
    direct = System()
    direct.add_body(RotatingBody(cluster("disc"), "y", Parameter("omega", 3.0), damping_ratio=0.01))
    direct.add_body(TranslatingBody(cluster("pad"), ["y"], origin=(0.0, 1.0, 0.0)))
    direct.add_body(FixedBody(cluster("base"), origin=(0.0, 2.0, 0.0)))
    direct = add_forces(direct).compile()
    assert len(general.data) == len(direct.data)
    for a, b in zip(general.data, direct.data, strict=True):
        np.testing.assert_array_equal(a, b)  # the same arrays: the same kernel results
    assert general.parameters.slots == direct.parameters.slots
    np.testing.assert_array_equal(general.initial_state(2), np.zeros((2, general.n_state)))


def test_initial_coordinates_and_slide_velocity_reach_the_state():
    system = System()
    modal = cluster("pad")
    q0 = np.linspace(1e-3, 2e-3, modal.n_modes)
    pad = system.add_body(
        FlexibleBody("pad", modal, velocity=(0.0, 0.5, 0.0), coordinates=q0, rates=-q0)
    )
    system.add_joint(Prismatic(ground.point(axes=Y), pad.point(axes=Y)))
    compiled = system.compile()
    n = compiled.n_dofs
    state = compiled.initial_state(3)
    assert state.shape == (3, 2 * n)
    np.testing.assert_array_equal(state[:, 1:n], np.tile(q0, (3, 1)))
    np.testing.assert_array_equal(state[:, n], 0.5)  # the slide's rate: v . axis
    np.testing.assert_array_equal(state[:, n + 1 :], np.tile(-q0, (3, 1)))


def held(name, joint, **body_options):
    """A System of one body ``name`` held by ``joint(body)`` (a list of joints, or None)."""
    system = System()
    body = system.add_body(FlexibleBody(name, cluster(), **body_options))
    for j in joint(body) or []:
        system.add_joint(j)
    return system


def slide(body):
    """A prismatic joint along y from the ground to ``body``'s frame origin."""
    return [Prismatic(ground.point(axes=Y), body.point(axes=Y))]


def off_axis(at):
    # the markers meet at the ground point ``at``; the frame origin (0.1, 0, 0) is on the
    # joint's axis (along y) only when ``at`` lies above it
    return held(
        "wobbly",
        lambda b: [
            Revolute(
                ground.point(at, Y), b.point(np.subtract(at, (0.1, 0, 0)), Y), ConstantRate(1.0)
            )
        ],
        position=(0.1, 0.0, 0.0),
    )


REFUSALS = {
    "free turn": (
        lambda: held("rotor", lambda b: [Revolute(ground.point(axes=Y), b.point(axes=Y))]),
        "'rotor'.*ConstantRate.*spatial.Mechanism",
    ),
    "two joints": (
        lambda: held(
            "slider",
            lambda b: [*slide(b), Fixed(ground.point(), b.point())],
        ),
        "'slider' has 2 joints",
    ),
    "no joint": (lambda: held("loose", lambda b: None), "'loose' has 0 joints"),
    "markers apart": (
        lambda: held("gap", slide, position=(0.0, 0.01, 0.0)),
        "'gap'.*0.01 m apart",
    ),
    "turned frame": (
        lambda: held("tilted", lambda b: [Fixed(ground.point(axes=Y), b.point())], orientation=Y),
        "'tilted'.*orientation must be the identity",
    ),
    "origin off the axis": (
        lambda: off_axis((0.0, 0.0, 0.0)),
        "'wobbly'.*frame origin must lie on the",
    ),
    "sideways start": (
        lambda: held("drifting", slide, velocity=(1.0, 0.0, 0.0)),
        "'drifting'.*initial frame velocity",
    ),
    "ball joint": (
        lambda: held("ball", lambda b: [Spherical(ground.point(), b.point())]),
        "'ball'.*not Spherical",
    ),
}


@pytest.mark.parametrize("case", sorted(REFUSALS))
def test_what_the_minimal_form_cannot_hold_is_refused_by_name(case):
    build, match = REFUSALS[case]
    with pytest.raises(InvalidParameterError, match=match):
        build().compile()


def test_a_joint_between_moving_bodies_and_a_foreign_joint_are_refused():
    system = System()
    a = system.add_body(FlexibleBody("a", cluster("a")))
    b = system.add_body(FlexibleBody("b", cluster("b")))
    system.add_joint(Fixed(ground.point(), a.point()))
    system.add_joint(Fixed(a.point(), b.point()))
    with pytest.raises(InvalidParameterError, match="two moving bodies"):
        system.compile()
    with pytest.raises(InvalidParameterError, match="add_joint needs a spatial joint"):
        System().add_joint("hinge")
    off_axis((0.1, 0.3, 0.0)).compile()  # the axis through the frame origin: accepted


def test_a_parameter_rate_is_refused_by_the_absolute_coordinate_engine():
    body = FlexibleBody("disc", cluster())
    joint = Revolute(ground.point(axes=Y), body.point(axes=Y), ConstantRate(Parameter("w", 2.0)))
    with pytest.raises(InvalidParameterError, match=r"Parameter 'w'.*only a System binds"):
        Mechanism().add(body, joint).pack()


def modal_history_minimal(system, times):
    """Every coordinate of the System's single body, from SciPy's DOP853 at rtol 1e-10."""
    compiled = system.compile()
    outputs = {f"q{i}": Coordinate(b, i) for b in compiled.bodies for i in range(compiled.n_dofs)}
    run = simulate_reference(compiled, t_end=times[-1], outputs=outputs, times=times)
    return np.stack([run[f"q{i}"] for i in range(compiled.n_dofs)], axis=-1)


def both_forms(body, joint, times):
    """One body on one joint to the ground, in minimal coordinates (DOP853 on the System's
    right-hand side) and in absolute coordinates (the spatial engine), both at rtol 1e-10."""
    from fuzzymbs.mbs.spatial import simulate as simulate_mechanism

    system = System()
    system.add_body(body)
    system.add_joint(joint)
    minimal = modal_history_minimal(system, times)
    absolute = simulate_mechanism(Mechanism().add(body, joint), times, rtol=1e-10, atol=1e-13)
    return minimal, absolute


@pytest.mark.slow  # the spatial kernels compile for about 25 s
def test_a_driven_turn_agrees_with_the_absolute_coordinate_engine():
    rate = 12.0  # rad/s, 0.38 of the lowest mode's 31.6 rad/s: gyroscopic and softening terms
    modal = cluster("rotor")
    q0 = 1e-3 * np.cos(np.arange(modal.n_modes))
    body = FlexibleBody(
        "rotor", modal, angular_velocity=(0.0, rate, 0.0), coordinates=q0, damping_ratio=0.02
    )
    joint = Revolute(ground.point(axes=Y), body.point(axes=Y), ConstantRate(rate))
    times = np.linspace(0.0, 0.5, 101)
    minimal, absolute = both_forms(body, joint, times)
    modes = absolute.modal_coordinates("rotor")[0]
    scale = np.abs(minimal).max()
    # two formulations, both integrated to rtol 1e-10; measured 7.9e-11 of the motion
    # (the centrifugal load deflects the modes to 0.08 from 1e-3 at the start)
    np.testing.assert_allclose(modes, minimal, atol=1e-9 * scale)
    # the turn itself follows the drive: p = (cos(wt/2), 0, sin(wt/2), 0)
    p = absolute.euler_parameters("rotor")[0]
    np.testing.assert_allclose(p[:, 2], np.sin(rate * times / 2), atol=1e-8)
    # and the check has teeth: without the rotation, the modes move differently
    still = System()
    still.add_body(FixedBody(modal, damping_ratio=0.02))
    assert np.abs(modal_history_minimal(still, times)[:, 0] - minimal[:, 0]).max() > 0.05 * scale


@pytest.mark.slow
def test_a_slide_agrees_with_the_absolute_coordinate_engine():
    modal = cluster("slider")
    q0 = 2e-3 * np.sin(1.0 + np.arange(modal.n_modes))
    body = FlexibleBody("slider", modal, velocity=(0.0, 0.3, 0.0), coordinates=q0)
    joint = Prismatic(ground.point(axes=Y), body.point(axes=Y))
    times = np.linspace(0.0, 0.5, 101)
    minimal, absolute = both_forms(body, joint, times)
    slide = absolute.position("slider")[0][:, 1]
    modes = absolute.modal_coordinates("slider")[0]
    # measured: 1.8e-13 m of a 0.15 m slide; the modes 1.4e-9 of their largest value
    np.testing.assert_allclose(slide, minimal[:, 0], atol=1e-11)
    np.testing.assert_allclose(modes, minimal[:, 1:], atol=1e-8 * np.abs(minimal[:, 1:]).max())
    # momentum exchange through C_t: the slide leaves the constant rate by 9.7e-4 m
    assert np.abs(slide - 0.3 * times).max() > 1e-4


def test_as_mechanism_refuses_what_has_no_absolute_form():
    from fuzzymbs.mbs.profiles import TimeProfile

    with pytest.raises(InvalidParameterError, match=r"unknown parameter\(s\) \['omegaa'\]"):
        add_forces(general_system()).as_mechanism({"omegaa": 2.0})
    direct = System()
    direct.add_body(FixedBody(cluster("base")))
    with pytest.raises(InvalidParameterError, match="'base' is a FixedBody"):
        direct.as_mechanism()
    system = general_system()
    system.add(NodalForce("pulse", "pad", "tip", "y", 1.0, profile=TimeProfile([0, 1], [0, 1])))
    with pytest.raises(InvalidParameterError, match=r"'pulse'.*TimeProfile"):
        system.as_mechanism()


def test_as_mechanism_writes_each_element_in_the_general_vocabulary():
    system = add_forces(general_system())
    mechanism = system.as_mechanism({"omega": 5.0, "force": 2.0})
    assert len(mechanism.bodies) == 3 and len(mechanism.joints) == 3
    forces = {type(e).__name__: e for e in mechanism.forces}
    assert len(mechanism.forces) == 2  # the press on one node, the spring on one node pair
    np.testing.assert_array_equal(forces["MarkerLoad"].force, (0.0, -2.0, 0.0))  # sample, -y
    # a 3D spring: stiffness along all three axes, no angular springs
    assert list(forces["Bushing"].stiffness) == [1e3, 1e3, 1e3, 0.0, 0.0, 0.0]
    hinge = next(j for j in mechanism.joints if type(j).__name__ == "Revolute")
    assert hinge.drive.rate == 5.0
    np.testing.assert_array_equal(hinge.marker_j.body.angular_velocity, (0.0, 5.0, 0.0))
    # copies: the System's own disc keeps its start at rest
    np.testing.assert_array_equal(system.bodies["disc"].angular_velocity, 0.0)


def test_a_turning_body_carries_its_spin_stiffening_into_the_system():
    # a beam's foreshortening and an FE body's own prestress reach the rotating frame
    # motion as the same Omega^2 K_e (K_e = sum_ij e_i e_j K_ij; for a beam along x
    # turning about z, K_zz = K_s): without it the System would silently drop it
    from fuzzymbs.fe.beam import PlanarBeam

    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=6.75e-11
    ).reduce(4)
    z = frame_with_z((0.0, 0.0, 1.0))
    for stiffened in (True, False):
        body = FlexibleBody(
            "strip", beam.modal_body(), stiffening=beam.stiffening() if stiffened else None
        )
        system = System()
        system.add_body(body)
        system.add_joint(Revolute(ground.point(axes=z), body.point(axes=z), ConstantRate(3.0)))
        rotating = system.compile().bodies["strip"]
        softening = body.modal.centrifugal[2, 2]
        expected = softening + (beam.geometric_spin if stiffened else 0.0)
        np.testing.assert_allclose(rotating.rotated_matrices()["centrifugal"], expected)


def test_the_spin_up_profile_matches_the_mechanism_engines_drive():
    # Kane's ramp twice: the brake kernels' profile (speed multiplier, its integral and
    # slope) against the mechanism engines' SpinUp drive (angle, rate, acceleration), two
    # codes of one formula; and p(0) = 0, p(T) = 1 with zero slope at both ends
    from fuzzymbs.mbs.kernels.kinematics import spin_up
    from fuzzymbs.mbs.planar.profiles import SpinUp as Drive
    from fuzzymbs.mbs.planar.profiles import evaluate
    from fuzzymbs.mbs.profiles import SpinUpProfile

    duration, speed = 15.0, 4.0
    times = np.linspace(0.0, 20.0, 81)  # the runs start at t = 0
    angle, rate, acceleration = evaluate(Drive(speed, duration), times)
    ours = np.array([spin_up(duration, t) for t in times])
    np.testing.assert_allclose(speed * ours[:, 1], angle, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(speed * ours[:, 0], rate, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(speed * ours[:, 2], acceleration, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(SpinUpProfile(duration)(times), ours[:, 0], atol=1e-15)
    edges = np.array([spin_up(duration, t) for t in (0.0, duration)])
    np.testing.assert_allclose(edges[:, [0, 2]], [[0.0, 0.0], [1.0, 0.0]], atol=1e-15)
