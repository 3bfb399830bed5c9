"""Regenerate ``slider_crank_reference.npz``, the flexible slider-crank reference curves.

The curves are the rod midpoint's deflection across the chord [m], the
slider's position [m] and the force the rod exerts on the slider along x [N]
of the slider-crank of ``fuzzymbs.models.mechanisms.slider_crank`` at its
default parameters (crank spun up from rest to 150 rad/s in 20 ms), sampled
at 501 equally spaced times over 0..0.1 s (the model's grid), from the
co-rotational finite-element model in ``tests/mbs/nonlinear_beam.py``
(``slider_crank_reference``) at its default (converged) mesh and tolerances.
See that function's docstring for the model and the convergence numbers.

Run from anywhere: ``python tests/data/make_slider_crank_reference.py``
(about five minutes on one core).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
# the model lives beside the tests that use it; tests/ is not an installed package
sys.path.insert(0, str(HERE.parent / "mbs"))

from nonlinear_beam import (  # noqa: E402
    SLIDER_CRANK_ATOL,
    SLIDER_CRANK_ELEMENTS,
    SLIDER_CRANK_RTOL,
    slider_crank_reference,
)

OUTPUT = HERE / "slider_crank_reference.npz"


def main() -> None:
    """Compute the curves and write the npz next to this script."""
    time_grid = np.linspace(0.0, 0.1, 501)
    start = time.perf_counter()
    curves = slider_crank_reference(time_grid)
    print(
        f"{SLIDER_CRANK_ELEMENTS} elements, rtol {SLIDER_CRANK_RTOL:g}, atol "
        f"{SLIDER_CRANK_ATOL:g}: {time.perf_counter() - start:.0f} s"
    )
    for key, values in curves.items():
        print(f"  {key}: max |value| = {np.abs(values).max():.6g}")
    np.savez(OUTPUT, time=time_grid, **curves)
    print(f"wrote {OUTPUT}")


if __name__ == "__main__":
    main()
