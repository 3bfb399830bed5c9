"""This checkout against another one (e.g. the commit before a change), in the same minutes.

    git worktree add ../before <commit>
    python benchmarks/compare_checkouts.py ../before [--rounds 3] [--cold]

Each measurement runs in a fresh interpreter with the checkout's ``src`` first on
the path; the two checkouts alternate, ``--rounds`` times. Prints one JSON line:

* ``study1``: wall and CPU time [s] of study 1 of the brake (33 runs, reduced
  method, 10 ms, RK4 at 1 us, ``chunk_size=33``), two warm studies per process;
* ``rk4_calls``: the same model called alone on 32 samples of study 1's support (the
  kernels without the study's checks, which later versions add), best of two calls;
* ``ros_calls`` (with ``--ros``): ROS34PW2 at rtol 1e-3 (the studies' tolerance) on the
  eight corners of study 1's mu = 0 box over ``--ros-t-end`` (2 ms), without and with
  the sensitivities to its three parameters, best of two calls each (both checkouts
  must have the sensitivities);
* ``cold`` (with ``--cold``): the first call of a 20 us brake with an empty Numba
  cache directory (``benchmarks/startup.py``'s child), i.e. the cold compile.

docs/benchmarks.md's before/after tables are measured this way.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from bench_common import REPO, run_in_checkout

# the paper's RK4 on both sides (checkouts without the integrator option run RK4 anyway)
_RK4 = """
import inspect
from fuzzymbs.models.brake import DiscBrake
rk4 = dict(integrator="rk4") if "integrator" in inspect.signature(DiscBrake).parameters else dict()
"""

_STUDY = (
    _RK4
    + """
import json, time, warnings
from fuzzymbs.study.study import Study
parameters = {{
    "pad_spring_stiffness": {{"type": "triangular", "modal": 200e3, "spread": 0.1}},
    "caliper_spring_stiffness": {{"type": "triangular", "modal": 1e3, "spread": 0.1}},
    "nodal_force": {{"type": "triangular", "modal": 16e3, "spread": 0.01}},
}}
levels = [0.0, 0.25, 0.5, 0.75, 1.0]
warnings.simplefilter("ignore")
Study(DiscBrake(t_end=2e-5, **rk4), parameters, method="reduced", levels=levels).run(progress=False)
study = Study(DiscBrake(t_end={t_end}, **rk4), parameters, method="reduced", levels=levels)
runs = []
for _ in range(2):
    wall, cpu = time.perf_counter(), time.process_time()
    study.run(chunk_size=33, progress=False)
    runs.append([time.perf_counter() - wall, time.process_time() - cpu])
print(json.dumps(runs))
"""
)

_CALLS = (
    _RK4
    + """
import json, time
import numpy as np
rng = np.random.default_rng(0)
def samples(count):
    scale = lambda modal, spread: modal * (1.0 + spread * rng.uniform(-1.0, 1.0, count))
    return {{"pad_spring_stiffness": scale(200e3, 0.1),
            "caliper_spring_stiffness": scale(1e3, 0.1), "nodal_force": scale(16e3, 0.01)}}
DiscBrake(t_end=2e-5, **rk4)(samples(4))
model = DiscBrake(t_end={t_end}, **rk4)
runs = []
for _ in range(2):
    rows = samples(32)
    wall, cpu = time.perf_counter(), time.process_time()
    model(rows)
    runs.append([time.perf_counter() - wall, time.process_time() - cpu])
print(json.dumps(min(runs)))
"""
)

_ROS = """
import json, time
import numpy as np
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance
names = ("pad_spring_stiffness", "caliper_spring_stiffness", "nodal_force")
signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)
values = np.array([200e3, 1e3, 16e3]) * (1.0 + signs * np.array([0.1, 0.1, 0.01]))
corners = {{name: values[:, k] for k, name in enumerate(names)}}
compiled = DiscBrake(t_end={t_end}, record_interval=1e-5).compiled
common = dict(t_end={t_end}, dt=1e-6, record_interval=1e-5, integrator="ros34pw2",
              tolerance=Tolerance(1e-3), outputs={{"y": Coordinate("lower_pad", 0)}})
variants = (dict(), dict(sensitivities=names))
for extra in variants:
    simulate(compiled, corners, **{{**common, "t_end": 2e-5}}, **extra)
best = [[float("inf")] * 2 for _ in variants]
for _ in range(2):
    for k, extra in enumerate(variants):
        wall, cpu = time.perf_counter(), time.process_time()
        simulate(compiled, corners, **common, **extra)
        best[k] = min(best[k], [time.perf_counter() - wall, time.process_time() - cpu])
print(json.dumps(best))
"""

_COLD = (
    _RK4
    + """
import json, time
import numpy as np
brake = DiscBrake(t_end=2e-5, **rk4)
start = time.perf_counter()
brake({"nodal_force": np.array([16e3])})
print(json.dumps(time.perf_counter() - start))
"""
)


def compare(
    other: Path, rounds: int, cold: bool, t_end: float = 1e-2, ros_t_end: float | None = None
) -> dict:
    sides = {"this": REPO, "other": other.resolve()}
    figures: dict = {name: {"checkout": str(path), "study1": []} for name, path in sides.items()}
    for _ in range(rounds):
        for name, path in sides.items():
            figures[name]["study1"].extend(
                run_in_checkout(_STUDY.format(t_end=t_end), path, timeout=3600)
            )
            calls = run_in_checkout(_CALLS.format(t_end=t_end), path, timeout=3600)
            figures[name].setdefault("rk4_calls", []).append(calls)
            if ros_t_end is not None:
                ros = run_in_checkout(_ROS.format(t_end=ros_t_end), path, timeout=3600)
                figures[name].setdefault("ros_calls", []).append(ros)
            if cold:
                with tempfile.TemporaryDirectory(prefix="fuzzymbs-numba-") as cache:
                    seconds = run_in_checkout(_COLD, path, {"NUMBA_CACHE_DIR": cache}, timeout=3600)
                figures[name].setdefault("cold", []).append(seconds)
    for name in sides:
        walls = [wall for wall, _ in figures[name]["study1"]]
        cpus = [cpu for _, cpu in figures[name]["study1"]]
        figures[name]["study1_wall_min"] = min(walls)
        figures[name]["study1_cpu_min"] = min(cpus)
        figures[name]["rk4_calls_min"] = min(figures[name]["rk4_calls"])
    figures["study1_wall_this_over_other"] = (
        figures["this"]["study1_wall_min"] / figures["other"]["study1_wall_min"]
    )
    figures["rk4_calls_wall_this_over_other"] = (
        figures["this"]["rk4_calls_min"][0] / figures["other"]["rk4_calls_min"][0]
    )
    if ros_t_end is not None:
        for k, label in enumerate(("ros", "ros_sensitivities")):
            cpu = {name: min(run[k][1] for run in figures[name]["ros_calls"]) for name in sides}
            figures[f"{label}_cpu_this_over_other"] = cpu["this"] / cpu["other"]
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("other", type=Path, help="path of the other checkout")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cold", action="store_true", help="also the cold compile")
    parser.add_argument("--ros", action="store_true", help="also ROS34PW2 and its sensitivities")
    parser.add_argument("--ros-t-end", type=float, default=2e-3)
    args = parser.parse_args()
    ros_t_end = args.ros_t_end if args.ros else None
    print(json.dumps(compare(args.other, args.rounds, args.cold, ros_t_end=ros_t_end)))
