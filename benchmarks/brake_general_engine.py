"""The brake in both of the engine's forms, one sample: the figures docs/mechanisms.md
("The brake on the general engine") quotes.

    python benchmarks/brake_general_engine.py [--t-end 5e-5] [--rtol 1e-8]

The brake's System (minimal coordinates: the pads' and caliper's slides and every body's
modes; ROS34PW2 on the SIMD kernels) and the same model written by
``System.as_mechanism()`` for the absolute-coordinate engine (Lagrange multipliers for the
disc's driven hinge and the three slides, 250 force elements: 73 x 2 SurfaceContacts, 54
Bushings, 50 MarkerLoads; DOP853, the engine's pair for flexible bodies), both at the
same rtol over the press-on transient. Prints each run's wall time (after a first run
that compiles) and the largest differences: the pads' slides [m] and each body's modal
coordinates relative to their largest value.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fuzzymbs.mbs.integrate import simulate as simulate_minimal
from fuzzymbs.mbs.spatial import simulate as simulate_absolute
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import brake_system, build_bodies
from fuzzymbs.models.brake.geometry import BrakeDesign
from fuzzymbs.tolerance import Tolerance


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=5e-5)
    parser.add_argument("--rtol", type=float, default=1e-8)
    args = parser.parse_args()
    system = brake_system(build_bodies(BrakeDesign()))
    compiled = system.compile()
    outputs = {
        f"{name}{i}": Coordinate(name, i)
        for name, dofs in compiled.body_dofs.items()
        for i in range(dofs.stop - dofs.start)
    }

    def minimal():
        return simulate_minimal(
            compiled,
            t_end=args.t_end,
            dt=1e-7,
            record_interval=args.t_end / 20,
            outputs=outputs,
            integrator="ros34pw2",
            tolerance=Tolerance(args.rtol, args.rtol * 1e-7),
        )

    def absolute(times):
        mechanism = system.as_mechanism()
        return simulate_absolute(mechanism, times, rtol=args.rtol, atol=args.rtol * 1e-5)

    first = minimal()
    absolute(first.time)  # compiles
    start = time.perf_counter()
    mine = minimal()
    middle = time.perf_counter()
    theirs = absolute(mine.time)
    end = time.perf_counter()
    print(f"minimal form (ROS34PW2):          {middle - start:6.2f} s")
    print(f"absolute form (DOP853):           {end - middle:6.2f} s")
    for pad in ("lower_pad", "upper_pad"):
        ours = mine.outputs[f"{pad}0"][0]
        gap = np.abs(theirs.position(pad)[0][:, 1] - ours).max()
        print(f"{pad} slide: largest {np.abs(ours).max():.3g} m, difference {gap:.2g} m")
    for name, dofs in compiled.body_dofs.items():
        first_mode = 0 if name == "disc" else 1
        ours = np.stack(
            [mine.outputs[f"{name}{i}"][0] for i in range(first_mode, dofs.stop - dofs.start)],
            -1,
        )
        scale = np.abs(ours).max()
        gap = np.abs(theirs.modal_coordinates(name)[0] - ours).max() / scale
        print(f"{name} modes: difference {gap:.2g} of their largest value")


if __name__ == "__main__":
    main()
