"""Identification files: inverse fuzzy arithmetic from TOML (``fuzzymbs identify``).

Layout (see docs/fuzzy.md, "Inverse fuzzy arithmetic")::

    [identify]   name, description, levels, tolerance, nonmonotonic ("auto" or a list),
                 on_mismatch ("raise" | "warn"), max_iterations
    [model]      name (a registered model or "package.module:callable", which needs
                 --allow-code as in a study file), [model.options]
    [modal]      parameter = starting value of the crisp solution (one per parameter
                 to identify)
    [bounds]     parameter = [lower, upper]: admissible range (optional)
    [parameters] parameter = number: crisp values of the model's other parameters (optional)
    [measured]   output = fuzzy number, as a study file's parameters
                 ({type = "triangular", lower = .., modal = .., upper = ..}, ...)

:func:`run_identification_file` writes ``identified.toml`` (the identified
parameters as a ``[parameters]`` table for a study file), ``identified.nc``
(cuts, measured and reproduced outputs, residuals), ``summary.txt`` and
membership plots.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from fuzzymbs.errors import (
    InvalidFuzzyNumberError,
    InvalidParameterError,
    StudyFileError,
)
from fuzzymbs.fuzzy.inverse import DEFAULT_MAX_ITERATIONS, DEFAULT_TOLERANCE, InverseResult

__all__ = ["IdentificationOutput", "load_identification_file", "run_identification_file"]


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class IdentifySection(_Section):
    """``[identify]``: how to identify."""

    name: str | None = None
    description: str = ""
    levels: int | list[float] = 4
    tolerance: float = Field(default=DEFAULT_TOLERANCE, gt=0.0, allow_inf_nan=False)
    nonmonotonic: list[str] | Literal["auto"] = "auto"
    on_mismatch: Literal["raise", "warn"] = "raise"
    max_iterations: int = Field(default=DEFAULT_MAX_ITERATIONS, ge=1)


class ModelSection(_Section):
    """``[model]``: which model and its factory options."""

    name: str
    options: dict[str, Any] = Field(default_factory=dict)


class IdentificationFileModel(_Section):
    """The whole identification file."""

    identify: IdentifySection = Field(default_factory=IdentifySection)
    model: ModelSection
    modal: dict[str, float | int]
    bounds: dict[str, list[float | int]] = Field(default_factory=dict)
    parameters: dict[str, float | int] = Field(default_factory=dict)
    measured: dict[str, Any]


@dataclass
class IdentificationDefinition:
    """A loaded identification file: the model and the inverse problem's data."""

    path: Path
    name: str
    description: str
    model: Any  # the batched model with the crisp parameters filled in
    measured: dict[str, Any]
    modal: dict[str, float]
    bounds: dict[str, tuple[float, float]]
    options: dict[str, Any] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)


@dataclass
class IdentificationOutput:
    """What :func:`run_identification_file` wrote."""

    directory: Path
    result: InverseResult
    toml_path: Path
    result_path: Path
    summary_path: Path
    plots: list[Path]


class _WithConstants:
    """The model with the crisp parameters (given or default) added to every call."""

    def __init__(self, model: Any, constants: Mapping[str, float]) -> None:
        self.model = model
        self.constants = dict(constants)

    def __call__(self, samples: Mapping[str, np.ndarray]) -> Mapping[str, Any]:
        size = len(next(iter(samples.values())))
        columns = {name: np.full(size, value) for name, value in self.constants.items()}
        return self.model({**columns, **samples})


def _fail(path: Path, message: str) -> StudyFileError:
    return StudyFileError(f"{path}: {message}")


def load_identification_file(
    path: str | Path, allow_code: bool = False
) -> IdentificationDefinition:
    """Read and check an identification file (layout in the module docstring).

    Raises
    ------
    StudyFileError
        Malformed TOML, unknown keys, unknown model or parameter names, bad fuzzy
        numbers or bounds; the message names the file and the key.
    UntrustedCodeError
        A ``"package.module:callable"`` model without ``allow_code`` (nothing imported).
    """
    from fuzzymbs.study.parameters import fuzzy_number_from_definition
    from fuzzymbs.study.planning import declared_parameters, resolve_model
    from fuzzymbs.study.registry import get_model
    from fuzzymbs.study.studyfile import describe_validation_error, resolve_option_paths
    from fuzzymbs.study.trust import check_study_code

    path = Path(path)
    try:
        with path.open("rb") as handle:
            raw = tomllib.load(handle)
    except FileNotFoundError:
        raise _fail(path, "identification file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise _fail(path, f"not valid TOML: {exc}") from None
    try:
        parsed = IdentificationFileModel.model_validate(raw)
    except ValidationError as exc:
        raise StudyFileError(
            "; ".join(describe_validation_error(path, e) for e in exc.errors())
        ) from None
    if not parsed.modal:
        raise _fail(path, "[modal] is empty; give a starting value per parameter to identify")
    if not parsed.measured:
        raise _fail(path, "[measured] is empty; give the observed outputs as fuzzy numbers")
    model_name = parsed.model.name
    options = resolve_option_paths(path, model_name, parsed.model.options)
    runs_code = False
    spec = None
    if ":" not in model_name:
        try:
            spec = get_model(model_name)
        except InvalidParameterError as exc:
            raise _fail(path, f"key 'model.name': {exc}") from exc
        runs_code = spec.runs_code
    check_study_code(path, model_name, options, runs_code, allow_code, command="identify")
    try:
        resolved = resolve_model(model_name, options)
    except InvalidParameterError as exc:
        raise _fail(path, f"[model]: {exc}") from exc
    declared = (
        dict(spec.parameters)
        if spec is not None and not spec.dynamic
        else declared_parameters(resolved.model)
    )
    names = list(parsed.modal)
    for section, keys in (("modal", names), ("parameters", list(parsed.parameters))):
        for key in keys:
            if declared is not None and key not in declared:
                valid = ", ".join(f"{n} [{info.unit}]" for n, info in declared.items())
                raise _fail(
                    path,
                    f"key '{section}.{key}': model {model_name!r} has no parameter {key!r}; "
                    f"valid parameters: {valid}",
                )
            value = (parsed.modal if section == "modal" else parsed.parameters)[key]
            if not math.isfinite(value):
                raise _fail(path, f"key '{section}.{key}': value must be finite, got {value!r}")
    overlap = sorted(set(names) & set(parsed.parameters))
    if overlap:
        raise _fail(path, f"{overlap} are both identified ([modal]) and crisp ([parameters])")
    constants = {name: float(value) for name, value in parsed.parameters.items()}
    for name, info in (declared or {}).items():
        if name in names or name in constants:
            continue
        if info.default is None:
            raise _fail(
                path,
                f"parameter {name!r} of model {model_name!r} has no default: give it in "
                "[modal] (to identify) or [parameters] (crisp)",
            )
        constants[name] = float(info.default)
    bounds = {}
    for name, pair in parsed.bounds.items():
        if name not in parsed.modal:
            raise _fail(path, f"key 'bounds.{name}': not a parameter in [modal] ({names})")
        if len(pair) != 2:
            raise _fail(path, f"key 'bounds.{name}': expected [lower, upper], got {pair!r}")
        bounds[name] = (float(pair[0]), float(pair[1]))
    measured = {}
    for name, definition in parsed.measured.items():
        if not isinstance(definition, dict):
            raise _fail(
                path,
                f"key 'measured.{name}': expected a fuzzy number table like "
                f'{{type = "triangular", lower = 1.0, modal = 2.0, upper = 3.0}}, '
                f"got {definition!r}",
            )
        try:
            measured[name] = fuzzy_number_from_definition(definition, name)
        except (InvalidFuzzyNumberError, InvalidParameterError) as exc:
            raise _fail(path, f"key 'measured.{name}': {exc}") from exc
    units = {name: info.unit for name, info in (declared or {}).items()}
    return IdentificationDefinition(
        path=path,
        name=parsed.identify.name or path.stem,
        description=parsed.identify.description,
        model=_WithConstants(resolved.model, constants),
        measured=measured,
        modal={name: float(value) for name, value in parsed.modal.items()},
        bounds=bounds,
        options={
            "levels": parsed.identify.levels,
            "tolerance": parsed.identify.tolerance,
            "nonmonotonic": parsed.identify.nonmonotonic,
            "on_mismatch": parsed.identify.on_mismatch,
            "max_iterations": parsed.identify.max_iterations,
        },
        units=units,
    )


def identified_toml(result: InverseResult) -> str:
    """The identified parameters as a study file's ``[parameters]`` table (piecewise)."""

    def numbers(values: np.ndarray) -> str:
        return "[" + ", ".join(repr(float(v)) for v in values) + "]"

    lines = [
        "# identified by inverse fuzzy arithmetic (fuzzymbs identify); paste into a study file",
        f"# method {result.method}, largest residual {result.max_residual:.3g} of the measured "
        f"widths, converged: {str(result.converged).lower()}",
        "[parameters]",
    ]
    for name, number in result.parameters.items():
        cuts = number.cuts(result.levels)
        lines.append(
            f'{name} = {{ type = "piecewise", levels = {numbers(result.levels)}, '
            f"lower = {numbers(cuts[:, 0])}, upper = {numbers(cuts[:, 1])} }}"
        )
    return "\n".join(lines) + "\n"


def run_identification_file(
    path: str | Path,
    out: str | Path,
    *,
    plots: bool = True,
    allow_code: bool = False,
) -> IdentificationOutput:
    """Identify the fuzzy parameters of an identification file and write the results.

    Writes ``out/identified.toml``, ``out/identified.nc``, ``out/summary.txt`` and,
    with ``plots``, ``out/parameters.png`` and ``out/outputs.png``.

    Raises
    ------
    StudyFileError, UntrustedCodeError
        From :func:`load_identification_file`.
    InverseProblemError, InverseMismatchError
        From :func:`fuzzymbs.fuzzy.inverse.inverse`; a mismatch still writes the
        best fit (``identified.nc``, ``summary.txt``) before it is raised.
    """
    from fuzzymbs.errors import InverseMismatchError
    from fuzzymbs.fuzzy.inverse import inverse
    from fuzzymbs.study.result import netcdf_engine

    definition = load_identification_file(path, allow_code=allow_code)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InvalidParameterError(f"output folder {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    mismatch: InverseMismatchError | None = None
    try:
        result = inverse(
            definition.model,
            definition.measured,
            definition.modal,
            bounds=definition.bounds,
            **definition.options,
        )
    except InverseMismatchError as exc:
        mismatch = exc
        result = exc.result  # type: ignore[assignment]
    dataset = result.to_dataset(definition.name, definition.units)
    dataset.attrs["description"] = definition.description
    # the model's output units label the figures (engineering units, e.g. um for m)
    output_units = getattr(definition.model.model, "outputs", None) or {}
    dataset.attrs["output_units"] = json.dumps(
        {o: str(u) for o, u in dict(output_units).items() if o in definition.measured}
    )
    dataset.attrs["identification_file"] = str(definition.path)
    result_path = out / "identified.nc"
    dataset.to_netcdf(result_path, engine=netcdf_engine())
    toml_path = out / "identified.toml"
    toml_path.write_text(identified_toml(result), encoding="utf-8")
    summary_path = out / "summary.txt"
    summary_path.write_text(
        f"{definition.name}: {definition.description}\n{result.summary()}\n", encoding="utf-8"
    )
    written: list[Path] = []
    if plots:
        from fuzzymbs.plot import plot_input_memberships, plot_inverse_outputs, save_figure

        written += save_figure(plot_input_memberships(dataset), out, "parameters", ("png",))
        written += save_figure(plot_inverse_outputs(dataset), out, "outputs", ("png",))
    if mismatch is not None:
        raise mismatch
    return IdentificationOutput(out, result, toml_path, result_path, summary_path, written)
