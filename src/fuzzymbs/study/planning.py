"""From a study's definition to its plan: the model, its parameters and outputs, the samples.

The plan step of a study (``plan -> evaluate -> retransform -> store``):
:func:`resolve_model` turns a model name, reference or callable into the
batched model; :func:`split_parameters` checks the parameters against what the
model declares and splits them into fuzzy numbers and crisp values;
:func:`checked_outputs` checks the output selection; :func:`build_plan` makes
the sampling plan, or, for ``nonmonotonic="auto"``, the screening samples
from which the extended plan is built after the screening run.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError, InvalidPlanError, named
from fuzzymbs.fuzzy.methods import Method, method_named, option_users
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_size import DEFAULT_MAX_RUNS, check_screening_run_limit
from fuzzymbs.fuzzy.screening import DEFAULT_RTOL, Screening, check_tolerance
from fuzzymbs.fuzzy.screening import screening_samples as make_screening_samples
from fuzzymbs.fuzzy.transform import Plan
from fuzzymbs.study.options import StudyOptions
from fuzzymbs.study.parameters import fuzzy_number_from_definition
from fuzzymbs.study.registry import ModelSpec, ParameterInfo, get_model, load_callable

__all__ = [
    "AUTO",
    "ResolvedModel",
    "build_plan",
    "checked_outputs",
    "declared_parameters",
    "is_method_option",
    "resolve_model",
    "split_parameters",
]

#: ``nonmonotonic`` value asking the study to find the non-monotonic parameters itself
AUTO = "auto"


@dataclass
class ResolvedModel:
    """A study's model, resolved.

    Attributes
    ----------
    model : the batched model; name : its label in results.
    spec : the registry entry of a registered model, else None.
    factory : the factory that built it (registered or referenced models; the
        study's code record digests its source), else None.
    options : the model options as plain data.
    """

    model: Any
    name: str
    spec: ModelSpec | None
    factory: Callable[..., Any] | None
    options: dict[str, Any]


def model_label(model: Any) -> str:
    """``module.qualname`` of a model given as an object (function or instance)."""
    kind = model if hasattr(model, "__qualname__") else type(model)
    return f"{kind.__module__}.{kind.__qualname__}"


def _path_text(value: Any) -> str:
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


def resolve_model(model: str | Callable[..., Any], options: Mapping[str, Any]) -> ResolvedModel:
    """A registered name, a ``"package.module:callable"`` factory, or a batched model.

    Raises
    ------
    InvalidParameterError
        Unknown model or options, options that are not plain data, options for
        a model given as an object, or options the factory rejects.
    """
    try:  # paths become strings (an FMU's path, a template); nothing else is converted
        plain = json.loads(json.dumps(dict(options), sort_keys=True, default=_path_text))
    except TypeError as exc:
        raise InvalidParameterError(
            f"model options must be plain data (numbers, strings, lists, tables): {exc}"
        ) from None
    if isinstance(model, str):
        spec = None
        if ":" in model:
            factory = load_callable(model)
        else:
            spec = get_model(model)
            factory = spec.factory
            unknown = sorted(set(plain) - set(spec.options))
            if unknown:
                allowed = ", ".join(spec.options) or "(none)"
                raise InvalidParameterError(
                    f"model {model!r} has no option(s) {unknown}; its options: {allowed}"
                )
        try:
            built = factory(**plain)
        except TypeError as exc:
            raise InvalidParameterError(
                f"model {model!r} rejected the options {plain}: {exc}"
            ) from exc
        return ResolvedModel(built, model, spec, factory, plain)
    if callable(model):
        if plain:
            raise InvalidParameterError(
                "model_options only apply to a model given by name or 'package.module:callable'"
            )
        return ResolvedModel(model, model_label(model), None, None, plain)
    raise InvalidParameterError(
        f"model must be a registered name, 'package.module:callable' or a batched "
        f"callable, got {model!r}"
    )


def declared_parameters(model: Any) -> dict[str, ParameterInfo] | None:
    """The parameters a model object declares (``model.parameters``), if it does."""
    declared = getattr(model, "parameters", None)
    if isinstance(declared, Mapping) and all(
        isinstance(v, ParameterInfo) for v in declared.values()
    ):
        return dict(declared)
    return None


def split_parameters(
    parameters: Mapping[str, Any],
    parameter_info: Mapping[str, ParameterInfo] | None,
    model_name: str,
) -> tuple[dict[str, FuzzyNumber], dict[str, float]]:
    """Fuzzy numbers and crisp values of a study's parameters.

    ``parameters`` maps names to fuzzy numbers, study-file definitions or
    numbers. Where the model declares its parameters, unknown names are
    refused and undeclared ones take their defaults (crisp).

    Raises
    ------
    InvalidParameterError
        A value of another kind, a non-finite crisp value, an unknown name,
        a declared parameter without default and without value, or no fuzzy
        parameter at all.
    """
    fuzzy: dict[str, FuzzyNumber] = {}
    crisp: dict[str, float] = {}
    for key, value in parameters.items():
        if isinstance(value, FuzzyNumber):
            fuzzy[key] = value
        elif isinstance(value, Mapping):
            fuzzy[key] = fuzzy_number_from_definition(value, key)
        elif isinstance(value, int | float | np.number) and not isinstance(value, bool):
            if not math.isfinite(float(value)):
                raise InvalidParameterError(f"crisp parameter {key!r} must be finite")
            crisp[key] = float(value)
        else:
            raise InvalidParameterError(
                f"parameter {key!r}: expected a FuzzyNumber, a definition such as "
                f'{{"type": "triangular", "modal": 1.0, "spread": 0.1}} or a number, '
                f"got {value!r}"
            )
    if parameter_info is not None:
        unknown = [key for key in parameters if key not in parameter_info]
        if unknown:
            valid = ", ".join(f"{n} [{info.unit}]" for n, info in parameter_info.items())
            raise InvalidParameterError(
                f"unknown parameter(s) {named(unknown)} for model {model_name!r}; "
                f"valid parameters: {valid}"
            )
        for key, info in parameter_info.items():
            if key in parameters:
                continue
            if info.default is None:
                raise InvalidParameterError(
                    f"parameter {key!r} of model {model_name!r} has no default; "
                    "give it as a fuzzy number or a crisp value"
                )
            crisp[key] = float(info.default)
    if not fuzzy:
        raise InvalidParameterError("a study needs at least one fuzzy parameter")
    return fuzzy, crisp


def checked_outputs(
    outputs: Sequence[str] | None, known: Sequence[str] | None, model_name: str
) -> tuple[str, ...] | None:
    """The output selection as a tuple (None: all), checked against the model's outputs.

    Raises
    ------
    InvalidParameterError
        An empty selection, or names the model does not declare (when it declares any).
    """
    if outputs is None:
        return None
    names = [str(o) for o in outputs]
    if not names:
        raise InvalidParameterError("outputs, when given, must name at least one output")
    if known is not None:
        unknown = [o for o in names if o not in known]
        if unknown:
            raise InvalidParameterError(
                f"unknown output(s) {unknown} of model {model_name!r}; outputs: {', '.join(known)}"
            )
    return tuple(names)


def is_method_option(name: str) -> bool:
    """Whether a transformation method declares option ``name`` and the study does not hold
    it itself (``method_tolerance`` and ``max_runs`` are the study's, given on to a method
    that declares them)."""
    return bool(option_users(name)) and not StudyOptions.declares(name)


def build_plan(
    fuzzy: Mapping[str, FuzzyNumber],
    method: str | Method,
    levels: int | Sequence[float],
    nonmonotonic: Sequence[str] | str | None,
    options: StudyOptions | None = None,
    method_options: Mapping[str, Any] | None = None,
) -> tuple[Plan | None, Screening | None, float | None]:
    """``(plan, screening samples, screening tolerance)`` of a study.

    With ``nonmonotonic="auto"`` the plan is None (built after the screening)
    and the screening samples and tolerance are set; otherwise the plan is
    built now and the other two are None. ``options.max_runs`` limits the plan's runs
    (:class:`~fuzzymbs.fuzzy.transform.Plan`); for ``"auto"`` the screening
    runs plus the reduced corners the extended plan holds at least. For
    ``method="adaptive"`` the plan is a :class:`~fuzzymbs.fuzzy.transform.RoundsPlan`
    with ``max_runs`` as its run budget and ``options.method_tolerance`` as its tolerance
    (``method_tolerance`` is given to the methods that declare it). ``method_options``:
    the options of a method given by name (:func:`~fuzzymbs.fuzzy.methods.method_named`).

    Raises
    ------
    InvalidPlanError
        Options that do not go together (``"auto"`` with a method other than
        "extended", sparse options with "auto", a screening tolerance without
        "auto") or invalid plan settings.
    PlanTooLargeError
        (an InvalidPlanError) More runs than ``max_runs``, refused before any
        sample is built.
    """
    options = StudyOptions() if options is None else options
    method_options = dict(method_options or {})
    max_runs = options.max_runs
    screening_rtol = options.screening_rtol
    if isinstance(nonmonotonic, str) and nonmonotonic == AUTO:
        # the method's other options checked as for its plan
        scheme = method_named(method, **method_options)
        if not scheme.declares("nonmonotonic"):
            raise InvalidPlanError(
                f"nonmonotonic={AUTO!r} is only used by method="
                f"{' or '.join(map(repr, option_users('nonmonotonic')))}, not {scheme.name!r}"
            )
        rtol = DEFAULT_RTOL if screening_rtol is None else screening_rtol
        check_tolerance("screening_rtol", rtol)
        check_screening_run_limit(fuzzy, levels, max_runs=max_runs)
        return None, make_screening_samples(fuzzy, levels), rtol
    if screening_rtol is not None:
        raise InvalidPlanError(
            f"screening_rtol={screening_rtol!r} is only used with "
            f"nonmonotonic={AUTO!r}, not {nonmonotonic!r}"
        )
    scheme = method_named(method, nonmonotonic=nonmonotonic, **method_options)
    if options.method_tolerance is not None and scheme.declares("method_tolerance"):
        scheme = replace(scheme, method_tolerance=options.method_tolerance)
    if scheme.declares("max_runs"):  # the method's own run budget
        if max_runs is not None and max_runs != DEFAULT_MAX_RUNS:
            scheme = replace(scheme, max_runs=max_runs)
        max_runs = None
    scheme.check_bounds(len(fuzzy))  # before the plan: bounds that could never be computed
    plan = Plan(fuzzy, method=scheme, levels=levels, max_runs=max_runs)
    return plan, None, None
