"""Public time-integration API: batched fixed-step RK4 and a DOP853 reference.

:func:`simulate` integrates a batch of samples with the compiled RK4 kernel
(chunks of samples, one parallel call per chunk over blocks of LANES samples in
lockstep, :func:`fuzzymbs.mbs.kernels.rk4.rk4`).
:class:`SimulationModel` wraps a compiled system as a fuzzymbs model,
``model({name: (B,)}) -> {output: (B, T)}`` with ``model.coords = {"time": t}``.
:func:`simulate_reference` integrates one sample with SciPy's adaptive DOP853
on the same right-hand side, for checks.
"""

from __future__ import annotations

import contextlib
import inspect
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import scipy.integrate
from numpy.typing import NDArray

from fuzzymbs.background import Background
from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.central_differences import on_fixed_steps
from fuzzymbs.mbs.kernels.jacobian_log import jacobian_arrays, logged_rows
from fuzzymbs.mbs.kernels.layout import FAILURE_REASONS, OK
from fuzzymbs.mbs.kernels.rhs import make_work, rhs_batch, rhs_sample
from fuzzymbs.mbs.kernels.rk4 import rk4
from fuzzymbs.mbs.kernels.rosenbrock import ros34pw2
from fuzzymbs.mbs.kernels.rosenbrock_methods import METHODS
from fuzzymbs.mbs.kernels.sensitivities import SENS_DELTA, no_sensitivity
from fuzzymbs.mbs.sensitivities import checked_wrt, gradient_cost, sensitivity_directions
from fuzzymbs.mbs.shared_steps import (
    SharedSteps,
    checked_renewals,
    checked_sequence,
    kept_run,
    logged_steps,
    predicted_reference_error,
    share_steps,
)
from fuzzymbs.mbs.simulate_checks import (
    check_integrator,
    check_kernel,
    check_timing,
    checked_initial_state,
    checked_log_samples,
    per_sample,
    samples_per_block,
)
from fuzzymbs.mbs.system import CompiledSystem, Output, System
from fuzzymbs.tolerance import DEFAULT_TOLERANCE, Tolerance

#: the integrators with error control (a tolerance, shared steps, step logs, sensitivities)
ROSENBROCK = ("ros34pw2", "rodas4")
#: the key of the outputs' derivatives in a model's outputs when it is called with ``wrt``
#: (the model protocol of :mod:`fuzzymbs.study`)
GRADIENTS = "gradients"


@dataclass
class SimulationResult:
    """Outputs of a batch run.

    Attributes
    ----------
    time : (T,) recording times [s].
    outputs : {name: (B, T)} recorded outputs (NaN rows for failed samples).
    failed : (B,) bool; failure_reason : (B,) str; failure_time : (B,) [s] (NaN if ok).
    step_counts : (B, 2) accepted and rejected steps per sample (ROS34PW2, RODAS4), None
        for RK4 (``t_end / dt`` steps).
    step_times : the ends of the accepted steps of the first sample (ROS34PW2 with
        ``log_steps``), else None.
    step_renewals : with ``step_times``, True for each step whose Jacobian was
        evaluated at its start (the ``jacobian_renewals`` of a replay), else None.
    step_logs : with ``log_steps``, ``(step_times, step_renewals)`` of each of the first
        ``log_samples`` samples (the first is the attributes above; None for a later
        sample whose steps overflowed the log), else None.
    """

    time: NDArray[np.float64]
    outputs: dict[str, NDArray[np.float64]]
    failed: NDArray[np.bool_]
    failure_reason: NDArray[np.str_]
    failure_time: NDArray[np.float64]
    step_counts: NDArray[np.int64] | None = None
    step_times: NDArray[np.float64] | None = None
    step_renewals: NDArray[np.bool_] | None = None
    step_logs: list[tuple[NDArray[np.float64], NDArray[np.bool_]]] | None = None
    #: (B, 3) right-hand sides, Jacobians and LU factorisations of each sample's runs
    #: (ROS34PW2, RODAS4: the block calls it took part in), None for RK4
    work_counts: NDArray[np.int64] | None = None
    #: {output: (B, T, P)} the outputs' derivatives with respect to the parameters asked
    #: for (``simulate(..., sensitivities=names)``), the last axis in that order, in the
    #: output's unit per the parameter's (NaN rows for failed samples); None without
    gradients: dict[str, NDArray[np.float64]] | None = None
    #: the parameters of ``gradients``' last axis
    gradient_parameters: tuple[str, ...] = ()
    #: (B,) right-hand sides the sensitivities took (besides ``work_counts``'), None without
    sensitivity_rhs: NDArray[np.int64] | None = None
    #: with ``log_jacobians``: ``(rows, step_rows)``, the first sample's Jacobians and the
    #: row each logged step took (:mod:`fuzzymbs.mbs.kernels.jacobian_log`), else None
    jacobian_log: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None


def simulate(
    system: System | CompiledSystem,
    samples: Mapping[str, NDArray[np.float64]] | None = None,
    *,
    t_end: float,
    dt: float,
    outputs: Mapping[str, Output],
    record_interval: float | None = None,
    initial_state: NDArray[np.float64] | None = None,
    displacement_bound: float = 1.0,
    chunk_size: int = 64,
    kernel: str = "auto",
    integrator: str = "rk4",
    tolerance: Tolerance = DEFAULT_TOLERANCE,
    step_sequence: NDArray[np.float64] | None = None,
    jacobian_renewals: NDArray[np.bool_] | None = None,
    log_steps: bool | int = False,
    log_samples: int = 1,
    sensitivities: Sequence[str] = (),
    log_jacobians: bool = False,
    logged_jacobians: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> SimulationResult:
    """Integrate a batch of samples with classic RK4 (fixed step) or ROS34PW2.

    Parameters
    ----------
    system : System or CompiledSystem
    samples : {name: (B,)}, optional
        Values of the bound parameters (missing names take their defaults).
    t_end, dt : float
        End time and step [s]; ``t_end`` must be a multiple of ``dt``. With
        ``integrator="ros34pw2"``, dt is the first step tried.
        Explicit RK4 is stable for ``omega_max dt < 2.8`` (omega_max: highest
        angular frequency of the system, including contact stiffness).
    outputs : {name: NodeDisplacement | Coordinate}
        Linear outputs recorded every ``record_interval`` (default every step).
    initial_state : (2n,) or (B, 2n), optional
        Default zero.
    displacement_bound : float
        A sample whose displacement output (not velocity outputs) exceeds this
        magnitude [m] is stopped and flagged. Every step, a non-finite state stops it too.
    chunk_size : int
        Samples per compiled call.
    kernel : {"auto", "lanes", "samples"}
        How samples share the lanes of the lockstep kernel (one SIMD vector of
        :data:`~fuzzymbs.mbs.kernels.simd.LANES` samples, 4 by default, per quantity).
        ``"auto"`` and ``"lanes"``: blocks of LANES samples, a last, partial block
        padded with copies of its last sample. ``"samples"``: a block per sample,
        its lanes repeating it (about 1.4 times the cost per sample,
        docs/benchmarks.md). Both give every sample the same arithmetic, so its
        outputs are bit for bit the same whichever samples share its block.
    integrator : {"rk4", "ros34pw2", "rodas4"}
        ``"rk4"``: classic RK4 at the fixed step dt (the brake paper's method;
        stable only for ``|lambda dt| < 2.785`` on the real axis). ``"ros34pw2"``:
        the linearly implicit ROS34PW2 with error control, each sample on its own
        step sequence, so that its outputs do not depend on the samples beside it
        (docs/theory.md, "ROS34PW2"). ``"rodas4"``: RODAS4 (order 4, six stages, a
        fresh Jacobian every step) in the same kernel, with the same options
        (docs/theory.md, "RODAS4").
    tolerance : Tolerance
        ROS34PW2's tolerances (:class:`~fuzzymbs.tolerance.Tolerance`; default
        :data:`~fuzzymbs.tolerance.DEFAULT_TOLERANCE`): a sample's step is accepted when
        the RMS over its state of ``error / (atol + rtol |x|)`` is at most 1. One rtol
        (and atol) per sample runs samples of one batch at different tolerances, a
        block costing about as much as its tightest lane (a reference and its companion
        in one block).
    step_sequence : (K,) array, optional
        ROS34PW2 only: the ends of the steps every sample takes (increasing, the last
        at ``t_end``), typically the accepted steps of one sample logged with
        ``log_steps``. The error control still guards each step and cuts a step it
        rejects into the sample's own smaller steps up to the next point
        (:mod:`fuzzymbs.mbs.shared_steps`).
    jacobian_renewals : (K,) bool array, optional
        With ``step_sequence``: True where a sample arriving at the step's start renews
        its Jacobian (the logged ``step_renewals``: where the logged sample evaluated it,
        by age or after a rejected try), so that the logged sample's replay repeats its
        run to the rounding of the step lengths. Default: each sample renews by its own
        rules.
    log_steps : bool or int
        ROS34PW2 only: return the ends of the first sample's accepted steps as
        ``step_times`` (and ``step_renewals``); a number: at most that many per logged
        sample (default 20 per dt, at least 10^6); more in the first sample raise
        :class:`~fuzzymbs.errors.InvalidParameterError`.
    log_samples : int
        With ``log_steps``: the first ``log_samples`` samples log their steps
        (``step_logs``), at most one block of lanes (:func:`samples_per_block`); each
        sample's steps are its own, as without the log.
    sensitivities : sequence of str
        ROS34PW2 and RODAS4 only: names of bound parameters (``compiled.parameters.names``)
        whose forward sensitivities ``dx/dp`` are integrated with the state, on the
        state's steps (the state's error control alone chooses them, so the outputs are
        bit for bit those of the run without); the result's ``gradients`` then hold the
        outputs' derivatives, (B, T, P) per output in this order, in the output's unit
        per the parameter's (docs/theory.md, "Forward sensitivities").
    log_jacobians : bool
        ROS34PW2 with ``log_steps``: keep the first sample's Jacobians too, as
        ``jacobian_log`` (:mod:`fuzzymbs.mbs.kernels.jacobian_log`; 27.5 kB each, brake).
    logged_jacobians : (rows, step_rows), optional
        ROS34PW2 with ``step_sequence``: a logging run's ``jacobian_log``, whose Jacobians
        the samples take where they renew theirs at a point of the sequence.
    """
    check_kernel(kernel)
    rtols, atols, h_min = check_integrator(integrator, tolerance)
    if log_steps is not False and integrator not in ROSENBROCK:
        raise InvalidParameterError(f"log_steps needs an integrator of {ROSENBROCK}")
    compiled = system.compile() if isinstance(system, System) else system
    if not outputs:
        raise InvalidParameterError("simulate needs at least one output")
    n_steps, every = check_timing(t_end, dt, record_interval)
    params = compiled.parameters.values(samples or {})
    batch = params.shape[0]
    directions = sensitivity_directions(
        compiled, sensitivities, integrator in ROSENBROCK, params.shape[1]
    )
    sens_settings = np.array([SENS_DELTA])
    nsens = directions.shape[0]
    rtols = per_sample(rtols, batch, "rtol")
    atols = per_sample(atols, batch, "atol")
    x0 = checked_initial_state(compiled, initial_state, batch)
    out_w = np.array([compiled.output_functional(spec) for spec in outputs.values()])
    if not displacement_bound > 0:
        raise InvalidParameterError(f"displacement_bound must be > 0 m, got {displacement_bound!r}")
    # float64 whatever the caller's number: an int bound would compile the kernels again
    bounds = np.array(
        [
            np.inf if getattr(spec, "velocity", False) else displacement_bound
            for spec in outputs.values()
        ],
        dtype=np.float64,
    )
    n_rec = n_steps // every + 1
    # the kernel's final time, computed as it computes it
    sequence = checked_sequence(
        step_sequence, integrator in ROSENBROCK, 0.0 + (n_rec - 1) * float(every * dt)
    )
    renewals = checked_renewals(jacobian_renewals, sequence)
    jacobians = jacobian_arrays(
        compiled, integrator, log_jacobians, log_steps, logged_jacobians, sequence, n_steps
    )
    out = np.empty((batch, out_w.shape[0], n_rec))
    status = np.zeros(batch, dtype=np.int64)
    fail_t = np.full(batch, np.nan)
    counts = np.zeros((batch, 6), dtype=np.int64)
    derivatives = np.empty((batch, out_w.shape[0], n_rec, nsens))
    no_log = np.zeros((1, 1))
    step_log = no_log
    if log_steps is not False:
        capacity = max(20 * n_steps, 10**6) if log_steps is True else int(log_steps)
        rows = checked_log_samples(log_samples, batch, samples_per_block(kernel))
        step_log = np.zeros((rows, 1 + 2 * capacity))  # per row: count, (time, renewed) pairs
    for start in range(0, batch, max(int(chunk_size), 1)):
        sl = slice(start, min(start + chunk_size, batch))
        o = np.empty((sl.stop - sl.start, out_w.shape[0], n_rec))
        st = np.zeros(sl.stop - sl.start, dtype=np.int64)
        ft = np.full(sl.stop - sl.start, np.nan)
        if integrator == "rk4":  # blocks of samples in lockstep, over threads
            rk4(
                compiled.data,
                np.ascontiguousarray(params[sl]),
                np.ascontiguousarray(x0[sl]),
                (0.0, float(dt), int(n_steps), int(every)),
                (out_w, bounds, o, st, ft),
                samples_per_block(kernel),
            )
        else:
            d = np.empty((sl.stop - sl.start, out_w.shape[0], n_rec, nsens))
            sensitivity = (
                (directions, sens_settings, d)
                if nsens
                else no_sensitivity(params.shape[1], d.shape[0], out_w.shape[0], n_rec)
            )
            ros34pw2(
                compiled.data,
                np.ascontiguousarray(params[sl]),
                np.ascontiguousarray(x0[sl]),
                (0.0, float(every * dt), int(n_rec), float(dt)),
                (out_w, bounds, o, st, ft),
                (rtols[sl], atols[sl], h_min),
                samples_per_block(kernel),
                counts[sl],
                sequence,
                renewals,
                step_log if start == 0 else no_log,
                METHODS[integrator],
                sensitivity,
                jacobians,  # written only where step_log is: the first chunk's
            )
            derivatives[sl] = d
        out[sl] = o
        status[sl] = st
        fail_t[sl] = ft
    time = np.arange(n_rec) * every * dt
    logs = None
    if log_steps is not False:  # the first sample's overflow raises; another's is None
        logs = [
            logged_steps(row) if r == 0 or row[0] >= 0 else None for r, row in enumerate(step_log)
        ]
    reasons = np.array([FAILURE_REASONS[int(s)] for s in status], dtype=str)
    gradients = None
    if nsens:
        derivatives[status != OK] = np.nan
        gradients = {name: derivatives[:, i] for i, name in enumerate(outputs)}
    return SimulationResult(
        time=time,
        outputs={name: out[:, i, :] for i, name in enumerate(outputs)},
        failed=status != OK,
        failure_reason=reasons,
        failure_time=fail_t,
        step_counts=None if integrator == "rk4" else counts[:, :2].copy(),
        step_times=None if logs is None else logs[0][:, 0].copy(),
        step_renewals=None if logs is None else logs[0][:, 1] != 0.0,
        step_logs=None
        if logs is None
        else [None if log is None else (log[:, 0].copy(), log[:, 1] != 0.0) for log in logs],
        work_counts=None if integrator == "rk4" else counts[:, 2:5].copy(),
        gradients=gradients,
        gradient_parameters=tuple(sensitivities) if nsens else (),
        sensitivity_rhs=counts[:, 5].copy() if nsens else None,
        jacobian_log=logged_rows(jacobians, logs) if log_jacobians else None,
    )


def evaluate_rhs(
    compiled: CompiledSystem,
    params: NDArray[np.float64],
    rows: NDArray[np.int64],
    times: NDArray[np.float64],
    states: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Time derivatives of many states at once (row i uses parameter row ``rows[i]``).

    LANES states with equal times share a block of lanes
    (:func:`fuzzymbs.mbs.kernels.rhs.rhs_batch`).
    """
    states = np.ascontiguousarray(states, dtype=float)
    out = np.empty_like(states)
    rhs_batch(
        compiled.data,
        np.ascontiguousarray(params),
        np.asarray(rows, dtype=np.int64),
        np.asarray(times, dtype=float),
        states,
        out,
    )
    return out


def simulate_reference(
    system: System | CompiledSystem,
    sample: Mapping[str, float] | None = None,
    *,
    t_end: float,
    outputs: Mapping[str, Output],
    times: NDArray[np.float64],
    initial_state: NDArray[np.float64] | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-14,
    max_step: float = np.inf,
) -> dict[str, NDArray[np.float64]]:
    """One sample with SciPy ``solve_ivp(method="DOP853")`` on the same right-hand side.

    Returns ``{name: (T,)}`` at ``times``. Slow (one Python call per evaluation):
    for checks only.
    """
    compiled = system.compile() if isinstance(system, System) else system
    params = compiled.parameters.values({k: np.atleast_1d(v) for k, v in (sample or {}).items()})
    if params.shape[0] != 1:
        raise InvalidParameterError("simulate_reference integrates exactly one sample")
    x0 = checked_initial_state(compiled, initial_state, 1)[0]
    work = make_work(compiled.data)
    p = params[0]

    def f(t: float, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return rhs_sample(t, np.ascontiguousarray(x), p, compiled.data, work)

    sol = scipy.integrate.solve_ivp(
        f, (0.0, t_end), x0, method="DOP853", t_eval=times, rtol=rtol, atol=atol, max_step=max_step
    )
    if not sol.success:
        raise InvalidParameterError(f"DOP853 reference failed: {sol.message}")
    out_w = np.array([compiled.output_functional(spec) for spec in outputs.values()])
    y = out_w @ sol.y
    return {name: y[i] for i, name in enumerate(outputs)}


#: the keyword arguments of :func:`simulate` a :class:`SimulationModel` fixes for all its
#: runs (the others belong to one call: samples, step sequence, logging)
MODEL_SETTINGS = (
    "t_end",
    "dt",
    "record_interval",
    "displacement_bound",
    "chunk_size",
    "kernel",
    "integrator",
    "tolerance",
)
#: :func:`simulate`'s parameters, read once (a simulate patched later, in a test or a
#: benchmark that times its calls, leaves the settings' defaults as they are)
_SIMULATE_PARAMETERS = inspect.signature(simulate).parameters
#: held while a model checks and sets the tightened model it builds (threads may ask at once)
_PREPARING = threading.Lock()


def model_settings(given: Mapping[str, Any]) -> dict[str, Any]:
    """Every one of :data:`MODEL_SETTINGS`: ``given``, else :func:`simulate`'s default.

    Raises
    ------
    InvalidParameterError
        A setting that is not one of them, or ``t_end`` or ``dt`` missing.
    """
    unknown = sorted(set(given) - set(MODEL_SETTINGS))
    if unknown:
        raise InvalidParameterError(
            f"unknown setting(s) {unknown}; settings: {', '.join(MODEL_SETTINGS)}"
        )
    defaults = _SIMULATE_PARAMETERS
    missing = [
        name
        for name in MODEL_SETTINGS
        if name not in given and defaults[name].default is inspect.Parameter.empty
    ]
    if missing:
        raise InvalidParameterError(f"missing setting(s) {missing}")
    return {name: given.get(name, defaults[name].default) for name in MODEL_SETTINGS}


class SimulationModel:
    """A compiled system as a batched fuzzymbs model.

    ``model({name: (B,)}) -> {output: (B, T), "failed": (B,), "failure_reason": (B,)}``;
    ``model.coords = {"time": t}``; ``model.output_dims`` labels the outputs.
    ``settings``: keyword arguments of :func:`simulate` (:data:`MODEL_SETTINGS`, its
    defaults where not given; ``t_end`` and ``dt`` required). Picklable (plain arrays);
    the kernels compile (or load from cache) on first call.

    With a Rosenbrock integrator ``model(samples, wrt=names)`` (names of ``differentiable``)
    adds ``"gradients": {output: (B, T, len(names))}``, in the output's unit per the
    parameter's (forward sensitivities, :func:`simulate`'s ``sensitivities``).
    """

    def __init__(
        self,
        system: System | CompiledSystem,
        *,
        outputs: Mapping[str, Output],
        initial_state: NDArray[np.float64] | None = None,
        **settings: Any,
    ) -> None:
        self.compiled = system.compile() if isinstance(system, System) else system
        self.settings = model_settings(settings)
        n_steps, every = check_timing(
            self.settings["t_end"], self.settings["dt"], self.settings["record_interval"]
        )
        check_kernel(self.settings["kernel"])
        check_integrator(self.settings["integrator"], self.settings["tolerance"])
        dt = self.settings["dt"]
        self.outputs = dict(outputs)
        for spec in self.outputs.values():
            self.compiled.output_functional(spec)  # validate now, not at run time
        self.initial_state = initial_state
        self.coords = {"time": np.arange(n_steps // every + 1) * every * dt}
        self.output_dims = {name: ("time",) for name in self.outputs}
        self.output_dims.update({"failed": (), "failure_reason": ()})
        #: the step sequence and correction all samples share (:meth:`share_steps`)
        self.shared: SharedSteps | None = None
        #: factor -> the tightened model, perhaps being built (:meth:`prepare_tightened`)
        self._prepared: dict[float, Background] = {}
        #: runs started ahead of need (:meth:`run_ahead`)
        self._ahead: Background | None = None

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Sample columns the model accepts."""
        return self.compiled.parameters.names

    @property
    def parameter_defaults(self) -> dict[str, float]:
        return self.compiled.parameters.defaults()

    @property
    def differentiable(self) -> tuple[str, ...]:
        """Parameters ``model(samples, wrt=...)`` differentiates with respect to: every
        bound one (a Rosenbrock integrator: forward sensitivities; RK4: central differences
        on its fixed steps, :func:`~fuzzymbs.mbs.central_differences.on_fixed_steps`)."""
        return self.compiled.parameters.names

    @property
    def gradient_cost(self) -> float:
        """:func:`~fuzzymbs.mbs.sensitivities.gradient_cost` of this model's integrator."""
        return gradient_cost(self.settings["integrator"])

    def _wrt(self, wrt: Sequence[str] | None) -> tuple[str, ...] | None:
        return checked_wrt(wrt, self.differentiable)

    def simulate(self, samples: Mapping[str, NDArray[np.float64]], **overrides) -> SimulationResult:
        """:func:`simulate` of ``samples`` with this model's settings, ``overrides`` replacing
        or adding keyword arguments (no correction of shared steps applied)."""
        settings = {**self.settings, **overrides}
        return simulate(
            self.compiled,
            samples,
            outputs=self.outputs,
            initial_state=self.initial_state,
            **settings,
        )

    def __call__(
        self, samples: Mapping[str, NDArray[np.float64]], wrt: Sequence[str] | None = None
    ) -> dict[str, NDArray]:
        """The outputs of ``samples``; with ``wrt`` (names of :attr:`differentiable`) also
        ``"gradients": {output: (B, T, len(wrt))}``. The outputs are bit for bit the same
        with or without ``wrt``."""
        names = self._wrt(wrt)
        if names and self.settings["integrator"] not in ROSENBROCK:
            return on_fixed_steps(self, samples, names)
        if self.shared is None:
            return self._outputs(self.simulate(samples, sensitivities=names or ()), {}, names)
        # the modal sample's error removed from every sample (a constant to the gradients)
        correction = self.shared.correction
        return self._outputs(self._on_shared_steps(samples, wrt=names), correction, names)

    def deviations(
        self, samples: Mapping[str, NDArray[np.float64]], wrt: Sequence[str] | None = None
    ) -> dict[str, NDArray]:
        """On shared steps (:meth:`share_steps`): each sample's outputs minus the modal
        sample's on the same steps, as ``__call__`` returns them. Differences and spreads
        of samples are those of the corrected outputs, and they need no reference run
        (a study's choice of tolerance goes on while the reference runs). ``wrt`` as for
        ``__call__`` (the gradients are those of the outputs)."""
        names = self._wrt(wrt)
        shared = self.shared
        if shared is None:
            raise InvalidParameterError("deviations need shared steps (share_steps)")
        negated = {name: -values for name, values in shared.modal_outputs.items()}
        result = self._on_shared_steps(samples, keep=True, wrt=names)
        return self._outputs(result, negated, names)

    def run_ahead(
        self,
        samples: Mapping[str, NDArray[np.float64]],
        then: Callable[[], Any] | None = None,
        wrt: Sequence[str] | None = None,
    ) -> None:
        """On shared steps: run ``samples`` in a background thread on the free cores and keep
        them (as :meth:`deviations` does), then call ``then``; the model's next run waits
        for them and takes them. A study runs its first points so while the reference
        finishes on the other core; a failed run ahead only loses what it would have
        kept. With ``wrt`` the runs ahead also integrate those sensitivities (a kept run
        without the gradients a later call asks for runs again)."""
        if self.shared is None:
            raise InvalidParameterError("run_ahead needs shared steps (share_steps)")
        names = self._wrt(wrt)
        self._wait_ahead()

        def ahead() -> None:
            # on the core the reference leaves; a second joins once the reference is done
            # (fuzzymbs.mbs.kernels.threads)
            self._shared_runs(samples, keep=True, wrt=names)
            if then is not None:
                then()

        self._ahead = Background(ahead)

    def _wait_ahead(self) -> None:
        """Wait for the runs of :meth:`run_ahead`, if any (their errors are its own)."""
        ahead = getattr(self, "_ahead", None)
        if ahead is not None:
            with contextlib.suppress(Exception):  # the runs are made again where needed
                ahead.result()
            self._ahead = None

    def _on_shared_steps(
        self,
        samples: Mapping[str, NDArray[np.float64]],
        keep: bool = False,
        wrt: tuple[str, ...] | None = None,
    ) -> SimulationResult:
        """The samples on the shared sequence; runs kept on it (``shared.kept``) are taken
        as they are (with ``wrt``: those that hold these gradients), the others run (and
        are kept too with ``keep``)."""
        self._wait_ahead()
        return self._shared_runs(samples, keep, wrt)

    def _shared_runs(
        self,
        samples: Mapping[str, NDArray[np.float64]],
        keep: bool,
        wrt: tuple[str, ...] | None = None,
    ) -> SimulationResult:
        shared = self.shared
        names = wrt or ()
        rows = self.compiled.parameters.values(samples)
        keys = [row.tobytes() for row in rows]
        missing = [
            i
            for i, key in enumerate(keys)
            if key not in shared.kept or not shared.kept[key].has_gradients(names)
        ]
        if missing:
            if len(missing) < len(keys):
                samples = {
                    name: np.atleast_1d(np.asarray(values, dtype=float))[missing]
                    for name, values in samples.items()
                }
            result = self.simulate(
                samples,
                step_sequence=shared.sequence,
                jacobian_renewals=shared.renewals,
                logged_jacobians=shared.jacobians,
                sensitivities=names,
            )
            renewed = any(keys[i] in shared.kept for i in missing)
            if len(missing) == len(keys) and not keep and not renewed:
                return result
            fresh = {}
            for row, i in enumerate(missing):
                run = kept_run(result, row)
                earlier = shared.kept.get(keys[i])
                if earlier is not None:
                    # a kept run without these gradients (the modal sample's logging run,
                    # which its replay repeats to the rounding of the step lengths) keeps
                    # its outputs: they are bit for bit the same with or without wrt
                    run = replace(
                        earlier,
                        gradients=run.gradients,
                        gradient_parameters=run.gradient_parameters,
                    )
                fresh[keys[i]] = run
            if keep:
                shared.kept.update(fresh)
        else:
            fresh = {}
        runs = [fresh[key] if key in fresh else shared.kept[key] for key in keys]
        gradients = None
        if names:
            taken = [run.gradients_for(names) for run in runs]
            gradients = {name: np.stack([g[name] for g in taken]) for name in self.outputs}
        return SimulationResult(
            time=self.coords["time"],
            outputs={name: np.stack([run.outputs[name] for run in runs]) for name in self.outputs},
            failed=np.array([run.failed for run in runs]),
            failure_reason=np.array([run.failure_reason for run in runs], dtype=str),
            failure_time=np.array([run.failure_time for run in runs]),
            step_counts=np.stack([run.step_counts for run in runs]),
            gradients=gradients,
            gradient_parameters=names,
        )

    def _outputs(
        self,
        result: SimulationResult,
        added: Mapping[str, NDArray],
        wrt: tuple[str, ...] | None = None,
    ) -> dict[str, NDArray]:
        """The model's outputs dict of a result (``added`` to its outputs; with ``wrt``
        the ``"gradients"``, unchanged by what is added: a constant in the parameters)."""
        out: dict[str, Any] = dict(result.outputs)
        for name, values in added.items():
            out[name] = out[name] + values
        out["failed"] = result.failed
        out["failure_reason"] = result.failure_reason
        if wrt is not None:
            given = result.gradients or {}
            batch = result.failed.shape[0]
            out[GRADIENTS] = {
                name: given.get(name, np.empty((batch, self.coords["time"].size, 0)))
                for name in self.outputs
            }
        return out

    @property
    def time_integration(self) -> str:
        """The time integration in words, e.g. ``"ros34pw2, rtol 0.01"``."""
        settings = self.settings
        if settings["integrator"] == "rk4":
            return f"rk4, dt {settings['dt']:g} s"
        words = f"{settings['integrator']}, rtol {self.tolerance.rtol:g}"
        if self.shared is not None:
            tight = self.shared.reference_rtol
            words += (
                ", on the modal sample's steps, corrected by its runs at rtol "
                f"{tight:g} and {self.tolerance.tightening * tight:g}, extrapolated"
            )
        return words

    @property
    def tolerance(self) -> Tolerance:
        """The integrator's tolerance and its checks' tightening."""
        return self.settings["tolerance"]

    @property
    def scalable_tolerance(self) -> bool:
        """True for ROS34PW2: :meth:`tightened` divides its tolerance by any factor (a study
        may then choose it, :func:`fuzzymbs.study.integration_check.choose_tolerance`)."""
        return self.settings["integrator"] in ROSENBROCK

    def tightened(self, factor: float | None = None) -> SimulationModel:
        """The same model with the tolerance divided by ``factor`` (ROS34PW2; atol too;
        default the tolerance's ``tightening``) or, for RK4, the step divided by the
        tolerance's ``step_division``: the study runner's check of the time integration
        (:mod:`fuzzymbs.study.integration_check`)."""
        factor = self.tolerance.tightening if factor is None else factor
        if not (np.isfinite(factor) and factor > 0):
            raise InvalidParameterError(f"factor must be > 0, got {factor!r}")
        if self.shared is None:
            return self._tightened(factor)
        # one model per factor, whichever thread asks first: the runs it keeps (a
        # study's pilot corners) serve every later call (the study's check)
        self.prepare_tightened(factor)
        return self._prepared[factor].result()

    def _tightened(self, factor: float) -> SimulationModel:
        settings = dict(self.settings)
        if settings["integrator"] == "rk4":
            settings["dt"] = settings["dt"] / self.tolerance.step_division
        else:
            settings["tolerance"] = self.tolerance.tightened(factor)
        tight = SimulationModel(
            self.compiled, outputs=self.outputs, initial_state=self.initial_state, **settings
        )
        shared = self.shared
        if shared is None:
            return tight
        # the tighter model's own sequence, corrected by the same reference
        return share_steps(tight, shared.modal, shared.references, shared.ahead)

    def logged_ahead(self, factor: float | None = None) -> bool:
        """On shared steps: True when :meth:`tightened` ``(factor)`` takes the sequence the
        reference block logs ahead (no logging run of its own, unless that lane failed),
        so that a study's pilot can measure this model's error against it cheaply
        (:func:`fuzzymbs.study.integration_check.choose_tolerance`)."""
        shared = self.shared
        if shared is None:
            return False
        tolerance = self.tolerance.tightened(factor)
        return any((tolerance.rtol, tolerance.atol) == (t.rtol, t.atol) for t in shared.ahead)

    def prepare_tightened(self, factor: float | None = None) -> None:
        """Start building ``tightened(factor)`` in a background thread (on shared steps,
        its modal sample's logging run: the check of a study takes it later, and the
        run fills a core the study leaves idle); without shared steps, nothing to do."""
        factor = self.tolerance.tightening if factor is None else factor
        if not (np.isfinite(factor) and factor > 0):
            raise InvalidParameterError(f"factor must be > 0, got {factor!r}")
        with _PREPARING:  # the check and the set at once: a model built once
            if self.shared is not None and factor not in self._prepared:
                self._prepared[factor] = Background(self._tightened, factor)

    def __getstate__(self) -> dict[str, Any]:
        # a copy or a pickled model builds its own tightened model
        self._wait_ahead()  # its runs kept before the model is copied
        return {**self.__dict__, "_prepared": {}, "_ahead": None}

    @property
    def shares_steps(self) -> bool:
        """True when every sample takes the modal sample's step sequence (:meth:`share_steps`)."""
        return self.shared is not None

    def predicted_reference_error(
        self, tighter: SimulationModel
    ) -> dict[str, NDArray[np.float64]] | None:
        """On shared steps, with ``tighter`` this model at a tighter tolerance (also on
        shared steps): the reference's error per output (T,) predicted from the two
        modal logging runs, before the reference has run
        (:func:`fuzzymbs.mbs.shared_steps.predicted_reference_error`); else None."""
        if self.shared is None or tighter.shared is None:
            return None
        return predicted_reference_error(
            self.shared, self.tolerance.rtol, tighter.shared, tighter.tolerance.rtol
        )

    @property
    def reference_error(self) -> dict[str, NDArray[np.float64]] | None:
        """Per output (T,), the estimated error of the reference that corrects the samples
        on shared steps (it moves every sample alike); None without shared steps."""
        return None if self.shared is None else self.shared.reference_error

    def share_steps(self, modal: Mapping[str, float]) -> SimulationModel:
        """This model with every sample on the modal sample's step sequence and the modal
        sample's error removed (ROS34PW2; :mod:`fuzzymbs.mbs.shared_steps`)."""
        return share_steps(self, modal)
