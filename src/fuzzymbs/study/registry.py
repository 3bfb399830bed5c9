"""Registry of models a study file can name.

Built-in models register themselves when their package is imported; the
registry imports the built-in packages on first lookup. Installed packages
add models through the entry-point group ``fuzzymbs.models``: each entry
point names a module (imported) or a function (imported and called) that
calls :func:`register_model`, for example in the package's pyproject.toml::

    [project.entry-points."fuzzymbs.models"]
    my-brake = "my_package.fuzzymbs_models"

A user model is named ``"package.module:callable"`` instead, where the
callable takes the model options as keyword arguments and returns a batched
model (in a study file only with ``--allow-code``: :mod:`fuzzymbs.study.trust`).
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from fuzzymbs.errors import InvalidParameterError

logger = logging.getLogger(__name__)

#: Packages whose import registers the built-in models.
BUILTIN_PACKAGES: tuple[str, ...] = (
    "fuzzymbs.models.closed_form",
    "fuzzymbs.models.gears",
    "fuzzymbs.models.brake",
    "fuzzymbs.models.mechanisms",
    "fuzzymbs.models.external",
)


@dataclass(frozen=True)
class ParameterInfo:
    """What a model parameter is: its unit and meaning (and the paper's symbol)."""

    unit: str
    description: str
    default: float | None = None


@dataclass(frozen=True)
class ModelSpec:
    """A registered model.

    Attributes
    ----------
    name : str
        Name used in study files (``[model] name = "..."``).
    factory : callable
        ``factory(**options) -> model``; the model is callable as
        ``model({name: (B,) array}) -> {output: (B, ...) array}``.
    parameters : mapping of str to ParameterInfo
        Every parameter the model accepts as a sample column.
    outputs : mapping of str to str
        Output name -> unit.
    description : str
        One line for ``fuzzymbs info``.
    options : mapping of str to str
        Factory keyword options and a short description of each.
    dynamic : bool
        The parameters and outputs are those of the built model
        (``model.parameters``, ``model.outputs``: an FMU, an external program),
        not listed here.
    runs_code : bool
        The options name code to run (a program, an FMU's binary): a study
        file may use the model only when its user allows it (``--allow-code``).
    """

    name: str
    factory: Callable[..., Any]
    parameters: Mapping[str, ParameterInfo]
    outputs: Mapping[str, str]
    description: str
    options: Mapping[str, str] = field(default_factory=dict)
    dynamic: bool = False
    runs_code: bool = False


class LazyFactory:
    """A factory named ``"package.module:callable"``, imported on first call.

    Lets a model package register itself without importing its heavy modules
    (Numba kernels, FE assembly), so ``fuzzymbs info`` stays quick.
    """

    def __init__(self, reference: str) -> None:
        self.reference = reference

    def __call__(self, **options: Any) -> Any:
        return load_callable(self.reference)(**options)

    def __repr__(self) -> str:
        return f"LazyFactory({self.reference!r})"


_REGISTRY: dict[str, ModelSpec] = {}
_imported: set[str] = set()
_import_errors: dict[str, str] = {}


def register_model(
    name: str,
    factory: Callable[..., Any] | str,
    *,
    parameters: Mapping[str, ParameterInfo],
    outputs: Mapping[str, str],
    description: str,
    options: Mapping[str, str] | None = None,
    dynamic: bool = False,
    runs_code: bool = False,
) -> ModelSpec:
    """Register a model under ``name`` (re-registering the same name replaces it).

    Parameters
    ----------
    name : str
        Name used in study files.
    factory : callable or str
        ``factory(**options)`` returns a batched model; or a reference
        ``"package.module:callable"`` imported only when the model is built
        (see :class:`LazyFactory`).
    parameters : mapping of str to ParameterInfo
        The sample columns the model accepts, with units.
    outputs : mapping of str to str
        Output names and units.
    description : str
        One line shown by ``fuzzymbs info``.
    options : mapping of str to str, optional
        Factory keyword options and a short description of each.
    dynamic, runs_code : bool
        See :class:`ModelSpec`.
    """
    if isinstance(factory, str):
        factory = LazyFactory(factory)
    spec = ModelSpec(
        name=name,
        factory=factory,
        parameters=dict(parameters),
        outputs=dict(outputs),
        description=description,
        options=dict(options or {}),
        dynamic=dynamic,
        runs_code=runs_code,
    )
    _REGISTRY[name] = spec
    return spec


def _import_builtin(package: str) -> None:
    """Import one built-in model package (once); a broken package is logged, not fatal."""
    if package in _imported or package in _import_errors:
        return
    try:
        importlib.import_module(package)
    except Exception as exc:  # one broken model package must not disable the others
        _import_errors[package] = f"{type(exc).__name__}: {exc}"
        logger.warning("built-in model package %s failed to import: %s", package, exc)
    else:
        _imported.add(package)


#: entry-point group through which installed packages register models
ENTRY_POINT_GROUP = "fuzzymbs.models"


def _plugin_entry_points() -> list[Any]:
    from importlib.metadata import entry_points

    return list(entry_points(group=ENTRY_POINT_GROUP))


def _load_plugin(entry_point: Any) -> None:
    """Load one ``fuzzymbs.models`` entry point (once); a broken plugin is logged, not fatal."""
    key = f"entry point {entry_point.name} = {entry_point.value}"
    if key in _imported or key in _import_errors:
        return
    try:
        target = entry_point.load()
        if callable(target):
            target()
    except Exception as exc:  # one broken plugin must not disable the other models
        _import_errors[key] = f"{type(exc).__name__}: {exc}"
        logger.warning("model plugin %s failed to load: %s", key, exc)
    else:
        _imported.add(key)


def _load_builtins() -> None:
    for package in BUILTIN_PACKAGES:
        _import_builtin(package)
    for entry_point in _plugin_entry_points():
        _load_plugin(entry_point)


def available_models() -> dict[str, ModelSpec]:
    """All registered models, built-ins included, by name."""
    _load_builtins()
    return dict(sorted(_REGISTRY.items()))


def get_model(name: str) -> ModelSpec:
    """Look up a registered model by name.

    Built-in packages are imported one after another only until the name is
    found, so a study of a closed-form model does not import the gear or brake
    kernels.

    Raises
    ------
    InvalidParameterError
        If no model of that name is registered; the message lists the known ones
        (and built-in packages that failed to import).
    """
    for package in (None, *BUILTIN_PACKAGES):
        if package is not None:
            _import_builtin(package)
        if name in _REGISTRY:
            return _REGISTRY[name]
    for entry_point in _plugin_entry_points():
        _load_plugin(entry_point)
        if name in _REGISTRY:
            return _REGISTRY[name]
    known = ", ".join(sorted(_REGISTRY)) or "(none)"
    broken = "".join(
        f"; {package} failed to import ({error})" for package, error in _import_errors.items()
    )
    raise InvalidParameterError(
        f"unknown model {name!r}; registered models are: {known}; "
        f"a user model is named 'package.module:callable'{broken}"
    )


def load_callable(reference: str) -> Callable[..., Any]:
    """Import ``"package.module:callable"`` and return the callable.

    Raises
    ------
    InvalidParameterError
        If the reference is malformed, the module cannot be imported or the
        attribute is missing or not callable.
    """
    module_name, sep, attribute = reference.partition(":")
    if not sep or not module_name or not attribute:
        raise InvalidParameterError(
            f"model reference {reference!r} is not of the form 'package.module:callable'"
        )
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise InvalidParameterError(
            f"cannot import module {module_name!r} of model reference {reference!r}: {exc}"
        ) from exc
    target: Any = module
    for part in attribute.split("."):
        if not hasattr(target, part):
            raise InvalidParameterError(f"module {module_name!r} has no attribute {attribute!r}")
        target = getattr(target, part)
    if not callable(target):
        raise InvalidParameterError(f"{reference!r} is not callable")
    return target
