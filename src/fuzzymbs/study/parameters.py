"""Fuzzy-parameter definitions as written in study files, turned into fuzzy numbers.

A definition is a plain mapping (TOML table or Python dict)::

    {"type": "triangular", "modal": 2e5, "spread": 0.1}        # +-10 % of the modal value
    {"type": "triangular", "lower": 1.0, "modal": 2.0, "upper": 3.0}
    {"type": "trapezoidal", "lower": 0, "core_lower": 1, "core_upper": 2, "upper": 3}
    {"type": "gaussian", "mean": 1.0, "std": 0.1, "truncation": 3.0}
    {"type": "piecewise", "levels": [0, 0.5, 1], "lower": [..], "upper": [..]}

A bare number is a crisp (non-fuzzy) value that overrides the model default.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from fuzzymbs.errors import InvalidFuzzyNumberError

#: Allowed keys per fuzzy-number type (the keys a study file may use).
FUZZY_TYPES: dict[str, tuple[str, ...]] = {
    "triangular": ("modal", "spread", "lower", "upper"),
    "trapezoidal": ("lower", "core_lower", "core_upper", "upper"),
    "gaussian": ("mean", "std", "truncation"),
    "piecewise": ("levels", "lower", "upper"),
}


def fuzzy_number_from_definition(definition: Mapping[str, Any], name: str = "parameter") -> Any:
    """Build a :class:`fuzzymbs.fuzzy.numbers.FuzzyNumber` from a study-file definition.

    Parameters
    ----------
    definition : mapping
        ``{"type": ..., ...}`` as listed in the module docstring.
    name : str
        Parameter name, used in error messages.

    Raises
    ------
    InvalidFuzzyNumberError
        Unknown type, missing or unexpected keys, or an inconsistent definition.
    """
    from fuzzymbs.fuzzy import numbers

    kind = definition.get("type")
    if kind not in FUZZY_TYPES:
        raise InvalidFuzzyNumberError(
            f"parameter {name!r}: type {kind!r} is not one of {', '.join(FUZZY_TYPES)}"
        )
    keys = set(definition) - {"type"}
    unexpected = keys - set(FUZZY_TYPES[kind])
    if unexpected:
        raise InvalidFuzzyNumberError(
            f"parameter {name!r} ({kind}): unexpected key(s) {sorted(unexpected)}; "
            f"allowed: {', '.join(FUZZY_TYPES[kind])}"
        )

    def need(*required: str) -> None:
        missing = [key for key in required if key not in definition]
        if missing:
            raise InvalidFuzzyNumberError(f"parameter {name!r} ({kind}): missing key(s) {missing}")

    try:
        if kind == "triangular":
            if "spread" in definition:
                if keys & {"lower", "upper"}:
                    raise InvalidFuzzyNumberError(
                        f"parameter {name!r} (triangular): give either modal + spread "
                        "or lower + modal + upper, not both"
                    )
                need("modal")
                return numbers.Triangular.relative(
                    float(definition["modal"]), float(definition["spread"])
                )
            need("lower", "modal", "upper")
            return numbers.Triangular(
                float(definition["lower"]), float(definition["modal"]), float(definition["upper"])
            )
        if kind == "trapezoidal":
            need("lower", "core_lower", "core_upper", "upper")
            return numbers.Trapezoidal(
                float(definition["lower"]),
                float(definition["core_lower"]),
                float(definition["core_upper"]),
                float(definition["upper"]),
            )
        if kind == "gaussian":
            need("mean", "std")
            return numbers.Gaussian(
                float(definition["mean"]),
                float(definition["std"]),
                truncation=float(definition.get("truncation", 3.0)),
            )
        need("levels", "lower", "upper")
        return numbers.PiecewiseLinear(
            [float(v) for v in definition["levels"]],
            [float(v) for v in definition["lower"]],
            [float(v) for v in definition["upper"]],
        )
    except InvalidFuzzyNumberError as exc:
        message = str(exc)
        if f"parameter {name!r}" in message:
            raise
        raise InvalidFuzzyNumberError(f"parameter {name!r}: {message}") from exc
    except (TypeError, ValueError) as exc:
        raise InvalidFuzzyNumberError(f"parameter {name!r} ({kind}): {exc}") from exc
