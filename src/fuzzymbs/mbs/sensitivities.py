"""The parameters a run differentiates its outputs with respect to: checks and the
kernel's directions (:func:`fuzzymbs.mbs.integrate.simulate`'s ``sensitivities``, a
model's ``wrt``).

The sensitivities themselves are integrated by the Rosenbrock kernel
(:mod:`fuzzymbs.mbs.kernels.sensitivities`; docs/theory.md, "Forward sensitivities").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError

__all__ = ["GRADIENT_COSTS", "checked_wrt", "gradient_cost", "sensitivity_directions"]

#: CPU of a run per parameter differentiated, as a fraction of the run without: one
#: right-hand side per parameter and stage besides the state's. The brake over 2 ms,
#: study 1's three parameters: 3.0-3.2 times the run with ROS34PW2 (3.0 on shared steps
#: too) and 2.2 with RODAS4,
#: whose Jacobian every step they do not need (docs/benchmarks.md, "Forward
#: sensitivities"); a study's ``gradients = "auto"`` weighs it
#: RK4 integrates none: its gradients are central differences of two runs per parameter
#: on its fixed steps (:mod:`fuzzymbs.mbs.central_differences`)
GRADIENT_COSTS = {"ros34pw2": 0.72, "rodas4": 0.40, "rk4": 2.0}


def gradient_cost(integrator: str) -> float:
    """:data:`GRADIENT_COSTS` of ``integrator``."""
    return GRADIENT_COSTS[integrator]


def _names(names: Sequence[str], what: str) -> tuple[str, ...]:
    if isinstance(names, str) or not all(isinstance(name, str) for name in names):
        raise InvalidParameterError(f"{what} must be a sequence of parameter names, got {names!r}")
    names = tuple(names)
    if len(set(names)) != len(names):
        raise InvalidParameterError(f"{what}: a parameter named twice in {list(names)}")
    return names


def sensitivity_directions(
    compiled, names: Sequence[str], integrated: bool, slots: int
) -> NDArray[np.float64]:
    """(P, slots): 1.0 in the slots each named parameter sets (a name may set several),
    the kernel's directions; ``integrated``: the integrator has sensitivities.

    Raises
    ------
    InvalidParameterError
        Not a sequence of names, a name twice, a name the system does not bind, or an
        integrator without sensitivities (RK4).
    """
    names = _names(names, "sensitivities")
    if not names:
        return np.zeros((0, slots))
    if not integrated:
        raise InvalidParameterError(
            "sensitivities are integrated by the Rosenbrock methods ('ros34pw2', 'rodas4') "
            "only; choose one of them as the integrator ('rk4' has none)"
        )
    known = compiled.parameters.names
    unknown = [name for name in names if name not in known]
    if unknown:
        raise InvalidParameterError(
            f"sensitivities: unknown parameter(s) {unknown}; this system binds {list(known)}"
        )
    directions = np.zeros((len(names), slots))
    for k, name in enumerate(names):
        for slot, entry in enumerate(compiled.parameters.slots):
            if entry.parameter == name:
                directions[k, slot] = 1.0
    return directions


def checked_wrt(
    wrt: Sequence[str] | None, differentiable: tuple[str, ...]
) -> tuple[str, ...] | None:
    """A model's ``wrt`` as a tuple (None: no gradients asked).

    Raises
    ------
    InvalidParameterError
        Not a sequence of names, a name twice, or a name the model cannot differentiate
        with respect to (naming it and those it can).
    """
    if wrt is None:
        return None
    names = _names(wrt, "wrt")
    unknown = [name for name in names if name not in differentiable]
    if unknown:
        raise InvalidParameterError(
            f"wrt: cannot differentiate with respect to {unknown}; it differentiates with "
            f"respect to {list(differentiable)}"
        )
    return names
