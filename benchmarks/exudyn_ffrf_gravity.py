"""Uniform gravity on a freely falling flexible body, in fuzzymbs and in Exudyn's
ObjectFFRFreducedOrder (its own ``gravity=`` option): the figures docs/mechanisms.md quotes.

    python benchmarks/exudyn_ffrf_gravity.py

Every point of a free body in uniform gravity g gets the same acceleration, so its motion
relative to its falling frame is the one without gravity and its frame falls by g t^2 / 2
more. Both codes run the tumbling body of ``tests/mbs/spatial/test_exudyn_ffrf.py`` (six
point masses, 12 modes; Exudyn with RK4 at 0.1 ms) for 0.5 s with and without gravity; the
script prints, for each, the largest change of the modal coordinates and of the frame's
path beyond g t^2 / 2.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.mbs.spatial.test_exudyn_ffrf import exudyn_tumbling
from tests.mbs.spatial.test_flexible import lumped_body

from fuzzymbs.mbs.spatial import FlexibleBody, Mechanism, simulate

GRAVITY = np.array([0.0, -9.81, 0.0])


def main() -> None:
    modal, masses = lumped_body()
    coordinates = 0.01 * np.random.default_rng(3).standard_normal(modal.n_modes)
    velocity, spin = (0.3, -0.2, 0.1), (2.0, 5.0, -3.0)
    times = np.linspace(0.0, 0.5, 51)
    drop = 0.5 * np.outer(times**2, GRAVITY)
    mass = np.diag(np.repeat(masses, 3))
    psi = modal.mode_shapes.reshape(-1, modal.n_modes)
    stiffness = mass @ psi @ np.diag(modal.frequencies**2) @ psi.T @ mass

    def ours(gravity):
        body = FlexibleBody(
            "cluster", modal, velocity=velocity, angular_velocity=spin, coordinates=coordinates
        )
        result = simulate(Mechanism(gravity=gravity).add(body), times, rtol=1e-11, atol=1e-13)
        return result.position("cluster")[0], result.modal_coordinates("cluster")[0]

    def theirs(gravity):
        return exudyn_tumbling(
            modal, mass, stiffness, velocity, spin, coordinates, times, 5000, gravity
        )

    for name, run in (("fuzzymbs", ours), ("exudyn", theirs)):
        (fell, fell_modes), (floated, floated_modes) = run(GRAVITY), run(np.zeros(3))
        print(
            f"{name:8s}: modes change by {np.abs(fell_modes - floated_modes).max():.2g} "
            f"(of {np.abs(floated_modes).max():.2g}), the frame's path by "
            f"{np.abs(fell - drop - floated).max():.2g} m beyond g t^2 / 2"
        )


if __name__ == "__main__":
    main()
