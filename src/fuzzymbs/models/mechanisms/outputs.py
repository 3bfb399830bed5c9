"""Output readers shared by the mechanism models."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.mbs.planar.simulation import PlanarResult


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
