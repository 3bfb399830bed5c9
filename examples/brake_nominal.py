"""Nominal run of the disc brake: the three signals and their phase diagrams.

    python examples/brake_nominal.py [--out docs/figures] [--stability] [--studies DIR]

Integrates the brake at the paper's values (THEORY section 4; 10 ms, dt = 1e-6 s,
zero initial conditions) with the two-pass contact (the model's default) and,
for comparison, the single-pass contact and the asymmetric "hat" clamp of the
disc; prints the numbers docs/brake.md quotes and writes

* ``brake-signals.png``: y_lpad, y_upad, y_cali over time (the three variants);
* ``brake-phase.png``: phase diagrams (y, dy/dt) of the pads and the caliper;
* with ``--stability``: ``brake-stability-speed.png``, the largest real part of
  the linearised brake against the disc speed, next to the growth rate measured
  in time integrations (from rest, and from steady sliding plus a 1 nm push);
* with ``--studies DIR`` (the output of ``fuzzymbs demo brake --out DIR``):
  ``brake-study1-bands.png``, ``brake-study2-bands.png``, zoomed alpha-cut bands
  and the width of the support over time, and the time-averaged relative influences.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.linearize import eigenanalysis
from fuzzymbs.models.brake import BrakeDesign, DiscBrake, growth_rate, stability_analysis

SIGNALS = (("y_lpad", "lower pad"), ("y_upad", "upper pad"), ("y_cali", "caliper"))


def separation_time(y_l: np.ndarray, y_u: np.ndarray, t: np.ndarray, tol: float) -> float:
    """First time [s] at which |y_lpad + y_upad| (zero for mirror-symmetric pads) exceeds tol."""
    hit = np.flatnonzero(np.abs(y_l + y_u) > tol)
    return float(t[hit[0]]) if hit.size else float("nan")


def nominal(out: Path) -> dict:
    runs = {}
    variants = {
        "two-pass": ("two-pass", BrakeDesign()),
        "single-pass": ("single-pass", BrakeDesign()),
        "two-pass, hat clamp": ("two-pass", BrakeDesign(disc_clamp="hat")),
    }
    for label, (contact, design) in variants.items():
        # every step recorded: the pads ring at 32 kHz (31 us period)
        model = DiscBrake(design, contact=contact, velocities=True, record_interval=1e-6)
        result = model({"nodal_force": np.array([16e3])})
        if result["failed"].any():
            raise RuntimeError(f"nominal {label} run failed: {result['failure_reason']}")
        runs[label] = {k: v[0] for k, v in result.items() if k.startswith(("y_", "v_"))}
        t = model.coords["time"]
    summary = {}
    late = t >= 5e-3
    for contact, r in runs.items():
        summary[contact] = {
            **{f"{k}_mean_5_10ms_um": float(1e6 * r[k][late].mean()) for k, _ in SIGNALS},
            **{f"{k}_range_5_10ms_um": float(1e6 * np.ptp(r[k][late])) for k, _ in SIGNALS},
            "pads_separate_at_1um_ms": 1e3 * separation_time(r["y_lpad"], r["y_upad"], t, 1e-6),
            "max_abs_y_cali_um": float(1e6 * np.abs(r["y_cali"]).max()),
        }

    fig, axes = plt.subplots(3, 1, figsize=(7.0, 7.5), sharex=True)
    for ax, (key, label) in zip(axes, SIGNALS, strict=True):
        for variant, style in zip(runs, ("-", "--", ":"), strict=True):
            ax.plot(1e3 * t, 1e6 * runs[variant][key], style, lw=0.8, label=variant)
        ax.set_ylabel(f"{key} [um]")
        ax.set_title(label, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time [ms]")
    fig.tight_layout()
    fig.savefig(out / "brake-signals.png", dpi=130)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(12.0, 3.8), layout="constrained")
    r = runs["two-pass"]
    for ax, (key, label) in zip(axes, SIGNALS, strict=True):
        vel = r["v" + key[1:]]
        scale, unit = (1e3, "mm/s") if key == "y_cali" else (1.0, "m/s")
        xs, ys = (1e9, "nm") if key == "y_cali" else (1e6, "um")
        for part, colour in (
            (t < 2e-3, "tab:blue"),
            ((t >= 2e-3) & (t < 6e-3), "tab:orange"),
            (t >= 6e-3, "tab:green"),
        ):
            ax.plot(xs * r[key][part], scale * vel[part], lw=0.3, color=colour)
        ax.set_xlabel(f"{key} [{ys}]")
        ax.set_ylabel(f"d{key}/dt [{unit}]")
        ax.set_title(f"{label} (two-pass)", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(["0-2 ms", "2-6 ms", "6-10 ms"], fontsize=8)
    fig.savefig(out / "brake-phase.png", dpi=130)
    plt.close(fig)
    return summary


def stability_versus_speed(out: Path) -> dict:
    speeds = np.array([1.0, 2.0, 3.0, 3.25, 3.5, 4.0, 5.0, 7.0, 10.0])
    model = DiscBrake(t_end=2e-3, record_interval=2e-6)
    compiled = model.compiled
    linear = stability_analysis(compiled, {"disc_speed": speeds}, n_modes=2)
    from_rest = model({"disc_speed": speeds})
    rest_rate = growth_rate(from_rest["y_lpad"], model.coords["time"])
    # the pad-disc (contact) modes lie above 10 kHz; below the onset the least stable
    # mode overall is a nearly undamped caliper mode (2.5 kHz) that the pads hardly see
    eig = eigenanalysis(compiled, {"disc_speed": speeds})
    n = compiled.n_dofs
    x0 = np.zeros((2 * speeds.size, 2 * n))
    x0[:, :n] = np.tile(eig.steady_state.x, (2, 1))
    contact_real = np.empty(speeds.size)
    contact_freq = np.empty(speeds.size)
    for i in range(speeds.size):
        lam = eig.eigenvalues[i]
        contact = (lam.imag >= 0) & (lam.imag / (2 * np.pi) > 10e3)
        k = int(np.argmax(np.where(contact, lam.real, -np.inf)))
        contact_real[i], contact_freq[i] = lam[k].real, lam[k].imag / (2 * np.pi)
        # steady sliding + 1 nm push along that mode, minus the unpushed run
        shape = eig.mode_shapes[i, :, k]
        x0[i, :n] += 1e-9 * shape.real
        x0[i, n:] += 1e-9 * (lam[k] * shape).real
    pushed = simulate(
        compiled,
        {"disc_speed": np.tile(speeds, 2)},
        t_end=4e-4,
        dt=1e-6,
        record_interval=2e-6,
        initial_state=x0,
        outputs=model.simulation.outputs,
    )
    diff = pushed.outputs["y_lpad"][: speeds.size] - pushed.outputs["y_lpad"][speeds.size :]
    push_rate = growth_rate(diff, pushed.time)

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(speeds, linear.max_real_part, "o-", label="linearised: max Re(lambda), all modes")
    ax.plot(speeds, contact_real, "d-", label="linearised: max Re(lambda), modes > 10 kHz")
    ax.plot(speeds, push_rate, "s--", label="integration: 1 nm push on that mode (0.4 ms)")
    ax.plot(speeds, rest_rate, "^:", label="integration: from rest (2 ms)")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("disc speed omega [rad/s]")
    ax.set_ylabel("growth rate [1/s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "brake-stability-speed.png", dpi=130)
    plt.close(fig)
    return {
        "speeds": speeds.tolist(),
        "max_real_part": linear.max_real_part.tolist(),
        "frequency_hz": linear.frequencies[:, 0].tolist(),
        "contact_mode_real_part": contact_real.tolist(),
        "contact_mode_frequency_hz": contact_freq.tolist(),
        "growth_push": push_rate.tolist(),
        "growth_from_rest": rest_rate.tolist(),
    }


def study_figure(result: Path, out: Path, stem: str) -> dict:
    """Zoomed alpha-cut bands of a study's three signals and their mu = 0 width over time."""
    import xarray

    data = xarray.open_dataset(result)
    t = data["time"].values
    levels = data["level"].values
    fig, axes = plt.subplots(3, 3, figsize=(12.0, 7.5), layout="constrained")
    windows = ((0.0, 0.1e-3), (9.9e-3, 10e-3))
    widths = {}
    for row, (key, label) in enumerate(SIGNALS):
        lower, upper = data[f"{key}_lower"].values, data[f"{key}_upper"].values
        scale, unit = (1e9, "nm") if key == "y_cali" else (1e6, "um")
        for col, (a, b) in enumerate(windows):
            ax = axes[row, col]
            m = (t >= a) & (t <= b)
            for j, mu in enumerate(levels):
                ax.fill_between(
                    1e3 * t[m],
                    scale * lower[j, m],
                    scale * upper[j, m],
                    color=plt.cm.Blues(0.25 + 0.7 * mu),
                    lw=0,
                    label=f"mu={mu:g}",
                )
            ax.set_title(f"{label}, {1e3 * a:g}-{1e3 * b:g} ms", fontsize=9)
            ax.set_ylabel(f"{key} [{unit}]")
            ax.grid(alpha=0.3)
        width = upper[0] - lower[0]
        widths[key] = {"max_support_width": float(width.max()), "at_s": float(t[width.argmax()])}
        axes[row, 2].plot(1e3 * t, scale * width, lw=0.5)
        axes[row, 2].set_title(f"{label}: width of the mu = 0 cut", fontsize=9)
        axes[row, 2].set_ylabel(f"[{unit}]")
        axes[row, 2].grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time [ms]")
    axes[0, 0].legend(fontsize=7, ncol=2)
    fig.savefig(out / f"{stem}-bands.png", dpi=120)
    plt.close(fig)
    rho = {}
    for key, _ in SIGNALS:
        rel = data[f"{key}_relative_influence"]
        rho[key] = {}
        for a, b in ((0.0, 2e-3), (2e-3, 5e-3), (5e-3, 10e-3)):
            m = (t >= a) & (t < b)
            rho[key][f"{1e3 * a:g}-{1e3 * b:g} ms"] = {
                str(p): round(float(v), 3)
                for p, v in zip(rel["parameter"].values, rel.values[:, m].mean(axis=1), strict=True)
            }
    return {"support_width": widths, "mean_relative_influence": rho}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    parser.add_argument("--stability", action="store_true", help="also the speed sweep")
    parser.add_argument(
        "--studies",
        type=Path,
        default=None,
        help="output folder of `fuzzymbs demo brake`: zoomed band figures",
    )
    parser.add_argument("--skip-nominal", action="store_true")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report = {} if args.skip_nominal else {"nominal": nominal(args.out)}
    if args.studies is not None:
        names = ("brake-study1", "brake-study2", "brake-study1-paper", "brake-study2-paper")
        for name in names:  # the demo's studies and, if run, the paper's RK4 ones (examples/)
            if (args.studies / name / "result.nc").is_file():
                report[name] = study_figure(args.studies / name / "result.nc", args.out, name)
    if args.stability:
        report["stability"] = stability_versus_speed(args.out)
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
