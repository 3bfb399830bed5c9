"""Regenerate the validation figures of docs/gears.md (docs/figures/gears-*.png).

Run from the repository root::

    python examples/gears_figures.py

Prints the numbers quoted in docs/gears.md as well.
"""

from __future__ import annotations

import math
import shutil
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fuzzymbs.models.gears import MubocoPR, iso_mean_ste, iso_pair_stiffness, make_pair
from fuzzymbs.models.gears.identification import hinge_lever_arm, weber_banaschek_approach
from fuzzymbs.models.gears.potential_energy import contact_positions, reference_ste

FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures"
TORQUE = 100.0


def rotate(points: np.ndarray, angle: float, centre=(0.0, 0.0)) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]]) + np.asarray(centre)


def gear_outline(gear, angle: float, centre=(0.0, 0.0)) -> np.ndarray:
    """Closed outline of all teeth of a gear turned by ``angle``."""
    half = gear.half_profile(120)
    tooth = np.vstack((half[::-1] * [1, -1], half))  # -y flank root->tip, +y tip->root
    parts = []
    for k in range(gear.teeth):
        parts.append(rotate(tooth, angle + k * gear.angular_pitch, centre))
    return np.vstack([*parts, parts[0][:1]])


def figure_geometry(pair) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 5))
    gear = pair.pinion
    fillet, flank = gear.fillet(60), gear.flank(60)
    for sign in (1, -1):
        ax1.plot(fillet[:, 0] * 1e3, sign * fillet[:, 1] * 1e3, color="C1", lw=2)
        ax1.plot(flank[:, 0] * 1e3, sign * flank[:, 1] * 1e3, color="C0", lw=2)
    for radius, name in (
        (gear.base_radius, "base"),
        (gear.root_radius, "root"),
        (gear.pitch_radius, "pitch"),
        (gear.tip_radius, "tip"),
    ):
        phi = np.linspace(-0.2, 0.2, 50)
        ax1.plot(radius * np.cos(phi) * 1e3, radius * np.sin(phi) * 1e3, "k:", lw=0.7)
        ax1.annotate(name, (radius * 1e3, 0.2 * radius * 1e3 + 0.3), fontsize=8)
    ax1.plot(gear.root_radius * 1e3, 0, "ks")
    ax1.annotate("hinge", (gear.root_radius * 1e3 + 0.2, -0.6))
    ax1.set_aspect("equal")
    ax1.set_xlim(37, 51)
    ax1.set_title("pinion tooth: involute (blue), trochoidal fillet (orange)")
    ax1.set_xlabel("x [mm]")
    ax1.set_ylabel("y [mm]")
    # the mesh: pinion and wheel near the pitch point, with the line of action
    from fuzzymbs.models.gears.flank_contact import PHI_REF2, THETA_REF1, pack_geometry

    g = pack_geometry(pair)
    p = 0.3
    theta = g[THETA_REF1] + p * pair.pinion.angular_pitch
    phi = g[PHI_REF2] - p * pair.wheel.angular_pitch
    ax2.plot(*(gear_outline(pair.pinion, theta) * 1e3).T, color="C0", lw=1)
    ax2.plot(*(gear_outline(pair.wheel, phi, (pair.center_distance, 0)) * 1e3).T, color="C2", lw=1)
    aw = pair.operating_pressure_angle
    t1 = pair.pinion.base_radius * np.array([math.cos(aw), -math.sin(aw)])
    u = np.array([math.sin(aw), math.cos(aw)])
    s_a, s_e = pair.path_of_contact
    line = np.array([t1 + s_a * u, t1 + s_e * u]) * 1e3
    ax2.plot(*line.T, "r-", lw=2, label="path of contact A-E")
    ax2.set_xlim(30, 80)
    ax2.set_ylim(-22, 22)
    ax2.set_aspect("equal")
    ax2.legend(loc="lower left")
    teeth = f"{pair.pinion.teeth}/{pair.wheel.teeth}"
    ax2.set_title(f"z {teeth} in mesh, eps = {pair.contact_ratio:.3f}")
    ax2.set_xlabel("x [mm]")
    fig.tight_layout()
    fig.savefig(FIGURES / "gears-geometry.png", dpi=120)
    plt.close(fig)


def figure_identification(pair, model) -> None:
    ident = model.identified
    s = ident.s
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    x = (s - s[0]) / pair.base_pitch
    kt = ident.tooth_stiffness
    ax1.plot(x, ident.pe_pinion * 1e9, "C0-", label="PE pinion tooth")
    ax1.plot(x, ident.lever_pinion**2 / kt * 1e9, "C0--", label="hinge d1^2/k_t")
    ax1.plot(x, ident.pe_wheel * 1e9, "C2-", label="PE wheel tooth")
    ax1.plot(x, ident.lever_wheel**2 / kt * 1e9, "C2--", label="hinge d2^2/k_t")
    total = ident.pe_pinion + ident.pe_wheel
    fitted = (ident.lever_pinion**2 + ident.lever_wheel**2) / kt
    ax1.plot(x, total * 1e9, "k-", label="PE sum")
    ax1.plot(x, fitted * 1e9, "k--", label=f"hinge sum (k_t = {kt:.0f} N m/rad)")
    ax1.set_xlabel("contact position along the path A-E [base pitches]")
    ax1.set_ylabel("tooth compliance along the line of action [um/kN]")
    ax1.set_title(f"tooth stiffness fit (RMS misfit {100 * ident.fit_error:.1f} %)")
    ax1.legend(fontsize=7)
    loads = np.linspace(200.0, 3000.0, 50)
    s_pitch = pair.pinion.base_radius * math.tan(pair.operating_pressure_angle)
    from fuzzymbs.models.gears.identification import contact_depth

    wb = weber_banaschek_approach(
        loads,
        pair.pinion.face_width,
        (s_pitch, pair.line_of_action_length - s_pitch),
        (
            contact_depth(pair.pinion, s_pitch),
            contact_depth(pair.wheel, pair.line_of_action_length - s_pitch),
        ),
        (pair.pinion.youngs_modulus, pair.wheel.youngs_modulus),
        (pair.pinion.poisson_ratio, pair.wheel.poisson_ratio),
    )
    ax2.plot(wb * 1e6, loads, "k-", label="Weber-Banaschek at the pitch point")
    ax2.plot(
        ident.contact_approach * 1e6, ident.contact_loads, "C1.", ms=3, label="pair loads used"
    )
    delta = np.linspace(0, wb.max(), 20)
    ax2.plot(delta * 1e6, ident.contact_stiffness * delta, "C3--", label="fitted k_con delta")
    ax2.set_xlabel("approach delta [um]")
    ax2.set_ylabel("normal force [N]")
    ax2.set_title(f"contact stiffness k_con = {ident.contact_stiffness:.3g} N/m")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURES / "gears-identification.png", dpi=120)
    plt.close(fig)


def figure_ste_validation(pair, model) -> dict[str, float]:
    positions = model.positions
    nominal = model({})["ste"][0]
    reference = model.reference["ste"]
    kt, kc = model.defaults["tooth_stiffness"], model.defaults["contact_stiffness"]
    s = contact_positions(pair, positions)
    d1 = hinge_lever_arm(pair.pinion, np.nan_to_num(s))
    d2 = hinge_lever_arm(pair.wheel, pair.line_of_action_length - np.nan_to_num(s))
    stiffness = np.where(np.isfinite(s), 1 / (1 / kc + d1**2 / kt + d2**2 / kt), 0.0)
    closed = TORQUE / pair.pinion.base_radius / stiffness.sum(axis=1)
    rigid = model({"tooth_stiffness": [np.inf]})["ste"][0]
    iso = iso_mean_ste(pair, TORQUE)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(positions, nominal * 1e6, "k-", lw=2, label="MUBOCO-PR (Newton, corner contact)")
    ax.plot(positions, closed * 1e6, "C0--", label="closed form (linear, rigid kinematics)")
    ax.plot(positions, reference * 1e6, "C3-.", label="potential-energy reference")
    ax.plot(positions, rigid * 1e6, "C2:", label="rigid teeth (contact only)")
    ax.axhline(iso * 1e6, color="C1", lw=1, label="ISO 6336-1 mean F/(c_gamma_alpha b)")
    ax.axhline(nominal.mean() * 1e6, color="k", lw=0.7, ls=":", label="MUBOCO-PR mean")
    ax.set_xlabel("mesh position [fraction of the mesh period]")
    ax.set_ylabel("STE [um]")
    ax.set_title(f"STE at T1 = {TORQUE:.0f} N m, identified modal values")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_ylim(0, None)
    fig.tight_layout()
    fig.savefig(FIGURES / "gears-ste-validation.png", dpi=120)
    plt.close(fig)
    return {
        "mean_muboco_um": nominal.mean() * 1e6,
        "mean_reference_um": reference.mean() * 1e6,
        "mean_closed_um": closed.mean() * 1e6,
        "iso_mean_um": iso * 1e6,
        "peak_to_peak_muboco_um": np.ptp(nominal) * 1e6,
        "peak_to_peak_reference_um": np.ptp(reference) * 1e6,
    }


def figure_dynamics(pair) -> None:
    speeds = [300.0, 3000.0, 9000.0, 13500.0]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    amplitudes = []
    for speed in speeds:
        settings = {"speed_rpm": speed, "mesh_periods": 12, "output_periods": 3}
        model = MubocoPR(pair, torque=TORQUE, mode="dynamic", damping=3000.0, dynamic=settings)
        out = model({})
        time = model.coords["time"]
        mesh = (time - time[0]) * settings["speed_rpm"] * pair.pinion.teeth / 60
        ax1.plot(mesh, out["dte"][0] * 1e6, label=f"{speed:.0f} rpm")
        amplitudes.append(out["dte_spectrum"][0])
    ax1.set_xlabel("time [mesh periods]")
    ax1.set_ylabel("DTE [um]")
    ax1.legend(fontsize=8)
    ax1.set_title("dynamic transmission error (c = 3000 N s/m)")
    width = 0.2
    harmonics = np.arange(1, len(amplitudes[0]) + 1)
    for i, (speed, amp) in enumerate(zip(speeds, amplitudes, strict=True)):
        ax2.bar(harmonics + (i - 1.5) * width, amp * 1e6, width, label=f"{speed:.0f} rpm")
    ax2.set_xlabel("harmonic of the mesh frequency")
    ax2.set_ylabel("DTE amplitude [um]")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURES / "gears-dynamic.png", dpi=120)
    plt.close(fig)


def figure_fuzzy_study() -> None:
    from importlib import resources

    from fuzzymbs.study.pipeline import run_study_file

    demo = resources.files("fuzzymbs") / "demos" / "gear-ste"
    with tempfile.TemporaryDirectory() as tmp:
        for study, name in (("01-ste-adaptive.toml", "adaptive"), ("02-ste-influence.toml", "reduced")):
            out = Path(tmp) / name
            run_study_file(demo / study, out, progress=False)
            for png in out.glob("*.png"):
                shutil.copy(png, FIGURES / f"gears-{name}-{png.name}")


def main() -> None:
    FIGURES.mkdir(parents=True, exist_ok=True)
    pair = make_pair()
    model = MubocoPR(pair, torque=TORQUE, positions=100)
    ident = model.identified
    iso = iso_pair_stiffness(pair, TORQUE)
    print(f"contact ratio {pair.contact_ratio:.4f}, base pitch {pair.base_pitch * 1e3:.4f} mm")
    print(
        f"identified: k_t = {ident.tooth_stiffness:.1f} (pinion {ident.pinion_tooth_stiffness:.1f},"
        f" wheel {ident.wheel_tooth_stiffness:.1f}) N m/rad, fit RMS {ident.fit_error:.3f};"
        f" k_con = {ident.contact_stiffness:.4g} N/m"
    )
    print(
        f"ISO: c'_th {iso.single_theoretical:.3f}, c' {iso.single:.3f},"
        f" c_gamma_alpha {iso.mesh:.3f} N/(mm um)"
    )
    figure_geometry(pair)
    figure_identification(pair, model)
    numbers = figure_ste_validation(pair, model)
    print({k: round(v, 3) for k, v in numbers.items()})
    figure_dynamics(pair)
    figure_fuzzy_study()
    print(f"figures written to {FIGURES}")
    _ = reference_ste  # the reference curve is model.reference["ste"]


if __name__ == "__main__":
    main()
