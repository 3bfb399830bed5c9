"""A planar mechanism: bodies, joints and forces, packed for the batched kernels.

Build one in a few lines per element::

    from fuzzymbs.mbs.planar import Mechanism, RigidBody, Revolute, ground

    rod = RigidBody("rod", mass=1.0, inertia=1 / 12, center=(0.5, 0.0), angle=-1.0)
    pendulum = Mechanism(gravity=(0.0, -9.81))
    pendulum.add(rod, Revolute(ground.point(), rod.point()))

Samples of a fuzzy study are mechanisms of the same structure with other
numbers: :func:`pack_batch` checks the structure is shared and stacks each
sample's numbers into one row of the kernels' ``data``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.assembly import Assembly
from fuzzymbs.mbs.planar import kernels, readout
from fuzzymbs.mbs.planar.bodies import Body, Marker
from fuzzymbs.mbs.planar.forces import (
    ForceElement,
)
from fuzzymbs.mbs.planar.joints import Joint
from fuzzymbs.mbs.planar.linearization import (
    ReducedRate,
    free_directions,
    projected_state,
    reduced_rate_function,
)

#: Largest joint residual [m or rad] a mechanism may start with (its markers must meet).
START_TOLERANCE = 1e-9
#: Smallest ratio of the smallest to the largest eigenvalue of the mass matrix on the
#: joints' free directions: below it the modes of a flexible body nearly reproduce its
#: frame's motion (clamped modes of a pinned beam: 1.2e-5 at 8 modes, 3.7e-6 at 12;
#: docs/mechanisms.md), and the equations are too ill-conditioned to integrate.
MASS_CONDITION = 1e-5


@dataclass(frozen=True)
class Layout:
    """Where each element's numbers and coordinates are, as the kernels read them."""

    bodies: NDArray[np.int64]
    markers: NDArray[np.int64]
    joints: NDArray[np.int64]
    forces: NDArray[np.int64]
    sizes: NDArray[np.int64]

    def arrays(self) -> tuple:
        return (self.bodies, self.markers, self.joints, self.forces, self.sizes)

    def same_as(self, other: Layout) -> bool:
        return all(np.array_equal(a, b) for a, b in zip(self.arrays(), other.arrays(), strict=True))


class Mechanism(Assembly):
    """Bodies, joints and force elements in the plane, with gravity.

    Parameters
    ----------
    gravity : (2,)
        Acceleration of gravity in the inertial frame [m/s^2].
    """

    engine = "planar"
    dimension = 2
    marker_type = Marker
    bodies: list[Body]
    joints: list[Joint]
    forces: list[ForceElement]
    named_markers: dict[str, Marker]

    def __init__(self, gravity: ArrayLike = (0.0, 0.0)) -> None:
        super().__init__(gravity)

    def coordinate_offsets(self) -> dict[str, int]:
        """First coordinate (x) of each body in the state vector."""
        offsets = {}
        at = 0
        for b in self.bodies:
            offsets[b.name] = at
            at += 3 + b.mode_count
        return offsets

    def coordinate_count(self) -> int:
        return sum(3 + b.mode_count for b in self.bodies)

    def equation_count(self) -> int:
        return sum(j.equations for j in self.joints)

    def user_function(self) -> object:
        functions = {
            id(f.function): f.function for f in self.forces if f.kind == kernels.USER_FORCE
        }
        if len(functions) > 1:
            raise InvalidParameterError(
                "a Mechanism runs one user force function; dispatch on the element index inside it "
                f"(got {len(functions)} functions)"
            )
        return next(iter(functions.values()), kernels.no_user_force)

    def reduced_system(
        self, t: float, state: ArrayLike | None, step: float
    ) -> tuple[ReducedRate, NDArray[np.float64], float]:
        """What :func:`~fuzzymbs.mbs.planar.linearization.central_linearization` takes:
        the reduced rate, the joints' free directions and the step (``step`` times the
        state's largest magnitude)."""
        layout, data, initial = self.pack()
        arrays = layout.arrays()
        n, c = (int(s) for s in layout.sizes)
        x0 = projected_state(kernels, t, state, initial, n, arrays, data, "z then v")
        _, jac = joint_rows(t, layout, data, x0)
        basis = free_directions(jac, n)
        user = self.user_function()
        rate = reduced_rate_function(kernels, t, x0, n, arrays, data, user, basis, c, _shift)
        return rate, basis, step * max(1.0, float(np.abs(x0).max()))

    def _marker_index(self, markers: list[Marker], marker: Marker | None) -> int:
        if marker is None:
            return -1
        for i, m in enumerate(markers):
            if m is marker:
                return i
        raise AssertionError("marker not collected")

    def pack(self) -> tuple[Layout, NDArray[np.float64], NDArray[np.float64]]:
        """(layout, data row, initial state (z, v)) of this mechanism."""
        if not self.bodies:
            raise InvalidParameterError("a Mechanism needs at least one body")
        known = set(map(id, self.bodies))
        offsets = self.coordinate_offsets()
        data: list[float] = [*self.gravity]
        bodies = []
        for b in self.bodies:
            stiffening = int(b.geometric_stiffening)
            bodies.append([offsets[b.name], b.mode_count, len(data), stiffening])
            data.extend(b.pack())
        markers = self.markers()
        marker_rows = []
        for m in markers:
            if m.body is not None and id(m.body) not in known:
                raise InvalidParameterError(
                    f"marker {m.name} is on body {m.body.name!r}, which was not added to the "
                    "mechanism"
                )
            body = -1 if m.body is None else self.bodies.index(m.body)
            marker_rows.append([body, len(data), 0 if m.body is None else m.body.mode_count])
            data.extend(m.pack())
        n = self.coordinate_count()
        state = np.zeros(2 * n)
        for b in self.bodies:
            o = offsets[b.name]
            state[o : o + 3] = [*b.position, b.angle]
            state[n + o : n + o + 3] = [*b.velocity, b.angular_velocity]
        layout_markers = np.array(marker_rows, dtype=np.int64).reshape(-1, 3)
        partial = Layout(
            np.array(bodies, dtype=np.int64).reshape(-1, 4),
            layout_markers,
            np.zeros((0, 6), dtype=np.int64),
            np.zeros((0, 5), dtype=np.int64),
            np.array([n, 0], dtype=np.int64),
        )
        start = self._marker_states(partial, np.array(data), state, len(markers))
        joints = []
        row = 0
        for j in self.joints:
            i, k = (
                self._marker_index(markers, j.marker_i),
                self._marker_index(markers, j.marker_j),
            )
            joints.append([j.kind, i, k, row, len(data), j.drive_code])
            data.extend(j.pack(start[k, 2] - start[i, 2]))
            row += j.equations
        forces = []
        for f in self.forces:
            i = self._marker_index(markers, f.marker_i)
            k = self._marker_index(markers, f.marker_j)
            other = start[k] if k >= 0 else np.zeros(6)
            forces.append([f.kind, i, k, len(data), f.profile_code])
            data.extend(f.pack(start[i], other))
        layout = Layout(
            partial.bodies,
            layout_markers,
            np.array(joints, dtype=np.int64).reshape(-1, 6),
            np.array(forces, dtype=np.int64).reshape(-1, 5),
            np.array([n, row], dtype=np.int64),
        )
        return layout, np.array(data, dtype=float), state

    @staticmethod
    def _marker_states(layout: Layout, data, state, count: int) -> NDArray[np.float64]:
        out = np.empty((1, 1, count, 6))
        readout.markers_at(
            np.arange(count, dtype=np.int64),
            state[None, None, :],
            layout.arrays(),
            data[None, :],
            out,
        )
        return out[0, 0]

    def check(self, t0: float = 0.0) -> None:
        """Refuse a mechanism that cannot be right, naming the element.

        Joints whose markers do not meet at the start, redundant or
        contradictory joints (a constraint Jacobian without full row rank), and
        a mass matrix that is singular on the directions the joints leave free
        (the modes of a flexible body nearly reproducing its frame's motion).
        """
        layout, data, state = self.pack()
        n, c = (int(s) for s in layout.sizes)
        self._check_joints(t0, layout, data, state)
        mass = np.zeros((n, n))
        kernels.body_terms(
            layout.bodies, data, state[:n].copy(), state[n:].copy(), mass, np.zeros(n)
        )
        _, jac = joint_rows(t0, layout, data, state)
        _, singular, vt = np.linalg.svd(jac) if c else (None, np.zeros(0), np.eye(n))
        free = vt[int(np.sum(singular > 1e-10 * max(1.0, singular.max(initial=0.0)))) :].T
        values = np.linalg.eigvalsh(free.T @ mass @ free) if free.size else np.ones(1)
        if values[0] < MASS_CONDITION * values[-1]:
            flexible = [b.name for b in self.bodies if b.mode_count]
            raise InvalidParameterError(
                f"the mass matrix is (nearly) singular on the motion the joints allow "
                f"(smallest/largest eigenvalue {values[0] / values[-1]:.2g} < {MASS_CONDITION:g})"
                + (
                    f": the modes of {flexible} nearly reproduce their frame's motion; keep fewer "
                    "modes, or choose modes held where the joint holds the body "
                    "(support='pinned-pinned' for a beam pinned at its root)"
                    if flexible
                    else ""
                )
            )

    def _check_joints(self, t0: float, layout: Layout, data, state) -> None:
        c = int(layout.sizes[1])
        if c == 0:
            return
        residual, jac = joint_rows(t0, layout, data, state)
        row = 0
        for j in self.joints:
            worst = np.abs(residual[row : row + j.equations]).max()
            if worst > START_TOLERANCE:
                raise InvalidParameterError(
                    f"joint {j.label()} is violated at the start by {worst:.3g} (m or rad): "
                    "place the "
                    "bodies so its markers meet (and its drive starts where the joint is)"
                )
            row += j.equations
        rank = np.linalg.matrix_rank(jac, tol=1e-9 * max(1.0, np.abs(jac).max()))
        if rank < c:
            # name the first joint whose rows do not add rank
            row = 0
            for j in self.joints:
                upto = np.linalg.matrix_rank(
                    jac[: row + j.equations], tol=1e-9 * max(1.0, np.abs(jac).max())
                )
                if upto < row + j.equations:
                    raise InvalidParameterError(
                        f"joint {j.label()} is redundant with the joints before it ({c - rank} of "
                        f"{c} equations are dependent): remove it or use a joint with fewer "
                        "equations"
                    )
                row += j.equations


def _shift(positions: NDArray[np.float64], position: NDArray[np.float64]) -> None:
    positions += position


def joint_rows(
    t: float, layout: Layout, data: NDArray[np.float64], state: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The joints' residual g (c,) and Jacobian G (c, n) at time ``t`` and ``state`` (z, v)."""
    n, c = (int(s) for s in layout.sizes)
    residual = np.zeros(c)
    jac = np.zeros((c, n))
    if c:
        spare = [np.empty(c) for _ in range(3)]
        kernels.joint_terms(t, layout.arrays(), data, state[:n], state[n:], jac, residual, *spare)
    return residual, jac


@dataclass(frozen=True)
class PackedBatch:
    """A batch of mechanisms of one structure, ready for the kernels."""

    layout: Layout
    data: NDArray[np.float64]
    initial: NDArray[np.float64]
    user_force: object
    template: Mechanism


def pack_batch(mechanisms: list[Mechanism], check: bool = True) -> PackedBatch:
    """Pack mechanisms of one structure (one per sample) into kernel arrays."""
    if not mechanisms:
        raise InvalidParameterError("pack_batch needs at least one mechanism")
    rows = []
    states = []
    layout = None
    function = None
    for index, mechanism in enumerate(mechanisms):
        if check:
            mechanism.check()
        lay, data, state = mechanism.pack()
        f = mechanism.user_function()
        if layout is None:
            layout, function = lay, f
        elif not lay.same_as(layout) or data.size != rows[0].size:
            raise InvalidParameterError(
                f"sample {index}'s mechanism has another structure than sample 0's (bodies, modes, "
                "joints or forces differ); a parameter may change numbers, not the structure"
            )
        elif f is not function:
            raise InvalidParameterError(
                f"sample {index}'s mechanism has another user force function"
            )
        rows.append(data)
        states.append(state)
    return PackedBatch(layout, np.stack(rows), np.stack(states), function, mechanisms[0])
