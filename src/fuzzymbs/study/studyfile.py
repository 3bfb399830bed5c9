"""Study files: TOML, validated with pydantic, turned into a :class:`Study`.

Layout (see docs/studies.md)::

    [study]      name, description, method, levels, outputs, nonmonotonic (list or "auto"),
                 the study's own options as StudyOptions declares them
                 (fuzzymbs.study.options: screening_rtol, integration_tolerance,
                 integration_runs, choose_integration, shared_steps, validation_runs,
                 method_tolerance, widen_with_validation, max_runs), the method's own
                 options as it declares them (fuzzymbs.fuzzy.methods; e.g. sparse_level)
    [model]      name ("registry-name", "fmu", "command" or "package.module:callable"),
                 [model.options] (fmu, command and references need --allow-code)
    [parameters] one table (fuzzy) or number (crisp) per model parameter
    [run]        executor, chunk_size, on_failure, timeout (seconds per sample)
    [[plots.membership]]  output, coord, value

Every mistake becomes a :class:`~fuzzymbs.errors.StudyFileError` naming the
file, the key and what is allowed.
"""

from __future__ import annotations

import itertools
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model, field_validator

from fuzzymbs.errors import (
    FuzzymbsError,
    InvalidFuzzyNumberError,
    InvalidParameterError,
    InvalidPlanError,
    StudyFileError,
    UntrustedCodeError,
)
from fuzzymbs.fuzzy.methods import METHODS, method_named
from fuzzymbs.options import Declared, option_type
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.study.parameters import FUZZY_TYPES


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)  # TOML is typed: no "4" or true for 4


class _StudyFields(_Section):
    """``[study]``'s keys of what to compute (the study's and the methods' options are
    added from their declarations)."""

    name: str | None = None
    description: str = ""
    method: Literal[tuple(METHODS)] = "reduced"  # type: ignore[valid-type]
    levels: int | list[float] = 4
    outputs: list[str] | None = None
    nonmonotonic: list[str] | Literal["auto"] = Field(default_factory=list)

    @field_validator("nonmonotonic", mode="before")
    @classmethod
    def _check_nonmonotonic(cls, value: Any) -> Any:
        if value == "auto" or (
            isinstance(value, list) and all(isinstance(name, str) for name in value)
        ):
            return value
        raise ValueError(
            'nonmonotonic must be a list of parameter names (e.g. ["mass"]) or "auto" '
            "(found by a screening run; method 'extended' only)"
        )

    @field_validator("levels", mode="before")
    @classmethod
    def _check_levels_type(cls, value: Any) -> Any:
        if isinstance(value, bool) or not isinstance(value, int | list):
            raise ValueError(
                "levels must be an int >= 1 (e.g. 4) or an increasing list from 0 to 1 "
                "(e.g. [0, 0.5, 1])"
            )
        return value

    @field_validator("levels")
    @classmethod
    def _check_levels(cls, value: int | list[float]) -> int | list[float]:
        if isinstance(value, int):
            if value < 1:
                raise ValueError("levels must be an int >= 1 or an increasing list from 0 to 1")
            return value
        if len(value) < 2 or value[0] != 0.0 or value[-1] != 1.0:
            raise ValueError("an explicit levels list must start at 0 and end at 1")
        if any(b <= a for a, b in itertools.pairwise(value)):
            raise ValueError("an explicit levels list must be strictly increasing")
        return value

    @field_validator("name")
    @classmethod
    def _check_name(cls, value: str | None) -> str | None:
        if value is not None and (not value or "/" in value or "\\" in value or value in ".."):
            raise ValueError("name must be a non-empty folder name without path separators")
        return value


def _declared_field(cls: type[Declared], name: str, default: Any) -> tuple[Any, Any]:
    """A pydantic field of option ``name`` as ``cls`` declares it: its type (None where the
    declaration allows it), its limit and ``default``."""
    kind, nullable, minimum, inclusive = option_type(cls, name)
    limit: dict[str, Any] = {}
    if minimum is not None:  # ints: inclusive, as the declaration checks them
        limit = {"ge" if inclusive or kind is int else "gt": minimum}
    if kind is float:
        limit["allow_inf_nan"] = False
    return (kind | None if nullable else kind), Field(default=default, **limit)


def _study_option_fields() -> dict[str, Any]:
    """A ``[study]`` key for every study option, typed, limited and defaulted as
    :class:`~fuzzymbs.study.options.StudyOptions` declares it."""
    return {
        declared.name: _declared_field(StudyOptions, declared.name, declared.default)
        for declared in StudyOptions.options()
    }


def _method_option_fields() -> dict[str, Any]:
    """A ``[study]`` key for every method option the study does not hold itself, typed and
    limited as the method declares it (None: not given, the method's default)."""
    fields: dict[str, Any] = {}
    for cls in METHODS.values():
        for declared in cls.options():
            taken = declared.name in _StudyFields.model_fields or StudyOptions.declares(
                declared.name
            )
            if taken or declared.name in fields:
                continue
            kind, field = _declared_field(cls, declared.name, None)
            fields[declared.name] = (kind | None, field)
    return fields


#: the method options a study file passes to its method (every one a method declares)
METHOD_OPTION_KEYS: tuple[str, ...] = tuple(_method_option_fields())

StudySection = create_model(
    "StudySection",
    __base__=_StudyFields,
    __doc__="``[study]``: what to compute, the study's own options and the method's.",
    **_study_option_fields(),
    **_method_option_fields(),
)


class ModelSection(_Section):
    """``[model]``: which model and its factory options."""

    name: str
    options: dict[str, Any] = Field(default_factory=dict)


class RunSection(_Section):
    """``[run]``: how to execute."""

    executor: str = "inline"
    chunk_size: int | None = Field(default=None, gt=0)
    on_failure: Literal["raise", "fail-fast", "partial"] = "raise"
    timeout: float | None = Field(default=None, gt=0.0, allow_inf_nan=False)

    @field_validator("timeout", mode="before")
    @classmethod
    def _timeout_number(cls, value: Any) -> Any:
        if isinstance(value, int) and not isinstance(value, bool):
            return float(value)  # strict mode: an int is a valid number of seconds too
        return value

    @field_validator("executor")
    @classmethod
    def _check_executor(cls, value: str) -> str:
        from fuzzymbs.study.executors import is_remote, process_workers

        if value == "inline" or is_remote(value):  # a remote one needs --allow-code (below)
            return value
        if process_workers(value) is not None:  # raises for a bad or too large count
            return value
        raise ValueError("executor must be 'inline', 'processes[:N]' or 'dask://host:port'")


class MembershipPlot(_Section):
    """``[[plots.membership]]``: membership of an output (at a coordinate value)."""

    output: str
    coord: str | None = None
    value: float | None = None


class PlotsSection(_Section):
    """``[plots]``: extra plots."""

    membership: list[MembershipPlot] = Field(default_factory=list)


class StudyFileModel(_Section):
    """The whole study file."""

    study: StudySection = Field(default_factory=StudySection)
    model: ModelSection
    parameters: dict[str, Any]
    run: RunSection = Field(default_factory=RunSection)
    plots: PlotsSection = Field(default_factory=PlotsSection)


_SECTION_MODELS: dict[tuple[str, ...], type[BaseModel]] = {
    (): StudyFileModel,
    ("study",): StudySection,
    ("model",): ModelSection,
    ("run",): RunSection,
    ("plots",): PlotsSection,
    ("plots", "membership"): MembershipPlot,
}


@dataclass
class StudyDefinition:
    """A loaded study file: the study plus how to run and plot it."""

    path: Path
    name: str
    description: str
    study: Any  # fuzzymbs.study.study.Study
    executor: str = "inline"
    chunk_size: int | None = None
    on_failure: str = "raise"
    timeout: float | None = None
    membership_plots: list[dict[str, Any]] = field(default_factory=list)


def _key(loc: tuple[Any, ...]) -> str:
    return ".".join(str(part) for part in loc) or "(top level)"


def describe_validation_error(path: Path, error: dict[str, Any]) -> str:
    """One readable line for one schema error of a study or identification file.

    Parameters
    ----------
    path : Path
        The file, named at the start of the line.
    error : dict
        One entry of :meth:`pydantic.ValidationError.errors` (``loc``, ``type``,
        ``msg``, ``input``).

    Returns
    -------
    str
        ``"PATH: unknown key 'k' in [section]; allowed keys: ..."``, ``"PATH: missing
        required key 'k'"`` or ``"PATH: key 'k': MESSAGE (got VALUE)"``.
    """
    loc = tuple(error["loc"])
    key = _key(loc)
    if error["type"] == "extra_forbidden":
        parent = tuple(part for part in loc[:-1] if not isinstance(part, int))
        section = _SECTION_MODELS.get(parent)
        allowed = ", ".join(section.model_fields) if section else "(see docs/studies.md)"
        where = f"[{'.'.join(parent)}]" if parent else "the top level"
        return f"{path}: unknown key {key!r} in {where}; allowed keys: {allowed}"
    if error["type"] == "missing":
        return f"{path}: missing required key {key!r}"
    return f"{path}: key {key!r}: {error['msg']} (got {error.get('input')!r})"


def _parameter_definitions(path: Path, raw: dict[str, Any]) -> dict[str, Any]:
    """Check the shape of each ``[parameters.NAME]`` entry (deeper checks: fuzzy engine)."""
    definitions: dict[str, Any] = {}
    for name, value in raw.items():
        key = f"parameters.{name}"
        if isinstance(value, bool) or not isinstance(value, int | float | dict):
            raise StudyFileError(
                f"{path}: key {key!r}: expected a table like "
                '{type = "triangular", modal = 1.0, spread = 0.1} or a number, '
                f"got {value!r}"
            )
        if isinstance(value, int | float):
            if not math.isfinite(value):
                raise StudyFileError(f"{path}: key {key!r}: value must be finite, got {value!r}")
            definitions[name] = float(value)
            continue
        kind = value.get("type")
        if kind not in FUZZY_TYPES:
            raise StudyFileError(
                f"{path}: key '{key}.type': {kind!r} is not allowed; "
                f"allowed: {', '.join(FUZZY_TYPES)}"
            )
        unexpected = sorted(set(value) - {"type", *FUZZY_TYPES[kind]})
        if unexpected:
            raise StudyFileError(
                f"{path}: unknown key(s) {', '.join(f'{key}.{k}' for k in unexpected)} "
                f"for type {kind!r}; allowed: type, {', '.join(FUZZY_TYPES[kind])}"
            )
        for item, entry in value.items():
            if item == "type":
                continue
            entries = entry if isinstance(entry, list) else [entry]
            numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in entries)
            if not numeric or (isinstance(entry, list) and kind != "piecewise"):
                raise StudyFileError(
                    f"{path}: key '{key}.{item}': expected a number"
                    + (" list" if kind == "piecewise" else "")
                    + f", got {entry!r}"
                )
        definitions[name] = dict(value)
    return definitions


def resolve_option_paths(path: Path, model: str, options: dict[str, Any]) -> dict[str, Any]:
    """The model options with their file paths resolved against the file's folder.

    A relative ``path`` of the ``"fmu"`` model becomes absolute in the folder of
    ``path``, and that folder is the ``"command"`` model's ``base_dir`` (what its
    relative paths refer to) unless the options give one, so a study or
    identification file means the same from any working directory.

    Parameters
    ----------
    path : Path
        The study or identification file whose ``[model.options]`` these are.
    model : str
        The ``[model] name``.
    options : dict
        The ``[model.options]`` table as read.

    Returns
    -------
    dict
        A copy of ``options``, paths resolved; other models' options unchanged.
    """
    options = dict(options)
    folder = path.parent.resolve()
    if model == "fmu" and isinstance(options.get("path"), str):
        fmu = Path(options["path"]).expanduser()
        options["path"] = str(fmu if fmu.is_absolute() else folder / fmu)
    if model == "command":
        options.setdefault("base_dir", str(folder))
    return options


def _parse(path: Path) -> StudyFileModel:
    """The study file read and checked against its schema (nothing resolved yet).

    Raises
    ------
    StudyFileError
        The file cannot be read, is not TOML, or does not match the schema.
    """
    try:
        with path.open("rb") as handle:
            raw = tomllib.load(handle)
    except FileNotFoundError:
        raise StudyFileError(f"{path}: study file not found") from None
    except IsADirectoryError:
        raise StudyFileError(f"{path}: is a directory; give a study file (TOML)") from None
    except OSError as exc:
        raise StudyFileError(f"{path}: cannot read the study file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise StudyFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise StudyFileError(f"{path}: not valid TOML: {exc}") from None
    try:
        parsed = StudyFileModel.model_validate(raw)
    except ValidationError as exc:
        messages = [describe_validation_error(path, error) for error in exc.errors()]
        raise StudyFileError("; ".join(messages)) from None
    return parsed


def study_file_name(path: str | Path) -> str:
    """The study's name (``[study] name``, else the file's stem) from a study file checked
    against its schema, without building its model (a demo names its output folders so).

    Raises
    ------
    StudyFileError
        As :func:`load_study_file` for a file that cannot be read or is malformed.
    """
    path = Path(path)
    return _parse(path).study.name or path.stem


def load_study_file(
    path: str | Path,
    allow_code: bool = False,
    max_runs: int | None = None,
    file_executor: bool = True,
    study_options: Mapping[str, Any] | None = None,
) -> StudyDefinition:
    """Read, validate and resolve a study file.

    Parameters
    ----------
    path : str or Path
        The TOML study file.
    allow_code : bool
        Let the file run code its author named: a ``"package.module:callable"``
        model, an FMU or a program (``fuzzymbs run --allow-code``; see
        :mod:`fuzzymbs.study.trust`). Registered models never need it.
    max_runs : int, optional
        Overrides the file's ``[study] max_runs`` (``fuzzymbs run --max-runs``).
    file_executor : bool
        The file's ``[run] executor`` is used (False: the caller gives its own,
        so a Dask address in the file is neither checked nor used).
    study_options : mapping, optional
        Study options by name overriding the file's ``[study]`` ones
        (``fuzzymbs run --option NAME=VALUE``; :class:`~fuzzymbs.study.options.StudyOptions`),
        or the method's options (e.g. ``gradients``).

    Returns
    -------
    StudyDefinition
        The :class:`~fuzzymbs.study.study.Study` and its run and plot settings.

    Raises
    ------
    StudyFileError
        Malformed TOML, unknown or mistyped keys, unknown model, parameter or
        output names, or invalid fuzzy numbers; the message names the file and key.
    UntrustedCodeError
        The file names code to run, or a Dask scheduler to connect to (Dask
        exchanges pickled data, so a scheduler can run code here), and
        ``allow_code`` is False (and the user's trust file does not list the
        code); nothing has been imported, run or connected to.
    """
    from fuzzymbs.study.executors import is_remote
    from fuzzymbs.study.registry import get_model
    from fuzzymbs.study.study import Study
    from fuzzymbs.study.trust import check_study_code

    path = Path(path)
    parsed = _parse(path)
    if not parsed.parameters:
        raise StudyFileError(f"{path}: [parameters] is empty; give at least one fuzzy parameter")
    definitions = _parameter_definitions(path, parsed.parameters)

    model = parsed.model.name
    options = resolve_option_paths(path, model, parsed.model.options)
    runs_code = False
    if ":" not in model:
        try:
            runs_code = get_model(model).runs_code
        except InvalidParameterError as exc:
            raise StudyFileError(f"{path}: key 'model.name': {exc}") from exc
    check_study_code(path, model, options, runs_code, allow_code)  # before any import or run
    if file_executor and is_remote(parsed.run.executor) and not allow_code:
        raise UntrustedCodeError(
            f"{path}: key 'run.executor': {parsed.run.executor!r} connects to a Dask "
            "scheduler, which exchanges pickled data with this process (it could run code "
            f"here). If you trust this file, run it with `fuzzymbs run --allow-code {path} "
            "...`, or give the scheduler on the command line (--executor)"
        )

    name = parsed.study.name or path.stem
    auto = parsed.study.nonmonotonic == "auto"
    try:
        # the method and its options as one object (nonmonotonic = "auto" is the study's:
        # its screening names them)
        # the command line's --option NAME=VALUE: a method's option goes to the method
        command_line = dict(study_options or {})
        method_given = {key: getattr(parsed.study, key) for key in METHOD_OPTION_KEYS}
        method_given.update(
            {key: command_line.pop(key) for key in list(command_line) if key in method_given}
        )
        method = method_named(
            parsed.study.method,
            nonmonotonic=None if auto else parsed.study.nonmonotonic,
            **method_given,
        )
        given = {item.name: getattr(parsed.study, item.name) for item in StudyOptions.options()}
        given.update(command_line)
        if max_runs is not None:  # the command line's --max-runs
            given["max_runs"] = max_runs
        study = Study(
            model,
            definitions,
            method=method,
            levels=parsed.study.levels,
            outputs=parsed.study.outputs,
            model_options=options,
            nonmonotonic="auto" if auto else None,
            options=StudyOptions.given(values=given),
            name=name,
            description=parsed.study.description,
        )
    except InvalidFuzzyNumberError as exc:
        raise StudyFileError(f"{path}: [parameters]: invalid fuzzy number: {exc}") from exc
    except InvalidPlanError as exc:
        raise StudyFileError(f"{path}: [study]: {exc}") from exc
    except InvalidParameterError as exc:
        raise StudyFileError(f"{path}: {exc}") from exc
    except FuzzymbsError as exc:
        raise StudyFileError(f"{path}: {exc}") from exc

    for index, plot in enumerate(parsed.plots.membership):
        key = f"plots.membership.{index}"
        if study.output_names and plot.output not in study.output_names:
            raise StudyFileError(
                f"{path}: key '{key}.output': unknown output {plot.output!r}; "
                f"outputs of this study: {', '.join(study.output_names)}"
            )
        if (plot.coord is None) != (plot.value is None):
            raise StudyFileError(f"{path}: key {key!r}: give both coord and value, or neither")
        if (
            plot.coord is not None
            and study.output_names
            and plot.coord not in study.output_dims(plot.output)
        ):
            dims = ", ".join(study.output_dims(plot.output)) or "(none: scalar output)"
            raise StudyFileError(
                f"{path}: key '{key}.coord': output {plot.output!r} has no coordinate "
                f"{plot.coord!r}; its coordinates: {dims}"
            )

    return StudyDefinition(
        path=path,
        name=name,
        description=parsed.study.description,
        study=study,
        executor=parsed.run.executor,
        chunk_size=parsed.run.chunk_size,
        on_failure=parsed.run.on_failure,
        timeout=parsed.run.timeout,
        membership_plots=[plot.model_dump() for plot in parsed.plots.membership],
    )
