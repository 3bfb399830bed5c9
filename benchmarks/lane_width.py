"""CPU per sample-step of the kernels at 4 and at 8 lanes per vector; prints one JSON line.

    python benchmarks/lane_width.py [--rounds 3] [--repeat 2] [--quick] [--cases ...]

The lane count (:data:`fuzzymbs.mbs.kernels.simd.LANES`) is fixed at import, so
every measurement runs in a fresh interpreter with ``FUZZYMBS_LANES`` set, 4 and 8
alternating for ``--rounds`` rounds, each width with a Numba cache directory of its
own (benchmarks/.cache/numba-lanes4, -lanes8: a cached kernel holds one width). One
kernel thread (``NUMBA_NUM_THREADS=1``); CPU time (``time.process_time``) of the
call after a warm-up call, the smallest of ``--repeat`` calls per process and of the
rounds. Cases, on the brake (:class:`~fuzzymbs.models.brake.DiscBrake`) with
study 1's samples (k, k_c +-10 %, F_n +-1 %; the 33 of the reduced plan, or a
7 x 7 x 7 grid over the supports):

* ``rk4_343``: RK4 at 1 us, the 343 grid samples over 0.2 ms;
* ``rk4_33``: RK4 at 1 us, the 33 samples over 1 ms;
* ``ros_own``: ROS34PW2 at rtol 1e-3, the 33 samples on their own steps over 1 ms;
* ``ros_shared``: the same on the modal sample's step sequence (``share_steps``; the
  sequence's logging and reference runs are not timed);
* ``sens``: ``ros_own`` with the three parameters' forward sensitivities;
* ``single``: ``ros_own`` of the modal sample alone (a block whose lanes repeat it);
* ``study``: the shared-step study as ``DiscBrake.share_steps`` runs it, at the
  default tolerance (rtol 1e-2): the modal sample's logging run and its reference
  block (three lanes: rtol 1e-5, 1e-6 and the run logged ahead at 1e-4) timed with
  the 33 samples on the shared steps and the correction (sample-steps: the 33
  samples' only);
* ``planar``: the flexible slider-crank (DOP853), 11 samples over 40 ms (its
  own lane kernels, DOP853 on their own steps).

Per case and width: CPU seconds, sample-steps (samples x steps; ROS34PW2: each
sample's accepted and rejected steps, the padding lanes not counted), CPU
microseconds per sample-step, and a hash of every output (outputs, gradients, step
counts, failure flags and times): equal hashes mean the two widths give every sample
bit for bit the same results. ``ratio_8_over_4`` < 1: 8 lanes are cheaper.
``--quick``: a fifth of the time spans, one round; ``--t-end``: one span for every
case.
"""

from __future__ import annotations

import argparse
import hashlib
import json

import numpy as np
from bench_common import BENCH_DIR, load_average, log, machine, run_json_subprocess

CASES = ("rk4_343", "rk4_33", "ros_own", "ros_shared", "sens", "single", "study", "planar")
#: the time span [s] of each case
SPANS = {
    "rk4_343": 2e-4,
    "rk4_33": 1e-3,
    "ros_own": 1e-3,
    "ros_shared": 1e-3,
    "sens": 1e-3,
    "single": 1e-3,
    "study": 1e-3,
    "planar": 4e-2,
}


def _digest(arrays: list[np.ndarray]) -> str:
    found = hashlib.sha256()
    for array in arrays:
        found.update(np.ascontiguousarray(array).tobytes())
    return found.hexdigest()[:16]


def _study_samples(grid: bool) -> tuple[dict[str, np.ndarray], int]:
    """Study 1's samples (the reduced plan's 33, or the 7^3 grid) and the modal one's row."""
    from brake_bands import LEVELS, study_parameters

    import fuzzymbs

    parameters = study_parameters(1)
    plan = fuzzymbs.plan(parameters, method="reduced", levels=LEVELS)
    if not grid:
        samples = {name: plan.samples[:, i] for i, name in enumerate(parameters)}
        return samples, int(plan.nominal_index)
    axes = [np.linspace(*p.support, 7) for p in parameters.values()]
    mesh = np.meshgrid(*axes, indexing="ij")
    return {name: m.ravel() for name, m in zip(parameters, mesh, strict=True)}, 0


def _brake_call(case: str, t_end: float):
    """A function running the case once: (SimulationResult, sample-steps)."""
    from fuzzymbs.models.brake import DiscBrake

    samples, modal = _study_samples(grid=case == "rk4_343")
    if case == "study":
        brake = DiscBrake(t_end=t_end)
        single = {name: v[modal : modal + 1] for name, v in samples.items()}

        def study():
            shared = brake.share_steps(single)
            out = shared(samples)
            arrays = [out[name] for name in sorted(brake.outputs)] + [out["failed"]]
            return arrays, len(samples["nodal_force"]) * shared.simulation.shared.sequence.size

        return study
    if case == "single":
        samples = {name: v[modal : modal + 1] for name, v in samples.items()}
    if case.startswith("rk4"):
        simulation = DiscBrake(t_end=t_end, integrator="rk4", dt=1e-6).simulation

        def run():
            result = simulation.simulate(samples)
            return result, len(samples["nodal_force"]) * round(t_end / 1e-6)

        return run
    simulation = DiscBrake(t_end=t_end, rtol=1e-3).simulation
    options: dict = {}
    if case == "ros_shared":
        single = {name: float(v[modal]) for name, v in samples.items()}
        shared = simulation.share_steps(single).shared
        options = {"step_sequence": shared.sequence, "jacobian_renewals": shared.renewals}
    if case == "sens":
        options = {"sensitivities": tuple(samples)}

    def run():
        result = simulation.simulate(samples, **options)
        return result, int(result.step_counts.sum())

    return run


def _planar_call(t_end: float):
    from fuzzymbs.mbs.planar import simulate
    from fuzzymbs.models.mechanisms.slider_crank import build

    rng = np.random.default_rng(7)
    mechanisms = [
        build(
            {
                "crank_speed": 150.0,
                "spin_up_time": 0.02,
                "youngs_modulus": 2.0e11 * rng.uniform(0.95, 1.05),
                "rod_width": 0.01,
                "rod_height": 0.006 * rng.uniform(0.98, 1.02),
                "slider_mass": 0.1 * rng.uniform(0.9, 1.1),
            }
        )
        for _ in range(11)
    ]
    times = np.linspace(0.0, t_end, 21)

    def run():
        result = simulate(mechanisms, times, rtol=1e-5, atol=1e-7)
        arrays = [result.states, result.status, result.accepted, result.rejected]
        return arrays, int((result.accepted + result.rejected).sum())

    return run


def child(case: str, t_end: float, repeat: int) -> dict:
    """One width's measurement of ``case`` in this interpreter (run by :func:`main`)."""
    import time

    from fuzzymbs.mbs.kernels.simd import LANES

    run = _planar_call(t_end) if case == "planar" else _brake_call(case, t_end)
    run()  # compile or load the kernels, warm up
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        result, steps = run()
        best = min(best, time.process_time() - start)
    if case in ("planar", "study"):
        arrays = result
    else:
        arrays = [result.outputs[name] for name in sorted(result.outputs)]
        arrays += [result.failed, result.failure_time]
        for name in sorted(result.gradients or {}):
            arrays.append(result.gradients[name])
        if result.step_counts is not None:
            arrays.append(result.step_counts)
    return {"lanes": LANES, "cpu_s": best, "sample_steps": steps, "hash": _digest(arrays)}


def measure(case: str, lanes: int, t_end: float, repeat: int) -> dict:
    call = f"lane_width.child({case!r}, {t_end}, {repeat})"
    code = f"import json, lane_width; print(json.dumps({call}))"
    env = {
        "FUZZYMBS_LANES": str(lanes),
        "NUMBA_CACHE_DIR": str(BENCH_DIR / ".cache" / f"numba-lanes{lanes}"),
        "NUMBA_NUM_THREADS": "1",
    }
    found = run_json_subprocess(code, env=env, timeout=7200.0)
    if found["lanes"] != lanes:
        raise RuntimeError(f"the child ran {found['lanes']} lanes, not {lanes}")
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    parser.add_argument("--t-end", type=float, help="every case's time span [s]")
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    found: dict = {"machine": machine(), "rounds": rounds, "repeat": args.repeat}
    for case in args.cases:
        t_end = args.t_end or SPANS[case] / (5 if args.quick else 1)
        runs: dict[int, list[dict]] = {4: [], 8: []}
        for k in range(rounds):
            for lanes in (4, 8) if k % 2 == 0 else (8, 4):
                runs[lanes].append(measure(case, lanes, t_end, args.repeat))
                log(f"{case} lanes {lanes}: {runs[lanes][-1]}")
        entry: dict = {"t_end": t_end}
        for lanes, done in runs.items():
            cpu = min(r["cpu_s"] for r in done)
            steps = done[0]["sample_steps"]
            entry[f"lanes{lanes}"] = {
                "cpu_s": cpu,
                "sample_steps": steps,
                "us_per_sample_step": 1e6 * cpu / steps,
                "hashes": sorted({r["hash"] for r in done}),
            }
        entry["ratio_8_over_4"] = (
            entry["lanes8"]["us_per_sample_step"] / entry["lanes4"]["us_per_sample_step"]
        )
        entry["bit_identical"] = entry["lanes4"]["hashes"] == entry["lanes8"]["hashes"]
        found[case] = entry
    found["load_average_at_end"] = load_average()
    print(json.dumps(found))


if __name__ == "__main__":
    main()
