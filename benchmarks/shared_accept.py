"""The acceptance threshold of a step along a shared step sequence (``SHARED_ACCEPT_LOGGED``).

For each threshold, the 33 samples of brake study 1's and study 2's reduced plans
(levels 0, 0.25, 0.5, 0.75, 1; 10 ms) on their modal sample's step sequence as a
study runs them (``DiscBrake.share_steps``: the logged renewals and Jacobians), at
the tolerances the studies' pilots try (study 1 rtol 1e-2 and 1e-3, study 2 1e-3 and
1e-4): the runs' CPU seconds (the smaller of ``--rounds`` calls; the logging and
reference runs not counted), rejected steps, the Jacobians the samples evaluated
themselves, and the band error against the same plan at rtol 1e-6 on each sample's
own steps (cached in benchmarks/.cache by brake_bands.py), the modal sample's
reference added, largest over the levels, on the cut-width scale.

The threshold is a compile-time constant of the kernel, so each value runs in a
fresh interpreter with the kernel file patched in a temporary copy of ``src``.

``--replay`` also measures, with the checkout's own kernel, the two other facts the
shared steps rest on (docs/theory.md, "Shared steps"): the modal sample (10 ms,
rtol 1e-2) replayed on its logged sequence with and without the logged Jacobian
renewals against its logging run (largest deviation over the peak, rejected
steps), and the reference pair (rtol 1e-6 and 1e-5) as two lanes of one block
against each run alone (seconds, and whether the outputs are bit for bit equal).

    python benchmarks/shared_accept.py [--thresholds 1 2 4 10] [--cases 1:1e-3 2:1e-4]
        [--rounds 2] [--replay]   (JSON rows)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KERNEL = Path("fuzzymbs/mbs/kernels/rosenbrock.py")
#: (study, rtol) pairs: the tolerances the studies' pilots try
CASES = ("1:1e-2", "1:1e-3", "2:1e-3", "2:1e-4")

CHILD = r"""
import json, sys, time
from brake_bands import reduced_plan, reference_bands, shared_step_deviation
from fuzzymbs.models.brake import DiscBrake

cases, rounds = json.loads(sys.argv[1]), int(sys.argv[2])
for case in cases:
    study, rtol = int(case.split(":")[0]), float(case.split(":")[1])
    reference = reference_bands(study, 1e-2)
    plan, samples, modal = reduced_plan(study)
    shared = DiscBrake(t_end=1e-2, rtol=rtol).share_steps(modal).simulation
    steps, cpu = shared.shared, []
    _ = steps.reference  # waits for the reference pair: its CPU is not the runs'
    for _ in range(rounds):
        start = time.process_time()
        result = shared.simulate(
            samples,
            step_sequence=steps.sequence,
            jacobian_renewals=steps.renewals,
            logged_jacobians=steps.jacobians,
        )
        cpu.append(time.process_time() - start)
    if result.failed.any():
        raise RuntimeError(f"study {study} at rtol {rtol:g}: samples failed")
    deviation = shared_step_deviation(plan, result, steps, reference)
    row = {
        "study": study,
        "rtol": rtol,
        "cpu_s": round(min(cpu), 2),
        "accepted": int(result.step_counts[:, 0].sum()),
        "rejected": int(result.step_counts[:, 1].sum()),
        "jacobians": int(result.work_counts[:, 1].sum()),
        "band_error": {k: max(v) for k, v in deviation.items()},
    }
    print(json.dumps(row), flush=True)
"""


def measure(threshold: float, cases: list[str], rounds: int) -> list[dict]:
    """The child's rows for one threshold (module docstring)."""
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "src"
        shutil.copytree(ROOT / "src", src, ignore=shutil.ignore_patterns("*.nbi", "*.nbc"))
        kernel = src / KERNEL
        # the threshold of lanes taking the logging run's Jacobians, as the plans' do
        pattern = r"^(SHARED_ACCEPT, SHARED_ACCEPT_LOGGED = [^,]+), .*$"
        line = rf"\1, {threshold!r}"
        text, count = re.subn(pattern, line, kernel.read_text(), flags=re.M)
        assert count == 1, "SHARED_ACCEPT_LOGGED not found in the kernel"
        kernel.write_text(text)
        path = os.pathsep.join((str(src), str(ROOT / "benchmarks")))
        env = {"PYTHONPATH": path, "NUMBA_CACHE_DIR": str(Path(tmp) / "cache")}
        out = subprocess.run(
            [sys.executable, "-c", CHILD, json.dumps(cases), str(rounds)],
            env={**os.environ, **env},
            check=True,
            capture_output=True,
            text=True,
        ).stdout
    return [{"threshold": threshold, **json.loads(line)} for line in out.strip().splitlines()]


def replay_and_pair() -> dict:
    """The replay with and without the logged renewals; the reference pair in one block."""
    import time

    import numpy as np

    from fuzzymbs.models.brake import DiscBrake
    from fuzzymbs.tolerance import Tolerance

    model = DiscBrake(rtol=1e-2).simulation
    modal = {"pad_spring_stiffness": 200e3, "caliper_spring_stiffness": 1e3, "nodal_force": 16e3}
    one = {name: np.array([value]) for name, value in modal.items()}
    log = model.simulate(one, log_steps=True)
    row: dict = {"logged_steps": len(log.step_times)}
    for label, renewals in (("with_renewals", log.step_renewals), ("own_ages", None)):
        replay = model.simulate(one, step_sequence=log.step_times, jacobian_renewals=renewals)
        row[label] = {
            "rejected": int(replay.step_counts[0, 1]),
            **{
                name: float(
                    np.abs(replay.outputs[name] - log.outputs[name]).max()
                    / np.abs(log.outputs[name]).max()
                )
                for name in model.outputs
            },
        }
    two = {name: np.repeat(values, 2) for name, values in one.items()}
    start = time.perf_counter()
    both = model.simulate(two, tolerance=Tolerance(np.array([1e-6, 1e-5])))
    row["pair_s"] = time.perf_counter() - start
    for rtol, lane in ((1e-6, 0), (1e-5, 1)):
        start = time.perf_counter()
        alone = model.simulate(one, tolerance=Tolerance(rtol))
        row[f"alone_{rtol:g}_s"] = time.perf_counter() - start
        row[f"alone_{rtol:g}_identical"] = all(
            np.array_equal(both.outputs[name][lane], alone.outputs[name][0])
            for name in model.outputs
        )
    return row


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--thresholds", type=float, nargs="*", default=[1.0, 2.0, 4.0, 10.0])
    parser.add_argument("--cases", nargs="*", default=list(CASES), help="study:rtol pairs")
    parser.add_argument("--rounds", type=int, default=2, help="calls per case (the smaller CPU)")
    parser.add_argument("--replay", action="store_true", help="also the replay and the pair")
    args = parser.parse_args(argv)
    from brake_bands import reference_bands

    for study in sorted({int(case.split(":")[0]) for case in args.cases}):
        reference_bands(study, 1e-2)  # computed once here, read by the children
    rows = []
    if args.replay:
        rows.append({"replay_and_pair": replay_and_pair()})
        print(json.dumps(rows[-1]), flush=True)
    for threshold in args.thresholds:
        for row in measure(threshold, args.cases, args.rounds):
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


if __name__ == "__main__":
    main()
