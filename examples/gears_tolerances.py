"""Manufacturing tolerances of the MUBOCO-PR gear pair: the figure and numbers of docs/gears.md.

Run from the repository root::

    python examples/gears_tolerances.py

Writes docs/figures/gears-tolerances.png (STE with tip relief, the Harris map, STE at
several centre distances) and prints the numbers quoted in the section "Manufacturing
tolerances" of docs/gears.md, among them a fuzzy peak-to-peak STE for a toleranced tip
relief and centre distance (grid method: peak-to-peak is not monotonic in the relief).
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import fuzzymbs
from fuzzymbs import Triangular
from fuzzymbs.models.gears import MubocoPR, make_pair
from fuzzymbs.models.gears.features import contact_zones

FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures"
DESIGN_TORQUE = 100.0  # N m at the pinion
UM, MM = 1e-6, 1e-3


def main() -> None:
    pair = make_pair()  # the example pair of docs/gears.md
    model = MubocoPR(pair, torque=DESIGN_TORQUE, positions=120, reference=False)
    single, _ = contact_zones(pair, model.positions)
    design = float(model({})["ste"][0, single].mean())  # single-pair deflection at 100 N m
    print(f"single-pair deflection at {DESIGN_TORQUE:g} N m (design relief): {design / UM:.3f} um")
    starts = [round(d / MM, 3) for d in model.relief_start_diameters]
    print(f"relief start (HPSTC) diameters: {starts} mm")

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4.4))
    position = model.positions

    # (a) STE over the mesh period at the design load for several reliefs
    reliefs = np.array([0.0, 4 * UM, design, 13 * UM])
    out = model({"tip_relief": reliefs})
    for relief, ste in zip(reliefs, out["ste"], strict=True):
        label = f"C_a = {relief / UM:.1f} um" + (" (design)" if relief == design else "")
        ax1.plot(position, ste / UM, label=label)
        print(
            f"  100 N m, C_a {relief / UM:5.2f} um: mean {ste.mean() / UM:.3f} um, "
            f"peak-to-peak {np.ptp(ste) / UM:.3f} um"
        )
    ax1.axvline(pair.contact_ratio - 1.0, color="0.6", lw=0.8, ls=":")
    ax1.set_xlabel("mesh position [period]")
    ax1.set_ylabel("STE [um]")
    ax1.set_title(f"STE at T1 = {DESIGN_TORQUE:g} N m, linear tip relief")
    ax1.legend(fontsize=8)

    # (b) Harris map: peak-to-peak STE over load for several reliefs
    torques = np.arange(5.0, 305.0, 5.0)
    map_reliefs = np.array([0.0, 4 * UM, design, 13 * UM, 17 * UM])
    grid_r, grid_t = np.meshgrid(map_reliefs, torques, indexing="ij")
    out = model({"torque": grid_t.ravel(), "tip_relief": grid_r.ravel()})
    assert not out["failed"].any()
    p2p = np.ptp(out["ste"], axis=1).reshape(grid_r.shape)
    print("Harris map (peak-to-peak STE over pinion torque):")
    for relief, row in zip(map_reliefs, p2p, strict=True):
        best = int(np.argmin(row))
        at_design = row[torques == DESIGN_TORQUE][0]
        label = f"C_a = {relief / UM:.1f} um" + (" (design)" if relief == design else "")
        ax2.plot(torques, row / UM, label=label)
        print(
            f"  C_a {relief / UM:5.2f} um: minimum {row[best] / UM:.3f} um at "
            f"{torques[best]:g} N m, {at_design / UM:.3f} um at {DESIGN_TORQUE:g} N m, "
            f"{row[-1] / UM:.3f} um at {torques[-1]:g} N m"
        )
    flat = p2p[2] <= 1.01 * p2p[2].min()
    print(
        f"  design relief: within 1 % of its minimum over {torques[flat].min():g}-"
        f"{torques[flat].max():g} N m"
    )
    ax2.axvline(DESIGN_TORQUE, color="0.6", lw=0.8, ls=":")
    ax2.set_xlabel("pinion torque T1 [N m]")
    ax2.set_ylabel("peak-to-peak STE [um]")
    ax2.set_title("Harris map")
    ax2.legend(fontsize=8)

    # (c) STE at several centre distances (no relief)
    deviations = np.array([0.0, 0.3, 0.6, 1.0]) * MM
    out = model({"center_distance_deviation": deviations})
    geometry = model.operating_geometry({"center_distance_deviation": deviations})
    print("centre-distance deviation (no relief, 100 N m):")
    for i, deviation in enumerate(deviations):
        eps = geometry["contact_ratio"][i]
        alpha = math.degrees(geometry["operating_pressure_angle"][i])
        backlash = geometry["backlash"][i]
        ste = out["ste"][i]
        label = f"+{deviation / MM:.1f} mm: eps {eps:.3f}, backlash {backlash / UM:.0f} um"
        ax3.plot(position, ste / UM, label=label)
        print(
            f"  +{deviation / MM:.2f} mm: alpha_w {alpha:.3f} deg, eps {eps:.4f}, "
            f"j_wt {backlash / UM:.2f} um, mean STE {ste.mean() / UM:.3f} um, "
            f"peak-to-peak {np.ptp(ste) / UM:.3f} um"
        )
    ax3.set_xlabel("mesh position [period]")
    ax3.set_ylabel("STE [um]")
    ax3.set_title("centre distance a + deviation, no relief")
    ax3.legend(fontsize=8)
    fig.tight_layout()
    FIGURES.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURES / "gears-tolerances.png", dpi=120)
    plt.close(fig)
    print("wrote", FIGURES / "gears-tolerances.png")

    # a fuzzy peak-to-peak STE for toleranced gears: relief 8.6 um -3/+3 um, centre
    # distance +0.05 mm -0.05/+0.05 mm (a = 135 mm is the zero-backlash distance, so the
    # deviation cannot be negative here); peak-to-peak is not monotonic in the relief
    # (Harris V), so the grid method rather than the reduced one
    study = fuzzymbs.Study(
        "gear-ste-features",
        {
            "tip_relief": Triangular(design - 3 * UM, design, design + 3 * UM),
            "center_distance_deviation": Triangular(0.0, 0.05 * MM, 0.1 * MM),
        },
        method="grid",
        levels=3,
        outputs=["ste_peak_to_peak", "ste_mean"],
    )
    result = study.run(progress=False)
    for name in ("ste_peak_to_peak", "ste_mean"):
        low, high = result.alpha_cut(name, 0.0)
        modal = result.alpha_cut(name, 1.0)
        print(
            f"fuzzy {name}: modal {float(np.ravel(modal)[0]) / UM:.3f} um, support "
            f"[{float(np.ravel(low)[0]) / UM:.3f}, {float(np.ravel(high)[0]) / UM:.3f}] um "
            f"({len(study.plan)} runs)"
        )


if __name__ == "__main__":
    main()
