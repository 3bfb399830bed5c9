"""Binding element scalars to named sample columns.

Any scalar of a force element (stiffness, damping, force magnitude, contact
penalty, friction coefficient) and a rotating body's speed may be given either
as a plain float or as a :class:`Parameter`. A ``Parameter`` names a sample
column; several elements may share one name (e.g. ``mu`` for both pads). When
the system is compiled every scalar gets a *slot*; a batch of samples becomes a
``(B, n_slots)`` array that the kernels read row by row.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError


@dataclass(frozen=True)
class Parameter:
    """A scalar bound to the sample column ``name``.

    Parameters
    ----------
    name : str
        Sample column name (e.g. ``"mu"``).
    default : float
        Value used when a batch of samples does not contain the column.
    """

    name: str
    default: float

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(
                f"parameter name must be a non-empty str, got {self.name!r}"
            )
        if not np.isfinite(self.default):
            raise InvalidParameterError(
                f"parameter {self.name!r}: default must be finite, got {self.default!r}"
            )


Scalar = float | Parameter


def scalar_default(value: Scalar) -> float:
    """The value of a scalar when no sample overrides it."""
    return float(value.default) if isinstance(value, Parameter) else float(value)


@dataclass(frozen=True)
class Slot:
    """One scalar the kernels read: a constant or a bound sample column."""

    label: str  # e.g. "spring 'pad_caliper' stiffness"
    default: float
    parameter: str | None  # sample column, None for a constant
    minimum: float  # smallest valid value (inclusive), e.g. 0 for a stiffness


class ParameterTable:
    """Collects the slots of a system while it is compiled."""

    def __init__(self) -> None:
        self.slots: list[Slot] = []

    def add(self, value: Scalar, label: str, minimum: float = -np.inf) -> int:
        """Register ``value`` and return its slot index; checks the default against ``minimum``."""
        default = scalar_default(value)
        if not np.isfinite(default) or default < minimum:
            raise InvalidParameterError(f"{label} must be finite and >= {minimum}, got {default!r}")
        name = value.name if isinstance(value, Parameter) else None
        for other in self.slots:
            if name is not None and other.parameter == name and other.default != default:
                raise InvalidParameterError(
                    f"parameter {name!r} has default {other.default!r} at {other.label} but "
                    f"{default!r} at {label}; one name must have one default"
                )
        self.slots.append(Slot(label, default, name, minimum))
        return len(self.slots) - 1

    @property
    def names(self) -> tuple[str, ...]:
        """Names of all bound sample columns, sorted."""
        return tuple(sorted({s.parameter for s in self.slots if s.parameter is not None}))

    def defaults(self) -> dict[str, float]:
        """Default value of every bound column (the first default seen for a shared name)."""
        out: dict[str, float] = {}
        for s in self.slots:
            if s.parameter is not None and s.parameter not in out:
                out[s.parameter] = s.default
        return out

    def values(self, samples: Mapping[str, NDArray[np.float64] | float]) -> NDArray[np.float64]:
        """Per-sample slot values, shape ``(B, n_slots)``.

        Raises
        ------
        InvalidParameterError
            Unknown column names, columns of different lengths, non-finite values, or a
            value below a slot's minimum (e.g. a negative stiffness).
        """
        known = set(self.names)
        unknown = sorted(set(samples) - known)
        if unknown:
            raise InvalidParameterError(
                f"unknown parameter(s) {unknown}; this system accepts {sorted(known)}"
            )
        columns = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in samples.items()}
        sizes = {k: c.shape for k, c in columns.items()}
        if any(c.ndim != 1 for c in columns.values()) or len({s[0] for s in sizes.values()}) > 1:
            raise InvalidParameterError(f"sample columns must be 1-D of equal length, got {sizes}")
        batch = next(iter(columns.values())).shape[0] if columns else 1
        table = np.empty((batch, max(len(self.slots), 1)))
        for i, slot in enumerate(self.slots):
            column = columns.get(slot.parameter) if slot.parameter is not None else None
            if column is None:
                table[:, i] = slot.default
                continue
            bad = ~np.isfinite(column) | (column < slot.minimum)
            if bad.any():
                j = int(np.flatnonzero(bad)[0])
                raise InvalidParameterError(
                    f"parameter {slot.parameter!r} ({slot.label}) must be finite and "
                    f">= {slot.minimum}; sample {j} has {column[j]!r}"
                )
            table[:, i] = column
        return table
