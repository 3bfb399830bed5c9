"""Brake study 1 (33 runs) with fuzzymbs against per-sample baselines.

fuzzymbs: ``Study("brake", ...)`` with k, k_c +-10 % and F_n +-1 %, reduced
method on mu = 0, .25, .5, .75, 1 (33 runs), the paper's RK4 at dt = 1e-6 s
(``integrator = "rk4"``: the baselines below are per RK4 step; the default
ROS34PW2 study is timed against it in ``brake_study.py``), all 33 samples in
one compiled, sample-parallel call; the wall time includes the study's own
time-integration check (the modal sample again at dt = 0.5 us), not its method check
(``validation_runs=0``: the target is the 33 runs'; the default study with its 36
validation runs is timed in ``brake_study.py``). The cost per sample-step divides by
every RK4 step the study took (its runs at 1 us, the check's re-runs at 0.5 us: twice
the steps). Full mode
integrates the paper's 10 ms; ``--quick`` integrates 1 ms and reports the
10 ms figure as ten times that (the cost per step is constant; the JSON says
which end time was run).

Baselines, one sample at a time (each reports its cost per sample-step and
the figure scaled to every step the study made over 10 ms; they run a subset of
steps):

* ``numpy_loop``: :mod:`brake_numpy` -- the same equations in plain NumPy,
  Python RK4 loop. Its trajectory is compared with the kernel's.
* ``solve_ivp``: SciPy ``solve_ivp`` on the engine's compiled right-hand side
  (one call per evaluation), at the loosest tolerance whose error against a
  tight DOP853 reference is no larger than fuzzymbs's RK4 error over the same
  window (RK45 and DOP853 are both tried; the cheaper one counts).
"""

from __future__ import annotations

import time
from typing import Any

import numba
import numpy as np
from bench_common import best_time, log

from fuzzymbs.fuzzy.numbers import Triangular
from fuzzymbs.study.study import Study

DT = 1e-6
RECORD = 5e-6
STUDY_END = 0.01
OUTPUTS = ("y_lpad", "y_upad", "y_cali")
NOMINAL = {"pad_spring_stiffness": 200e3, "caliper_spring_stiffness": 1e3, "nodal_force": 16e3}


def brake_study(t_end: float = STUDY_END, chunk_size: int = 33) -> Study:
    """Study 1 of the paper: 33 runs of the brake (reduced method, 5 levels), RK4 at 1 us."""
    k, kc, fn = (NOMINAL[n] for n in NOMINAL)
    return Study(
        "brake",
        {
            "pad_spring_stiffness": Triangular(0.9 * k, k, 1.1 * k),
            "caliper_spring_stiffness": Triangular(0.9 * kc, kc, 1.1 * kc),
            "nodal_force": Triangular(0.99 * fn, fn, 1.01 * fn),
        },
        method="reduced",
        levels=[0.0, 0.25, 0.5, 0.75, 1.0],
        outputs=list(OUTPUTS),
        model_options={"t_end": t_end, "chunk_size": chunk_size, "integrator": "rk4"},
        name="brake-study1-bench",
        validation_runs=0,
    )


def brake_model(t_end: float, record_interval: float = RECORD, chunk_size: int = 64) -> Any:
    """The registered brake model with the given end time and the paper's RK4 at 1 us, the
    integrator these per-step comparisons (NumPy, Exudyn) are about."""
    from fuzzymbs.models.brake import brake_model as factory

    return factory(
        t_end=t_end, record_interval=record_interval, chunk_size=chunk_size, integrator="rk4"
    )


def output_matrix(model: Any) -> np.ndarray:
    """Rows w with output = w . state, in the order of OUTPUTS."""
    compiled = model.compiled
    return np.array([compiled.output_functional(model.simulation.outputs[n]) for n in OUTPUTS])


def parameter_row(model: Any, sample: dict[str, float] | None = None) -> np.ndarray:
    """The compiled parameter row of one sample (defaults where not given)."""
    columns = {k: np.atleast_1d(float(v)) for k, v in (sample or NOMINAL).items()}
    return model.compiled.parameters.values(columns)


def engine_rhs(model: Any, params: np.ndarray) -> Any:
    """f(t, x) of one sample: the engine's compiled right-hand side, called serially.

    Uses the single-sample kernel entry (:func:`fuzzymbs.mbs.kernels.rhs.rhs_sample`,
    as :func:`fuzzymbs.mbs.integrate.simulate_reference` does): the public
    batched ``evaluate_rhs`` starts a parallel region per call, whose wake-up
    cost (~8 ms here under load) would dominate and flatter fuzzymbs.
    """
    from fuzzymbs.mbs.kernels.rhs import make_work, rhs_sample

    data = model.compiled.data
    work = make_work(data)
    row = np.ascontiguousarray(params[0])

    def f(t: float, x: np.ndarray) -> np.ndarray:
        return rhs_sample(float(t), np.ascontiguousarray(x), row, data, work)

    return f


def kernel_outputs(model: Any, sample: dict[str, float] | None = None) -> np.ndarray:
    """(3, T) outputs of one sample from the compiled batched kernel."""
    columns = {k: np.atleast_1d(float(v)) for k, v in (sample or NOMINAL).items()}
    result = model(columns)
    return np.array([result[n][0] for n in OUTPUTS])


# ------------------------------------------------------------------------------ baselines
def numpy_loop(steps: int, record_every: int = 5) -> dict[str, Any]:
    """Per-sample-step cost of the NumPy RK4 loop, its agreement with the kernel, contact stats."""
    from brake_numpy import NumpyRHS, rk4_numpy

    model = brake_model(steps * DT, record_every * DT)
    rhs = NumpyRHS(model.compiled.data, parameter_row(model)[0])
    x0 = np.zeros(model.compiled.n_state)
    w = output_matrix(model)
    rk4_numpy(rhs, x0, DT, 2, 1, w)  # warm-up
    rhs.stats.__init__()
    start = time.perf_counter()
    baseline = rk4_numpy(rhs, x0, DT, steps, record_every, w)
    per_step = (time.perf_counter() - start) / steps
    kernel = kernel_outputs(model)
    scale = np.max(np.abs(kernel), axis=1)
    return {
        "seconds_per_sample_step": per_step,
        "steps_timed": steps,
        "max_abs_diff_m": float(np.max(np.abs(baseline - kernel))),
        "max_rel_diff": float(np.max(np.max(np.abs(baseline - kernel), axis=1) / scale)[()]),
        "active_fraction": rhs.stats.active / max(rhs.stats.checked, 1),
    }


def _error(y: np.ndarray, reference: np.ndarray) -> float:
    """Largest output error relative to that output's largest magnitude."""
    scale = np.max(np.abs(reference), axis=1)
    return float(np.max(np.max(np.abs(y - reference), axis=1) / scale))


def solve_ivp_matched(window: float, quick: bool) -> dict[str, Any]:
    """solve_ivp at the loosest tolerance whose error is no larger than RK4's over ``window``.

    The reference is DOP853 at rtol 1e-8 (1e-6 in quick mode), atol = 1e-6 rtol; the
    adaptive solutions for rtol <= 1e-5 agree with it to ~1e-6 relative (docs), far
    below the RK4 error, so it is tight enough to measure that error.
    """
    import scipy.integrate

    model = brake_model(window)
    params = parameter_row(model)
    f = engine_rhs(model, params)
    x0 = np.zeros(model.compiled.n_state)
    f(0.0, x0)  # compile / load
    rhs_seconds = best_time(lambda: f(1e-6, x0), repeat=200)
    times = model.coords["time"]
    w = output_matrix(model)

    def solve(method: str, rtol: float) -> tuple[np.ndarray, float, int]:
        start = time.perf_counter()
        sol = scipy.integrate.solve_ivp(
            f, (0.0, window), x0, method=method, t_eval=times, rtol=rtol, atol=rtol * 1e-6
        )
        elapsed = time.perf_counter() - start
        if not sol.success:
            raise RuntimeError(f"solve_ivp {method} rtol={rtol}: {sol.message}")
        return w @ sol.y, elapsed, int(sol.nfev)

    reference_rtol = 1e-6 if quick else 1e-8
    reference, ref_seconds, ref_nfev = solve("DOP853", reference_rtol)
    rk4 = kernel_outputs(model)
    rk4_error = _error(rk4, reference)
    log(f"brake: RK4 (dt = 1 us) error over {window * 1e3:g} ms: {rk4_error:.2e}")
    tried = []
    chosen = {}
    for method in ("RK45", "DOP853"):
        for exponent in range(2, 9):
            rtol = 10.0**-exponent
            y, seconds, nfev = solve(method, rtol)
            err = _error(y, reference)
            entry = {"method": method, "rtol": rtol, "error": err, "seconds": seconds}
            entry["nfev"] = nfev
            tried.append(entry)
            if err <= rk4_error:
                chosen[method] = entry
                break
    if not chosen:
        raise RuntimeError(f"no solve_ivp tolerance reached the RK4 error {rk4_error:.2e}")
    best = min(chosen.values(), key=lambda e: e["seconds"])
    steps = round(window / DT)
    return {
        "window_s": window,
        "reference": {"method": "DOP853", "rtol": reference_rtol, "nfev": ref_nfev},
        "reference_seconds": ref_seconds,
        "rk4_error": rk4_error,
        "rk4_rhs_evaluations": 4 * steps,
        "engine_rhs_seconds_per_call": rhs_seconds,
        "chosen": best,
        "tried": tried,
        "seconds_per_sample_step": best["seconds"] / steps,
    }


def run(quick: bool = False) -> dict[str, Any]:
    """Time the brake study and the per-sample baselines; return the figures."""
    end = 1e-3 if quick else STUDY_END
    study = brake_study(end)
    runs = len(study.plan)
    steps = round(end / DT)
    log(f"brake: {runs} runs x {steps} steps; warm-up (compile or load cache)")
    brake_study(20 * DT).run(progress=False)  # compiles the kernels (or loads the cache)
    cpu_start = time.process_time()
    results = []
    study_seconds = best_time(lambda: results.append(study.run(progress=False)), repeat=1)
    # CPU time of all threads: not inflated when other jobs share the cores
    study_cpu = time.process_time() - cpu_start
    scale_to_paper = STUDY_END / end
    attrs = results[-1].dataset.attrs
    # every RK4 step the study took: its runs at 1 us, the check's re-runs at 0.5 us
    sample_steps = steps * (
        runs + int(attrs.get("validation_runs", 0)) + 2 * int(attrs["time_integration_runs"])
    )
    per_sample_step = study_seconds / sample_steps
    log(f"brake: study {study_seconds:.2f} s for {end * 1e3:g} ms ({per_sample_step * 1e6:.2f} us)")

    # the baselines make every step the study made (the check's re-runs included)
    total_steps = round(sample_steps * scale_to_paper)
    numpy_result = numpy_loop(60 if quick else 400)
    log(f"brake: numpy loop {numpy_result['seconds_per_sample_step'] * 1e3:.2f} ms/sample-step")
    ivp = solve_ivp_matched(5e-5 if quick else 2e-4, quick)
    log(f"brake: solve_ivp {ivp['chosen']} -> {ivp['seconds_per_sample_step'] * 1e6:.1f} us")
    study_paper = study_seconds * scale_to_paper
    # the study's CPU time over its threads: its wall time on idle cores (other jobs on a
    # shared machine inflate the wall time, not the CPU time)
    study_idle = study_cpu * scale_to_paper / numba.config.NUMBA_NUM_THREADS
    numpy_seconds = numpy_result["seconds_per_sample_step"] * total_steps
    ivp_seconds = ivp["seconds_per_sample_step"] * total_steps
    return {
        "brake_runs": runs,
        "brake_study_sample_steps": sample_steps,
        "brake_end_time_run_s": end,
        "brake_study_seconds": study_paper,
        "brake_study_seconds_measured": study_seconds,
        "brake_study_cpu_seconds": study_cpu * scale_to_paper,
        "brake_study_idle_core_seconds": study_idle,
        "brake_seconds_per_sample_step": per_sample_step,
        "brake_numpy_loop_seconds_per_sample_step": numpy_result["seconds_per_sample_step"],
        "brake_numpy_loop_steps_timed": numpy_result["steps_timed"],
        "brake_numpy_loop_seconds_scaled": numpy_seconds,
        "brake_numpy_loop_max_rel_diff": numpy_result["max_rel_diff"],
        "brake_contact_active_fraction": numpy_result["active_fraction"],
        "brake_speedup_vs_numpy_loop": numpy_seconds / study_paper,
        "brake_speedup_vs_numpy_loop_idle_cores": numpy_seconds / study_idle,
        "brake_solve_ivp": ivp,
        "brake_solve_ivp_seconds_scaled": ivp_seconds,
        "brake_speedup_vs_solve_ivp": ivp_seconds / study_paper,
        "brake_speedup_vs_solve_ivp_idle_cores": ivp_seconds / study_idle,
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(quick=True)))
