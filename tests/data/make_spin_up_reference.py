"""Regenerate ``spin_up_beam_reference.npz``, the spin-up beam reference curves.

The curves are the tip deflection in the hub frame of the Kane, Ryan & Banerjee
(1987) spin-up beam for Omega_s = 1, 2.5, 4 and 10 rad/s (T_s = 15 s), sampled
every 0.1 s over 0..20 s, from the co-rotational finite-element model in
``tests/mbs/nonlinear_beam.py`` at its default (converged) mesh and tolerances.
See that module's docstring for the model and the convergence numbers.

Run from anywhere: ``python tests/data/make_spin_up_reference.py`` (about half a
minute on one core).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
# the model lives beside the tests that use it; tests/ is not an installed package
sys.path.insert(0, str(HERE.parent / "mbs"))

from nonlinear_beam import spin_up_tip_deflection  # noqa: E402

#: Final hub speeds [rad/s] and the npz keys they are stored under.
SPEEDS = {
    "tip_deflection_1": 1.0,
    "tip_deflection_2_5": 2.5,
    "tip_deflection_4": 4.0,
    "tip_deflection_10": 10.0,
}
SPIN_UP_TIME = 15.0  # s
OUTPUT = HERE / "spin_up_beam_reference.npz"


def main() -> None:
    """Compute every curve and write the npz next to this script."""
    # rounded so that the stored grid is exactly 0.0, 0.1, ..., 20.0
    time_grid = np.round(np.arange(201) * 0.1, 10)
    arrays = {"time": time_grid}
    for key, speed in SPEEDS.items():
        start = time.perf_counter()
        d = spin_up_tip_deflection(speed, time_grid, spin_up_time=SPIN_UP_TIME)
        arrays[key] = d
        print(
            f"Omega_s = {speed:4.1f} rad/s: max |d| = {np.abs(d).max():.4f} m, "
            f"d(20 s) = {d[-1]: .5f} m ({time.perf_counter() - start:.1f} s)"
        )
    np.savez(OUTPUT, **arrays)
    print(f"wrote {OUTPUT}")


if __name__ == "__main__":
    main()
