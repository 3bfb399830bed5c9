"""Time integration of a batch of planar mechanisms, and what a run reports.

An explicit Runge-Kutta pair (DOP853 by default, or Dormand-Prince 5(4)),
with its own step size per sample (so a
sample's trajectory is the same whatever batch it runs in), every output time
hit exactly, and the joints projected after every accepted step
(:mod:`fuzzymbs.mbs.planar.kernels`). The error control covers every
coordinate, the constrained ones included. Samples run LANES (4; 8 by choice) at a time, one per
SIMD lane (:mod:`fuzzymbs.mbs.planar.lanes`), bit for bit as the one-sample
kernel runs them (:mod:`fuzzymbs.mbs.planar.integrator`, ``kernel="samples"``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.assembly import PROJECTION_TOLERANCE
from fuzzymbs.mbs.kernels.threads import for_each_range
from fuzzymbs.mbs.planar import integrator, kernels, lanes, readout
from fuzzymbs.mbs.planar.step_sequences import replay_arrays, run_logging
from fuzzymbs.mbs.planar.system import Mechanism, PackedBatch, pack_batch

#: Default relative and absolute tolerances of the step control (docs/embs.md
#: has the convergence measurement behind them).
DEFAULT_RTOL = 1e-6
DEFAULT_ATOL = 1e-8
#: Default Runge-Kutta pair: "auto" takes DOP853 for a mechanism with flexible bodies
#: (their undamped stiff modes) and Dormand-Prince 5(4) for a rigid one (whose
#: singular positions DOP853's error estimate cannot pass); docs/mechanisms.md has the
#: measurements behind both.
DEFAULT_METHOD = "auto"
#: The pairs in words (for study summaries).
INTEGRATOR_NAMES = {
    "auto": "DOP853 with flexible bodies, else Dormand-Prince 5(4)",
    "dop853": "DOP853 (Dormand-Prince 8(5,3))",
    "dopri5": "Dormand-Prince 5(4)",
}
#: The integration kernels: LANES samples per call in SIMD lanes, or one (the same
#: numbers, bit for bit; the lanes take about a third of the time).
KERNELS = ("lanes", "samples")

STATUS_TEXT = {
    kernels.FINISHED: "finished",
    kernels.NOT_FINITE: "not finite (diverged, or a singular mass matrix)",
    kernels.STEP_TOO_SMALL: "step size underflow",
    kernels.TOO_MANY_STEPS: "step budget exhausted",
    kernels.PROJECTION_FAILED: "joint projection did not converge (a locked or singular position)",
    kernels.REPLAY_ENDED: "the replayed step sequence does not reach the last output time",
}


def checked_method(method: str) -> str:
    """``method`` if it names a Runge-Kutta pair (:data:`INTEGRATOR_NAMES`), else a clear
    error."""
    if method not in INTEGRATOR_NAMES:
        raise InvalidParameterError(
            f"unknown integration method {method!r}; choose one of {sorted(INTEGRATOR_NAMES)}"
        )
    return method


def integrator_method(method: str, flexible: bool) -> int:
    """The kernels' code of the Runge-Kutta pair ``method`` (:data:`INTEGRATOR_NAMES`) for a
    mechanism with (``flexible``) or without modal coordinates, or a clear error."""
    if checked_method(method) == "auto":
        method = "dop853" if flexible else "dopri5"
    return integrator.METHODS[method]


def describe_failure(
    status: int, states: NDArray[np.float64], times: NDArray[np.float64]
) -> str | None:
    """Why a run with kernel ``status`` failed and the last time it stored (its ``states``
    (T, ...) are NaN after the failure), or None if it finished."""
    if status == kernels.FINISHED:
        return None
    good = np.isfinite(states[:, 0])
    last = times[good][-1] if good.any() else times[0]
    return f"{STATUS_TEXT.get(int(status), 'failed')} after t = {last:.6g} s"


@dataclass(frozen=True)
class PlanarResult:
    """States of every sample at the output times, and how each run ended.

    Attributes
    ----------
    times : (T,) output times [s].
    states : (B, T, 2n) coordinates z then rates v; rows after a failure are NaN.
    status : (B,) kernel status codes (:data:`STATUS_TEXT`).
    accepted, rejected : (B,) step counts.
    joint_residual : (B,) largest joint residual after projection [m or rad].
    batch : the packed mechanisms.
    step_logs : with ``simulate(..., log_steps=True)``, each sample's accepted steps'
        end times [s] (up to its failure), which ``step_sequences`` replays; else None.
    """

    times: NDArray[np.float64]
    states: NDArray[np.float64]
    status: NDArray[np.int64]
    accepted: NDArray[np.int64]
    rejected: NDArray[np.int64]
    joint_residual: NDArray[np.float64]
    batch: PackedBatch
    step_logs: tuple[NDArray[np.float64], ...] | None = None

    @property
    def failed(self) -> NDArray[np.bool_]:
        return self.status != kernels.FINISHED

    def failure(self, sample: int) -> str | None:
        """Why sample ``sample`` failed and when, or None."""
        return describe_failure(self.status[sample], self.states[sample], self.times)

    @property
    def coordinate_count(self) -> int:
        return int(self.batch.layout.sizes[0])

    def coordinates(self, body: str) -> NDArray[np.float64]:
        """(B, T, 3 + m): x, y, angle, modal coordinates of ``body``."""
        template = self.batch.template
        start = template.coordinate_offsets()[template.body(body).name]
        size = 3 + template.body(body).mode_count
        return self.states[:, :, start : start + size]

    def rates(self, body: str) -> NDArray[np.float64]:
        """(B, T, 3 + m): the rates of :meth:`coordinates`."""
        n = self.coordinate_count
        template = self.batch.template
        start = template.coordinate_offsets()[template.body(body).name]
        size = 3 + template.body(body).mode_count
        return self.states[:, :, n + start : n + start + size]

    def _marker_index(self, name: str) -> int:
        template = self.batch.template
        if name not in template.named_markers:
            raise InvalidParameterError(
                f"no marker named {name!r}; named markers: {sorted(template.named_markers)}"
            )
        markers = template.markers()
        return next(i for i, m in enumerate(markers) if m is template.named_markers[name])

    def marker_acceleration(self, name: str) -> NDArray[np.float64]:
        """(B, T, 3): ax, ay [m/s^2] and the angular acceleration [rad/s^2] of a named
        marker (on a flexible body with its node's elastic motion)."""
        index = self._marker_index(name)
        out = np.empty((*self.states.shape[:2], 3))
        readout.marker_accelerations_at(
            index, self.states, self.solved(), self.batch.layout.arrays(), self.batch.data, out
        )
        return out

    def marker(self, name: str) -> NDArray[np.float64]:
        """(B, T, 6): x, y, angle, vx, vy, angular velocity of a named marker."""
        index = self._marker_index(name)
        out = np.empty((*self.states.shape[:2], 1, 6))
        readout.markers_at(
            np.array([index], dtype=np.int64),
            self.states,
            self.batch.layout.arrays(),
            self.batch.data,
            out,
        )
        return out[:, :, 0]

    def energy(self) -> NDArray[np.float64]:
        """(B, T, 2): kinetic and potential energy [J] (gravity, modal stiffness, springs,
        closed contacts; drives, loads and user forces have none), NaN after a failure."""
        out = np.empty((*self.states.shape[:2], 2))
        readout.energy_at(self.states, self.batch.layout.arrays(), self.batch.data, out)
        return out

    def solved(self) -> NDArray[np.float64]:
        """(B, T, n + c): accelerations and multipliers at every stored state (read-only).

        Solved once per result and kept: every reaction and acceleration output reads it.
        """
        return self._solution

    @cached_property
    def _solution(self) -> NDArray[np.float64]:
        n, c = (int(s) for s in self.batch.layout.sizes)
        out = np.empty((*self.states.shape[:2], n + c))
        arrays = self.batch.layout.arrays()

        def run(start: int, stop: int) -> None:
            lanes.solve_blocks(
                start,
                stop,
                self.times,
                self.states,
                arrays,
                self.batch.data,
                self.batch.user_force,
                out,
            )

        # LANES samples per call, one per SIMD lane (bit for bit integrator.solve_range)
        for_each_range(-(-self.states.shape[0] // lanes.L), run)
        out.flags.writeable = False
        return out

    def element_force(self, element: str) -> NDArray[np.float64]:
        """(B, T, 3): the load a force element applies to its marker i -- (fx, fy) [N],
        global, and the torque [N m]; marker j's body takes the opposite (for a contact,
        at the contact point). ``element`` is its name or label (``Mechanism.force``)."""
        template = self.batch.template
        index = template.forces.index(template.force(element))
        out = np.empty((*self.states.shape[:2], 3))
        readout.element_forces_at(
            index,
            self.times,
            self.states,
            self.batch.layout.arrays(),
            self.batch.data,
            self.batch.user_force,
            out,
        )
        return out

    def reaction(self, joint: str) -> NDArray[np.float64]:
        """(B, T, rows): the joint's multipliers.

        For a revolute or fixed joint, rows 0 and 1 are the force [N] the
        joint applies to marker j's body (global x, y; marker i's body gets
        the opposite), row 2 of a fixed joint or a drive is the torque [N m]
        on marker j's body. For a prismatic joint, row 0 is the force normal
        to the axis on marker j's body [N], row 1 the torque [N m].
        """
        template = self.batch.template
        wanted = template.joint(joint)
        row = 0
        for j in template.joints:
            if j is wanted:
                break
            row += j.equations
        n = self.coordinate_count
        return self.solved()[:, :, n + row : n + row + wanted.equations]


def simulate(
    mechanisms: Mechanism | list[Mechanism],
    times: ArrayLike,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    first_step: float | None = None,
    max_steps: int = 10_000_000,
    method: str = DEFAULT_METHOD,
    kernel: str = "lanes",
    log_steps: bool = False,
    step_sequences: Sequence[ArrayLike] | None = None,
) -> PlanarResult:
    """Integrate one mechanism or a batch of one structure over ``times``.

    Parameters
    ----------
    mechanisms : Mechanism or list of Mechanism
        One per sample; all of one structure (:func:`pack_batch`).
    times : array_like, shape (T,)
        Increasing output times [s]; the run starts at ``times[0]``.
    rtol, atol : float
        Step-control tolerances on every coordinate and rate.
    first_step : float, optional
        Initial step [s] (default a thousandth of the span).
    max_steps : int
        Steps per sample before the run is stopped as failed.
    method : {"auto", "dop853", "dopri5"}
        The explicit Runge-Kutta pair: "auto" takes DOP853 if a body has modes, else
        Dormand-Prince 5(4) (docs/mechanisms.md, "Integrator").
    kernel : {"lanes", "samples"}
        LANES samples per kernel call, one per SIMD lane, or one sample per call: the
        same trajectories bit for bit (:data:`KERNELS`).
    log_steps : bool
        Log each sample's accepted steps (``result.step_logs``).
    step_sequences : sequence of array_like, optional
        One per sample: the end times of the steps to take (a run's ``step_logs``),
        replayed without the step control (rtol and atol then only judge whether a
        step is finite); an empty one leaves that sample to the step control
        (:mod:`fuzzymbs.mbs.planar.step_sequences`).
    """
    batch = pack_batch(mechanisms if isinstance(mechanisms, list) else [mechanisms])
    code = integrator_method(method, bool(np.any(batch.layout.bodies[:, 1] > 0)))
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.isfinite(t).all() or np.any(np.diff(t) <= 0):
        raise InvalidParameterError(
            "times must be at least two finite, strictly increasing values [s]"
        )
    if kernel not in KERNELS:
        raise InvalidParameterError(f"unknown kernel {kernel!r}; choose one of {list(KERNELS)}")
    if not (rtol > 0 and atol > 0):
        raise InvalidParameterError(f"rtol and atol must be > 0, got {rtol!r} and {atol!r}")
    step = (t[-1] - t[0]) * 1e-3 if first_step is None else float(first_step)
    samples = batch.data.shape[0]
    replay = replay_arrays(step_sequences, samples, t)
    states = np.full((samples, t.size, batch.initial.shape[1]), np.nan)
    initial = batch.initial.copy()
    arrays = batch.layout.arrays()

    integrate = lanes.integrate_blocks if kernel == "lanes" else integrator.integrate_range
    control = (code, float(rtol), float(atol), step, int(max_steps), PROJECTION_TOLERANCE)

    def run_batch(steps):
        report = np.zeros((samples, 4))

        def run(start: int, stop: int) -> None:
            integrate(
                start, stop, t, initial, arrays, batch.data, batch.user_force, control, states,
                report, steps,
            )  # fmt: skip

        # the lanes kernel takes blocks of LANES samples (the last one possibly short)
        for_each_range(-(-samples // lanes.L) if kernel == "lanes" else samples, run)
        return report

    report, logs = run_logging(run_batch, replay, samples, log_steps)
    return PlanarResult(
        t,
        states,
        report[:, 0].astype(np.int64),
        report[:, 1].astype(np.int64),
        report[:, 2].astype(np.int64),
        report[:, 3],
        batch,
        logs,
    )
