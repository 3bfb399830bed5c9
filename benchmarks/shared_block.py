"""What a SIMD block of four samples costs on a shared step sequence.

The brake's study-1 corners of the mu = 0 cut (k +-10 %, F_n +-1 %) over 10 ms on
the modal sample's logged sequence, at rtol 1e-2 and 1e-3: the four as one block
against each corner alone (a block of one). With the lanes in lockstep the block
would cost what its slowest lane costs alone; the lanes leave the sequence where a
step is rejected and fall out of step, and a lane waiting for its block mates'
Jacobian renewals is masked. The ratio block / slowest corner alone says what
that costs. Each checkout runs in a fresh interpreter with its own ``src`` first
on the path (``--before CHECKOUT`` adds another checkout, e.g. a git worktree of
an earlier commit); best of two runs, warm.

    python benchmarks/shared_block.py [--before CHECKOUT]   (JSON rows)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, time
import numpy as np
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.tolerance import Tolerance

model = DiscBrake().simulation
corners = {
    "pad_spring_stiffness": np.array([180e3, 220e3, 180e3, 220e3]),
    "nodal_force": np.array([15840.0, 15840.0, 16160.0, 16160.0]),
}


def run(samples, logged, rtol):
    settings = {**model.settings, "tolerance": Tolerance(rtol)}
    best = np.inf
    for _ in range(2):
        start = time.perf_counter()
        result = simulate(model.compiled, samples, outputs=model.outputs,
                          step_sequence=logged.step_times,
                          jacobian_renewals=logged.step_renewals, **settings)
        best = min(best, time.perf_counter() - start)
    return best, result


for rtol in (1e-2, 1e-3):
    settings = {**model.settings, "tolerance": Tolerance(rtol)}
    logged = simulate(model.compiled, {}, outputs=model.outputs, log_steps=True, **settings)
    block, together = run(corners, logged, rtol)
    alone, equal = [], True
    for k in range(4):
        seconds, one = run({name: v[k : k + 1] for name, v in corners.items()}, logged, rtol)
        alone.append(seconds)
        equal = equal and all(
            np.array_equal(one.outputs[name][0], together.outputs[name][k])
            for name in model.outputs
        )
    print(json.dumps({
        "rtol": rtol, "block_s": round(block, 3), "alone_s": [round(s, 3) for s in alone],
        "block_over_slowest_alone": round(block / max(alone), 3),
        "block_over_sum_alone": round(block / sum(alone), 3),
        "rejected": together.step_counts[:, 1].tolist(), "bit_for_bit": bool(equal),
    }), flush=True)
"""


def measure(checkout: Path) -> list[dict]:
    """The child script with ``checkout/src`` first on the path; its JSON rows."""
    env = {**os.environ, "PYTHONPATH": str(checkout / "src")}
    done = subprocess.run(
        [sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True
    )
    rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    return [{"checkout": str(checkout), **row} for row in rows]


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, help="another checkout, measured first")
    args = parser.parse_args(argv)
    rows = []
    for checkout in ([args.before] if args.before else []) + [ROOT]:
        for row in measure(checkout):
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


if __name__ == "__main__":
    main()
