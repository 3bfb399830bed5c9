"""Cost of the quasi-static gear STE: batching, threads, and the demo study.

    python benchmarks/gears_ste.py

Prints wall times of one run on this machine and the ratios between them
(numbers for docs/gears.md come from here; nothing is asserted).
"""

from __future__ import annotations

import tempfile
import time
from importlib import resources
from pathlib import Path

import numba
import numpy as np

from fuzzymbs.models.gears import MubocoPR, make_pair


def best_of(function, repeats: int = 5) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    model = MubocoPR(make_pair(), torque=100.0, positions=100)
    kt, kc = model.defaults["tooth_stiffness"], model.defaults["contact_stiffness"]
    grid = np.linspace(-1, 1, 7)
    samples = {
        "tooth_stiffness": np.repeat(kt * (1 + 0.2 * grid), 7),
        "contact_stiffness": np.tile(kc * (1 + 0.3 * grid), 7),
    }
    model(samples)  # load the compiled kernels

    batched = best_of(lambda: model(samples))
    single = best_of(
        lambda: [
            model({name: values[i : i + 1] for name, values in samples.items()}) for i in range(49)
        ]
    )
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    serial = best_of(lambda: model(samples))
    numba.set_num_threads(threads)
    print(f"49 samples x 100 positions, one batched call ({threads} threads): {batched:.4f} s")
    print(f"  49 one-sample calls:            {single:.4f} s  (ratio {single / batched:.1f})")
    print(f"  one batched call on 1 thread:   {serial:.4f} s  (ratio {serial / batched:.2f})")

    from fuzzymbs.study.pipeline import run_study_file

    demo = resources.files("fuzzymbs") / "demos" / "gear-ste" / "01-ste-adaptive.toml"
    with tempfile.TemporaryDirectory() as tmp:
        run_study_file(demo, Path(tmp) / "warm", progress=False, plots=False)
        start = time.perf_counter()
        run_study_file(demo, Path(tmp) / "run", progress=False, plots=False)
        study = time.perf_counter() - start
    print(f"demo study gear-ste (adaptive, model set-up, result.nc, no plots): {study:.3f} s")


if __name__ == "__main__":
    main()
