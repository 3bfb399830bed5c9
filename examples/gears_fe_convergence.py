"""Convergence of the FE reference ``gear-pair-fe``: the table behind its defaults.

Default pair (z 20/40, m 4.5 mm, b 20 mm, steel), T1 = 100 N m, 60 positions.
Each row changes one setting of the default model; the STE features (mean,
peak-to-peak, single- and double-contact means 8 % of the period away from the
zone changes, as ``gear-ste-features``) are compared with the finest
discretisation. Every row is computed cold (its own empty cache directory).

    python examples/gears_fe_convergence.py          # about 2 minutes on 2 cores
"""

from __future__ import annotations

import os
import tempfile
import time

import numpy as np

from fuzzymbs.models.gears import make_pair
from fuzzymbs.models.gears.fe_compliance import MeshOptions
from fuzzymbs.models.gears.fe_model import GearPairFE
from fuzzymbs.models.gears.features import contact_zones, ste_features

PAIR = make_pair()
POSITIONS = 60

#: (label, model keyword arguments); the first row is the reference
ROWS: list[tuple[str, dict]] = [
    ("finest: fine 1/64 m, coarse 1/6 m, grid 48", {"mesh": MeshOptions(1 / 64, 1 / 6, 5, 48)}),
    ("default: fine 1/24 m, coarse 1/3 m, 5 teeth, grid 24, d_ref 0.15 m", {}),
    ("fine 1/12 m", {"mesh": MeshOptions(fine_size=1 / 12, reference_depth=0.2)}),
    ("fine 1/48 m", {"mesh": MeshOptions(fine_size=1 / 48)}),
    ("coarse 1/6 m", {"mesh": MeshOptions(coarse_size=1 / 6)}),
    ("coarse 2/3 m", {"mesh": MeshOptions(coarse_size=2 / 3)}),
    ("grid 12 points", {"mesh": MeshOptions(grid_points=12)}),
    ("grid 48 points", {"mesh": MeshOptions(grid_points=48)}),
    ("3 loaded teeth (coupling of neighbours only)", {"mesh": MeshOptions(loaded_teeth=3)}),
    ("1 loaded tooth (no tooth-to-tooth coupling)", {"mesh": MeshOptions(loaded_teeth=1)}),
    ("7 loaded teeth", {"mesh": MeshOptions(loaded_teeth=7)}),
    ("d_ref 0.1 m", {"mesh": MeshOptions(reference_depth=0.1)}),
    ("d_ref 0.25 m", {"mesh": MeshOptions(reference_depth=0.25)}),
    ("support tangential (bore may widen)", {"support": "tangential"}),
    ("plane stress", {"analysis": "plane-stress"}),
]


def features(ste: np.ndarray) -> dict[str, float]:
    single, double = contact_zones(PAIR, np.arange(POSITIONS) / POSITIONS, 0.08)
    return {k: float(v) for k, v in ste_features(ste, single, double).items()}


def main() -> None:
    names = ("ste_mean", "ste_peak_to_peak", "ste_single", "ste_double")
    print("| setting | mean [um] | peak-to-peak [um] | single [um] | double [um] | "
          "dofs pinion / wheel | cold [s] | warm [s] |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    reference = None
    for label, options in ROWS:
        with tempfile.TemporaryDirectory() as cache:
            os.environ["FUZZYMBS_CACHE_DIR"] = cache
            start = time.perf_counter()
            model = GearPairFE(PAIR, torque=100.0, positions=POSITIONS, **options)
            out = model({})
            cold = time.perf_counter() - start
            warm_model = GearPairFE(PAIR, torque=100.0, positions=POSITIONS, **options)
            start = time.perf_counter()
            warm_model({})
            warm = time.perf_counter() - start
            dofs = "/".join(str(t.dofs) for t in model.tables())
        value = features(out["ste"][0])
        if reference is None:
            reference = value
        cells = [
            f"{value[n] * 1e6:.3f} ({100 * (value[n] / reference[n] - 1):+.1f} %)" for n in names
        ]
        print(f"| {label} | {' | '.join(cells)} | {dofs} | {cold:.1f} | {warm:.2f} |", flush=True)


if __name__ == "__main__":
    main()
