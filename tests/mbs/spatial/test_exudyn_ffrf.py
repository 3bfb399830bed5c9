"""Spatial flexible bodies against a second code: Exudyn's ObjectFFRFreducedOrder.

The same body -- the six point masses on springs with 12 modes of
``test_flexible.lumped_body`` -- goes to Exudyn as FE data (its mass and stiffness
matrices and the mode basis), from which Exudyn's ``ObjectFFRFreducedOrderInterface``
computes its own inertia integrals; Exudyn then integrates its floating-frame equations
(rotation vector node, classic RK4 at a fixed step of 10 us). fuzzymbs takes the
``ModalBody`` integrals and integrates with Dormand-Prince at rtol 1e-11. The body tumbles
freely, spinning about all three axes with its modes excited, for 0.5 s.

Without gravity: Exudyn's gravity on this object (``AddObjectFFRFreducedOrder(gravity=...)``)
changes the modal motion of a freely falling body by 7.5e-3 (of 0.065) and its frame's path
by 4.7e-3 m beyond g t^2 / 2, where uniform gravity must leave the motion relative to the
falling frame as it is; fuzzymbs keeps it to 3e-14 (``test_flexible.py``;
``python benchmarks/exudyn_ffrf_gravity.py`` measures both).
"""

import numpy as np
import pytest
import scipy.sparse

from fuzzymbs.mbs.spatial import FlexibleBody, Mechanism, simulate

from .test_flexible import lumped_body

exu = pytest.importorskip("exudyn")

# slow: the spatial kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow


def exudyn_tumbling(
    modal, mass, stiffness, velocity, angular_velocity, coordinates, times, steps, gravity=None
):
    """Frame origin (T, 3) and modal coordinates (T, r) from Exudyn, given the FE mass and
    stiffness matrices over the ModalBody's nodes (3 per node); ``gravity`` goes to Exudyn's
    own option (``benchmarks/exudyn_ffrf_gravity.py``)."""
    from exudyn.FEM import FEMinterface, ObjectFFRFreducedOrderInterface
    from exudyn.itemInterface import SensorNode

    r = modal.n_modes
    psi = modal.mode_shapes.reshape(-1, r)
    fem = FEMinterface()
    fem.nodes = {"Position": modal.node_positions.copy()}
    fem.massMatrix = scipy.sparse.csr_matrix(mass)
    fem.stiffnessMatrix = scipy.sparse.csr_matrix(stiffness)
    fem.modeBasis = {"matrix": psi, "type": "NormalModes"}
    fem.surface = []
    body = ObjectFFRFreducedOrderInterface(fem, rigidBodyNodeType="NodeType.RotationRotationVector")
    system = exu.SystemContainer()
    mbs = system.AddSystem()
    items = body.AddObjectFFRFreducedOrder(
        mbs,
        positionRef=[0.0, 0.0, 0.0],
        initialVelocity=list(velocity),
        initialAngularVelocity=list(angular_velocity),
        **({} if gravity is None else {"gravity": list(gravity)}),
    )
    mbs.SetNodeParameter(items["nGenericODE2"], "initialCoordinates", list(coordinates))
    sensors = [
        mbs.AddSensor(
            SensorNode(nodeNumber=items[node], storeInternal=True, outputVariableType=output)
        )
        for node, output in (
            ("nRigidBody", exu.OutputVariableType.Position),
            ("nGenericODE2", exu.OutputVariableType.Coordinates),
        )
    ]
    mbs.Assemble()
    settings = exu.SimulationSettings()
    settings.timeIntegration.endTime = float(times[-1])
    settings.timeIntegration.numberOfSteps = steps
    settings.timeIntegration.adaptiveStep = False
    settings.timeIntegration.verboseMode = 0
    settings.solution.sensors.writePeriod = float(times[1] - times[0])
    settings.solution.file.write = False
    mbs.SolveDynamic(settings, solverType=exu.DynamicSolverType.RK44)
    origin, modes = (np.asarray(mbs.GetSensorStoredData(s))[:, 1:] for s in sensors)
    return origin, modes


def test_tumbling_flexible_body_agrees_with_exudyns_ffrf_body():
    modal, masses = lumped_body()
    rng = np.random.default_rng(3)
    coordinates = 0.01 * rng.standard_normal(modal.n_modes)
    velocity, angular_velocity = (0.3, -0.2, 0.1), (2.0, 5.0, -3.0)
    times = np.linspace(0.0, 0.5, 51)
    body = FlexibleBody(
        "cluster",
        modal,
        velocity=velocity,
        angular_velocity=angular_velocity,
        coordinates=coordinates,
    )
    ours = simulate(Mechanism().add(body), times, rtol=1e-11, atol=1e-13)
    assert not ours.failed.any()
    mass = np.diag(np.repeat(masses, 3))
    psi = modal.mode_shapes.reshape(-1, modal.n_modes)
    # a stiffness matrix with exactly these modes and frequencies on the mode basis
    stiffness = mass @ psi @ np.diag(modal.frequencies**2) @ psi.T @ mass
    origin, modes = exudyn_tumbling(
        modal, mass, stiffness, velocity, angular_velocity, coordinates, times, steps=50_000
    )
    assert np.abs(modes).max() > 0.01  # the modes are excited by the spin
    # measured 3.4e-12 m and 1.4e-12 (Exudyn's RK4 at 10 us; at 100 us: 9e-11 and 2.4e-10)
    np.testing.assert_allclose(origin, ours.position("cluster")[0], atol=1e-9)
    np.testing.assert_allclose(modes, ours.modal_coordinates("cluster")[0], atol=1e-9)


def test_fe_reduced_bar_agrees_with_exudyn_on_the_same_fe_matrices():
    # a steel bar of 8 x 2 x 1 hexahedra (54 nodes) clamped at x = 0 for its modes, reduced
    # to 4 by fuzzymbs.fe (consistent mass: the ModalBody's integrals from fuzzymbs.fe), and
    # Exudyn given the same mass and stiffness matrices and mode basis; the bar tumbles
    # freely for 20 ms with its modes excited (the 4th at 10 krad/s)
    from fuzzymbs.fe.elastic_body import ElasticBody
    from fuzzymbs.fe.meshes import box_mesh

    bar = ElasticBody(
        box_mesh(0.4, 0.04, 0.02, 8, 2, 1, order=1),
        youngs_modulus=2.1e11,
        poisson_ratio=0.3,
        density=7800.0,
        fixed=lambda x: x[0] < 1e-9,
    )
    modal = bar.reduce(4, cache=False)
    assert modal.n_nodes == bar.n_nodes  # no node sets: every node kept, the full basis
    coordinates = 1e-4 * np.random.default_rng(1).standard_normal(4)
    velocity, angular_velocity = (0.3, -0.2, 0.1), (2.0, 5.0, -3.0)
    times = np.linspace(0.0, 0.02, 51)
    body = FlexibleBody(
        "bar", modal, velocity=velocity, angular_velocity=angular_velocity, coordinates=coordinates
    )
    ours = simulate(Mechanism().add(body), times, rtol=1e-10, atol=1e-13)
    assert not ours.failed.any()
    origin, modes = exudyn_tumbling(
        modal,
        bar.mass_matrix.toarray(),
        bar.stiffness.toarray(),
        velocity,
        angular_velocity,
        coordinates,
        times,
        steps=40_000,
    )
    # measured 1.4e-11 m and 8.9e-11 (of 1.8e-4) with Exudyn's RK4 at 0.5 us; the gap
    # falls as its step^4 (9.4e-8, 5.9e-9, 3.7e-10 at 2, 1, 0.5 us over 0.1 s)
    np.testing.assert_allclose(origin, ours.position("bar")[0], atol=1e-9)
    np.testing.assert_allclose(modes, ours.modal_coordinates("bar")[0], atol=1e-9)
