"""Options declared once: a frozen dataclass whose fields say type, default, range and help.

A transformation method (:mod:`fuzzymbs.fuzzy.methods`) and a study's own options
(:class:`fuzzymbs.study.options.StudyOptions`) are such dataclasses. Each field is
declared with :func:`option`; from that one declaration the values are checked (an
error naming the option and what is valid), a study file gets a typed key, and
``fuzzymbs info`` and the command line show the default and the help.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from typing import Any, ClassVar, NamedTuple

import numpy as np

from fuzzymbs.errors import InvalidParameterError

__all__ = ["Declared", "OptionInfo", "OptionType", "checked_value", "option", "option_type"]


def option(
    default: Any,
    help: str,
    *,
    must: str,
    minimum: float | None = None,
    inclusive: bool = False,
    default_text: str | None = None,
) -> Any:
    """Declare one option (a dataclass field with its description).

    Parameters
    ----------
    default : Any
        The value when the option is not given (None: chosen later, e.g. from the
        parameters; ``default_text`` says how).
    help : str
        One line for ``fuzzymbs info``, the command line and the docs.
    must : str
        What a valid value is, for the error message (``"an int >= 1"``).
    minimum : float, optional
        The smallest valid value of a number: inclusive for ints; for floats exclusive
        unless ``inclusive``.
    inclusive : bool
        A float may equal ``minimum``.
    default_text : str, optional
        How the default reads where it is not a plain value (``"a fifth of the runs"``).
    """
    metadata = {
        "help": help,
        "must": must,
        "minimum": minimum,
        "inclusive": inclusive,
        "default_text": default_text,
    }
    return dataclasses.field(default=default, metadata=metadata)


class OptionInfo(NamedTuple):
    """One declared option: what a study file, a Study, the CLI and ``fuzzymbs info`` show."""

    name: str
    type: Any
    default: Any
    help: str
    described_default: str | None = None

    def default_text(self) -> str:
        """``"default 2,000"``, ``"default 0.01"``, ``"default true"``, ``"default none"``,
        the declared wording, or ``"default chosen from the parameters"`` (for None)."""
        value = self.default
        if self.described_default is not None:
            return f"default {self.described_default}"
        if value is None:
            return "default chosen from the parameters"
        if isinstance(value, bool):
            return f"default {str(value).lower()}"
        if isinstance(value, str):
            return f'default "{value}"'
        if isinstance(value, tuple):
            return f"default {', '.join(value) or 'none'}"
        if isinstance(value, int):
            return f"default {value:,}"
        return f"default {value:g}"


class OptionType(NamedTuple):
    """What a schema checks of an option: its type (None removed), whether None is valid,
    and its smallest value (``inclusive``: the value may equal it)."""

    kind: Any
    nullable: bool
    minimum: float | None
    inclusive: bool


def _base_type(hint: Any) -> tuple[Any, bool]:
    """``(type, None allowed)`` of an option's annotation (``int | None`` -> ``(int, True)``)."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return args[0], len(args) < len(typing.get_args(hint))
    return hint, False


def option_type(cls: type, name: str) -> OptionType:
    """The type and range of option ``name`` of the declaring class ``cls``."""
    item = next(f for f in dataclasses.fields(cls) if f.name == name)
    kind, nullable = _base_type(typing.get_type_hints(cls)[name])
    return OptionType(kind, nullable, item.metadata["minimum"], item.metadata["inclusive"])


def checked_value(owner: str, name: str, value: Any, hint: Any, meta: Any, error: type) -> Any:
    """One option's value checked against its declaration (``error`` naming the option).

    ``owner`` names the declaring class in the message of an undeclared type (a
    programming error, :class:`TypeError`).
    """
    kind, nullable = _base_type(hint)
    if value is None and nullable:
        return None
    minimum = meta["minimum"]

    def bad() -> Exception:
        return error(f"{name} must be {meta['must']}, got {value!r}")

    if kind is bool:
        if not isinstance(value, bool | np.bool_):
            raise bad()
        return bool(value)
    if kind is int:
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            raise bad()
        if minimum is not None and value < minimum:
            raise bad()
        return int(value)
    if kind is float:
        if (
            isinstance(value, bool | np.bool_)
            or not isinstance(value, int | float | np.integer | np.floating)
            or not np.isfinite(value)
        ):
            raise bad()
        if minimum is not None and (
            value < minimum or (value == minimum and not meta["inclusive"])
        ):
            raise bad()
        return float(value)
    if typing.get_origin(kind) is typing.Literal:  # one of a few values (true != 1)
        for choice in typing.get_args(kind):
            same_kind = isinstance(value, bool | np.bool_) == isinstance(choice, bool)
            if same_kind and isinstance(value, str | bool | np.bool_) and value == choice:
                return choice
        raise bad()
    if typing.get_origin(kind) is tuple:  # names
        if value is None:
            return ()
        names = (value,) if isinstance(value, str) else value
        try:
            names = tuple(names)
        except TypeError:
            raise bad() from None
        if not all(isinstance(n, str) for n in names):
            raise bad()
        return names
    raise TypeError(f"option {name!r} of {owner!r}: undeclared type {hint!r}")


class Declared:
    """Base of a frozen dataclass of declared options: checks every field on creation.

    Subclasses are ``@dataclass(frozen=True)`` with fields declared by :func:`option`;
    :attr:`invalid` is the error a bad value raises (naming the option).
    """

    #: the error of a bad value
    invalid: ClassVar[type[Exception]] = InvalidParameterError

    def __post_init__(self) -> None:
        hints = typing.get_type_hints(type(self))
        for item in dataclasses.fields(self):  # type: ignore[arg-type]
            value = checked_value(
                type(self).__name__,
                item.name,
                getattr(self, item.name),
                hints[item.name],
                item.metadata,
                self.invalid,
            )
            object.__setattr__(self, item.name, value)

    @classmethod
    def options(cls) -> tuple[OptionInfo, ...]:
        """The declared options, in declaration order."""
        hints = typing.get_type_hints(cls)
        return tuple(
            OptionInfo(
                f.name, hints[f.name], f.default, f.metadata["help"], f.metadata["default_text"]
            )
            for f in dataclasses.fields(cls)  # type: ignore[arg-type]
        )

    @classmethod
    def declares(cls, name: str) -> bool:
        """Whether ``name`` is one of the declared options."""
        return any(item.name == name for item in dataclasses.fields(cls))  # type: ignore[arg-type]

    def option_values(self) -> dict[str, Any]:
        """The options as given or checked, ``{name: value}``."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}  # type: ignore[arg-type]
