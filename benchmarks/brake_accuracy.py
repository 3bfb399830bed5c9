"""Time-step convergence of RK4 on the disc brake.

See docs/brake.md, "Accuracy of the time integration".

Prints the tables of that section: errors of y_lpad/y_upad over the first 0.2 ms
against DOP853 (rtol 1e-10) for dt = 2 us ... 7.8 ns; the error at dt = 1 us with one
thing switched at a time; the stiffest eigenvalue of the linearised brake times dt;
and (without ``--quick``) the 10 ms runs and the F_n +-1 % band at 1 us against a fine
step. About 3 min on one core; ``--quick`` about 25 s.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from fuzzymbs.mbs.forces import NodalForce
from fuzzymbs.mbs.integrate import simulate, simulate_reference
from fuzzymbs.mbs.linearize import eigenanalysis
from fuzzymbs.mbs.profiles import TimeProfile
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import BrakeDesign, DiscBrake
from fuzzymbs.models.brake.geometry import build_bodies
from fuzzymbs.models.brake.model import brake_system

WINDOW = 2e-4  # s
RECORD = 2e-6  # s, a multiple of every step
STEPS = [2e-6 / 2**k for k in range(9)]  # 2 us ... 7.8 ns
PADS = ("y_lpad", "y_upad")


def pads(dt: float, t_end: float = WINDOW, record: float = RECORD, sample=None, **options):
    """(2, T) pad translations (or (B, T) y_lpad for a batch ``sample``) with RK4 at dt."""
    brake = DiscBrake(t_end=t_end, dt=dt, record_interval=record, integrator="rk4", **options)
    out = brake({k: np.atleast_1d(v) for k, v in (sample or {"nodal_force": 16e3}).items()})
    if out["failed"].any():
        raise RuntimeError(f"brake run failed at dt = {dt}: {out['failure_reason']}")
    return np.array([out[name][0] for name in PADS]), out["y_lpad"], brake


def ramped_pads(dt: float, ramp: float) -> np.ndarray:
    """Pad translations with the press forces ramped linearly over ``ramp`` [s]."""
    system = brake_system(build_bodies(BrakeDesign()))
    profile = TimeProfile([0.0, ramp], [0.0, 1.0])
    system.elements = [
        dataclasses.replace(e, profile=profile) if isinstance(e, NodalForce) else e
        for e in system.elements
    ]
    outputs = {"y_lpad": Coordinate("lower_pad", 0), "y_upad": Coordinate("upper_pad", 0)}
    result = simulate(system, t_end=WINDOW, dt=dt, outputs=outputs, record_interval=RECORD)  # RK4
    return np.array([result.outputs[name][0] for name in PADS])


def relative(y: np.ndarray, reference: np.ndarray) -> float:
    """Largest deviation relative to the reference's largest magnitude."""
    return float(np.abs(y - reference).max() / np.abs(reference).max())


def convergence() -> None:
    runs = [pads(dt)[0] for dt in STEPS]
    brake = pads(1e-6)[2]
    outputs = {name: brake.simulation.outputs[name] for name in PADS}
    ref = simulate_reference(
        brake.compiled, {}, t_end=WINDOW, outputs=outputs, times=brake.coords["time"], rtol=1e-10
    )
    dop = np.array([ref[name] for name in PADS])
    print("dt [ns] | error 0-0.05 / 0-0.1 / 0-0.2 ms vs DOP853 | order (0.2 ms, to next dt)")
    errors = []
    for dt, y in zip(STEPS, runs, strict=True):
        window = [relative(y[:, : n + 1], dop[:, : n + 1]) for n in (25, 50, 100)]
        errors.append(window[-1])
        print(f"{dt * 1e9:8.2f} | " + " / ".join(f"{e:.2e}" for e in window))
    print("orders:", np.round(np.log2(np.array(errors[:-1]) / np.array(errors[1:])), 2))


def isolation() -> None:
    variants = {
        "paper's setup": {},
        "mu = 0": {"sample": {"friction_coefficient": 0.0}},
        "eps = 1e-2": {"regularization_velocity": 1e-2},
        "eps = 1e-1": {"regularization_velocity": 1e-1},
        "single-pass": {"contact": "single-pass"},
        "disc_speed = 0": {"sample": {"disc_speed": 0.0}},
        "disc 4, pads 2, caliper 2 modes": {
            "design": BrakeDesign(disc_modes=4, pad_modes=2, caliper_modes=2)
        },
    }
    print("variant | error at 1 us, 0.5 us (vs 7.8 ns) | stiffest |lambda| dt at 1 us")
    for name, options in variants.items():
        options = dict(options)
        fine = pads(STEPS[-1], **options)[0]
        e1 = relative(pads(1e-6, **options)[0], fine)
        e2 = relative(pads(5e-7, **options)[0], fine)
        brake = DiscBrake(
            t_end=1e-5, dt=1e-6, **{k: v for k, v in options.items() if k != "sample"}
        )
        sample = {k: np.array([v]) for k, v in options.get("sample", {}).items()}
        lam = eigenanalysis(brake.compiled, sample).eigenvalues[0]
        print(f"{name}: {e1:.2e}, {e2:.2e} | {np.abs(lam).max() * 1e-6:.3g}")
    fine = ramped_pads(STEPS[-1], 1e-4)
    print(f"ramp 0.1 ms: {relative(ramped_pads(1e-6, 1e-4), fine):.2e}")


def long_runs() -> None:
    steps = (2e-6, 1e-6, 5e-7, 2.5e-7, 1.25e-7, 6.25e-8, 3.125e-8, 1.5625e-8)
    print("dt [ns] | y_lpad(1 ms) | mean 5-10 ms | peak-to-peak 5-10 ms | y(10 ms) [um]")
    for dt in steps:
        y = pads(dt, t_end=1e-2, record=1e-5)[0][0] * 1e6
        late = y[500:]
        print(
            f"{dt * 1e9:7.2f} | {y[100]:.2f} | {late.mean():.2f} | {np.ptp(late):.2f} | {y[-1]:.2f}"
        )
    forces = {"nodal_force": np.array([0.99, 1.0, 1.01]) * 16e3}
    coarse = pads(1e-6, t_end=1e-2, record=1e-5, sample=forces)[1]
    fine = pads(3.125e-8, t_end=1e-2, record=1e-5, sample=forces)[1]
    t = np.arange(coarse.shape[1]) * 1e-5
    for lo, hi in ((0, 2e-4), (2e-4, 2e-3), (2e-3, 5e-3), (5e-3, 1e-2)):
        w = (t >= lo) & (t <= hi)
        wc = np.abs(coarse[2] - coarse[0])[w]
        wf = np.abs(fine[2] - fine[0])[w]
        print(
            f"{lo * 1e3:.1f}-{hi * 1e3:.1f} ms: dt error "
            f"{np.abs(coarse[1] - fine[1])[w].max() * 1e6:.2f}"
            f" um; F_n band width max {wc.max() * 1e6:.2f} / {wf.max() * 1e6:.2f} um"
            f" (1 us / 31 ns); width error {np.abs(wc - wf).max() * 1e6:.2f} um"
        )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="skip the 10 ms runs")
    args = parser.parse_args()
    convergence()
    isolation()
    if not args.quick:
        long_runs()
