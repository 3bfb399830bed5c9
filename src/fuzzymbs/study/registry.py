"""Registry of models a study file can name.

Built-in models register themselves when their package is imported; the
registry imports the built-in packages on first lookup. A user model is named
``"package.module:callable"`` instead, where the callable takes the model
options as keyword arguments and returns a batched model.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from fuzzymbs.errors import InvalidParameterError

#: Packages whose import registers the built-in models.
BUILTIN_PACKAGES: tuple[str, ...] = (
    "fuzzymbs.models.closed_form",
    "fuzzymbs.models.gears",
    "fuzzymbs.models.brake",
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
    """

    name: str
    factory: Callable[..., Any]
    parameters: Mapping[str, ParameterInfo]
    outputs: Mapping[str, str]
    description: str
    options: Mapping[str, str] = field(default_factory=dict)


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
_builtins_loaded = False


def register_model(
    name: str,
    factory: Callable[..., Any] | str,
    *,
    parameters: Mapping[str, ParameterInfo],
    outputs: Mapping[str, str],
    description: str,
    options: Mapping[str, str] | None = None,
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
    )
    _REGISTRY[name] = spec
    return spec


def _load_builtins() -> None:
    global _builtins_loaded
    if _builtins_loaded:
        return
    _builtins_loaded = True
    for package in BUILTIN_PACKAGES:
        importlib.import_module(package)


def available_models() -> dict[str, ModelSpec]:
    """All registered models, built-ins included, by name."""
    _load_builtins()
    return dict(sorted(_REGISTRY.items()))


def get_model(name: str) -> ModelSpec:
    """Look up a registered model by name.

    Raises
    ------
    InvalidParameterError
        If no model of that name is registered; the message lists the known ones.
    """
    _load_builtins()
    try:
        return _REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(_REGISTRY)) or "(none)"
        raise InvalidParameterError(
            f"unknown model {name!r}; registered models are: {known}; "
            "a user model is named 'package.module:callable'"
        ) from None


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
