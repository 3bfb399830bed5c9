"""The sparse grid's Hermite direction on one axis: what a level's derivatives buy.

    python benchmarks/hermite_direction.py

ringing3's signal (:func:`fuzzymbs.models.closed_form.hard_cases.ringing3`: damping ratio
0.02, amplitude 1, 201 times over 10 s) along its frequency alone, over the support
(0.83 to 1.17 Hz): a one-direction :class:`~fuzzymbs.fuzzy.chebyshev_grid.ChebyshevSparseGrid`
of levels 1 to 5 (3 to 33 nodes) through the values, and through the values and the
derivatives (``use_hermite(0)``). Error: the largest deviation from the signal on 4,001
points of the support, per time over that time's range (at least a tenth of the widest
range: the cut-width scale of docs/fuzzy.md), the largest over the times. Also the
condition number of the matrix from a level's values and derivatives to the Chebyshev
coefficients. Prints one line per level and one JSON line.
"""

from __future__ import annotations

import json

import numpy as np

from fuzzymbs.fuzzy.chebyshev_grid import (
    ChebyshevSparseGrid,
    chebyshev_basis,
    evaluate_series,
    node_values,
)
from fuzzymbs.models.closed_form.hard_cases import RINGING_TIME

LOW, HIGH = 0.83, 1.17  # ringing3's frequency support [Hz]
DAMPING = 0.02


def signal(frequency: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ringing3's signal (P, 201) and its derivative with respect to the unit coordinate."""
    omega = 2.0 * np.pi * RINGING_TIME[None, :]
    f = np.asarray(frequency, dtype=float)[:, None]
    decay = np.exp(-DAMPING * omega * f)
    value = decay * np.cos(omega * f)
    slope = decay * (-DAMPING * omega * np.cos(omega * f) - omega * np.sin(omega * f))
    return value, slope * (HIGH - LOW) / 2.0


def errors(level: int) -> tuple[int, float, float, float]:
    """Nodes, error with values only, with derivatives, and the Hermite matrix's condition."""
    grid = ChebyshevSparseGrid(1)
    positions = []
    for k in range(level + 1):
        new = grid.add_index((k,))
        unit = node_values(np.array(new))[:, 0]
        value, slope = signal(LOW + (unit + 1.0) * (HIGH - LOW) / 2.0)
        grid.set_values(new, value, slope[:, :, None])
        positions += new
    units = np.linspace(-1.0, 1.0, 4001)
    truth, _ = signal(LOW + (units + 1.0) * (HIGH - LOW) / 2.0)
    spread = truth.max(axis=0) - truth.min(axis=0)
    scale = np.maximum(spread, 0.1 * spread.max())
    found = []
    for direction in (None, 0):
        grid.use_hermite(direction)
        fitted = evaluate_series(*grid.series(), units[:, None])
        found.append(float((np.abs(fitted - truth) / scale).max()))
    x = node_values(np.array(positions))[:, 0]
    value, slope = chebyshev_basis(x, 2 * len(x) - 1, derivative=True)
    condition = float(np.linalg.cond(np.vstack((value, slope))))
    return len(positions), found[0], found[1], condition


def main() -> None:
    rows = {}
    for level in range(1, 6):
        nodes, plain, hermite, condition = errors(level)
        rows[level] = {"nodes": nodes, "values": plain, "hermite": hermite, "cond": condition}
        print(
            f"level {level}: {nodes:2d} nodes  values {100 * plain:9.3g} %  "
            f"with derivatives {100 * hermite:9.3g} %  condition {condition:7.0f}"
        )
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
