"""The dynamic gear pair (``gear-pair-dynamic``): its cost, how smooth its DTE is in a
parameter, and how its default step converges; one JSON line.

    python benchmarks/gear_dynamic.py [--checkout ../before] [--rounds 3] [--quick]

* **cost**: wall and CPU time of the registered model's call on four samples (torque
  90, 100, 110, 120 N m; defaults otherwise: 1000 rpm, 40 mesh periods), the smallest
  of three calls after a warm-up (``--quick``: one), in a fresh interpreter; with
  ``--checkout`` the same in another checkout (``git worktree add ../before <commit>``),
  the two alternating ``--rounds`` times, and the largest difference of their DTEs
  relative to its peak;
* **smoothness**: the DTE over 12 mesh periods (4 recorded) at the torque moved by
  ``k 1e-4`` relative, k = -10..10, for the contact's default damping (viscous while
  in contact: its force jumps to ``c delta'`` as a tooth pair enters contact), without
  damping, and with Hunt-Crossley damping (``damping_exponents`` (1, 1), its force
  growing from zero with the penetration); per law the largest residual of a quadratic
  fit in k over ``1e-4`` times the largest slope (the DTE's jitter in the parameter, in
  units of a central difference's step), and the largest change of the central
  differences at steps 1e-4, 2e-4, 5e-4, 1e-3 from the fit's slope, relative to the
  largest slope (what a derivative by central differences would be off);
* **convergence**: at 1000 and 3000 rpm, three samples (torque 80, 100, 120 N m with
  the contact stiffness at 0.8, 1, 1.2 times its default), the DTE at the default step
  against a sixteenth of it, and the difference to half the step (what a study's
  time-integration check reports), both over the width of the band the samples span.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from bench_common import load_average, run_in_checkout, run_json_subprocess

_COST = """
import json, time
import numpy as np
from fuzzymbs.models.gears import gear_pair_dynamic_model
model = gear_pair_dynamic_model()
samples = {{"torque": np.array([90.0, 100.0, 110.0, 120.0])}}
model(samples)
wall = cpu = float("inf")
for _ in range({repeats}):
    w, c = time.perf_counter(), time.process_time()
    out = model(samples)
    wall = min(wall, time.perf_counter() - w)
    cpu = min(cpu, time.process_time() - c)
np.save({path!r}, out["dte"])
print(json.dumps({{"wall_s": round(wall, 3), "cpu_s": round(cpu, 3)}}))
"""

_CONVERGENCE = """
import json
import numpy as np
from fuzzymbs.models.gears import gear_pair_dynamic_model
def dte(scale, speed):
    model = gear_pair_dynamic_model(dynamic={{"step_scale": scale, "speed_rpm": speed,
                                             "mesh_periods": {periods},
                                             "output_periods": {recorded}}})
    samples = {{"torque": np.array([80.0, 100.0, 120.0]),
               "contact_stiffness": model.defaults["contact_stiffness"] * np.array([0.8, 1, 1.2])}}
    return model.dynamic_plan.dt, model(samples)["dte"]
report = {{}}
for speed in (1000.0, 3000.0):
    _, reference = dte(1 / 16, speed)
    band = np.max(reference.max(axis=0) - reference.min(axis=0))
    dt, default = dte(1.0, speed)
    _, half = dte(0.5, speed)
    error = float(np.max(np.abs(default - reference)) / band)
    difference = float(np.max(np.abs(default - half)) / band)
    report[f"{{speed:g}} rpm"] = {{"dt_s": dt, "error_of_band": error,
                                  "half_step_difference_of_band": difference,
                                  "difference_over_error": difference / error}}
print(json.dumps(report))
"""

_SMOOTHNESS = """
import json
import numpy as np
from fuzzymbs.models.gears import DEFAULT_PAIR_OPTIONS, DEFAULT_TORQUE, make_pair
from fuzzymbs.models.gears.model import MubocoPR
pair = make_pair(**DEFAULT_PAIR_OPTIONS)
laws = {{
    "viscous (default)": dict(damping=3000.0),
    "undamped": dict(damping=0.0),
    "Hunt-Crossley": dict(damping=1.7e9, damping_exponents=(1.0, 1.0)),
}}
k = np.arange(-10, 11)
s = k * 1e-4
fit = np.vstack([np.ones_like(s), s, s**2]).T
report = {{}}
for name, law in laws.items():
    model = MubocoPR(pair, torque=DEFAULT_TORQUE, mode="dynamic",
                     dynamic={{"mesh_periods": {periods}, "output_periods": 4}}, **law)
    dte = model({{"torque": DEFAULT_TORQUE * (1.0 + s)}})["dte"]
    coefficients = np.linalg.lstsq(fit, dte, rcond=None)[0]
    slope = np.abs(coefficients[1]).max()
    residual = np.abs(dte - fit @ coefficients).max()
    changes = {{}}
    for d in (1, 2, 5, 10):
        central = (dte[10 + d] - dte[10 - d]) / (2 * d * 1e-4)
        changes[f"{{d * 1e-4:g}}"] = float(np.abs(central - coefficients[1]).max() / slope)
    report[name] = {{
        "jitter_in_steps": float(residual / (1e-4 * slope)),
        "difference_change": changes,
        "dt_s": model.dynamic_plan.dt,
    }}
print(json.dumps(report))
"""


def measure(checkout: Path | None = None, rounds: int = 3, quick: bool = False) -> dict:
    """The report of the module docstring (``quick``: one timed call of the cost, the
    smoothness over 5 mesh periods, the convergence over 3)."""
    import numpy as np

    folder = Path(tempfile.mkdtemp(prefix="gear_dynamic_"))
    here, there = str(folder / "here.npy"), str(folder / "there.npy")
    report: dict = {"load_average_before": load_average()}
    costs: dict[str, list] = {"this": [], "other": []}
    repeats = 1 if quick else 3
    for _ in range(rounds if checkout else 1):
        costs["this"].append(run_json_subprocess(_COST.format(path=here, repeats=repeats)))
        if checkout:
            cost = _COST.format(path=there, repeats=repeats)
            costs["other"].append(run_in_checkout(cost, checkout.resolve()))
    report["cost_this"] = costs["this"]
    if checkout:
        report["cost_other"] = costs["other"]
        a, b = np.load(here), np.load(there)
        report["dte_difference_of_peak"] = float(np.abs(a - b).max() / np.abs(b).max())
        cpu = {side: min(c["cpu_s"] for c in runs) for side, runs in costs.items()}
        report["cpu_ratio_this_over_other"] = round(cpu["this"] / cpu["other"], 3)
    periods = 5 if quick else 12
    report["smoothness"] = run_json_subprocess(_SMOOTHNESS.format(periods=periods))
    periods, recorded = (3, 1) if quick else (40, 8)  # quick: 3 mesh periods, the last recorded
    report["convergence"] = run_json_subprocess(
        _CONVERGENCE.format(periods=periods, recorded=recorded)
    )
    report["load_average_after"] = load_average()
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkout", type=Path, help="another checkout to time against")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="one timed call of the cost, smoothness over 5 mesh periods, convergence over 3",
    )
    args = parser.parse_args()
    print(json.dumps(measure(args.checkout, args.rounds, args.quick)))


if __name__ == "__main__":
    main()
