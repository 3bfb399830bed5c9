"""Reduced brake comparison with Exudyn (optional dependency: ``pip install exudyn``).

What is compared -- a reduced, not the whole, brake: the lower pad of the
brake (the same reduced FE body: 8 free-free modes, 74 kept nodes, 0.194 kg)
translating in y, pressed by 25 nodal forces F_n = 16 kN on its back face, held
by 25 springs k = 200 kN/m in y from the back-face nodes to ground (the caliper
is taken as ground), and in penalty contact (c_p = 1e8 N/m, regularised Coulomb
mu = 0.7, eps = 1e-3 m/s) with the rigid disc face rotating at 1 rad/s about y.
25 slave nodes, single pass. Classic RK4, dt = 1e-6 s, zero initial state.

* fuzzymbs: the same bodies through :mod:`fuzzymbs.mbs` (a RotatingBody disc
  with its modes removed, a TranslatingBody pad, NodalForce, Spring,
  PenaltyContact on the disc's 48-node patch), a batch of samples per call.
* Exudyn: ``ObjectFFRFreducedOrder`` built from the same modal data (identity
  reduced mass, diag(omega^2) stiffness, the kept nodes' mode basis), its rigid
  node (``NodeRigidBodyRxyz``) held to y translation by CoordinateConstraints
  (eliminated by the explicit solver); 25 native ``LoadForceVector`` and 25
  native ``ObjectConnectorCartesianSpringDamper``; the contact as the body's
  ``forceUserFunction`` in Python/NumPy (all 25 nodes vectorised, one call per
  stage) -- how Exudyn lets a user add a custom contact law. RK44, fixed step.

With rotations locked and free-free modes, the FFRF inertia coupling terms
that involve angular velocity or rotation vanish, so they are passed as zeros;
the frame-translation/mode coupling (``mPhitTPsi``) is zero for free-free
modes in both codes. The disc's surface velocity is exact (omega e_y x r) in
the Exudyn callback and bilinearly interpolated from the patch nodes in
fuzzymbs; the y trajectories agree to the figure the benchmark reports.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

DT = 1e-6
PENALTY = 1e8
FRICTION = 0.7
EPS = 1e-3
NODAL_FORCE = 16e3
SPRING = 200e3
SPEED = 1.0


def reduced_bodies() -> tuple[Any, Any]:
    """(rigid disc, lower pad) modal bodies of the default brake design."""
    from fuzzymbs.models.brake import BrakeDesign, build_bodies

    bodies = build_bodies(BrakeDesign())
    disc = bodies.disc
    rigid = dataclasses.replace(
        disc,
        mode_shapes=disc.mode_shapes[:, :, :0],
        frequencies=disc.frequencies[:0],
        translation_coupling=disc.translation_coupling[:, :0],
        rotation_coupling=disc.rotation_coupling[:, :0],
        gyroscopic=disc.gyroscopic[:, :0, :0],
        centrifugal=disc.centrifugal[:, :, :0, :0],
        centrifugal_load=disc.centrifugal_load[:, :, :0],
    )
    return rigid, bodies.lower_pad


def fuzzymbs_system(disc: Any, pad: Any) -> Any:
    """The reduced pad-on-disc system in fuzzymbs (parameters k and F_n per sample)."""
    from fuzzymbs.mbs.bodies import RotatingBody, TranslatingBody
    from fuzzymbs.mbs.contact import PenaltyContact, PolarChart
    from fuzzymbs.mbs.forces import NodalForce, Spring
    from fuzzymbs.mbs.parameters import Parameter
    from fuzzymbs.mbs.system import System

    system = System()
    system.add_body(RotatingBody(disc, "y", speed=SPEED))
    system.add_body(TranslatingBody(pad, ["y"]))
    system.add(NodalForce("press", pad.name, "back", "y", Parameter("nodal_force", NODAL_FORCE)))
    system.add(
        Spring(
            "pad_ground",
            pad.name,
            "back",
            stiffness=Parameter("pad_spring_stiffness", SPRING),
            direction="y",
        )
    )
    system.add(
        PenaltyContact(
            "pad->disc",
            pad.name,
            "contact",
            disc.name,
            "patch_lower",
            PolarChart("y", "x"),
            normal="-y",
            penalty=PENALTY,
            friction=FRICTION,
            regularization_velocity=EPS,
        )
    )
    return system


def run_fuzzymbs(steps: int, batch: int, record_every: int = 5) -> tuple[np.ndarray, float]:
    """y of the pad frame (T,) of the first sample, and the best wall time of the batch [s]."""
    from bench_common import best_time

    from fuzzymbs.mbs.integrate import simulate
    from fuzzymbs.mbs.system import Coordinate

    disc, pad = reduced_bodies()
    compiled = fuzzymbs_system(disc, pad).compile()
    samples = {"nodal_force": np.full(batch, NODAL_FORCE)}
    outputs = {"y_pad": Coordinate(pad.name, 0)}

    def once() -> Any:
        return simulate(
            compiled,
            samples,
            t_end=steps * DT,
            dt=DT,
            outputs=outputs,
            record_interval=record_every * DT,
            chunk_size=batch,
        )

    result = once()  # compile or load
    seconds = best_time(once, repeat=3)
    if result.failed.any():
        raise RuntimeError(f"reduced fuzzymbs run failed: {result.failure_reason[0]}")
    return result.outputs["y_pad"][0], seconds


def _matrix(exu: Any, dense: np.ndarray) -> Any:
    container = exu.MatrixContainer()
    container.SetWithDenseMatrix(dense, useDenseMatrix=False)
    return container


def run_exudyn(steps: int, record_every: int = 5) -> tuple[np.ndarray, float]:
    """y of the pad frame (T,) and the wall time of SolveDynamic [s] (one sample)."""
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        LoadForceVector,
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        MarkerSuperElementPosition,
        NodeGenericODE2,
        NodePointGround,
        NodeRigidBodyRxyz,
        ObjectConnectorCartesianSpringDamper,
        ObjectFFRFreducedOrder,
        ObjectGround,
        SensorNode,
    )

    _, pad = reduced_bodies()
    n_modes = pad.n_modes
    xbar = pad.node_positions
    psi = pad.mode_shapes.transpose(0, 1, 2).reshape(-1, n_modes)  # (3 nodes, modes)
    contact = pad.node_sets["contact"]
    back = pad.node_sets["back"]
    psi_contact = pad.mode_shapes[contact]  # (25, 3, r)
    normal = np.array([0.0, -1.0, 0.0])  # disc face normal towards the lower pad

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    # frame at the centre of mass: no translation-rotation mass coupling, so locking the
    # rotations (constraint elimination in the explicit solver) leaves the y equation exact
    centre = pad.first_moment / pad.mass
    rigid = mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[*centre, 0.0, 0.0, 0.0]))
    modal = mbs.AddNode(
        NodeGenericODE2(
            numberOfODE2Coordinates=n_modes,
            referenceCoordinates=[0.0] * n_modes,
            initialCoordinates=[0.0] * n_modes,
            initialCoordinates_t=[0.0] * n_modes,
        )
    )

    def contact_force(mbs_: Any, t: float, item: int, q: Any, q_t: Any) -> np.ndarray:
        q = np.asarray(q)
        q_t = np.asarray(q_t)
        s, sdot = q[1], q_t[1]
        u = psi_contact @ q[6:]  # (25, 3) elastic displacement (rotations locked)
        udot = psi_contact @ q_t[6:]
        pos = xbar[contact] + u
        pos[:, 1] += s
        vel = udot
        vel[:, 1] += sdot
        gap = -(pos[:, 1])  # disc face at y = 0, pad below
        force = np.zeros_like(pos)
        touching = gap < 0.0
        if touching.any():
            p = pos[touching]
            surface = SPEED * np.stack([p[:, 2], np.zeros(len(p)), -p[:, 0]], axis=1)
            vr = vel[touching] - surface
            vn = vr @ normal
            fn = -PENALTY * gap[touching]
            vt = vr - vn[:, None] * normal
            scale = -FRICTION * fn / np.sqrt(np.einsum("ij,ij->i", vt, vt) + EPS * EPS)
            force[touching] = fn[:, None] * normal + scale[:, None] * vt
        generalised = np.zeros(6 + n_modes)
        generalised[0:3] = force.sum(axis=0)
        generalised[6:] = np.einsum("kcr,kc->r", psi_contact, force)
        return generalised

    body = mbs.AddObject(
        ObjectFFRFreducedOrder(
            nodeNumbers=[rigid, modal],
            massMatrixReduced=_matrix(exu, np.eye(n_modes)),
            stiffnessMatrixReduced=_matrix(exu, np.diag(pad.frequencies**2)),
            modeBasis=psi,
            referencePositions=(xbar - centre).reshape(-1),
            mass=pad.mass,
            inertia=np.eye(3) * 1e-3,  # rotations locked: any positive inertia
            centerOfMass=[0.0, 0.0, 0.0],
            # rotation-related inertia integrals: inactive with the rotations locked
            mPsiTildePsi=np.zeros((3 * n_modes, n_modes)),
            mPsiTildePsiTilde=np.zeros((3 * n_modes, 3 * n_modes)),
            mPhitTPsi=np.zeros((3, n_modes)),  # Phi_t^T M Psi = 0 for free-free modes
            mPhitTPsiTilde=np.zeros((3, 3 * n_modes)),
            mXRefTildePsi=np.zeros((3, n_modes)),
            mXRefTildePsiTilde=np.zeros((3, 3 * n_modes)),
            computeFFRFterms=True,
            forceUserFunction=contact_force,
        )
    )
    ground = mbs.AddObject(ObjectGround())
    ground_node = mbs.AddNode(NodePointGround())
    ground_marker = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    for coordinate in (0, 2, 3, 4, 5):  # only the y translation stays free
        marker = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=rigid, coordinate=coordinate))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_marker, marker]))
    for node in back:
        marker = mbs.AddMarker(
            MarkerSuperElementPosition(
                bodyNumber=body, meshNodeNumbers=[node], weightingFactors=[1.0]
            )
        )
        anchor = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=xbar[node]))
        mbs.AddObject(
            ObjectConnectorCartesianSpringDamper(
                markerNumbers=[anchor, marker],
                stiffness=[0.0, SPRING, 0.0],
                damping=[0.0, 0.0, 0.0],
            )
        )
        mbs.AddLoad(LoadForceVector(markerNumber=marker, loadVector=[0.0, NODAL_FORCE, 0.0]))
    sensor = mbs.AddSensor(
        SensorNode(
            nodeNumber=rigid,
            storeInternal=True,
            outputVariableType=exu.OutputVariableType.Displacement,
        )
    )
    mbs.Assemble()

    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = steps * DT
    ti.solverType = exu.DynamicSolverType.RK44
    ti.explicit.eliminateConstraints = True
    ti.explicit.computeEndOfStepAccelerations = False
    ti.verboseMode = 0
    settings.solution.file.write = False  # Exudyn >= 1.12 names
    settings.solution.sensors.writePeriod = record_every * DT
    settings.show.computationTime = False
    settings.show.statistics = False
    start = time.perf_counter()
    mbs.SolveDynamic(settings)
    seconds = time.perf_counter() - start
    data = mbs.GetSensorStoredData(sensor)  # columns t, x, y, z
    return np.asarray(data)[:, 2], seconds


def run(steps: int = 200, batch: int = 33) -> dict[str, Any]:
    """Per-sample-step cost of both codes on the reduced system and their agreement."""
    from bench_common import log

    y_ref, fuzzy_seconds = run_fuzzymbs(steps, batch)
    y_exu, exu_seconds = run_exudyn(steps)
    count = min(len(y_ref), len(y_exu))
    diff = float(np.max(np.abs(y_ref[:count] - y_exu[:count])))
    scale = float(np.max(np.abs(y_ref)))
    fuzzy_per = fuzzy_seconds / (batch * steps)
    exu_per = exu_seconds / steps
    log(
        f"exudyn: {exu_per * 1e6:.1f} us/step (1 sample), fuzzymbs {fuzzy_per * 1e6:.2f} "
        f"us/sample-step (batch {batch}); max |dy| {diff:.2e} m of {scale:.2e} m"
    )
    return {
        "steps": steps,
        "batch": batch,
        "exudyn_seconds_per_sample_step": exu_per,
        "fuzzymbs_seconds_per_sample_step": fuzzy_per,
        "speedup": exu_per / fuzzy_per,
        "max_abs_diff_m": diff,
        "max_rel_diff": diff / scale,
        "records_compared": count,
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run()))
