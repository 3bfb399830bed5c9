"""RODAS4 against ROS34PW2 on the disc brake: error against cost at rtol 1e-2 .. 1e-5.

    python benchmarks/rodas_work_precision.py [--quick] [--t-end S] [--rtol ...] [--repeats N]

Prints one JSON line. For the nominal brake and the corner sample (k -10 %, k_c +10 %,
F_n +1 %) over ``t_end`` (default 2 ms, the slip-reversal phase where the steps are
smallest; ``--quick``: 0.2 ms, two tolerances, one repeat), recorded every 10 us, each
sample alone in its block (kernel "samples"), through
:func:`fuzzymbs.mbs.integrate.simulate`:

* **error**: the largest deviation over time of y_lpad / y_upad (and apart, y_cali)
  from a reference, relative to the reference's peak. The reference is ROS34PW2 at
  rtol 1e-8, cached in ``benchmarks/.cache/``; its own error is estimated by its
  distance from RODAS4 at rtol 1e-7 (reported as ``reference_check``);
* **cost**: process CPU time of the call (median of ``--repeats``, warm), and the
  counts of the kernel: accepted / rejected steps, right-hand sides, Jacobians and LU
  factorisations (:attr:`~fuzzymbs.mbs.integrate.SimulationResult.work_counts`).

Variants: ROS34PW2 (Jacobian renewed every 10 accepted steps, the default) and RODAS4 with
a fresh Jacobian every step (``rodas4``, as its order needs); ``--aged`` (and ``--quick``)
adds RODAS4 reusing it for 3 and 10 steps (``rodas4 age 3`` / ``age 10``; a Rosenbrock
method that is not a W-method loses order with an aged Jacobian). ``--w-methods`` adds two
other W-methods of Rang (J. Comput. Appl. Math. 286 (2015) 128, Tables 2 and 3), run by the
kernel in ROS34PW2's place with the same Jacobian age: ROS34PRw (4 stages, order 3,
L-stable, stiffly accurate; its stages 3 and 4 share one point, so it needs 3 right-hand
sides a step where the kernel makes 4: ``rhs_distinct`` counts those it needs) and ROS3PRw
(3 stages, order 3, R(inf) = -0.73).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import time
from pathlib import Path

import numpy as np
from bench_common import BRAKE_SAMPLES, brake_errors, brake_run

from fuzzymbs.mbs.kernels import rosenbrock_methods
from fuzzymbs.mbs.kernels.rosenbrock_methods import GAMMA, JACOBIAN_AGE, transformed
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

RTOLS = (1e-2, 1e-3, 1e-4, 1e-5)
#: (label, integrator, Jacobian age or None for the method's own)
VARIANTS = (
    ("ros34pw2", "ros34pw2", None),
    ("rodas4", "rodas4", None),
    ("rodas4 age 3", "rodas4", 3),
    ("rodas4 age 10", "rodas4", 10),
)
#: the reference: ROS34PW2 at rtol 1e-8 (over 0.2 ms it agrees with RODAS4 at rtol 1e-9
#: to 7e-9 of the peak, at an eighth of that run's 81 s); checked against RODAS4 at 1e-7
REFERENCE = ("ros34pw2", 1e-8)
CHECK = ("rodas4", 1e-7)
CACHE = Path(__file__).resolve().parent / ".cache"
# Rang (2015), Table 3: ROS34PRw in the W-form (A, Gamma, b, bhat); A's rows 3 and 4 agree
_ROS34PRW = (
    np.array([[0, 0, 0, 0], [1.3075995645253771, 0, 0, 0], [0.5, 0.5, 0, 0], [0.5, 0.5, 0, 0]]),
    np.array(
        [
            [GAMMA, 0, 0, 0],
            [-1.3075995645253771, GAMMA, 0, 0],
            [-0.7098857586097217, -0.55996735960277766, GAMMA, 0],
            [-0.15550856807552085, -0.95388516575112225, 0.67352721231818413, GAMMA],
        ]
    ),
    np.array([0.34449143192447917, -0.45388516575112231, 0.67352721231818413, GAMMA]),
    np.array([0.5, -0.25738812086522078, 0.43542008724775044, 0.32196803361747034]),
)
# Rang (2015), Table 2: ROS3PRw
_G3 = 0.78867513459481287
_ROS3PRW = (
    np.array([[0, 0, 0], [2.3660254037844388, 0, 0], [0.5, 0.76794919243112270, 0]]),
    np.array(
        [
            [_G3, 0, 0],
            [-2.3660254037844388, _G3, 0],
            [-0.86791218280355165, -0.87306695894642317, _G3],
        ]
    ),
    np.array([0.50544867840851759, -0.11571687603637559, 0.610268197627858]),
    np.array([0.28973180237214197, 0.1, 0.610268197627858]),
)
#: (label, W-form, right-hand sides a step the method needs)
W_METHODS = (("ros34prw", _ROS34PRW, 3), ("ros3prw", _ROS3PRW, 3))
#: right-hand sides a step the kernel makes beyond those a W-method needs (its stages apart)
_SAVED = {method: len(form[2]) - used for method, form, used in W_METHODS}


def run(compiled, sample: dict, t_end: float, integrator: str, rtol: float, age: int | None):
    """Outputs (3, T), CPU seconds and the result of one sample; ``integrator`` one of the
    kernel's, or a label of W_METHODS (run in ROS34PW2's place)."""
    methods = rosenbrock_methods.METHODS
    kept = dict(methods)
    if age is not None:
        methods["rodas4"] = rosenbrock_methods.rodas4_coefficients(age)
    for label, form, _ in W_METHODS:
        if integrator == label:
            methods["ros34pw2"] = transformed(*form, JACOBIAN_AGE, embedded_order=2)
            integrator = "ros34pw2"
    try:
        return brake_run(
            compiled,
            sample,
            t_end,
            clock=time.process_time,
            dt=1e-7,
            integrator=integrator,
            tolerance=Tolerance(rtol),
        )
    finally:
        methods.update(kept)


def reference(compiled, label: str, sample: dict, t_end: float) -> tuple[np.ndarray, dict]:
    """The REFERENCE run's outputs (cached) and its distance from the CHECK run."""
    key = json.dumps([label, sample, t_end, REFERENCE, CHECK], sort_keys=True)
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    path = CACHE / f"rodas_reference_{digest}.npz"
    if path.exists():
        stored = np.load(path)
        return stored["y"], json.loads(str(stored["check"]))
    y, seconds, result = run(compiled, sample, t_end, *REFERENCE, None)
    other, other_seconds, other_result = run(compiled, sample, t_end, *CHECK, None)
    errors = brake_errors(other, y)
    check = {
        "reference": f"{REFERENCE[0]} rtol {REFERENCE[1]:g}",
        "reference_cpu_s": round(seconds, 2),
        "reference_steps": result.step_counts[0].tolist(),
        "against": f"{CHECK[0]} rtol {CHECK[1]:g}",
        "against_cpu_s": round(other_seconds, 2),
        "against_steps": other_result.step_counts[0].tolist(),
        "pads": errors["error"],
        "y_cali": errors["error_y_cali"],
    }
    CACHE.mkdir(exist_ok=True)
    np.savez(path, y=y, check=json.dumps(check))
    return y, check


def table(
    t_end: float, rtols: tuple[float, ...], repeats: int, aged: bool, w_methods: bool = False
) -> dict:
    compiled = DiscBrake(t_end=t_end).compiled
    for integrator in ("ros34pw2", "rodas4"):  # compile
        run(compiled, {}, 2e-5, integrator, 1e-2, None)
    figures: dict = {"benchmark": "rodas_work_precision", "t_end_s": t_end, "repeats": repeats}
    for label, sample in BRAKE_SAMPLES.items():
        ref, check = reference(compiled, label, sample, t_end)
        entry: dict = {"reference_check": check, "rows": []}
        variants = list(VARIANTS if aged else VARIANTS[:2])
        if w_methods:
            variants += [(method, method, None) for method, _, _ in W_METHODS]
        for name, integrator, age in variants:
            for rtol in rtols:
                cpu = []
                for _ in range(repeats):
                    y, seconds, result = run(compiled, sample, t_end, integrator, rtol, age)
                    cpu.append(seconds)
                rhs, jacobians, lus = result.work_counts[0].tolist()
                rhs_distinct = rhs - _SAVED.get(name, 0) * int(result.step_counts[0].sum())
                entry["rows"].append(
                    {
                        "method": name,
                        "rtol": rtol,
                        "cpu_s": round(statistics.median(cpu), 3),
                        "steps_accepted_rejected": result.step_counts[0].tolist(),
                        "rhs": rhs,
                        "rhs_distinct": rhs_distinct,
                        "jacobians": jacobians,
                        "lu": lus,
                        **brake_errors(y, ref),
                    }
                )
        figures[label] = entry
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="0.2 ms, 2 tolerances, 1 repeat")
    parser.add_argument("--t-end", type=float, default=2e-3, help="s (default 2 ms)")
    parser.add_argument("--rtol", type=float, nargs="+", default=list(RTOLS))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--aged", action="store_true", help="also RODAS4 with aged Jacobians")
    parser.add_argument("--w-methods", action="store_true", help="also ROS34PRw and ROS3PRw")
    args = parser.parse_args()
    if args.quick:
        print(json.dumps(table(2e-4, (1e-2, 1e-3), 1, True)))
    else:
        print(
            json.dumps(table(args.t_end, tuple(args.rtol), args.repeats, args.aged, args.w_methods))
        )
