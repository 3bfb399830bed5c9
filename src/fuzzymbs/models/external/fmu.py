"""A Functional Mock-up Unit (FMI 2.0 or 3.0) as a batched fuzzymbs model, through FMPy.

The FMU's variables are the model's parameters and outputs, by name, checked
against its ``modelDescription.xml``: a fuzzy (or crisp) parameter must be a
real variable of causality ``parameter`` that can be set (variability fixed or
tunable); an output is any numeric variable of causality ``output`` and is
recorded on the time grid ``start_time, start_time + output_interval, ...,
stop_time`` as a time signal (coordinate ``time``).

Each process (or Dask worker thread) extracts and instantiates the FMU once,
on its first sample, and resets the instance between samples (FMI
``Reset``); an instance left in an error state is freed and instantiated
again. A sample whose simulation fails is flagged failed with FMPy's message
and the FMU's last log messages; the other samples of the batch are kept.

FMPy is an optional dependency: ``pip install "fuzzymbs[fmu]"``.
"""

from __future__ import annotations

import atexit
import hashlib
import math
import shutil
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.study.registry import ParameterInfo

__all__ = ["FmuDescription", "FmuModel", "describe_fmu", "make_fmu_model"]

#: FMI types whose values are reals (the only ones that can be fuzzy)
REAL_TYPES = ("Real", "Float64", "Float32")
#: FMI types an output may have (recorded as float64)
NUMERIC_TYPES = (
    *REAL_TYPES,
    "Integer",
    "Enumeration",
    "Boolean",
    *(f"{sign}Int{bits}" for sign in ("", "U") for bits in (8, 16, 32, 64)),
)
#: ``interface`` option -> FMPy's ``fmi_type``
INTERFACES = {"co-simulation": "CoSimulation", "model-exchange": "ModelExchange"}
#: default relative tolerance of the model-exchange solver (CVODE) and of co-simulation FMUs
DEFAULT_SOLVER_TOLERANCE = 1e-6
#: log messages of a failed sample quoted in its failure reason
LOG_LINES = 5


def _require_fmpy() -> Any:
    try:
        import fmpy
    except ImportError as exc:
        raise InvalidParameterError(
            'FMU models need FMPy: pip install "fuzzymbs[fmu]" (or pip install fmpy)'
        ) from exc
    return fmpy


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _unit(variable: Any) -> str:
    unit = getattr(variable, "unit", None)
    if not unit and getattr(variable, "declaredType", None) is not None:
        unit = getattr(variable.declaredType, "unit", None)
    return str(unit or "1")


@dataclass(frozen=True)
class FmuVariable:
    """One variable of an FMU's model description, as fuzzymbs sees it."""

    name: str
    type: str
    causality: str
    variability: str
    unit: str
    description: str
    start: float | None


@dataclass(frozen=True)
class FmuDescription:
    """What an FMU offers: its FMI version, interfaces, parameters and outputs.

    ``parameters`` are the settable real parameters (those that can be fuzzy);
    ``variables`` every variable by name (for explaining refusals).
    """

    path: Path
    fmi_version: str
    model_name: str
    interfaces: tuple[str, ...]
    parameters: dict[str, FmuVariable]
    outputs: dict[str, FmuVariable]
    variables: dict[str, FmuVariable] = field(repr=False)
    default_experiment: dict[str, float] = field(default_factory=dict)

    def lines(self) -> list[str]:
        """A readable listing for ``fuzzymbs info path/to/model.fmu``."""
        lines = [
            f"FMU {self.path.name}: {self.model_name} (FMI {self.fmi_version}; "
            f"{', '.join(self.interfaces)})",
            "  parameters (settable reals; fuzzy or crisp in a study):",
        ]
        for name, variable in self.parameters.items():
            start = "" if variable.start is None else f" (start {variable.start:g})"
            text = f": {variable.description}" if variable.description else ""
            lines.append(f"    {name} [{variable.unit}]{text}{start}")
        lines.append("  outputs (time signals over 'time'):")
        for name, variable in self.outputs.items():
            text = f": {variable.description}" if variable.description else ""
            lines.append(f"    {name} [{variable.unit}]{text}")
        if self.default_experiment:
            experiment = ", ".join(f"{k} = {v:g}" for k, v in self.default_experiment.items())
            lines.append(f"  default experiment: {experiment}")
        return lines


def describe_fmu(path: str | Path) -> FmuDescription:
    """Read an FMU's model description.

    Raises
    ------
    InvalidParameterError
        The file does not exist or is not an FMU FMPy can read (FMI 2.0 or 3.0).
    """
    fmpy = _require_fmpy()
    path = Path(path)
    if not path.is_file():
        raise InvalidParameterError(f"FMU {path} not found")
    try:
        description = fmpy.read_model_description(str(path), validate=False)
    except Exception as exc:  # FMPy raises plain Exceptions for broken archives
        raise InvalidParameterError(f"{path} is not a readable FMU: {exc}") from exc
    version = str(description.fmiVersion)
    if not version.startswith(("2.", "3.")):
        raise InvalidParameterError(
            f"{path} is an FMI {version} FMU; fuzzymbs supports FMI 2.0 and 3.0"
        )
    interfaces = tuple(
        label
        for label, attribute in (
            ("co-simulation", "coSimulation"),
            ("model-exchange", "modelExchange"),
        )
        if getattr(description, attribute, None) is not None
    )
    variables: dict[str, FmuVariable] = {}
    for variable in description.modelVariables:
        start = variable.start
        try:
            start_value = None if start is None else float(start)
        except (TypeError, ValueError):
            start_value = None
        variables[variable.name] = FmuVariable(
            name=variable.name,
            type=str(variable.type),
            causality=str(variable.causality),
            variability=str(variable.variability),
            unit=_unit(variable),
            description=str(variable.description or ""),
            start=start_value,
        )
    parameters = {
        name: v
        for name, v in variables.items()
        if v.causality == "parameter"
        and v.variability in ("fixed", "tunable")
        and v.type in REAL_TYPES
    }
    outputs = {
        name: v
        for name, v in variables.items()
        if v.causality == "output" and v.type in NUMERIC_TYPES
    }
    experiment = {}
    default = getattr(description, "defaultExperiment", None)
    if default is not None:
        for key in ("startTime", "stopTime", "stepSize", "tolerance"):
            value = getattr(default, key, None)
            if value is not None:
                experiment[key] = float(value)
    return FmuDescription(
        path=path,
        fmi_version=version,
        model_name=str(description.modelName),
        interfaces=interfaces,
        parameters=parameters,
        outputs=outputs,
        variables=variables,
        default_experiment=experiment,
    )


def _log_message(*args: Any) -> None:
    """The FMU logger of every instance: appends to the calling thread's log.

    FMPy passes FMI 2.0 log messages through one process-wide proxy that keeps
    only the logger registered last, so a logger per instance would see other
    instances' messages. An FMU logs on the thread that called it, and a thread
    runs one sample at a time, so the thread's log is the running sample's.
    """
    # FMI 2.0: (environment, instance name, status, category, message); 3.0 drops the name
    status, message = args[-3], args[-1]
    text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
    label = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"][int(status)]
    log = _thread_log()
    log.append(f"[{label}] {text}")
    del log[:-LOG_LINES]


def _thread_log() -> list[str]:
    """The last :data:`LOG_LINES` FMU messages logged on this thread."""
    log: list[str] | None = getattr(_local, "log", None)
    if log is None:
        log = _local.log = []
    return log


class _Loaded:
    """An extracted FMU and its instance in one process and thread."""

    def __init__(self, model: FmuModel) -> None:
        fmpy = _require_fmpy()
        self.fmpy = fmpy
        self.directory = fmpy.extract(str(model.path))
        self.description = fmpy.read_model_description(self.directory, validate=False)
        self.fmi_type = model.fmi_type
        self.instance = self._instantiate()

    @property
    def log(self) -> list[str]:
        """This thread's recent FMU messages (cleared before each sample)."""
        return _thread_log()

    def _instantiate(self) -> Any:
        return self.fmpy.instantiate_fmu(
            self.directory, self.description, self.fmi_type, logger=_log_message
        )

    def renew(self) -> None:
        """Free an instance that failed and create a fresh one."""
        try:
            self.instance.freeInstance()
        except Exception:  # an instance in error state may refuse; a new one replaces it
            pass
        self.instance = self._instantiate()

    def close(self) -> None:
        try:
            self.instance.freeInstance()
        except Exception:  # at exit: nothing left to report to
            pass
        shutil.rmtree(self.directory, ignore_errors=True)


_local = threading.local()
_all_loaded: list[_Loaded] = []
_lock = threading.Lock()


@atexit.register
def _close_all() -> None:
    with _lock:
        while _all_loaded:
            _all_loaded.pop().close()


def _loaded(model: FmuModel) -> _Loaded:
    """This thread's instance of ``model``'s FMU (created on first use)."""
    cache: dict[tuple[str, str], _Loaded] = getattr(_local, "cache", None) or {}
    _local.cache = cache
    key = (model.digest, model.fmi_type)
    if key not in cache:
        cache[key] = _Loaded(model)
        with _lock:
            _all_loaded.append(cache[key])
    return cache[key]


class FmuModel:
    """A batched model that simulates an FMU once per sample.

    Parameters
    ----------
    path : str or Path
        The ``.fmu`` file.
    stop_time : float
        End of the simulation [s].
    output_interval : float
        Spacing of the recorded time grid [s]; ``stop_time - start_time`` must
        be a whole multiple of it.
    start_time : float
        Start of the simulation [s] (default 0).
    step_size : float, optional
        Model exchange: the fixed step of FMPy's explicit Euler solver (without
        it, the variable-step CVODE solver at ``solver_tolerance`` integrates).
        Co-simulation: the communication step (default ``output_interval``);
        ``output_interval`` must be a whole multiple of it.
    solver_tolerance : float
        Relative tolerance of CVODE (model exchange), passed to a co-simulation
        FMU as its tolerance (default 1e-6).
    interface : {"auto", "co-simulation", "model-exchange"}
        Which interface of the FMU to use; "auto": co-simulation if the FMU
        has it, else model exchange.
    outputs : sequence of str, optional
        FMU output variables to record (default: every output).

    Raises
    ------
    InvalidParameterError
        Missing FMPy, a missing or unreadable FMU, an FMI version other than 2.0
        or 3.0, an interface the FMU lacks, an inconsistent time grid, or unknown
        output names.
    """

    #: what the study's time-integration check reports
    time_integration: str

    def __init__(
        self,
        path: str | Path,
        stop_time: float,
        output_interval: float,
        start_time: float = 0.0,
        step_size: float | None = None,
        solver_tolerance: float = DEFAULT_SOLVER_TOLERANCE,
        interface: str = "auto",
        outputs: list[str] | None = None,
    ) -> None:
        self.path = Path(path).resolve()
        self.description = describe_fmu(self.path)
        for label, value in (
            ("stop_time", stop_time),
            ("output_interval", output_interval),
            ("start_time", start_time),
            ("solver_tolerance", solver_tolerance),
        ):
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InvalidParameterError(f"FMU option {label} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise InvalidParameterError(f"FMU option {label} must be finite, got {value!r}")
        if not stop_time > start_time:
            raise InvalidParameterError(
                f"FMU option stop_time = {stop_time!r} must be after start_time = {start_time!r}"
            )
        if not output_interval > 0.0:
            raise InvalidParameterError(
                f"FMU option output_interval must be positive, got {output_interval!r}"
            )
        if not solver_tolerance > 0.0:
            raise InvalidParameterError(
                f"FMU option solver_tolerance must be positive, got {solver_tolerance!r}"
            )
        intervals = (stop_time - start_time) / output_interval
        if abs(intervals - round(intervals)) > 1e-9 * max(1.0, intervals):
            raise InvalidParameterError(
                f"FMU options: stop_time - start_time = {stop_time - start_time!r} must be a "
                f"whole multiple of output_interval = {output_interval!r}"
            )
        if step_size is not None:
            if isinstance(step_size, bool) or not isinstance(step_size, int | float):
                raise InvalidParameterError(
                    f"FMU option step_size must be a number, got {step_size!r}"
                )
            if not (math.isfinite(step_size) and step_size > 0.0):
                raise InvalidParameterError(
                    f"FMU option step_size must be positive, got {step_size!r}"
                )
            ratio = output_interval / step_size
            if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
                raise InvalidParameterError(
                    f"FMU options: output_interval = {output_interval!r} must be a whole "
                    f"multiple of step_size = {step_size!r}"
                )
        available = self.description.interfaces
        if interface == "auto":
            chosen = available[0] if available else ""
        elif interface in INTERFACES:
            if interface not in available:
                raise InvalidParameterError(
                    f"FMU {self.path.name} has no {interface} interface; it offers: "
                    f"{', '.join(available) or '(none)'}"
                )
            chosen = interface
        else:
            raise InvalidParameterError(
                f"FMU option interface = {interface!r}; allowed: auto, {', '.join(INTERFACES)}"
            )
        if not chosen:
            raise InvalidParameterError(f"FMU {self.path.name} declares no interface")
        self.interface = chosen
        self.fmi_type = INTERFACES[chosen]
        self.start_time = float(start_time)
        self.stop_time = float(stop_time)
        self.output_interval = float(output_interval)
        self.step_size = None if step_size is None else float(step_size)
        self.solver_tolerance = float(solver_tolerance)
        known = self.description.outputs
        if outputs is not None:
            unknown = [name for name in outputs if name not in known]
            if unknown:
                raise InvalidParameterError(
                    f"FMU {self.path.name} has no output variable(s) {unknown}; its outputs: "
                    f"{', '.join(known) or '(none)'}"
                )
        self.recorded = list(outputs) if outputs is not None else list(known)
        if not self.recorded:
            raise InvalidParameterError(f"FMU {self.path.name} declares no output variables")
        self.digest = _sha256(self.path)
        count = round((self.stop_time - self.start_time) / self.output_interval)
        self.coords = {"time": self.start_time + self.output_interval * np.arange(count + 1)}
        self.coord_units = {"time": "s"}
        self.parameters = {
            name: ParameterInfo(variable.unit, variable.description or name, variable.start)
            for name, variable in self.description.parameters.items()
        }
        self.outputs = {name: known[name].unit for name in self.recorded}
        self.output_dims = {name: ("time",) for name in self.recorded}
        if self.fmi_type == "ModelExchange":
            self.time_integration = (
                f"FMPy explicit Euler, step {self.step_size:g} s"
                if self.step_size is not None
                else f"FMPy CVODE, rtol {self.solver_tolerance:g}"
            )
        else:
            self.time_integration = (
                f"co-simulation FMU, communication step {self.step_size or self.output_interval:g} "
                f"s, tolerance {self.solver_tolerance:g}"
            )

    # ---------------------------------------------------------------- checks
    def check_parameters(self, names: list[str]) -> None:
        """Refuse parameter names that are not settable real parameters, saying why.

        Raises
        ------
        InvalidParameterError
            Naming the variable and what it is (missing, an output, an integer, ...).
        """
        variables = self.description.variables
        for name in names:
            if name in self.description.parameters:
                continue
            if name not in variables:
                valid = ", ".join(f"{n} [{v.unit}]" for n, v in self.description.parameters.items())
                raise InvalidParameterError(
                    f"FMU {self.path.name} has no variable {name!r}; its settable real "
                    f"parameters: {valid or '(none)'}"
                )
            variable = variables[name]
            if variable.causality != "parameter":
                why = f"a variable of causality {variable.causality!r}, not a parameter"
            elif variable.variability not in ("fixed", "tunable"):
                why = f"a {variable.variability} parameter, which cannot be set"
            else:
                why = f"of type {variable.type}; only real parameters can be fuzzy or set"
            raise InvalidParameterError(f"FMU {self.path.name}: variable {name!r} is {why}")

    def identity(self) -> dict[str, Any]:
        """What a result store must match besides the options: the FMU's content."""
        return {"fmu_sha256": self.digest, "fmi_type": self.fmi_type}

    def tightened(self) -> FmuModel:
        """The same FMU with a tenfold tighter tolerance (fixed steps: halved)."""
        return FmuModel(
            self.path,
            self.stop_time,
            self.output_interval,
            start_time=self.start_time,
            step_size=None if self.step_size is None else self.step_size / 2.0,
            solver_tolerance=self.solver_tolerance / 10.0,
            interface=self.interface,
            outputs=self.recorded,
        )

    def __getstate__(self) -> dict[str, Any]:
        return dict(self.__dict__)  # plain data only: instances live in _loaded's cache

    # ------------------------------------------------------------------ run
    def _simulate(self, loaded: _Loaded, start_values: dict[str, float]) -> dict[str, np.ndarray]:
        fmpy = loaded.fmpy
        model_exchange = self.fmi_type == "ModelExchange"
        step = self.step_size
        result = fmpy.simulate_fmu(
            loaded.directory,
            validate=False,
            start_time=self.start_time,
            stop_time=self.stop_time,
            solver="Euler" if model_exchange and step is not None else "CVode",
            step_size=step,
            relative_tolerance=self.solver_tolerance,
            output_interval=step
            if (not model_exchange and step is not None)
            else self.output_interval,
            record_events=False,
            fmi_type=self.fmi_type,
            start_values=start_values,
            output=self.recorded,
            model_description=loaded.description,
            fmu_instance=loaded.instance,
        )
        times = np.asarray(result["time"], dtype=float)
        grid = self.coords["time"]
        # keep the last row at repeated times (values after an event), then read the grid
        keep = np.append(np.diff(times) > 0.0, True)
        times = times[keep]
        span = grid[-1] - grid[0]
        if times[0] > grid[0] + 1e-9 * span or times[-1] < grid[-1] - 1e-9 * span:
            raise RuntimeError(
                f"the FMU simulation covered {times[0]:g} s to {times[-1]:g} s, "
                f"not the requested {grid[0]:g} s to {grid[-1]:g} s"
            )
        return {
            name: np.interp(grid, times, np.asarray(result[name], dtype=float)[keep])
            for name in self.recorded
        }

    def __call__(self, samples: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Simulate each sample; ``{output: (B, T)}`` plus ``failed`` and ``failure_reason``."""
        self.check_parameters(list(samples))
        columns = {name: np.asarray(values, dtype=float) for name, values in samples.items()}
        size = len(next(iter(columns.values()))) if columns else 0
        loaded = _loaded(self)
        outputs = {
            name: np.full((size, len(self.coords["time"])), np.nan) for name in self.recorded
        }
        failed = np.zeros(size, dtype=bool)
        reasons = np.full(size, "", dtype=object)
        starts = {name: self.description.parameters[name].start for name in columns}
        for i in range(size):
            # values equal to the FMU's start value are left alone (most parameters, usually)
            values = {
                name: float(column[i])
                for name, column in columns.items()
                if starts[name] is None or float(column[i]) != starts[name]
            }
            loaded.log.clear()
            try:
                signals = self._simulate(loaded, values)
            except Exception as exc:  # FMPy and the FMU raise plain Exceptions
                failed[i] = True
                log = "; ".join(loaded.log)
                reasons[i] = f"FMU {self.path.name}: {exc}" + (f" (FMU log: {log})" if log else "")
                loaded.renew()
                continue
            for name, signal in signals.items():
                outputs[name][i] = signal
            try:
                loaded.instance.reset()
            except Exception:  # a reset the FMU refuses: start over with a new instance
                loaded.renew()
        return {**outputs, "failed": failed, "failure_reason": reasons.astype(str)}

    def __repr__(self) -> str:
        return (
            f"FmuModel({self.path.name!r}, FMI {self.description.fmi_version} {self.interface}, "
            f"{self.start_time:g}..{self.stop_time:g} s every {self.output_interval:g} s)"
        )


def make_fmu_model(**options: Any) -> FmuModel:
    """Factory of the registered model ``fmu`` (options as in :class:`FmuModel`)."""
    if "path" not in options:
        raise InvalidParameterError("model 'fmu' needs the option path (the .fmu file)")
    for required in ("stop_time", "output_interval"):
        if required not in options:
            raise InvalidParameterError(f"model 'fmu' needs the option {required} [s]")
    return FmuModel(**options)
