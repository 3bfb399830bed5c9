"""What the mechanism models share: output readers, the beam from the parameters and the
factory of a beam model."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fe.beam import PlanarBeam, ReducedBeam
from fuzzymbs.mbs.mechanism_model import ENGINE_TOLERANCE, MechanismModel, OutputReader
from fuzzymbs.mbs.planar.simulation import PlanarResult
from fuzzymbs.mbs.planar.system import Mechanism


def deflection_in_frame(result: PlanarResult, body: str, marker: str) -> NDArray[np.float64]:
    """(B, T) displacement of ``marker`` across ``body``'s frame x axis [m].

    The marker's position relative to the frame origin, turned into the
    frame: its y component, the transverse deflection of a beam along x.
    """
    frame = result.coordinates(body)
    point = result.marker(marker)
    dx = point[..., 0] - frame[..., 0]
    dy = point[..., 1] - frame[..., 1]
    angle = frame[..., 2]
    return -np.sin(angle) * dx + np.cos(angle) * dy


def reduced_beam(
    p: dict[str, float], area: float, second_moment: float, modes: int, elements: int
) -> ReducedBeam:
    """The beam of the parameters ``length``, ``youngs_modulus`` and ``density`` in ``p``
    with the section's ``area`` and ``second_moment``, meshed with ``elements`` and reduced to
    ``modes`` clamped modes (:meth:`fuzzymbs.fe.beam.PlanarBeam.reduce`)."""
    return PlanarBeam(
        length=p["length"],
        youngs_modulus=p["youngs_modulus"],
        density=p["density"],
        area=area,
        second_moment=second_moment,
        elements=elements,
    ).reduce(modes)


def beam_model(
    build: Callable[..., Mechanism],
    parameters: Mapping[str, float],
    outputs: Mapping[str, tuple[OutputReader, str]],
    duration: float,
    time_steps: int = 401,
    modes: int | None = None,
    elements: int | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    integrator: str = "auto",
) -> MechanismModel:
    """The study model of a mechanism with one FE beam, over ``time_steps`` output times
    from 0 to ``duration`` [s].

    Parameters
    ----------
    build : callable
        ``build(p, modes=..., elements=...)``: the mechanism for one parameter set.
    parameters, outputs
        As for :class:`~fuzzymbs.mbs.mechanism_model.MechanismModel`.
    duration : float
        Simulated time [s].
    time_steps : int
        Number of output times.
    modes, elements : int, optional
        The beam's modes kept and its elements; None keeps ``build``'s defaults.
    rtol, atol : float, optional
        Step-control tolerances; None keeps the engine's defaults.
    integrator : str
        The Runge-Kutta pair (:func:`fuzzymbs.mbs.planar.simulate`'s ``method``).
    """
    sizes = {k: v for k, v in (("modes", modes), ("elements", elements)) if v is not None}
    return MechanismModel(
        lambda p: build(p, **sizes),
        parameters=parameters,
        outputs=outputs,
        times=np.linspace(0.0, duration, int(time_steps)),
        method=integrator,
        tolerance=ENGINE_TOLERANCE.with_values(rtol, atol),
    )
