"""StudyResult: the xarray.Dataset a study produces, plus summary and I/O helpers.

Dataset layout (``o`` = output name, ``dims`` = the output's own axes)::

    coords    level (L) = mu_j, sample (N), parameter (n), model coords (time, ...)
    o_lower, o_upper               (level, *dims)   alpha-cut bounds (NaN: level incomplete)
    o_nominal                      (*dims)          output at the all-modal point
    o_reference                    (*dims)          the model's reference curve, if any
                                                    (long_name: the model's reference_labels)
    o_gain                         (parameter, level, *dims)  eta_i^(j)  [reduced/extended]
    o_mean_gain, o_absolute_influence, o_relative_influence  (parameter, *dims)
    o_samples                      (sample, *dims)  raw outputs (keep_raw)
    samples                        (sample, parameter)
    sample_failed, failure_reason  (sample)
    level_usage                    (level, sample)
    level_complete                 (level)
    parameter_lower, parameter_upper (level, parameter)  input alpha-cuts
    attrs: fuzzymbs_version, study_name, model, method, status ("complete" | "partial"),
           outputs (JSON),
           provenance (JSON: versions, plan, options, wall time, evaluations, ...);
           time-integrated models: time_integration_error (largest deviation of a
           bound from a tenfold tighter re-run of the samples that give the bounds,
           relative to the cut width), time_integration_error_peak (the modal
           sample's, relative to each output's peak), time_integration_runs,
           time_integration_worst, time_integration_tolerance, time_integration,
           time_integration_note;
           with validation runs: method_error (largest excursion of a validation run
           beyond its level's cut, relative to the cut's width), method_error_bound
           ("lower": the runs are a sample, so the method's miss is at least
           method_error), method_tolerance, validation_runs; the adaptive method:
           method_error with method_error_bound "certified" (its own estimate),
           adaptive_runs, adaptive_rounds, adaptive_status ("converged", "budget", or
           "noise": stopped by the model's own noise), adaptive_noise (that noise on
           the cut-width scale; NaN when the error never stalled) and adaptive_certify
           ("bounds" or "global")
    o_validation                   (validation, *dims)  outputs of the validation runs (kept
                                   as the raw outputs are: by default up to 64 MiB)
    o_validation_excursion         (validation)     each run's excursion / cut width
    validation_samples             (validation, parameter)
    validation_level, validation_failed  (validation)
"""

from __future__ import annotations

import json
import logging
import platform
import warnings
from collections.abc import Mapping
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from fuzzymbs.errors import (
    InvalidFuzzyNumberError,
    InvalidParameterError,
    ModelOutputError,
    ResultFileError,
    UnsupportedOperationError,
)
from fuzzymbs.study.evaluation import check_output_name
from fuzzymbs.study.integration_check import IntegrationCheck
from fuzzymbs.study.method_check import ValidationRuns, check_method
from fuzzymbs.study.store import json_safe

if TYPE_CHECKING:  # pragma: no cover
    import xarray

    from fuzzymbs.fuzzy.transform import Plan
    from fuzzymbs.study.registry import ParameterInfo
    from fuzzymbs.study.streaming import ChunkFeed

logger = logging.getLogger(__name__)


class StudyDescription(Protocol):
    """What the result dataset records of a study (:class:`~fuzzymbs.study.study.Study` meets it).

    Written out here so that the dataset is built from the study's description
    without importing the study's module: imports point one way, study -> result.
    """

    name: str
    description: str
    model: Any
    model_name: str
    model_options: dict[str, Any]
    constants: dict[str, float]
    parameter_info: dict[str, ParameterInfo] | None
    screening: dict[str, Any] | None

    @property
    def plan(self) -> Plan: ...

    @property
    def coords(self) -> dict[str, np.ndarray]: ...

    def output_dims(self, output: str) -> tuple[str, ...]: ...

    def units(self) -> dict[str, str]: ...


_VERSIONED = (
    "fuzzymbs",
    "numpy",
    "scipy",
    "numba",
    "xarray",
    "h5netcdf",
    "h5py",
    "netCDF4",
    "dask",
    "distributed",
)


def netcdf_engine() -> str:
    """The first NetCDF engine available: h5netcdf (needs h5py), netcdf4, scipy (NetCDF-3).

    ``h5netcdf`` alone cannot write without h5py (``h5netcdf[h5py]``); the
    fallbacks keep results writable on a minimal install.
    """
    import importlib.util

    if importlib.util.find_spec("h5netcdf") and importlib.util.find_spec("h5py"):
        return "h5netcdf"
    if importlib.util.find_spec("netCDF4"):
        return "netcdf4"
    return "scipy"


def import_result_modules() -> None:
    """Import what :func:`build_dataset` and :meth:`StudyResult.to_netcdf` need and load
    lazily (xarray, through it ``dask.array`` where Dask is installed, the NetCDF engine).

    A study whose runs go to other processes calls it in a thread while it waits for them
    (:class:`~fuzzymbs.study.execution.LazyExecutor`): otherwise the imports, about 0.35 s
    of a ``fuzzymbs run`` on Dask, come after the last run (docs/benchmarks.md, "Dask: two
    workers against one core").
    """
    import importlib

    import xarray

    xarray.Variable(("x",), np.zeros(1))  # xarray imports its duck-array modules here
    engine = netcdf_engine()
    for name in {"h5netcdf": ("h5py", "h5netcdf"), "netcdf4": ("netCDF4",)}.get(engine, ()):
        importlib.import_module(name)


def package_versions() -> dict[str, str]:
    """Installed versions of fuzzymbs and the packages its results depend on."""
    versions = {"python": platform.python_version()}
    for name in _VERSIONED:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return versions


def _output_layout(
    study: StudyDescription, name: str, shape: tuple[int, ...]
) -> tuple[tuple[str, ...], dict[str, np.ndarray]]:
    """Dims and coordinate values of an output's trailing axes."""
    dims = study.output_dims(name)
    coords = study.coords
    if len(dims) != len(shape):
        return tuple(f"{name}_dim{i}" for i in range(len(shape))), {}
    used = {}
    for dim, length in zip(dims, shape, strict=True):
        if dim in coords:
            if coords[dim].shape != (length,):
                logger.warning(
                    "output %r: coordinate %r has %d values for an axis of %d; left unlabelled",
                    name,
                    dim,
                    coords[dim].size,
                    length,
                )
                return tuple(f"{name}_dim{i}" for i in range(len(shape))), {}
            used[dim] = coords[dim]
    return dims, used


#: dataset variables that do not belong to one output (an output must not shadow them)
STUDY_VARIABLES = (
    "samples",
    "sample_failed",
    "failure_reason",
    "level_usage",
    "level_complete",
    "parameter_lower",
    "parameter_upper",
    "validation_samples",
    "validation_level",
    "validation_failed",
)
_OUTPUT_SUFFIXES = (
    "lower",
    "upper",
    "nominal",
    "reference",
    "samples",
    "gain",
    "mean_gain",
    "absolute_influence",
    "relative_influence",
    "validation",
    "validation_excursion",
)


def check_output_names(outputs: Mapping[str, Any]) -> None:
    """Refuse output names that are no safe variable and file names
    (:func:`~fuzzymbs.study.evaluation.check_output_name`), or whose variables would
    overwrite study variables or each other."""
    seen: dict[str, str] = {}
    for name in outputs:
        check_output_name(name)
        for suffix in _OUTPUT_SUFFIXES:
            variable = f"{name}_{suffix}"
            clash = variable in STUDY_VARIABLES or variable in seen
            if clash:
                other = seen.get(variable, "the study's own variables")
                raise ModelOutputError(
                    f"model output name {name!r} gives the dataset variable {variable!r}, "
                    f"which is already used by {other}; rename the output"
                )
            seen[variable] = f"output {name!r}"


def _json_attribute(dataset: xarray.Dataset, key: str, default: Any, path: Any) -> Any:
    text = dataset.attrs.get(key)
    if text is None:
        if default is None:
            raise ResultFileError(f"{path}: not a fuzzymbs result (no {key!r} attribute)")
        return default
    try:
        return json.loads(str(text))
    except json.JSONDecodeError as exc:
        raise ResultFileError(f"{path}: attribute {key!r} is not valid JSON ({exc})") from None


def check_result(dataset: xarray.Dataset, path: Any = "result") -> None:
    """Check a result read from a file before anything is named after its contents.

    A result file is data from anywhere: its output names become plot file
    names, so they are checked like a model's
    (:func:`~fuzzymbs.study.evaluation.check_output_name`), and every variable
    and attribute the plots and summary read must be there.

    Raises
    ------
    ResultFileError
        Names the file and what is missing or malformed.
    """
    outputs = _json_attribute(dataset, "outputs", None, path)
    if not isinstance(outputs, list) or not outputs:
        raise ResultFileError(f"{path}: attribute 'outputs' must be a non-empty list of names")
    try:
        for name in outputs:
            check_output_name(name, where=f"{path}: output")
    except ModelOutputError as exc:
        raise ResultFileError(str(exc)) from None
    needed = ["level", "sample_failed", "level_complete", "parameter_lower", "parameter_upper"]
    needed += [f"{name}_{bound}" for name in outputs for bound in ("lower", "upper")]
    missing = [name for name in needed if name not in dataset.variables]
    if missing:
        raise ResultFileError(
            f"{path}: not a complete fuzzymbs result (missing variables {missing})"
        )
    influence = _json_attribute(dataset, "influence_outputs", [], path)
    if not isinstance(influence, list) or not set(influence) <= set(outputs):
        raise ResultFileError(f"{path}: attribute 'influence_outputs' names unknown outputs")
    plots = _json_attribute(dataset, "plots", {}, path)
    membership = plots.get("membership", []) if isinstance(plots, dict) else None
    if not isinstance(membership, list):
        raise ResultFileError(f"{path}: attribute 'plots' must be {{\"membership\": [...]}}")
    for entry in membership:
        coord = entry.get("coord") if isinstance(entry, dict) else None
        value = entry.get("value") if isinstance(entry, dict) else None
        valid = (
            isinstance(entry, dict)
            and entry.get("output") in outputs
            and (coord is None) == (value is None)
            and (coord is None or (isinstance(coord, str) and coord in dataset.dims))
            and (value is None or (isinstance(value, int | float) and np.isfinite(value)))
        )
        if not valid:
            raise ResultFileError(
                f"{path}: attribute 'plots' holds an invalid membership plot {entry!r}"
            )
    for key in ("provenance", "parameter_units"):
        _json_attribute(dataset, key, {}, path)


def build_dataset(
    study: StudyDescription,
    feed: ChunkFeed,
    failed: np.ndarray,
    reasons: np.ndarray,
    *,
    wall_time: float,
    evaluated: int,
    reused: int,
    executor: str,
    chunk_size: int,
    on_failure: str,
    code: Mapping[str, Any],
    integration: IntegrationCheck | None = None,
    validation: ValidationRuns | None = None,
) -> xarray.Dataset:
    """Finish the online retransformation and assemble the result dataset (layout in the
    module doc). ``feed`` holds the reduced outputs (and the raw ones, if kept).

    ``code`` is :meth:`Study.code_version` as the run computed it (the store records the same).
    ``integration``: the study's check of its time integration (attributes
    ``time_integration_error``, ``time_integration_tolerance``, ``time_integration``,
    ``time_integration_note``), None for models without time integration.
    ``validation``: the study's validation runs (:mod:`fuzzymbs.study.method_check`):
    variables ``o_validation``, ``o_validation_excursion``, ``validation_samples``,
    ``validation_level``, ``validation_failed``, attributes ``method_error``,
    ``method_error_bound``, ``method_tolerance``, ``validation_runs``; None when the check
    is off.
    """
    import xarray

    plan = study.plan
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fuzzy = feed.results()
    bounds = {name: (result.lower.copy(), result.upper.copy()) for name, result in fuzzy.items()}
    method = None
    if validation is not None and len(validation.points):
        with warnings.catch_warnings(record=True) as caught_check:
            warnings.simplefilter("always")
            method = check_method(plan.names, plan.levels, bounds, validation)
        caught = [*caught, *caught_check]
        for w in caught_check:  # the method check's warning also reaches the caller
            warnings.warn(w.message, w.category, stacklevel=3)
    warning_texts = [str(w.message) for w in caught]
    for text in warning_texts:
        logger.warning("%s", text)
    touched = plan.levels_touched(failed)
    units = study.units()
    reference = getattr(study.model, "reference", None) or {}
    coord_units = getattr(study.model, "coord_units", None) or {}
    reference_labels = getattr(study.model, "reference_labels", None) or {}

    coords: dict[str, Any] = {
        "level": ("level", plan.levels, {"long_name": "membership level mu"}),
        "sample": np.arange(len(plan)),
        "parameter": list(plan.names),
    }
    data: dict[str, Any] = {}
    influence_outputs = []
    check_output_names(fuzzy)
    raw = feed.raw
    for name, result in fuzzy.items():
        dims, used = _output_layout(study, name, result.shape)
        for dim, values in used.items():
            unit = coord_units.get(dim)
            coords.setdefault(dim, (dim, values, {"units": unit} if unit else {}))
        attrs = {"units": units[name]} if name in units else {}
        data[f"{name}_lower"] = (("level", *dims), bounds[name][0], attrs)
        data[f"{name}_upper"] = (("level", *dims), bounds[name][1], attrs)
        kept = None if validation is None else validation.outcome.outputs
        if method is not None and kept is not None and name in kept:
            data[f"{name}_validation"] = (("validation", *dims), kept[name], attrs)
        if method is not None:
            data[f"{name}_validation_excursion"] = (
                ("validation",),
                method.excursion[name],
                {"long_name": "largest excursion beyond the level's cut / cut width"},
            )
        nominal = result.nominal if result.nominal is not None else np.full(result.shape, np.nan)
        data[f"{name}_nominal"] = (dims, nominal, attrs)
        if name in reference and np.shape(reference[name]) == result.shape:
            label = reference_labels.get(name)
            data[f"{name}_reference"] = (
                dims,
                np.asarray(reference[name], dtype=float),
                {**attrs, "long_name": label} if label else attrs,
            )
        if raw is not None:
            data[f"{name}_samples"] = (("sample", *dims), raw[name], attrs)
        if failed.any():
            continue  # influence needs every sample of every level
        try:
            influence = result.influence()
        except UnsupportedOperationError:
            continue
        influence_outputs.append(name)
        data[f"{name}_gain"] = (("parameter", "level", *dims), np.asarray(influence.gain))
        data[f"{name}_mean_gain"] = (("parameter", *dims), np.asarray(influence.mean_gain))
        data[f"{name}_absolute_influence"] = (
            ("parameter", *dims),
            np.asarray(influence.absolute),
            attrs,
        )
        data[f"{name}_relative_influence"] = (("parameter", *dims), np.asarray(influence.relative))

    data["samples"] = (("sample", "parameter"), plan.samples)
    data["sample_failed"] = (("sample",), np.asarray(failed, dtype=bool))
    data["failure_reason"] = (("sample",), np.asarray(reasons, dtype=str))
    data["level_usage"] = (("level", "sample"), np.asarray(plan.level_usage, dtype=bool))
    data["level_complete"] = (("level",), ~np.asarray(touched, dtype=bool))
    cuts = np.stack([plan.parameters[n].cuts(plan.levels) for n in plan.names], axis=1)
    data["parameter_lower"] = (("level", "parameter"), cuts[:, :, 0])
    data["parameter_upper"] = (("level", "parameter"), cuts[:, :, 1])
    if method is not None and validation is not None:
        data["validation_samples"] = (("validation", "parameter"), validation.points.samples)
        data["validation_level"] = (
            ("validation",),
            plan.levels[validation.points.level],
            {"long_name": "level whose cut the validation run is checked against"},
        )
        data["validation_failed"] = (("validation",), np.asarray(validation.failed, dtype=bool))

    status = "complete" if not failed.any() else "partial"
    provenance = {
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "versions": package_versions(),
        "code": dict(code),
        "study": study.name,
        "model": study.model_name,
        "model_options": study.model_options,
        "constants": study.constants,
        "plan": plan.to_dict(),
        "plan_fingerprint": plan.fingerprint(),
        "samples": len(plan),
        "evaluated": int(evaluated),
        "reused_from_store": int(reused),
        # the judging runs' outcomes taken from the store instead of made (judging_records.py)
        "judging_from_store": list(getattr(study, "judging_from_store", [])),
        "failed": int(np.count_nonzero(failed)),
        "executor": executor,
        "chunk_size": int(chunk_size),
        "on_failure": on_failure,
        "wall_time_s": round(float(wall_time), 6),
        "warnings": warning_texts,
    }
    if method is not None and validation is not None:
        provenance["method_check"] = {
            **method.to_provenance(),
            "evaluated": int(validation.evaluated),
            "reused_from_store": int(validation.reused),
            "failure_reasons": {
                str(i): str(validation.reasons[i]) or "non-finite output"
                for i in np.flatnonzero(validation.failed)
            },
        }
    if study.screening is not None:  # nonmonotonic="auto": what the screening found
        provenance["screening"] = study.screening
    dataset = xarray.Dataset(data, coords=coords)
    dataset.attrs.update(
        {
            "title": f"fuzzymbs study {study.name}",
            "fuzzymbs_version": str(code.get("fuzzymbs_version", "")),
            "study_name": study.name,
            "description": study.description,
            "model": study.model_name,
            "method": plan.method,
            "status": status,
            "outputs": json.dumps(list(fuzzy)),
            "influence_outputs": json.dumps(influence_outputs),
            "parameter_units": json.dumps(
                {
                    n: study.parameter_info[n].unit
                    for n in plan.names
                    if study.parameter_info and n in study.parameter_info
                }
            ),
            "provenance": json.dumps(json_safe(provenance), sort_keys=True, allow_nan=False),
            "plots": json.dumps({"membership": []}),
        }
    )
    if integration is not None:
        dataset.attrs.update(integration.to_attrs())
    if method is not None:
        dataset.attrs.update(method.to_attrs())
    if status == "partial":
        dataset.attrs["incomplete_levels"] = json.dumps(plan.levels[touched].tolist())
    return dataset


class StudyResult:
    """Result of :meth:`Study.run`: an :class:`xarray.Dataset` and helpers.

    Parameters
    ----------
    dataset : xarray.Dataset
        Layout described in :mod:`fuzzymbs.study.result`.
    """

    def __init__(self, dataset: xarray.Dataset) -> None:
        self.dataset = dataset

    def __repr__(self) -> str:
        return (
            f"StudyResult(study={self.dataset.attrs.get('study_name')!r}, "
            f"outputs={self.outputs}, status={self.status!r})"
        )

    @property
    def outputs(self) -> list[str]:
        """Names of the fuzzy outputs."""
        return json.loads(self.dataset.attrs["outputs"])

    @property
    def status(self) -> str:
        """ "complete", or "partial" when some levels could not be bounded."""
        return str(self.dataset.attrs["status"])

    @property
    def provenance(self) -> dict[str, Any]:
        """Versions, plan, options, wall time and evaluation counts."""
        return json.loads(self.dataset.attrs["provenance"])

    @property
    def failed(self) -> np.ndarray:
        """(N,) bool: samples that failed."""
        return self.dataset["sample_failed"].values.astype(bool)

    @property
    def level_complete(self) -> np.ndarray:
        """(L,) bool: levels whose bounds are known."""
        return self.dataset["level_complete"].values.astype(bool)

    def alpha_cut(self, output: str, mu: float) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of ``output`` at level ``mu`` (the next computed level up; never interpolated)."""
        if output not in self.outputs:
            raise InvalidParameterError(f"no output {output!r}; outputs: {', '.join(self.outputs)}")
        from fuzzymbs.fuzzy.retransform import cut_index

        try:
            index = cut_index(self.dataset["level"].values, mu)
        except InvalidFuzzyNumberError as exc:
            raise InvalidParameterError(str(exc)) from None
        return (
            self.dataset[f"{output}_lower"].values[index],
            self.dataset[f"{output}_upper"].values[index],
        )

    def to_netcdf(self, path: str | Path) -> Path:
        """Write the dataset as NetCDF (engine from :func:`netcdf_engine`); returns the path."""
        import os
        import tempfile

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        # a temporary name no other writer uses (process id: see store.remove_orphans)
        handle, name = tempfile.mkstemp(
            prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent
        )
        os.close(handle)
        temporary = Path(name)
        try:
            self.dataset.to_netcdf(temporary, engine=netcdf_engine())
            temporary.replace(path)
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise
        return path

    @classmethod
    def open(cls, path: str | Path) -> StudyResult:
        """Read a result written by :meth:`to_netcdf` (fully loaded, file closed) and check
        what plots and summaries read from it (:func:`check_result`).

        Raises
        ------
        ResultFileError
            The file is unreadable or not a complete fuzzymbs result (names what is wrong).
        """
        import xarray

        try:
            with xarray.open_dataset(path) as dataset:
                loaded = dataset.load()
        except Exception as exc:  # any damage: not a NetCDF file, truncated, bad encoding
            raise ResultFileError(
                f"{path}: not a readable result file ({type(exc).__name__}: {exc})"
            ) from None
        check_result(loaded, path)
        return cls(loaded)

    def summary(self) -> str:
        """A short plain-text report (see :func:`fuzzymbs.study.summary.summarize`)."""
        from fuzzymbs.study.summary import summarize

        return summarize(self.dataset)

    def plot(self, directory: str | Path, formats: tuple[str, ...] = ("png",)) -> list[Path]:
        """Write the standard plots into ``directory`` (``formats``: any of png, pdf,
        svg); returns the files written."""
        from fuzzymbs.plot import write_plots

        return write_plots(self.dataset, directory, formats=formats)
