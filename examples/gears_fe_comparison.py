"""MUBOCO-PR beside its FE reference: the figures and numbers of docs/gears.md, "FE reference".

Default pair (z 20/40, m 4.5 mm, b 20 mm, steel). For T1 = 50, 100 and 200 N m the
STE over one mesh period of ``gear-pair-fe`` (black crosses, as the FE points of the
MUBOCO-PR publication), of MUBOCO-PR at its identified modal values (identified at
100 N m, the demo's), of the potential-energy (PE) reference and the ISO 6336-1
mean; at 100 N m also the fuzzy STE of the demo study ``gear-ste`` (tooth stiffness
+-20 %, contact stiffness +-30 %, grid method, levels 3) and a mesh figure.

    python examples/gears_fe_comparison.py        # about 30 s (FE tables cached after)
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import fuzzymbs
from fuzzymbs.models.gears import MubocoPR, iso_mean_ste, make_pair
from fuzzymbs.models.gears.fe_compliance import MeshOptions
from fuzzymbs.models.gears.fe_mesh import mesh_gear
from fuzzymbs.models.gears.fe_model import GearPairFE
from fuzzymbs.models.gears.features import contact_zones, ste_features
from fuzzymbs.models.gears.potential_energy import reference_ste

FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures"
PAIR = make_pair()
POSITIONS = 60
TORQUES = (50.0, 100.0, 200.0)


def features(ste: np.ndarray) -> dict[str, float]:
    single, double = contact_zones(PAIR, np.arange(POSITIONS) / POSITIONS, 0.08)
    return {k: float(v) * 1e6 for k, v in ste_features(ste, single, double).items()}


def fuzzy_band(muboco: MubocoPR) -> fuzzymbs.FuzzyResult:
    """The demo study's fuzzy STE at 100 N m: its inputs and levels (gear-ste, levels 3), by
    the full alpha-bound grid (the demo's adaptive method gives the same bands, docs/gears.md)."""
    k_t = muboco.defaults["tooth_stiffness"]
    k_con = muboco.defaults["contact_stiffness"]
    plan = fuzzymbs.plan(
        {
            "tooth_stiffness": fuzzymbs.Triangular(0.8 * k_t, k_t, 1.2 * k_t),
            "contact_stiffness": fuzzymbs.Triangular(0.7 * k_con, k_con, 1.3 * k_con),
        },
        method="grid",
        levels=3,
    )
    samples = dict(zip(plan.names, plan.samples.T, strict=True))
    return plan.retransform(muboco(samples)["ste"])


def main() -> None:
    x = np.arange(POSITIONS) / POSITIONS
    muboco = MubocoPR(PAIR, torque=100.0, positions=POSITIONS, reference=False)
    fe = GearPairFE(PAIR, torque=100.0, positions=POSITIONS)
    k_con = muboco.defaults["contact_stiffness"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), sharex=True)
    print("| T1 [N m] | model | mean [um] | peak-to-peak [um] | single [um] | double [um] |")
    print("|---|---|---|---|---|---|")
    curves = {}
    for ax, torque in zip(axes, TORQUES, strict=True):
        sample = {"torque": np.array([torque])}
        fe_ste = fe(sample)["ste"][0]
        mb_ste = muboco(sample)["ste"][0]
        pe_ste = reference_ste(PAIR, torque, x, contact_stiffness=k_con)
        iso = iso_mean_ste(PAIR, torque)
        curves[torque] = (fe_ste, mb_ste, pe_ste)
        for name, ste in (("FE", fe_ste), ("MUBOCO-PR", mb_ste), ("PE", pe_ste)):
            f = features(ste)
            print(f"| {torque:g} | {name} | {f['ste_mean']:.3f} | {f['ste_peak_to_peak']:.3f} "
                  f"| {f['ste_single']:.3f} | {f['ste_double']:.3f} |")  # fmt: skip
        print(f"| {torque:g} | ISO 6336-1 (mean) | {iso * 1e6:.3f} | - | - | - |")
        if torque == 100.0:
            band = fuzzy_band(muboco)
            for level, alpha in ((0, 0.15), (1, 0.3), (2, 0.45)):
                label = "MUBOCO-PR fuzzy (mu = 0, 1/3, 2/3)" if level == 0 else None
                ax.fill_between(x, band.lower[level] * 1e6, band.upper[level] * 1e6,
                                color="C0", alpha=alpha, lw=0, label=label)  # fmt: skip
            inside = np.mean((fe_ste >= band.lower[0]) & (fe_ste <= band.upper[0]))
            cuts = [np.mean((fe_ste >= band.lower[i]) & (fe_ste <= band.upper[i])) for i in (1, 2)]
            print(f"FE inside the fuzzy support on {100 * inside:.0f} % of the period, inside "
                  f"the mu = 1/3 cut on {100 * cuts[0]:.0f} %, the mu = 2/3 cut on "
                  f"{100 * cuts[1]:.0f} %; support width "
                  f"{1e6 * np.mean(band.upper[0] - band.lower[0]):.2f} um on average")  # fmt: skip
        ax.plot(x, mb_ste * 1e6, color="C0", lw=1.5, label="MUBOCO-PR (modal values)")
        ax.plot(x, pe_ste * 1e6, "--", color="C1", lw=1.2, label="potential energy")
        ax.axhline(iso * 1e6, color="C2", ls=":", lw=1.2, label="ISO 6336-1 mean")
        ax.plot(x, fe_ste * 1e6, "kx", ms=4, label="FE (gear-pair-fe)")
        ax.set_title(f"T1 = {torque:g} N m")
        ax.set_xlabel("mesh position [period]")
        ax.grid(alpha=0.3)
    # load shares at 100 N m: FE's load_share beside MUBOCO-PR's pair forces
    fe_force = fe.solve({})["pair_force"][0]
    mb_force = muboco.solve({})["pair_force"][0]
    for position in (0, 30, 40, 41, 58):
        fe_share, mb_share = (
            np.round(force[position] / force[position].sum(), 3).tolist()
            for force in (fe_force, mb_force)
        )
        print(f"load share at position {position / POSITIONS:.3f} (pairs {fe.pairs.tolist()}): "
              f"FE {fe_share}, MUBOCO-PR {mb_share}")  # fmt: skip
    axes[0].set_ylabel("STE [um]")
    axes[1].legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(FIGURES / "gears-fe-comparison.png", dpi=110)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 5))
    options = MeshOptions()
    mesh = mesh_gear(PAIR.pinion, options.fine_size * PAIR.pinion.module,
                     options.coarse_size * PAIR.pinion.module, options.loaded_teeth,
                     options.grid_points)  # fmt: skip
    for ax in (ax1, ax2):
        ax.triplot(mesh.points[:, 0] * 1e3, mesh.points[:, 1] * 1e3, mesh.triangles, lw=0.2)
        ax.set_aspect("equal")
    ax2.plot(*(mesh.points[mesh.grid_vertices.ravel()] * 1e3).T, "r.", ms=3)
    ax2.set_xlim(36, 50.5)
    ax2.set_ylim(-9, 9)
    ax1.set_title(f"pinion, default mesh ({len(mesh.triangles)} triangles)")
    ax2.set_title("loaded teeth; influence grid (red)")
    for ax in (ax1, ax2):
        ax.set_xlabel("x [mm]")
    fig.tight_layout()
    fig.savefig(FIGURES / "gears-fe-mesh.png", dpi=110)


if __name__ == "__main__":
    main()
