"""A mechanism (planar or spatial) as a study model: parameters in by name, outputs over
time out.

A study model is called with a batch of samples ``{name: (B,) array}`` and
returns ``{output: (B, T) array}``. :class:`MechanismModel` builds one
mechanism per sample with the user's ``build(parameters)`` function (any
number a body, joint or force holds can so be a fuzzy parameter), runs the
whole batch in one kernel call of the mechanism's engine (planar or spatial)
and reads the outputs from the result::

    def build(p):
        rod = RigidBody("rod", mass=p["mass"], inertia=p["mass"] / 12, center=(0.5, 0), angle=-1.0)
        mechanism = Mechanism(gravity=(0, -9.81)).add(rod, Revolute(ground.point(), rod.point()))
        return mechanism

    model = MechanismModel(
        build,
        parameters={"mass": 1.0},
        outputs={"angle": (lambda result: result.coordinates("rod")[:, :, 2], "rad")},
        times=np.linspace(0, 2, 201),
    )

Failed runs (diverged, a step-size underflow, a joint locking) are flagged
in ``failed`` with the reason and the time of failure; their outputs keep
the history up to the failure (NaN after it), and a study leaves them out.

``model(samples, wrt=names)`` also returns the outputs' derivatives with respect to
the parameters ``names`` (any of them: :attr:`MechanismModel.differentiable`), as
central differences of runs replaying each sample's own steps
(:mod:`fuzzymbs.mbs.central_differences`): two runs per parameter.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs import planar, spatial
from fuzzymbs.mbs.assembly import Assembly
from fuzzymbs.mbs.central_differences import (
    GRADIENT_COST,
    central_differences,
    checked_steps,
    with_failures,
)
from fuzzymbs.mbs.planar.simulation import (
    DEFAULT_ATOL,
    DEFAULT_METHOD,
    DEFAULT_RTOL,
    INTEGRATOR_NAMES,
    checked_method,
)
from fuzzymbs.mbs.sensitivities import checked_wrt
from fuzzymbs.tolerance import Tolerance

#: the mechanism engines' own default tolerance (:func:`fuzzymbs.mbs.planar.simulate`
#: and :func:`fuzzymbs.mbs.spatial.simulate`: rtol 1e-6, atol 1e-8)
ENGINE_TOLERANCE = Tolerance(rtol=DEFAULT_RTOL, atol=DEFAULT_ATOL)

OutputReader = Callable[[Any], NDArray[np.float64]]


class MechanismModel:
    """Batched study model of a planar or spatial mechanism.

    Parameters
    ----------
    build : callable
        ``build(parameters: dict[str, float]) -> Mechanism`` for one sample (a
        :class:`fuzzymbs.mbs.planar.Mechanism` or a :class:`fuzzymbs.mbs.spatial.Mechanism`,
        the same structure for every sample).
    parameters : mapping of str to float
        Every parameter the model takes and its default (SI units).
    outputs : mapping of str to (reader, unit)
        ``reader(result) -> (B, T)`` for each output (``result``: the engine's
        ``PlanarResult`` or ``SpatialResult``).
    times : array_like, shape (T,)
        Output times [s].
    tolerance : Tolerance
        The step control's rtol and atol (default :data:`ENGINE_TOLERANCE`, the engines'
        own) and its checks' tightening.
    method : {"auto", "dop853", "dopri5"}
        The explicit Runge-Kutta pair (:func:`fuzzymbs.mbs.planar.simulate`).
    gradient_steps : mapping of str to float, optional
        Absolute steps [the parameter's unit] of the central differences behind
        ``model(samples, wrt=...)`` for some parameters; the others take a relative
        step, :data:`fuzzymbs.mbs.central_differences.GRADIENT_STEP` times their value
        (that times one unit where the value is 0). Give one for a parameter whose
        value may be 0 or whose relevant scale is not its value (an offset, a
        misalignment).
    """

    def __init__(
        self,
        build: Callable[[dict[str, float]], Assembly],
        parameters: Mapping[str, float],
        outputs: Mapping[str, tuple[OutputReader, str]],
        times: ArrayLike,
        tolerance: Tolerance = ENGINE_TOLERANCE,
        method: str = DEFAULT_METHOD,
        gradient_steps: Mapping[str, float] | None = None,
    ) -> None:
        self.build = build
        self.defaults = {name: float(value) for name, value in parameters.items()}
        self.readers = dict(outputs)
        self.times = np.asarray(times, dtype=float)
        if self.times.ndim != 1 or self.times.size < 2 or np.any(np.diff(self.times) <= 0):
            raise InvalidParameterError("times must be at least two strictly increasing values [s]")
        if not isinstance(tolerance, Tolerance) or tolerance.atol is None:
            raise InvalidParameterError(
                f"tolerance must be a Tolerance with rtol and atol, got {tolerance!r}"
            )
        self.tolerance = tolerance
        self.method = checked_method(method)
        self.parameters = tuple(self.defaults)
        self.gradient_steps = checked_steps(gradient_steps, self.parameters)
        self.outputs = {name: unit for name, (_, unit) in self.readers.items()}
        self.coords = {"time": self.times}
        self.coord_units = {"time": "s"}
        self.output_dims = {name: ("time",) for name in self.readers}

    @property
    def time_integration(self) -> str:
        """The time integration in words (for study summaries)."""
        tolerance = self.tolerance
        return (
            f"{INTEGRATOR_NAMES[self.method]}, rtol {tolerance.rtol:g}, atol {tolerance.atol:g}, "
            "joints projected after every step"
        )

    def tightened(self, factor: float | None = None) -> MechanismModel:
        """The same model with both tolerances divided by ``factor`` (default the
        tolerance's tightening; for the study's check of the time integration)."""
        tight = copy.copy(self)
        tight.tolerance = self.tolerance.tightened(factor)
        return tight

    def sample_parameters(self, samples: Mapping[str, Any]) -> list[dict[str, float]]:
        """One parameter dict per sample: the defaults overridden by the sample's columns."""
        unknown = sorted(set(samples) - set(self.defaults))
        if unknown:
            raise InvalidParameterError(
                f"unknown parameter(s) {unknown}; this model takes {sorted(self.defaults)}"
            )
        columns = {
            name: np.atleast_1d(np.asarray(value, dtype=float)) for name, value in samples.items()
        }
        sizes = {column.shape for column in columns.values()}
        if len(sizes) > 1 or any(len(size) != 1 for size in sizes):
            raise InvalidParameterError(
                f"sample columns must be 1-D and of one length, got {sizes}"
            )
        count = next(iter(sizes))[0] if sizes else 1
        for name, column in columns.items():
            if not np.isfinite(column).all():
                raise InvalidParameterError(f"parameter {name!r} has non-finite values")
        return [
            {**self.defaults, **{n: float(c[i]) for n, c in columns.items()}} for i in range(count)
        ]

    @property
    def differentiable(self) -> tuple[str, ...]:
        """Parameters ``model(samples, wrt=...)`` differentiates with respect to: all."""
        return self.parameters

    #: runs per parameter differentiated, as a fraction of the run without (a study's
    #: ``gradients = "auto"`` weighs it): the central difference's two replayed runs
    gradient_cost = GRADIENT_COST

    def run(self, samples: Mapping[str, Any], **options: Any) -> Any:
        """Simulate every sample; the engine's raw result (``PlanarResult``, ``SpatialResult``).
        ``options`` go to the engine's ``simulate`` (``log_steps``, ``step_sequences``)."""
        return self._simulate(self.sample_parameters(samples), **options)

    def _simulate(self, parameters: list[dict[str, float]], **options: Any) -> Any:
        """The engine's result for one parameter dict per sample."""
        mechanisms = [self.build(p) for p in parameters]
        engines = {getattr(m, "engine", None) for m in mechanisms}
        if engines == {"planar"}:
            simulate = planar.simulate
        elif engines == {"spatial"}:
            simulate = spatial.simulate
        else:
            raise InvalidParameterError(
                "build must return a planar or a spatial Mechanism, the same kind for every "
                f"sample; got {sorted(map(str, engines))}"
            )
        tolerance = self.tolerance
        return simulate(
            mechanisms,
            self.times,
            rtol=tolerance.rtol,
            atol=tolerance.atol,
            method=self.method,
            **options,
        )

    def __call__(
        self, samples: Mapping[str, Any], wrt: Sequence[str] | None = None
    ) -> dict[str, NDArray]:
        """Outputs ``{name: (B, T)}``, with ``failed`` and ``failure_reason`` per sample; with
        ``wrt`` (parameter names) also ``"gradients": {name: (B, T, len(wrt))}``, in the
        output's unit per the parameter's. The outputs are bit for bit the same with or
        without ``wrt``; a sample whose perturbed runs fail is flagged failed, saying which."""
        names = checked_wrt(wrt, self.parameters) or ()
        parameters = self.sample_parameters(samples)
        result = self._simulate(parameters, log_steps=bool(names))
        outputs: dict[str, Any] = {}
        for name, (reader, _) in self.readers.items():
            outputs[name] = np.asarray(reader(result), dtype=float)
        failed = np.array(result.failed, dtype=bool)
        reasons = [result.failure(i) or "" for i in range(failed.size)]
        if names:
            logs = result.step_logs

            def replayed(perturbed: list[dict[str, float]], owners: list[int]) -> tuple:
                runs = self._simulate(perturbed, step_sequences=[logs[s] for s in owners])
                values = {name: reader(runs) for name, (reader, _) in self.readers.items()}
                return values, runs.failed, [runs.failure(i) for i in range(len(perturbed))]

            own = {name: outputs[name] for name in self.readers}
            gradients, failures = central_differences(
                own, failed, parameters, names, replayed, self.gradient_steps
            )
            failed, reasons = with_failures(failed, reasons, failures)
            outputs["gradients"] = gradients
        outputs["failed"] = failed
        outputs["failure_reason"] = np.array(reasons, dtype=object)
        return outputs
