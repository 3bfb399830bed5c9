"""Nominal run of the disc brake: the three signals and their phase diagrams.

    python examples/brake_nominal.py [--out docs/figures] [--stability]

Integrates the brake at the paper's values (THEORY section 4; 10 ms, dt = 1e-6 s,
zero initial conditions) with the two-pass contact (the model's default) and,
for comparison, the single-pass contact; prints the numbers docs/brake.md
quotes and writes

* ``brake-signals.png``: y_lpad, y_upad, y_cali over time (both treatments);
* ``brake-phase.png``: phase diagrams (y, dy/dt) of the pads and the caliper;
* with ``--stability``: ``brake-stability-speed.png``, the largest real part of
  the linearised brake against the disc speed, next to the growth rate measured
  in time integrations (from rest, and from steady sliding plus a 1 nm push).
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
from fuzzymbs.models.brake import DiscBrake, growth_rate, stability_analysis

SIGNALS = (("y_lpad", "lower pad"), ("y_upad", "upper pad"), ("y_cali", "caliper"))


def separation_time(y_l: np.ndarray, y_u: np.ndarray, t: np.ndarray, tol: float) -> float:
    """First time [s] at which |y_lpad + y_upad| (zero for mirror-symmetric pads) exceeds tol."""
    hit = np.flatnonzero(np.abs(y_l + y_u) > tol)
    return float(t[hit[0]]) if hit.size else float("nan")


def nominal(out: Path) -> dict:
    runs = {}
    for contact in ("two-pass", "single-pass"):
        model = DiscBrake(contact=contact, velocities=True)
        result = model({"nodal_force": np.array([16e3])})
        if result["failed"].any():
            raise RuntimeError(f"nominal {contact} run failed: {result['failure_reason']}")
        runs[contact] = {k: v[0] for k, v in result.items() if k.startswith(("y_", "v_"))}
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
        for contact, style in (("two-pass", "-"), ("single-pass", "--")):
            ax.plot(1e3 * t, 1e6 * runs[contact][key], style, lw=0.8, label=contact)
        ax.set_ylabel(f"{key} [um]")
        ax.set_title(label, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time [ms]")
    fig.tight_layout()
    fig.savefig(out / "brake-signals.png", dpi=130)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(10.5, 3.6))
    r = runs["two-pass"]
    for ax, (key, label) in zip(axes, SIGNALS, strict=True):
        vel = r["v" + key[1:]]
        sc = ax.scatter(1e6 * r[key], vel, c=1e3 * t, s=0.5, cmap="viridis")
        ax.set_xlabel(f"{key} [um]")
        ax.set_ylabel(f"d{key}/dt [m/s]")
        ax.set_title(f"{label} (two-pass)", fontsize=9)
        ax.grid(alpha=0.3)
    fig.colorbar(sc, ax=axes, label="time [ms]", shrink=0.9)
    fig.savefig(out / "brake-phase.png", dpi=130, bbox_inches="tight")
    plt.close(fig)
    return summary


def stability_versus_speed(out: Path) -> dict:
    speeds = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 7.0, 10.0])
    model = DiscBrake(t_end=2e-3, record_interval=2e-6)
    compiled = model.compiled
    linear = stability_analysis(compiled, {"disc_speed": speeds}, n_modes=2)
    from_rest = model({"disc_speed": speeds})
    rest_rate = growth_rate(from_rest["y_lpad"], model.coords["time"])
    # steady sliding + 1 nm push along the least stable mode, minus the unpushed run
    eig = eigenanalysis(compiled, {"disc_speed": speeds})
    n = compiled.n_dofs
    x0 = np.zeros((2 * speeds.size, 2 * n))
    x0[:, :n] = np.tile(eig.steady_state.x, (2, 1))
    for i in range(speeds.size):
        lam = eig.eigenvalues[i]
        k = int(np.argmax(np.where(lam.imag >= 0, lam.real, -np.inf)))
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
    ax.plot(speeds, linear.max_real_part, "o-", label="linearised: max Re(lambda)")
    ax.plot(speeds, push_rate, "s--", label="integration: 1 nm push (0.4 ms)")
    ax.plot(speeds, rest_rate, "^:", label="integration: from rest (2 ms)")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("disc speed omega [rad/s]")
    ax.set_ylabel("growth rate [1/s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "brake-stability-speed.png", dpi=130)
    plt.close(fig)
    return {
        "speeds": speeds.tolist(),
        "max_real_part": linear.max_real_part.tolist(),
        "frequency_hz": linear.frequencies[:, 0].tolist(),
        "growth_push": push_rate.tolist(),
        "growth_from_rest": rest_rate.tolist(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    parser.add_argument("--stability", action="store_true", help="also the speed sweep")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report = {"nominal": nominal(args.out)}
    if args.stability:
        report["stability"] = stability_versus_speed(args.out)
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
