"""The closed-form test cases as study models that differentiate their outputs.

The hard cases (:mod:`fuzzymbs.models.closed_form.hard_cases`) and the resonance
models (:mod:`fuzzymbs.models.closed_form.resonance`) carry analytic gradients.
:class:`CaseModel` makes each a batched model a study can name (registered as
``bump3``, ``ringing3``, ``valley4``, ``sdof-resonance`` and ``2dof-resonance``)
and that meets the gradient protocol of a study model:

- ``model.differentiable``: the parameters it can differentiate with respect to
  (here all of them);
- ``model(samples)``: the outputs, as every model;
- ``model(samples, wrt=names)``: the outputs and, under the key ``"gradients"``,
  ``{output: (B, *output_shape, len(wrt))}``, the last axis in the order of
  ``wrt`` and in the parameters' units.

The model is its case's name only, so it pickles to worker processes and a
Dask cluster as a few bytes; the case (its closures) is rebuilt where it runs.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.closed_form.hard_cases import (
    RINGING_TIME,
    HardCase,
    bump3,
    ringing3,
    valley4,
)
from fuzzymbs.models.closed_form.resonance import sdof_resonance, two_dof_resonance

__all__ = [
    "CASE_MODELS",
    "GRADIENTS_KEY",
    "CaseModel",
    "bump3_model",
    "ringing3_model",
    "sdof_resonance_model",
    "two_dof_resonance_model",
    "valley4_model",
]

#: the key under which a model returns its gradients when called with ``wrt``
GRADIENTS_KEY = "gradients"
#: the damping ratio the resonance cases are built with: their models do not depend on it
#: (the damping ratio is a sample column); it only sets the suggested fuzzy numbers
_REFERENCE_DAMPING = 0.02

#: registered name -> (the case's builder, parameter units, output units)
CASE_MODELS: dict[str, tuple[Callable[[], HardCase], dict[str, str], dict[str, str]]] = {
    "bump3": (bump3, {"x1": "1", "x2": "1", "x3": "1"}, {"z": "1"}),
    "ringing3": (
        ringing3,
        {"frequency": "Hz", "damping_ratio": "1", "amplitude": "m"},
        {"y": "m"},
    ),
    "valley4": (valley4, {"x1": "1", "x2": "1", "x3": "1", "x4": "1"}, {"z": "1"}),
    "sdof-resonance": (
        lambda: sdof_resonance(_REFERENCE_DAMPING),
        {"stiffness": "N/m", "mass": "kg", "damping_ratio": "1"},
        {"amplitude": "m"},
    ),
    "2dof-resonance": (
        lambda: two_dof_resonance(_REFERENCE_DAMPING),
        {"stiffness_1": "N/m", "stiffness_2": "N/m", "mass_1": "kg", "damping_ratio": "1"},
        {"amplitude": "m"},
    ),
}


#: the cases with a trailing output axis: its coordinate values and unit
_TRAILING: dict[str, tuple[dict[str, NDArray[np.float64]], dict[str, str]]] = {
    "ringing3": ({"time": RINGING_TIME}, {"time": "s"}),
    "2dof-resonance": ({"mass": np.array([1.0, 2.0])}, {"mass": "1"}),
}


@cache
def _case(name: str) -> HardCase:
    return CASE_MODELS[name][0]()


@dataclass(frozen=True)
class CaseModel:
    """A closed-form test case as a batched study model with its analytic gradients.

    Parameters
    ----------
    name : str
        One of :data:`CASE_MODELS`.
    """

    name: str

    def __post_init__(self) -> None:
        if self.name not in CASE_MODELS:
            raise InvalidParameterError(
                f"unknown closed-form case {self.name!r}; cases: {', '.join(CASE_MODELS)}"
            )

    @property
    def differentiable(self) -> tuple[str, ...]:
        """The parameters the model differentiates its outputs with respect to: all."""
        return tuple(_case(self.name).triangles)

    @property
    def coords(self) -> dict[str, NDArray[np.float64]]:
        """The trailing output axes: ringing3's time [s], the two-mass chain's masses (1
        and 2); none for the scalar cases."""
        return _TRAILING.get(self.name, ({}, {}))[0]

    @property
    def output_dims(self) -> dict[str, tuple[str, ...]]:
        """Each output's trailing dimensions."""
        dims = tuple(self.coords)
        return {output: dims for output in CASE_MODELS[self.name][2]}

    @property
    def coord_units(self) -> dict[str, str]:
        """Units of the trailing coordinates."""
        return _TRAILING.get(self.name, ({}, {}))[1]

    def suggested(self) -> dict[str, tuple[float, float, float]]:
        """The case's fuzzy parameters as ``(lower, modal, upper)`` (the resonance cases
        at a damping ratio of 2 %)."""
        return dict(_case(self.name).triangles)

    def __call__(
        self, samples: Mapping[str, NDArray[np.float64]], wrt: Sequence[str] | None = None
    ) -> dict[str, Any]:
        """The outputs at ``samples`` ``{name: (B,)}``; with ``wrt`` also their gradients.

        Raises
        ------
        InvalidParameterError
            ``wrt`` names a parameter the model does not have, or one twice.
        """
        case = _case(self.name)
        if wrt is None:
            return case.model(samples)
        names = list(case.triangles)
        wanted = list(wrt)
        unknown = [w for w in wanted if w not in names]
        if unknown or len(set(wanted)) != len(wanted):
            raise InvalidParameterError(
                f"model {self.name!r} differentiates with respect to {', '.join(names)}, each "
                f"once; wrt = {wanted} asks for {unknown or 'a parameter twice'}"
            )
        assert case.gradient is not None
        outputs, slopes = case.gradient(samples)
        order = [names.index(w) for w in wanted]
        gradients = {key: np.ascontiguousarray(value[..., order]) for key, value in slopes.items()}
        return {**outputs, GRADIENTS_KEY: gradients}


def bump3_model() -> CaseModel:
    """Factory registered as ``"bump3"`` (:func:`~fuzzymbs.models.closed_form.hard_cases.bump3`)."""
    return CaseModel("bump3")


def ringing3_model() -> CaseModel:
    """Factory registered as ``"ringing3"`` (a 201-point signal over ``time``)."""
    return CaseModel("ringing3")


def valley4_model() -> CaseModel:
    """Factory registered as ``"valley4"``."""
    return CaseModel("valley4")


def sdof_resonance_model() -> CaseModel:
    """Factory registered as ``"sdof-resonance"``: the forced oscillator's amplitude."""
    return CaseModel("sdof-resonance")


def two_dof_resonance_model() -> CaseModel:
    """Factory registered as ``"2dof-resonance"``: the two-mass chain's amplitudes (B, 2)."""
    return CaseModel("2dof-resonance")
