"""Flexible bodies in the spatial engine: the floating-frame terms against independent
references.

* The mass matrix and the quadratic-velocity, gravity and elastic forces from the inertia
  shape integrals against the same quantities summed node by node over a body of point
  masses (the definition: each mass m_k at r + A (xbar_k + Psi_k q)).
* A free flexible body tumbling in space keeps its energy, its linear momentum and its
  angular momentum about the origin (each summed over the point masses).
* A flexible pendulum moving in a plane against the planar engine (a separate derivation
  and code) on the same beam modes, without geometric stiffening in either.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.beam import PlanarBeam
from fuzzymbs.mbs import planar
from fuzzymbs.mbs.lumped import lumped_modal_body
from fuzzymbs.mbs.spatial import FlexibleBody, Mechanism, Revolute, Spherical, ground, simulate
from fuzzymbs.mbs.spatial import kernels as spatial_kernels

# slow: the spatial kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow

GRAVITY = np.array([0.0, -9.81, 0.0])


def skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def bar_network(positions, pairs, stiffness):
    """Stiffness matrix of axial springs between nodes (rows (node, x/y/z))."""
    k = np.zeros((3 * len(positions), 3 * len(positions)))
    for i, j in pairs:
        n = positions[j] - positions[i]
        n = n / np.linalg.norm(n)
        block = stiffness * np.outer(n, n)
        for a, b, sign in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            k[3 * a : 3 * a + 3, 3 * b : 3 * b + 3] += sign * block
    return k


def lumped_body():
    """Six point masses on springs, node 0 held by the frame and nodes 1 and 2 in part (no
    mechanism is left, so the modes both move the centre of mass and turn the body: neither
    C_t nor C_r is zero)."""
    positions = np.array(
        [
            [0.0, 0.0, 0.0],
            [0.4, 0.05, 0.0],
            [0.0, 0.3, 0.1],
            [0.1, 0.0, 0.35],
            [0.45, 0.35, 0.05],
            [0.3, 0.1, 0.4],
        ]
    )
    masses = np.array([0.5, 0.8, 0.6, 0.7, 0.4, 0.9])
    pairs = [(i, j) for i in range(6) for j in range(i + 1, 6)]
    stiffness = bar_network(positions, pairs, 2e3)
    return lumped_modal_body(
        "cluster",
        positions,
        masses,
        stiffness,
        free_dofs=np.setdiff1d(np.arange(18), [0, 1, 2, 4, 5, 8]),
    ), masses


def node_sums(modal, masses, rotation, q, w, qd, damping):
    """Mass matrix and forces on (r', w, q') summed over the point masses (the definition)."""
    r = modal.n_modes
    size = 6 + r
    mass = np.zeros((size, size))
    forces = np.zeros(size)
    for k, m in enumerate(masses):
        psi = modal.mode_shapes[k]
        u = modal.node_positions[k] + psi @ q
        jac = np.hstack([np.eye(3), -rotation @ skew(u), rotation @ psi])
        quadratic = rotation @ (np.cross(w, np.cross(w, u)) + 2 * np.cross(w, psi @ qd))
        mass += m * jac.T @ jac
        forces += m * jac.T @ (GRAVITY - quadratic)
    omega = modal.frequencies
    forces[6:] -= omega**2 * q + damping * qd
    return mass, forces


def test_mass_matrix_and_forces_match_the_node_sums():
    modal, masses = lumped_body()
    assert modal.n_modes == 12
    assert np.abs(modal.translation_coupling).max() > 0
    assert np.abs(modal.rotation_coupling).max() > 0.1 * np.abs(modal.translation_coupling).max()
    rng = np.random.default_rng(7)
    rotation = Rotation.from_rotvec([0.3, -0.7, 1.1]).as_matrix()
    q = 0.02 * rng.standard_normal(modal.n_modes)
    qd = 0.5 * rng.standard_normal(modal.n_modes)
    w = np.array([1.5, -2.0, 0.7])
    body = FlexibleBody(
        "cluster",
        modal,
        position=(0.2, 0.1, -0.3),
        orientation=rotation,
        angular_velocity=rotation @ w,
        damping_ratio=0.02,
        coordinates=q,
        rates=qd,
    )
    layout, data, state = Mechanism(gravity=GRAVITY).add(body).pack()
    nq = layout[4][0]
    size = layout[4][1]
    mass = np.zeros((size, size))
    forces = np.zeros(size)
    spatial_kernels.body_terms(layout[0], data, state[:nq], state[nq:], mass, forces)
    ref_mass, ref_forces = node_sums(
        modal, masses, rotation, q, w, qd, 2 * 0.02 * modal.frequencies
    )
    # the same quantities by two routes: round-off only
    np.testing.assert_allclose(mass, ref_mass, atol=1e-12 * np.abs(ref_mass).max())
    np.testing.assert_allclose(forces, ref_forces, atol=1e-10 * np.abs(ref_forces).max())


def test_free_flexible_body_keeps_energy_and_momenta():
    modal, masses = lumped_body()
    rng = np.random.default_rng(3)
    body = FlexibleBody(
        "cluster",
        modal,
        velocity=(0.3, -0.2, 0.1),
        angular_velocity=(2.0, 5.0, -3.0),
        coordinates=0.01 * rng.standard_normal(modal.n_modes),
    )
    mechanism = Mechanism().add(body)
    times = np.linspace(0.0, 1.0, 51)
    result = simulate(mechanism, times, rtol=1e-10, atol=1e-12)
    assert not result.failed.any()
    rotation = Rotation.from_quat(result.euler_parameters("cluster")[0][:, [1, 2, 3, 0]])
    origin = result.position("cluster")[0]
    velocity = result.velocity("cluster")[0]
    w = result.angular_velocity("cluster")[0]
    q = result.modal_coordinates("cluster")[0]
    qd = result.states[0, :, -modal.n_modes :]
    momentum = np.zeros((times.size, 3))
    angular = np.zeros((times.size, 3))
    for k, m in enumerate(masses):
        psi = modal.mode_shapes[k]
        u = modal.node_positions[k] + q @ psi.T
        point = origin + rotation.apply(u)
        speed = velocity + rotation.apply(np.cross(w, u) + qd @ psi.T)
        momentum += m * speed
        angular += m * np.cross(point, speed)
    assert np.abs(q).max() > 1e-3  # the body really deforms
    # rtol 1e-10: conserved to 1e-9 of their size
    assert np.abs(momentum - momentum[0]).max() < 1e-9 * np.abs(momentum).max()
    assert np.abs(angular - angular[0]).max() < 1e-9 * np.abs(angular).max()
    energy = result.energy()[0]
    assert np.abs(energy[:, 1]).max() == 0.0  # no gravity
    total = energy.sum(axis=1)
    assert np.ptp(total) < 2e-9 * total[0]  # measured 4.7e-10


def test_uniform_gravity_leaves_a_free_bodys_relative_motion_unchanged():
    # a free body in uniform gravity: its frame falls by g t^2 / 2 on top of its motion
    # without gravity, its modes and its turning do not change (every point gets the same
    # acceleration g); this checks the gravity terms m g, S~ A^T g and C_t^T A^T g together
    modal, _ = lumped_body()
    coordinates = 0.01 * np.random.default_rng(3).standard_normal(modal.n_modes)
    times = np.linspace(0.0, 0.5, 51)

    def tumbling(gravity):
        body = FlexibleBody(
            "cluster",
            modal,
            velocity=(0.3, -0.2, 0.1),
            angular_velocity=(2.0, 5.0, -3.0),
            coordinates=coordinates,
        )
        return simulate(Mechanism(gravity=gravity).add(body), times, rtol=1e-11, atol=1e-13)

    falling, floating = tumbling(GRAVITY), tumbling((0.0, 0.0, 0.0))
    drop = 0.5 * np.outer(times**2, GRAVITY)
    # measured 1.4e-14 m and 2.6e-14
    np.testing.assert_allclose(
        falling.position("cluster")[0] - drop, floating.position("cluster")[0], atol=1e-11
    )
    np.testing.assert_allclose(
        falling.modal_coordinates("cluster")[0],
        floating.modal_coordinates("cluster")[0],
        atol=1e-11,
    )
    np.testing.assert_allclose(
        falling.euler_parameters("cluster")[0], floating.euler_parameters("cluster")[0], atol=1e-11
    )


def test_flexible_pendulum_matches_the_planar_engine():
    # a steel strip swinging from 60 degrees about a pivot at its root, 4 clamped modes;
    # both engines without geometric stiffening (the spatial engine has none)
    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=6.75e-11
    ).reduce(4)
    start = -np.pi / 2 + np.pi / 3
    flat = planar.FlexibleBody("beam", beam=beam, angle=start, geometric_stiffening=False)
    flat_mechanism = planar.Mechanism(gravity=(0.0, -9.81)).add(
        flat, planar.Revolute(planar.ground.point(), flat.node(0))
    )
    body = FlexibleBody(
        "beam", beam.modal_body(), orientation=Rotation.from_euler("z", start).as_matrix()
    )
    mechanism = Mechanism(gravity=GRAVITY).add(body, Revolute(ground.point(), body.node(0)))
    times = np.linspace(0.0, 1.5, 151)
    flat_result = planar.simulate(flat_mechanism, times, rtol=1e-10, atol=1e-12)
    result = simulate(mechanism, times, rtol=1e-10, atol=1e-12)
    assert not (flat_result.failed.any() or result.failed.any())
    flat_state = flat_result.coordinates("beam")[0]
    angle = Rotation.from_quat(result.euler_parameters("beam")[0][:, [1, 2, 3, 0]]).as_rotvec()
    # measured agreement: angle 7e-12 rad, modes 9e-10 of their largest (both at rtol 1e-10)
    np.testing.assert_allclose(angle[:, 2], flat_state[:, 2], atol=1e-9)
    np.testing.assert_allclose(angle[:, :2], 0.0, atol=1e-10)
    modes = result.modal_coordinates("beam")[0]
    assert np.abs(modes).max() > 1e-5  # the strip bends
    np.testing.assert_allclose(modes, flat_state[:, 3:], atol=1e-7 * np.abs(modes).max())


def test_node_set_marker_on_a_flexible_body_joins_a_spherical_joint():
    # the body hangs from the mean of two of its deforming nodes by a spherical joint and
    # tumbles under gravity: the joint holds and the energy is kept
    modal, _ = lumped_body()
    body = FlexibleBody("cluster", modal, angular_velocity=(1.0, 0.0, 2.0))
    interface = body.nodes([1, 2])
    pivot = modal.node_positions[[1, 2]].mean(axis=0)
    mechanism = Mechanism(gravity=GRAVITY).add(body, Spherical(ground.point(pivot), interface))
    result = simulate(mechanism, np.linspace(0.0, 1.0, 51), rtol=1e-10, atol=1e-12)
    assert not result.failed.any()
    assert result.joint_residual[0] < 1e-10
    assert np.abs(result.modal_coordinates("cluster")).max() > 1e-4  # the interface deforms
    energy = result.energy()[0]
    total = energy.sum(axis=1)
    assert np.ptp(total) < 1e-8 * np.abs(energy).max()


def test_a_spatial_mechanism_is_a_study_model():
    # the strip of the planar comparison as a study model with a fuzzy Young's modulus: a
    # stiffer strip bends less (the quasi-static bending under its own weight goes as 1/E)
    from fuzzymbs.mbs.mechanism_model import MechanismModel

    def build(p):
        beam = PlanarBeam(
            length=1.0,
            youngs_modulus=p["youngs_modulus"],
            density=7800.0,
            area=9e-5,
            second_moment=6.75e-11,
        ).reduce(4)
        body = FlexibleBody(
            "beam", beam.modal_body(), orientation=Rotation.from_euler("z", -np.pi / 6).as_matrix()
        )
        return Mechanism(gravity=GRAVITY).add(body, Revolute(ground.point(), body.node(0)))

    model = MechanismModel(
        build,
        parameters={"youngs_modulus": 2.1e11},
        outputs={
            "first_mode": (lambda r: r.modal_coordinates("beam")[:, :, 0], "m kg^0.5"),
            "energy": (lambda r: r.energy().sum(axis=2), "J"),
        },
        times=np.linspace(0.0, 0.5, 51),
    )
    out = model({"youngs_modulus": np.array([1.0e11, 2.1e11, 4.0e11])})
    assert out["first_mode"].shape == (3, 51) and not out["failed"].any()
    assert list(out["failure_reason"]) == ["", "", ""]
    peaks = np.abs(out["first_mode"]).max(axis=1)
    assert peaks[0] > peaks[1] > peaks[2]
    # no damping: each sample keeps its energy (default tolerances: measured 2.2e-9 J)
    assert np.ptp(out["energy"], axis=1).max() < 1e-7
    with pytest.raises(Exception, match="unknown parameter"):
        model({"youngs": np.array([1.0])})


def test_a_body_free_to_turn_where_it_has_no_inertia_is_refused():
    # a beam from ReducedBeam.modal_body() is a line: no inertia about its own axis. On a
    # ball joint that rotation is free, and the mechanism is refused before it runs, naming it
    beam = PlanarBeam(
        length=0.5, youngs_modulus=7e10, density=2700.0, area=1e-4, second_moment=8e-10
    ).reduce(2)
    body = FlexibleBody("strip", beam.modal_body())
    with pytest.raises(InvalidParameterError, match=r"singular .* mostly in body 'strip'"):
        simulate(
            Mechanism().add(body, Spherical(ground.point(), body.node(0))),
            np.linspace(0.0, 0.1, 3),
        )
    # on a hinge about z that rotation is held: it runs
    hinge = Mechanism(gravity=GRAVITY).add(body, Revolute(ground.point(), body.node(0)))
    assert not simulate(hinge, np.linspace(0.0, 0.1, 3)).failed.any()


def test_marker_acceleration_is_the_rate_of_its_velocity():
    # the tip node of the swinging strip (spatial engine): its reported acceleration and
    # the body's angular acceleration against fourth-order central differences of the
    # velocities on a 0.1 ms grid
    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=6.75e-11
    ).reduce(3)
    body = FlexibleBody(
        "strip", beam.modal_body(), orientation=Rotation.from_euler("z", -np.pi / 6).as_matrix()
    )
    mechanism = Mechanism(gravity=GRAVITY).add(body, Revolute(ground.point(), body.node(0)))
    mechanism.mark("tip", body.nodes("tip"))
    times = np.linspace(0.0, 0.5, 5001)
    result = simulate(mechanism, times, rtol=1e-11, atol=1e-13)
    velocity = result.marker("tip")[0, :, 3:]
    turn = Rotation.from_quat(result.euler_parameters("strip")[0][:, [1, 2, 3, 0]])
    spin = turn.apply(result.angular_velocity("strip")[0])
    acceleration = result.marker_acceleration("tip")[0]
    step = times[1] - times[0]

    def rate(values):
        return (values[:-4] - 8 * values[1:-3] + 8 * values[3:-1] - values[4:]) / (12 * step)

    # measured 1.0e-7 and 5.8e-7 of the largest value (the differences' truncation, h^4)
    linear, angular = (np.abs(acceleration[:, k : k + 3]).max() for k in (0, 3))
    np.testing.assert_allclose(acceleration[2:-2, :3], rate(velocity), atol=2e-6 * linear)
    np.testing.assert_allclose(acceleration[2:-2, 3:], rate(spin), atol=2e-6 * angular)


def test_stiffened_strip_pendulum_matches_the_planar_engine_and_keeps_its_energy():
    # the strip of the comparison above with its foreshortening (ReducedBeam.stiffening()):
    # gravity and the swing stiffen it as in the planar engine (whose pivot sits at the
    # root node, where the foreshortening vanishes, so the two models are the same)
    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=6.75e-11
    ).reduce(4)
    start = -np.pi / 2 + np.pi / 3
    flat = planar.FlexibleBody("beam", beam=beam, angle=start)
    flat_mechanism = planar.Mechanism(gravity=(0.0, -9.81)).add(
        flat, planar.Revolute(planar.ground.point(), flat.node(0))
    )
    body = FlexibleBody(
        "beam",
        beam.modal_body(),
        orientation=Rotation.from_euler("z", start).as_matrix(),
        stiffening=beam.stiffening(),
    )
    mechanism = Mechanism(gravity=GRAVITY).add(body, Revolute(ground.point(), body.node(0)))
    times = np.linspace(0.0, 1.5, 151)
    flat_state = planar.simulate(flat_mechanism, times, rtol=1e-10, atol=1e-12).coordinates("beam")[
        0
    ]
    result = simulate(mechanism, times, rtol=1e-10, atol=1e-12)
    angle = Rotation.from_quat(result.euler_parameters("beam")[0][:, [1, 2, 3, 0]]).as_rotvec()
    modes = result.modal_coordinates("beam")[0]
    # measured 8.5e-12 rad and 1.1e-9 of the modal coordinates; energy 1e-12 J of 3.4 J
    np.testing.assert_allclose(angle[:, 2], flat_state[:, 2], atol=1e-9)
    np.testing.assert_allclose(modes, flat_state[:, 3:], atol=1e-7 * np.abs(modes).max())
    energy = result.energy()[0]
    assert np.ptp(energy.sum(axis=1)) < 1e-10 * np.abs(energy).max()
    # the stiffening matters here: without it the modal coordinates move by nearly their
    # own size (measured 98 % of their largest value)
    loose = FlexibleBody(
        "beam", beam.modal_body(), orientation=Rotation.from_euler("z", start).as_matrix()
    )
    unstiffened = simulate(
        Mechanism(gravity=GRAVITY).add(loose, Revolute(ground.point(), loose.node(0))),
        times,
        rtol=1e-10,
        atol=1e-12,
    ).modal_coordinates("beam")[0]
    assert np.abs(unstiffened - modes).max() > 0.5 * np.abs(modes).max()


def test_spin_up_beam_is_bounded_with_stiffening_and_diverges_without():
    # Kane, Ryan & Banerjee's beam (the registered spin-up-beam's data) spun up to 4 rad/s
    # in 15 s: with its foreshortening it follows the planar engine's beam (validated
    # against a geometrically nonlinear beam, docs/mechanisms.md); without, it diverges
    data = dict(
        length=8.0,
        youngs_modulus=6.8952e10,
        density=2766.7,
        area=7.2968e-5,
        second_moment=8.2189e-9,
    )
    beam = PlanarBeam(elements=16, **data).reduce(6)
    flat = planar.FlexibleBody("beam", beam=beam)
    flat_mechanism = planar.Mechanism().add(
        flat, planar.Revolute(planar.ground.point(), flat.node(0), drive=planar.SpinUp(4.0, 15.0))
    )
    times = np.linspace(0.0, 20.0, 401)
    flat_modes = planar.simulate(flat_mechanism, times).coordinates("beam")[0][:, 3:]

    def spun(stiffening):
        body = FlexibleBody("beam", beam.modal_body(), stiffening=stiffening)
        hub = Revolute(ground.point(), body.node(0), drive=planar.SpinUp(4.0, 15.0))
        return simulate(Mechanism().add(body, hub), times)

    stiffened = spun(beam.stiffening())
    assert not stiffened.failed.any()
    # measured 1.9e-8 of 0.34 (both engines at their default tolerances)
    np.testing.assert_allclose(
        stiffened.modal_coordinates("beam")[0], flat_modes, atol=1e-6 * np.abs(flat_modes).max()
    )
    # without: the modes run away and the run fails (Kane, Ryan & Banerjee's finding for the
    # conventional floating frame)
    assert spun(None).failed.all()


@pytest.mark.parametrize("pull", [-10.0, 10.0], ids=["compressed", "pulled"])
def test_an_axial_tip_load_softens_or_stiffens_the_beam_as_in_the_planar_engine(pull):
    # a clamped strip with a force along its axis at the tip node: the node's foreshortening
    # (GeometricStiffening.nodes) makes compression lower and tension raise the bending
    # frequencies (Euler's buckling load here is pi^2 EI / (4 L^2) = 35 N); the planar
    # engine's beam, a separate code, gives the same linearisation
    from fuzzymbs.mbs.spatial import Fixed, MarkerLoad, linearize

    beam = PlanarBeam(
        length=1.0, youngs_modulus=2.1e11, density=7800.0, area=9e-5, second_moment=6.75e-11
    ).reduce(4)
    flat = planar.FlexibleBody("beam", beam=beam)
    flat_lin = planar.linearize(
        planar.Mechanism().add(
            flat,
            planar.Fixed(planar.ground.point(), flat.node(0)),
            planar.MarkerLoad(flat.tip(), force=(pull, 0.0)),
        )
    )
    body = FlexibleBody("beam", beam.modal_body(), stiffening=beam.stiffening())
    lin = linearize(
        Mechanism().add(
            body, Fixed(ground.point(), body.node(0)), MarkerLoad(body.nodes("tip"), (pull, 0, 0))
        )
    )
    unloaded = beam.frequencies[0]
    first = lin.frequencies()[0]
    assert (first < unloaded) if pull < 0 else (first > unloaded)  # 13.50 or 17.74 vs 15.80
    # measured 3e-15 relative
    np.testing.assert_allclose(lin.frequencies()[:4], flat_lin.frequencies()[:4], rtol=1e-9)
