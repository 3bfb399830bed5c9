"""Cost of the FE reference ``gear-pair-fe``: cold, warm, per sample, against MUBOCO-PR.

    python benchmarks/gear_fe.py

Default pair, T1 = 100 N m, 60 positions. Prints wall times of one run on this
machine and their ratios (the numbers in docs/benchmarks.md; nothing is asserted):

* the first use after an install: Numba compiles the model's kernels (once);
* cold in a fresh interpreter: import, meshing, assembly, factorisation and the
  unit-load solves of both gears (empty cache directory), then the contact analysis;
* warm in a fresh interpreter: the same with the flank tables on disk;
* in one process: the tables, one STE, a batch of 17 samples (the example study),
  a new Poisson's ratio (a new table), and MUBOCO-PR's STE of the same batch.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

SCRIPT = """
import time
start = time.perf_counter()
from fuzzymbs.models.gears import make_pair
from fuzzymbs.models.gears.fe_model import GearPairFE
imported = time.perf_counter()
model = GearPairFE(make_pair(), torque=100.0, positions=60)
model({})
print(imported - start, time.perf_counter() - start)
"""


def fresh_interpreter(cache: str, numba_cache: str | None = None) -> tuple[float, float]:
    """(import time, total time) [s] of one STE in a new interpreter.

    ``numba_cache``: an empty directory for Numba's cache, so that every kernel the
    model uses is compiled (the first use after an install).
    """
    env = {**os.environ, "FUZZYMBS_CACHE_DIR": cache}
    if numba_cache is not None:
        env["NUMBA_CACHE_DIR"] = numba_cache
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True
    )
    imports, total = map(float, out.stdout.strip().splitlines()[-1].split())
    return imports, total


def main() -> None:
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as numba_cache:
        _, first = fresh_interpreter(cache, numba_cache)
        print(f"fresh interpreter, first use after install (Numba compiles): {first:.1f} s")
    with tempfile.TemporaryDirectory() as cache:
        cold_import, cold = fresh_interpreter(cache)
        warm_import, warm = fresh_interpreter(cache)
        print(f"fresh interpreter, 60-position STE: cold {cold:.2f} s, warm {warm:.2f} s "
              f"(ratio {cold / warm:.1f}); of which imports {cold_import:.2f} / "
              f"{warm_import:.2f} s")  # fmt: skip

        os.environ["FUZZYMBS_CACHE_DIR"] = cache
        from fuzzymbs.models.gears import MubocoPR, make_pair
        from fuzzymbs.models.gears.fe_compliance import flank_compliance
        from fuzzymbs.models.gears.fe_model import GearPairFE

        pair = make_pair()
        start = time.perf_counter()
        tables = [flank_compliance(g, cache=False) for g in (pair.pinion, pair.wheel)]
        compute = time.perf_counter() - start
        start = time.perf_counter()
        for g in (pair.pinion, pair.wheel):
            flank_compliance(g)
        load = time.perf_counter() - start
        unknowns = f"{tables[0].dofs} + {tables[1].dofs} unknowns"
        print(f"flank tables of both gears: computed {compute:.2f} s ({unknowns}), "
              f"read from disk {load:.3f} s")  # fmt: skip

        model = GearPairFE(pair, torque=100.0, positions=60)
        model({})
        start = time.perf_counter()
        model({})
        one = time.perf_counter() - start
        rng = np.random.default_rng(1)
        samples = {
            "youngs_modulus": rng.uniform(2.04e11, 2.16e11, 17),
            "torque": rng.uniform(90.0, 110.0, 17),
            "tip_relief": rng.uniform(0.0, 6e-6, 17),
        }
        start = time.perf_counter()
        model(samples)
        batch = time.perf_counter() - start
        start = time.perf_counter()
        model({"poisson_ratio": np.array([0.29])})
        new_nu = time.perf_counter() - start
        muboco = MubocoPR(pair, torque=100.0, positions=60, reference=False)
        mb_samples = {"torque": samples["torque"], "tip_relief": samples["tip_relief"]}
        muboco(mb_samples)
        start = time.perf_counter()
        muboco(mb_samples)
        mb_batch = time.perf_counter() - start
        print(f"one STE (tables in memory): {one:.3f} s")
        print(f"17 samples: {batch:.3f} s ({batch / 17:.3f} s per sample); "
              f"MUBOCO-PR, same torques and reliefs: {mb_batch:.4f} s "
              f"(ratio {batch / mb_batch:.2f})")  # fmt: skip
        print(f"one sample at a new Poisson's ratio (new tables, cold): {new_nu:.2f} s")


if __name__ == "__main__":
    main()
