"""Share of the flop bound reached by the Rosenbrock path, its sensitivities and RK4.

    python benchmarks/ros_flops.py [--t-end S] [--rtol R] [--repeats N] [--two-core]

Prints readable tables to stderr and one JSON line to stdout.

Workload: the eight corners of study 1's mu = 0 box (k, k_c +-10 %, F_n +-1 %; two
blocks of four samples, one per thread) over ``--t-end`` (default 2 ms), recorded every
10 us: ROS34PW2 at ``--rtol`` (default 1e-3, the studies'), the same with the
sensitivities to study 1's three parameters, and RK4 at dt = 1 us; then both
ROS34PW2 variants on eight nominal samples (" | lanes in step": the four lanes of a
block take the same steps, so no lane idles while another steps). The variants
alternate; the smallest process CPU time of ``--repeats`` counts.

Flops: :mod:`brake_flops` counted from the compiled system's sizes and the kernel's own
work counters per sample (steps, right-hand sides, Jacobians, LUs, the sensitivities'
right-hand sides). The share of checked contact nodes in contact and the LU's work
(its rows that couple to each pivot column) are measured on the run's own states: the
Jacobian kernel evaluated at every 5th record of each sample.

Rates: flops per CPU-second of the call (both threads' CPU) against NumPy's 3000 x 3000
float64 matmul on one BLAS thread in this process (``gflops_per_cpu_second`` and
``fraction_of_one_core``), and beside it the rate of independent fused multiply-adds
of the kernels' own vector type (four float64 lanes: the ceiling of code written with
it where the CPU's widest vectors hold eight), and RK4 on 343 samples (the batch of
run.py's flop fraction) over 0.2 ms; with ``--two-core`` also wall rates against the
2-thread matmul (a fresh interpreter; meaningful only on a quiet machine: the load
average is reported). Where the time goes: each kernel part called alone on one block (4 samples)
in a compiled loop, its CPU time per call and its own rate, and the run's parts
predicted from the counters times these times.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import brake_flops
import numba as nb
import numpy as np
from bench_common import load_average
from threadpoolctl import threadpool_limits

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.contact import JREC
from fuzzymbs.mbs.kernels.jacobian import jacobian
from fuzzymbs.mbs.kernels.linalg import lu_factor_lanes, reduced_stage_solve
from fuzzymbs.mbs.kernels.rhs import make_work, rhs
from fuzzymbs.mbs.kernels.rosenbrock_methods import GAMMA
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

L = V.LANES
RECORD = 1e-5  # s
DT = 1e-6  # s, RK4's step and the Rosenbrock methods' first
STUDY1 = ("pad_spring_stiffness", "caliper_spring_stiffness", "nodal_force")
NOMINAL = np.array([200e3, 1e3, 16e3])
HALF_WIDTH = np.array([0.1, 0.1, 0.01])
OUTPUTS = {"y_lpad": Coordinate("lower_pad", 0), "y_upad": Coordinate("upper_pad", 0)}


def corners() -> dict[str, np.ndarray]:
    """The eight corners of study 1's mu = 0 box."""
    signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)
    values = NOMINAL * (1.0 + signs * HALF_WIDTH)
    return {name: values[:, k] for k, name in enumerate(STUDY1)}


def matmul_cpu_rate(size: int = 3000, repeat: int = 3) -> dict:
    """NumPy matmul on one BLAS thread in this process: best GFLOP/s per CPU-second."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((size, size)), rng.standard_normal((size, size))
    with threadpool_limits(1):
        c = a @ b
        best_cpu = best_wall = float("inf")
        for _ in range(repeat):
            cpu, wall = time.process_time(), time.perf_counter()
            np.matmul(a, b, out=c)
            best_cpu = min(best_cpu, time.process_time() - cpu)
            best_wall = min(best_wall, time.perf_counter() - wall)
    flops = 2.0 * size**3
    return {"gflops_per_cpu_second": flops / best_cpu / 1e9, "gflops_wall": flops / best_wall / 1e9}


@nb.njit(nogil=True, fastmath=V.FAST)
def _fma_chains(count, m, c):
    """``count`` rounds of 12 independent fused multiply-adds of the kernels' lane vector."""
    # distinct starts, or the compiler would merge equal chains
    step = V.splat(0.0)
    for lane in range(L):
        step = V.insert(step, lane, 0.1 * lane)
    a0, a1, a2 = step + 1.0, step + 2.0, step + 3.0
    a3, a4, a5 = step + 4.0, step + 5.0, step + 6.0
    b0, b1, b2 = step + 7.0, step + 8.0, step + 9.0
    b3, b4, b5 = step + 0.5, step + 1.5, step + 2.5
    mv, cv = V.splat(m), V.splat(c)
    for _ in range(count):
        a0, a1, a2 = V.fma(a0, mv, cv), V.fma(a1, mv, cv), V.fma(a2, mv, cv)
        a3, a4, a5 = V.fma(a3, mv, cv), V.fma(a4, mv, cv), V.fma(a5, mv, cv)
        b0, b1, b2 = V.fma(b0, mv, cv), V.fma(b1, mv, cv), V.fma(b2, mv, cv)
        b3, b4, b5 = V.fma(b3, mv, cv), V.fma(b4, mv, cv), V.fma(b5, mv, cv)
    total = a0 + a1 + a2 + a3 + a4 + a5 + b0 + b1 + b2 + b3 + b4 + b5
    return V.get(total, 0) + V.get(total, L - 1)


def vector_fma_rate(count: int = 50_000_000) -> float:
    """GFLOP/s per CPU-second of the kernels' vector (four float64 lanes) in independent
    fused multiply-adds: the peak of code written with it (half the matmul's where the
    CPU has 8-wide vectors)."""
    _fma_chains(10, 0.999999, 1e-9)
    best = float("inf")
    for _ in range(3):
        start = time.process_time()
        _fma_chains(count, 0.999999, 1e-9)
        best = min(best, time.process_time() - start)
    return 12 * L * 2.0 * count / best / 1e9


def lanes(rows: np.ndarray) -> np.ndarray:
    """(L, m) rows -> the kernels' lane-minor (m L,) array."""
    return np.ascontiguousarray(rows.T).reshape(-1)


def state_outputs(compiled) -> dict:
    """Every coordinate and velocity as an output, in state order."""
    out = {}
    for body, dofs in compiled.body_dofs.items():
        for i in range(dofs.stop - dofs.start):
            out[f"q{dofs.start + i}"] = Coordinate(body, i)
            out[f"v{dofs.start + i}"] = Coordinate(body, i, velocity=True)
    n = int(compiled.data[0])
    order = [f"q{i}" for i in range(n)] + [f"v{i}" for i in range(n)]
    return {name: out[name] for name in order}


def contact_and_lu(compiled, samples, t_end, rtol, every=5) -> dict:
    """The share of checked slave nodes in contact and the LU's operations, averaged over
    the Jacobian kernel at every ``every``-th record of each sample's ROS34PW2 run."""
    data = compiled.data
    n = int(data[0])
    outputs = state_outputs(compiled)
    run = simulate(
        compiled,
        samples,
        t_end=t_end,
        dt=DT,
        record_interval=RECORD,
        outputs=outputs,
        integrator="ros34pw2",
        tolerance=Tolerance(rtol),
    )
    states = np.stack([run.outputs[name] for name in outputs], axis=1)  # (B, 2n, T)
    params = compiled.parameters.values(samples)
    steps = t_end / np.mean(run.step_counts[:, 0])  # a typical step for the stage matrix
    checked = int(sum(data[11][:, 3]))
    active, lu, dense = [], [], brake_flops.lu_flops(n=n)
    for first in range(0, params.shape[0], L):
        block = slice(first, first + L)
        p = lanes(params[block])
        work = make_work(data)
        f, jq, jv = np.zeros(2 * n * L), np.zeros(n * n * L), np.zeros(n * n * L)
        for k in range(every, run.time.size, every):
            x = lanes(states[block, :, k])
            jacobian(np.full(L, run.time[k]), x, p, data, work, f, jq, jv)
            rec = work[10].reshape(checked, JREC, L)
            active.extend((rec[:, :18, :] != 0.0).any(axis=1).sum(axis=0) / checked)
            gh = GAMMA * steps
            mat = -(jv.reshape(n, n, L) + gh * jq.reshape(n, n, L))
            mat[np.arange(n), np.arange(n)] += 1.0 / gh
            lu.extend(brake_flops.lu_flops(mat[:, :, lane] != 0.0) for lane in range(L))
    return {
        "active_fraction": float(np.mean(active)),
        "active_fraction_range": [float(np.min(active)), float(np.max(active))],
        "lu_flops": float(np.mean(lu)),
        "lu_flops_dense": dense,
        "states": len(active),
        "typical_step_s": steps,
    }


@nb.njit(nogil=True)
def _rhs_loop(count, t, x, f, p, data, work):
    for _ in range(count):
        rhs(t, x, f, p, data, work)


@nb.njit(nogil=True)
def _jacobian_loop(count, t, x, f, p, data, work, jq, jv):
    for _ in range(count):
        jacobian(t, x, p, data, work, f, jq, jv)


@nb.njit(nogil=True)
def _lu_loop(count, source, mat, n, piv, factor):
    for _ in range(count):
        mat[:] = source
        if factor:
            lu_factor_lanes(mat, n, piv)


@nb.njit(nogil=True)
def _solve_loop(count, jq, mat, piv, n, gh, r, solve, u):
    for _ in range(count):
        reduced_stage_solve(jq, mat, piv, n, V.splat(gh), r, solve, u)


def _cpu_per_call(call, count) -> float:
    call(1)  # compile / warm
    best = float("inf")
    for _ in range(3):
        start = time.process_time()
        call(count)
        best = min(best, time.process_time() - start)
    return best / count


def part_times(compiled, samples, t_end, step) -> dict:
    """CPU time per call of the kernel's parts on one block (the first L corners at
    their state halfway through the run, RK4 at 1 us from the same start)."""
    data = compiled.data
    n = int(data[0])
    outputs = state_outputs(compiled)
    first4 = {name: values[:L] for name, values in samples.items()}
    run = simulate(
        compiled,
        first4,
        t_end=t_end / 2,
        dt=DT,
        record_interval=RECORD,
        outputs=outputs,
        integrator="ros34pw2",
    )
    x = lanes(np.stack([run.outputs[name][:, -1] for name in outputs], axis=1))
    p = lanes(compiled.parameters.values(first4))
    t = np.full(L, run.time[-1])
    work = make_work(data)
    f, jq, jv = np.zeros(2 * n * L), np.zeros(n * n * L), np.zeros(n * n * L)
    jacobian(t, x, p, data, work, f, jq, jv)
    gh = GAMMA * step
    mat = -(jv.reshape(n, n, L) + gh * jq.reshape(n, n, L))
    mat[np.arange(n), np.arange(n)] += 1.0 / gh
    source = np.ascontiguousarray(mat).reshape(-1)
    lu, piv = source.copy(), np.zeros(n * L, dtype=np.int64)
    lu_factor_lanes(lu, n, piv)
    r = np.random.default_rng(1).standard_normal(2 * n * L) * 1e-3
    solve, u = np.zeros(2 * n * L), np.zeros(2 * n * L)
    copy = _cpu_per_call(lambda c: _lu_loop(c, source, source.copy(), n, piv, False), 2000)
    return {
        "rhs": _cpu_per_call(lambda c: _rhs_loop(c, t, x, f, p, data, work), 2000),
        "jacobian": _cpu_per_call(lambda c: _jacobian_loop(c, t, x, f, p, data, work, jq, jv), 200),
        "lu": _cpu_per_call(lambda c: _lu_loop(c, source, lu, n, piv, True), 2000) - copy,
        "stage_solve": _cpu_per_call(
            lambda c: _solve_loop(c, jq, lu, piv, n, gh, r, solve, u), 5000
        ),
    }


SENS = "ros34pw2 + sensitivities (k, k_c, F_n)"
#: the same variants with the eight samples all nominal: the lanes step together
IN_STEP = " | lanes in step"


def timed(compiled, samples, repeats, common) -> dict:
    """Smallest CPU and wall time of each variant (alternating), with the counters."""
    ros = {"integrator": "ros34pw2", "tolerance": common["tolerance"]}
    nominal = {name: np.full(8, value) for name, value in zip(STUDY1, NOMINAL, strict=True)}
    variants = {
        "ros34pw2": (samples, ros),
        SENS: (samples, {**ros, "sensitivities": STUDY1}),
        "rk4": (samples, {"integrator": "rk4"}),
        "ros34pw2" + IN_STEP: (nominal, ros),
        SENS + IN_STEP: (nominal, {**ros, "sensitivities": STUDY1}),
    }
    base = {key: value for key, value in common.items() if key != "tolerance"}
    best = {label: [float("inf"), float("inf")] for label in variants}
    runs = {}
    for chosen, options in variants.values():  # warm (compiled, cached) before timing
        simulate(compiled, chosen, **{**base, "t_end": 2 * RECORD}, **options)
    for _ in range(repeats):
        for label, (chosen, options) in variants.items():
            cpu, wall = time.process_time(), time.perf_counter()
            runs[label] = simulate(compiled, chosen, **base, **options)
            wall = time.perf_counter() - wall
            best[label][0] = min(best[label][0], time.process_time() - cpu)
            best[label][1] = min(best[label][1], wall)
    return {"best": best, "runs": runs}


def run_flops(data, ros, sens, af, lu, records) -> tuple[dict, dict, list]:
    """Flops by part of a ROS34PW2 run and of its sensitivities (summed over the batch),
    and each sample's counters."""
    state: dict[str, float] = {}
    extra: dict[str, float] = {}
    per_sample = []
    for b in range(ros.step_counts.shape[0]):
        counts = dict(zip(("accepted", "rejected"), ros.step_counts[b].tolist(), strict=True))
        counts.update(zip(("rhs", "jacobians", "lus"), ros.work_counts[b].tolist(), strict=True))
        per_sample.append(counts)
        parts = brake_flops.rosenbrock_flops(data, counts, af, lu, records=records)
        for key, value in parts.items():
            state[key] = state.get(key, 0.0) + value
        rhs = float(sens.sensitivity_rhs[b])
        parts = brake_flops.sensitivity_flops(
            data, counts["accepted"], rhs, len(STUDY1), af, records=records
        )
        for key, value in parts.items():
            extra[key] = extra.get(key, 0.0) + value
    if not np.array_equal(sens.work_counts, ros.work_counts):
        raise RuntimeError("the sensitivities changed the state's work")
    return state, extra, per_sample


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--t-end", type=float, default=2e-3)
    parser.add_argument("--rtol", type=float, default=1e-3)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--two-core", action="store_true", help="also the 2-thread matmul")
    args = parser.parse_args()
    load_start = load_average()
    compiled = DiscBrake(t_end=args.t_end, record_interval=RECORD).compiled
    data = compiled.data
    samples = corners()
    batch = len(samples[STUDY1[0]])
    common = {"t_end": args.t_end, "dt": DT, "record_interval": RECORD, "outputs": OUTPUTS}
    common["tolerance"] = Tolerance(args.rtol)
    measured = timed(compiled, samples, args.repeats, common)
    contact = contact_and_lu(compiled, samples, args.t_end, args.rtol)
    af, lu = contact["active_fraction"], contact["lu_flops"]
    matmul = matmul_cpu_rate()
    one = matmul["gflops_per_cpu_second"]
    matmul["vector_fma_gflops_per_cpu_second"] = vector_fma_rate()
    two = None
    if args.two_core:
        from matmul_rate import matmul_gflops

        two = matmul_gflops(2, 3000, 3)["gflops"]
    records = round(args.t_end / RECORD)
    report: dict = {
        "t_end_s": args.t_end,
        "rtol": args.rtol,
        "batch": batch,
        "records": records,
        "load_average_start": load_start,
        "matmul_1_thread": matmul,
        "matmul_2_threads": two,
        "contact_and_lu": contact,
    }
    runs = measured["runs"]
    state, extra, per_sample = run_flops(data, runs["ros34pw2"], runs[SENS], af, lu, records)
    flops = {"ros34pw2": state, "sensitivities": extra}
    steps = round(args.t_end / DT)
    rk4 = brake_flops.step_flops(data, af)
    flops["rk4"] = {"steps": rk4["flops_per_sample_step"] * steps * batch}
    same = run_flops(data, runs["ros34pw2" + IN_STEP], runs[SENS + IN_STEP], af, lu, records)
    totals = {
        "ros34pw2": sum(state.values()),
        SENS: sum(state.values()) + sum(extra.values()),
        "rk4": flops["rk4"]["steps"],
        "ros34pw2" + IN_STEP: sum(same[0].values()),
        SENS + IN_STEP: sum(same[0].values()) + sum(same[1].values()),
    }
    rows = {}
    for label, (cpu, wall) in measured["best"].items():
        rate = totals[label] / cpu / 1e9
        rows[label] = {
            "cpu_s": round(cpu, 3),
            "wall_s": round(wall, 3),
            "gflop": round(totals[label] / 1e9, 3),
            "gflops_per_cpu_second": round(rate, 2),
            "fraction_of_one_core": round(rate / one, 4),
        }
        if two is not None:
            wall_rate = totals[label] / wall / 1e9
            rows[label]["gflops_wall"] = round(wall_rate, 2)
            bound = max(matmul["gflops_wall"], two)  # 2 threads can measure below 1
            rows[label]["fraction_of_two_core_wall"] = round(wall_rate / bound, 4)
    # the sensitivities alone: their flops over the CPU time they add
    for suffix, extra_flops in (("", extra), (IN_STEP, same[1])):
        added = measured["best"][SENS + suffix][0] - measured["best"]["ros34pw2" + suffix][0]
        rate = sum(extra_flops.values()) / added / 1e9
        rows["sensitivities alone (added CPU)" + suffix] = {
            "cpu_s": round(added, 3),
            "gflops_per_cpu_second": round(rate, 2),
            "fraction_of_one_core": round(rate / one, 4),
        }
    report["variants"] = rows
    report["flops_by_part"] = {
        label: {key: round(value / 1e9, 4) for key, value in parts.items()}
        for label, parts in flops.items()
    }
    report["counts_per_sample_mean"] = {
        key: float(np.mean([c[key] for c in per_sample])) for key in per_sample[0]
    }
    sens = runs[SENS]
    report["counts_per_sample_mean"]["sensitivity_rhs"] = float(np.mean(sens.sensitivity_rhs))
    report["per_call"] = parts_report(compiled, samples, args.t_end, contact, af, lu)
    report["rk4_large_batch"] = rk4_large_batch(compiled, af, one, args.repeats)
    report["predicted_cpu_s"] = predicted(report, per_sample, sens)
    report["load_average_end"] = load_average()
    _print(report)
    print(json.dumps(report))


def rk4_large_batch(compiled, af, one, repeats, batch=343, t_end=2e-4) -> dict:
    """RK4 on ``batch`` samples drawn in study 1's box (86 blocks over the two threads,
    the batch run.py's flop fraction reads) over ``t_end``: the same rate per CPU-second."""
    rng = np.random.default_rng(0)
    values = NOMINAL * (1.0 + HALF_WIDTH * rng.uniform(-1.0, 1.0, (batch, 3)))
    samples = {name: values[:, k] for k, name in enumerate(STUDY1)}
    common = {"t_end": t_end, "dt": DT, "record_interval": RECORD, "outputs": OUTPUTS}
    simulate(compiled, samples, **{**common, "t_end": 2 * RECORD}, integrator="rk4")
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        simulate(compiled, samples, **common, integrator="rk4")
        best = min(best, time.process_time() - start)
    flops = brake_flops.step_flops(compiled.data, af)["flops_per_sample_step"]
    rate = flops * round(t_end / DT) * batch / best / 1e9
    return {
        "batch": batch,
        "t_end_s": t_end,
        "cpu_s": round(best, 3),
        "gflops_per_cpu_second": round(rate, 2),
        "fraction_of_one_core": round(rate / one, 4),
    }


def parts_report(compiled, samples, t_end, contact, af, lu) -> dict:
    """Per block call of each part: CPU time, flops of its L samples, rate."""
    data = compiled.data
    n = int(data[0])
    times = part_times(compiled, samples, t_end, contact["typical_step_s"])
    jac = brake_flops.jacobian_flops(data, af)
    flops = {
        "rhs": sum(brake_flops.rhs_flops(data, af).values()),
        "jacobian": sum(jac.values()),
        "lu": lu,
        "stage_solve": brake_flops.stage_solve_flops(n),
    }
    return {
        key: {
            "cpu_us": round(1e6 * times[key], 2),
            "flops_per_sample": flops[key],
            "gflops_per_cpu_second": round(L * flops[key] / times[key] / 1e9, 2),
        }
        for key in times
    }


def predicted(report, per_sample, sens) -> dict:
    """The ROS34PW2 run's CPU by part: the counters times the parts' CPU per call (a
    block call serves L samples), against the measured CPU."""
    calls = report["per_call"]
    total = {"rhs": 0.0, "jacobian": 0.0, "lu": 0.0, "stage_solve": 0.0}
    for counts in per_sample:
        total["rhs"] += counts["rhs"] * calls["rhs"]["cpu_us"]
        total["jacobian"] += counts["jacobians"] * calls["jacobian"]["cpu_us"]
        total["lu"] += counts["lus"] * calls["lu"]["cpu_us"]
        tries = counts["accepted"] + counts["rejected"]
        total["stage_solve"] += 4 * tries * calls["stage_solve"]["cpu_us"]
    out = {key: round(value / L / 1e6, 3) for key, value in total.items()}
    out["sum"] = round(sum(out.values()), 3)
    out["measured"] = report["variants"]["ros34pw2"]["cpu_s"]
    accepted = sum(c["accepted"] for c in per_sample)
    sens_s = (
        (
            float(np.sum(sens.sensitivity_rhs)) * calls["rhs"]["cpu_us"]
            + 3 * 4 * accepted * calls["stage_solve"]["cpu_us"]
        )
        / L
        / 1e6
    )
    out["sensitivities_rhs_and_solves"] = round(sens_s, 3)
    out["sensitivities_measured"] = report["variants"]["sensitivities alone (added CPU)"]["cpu_s"]
    return out


def _print(report: dict) -> None:
    say = sys.stderr.write
    one = report["matmul_1_thread"]["gflops_per_cpu_second"]
    fma = report["matmul_1_thread"]["vector_fma_gflops_per_cpu_second"]
    say(f"matmul 1 thread: {one:.1f} GFLOP/s per CPU-second (4-lane FMA chains {fma:.1f}); ")
    say(f"load {report['load_average_start']}\n")
    c = report["contact_and_lu"]
    say(
        f"in contact {100 * c['active_fraction']:.1f} % of checked nodes; LU {c['lu_flops']:.0f}"
        f" flops (dense {c['lu_flops_dense']:.0f})\n"
    )
    for label, row in report["variants"].items():
        say(
            f"  {label:40s} cpu {row['cpu_s']:7.3f} s  {row['gflops_per_cpu_second']:6.2f} "
            f"GFLOP/s per CPU-s  {100 * row['fraction_of_one_core']:5.1f} % of one core\n"
        )
    for label, parts in report["flops_by_part"].items():
        total = sum(parts.values())
        cells = "  ".join(f"{k} {100 * v / total:.1f} %" for k, v in parts.items())
        say(f"  flops {label}: {total:.2f} GFLOP: {cells}\n")
    for label, row in report["per_call"].items():
        say(
            f"  per block call {label:12s} {row['cpu_us']:9.2f} us  "
            f"{row['gflops_per_cpu_second']:6.2f} GFLOP/s\n"
        )
    big = report["rk4_large_batch"]
    say(f"  rk4, {big['batch']} samples: {big['gflops_per_cpu_second']:.2f} GFLOP/s per CPU-s, ")
    say(f"{100 * big['fraction_of_one_core']:.1f} % of one core\n")
    say(f"  predicted CPU by part: {report['predicted_cpu_s']}\n")


if __name__ == "__main__":
    main()
