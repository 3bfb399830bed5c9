"""Work-precision diagram of the disc brake's time integrators; one JSON line.

    python benchmarks/brake_work_precision.py [--quick] [--figure PATH] [--scipy-budget S]

For the 33 samples of the brake's study 1 (reduced method, levels 4: k, k_c
+-10 %, F_n +-1 %), over ``t_end`` = 10 ms recorded every 10 us:

* **error**: the largest over the samples of the peak-relative deviation of
  y_lpad and y_upad (largest over time, relative to the reference's peak) from
  RK4 at dt = 1 us / 64 = 15.625 ns, the converged reference of docs/brake.md,
  computed once for all 33 samples and cached in ``benchmarks/.cache/``;
* **cost**: wall time and process CPU time (all threads; robust against other
  jobs) of the whole 33-sample batch, warm, one :func:`simulate` call each:
  RK4 at 1 us ... 31.25 ns, ROS34PW2 at rtol 2e-2 ... 1e-4;
* **SciPy** ``solve_ivp`` Radau, BDF and LSODA per sample on the engine's compiled
  right-hand side (``rhs_sample``) with the analytic Jacobian (``jacobian``, lane 0
  of a block repeating the sample): one Python call per evaluation, so they run
  on a subset (the modal sample and a corner of the mu = 0 box) and their cost is
  extrapolated linearly to 33 samples (stated in the JSON as
  ``samples_run``); a run exceeding ``--scipy-budget`` seconds is stopped and
  reported as over budget.

Exudyn is not in the diagram: the whole brake (two flexible FFRF bodies in
regularised-friction contact) is not expressible with Exudyn's native elements;
the contact exists there only as a Python user function
(``benchmarks/brake_exudyn.py`` compares a reduced one-pad model).
``--quick``: 0.2 ms, 2 samples, two settings per integrator (smoke test).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from pathlib import Path

import numpy as np

from fuzzymbs import Triangular, plan
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels.jacobian import jacobian
from fuzzymbs.mbs.kernels.rhs import make_work, rhs_sample
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.study.integration_check import peak_relative_deviation
from fuzzymbs.tolerance import Tolerance

OUTPUTS = {
    "y_lpad": Coordinate("lower_pad", 0),
    "y_upad": Coordinate("upper_pad", 0),
}
RECORD = 1e-5  # s
REFERENCE_DT = 1e-6 / 64
RK4_STEPS = (1e-6, 5e-7, 2.5e-7, 1.25e-7, 6.25e-8, 3.125e-8)
ROS_RTOLS = (2e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4)
SCIPY = (("Radau", 1e-3), ("Radau", 1e-4), ("BDF", 1e-3), ("BDF", 1e-4), ("LSODA", 1e-4))
CACHE = Path(__file__).resolve().parent / ".cache"
L = LANES


class OverBudget(Exception):
    """A SciPy run took longer than its budget."""


def study1_samples() -> dict[str, np.ndarray]:
    """The 33 sample points of study 1 (reduced method, levels 4)."""
    numbers = {
        "pad_spring_stiffness": Triangular.relative(200e3, 0.1),
        "caliper_spring_stiffness": Triangular.relative(1e3, 0.1),
        "nodal_force": Triangular.relative(16e3, 0.01),
    }
    scheme = plan(numbers, "reduced", 4)
    return {name: np.ascontiguousarray(scheme.samples[:, i]) for i, name in enumerate(numbers)}


def error_of(outputs: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    """Largest peak-relative deviation over samples and outputs."""
    return max(
        peak_relative_deviation(outputs[name][s], reference[name][s])
        for name in OUTPUTS
        for s in range(len(reference[name]))
    )


def timed(function):
    wall, cpu = time.perf_counter(), time.process_time()
    value = function()
    return value, time.perf_counter() - wall, time.process_time() - cpu


def reference_outputs(compiled, samples, t_end: float) -> dict[str, np.ndarray]:
    """RK4 at 15.6 ns for every sample, cached on t_end and the sample table."""
    key = np.concatenate([[t_end], *samples.values()])
    digest = hashlib.sha256(key.tobytes()).hexdigest()[:16]
    path = CACHE / f"work_precision_reference_{digest}.npz"
    if path.exists():
        stored = np.load(path)
        if np.array_equal(stored["key"], key):
            return {name: stored[name] for name in OUTPUTS}
    result = simulate(
        compiled, samples, t_end=t_end, dt=REFERENCE_DT, record_interval=RECORD, outputs=OUTPUTS
    )
    if result.failed.any():
        raise RuntimeError("the RK4 reference failed")
    CACHE.mkdir(exist_ok=True)
    np.savez(path, key=key, **result.outputs)
    return dict(result.outputs)


def scipy_run(compiled, sample: dict[str, float], t_end, method, rtol, budget):
    """One sample with solve_ivp; returns its outputs (2, T)."""
    import scipy.integrate

    p = compiled.parameters.values({k: np.atleast_1d(v) for k, v in sample.items()})[0]
    n = compiled.n_dofs
    x0 = compiled.zero_state(1)[0]
    work = make_work(compiled.data)
    pl = np.ascontiguousarray(np.repeat(p, L))
    xl = np.empty(2 * n * L)
    dxl = np.empty(2 * n * L)
    jq = np.empty(n * n * L)
    jv = np.empty(n * n * L)
    full = np.zeros((2 * n, 2 * n))
    full[:n, n:] = np.eye(n)
    deadline = time.perf_counter() + budget

    def f(t, x):
        if time.perf_counter() > deadline:
            raise OverBudget
        return rhs_sample(t, np.ascontiguousarray(x), p, compiled.data, work)

    def jac(t, x):
        xl[:] = np.repeat(x, L)
        jacobian(np.full(L, t), xl, pl, compiled.data, work, dxl, jq, jv)
        full[n:, :n] = jq.reshape(n, n, L)[:, :, 0]
        full[n:, n:] = jv.reshape(n, n, L)[:, :, 0]
        return full.copy()

    times = np.arange(round(t_end / RECORD) + 1) * RECORD
    times[-1] = t_end
    solution = scipy.integrate.solve_ivp(
        f,
        (0.0, t_end),
        x0,
        method=method,
        t_eval=times,
        rtol=rtol,
        atol=1e-5 * rtol,
        jac=jac,
        first_step=1e-7,
    )
    if not solution.success:
        raise RuntimeError(solution.message)
    out_w = np.array([compiled.output_functional(spec) for spec in OUTPUTS.values()])
    return out_w @ solution.y


def main(quick: bool, figure: Path | None, budget: float) -> dict:
    t_end = 2e-4 if quick else 1e-2
    compiled = DiscBrake(t_end=t_end).compiled
    samples = study1_samples()
    if quick:
        samples = {k: v[:2] for k, v in samples.items()}
    count = len(next(iter(samples.values())))
    for options in ({"dt": 1e-6}, {"dt": 1e-7, "integrator": "ros34pw2"}):  # compile
        simulate(compiled, {}, t_end=2e-5, record_interval=1e-5, outputs=OUTPUTS, **options)
    reference, ref_wall, _ = timed(lambda: reference_outputs(compiled, samples, t_end))
    rows = []

    def batch(label, setting, **options):
        result, wall, cpu = timed(
            lambda: simulate(
                compiled, samples, t_end=t_end, record_interval=RECORD, outputs=OUTPUTS, **options
            )
        )
        failed = int(result.failed.sum())
        rows.append(
            {
                "integrator": label,
                "setting": setting,
                "error": None if failed else error_of(result.outputs, reference),
                "failed": failed,
                "wall_s": round(wall, 3),
                "cpu_s": round(cpu, 3),
                "samples_run": count,
            }
        )

    for dt in RK4_STEPS[:2] if quick else RK4_STEPS:
        batch("RK4", f"dt {dt * 1e9:g} ns", dt=dt)
    for rtol in ROS_RTOLS[:2] if quick else ROS_RTOLS:
        batch(
            "ROS34PW2",
            f"rtol {rtol:g}",
            dt=1e-7,
            integrator="ros34pw2",
            tolerance=Tolerance(rtol),
        )

    # SciPy on the modal sample and a corner of the mu = 0 box
    names = list(samples)
    nominal = {"pad_spring_stiffness": 200e3, "caliper_spring_stiffness": 1e3, "nodal_force": 16e3}
    distance = sum(abs(samples[k] - nominal[k]) / nominal[k] for k in names)
    modal, corner = int(np.argmin(distance)), int(np.argmax(distance))  # a mu = 0 corner
    subset = sorted({modal, corner})
    for method, rtol in SCIPY[:1] if quick else SCIPY:
        errors, wall_total, cpu_total, status = [], 0.0, 0.0, "ok"
        for s in subset:
            sample = {k: float(samples[k][s]) for k in names}
            try:
                y, wall, cpu = timed(
                    lambda sample=sample, method=method, rtol=rtol: scipy_run(
                        compiled, sample, t_end, method, rtol, budget
                    )
                )
            except OverBudget:
                status = f"over budget ({budget:g} s for one sample)"
                break
            except RuntimeError as exc:
                status = f"failed: {exc}"
                break
            wall_total += wall
            cpu_total += cpu
            errors.extend(
                peak_relative_deviation(y[i], reference[name][s]) for i, name in enumerate(OUTPUTS)
            )
        scale = count / len(subset)
        rows.append(
            {
                "integrator": f"SciPy {method}",
                "setting": f"rtol {rtol:g}",
                "error": max(errors) if status == "ok" else None,
                "status": status,
                "wall_s": round(wall_total * scale, 2) if status == "ok" else None,
                "cpu_s": round(cpu_total * scale, 2) if status == "ok" else None,
                "samples_run": len(subset),
                "extrapolated_to": count,
            }
        )

    base = next(r for r in rows if r["integrator"] == "RK4")["cpu_s"]
    for row in rows:
        if row.get("cpu_s"):
            row["cpu_over_rk4_1us"] = round(row["cpu_s"] / base, 2)
    figures = {
        "benchmark": "brake_work_precision",
        "quick": quick,
        "t_end_s": t_end,
        "samples": count,
        "reference": f"RK4 dt {REFERENCE_DT * 1e9:.4g} ns",
        "reference_wall_s": round(ref_wall, 1),
        "rows": rows,
    }
    if figure is not None:
        draw(rows, figure)
    return figures


def draw(rows: list[dict], path: Path) -> None:
    """Error against CPU time, log-log, one series per integrator."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    markers = {"RK4": "o-", "ROS34PW2": "s-"}
    for label in dict.fromkeys(r["integrator"] for r in rows):
        series = [r for r in rows if r["integrator"] == label and r.get("error") and r.get("cpu_s")]
        if not series:
            continue
        x = [r["cpu_s"] for r in series]
        y = [100 * r["error"] for r in series]
        ax.loglog(x, y, markers.get(label, "^--"), label=label)
        for r, xi, yi in zip(series, x, y, strict=True):
            if r["setting"] in ("dt 1000 ns", "rtol 0.01"):
                note = "paper" if label == "RK4" else "default"
                ax.annotate(f"{note}: {r['setting']}", (xi, yi), fontsize=8)
    ax.axhline(0.5, color="gray", ls=":", label="0.5 % target")
    ax.set_xlabel("CPU time for the 33-sample batch [s]")
    ax.set_ylabel("error over 10 ms [% of peak]")
    ax.set_title("Disc brake, study 1: work-precision")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="0.2 ms, 2 samples")
    parser.add_argument("--figure", type=Path, default=None, help="write the diagram here")
    parser.add_argument("--scipy-budget", type=float, default=300.0, help="s per sample")
    args = parser.parse_args()
    print(json.dumps(main(args.quick, args.figure, args.scipy_budget)))
