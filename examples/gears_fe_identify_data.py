"""The measured outputs of examples/gear_fe_identify.toml: STE features of the FE reference.

Default pair, T1 = 100 N m, 120 positions, features as ``gear-ste-features``. Modal
value: ``gear-pair-fe`` with its defaults (plane strain, bore clamped); the support
spans the variants of the 2D idealisation (plane stress, a bore free to widen, both).

    python examples/gears_fe_identify_data.py      # prints the [measured] table
"""

from __future__ import annotations

import numpy as np

from fuzzymbs.models.gears import make_pair
from fuzzymbs.models.gears.fe_model import GearPairFE
from fuzzymbs.models.gears.features import FEATURES, contact_zones, ste_features

VARIANTS = (
    {},
    {"analysis": "plane-stress"},
    {"support": "tangential"},
    {"analysis": "plane-stress", "support": "tangential"},
)


def measured(positions: int = 120) -> dict[str, tuple[float, float, float]]:
    """(lower, modal, upper) of each feature [m] over the FE variants (modal: the default)."""
    pair = make_pair()
    single, double = contact_zones(pair, np.arange(positions) / positions, 0.08)
    values = []
    for variant in VARIANTS:
        ste = GearPairFE(pair, torque=100.0, positions=positions, **variant)({})["ste"]
        values.append({k: float(v[0]) for k, v in ste_features(ste, single, double).items()})
    return {
        name: (min(v[name] for v in values), values[0][name], max(v[name] for v in values))
        for name in FEATURES
    }


if __name__ == "__main__":
    print("[measured]             # [m]")
    for name, (lower, modal, upper) in measured().items():
        print(f'{name} = {{ type = "triangular", lower = {lower:.4e}, modal = {modal:.4e}, '
              f"upper = {upper:.4e} }}")  # fmt: skip
