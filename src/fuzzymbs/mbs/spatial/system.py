"""A spatial mechanism of rigid and flexible bodies: building, checks, packing, simulation.

Build it as the planar one (:mod:`fuzzymbs.mbs.planar.system`)::

    from fuzzymbs.mbs.spatial import Mechanism, RigidBody, Spherical, ground, simulate

    bob = RigidBody("bob", mass=1.0, inertia=(1e-3, 1e-3, 1e-3), position=(0.5, 0.0, -0.8))
    pendulum = Mechanism(gravity=(0.0, 0.0, -9.81))
    pendulum.add(bob, Spherical(ground.point(), bob.point((-0.5, 0.0, 0.8))))
    result = simulate(pendulum, np.linspace(0.0, 2.0, 201))
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.assembly import PROJECTION_TOLERANCE, Assembly
from fuzzymbs.mbs.kernels.threads import for_each_range
from fuzzymbs.mbs.planar.kernels import no_user_force
from fuzzymbs.mbs.planar.linearization import (
    ReducedRate,
    free_directions,
    projected_state,
    reduced_rate_function,
)
from fuzzymbs.mbs.planar.simulation import DEFAULT_METHOD, describe_failure, integrator_method
from fuzzymbs.mbs.planar.step_sequences import replay_arrays, run_logging
from fuzzymbs.mbs.spatial import elements, integrator, kernels, kinematics, readout
from fuzzymbs.mbs.spatial.bodies import Body, Marker
from fuzzymbs.mbs.spatial.forces import ForceElement
from fuzzymbs.mbs.spatial.joints import Joint

START_TOLERANCE = 1e-9
DEFAULT_RTOL = 1e-6
DEFAULT_ATOL = 1e-8
#: Smallest eigenvalue of the mass matrix on the joints' free directions, relative to the
#: largest, below which a mechanism is refused as singular (a small inertia, such as a
#: point-like bob's spin, 1e-6 of the pendulum's, integrates well; zero does not).
SINGULAR_MASS = 1e-12


class Mechanism(Assembly):
    """Spatial rigid and flexible bodies, joints and force elements, with gravity [m/s^2]."""

    engine = "spatial"
    dimension = 3
    marker_type = Marker
    bodies: list[Body]
    joints: list[Joint]
    forces: list[ForceElement]
    named_markers: dict[str, Marker]

    def __init__(self, gravity: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        super().__init__(gravity)

    def user_function(self) -> object:
        """The one user force function of the mechanism's UserForce elements (a no-op
        without them)."""
        functions = {
            id(f.function): f.function for f in self.forces if f.kind == elements.USER_FORCE
        }
        if len(functions) > 1:
            raise InvalidParameterError(
                "a Mechanism runs one user force function; dispatch on the element index inside it "
                f"(got {len(functions)} functions)"
            )
        return next(iter(functions.values()), no_user_force)

    def pack(self) -> tuple[tuple, NDArray[np.float64], NDArray[np.float64]]:
        """(layout arrays, data row, initial state (q, v))."""
        if not self.bodies:
            raise InvalidParameterError("a Mechanism needs at least one body")
        data: list[float] = [*self.gravity]
        bodies, qs, vs = [], [], []
        nq = n = 0
        for b in self.bodies:
            bodies.append([nq, n, len(data), b.mode_count, b.stiffening_code])
            data.extend(b.pack())
            q, v = b.initial_state()
            qs.append(q)
            vs.append(v)
            nq += q.size
            n += v.size
        markers = self.markers()
        marker_rows = []
        for m in markers:
            if m.body is not None and not any(m.body is b for b in self.bodies):
                raise InvalidParameterError(
                    f"marker {m.name} is on body {m.body.name!r}, which was not added"
                )
            body = (
                -1 if m.body is None else next(i for i, b in enumerate(self.bodies) if b is m.body)
            )
            marker_rows.append([body, len(data)])
            data.extend(m.pack())
        index = {id(m): i for i, m in enumerate(markers)}
        joints, row = [], 0
        for j in self.joints:
            joints.append(
                [j.kind, index[id(j.marker_i)], index[id(j.marker_j)], row, len(data), j.drive_code]
            )
            data.extend(j.pack())
            row += j.rows
        state = np.concatenate([*qs, *vs])
        marker_array = np.array(marker_rows, dtype=np.int64).reshape(-1, 2)
        body_array = np.array(bodies, dtype=np.int64).reshape(-1, 5)
        positions = self._marker_positions(body_array, marker_array, np.array(data), state, nq)
        # each marker's axes at the start (they follow their body's frame)
        axes = [m.axes if m.body is None else m.body.orientation @ m.axes for m in markers]
        forces = []
        for f in self.forces:
            i = index[id(f.marker_i)]
            k = index[id(f.marker_j)] if f.marker_j is not None else -1
            start_j = (positions[k], axes[k]) if k >= 0 else (np.zeros(3), np.eye(3))
            forces.append([f.kind, i, k, len(data), f.profile_code])
            data.extend(f.pack((positions[i], axes[i]), start_j))
        layout = (
            body_array,
            marker_array,
            np.array(joints, dtype=np.int64).reshape(-1, 6),
            np.array(forces, dtype=np.int64).reshape(-1, 5),
            np.array([nq, n, row], dtype=np.int64),
        )
        return layout, np.array(data, dtype=float), state

    def reduced_system(
        self, t: float, state: ArrayLike | None, step: float
    ) -> tuple[ReducedRate, NDArray[np.float64], float]:
        """What :func:`~fuzzymbs.mbs.planar.linearization.central_linearization` takes:
        the reduced rate (positions moved in velocity coordinates), the joints' free
        directions in the velocities (r', w, q') and the step."""
        self.check(t)
        layout, data, initial = self.pack()
        nq, n, c = (int(s) for s in layout[4])
        order = "positions then velocities"
        x0 = projected_state(kernels, t, state, initial, nq, layout, data, order)
        jac = np.zeros((c, n))
        if c:
            spare = [np.empty(c) for _ in range(4)]
            kernels.joint_terms(t, layout, data, x0[:nq], x0[nq:], jac, *spare)
        basis = free_directions(jac, n)
        user = self.user_function()

        def move(positions: NDArray[np.float64], position: NDArray[np.float64]) -> None:
            kinematics.displace(positions, layout[0], position)

        rate = reduced_rate_function(kernels, t, x0, nq, layout, data, user, basis, c, move)
        return rate, basis, step

    @staticmethod
    def _marker_positions(bodies, markers, data, state, nq) -> NDArray[np.float64]:
        out = np.empty((1, 1, markers.shape[0], 6))
        layout = (
            bodies,
            markers,
            np.zeros((0, 6), np.int64),
            np.zeros((0, 5), np.int64),
            np.array([nq, 0, 0]),
        )
        readout.markers_at(
            np.arange(markers.shape[0], dtype=np.int64), state[None, None], layout, data[None], out
        )
        return out[0, 0, :, :3]

    def check(self, t0: float = 0.0) -> None:
        """Refuse, naming the element: joints violated at the start, redundant joints, a
        mass matrix singular on the motion the joints allow."""
        layout, data, state = self.pack()
        nq, n, c = (int(s) for s in layout[4])
        q, v = state[:nq].copy(), state[nq:].copy()
        jac = np.zeros((c, n))
        if c:
            residual = np.empty(c)
            spare = [np.empty(c) for _ in range(3)]
            kernels.joint_terms(t0, layout, data, q, v, jac, residual, *spare)
            row = 0
            scale = 1e-9 * max(1.0, np.abs(jac).max())
            for j in self.joints:
                worst = np.abs(residual[row : row + j.rows]).max()
                if worst > START_TOLERANCE:
                    raise InvalidParameterError(
                        f"joint {j.label()} is violated at the start by {worst:.3g} (m or rad): "
                        "place the bodies so its markers meet and its axes line up"
                    )
                if np.linalg.matrix_rank(jac[: row + j.rows], tol=scale) < row + j.rows:
                    raise InvalidParameterError(
                        f"joint {j.label()} is redundant with the joints before it"
                    )
                row += j.rows
        mass = np.zeros((n, n))
        kernels.body_terms(layout[0], data, q, v, mass, np.zeros(n))
        free = free_directions(jac, n)
        values = np.linalg.eigvalsh(free.T @ mass @ free) if free.size else np.ones(1)
        if values[0] <= SINGULAR_MASS * values[-1]:
            weakest = free @ np.linalg.eigh(free.T @ mass @ free)[1][:, 0]
            body = self.bodies[
                int(np.searchsorted(layout[0][:, 1], np.argmax(np.abs(weakest)), "right")) - 1
            ]
            raise InvalidParameterError(
                f"the mass matrix is singular on the motion the joints allow (smallest/largest "
                f"eigenvalue {values[0] / values[-1]:.2g}), mostly in body {body.name!r}: a "
                "body without mass or inertia in a direction it may move (a beam from "
                "ReducedBeam.modal_body() has none about its own axis: hold that rotation)"
            )


@dataclass(frozen=True)
class SpatialResult:
    """States (B, T, 7 nb + 6 nb) at the output times, and how each run ended
    (``step_logs`` as :class:`fuzzymbs.mbs.planar.PlanarResult` holds them)."""

    times: NDArray[np.float64]
    states: NDArray[np.float64]
    status: NDArray[np.int64]
    accepted: NDArray[np.int64]
    joint_residual: NDArray[np.float64]
    layout: tuple
    data: NDArray[np.float64]
    template: Mechanism
    user_force: object
    step_logs: tuple[NDArray[np.float64], ...] | None = None

    @property
    def failed(self) -> NDArray[np.bool_]:
        return self.status != kernels.FINISHED

    def failure(self, sample: int) -> str | None:
        """Why sample ``sample`` failed and when, or None."""
        return describe_failure(self.status[sample], self.states[sample], self.times)

    def _offsets(self, body: str) -> tuple[int, int, int]:
        """(position offset, velocity offset (after the positions), mode count) of a body."""
        i = self.template.bodies.index(self.template.body(body))
        row = self.layout[0][i]
        return int(row[0]), int(self.layout[4][0] + row[1]), int(row[3])

    def position(self, body: str) -> NDArray[np.float64]:
        """(B, T, 3) frame origin [m] (a rigid body's centre of mass)."""
        po, _, _ = self._offsets(body)
        return self.states[:, :, po : po + 3]

    def euler_parameters(self, body: str) -> NDArray[np.float64]:
        """(B, T, 4) unit quaternion of the body's orientation."""
        po, _, _ = self._offsets(body)
        return self.states[:, :, po + 3 : po + 7]

    def modal_coordinates(self, body: str) -> NDArray[np.float64]:
        """(B, T, r) modal coordinates of a flexible body (r = 0 for a rigid one)."""
        po, _, r = self._offsets(body)
        return self.states[:, :, po + 7 : po + 7 + r]

    def angular_velocity(self, body: str) -> NDArray[np.float64]:
        """(B, T, 3) angular velocity in the body frame [rad/s]."""
        _, vo, _ = self._offsets(body)
        return self.states[:, :, vo + 3 : vo + 6]

    def velocity(self, body: str) -> NDArray[np.float64]:
        """(B, T, 3) velocity of the frame origin [m/s]."""
        _, vo, _ = self._offsets(body)
        return self.states[:, :, vo : vo + 3]

    def element_force(self, element: str) -> NDArray[np.float64]:
        """(B, T, 6): the force [N] and torque [N m] a force element applies to its marker
        i, global; marker j's body takes the opposite (for a contact, at the contact
        point). ``element`` is its name or label (``Mechanism.force``)."""
        index = self.template.forces.index(self.template.force(element))
        out = np.empty((*self.states.shape[:2], 6))
        readout.element_forces_at(
            index, self.times, self.states, self.layout, self.data, self.user_force, out
        )
        return out

    def solved(self) -> NDArray[np.float64]:
        """(B, T, n + c): the accelerations (r'', w', q'' per body) and the joints'
        multipliers at every stored state (read-only; solved once per result and kept)."""
        return self._solution

    @cached_property
    def _solution(self) -> NDArray[np.float64]:
        n, c = int(self.layout[4][1]), int(self.layout[4][2])
        out = np.empty((*self.states.shape[:2], n + c))

        def run(start: int, stop: int) -> None:
            integrator.solve_range(
                start, stop, self.times, self.states, self.layout, self.data, self.user_force, out
            )

        for_each_range(self.states.shape[0], run)
        out.flags.writeable = False
        return out

    def reaction(self, joint: str) -> NDArray[np.float64]:
        """(B, T, rows): the joint's multipliers, rows in its equations' order.

        For the joints whose first three equations make the points meet (spherical,
        revolute, universal, fixed), rows 0 to 2 are the force [N] the joint applies to
        marker j's body at its point, global (marker i's body takes the opposite). The
        other rows belong to the orientation equations (each a torque [N m] about the
        normal of the two axes it holds perpendicular), the drive (the torque about the
        axis) and, for cylindrical and prismatic joints, to marker j's point held on marker
        i's axis (rows 0 and 1: minus the force on marker j along marker i's x and y axes).
        """
        wanted = self.template.joint(joint)
        row = 0
        for j in self.template.joints:
            if j is wanted:
                break
            row += j.rows
        n = int(self.layout[4][1])
        return self.solved()[:, :, n + row : n + row + wanted.rows]

    def energy(self) -> NDArray[np.float64]:
        """(B, T, 3): kinetic, gravitational and elastic (modes and springs) energy [J]."""
        out = np.empty((*self.states.shape[:2], 3))
        readout.energy_at(self.states, self.layout, self.data, out)
        return out

    def _marker_index(self, name: str) -> int:
        if name not in self.template.named_markers:
            raise InvalidParameterError(
                f"no marker named {name!r}; named: {sorted(self.template.named_markers)}"
            )
        markers = self.template.markers()
        return next(i for i, m in enumerate(markers) if m is self.template.named_markers[name])

    def marker_acceleration(self, name: str) -> NDArray[np.float64]:
        """(B, T, 6): a named marker's acceleration [m/s^2] and its body's angular
        acceleration [rad/s^2], global (a point on a flexible body with its node's motion)."""
        index = self._marker_index(name)
        out = np.empty((*self.states.shape[:2], 6))
        readout.marker_accelerations_at(
            index, self.states, self.solved(), self.layout, self.data, out
        )
        return out

    def marker(self, name: str) -> NDArray[np.float64]:
        """(B, T, 6): position and velocity of a named marker."""
        index = self._marker_index(name)
        out = np.empty((*self.states.shape[:2], 1, 6))
        readout.markers_at(
            np.array([index], dtype=np.int64), self.states, self.layout, self.data, out
        )
        return out[:, :, 0]


def simulate(
    mechanisms: Mechanism | list[Mechanism],
    times: ArrayLike,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    max_steps: int = 10_000_000,
    method: str = DEFAULT_METHOD,
    log_steps: bool = False,
    step_sequences: Sequence[ArrayLike] | None = None,
) -> SpatialResult:
    """Integrate one spatial mechanism or a batch of one structure over ``times``
    (``method``, ``log_steps`` and ``step_sequences`` as :func:`fuzzymbs.mbs.planar.simulate`
    takes them)."""
    batch = mechanisms if isinstance(mechanisms, list) else [mechanisms]
    rows, states, layout = [], [], None
    for i, mechanism in enumerate(batch):
        mechanism.check()
        lay, data, state = mechanism.pack()
        if layout is None:
            layout = lay
        elif (
            not all(np.array_equal(a, b) for a, b in zip(lay, layout, strict=True))
            or data.size != rows[0].size
        ):
            raise InvalidParameterError(
                f"sample {i}'s mechanism has another structure than sample 0's"
            )
        rows.append(data)
        states.append(state)
    user = batch[0].user_function()
    if any(m.user_function() is not user for m in batch[1:]):
        raise InvalidParameterError(
            "every sample's mechanism must use the same user force function"
        )
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.isfinite(t).all() or np.any(np.diff(t) <= 0):
        raise InvalidParameterError(
            "times must be at least two finite, strictly increasing values [s]"
        )
    data = np.stack(rows)
    initial = np.stack(states)
    out = np.full((len(batch), t.size, initial.shape[1]), np.nan)
    replay = replay_arrays(step_sequences, len(batch), t)
    step = (t[-1] - t[0]) * 1e-3
    code = integrator_method(method, bool(np.any(layout[0][:, 3] > 0)))
    control = (code, float(rtol), float(atol), step, int(max_steps), PROJECTION_TOLERANCE)

    def run_batch(steps):
        report = np.zeros((len(batch), 4))

        def run(start: int, stop: int) -> None:
            integrator.integrate_range(
                start, stop, t, initial, layout, data, user, control, out, report, steps
            )

        for_each_range(len(batch), run)
        return report

    report, logs = run_logging(run_batch, replay, len(batch), log_steps)
    return SpatialResult(
        t,
        out,
        report[:, 0].astype(np.int64),
        report[:, 1].astype(np.int64),
        report[:, 3],
        layout,
        data,
        batch[0],
        user,
        logs,
    )
