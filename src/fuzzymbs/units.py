"""Engineering units for figures and reports: SI prefixes chosen from the data.

A value in metres of about 1e-5 reads as 10 µm, a time axis up to 0.01 s as
0 to 10 ms. Only units that start with an SI symbol get a prefix (``m``,
``N/m``, ``N m/rad``, ``Hz``, ...); units that already carry one (``kg``,
``mm``), powers of the first symbol (``m^2``) and dimensionless or free-text
units (``1``, ``mesh periods``) are left as they are.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

#: exponent -> SI prefix, from pico to tera
PREFIXES = {-12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G", 12: "T"}

# symbols that take a prefix when they open a unit ("N m/rad" -> "kN m/rad")
_SYMBOLS = ("m", "s", "N", "Hz", "Pa", "J", "W", "rad", "V", "A")
_FIRST = re.compile(r"^([A-Za-z]+)(.*)$")


@dataclass(frozen=True)
class Scale:
    """Divide values by ``factor`` to express them in ``unit``.

    Attributes
    ----------
    factor : float
        The prefix's factor (1e-6 for µ).
    unit : str
        The prefixed unit, e.g. "µm"; "" for a quantity without unit.
    """

    factor: float
    unit: str

    def __call__(self, values: ArrayLike) -> np.ndarray:
        """``values`` in this scale's unit."""
        return np.asarray(values, dtype=float) / self.factor

    def label(self, name: str) -> str:
        """An axis label, "name [unit]" (just the name without unit)."""
        return f"{name} [{self.unit}]" if self.unit else name


def prefixable(unit: str | None) -> bool:
    """Whether ``unit`` starts with an SI symbol that takes a prefix."""
    if not unit:
        return False
    match = _FIRST.match(unit.strip())
    if match is None:
        return False
    symbol, rest = match.groups()
    return symbol in _SYMBOLS and not rest.startswith("^")


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def engineering_scale(values: ArrayLike, unit: str | None, powers: bool = True) -> Scale:
    """The SI prefix that puts the largest magnitude of ``values`` in [1, 1000).

    A unit that takes no prefix (``1/s``, ``1``, ``periods``) gets a power of ten
    instead (``10⁻⁶ 1/s``) when ``powers`` is true and the largest magnitude is
    below 0.01 or from 10,000 up; axis labels then need no offset text.

    Parameters
    ----------
    values : array_like
        The data the axis or table shows (NaN and inf are ignored).
    unit : str or None
        The data's unit (SI, unprefixed), e.g. "m", "N/m", "s".

    Returns
    -------
    Scale
        Factor 1 and the unit unchanged when the unit takes no prefix or the
        data are all zero or not finite.
    """
    unit = (unit or "").strip()
    array = np.abs(np.asarray(values, dtype=float))
    array = array[np.isfinite(array)]
    largest = float(array.max()) if array.size else 0.0
    if largest == 0.0:
        return Scale(1.0, unit)
    exponent = 3 * math.floor(math.log10(largest) / 3)
    if not prefixable(unit):
        if not powers or 1e-2 <= largest < 1e4:
            return Scale(1.0, unit)
        return Scale(10.0**exponent, f"10{str(exponent).translate(_SUPERSCRIPT)} {unit}".strip())
    exponent = min(max(exponent, min(PREFIXES)), max(PREFIXES))
    return Scale(10.0**exponent, PREFIXES[exponent] + unit)


def format_quantity(value: float, unit: str | None, digits: int = 4) -> str:
    """``value`` with its own prefix and ``digits`` significant digits, e.g. "12.35 µm"."""
    if not np.isfinite(value):
        return "n/a"
    scale = engineering_scale([value], unit, powers=False)
    text = f"{scale(value).item():.{digits}g}"
    return f"{text} {scale.unit}" if scale.unit else text
