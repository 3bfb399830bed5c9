"""The acceptance threshold of a step along a shared step sequence (``SHARED_ACCEPT``).

The brake's study-1 corners (k, k_c +-10 %, F_n +-1 %) over 10 ms in one block on
the modal sample's sequence at rtol 2e-3 (the tolerance study 1 chooses), for
thresholds 1 (a step of its own), 2, 4 and 10: the block's time, each corner's
rejected steps, and the band error of the four corners against the same corners at
rtol 1e-6 on their own steps (corrected by the modal sample at rtol 1e-6; deviation
divided by max(the corners' spread, 0.1 x its widest), as a study measures it).

The threshold is a compile-time constant of the kernel, so each value runs in a
fresh interpreter with the kernel file patched in a temporary copy of ``src``.

``--replay`` also measures, with the checkout's own kernel, the two other facts the
shared steps rest on (docs/theory.md, "Shared steps"): the modal sample (10 ms,
rtol 1e-2) replayed on its logged sequence with and without the logged Jacobian
renewals against its logging run (largest deviation over the peak, rejected
steps), and the reference pair (rtol 1e-6 and 1e-5) as two lanes of one block
against each run alone (seconds, and whether the outputs are bit for bit equal).

    python benchmarks/shared_accept.py [--thresholds 1 2 4 10] [--replay]   (JSON rows)
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

CHILD = r"""
import json, sys, time
import numpy as np
from fuzzymbs.tolerance import Tolerance
from fuzzymbs.models.brake import DiscBrake

model = DiscBrake(rtol=2e-3).simulation
modal = {"pad_spring_stiffness": [200e3], "caliper_spring_stiffness": [1e3], "nodal_force": [16e3]}
modal = {k: np.array(v) for k, v in modal.items()}
corners = {
    "pad_spring_stiffness": np.array([180e3, 220e3, 180e3, 220e3]),
    "caliper_spring_stiffness": np.array([900.0, 1100.0, 1100.0, 900.0]),
    "nodal_force": np.array([15840.0, 15840.0, 16160.0, 16160.0]),
}
log = model.simulate(modal, log_steps=True)
start = time.perf_counter()
run = model.simulate(corners, step_sequence=log.step_times, jacobian_renewals=log.step_renewals)
seconds = time.perf_counter() - start
tight = model.simulate(corners, tolerance=Tolerance(1e-6))
tight_modal = model.simulate(modal, tolerance=Tolerance(1e-6))
row = {"seconds": seconds, "rejected": run.step_counts[:, 1].tolist()}
for name in model.outputs:
    corrected = run.outputs[name] + tight_modal.outputs[name][0] - log.outputs[name][0]
    width = tight.outputs[name].max(axis=0) - tight.outputs[name].min(axis=0)
    scale = np.maximum(width, 0.1 * width.max())
    row[name] = float(np.max(np.abs(corrected - tight.outputs[name]) / scale))
print(json.dumps(row))
"""


def measure(threshold: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "src"
        shutil.copytree(ROOT / "src", src, ignore=shutil.ignore_patterns("*.nbi", "*.nbc"))
        kernel = src / KERNEL
        line = f"SHARED_ACCEPT = {threshold!r}"
        text, count = re.subn(r"^SHARED_ACCEPT = .*$", line, kernel.read_text(), flags=re.M)
        assert count == 1, "SHARED_ACCEPT not found in the kernel"
        kernel.write_text(text)
        env = {"PYTHONPATH": str(src), "NUMBA_CACHE_DIR": str(Path(tmp) / "cache")}
        out = subprocess.run(
            [sys.executable, "-c", CHILD],
            env={**os.environ, **env},
            check=True,
            capture_output=True,
            text=True,
        ).stdout
    return {"threshold": threshold, **json.loads(out.strip().splitlines()[-1])}


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
    parser.add_argument("--replay", action="store_true", help="also the replay and the pair")
    args = parser.parse_args(argv)
    rows = []
    if args.replay:
        rows.append({"replay_and_pair": replay_and_pair()})
        print(json.dumps(rows[-1]), flush=True)
    for threshold in args.thresholds:
        row = measure(threshold)
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


if __name__ == "__main__":
    main()
