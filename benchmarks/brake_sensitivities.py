"""The brake's outputs' derivatives from forward sensitivities: accuracy and cost.

    python benchmarks/brake_sensitivities.py [--parts accuracy cost rk4] [--t-end S]
        [--cost-t-end S] [--rtol ...] [--cost-rtol ...] [--shared-rtol R] [--repeats N]
        [--delta D]

Prints readable tables to stderr and one JSON line to stdout.

**accuracy** (nominal brake over ``--t-end``, default 1 ms, recorded every 10 us): the
derivatives of y_lpad, y_upad, y_cali with respect to k, k_c, F_n and omega from
``simulate(..., sensitivities=...)`` against central differences (1e-3 relative) of
whole runs at rtol 1e-6 on the modal sample's own rtol 1e-6 step sequence (both
differenced runs take the same steps, so the difference is smooth; cached in
``benchmarks/.cache/``; differences at 1e-4 relative give ``fd_step_check``, the
reference's own uncertainty). Errors: the largest over time relative to each derivative's
peak, and on the scale a fuzzy surrogate reads them (``band``): the change a derivative
predicts over a parameter's half-width w_k, summed over a study's parameters,
``max_t sum_k |error_k(t)| w_k`` divided by the linear estimate of the mu = 0 half-width
``max(sum_k |dy/dp_k(t)| w_k, 0.1 of its largest)`` (study 1: k, k_c +-10 %, F_n +-1 %;
study 2: k, k_c, omega +-10 %). Also ``shared``: on a step sequence logged at
``--shared-rtol`` (default 1e-3), the sensitivities against central differences of
runs on the same sequence (the
derivative of the discrete map a study on shared steps evaluates).

**cost** (a block of four samples: the nominal and three corners of study 1's mu = 0 box,
over ``--cost-t-end``, default 2 ms, at each ``--rtol``): process CPU time of the call
(the smallest of ``--repeats``, the variants alternating) and the kernel's counts, for no
sensitivities and for 1 (each of study 1's parameters), study 1's three, study 2's three
and all four; the ratios against the run without, in the same process. ``shared steps``:
ROS34PW2 with every lane on the nominal sample's sequence logged at that rtol, taking its
logged Jacobians (a study's runs, whose lanes step together), without sensitivities and
with study 1's three.

**rk4** (RK4 at 1 us, whose model gives its gradients as central differences on its
fixed steps, :func:`fuzzymbs.mbs.central_differences.on_fixed_steps`): the nominal
brake's derivatives over ``--t-end`` against the accuracy's reference (errors as
there), their change from relative step 1e-4 to 1e-5 on each derivative's peak, and
the cost block above over ``--cost-t-end`` with study 1's three parameters against
none (CPU, the smallest of ``--repeats``).

``--delta``: the differences' relative perturbation instead of the kernel's
(:data:`fuzzymbs.mbs.kernels.sensitivities.SENS_DELTA`), for its choice.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

import fuzzymbs.mbs.central_differences as central_differences
from fuzzymbs.mbs import integrate
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

OUTPUTS = {
    "y_lpad": Coordinate("lower_pad", 0),
    "y_upad": Coordinate("upper_pad", 0),
    "y_cali": Coordinate("caliper", 0),
}
RECORD = 1e-5  # s
NOMINAL = {
    "pad_spring_stiffness": 200e3,
    "caliper_spring_stiffness": 1e3,
    "nodal_force": 16e3,
    "disc_speed": 1.0,
}
NAMES = tuple(NOMINAL)
SHORT = {
    "pad_spring_stiffness": "k",
    "caliper_spring_stiffness": "k_c",
    "nodal_force": "F_n",
    "disc_speed": "omega",
}
#: half-widths of the studies' mu = 0 cuts, relative to the nominal value
STUDIES = {
    "study 1": {"pad_spring_stiffness": 0.1, "caliper_spring_stiffness": 0.1, "nodal_force": 0.01},
    "study 2": {"pad_spring_stiffness": 0.1, "caliper_spring_stiffness": 0.1, "disc_speed": 0.1},
}
REFERENCE_RTOL = 1e-6
FD_STEP = 1e-3  # relative step of the central differences
CACHE = Path(__file__).resolve().parent / ".cache"


def _columns(rows: dict[str, list[float]] | dict[str, float]) -> dict[str, np.ndarray]:
    return {name: np.atleast_1d(np.asarray(values, dtype=float)) for name, values in rows.items()}


def run_brake(compiled, samples, t_end: float, rtol: float, integrator: str = "ros34pw2", **extra):
    """``simulate`` of the brake with this benchmark's settings (records every 10 us, the
    three outputs, ``integrator`` at ``rtol``), ``extra`` its further arguments."""
    return simulate(
        compiled,
        samples,
        t_end=t_end,
        dt=1e-6,
        record_interval=RECORD,
        outputs=OUTPUTS,
        integrator=integrator,
        tolerance=Tolerance(rtol),
        **extra,
    )


def _central_differences(compiled, t_end, rtol, sequence, renewals, step):
    """{output: (T, 4)} central differences of runs on ``sequence`` at ``rtol``."""
    rows: dict[str, list[float]] = {name: [] for name in NAMES}
    for name in NAMES:
        for sign in (1.0, -1.0):
            for other in NAMES:
                factor = 1.0 + sign * step if other == name else 1.0
                rows[other].append(NOMINAL[other] * factor)
    runs = run_brake(
        compiled,
        _columns(rows),
        t_end,
        rtol,
        step_sequence=sequence,
        jacobian_renewals=renewals,
    )
    if runs.failed.any():
        raise RuntimeError("a differenced run failed")
    out = {}
    for output in OUTPUTS:
        y = runs.outputs[output].reshape(len(NAMES), 2, -1)
        out[output] = np.stack(
            [(y[k, 0] - y[k, 1]) / (2 * step * NOMINAL[name]) for k, name in enumerate(NAMES)],
            axis=-1,
        )
    return out, runs.step_counts


def logged_sequence(compiled, t_end: float, rtol: float) -> tuple[np.ndarray, np.ndarray]:
    """The nominal sample's accepted steps at ``rtol`` with ROS34PW2 and where each took a
    fresh Jacobian (the shared sequence the central differences replay)."""
    log = run_brake(compiled, _columns(NOMINAL), t_end, rtol, log_steps=True)
    return log.step_times, log.step_renewals


def reference(compiled, t_end: float) -> dict[str, np.ndarray]:
    """Central differences at rtol 1e-6 (and their step check), cached on disk."""
    key = hashlib.sha256(f"sens-ref {t_end} {REFERENCE_RTOL} {FD_STEP} v1".encode()).hexdigest()
    path = CACHE / f"brake_sensitivities_{key[:16]}.npz"
    if path.is_file():
        with np.load(path) as data:
            return {name: data[name] for name in data.files}
    seq, ren = logged_sequence(compiled, t_end, REFERENCE_RTOL)
    fine, _ = _central_differences(compiled, t_end, REFERENCE_RTOL, seq, ren, FD_STEP)
    check, _ = _central_differences(compiled, t_end, REFERENCE_RTOL, seq, ren, FD_STEP / 10)
    data = {**fine, **{f"{name}_check": values for name, values in check.items()}}
    CACHE.mkdir(exist_ok=True)
    np.savez(path, **data)
    return data


def errors(gradients, truth) -> dict:
    """Per output: the error relative to each derivative's peak, and the band errors."""
    out = {}
    for output in OUTPUTS:
        r = truth[output]
        g = np.asarray(gradients[output]).reshape(r.shape)
        peak = np.abs(r).max(axis=0)
        entry = {
            "peak": {SHORT[n]: float(f"{v:.3e}") for n, v in zip(NAMES, peak, strict=True)},
            "relative": {
                SHORT[n]: float(f"{v:.2e}")
                for n, v in zip(NAMES, np.abs(g - r).max(axis=0) / peak, strict=True)
            },
        }
        for study, widths in STUDIES.items():
            w = np.array([widths.get(n, 0.0) * NOMINAL[n] for n in NAMES])
            half = np.abs(r) @ w
            wrong = np.abs(g - r) @ w
            scale = np.maximum(half, 0.1 * half.max())
            entry[study] = float(f"{(wrong / scale).max():.2e}")
        out[output] = entry
    return out


def accuracy(t_end: float, rtols: list[float], shared_rtol: float = 1e-3) -> dict:
    compiled = DiscBrake(t_end=t_end, record_interval=RECORD).compiled
    truth = reference(compiled, t_end)
    result: dict = {"t_end_s": t_end, "reference": f"central differences, rtol {REFERENCE_RTOL}"}
    result["fd_step_check"] = {
        output: {
            SHORT[n]: float(f"{v:.1e}")
            for n, v in zip(
                NAMES,
                np.abs(truth[output] - truth[f"{output}_check"]).max(0)
                / np.abs(truth[output]).max(0),
                strict=True,
            )
        }
        for output in OUTPUTS
    }
    rows = []
    for integrator in ("ros34pw2", "rodas4"):
        for rtol in rtols:
            start = time.process_time()
            run = run_brake(
                compiled,
                _columns(NOMINAL),
                t_end,
                rtol,
                integrator,
                sensitivities=NAMES,
                kernel="samples",
            )
            rows.append(
                {
                    "integrator": integrator,
                    "rtol": rtol,
                    "cpu_s": round(time.process_time() - start, 2),
                    "errors": errors(run.gradients, truth),
                }
            )
    result["own_steps"] = rows
    # on a shared sequence: the derivative of the discrete map
    rtol = shared_rtol
    seq, ren = logged_sequence(compiled, t_end, rtol)
    discrete, counts = _central_differences(compiled, t_end, rtol, seq, ren, FD_STEP)
    run = run_brake(
        compiled,
        _columns(NOMINAL),
        t_end,
        rtol,
        step_sequence=seq,
        jacobian_renewals=ren,
        sensitivities=NAMES,
    )
    result["shared"] = {
        "rtol": rtol,
        "differenced_runs_rejected_steps": counts[:, 1].tolist(),
        "against_the_discrete_map": errors(run.gradients, discrete),
        "against_the_reference": errors(run.gradients, truth),
        "discrete_map_against_the_reference": errors(discrete, truth),
    }
    return result


#: the cost block: the nominal sample and three corners of study 1's mu = 0 box
COST_BLOCK = {
    "pad_spring_stiffness": 200e3 * np.array([1.0, 0.9, 1.1, 0.9]),
    "caliper_spring_stiffness": 1e3 * np.array([1.0, 1.1, 0.9, 0.9]),
    "nodal_force": 16e3 * np.array([1.0, 1.01, 0.99, 0.99]),
}


def rk4(t_end: float, cost_t_end: float, repeats: int) -> dict:
    """RK4's central-difference gradients: accuracy against the reference, the change
    from step 1e-4 to 1e-5, and their cost with study 1's parameters."""
    truth = reference(DiscBrake(t_end=t_end, record_interval=RECORD).compiled, t_end)
    model = DiscBrake(t_end=t_end, record_interval=RECORD, integrator="rk4")
    found = {}
    saved = central_differences.GRADIENT_STEP
    try:
        for step in (1e-4, 1e-5):
            central_differences.GRADIENT_STEP = step
            found[step] = model(_columns(NOMINAL), wrt=NAMES)["gradients"]
    finally:
        central_differences.GRADIENT_STEP = saved
    change = {}
    for output in OUTPUTS:
        fine, finer = found[1e-4][output][0], found[1e-5][output][0]
        ratio = np.abs(fine - finer).max(axis=0) / np.abs(finer).max(axis=0)
        change[output] = {SHORT[n]: float(f"{v:.2e}") for n, v in zip(NAMES, ratio, strict=True)}
    timed = DiscBrake(t_end=cost_t_end, record_interval=RECORD, integrator="rk4")
    study1 = NAMES[:3]
    timed(COST_BLOCK, wrt=study1)  # warm
    cpu: dict[str, list[float]] = {"none": [], "study 1 (3)": []}
    for _ in range(repeats):
        for label, names in (("none", None), ("study 1 (3)", study1)):
            start = time.process_time()
            timed(COST_BLOCK, wrt=names)
            cpu[label].append(time.process_time() - start)
    return {
        "t_end_s": t_end,
        "errors": errors({o: g[0] for o, g in found[1e-4].items()}, truth),
        "step_change_1e-4_to_1e-5": change,
        "cost": {
            "t_end_s": cost_t_end,
            "cpu_s": {label: round(min(values), 3) for label, values in cpu.items()},
            "cpu_ratio": round(min(cpu["study 1 (3)"]) / min(cpu["none"]), 3),
        },
    }


def cost(t_end: float, rtols: list[float], repeats: int) -> dict:
    compiled = DiscBrake(t_end=t_end, record_interval=RECORD).compiled
    samples = COST_BLOCK
    study1 = NAMES[:3]
    study2 = (NAMES[0], NAMES[1], NAMES[3])
    cases = {"none": (), **{SHORT[n]: (n,) for n in study1}}
    cases.update({"study 1 (3)": study1, "study 2 (3)": study2, "all 4": NAMES})
    result: dict = {"t_end_s": t_end, "block": "nominal + 3 corners of study 1's mu = 0 box"}
    for integrator in ("ros34pw2", "rodas4"):
        for rtol in rtols:
            common = (compiled, samples, t_end, rtol, integrator)
            run_brake(*common, sensitivities=study1)  # warm
            result[f"{integrator} rtol {rtol:g}"] = _cost_rows(common, cases, repeats)
    for rtol in rtols:  # a study's runs: every lane on the nominal sample's sequence
        log = run_brake(
            compiled, _columns(NOMINAL), t_end, rtol, log_steps=True, log_jacobians=True
        )
        result[f"ros34pw2 rtol {rtol:g} shared steps"] = _cost_rows(
            (compiled, samples, t_end, rtol, "ros34pw2"),
            {label: cases[label] for label in ("none", "study 1 (3)")},
            repeats,
            step_sequence=log.step_times,
            jacobian_renewals=log.step_renewals,
            logged_jacobians=log.jacobian_log,
        )
    return result


def _cost_rows(common: tuple, cases: dict, repeats: int, **extra) -> dict:
    """Per case (label -> the parameters differentiated): the smallest CPU of ``repeats``
    runs of ``run_brake(*common, **extra)`` (the cases alternating), its ratio to the case
    ``"none"``, the kernel's counts and the right-hand sides' ratio."""
    cpu: dict[str, list[float]] = {label: [] for label in cases}
    counts = {}
    for _ in range(repeats):
        for label, names in cases.items():
            start = time.process_time()
            run = run_brake(*common, sensitivities=names, **extra)
            cpu[label].append(time.process_time() - start)
            sens = 0 if run.sensitivity_rhs is None else int(run.sensitivity_rhs.max())
            counts[label] = [*run.work_counts.max(axis=0).tolist(), sens]
    base = min(cpu["none"])
    return {
        label: {
            "cpu_s": round(min(cpu[label]), 3),
            "cpu_ratio": round(min(cpu[label]) / base, 3),
            "rhs_jac_lu_sens_rhs": counts[label],
            "rhs_ratio": round((counts[label][0] + counts[label][3]) / counts["none"][0], 3),
        }
        for label in cases
    }


def _print_tables(report: dict) -> None:
    say = sys.stderr.write
    if "accuracy" in report:
        acc = report["accuracy"]
        say(f"accuracy over {acc['t_end_s']} s (error / peak: k k_c F_n omega | bands)\n")
        for row in acc["own_steps"]:
            e = row["errors"]
            cells = []
            for output in OUTPUTS:
                rel = " ".join(f"{v:.1e}" for v in e[output]["relative"].values())
                cells.append(
                    f"{output} {rel} | {e[output]['study 1']:.1e} {e[output]['study 2']:.1e}"
                )
            say(
                f"{row['integrator']} {row['rtol']:g} cpu {row['cpu_s']}: "
                + " || ".join(cells)
                + "\n"
            )
        for key in ("against_the_discrete_map", "against_the_reference"):
            e = acc["shared"][key]
            cells = [
                f"{o} "
                + " ".join(f"{v:.1e}" for v in e[o]["relative"].values())
                + f" | {e[o]['study 1']:.1e} {e[o]['study 2']:.1e}"
                for o in OUTPUTS
            ]
            say(f"shared rtol {acc['shared']['rtol']:g}, {key}: " + " || ".join(cells) + "\n")
    if "rk4" in report:
        r = report["rk4"]
        for output in OUTPUTS:
            rel = " ".join(f"{v:.1e}" for v in r["errors"][output]["relative"].values())
            step = " ".join(f"{v:.1e}" for v in r["step_change_1e-4_to_1e-5"][output].values())
            say(f"rk4 {output} (k k_c F_n omega): error / peak {rel} | step change {step}\n")
        say(f"rk4 cost with study 1's three: x{r['cost']['cpu_ratio']:.2f}\n")
    if "cost" in report:
        for key, rows in report["cost"].items():
            if not isinstance(rows, dict):
                continue
            say(f"cost {key}:\n")
            for label, row in rows.items():
                say(
                    f"  {label:12s} cpu {row['cpu_s']:.2f} s  x{row['cpu_ratio']:.2f}  "
                    f"rhs x{row['rhs_ratio']:.2f}  counts {row['rhs_jac_lu_sens_rhs']}\n"
                )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", nargs="+", default=["accuracy", "cost"])
    parser.add_argument("--t-end", type=float, default=1e-3)
    parser.add_argument("--cost-t-end", type=float, default=2e-3)
    parser.add_argument("--rtol", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4])
    parser.add_argument("--cost-rtol", type=float, nargs="+", default=[1e-2, 1e-3])
    parser.add_argument("--shared-rtol", type=float, default=1e-3)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument(
        "--delta",
        type=float,
        default=None,
        help="relative perturbation of the differences (default the kernel's SENS_DELTA)",
    )
    args = parser.parse_args()
    if args.delta is not None:
        integrate.SENS_DELTA = args.delta  # simulate reads it at every call
    report: dict = {"delta": integrate.SENS_DELTA}
    if "accuracy" in args.parts:
        report["accuracy"] = accuracy(args.t_end, args.rtol, args.shared_rtol)
    if "cost" in args.parts:
        report["cost"] = cost(args.cost_t_end, args.cost_rtol, args.repeats)
    if "rk4" in args.parts:
        report["rk4"] = rk4(args.t_end, args.cost_t_end, args.repeats)
    _print_tables(report)
    print(json.dumps(report))


if __name__ == "__main__":
    main()
