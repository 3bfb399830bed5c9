"""The brake's fuzzy bands against the numerical noise; prints one JSON line.

    python benchmarks/brake_bands.py [--before PATH] [--quick] [--figure]

* ``noise``: the nominal brake (10 ms) run alone and in one block with three other
  study-1 samples: the largest difference relative to the peak per output, in this
  checkout and (``--before``) in another one (e.g. ``git worktree add ../before
  29decec``: the shared-step kernel);
* ``bands``: the 33 samples of study 1 (k, k_c +-10 %, F_n +-1 %) and study 2 (k, k_c,
  omega +-10 %), reduced method, levels 0, 0.25, 0.5, 0.75, 1, each integrated in one
  call with ROS34PW2 at several rtol and with the paper's RK4 at 1 us; the bands'
  deviation from those of the same plan at rtol 1e-6 (cached in benchmarks/.cache),
  per output and level, as a fraction of max(local cut width, 0.1 x the level's widest
  cut) (the normalisation of ``method_error`` and ``time_integration_error``); CPU
  time of each call (all threads);
* ``cost``: the whole default study 1 (``Study.run``) in fresh interpreters: this
  checkout's default (the demo's: adaptive method, shared steps, the tolerance chosen
  by a pilot, the time-integration check), the reduced plan of the earlier default on
  the same integration (33 runs, 6 validation runs), the ``--before`` checkout's
  default (its reduced study, 6 validation runs) and the reduced plan with RK4 at
  1 us, alternating, ``--rounds`` times; the smallest wall times, their ratios (wall
  and CPU), each study's own error estimates, and ``reduced_misses``: how far the
  default's runs lie beyond the reduced plan's bands at rtol 1e-6;
* ``default-runs``: the default study's runs saved by ``cost`` (``--cost-studies``),
  integrated once more at rtol 1e-6 on each sample's own steps; the cut bounds among
  the runs inside each box at the default against the same at rtol 1e-6 (where the
  adaptive method's bounds are decided), per output and level;
* ``simd``: the 33 samples of study 1 at rtol 1e-3 in one call, four samples per
  SIMD block (``kernel="lanes"``) against a block per sample (``kernel="samples"``),
  CPU time, in this checkout and (``--before``) in the other one: what the lanes
  still buy now that each keeps its own clock;
* ``--figure``: docs/figures/brake_band_precision.png, band-relative error against
  CPU time (the work-precision diagram on the scale of the bands); ``--figure-from
  A.json B.json``: the same figure from the ``bands`` of earlier runs (e.g. one run
  with ``--rtol`` on the samples' own steps, one with ``--shared-rtol``).

``--quick``: 0.3 ms signals (:data:`QUICK_T_END`), study 1 only, two tolerances, and the
cost of the default study and RK4 at 1 us only (not the reduced method's: the same study
code with other options, which the smoke test asserts nothing of; the smoke test's mode).
The rtol 1e-6 reference is kept in ``benchmarks/.cache/`` under the model source's
digest (:func:`reference_bands`).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from bench_common import BENCH_DIR, REPO, load_average, run_in_checkout

import fuzzymbs
from fuzzymbs.fuzzy.band_scale import width_relative
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.study.code_version import source_digest
from fuzzymbs.study.integration_check import run_cut_bounds

try:  # POSIX: processes that need the same reference wait for one another
    import fcntl
except ImportError:  # pragma: no cover - Windows computes it in each process
    fcntl = None

OUTPUTS = ("y_lpad", "y_upad", "y_cali")
LEVELS = [0.0, 0.25, 0.5, 0.75, 1.0]
REFERENCE_RTOL = 1e-6
#: the signal length of ``--quick``, the smoke tests' mode (this script's,
#: first_order_correction.py's and logged_jacobians.py's, which share its reference):
#: 1 ms took the three 190 s of a test process in a clean-clone run, the reference a
#: minute of it
QUICK_T_END = 3e-4


def study_parameters(study: int) -> dict[str, fuzzymbs.Triangular]:
    """The fuzzy parameters of the brake's study 1 or 2 (docs/brake.md)."""
    third = (
        ("nodal_force", fuzzymbs.Triangular.relative(16e3, 0.01))
        if study == 1
        else ("disc_speed", fuzzymbs.Triangular.relative(1.0, 0.1))
    )
    return {
        "pad_spring_stiffness": fuzzymbs.Triangular.relative(200e3, 0.1),
        "caliper_spring_stiffness": fuzzymbs.Triangular.relative(1e3, 0.1),
        third[0]: third[1],
    }


def reduced_plan(study: int) -> tuple[Any, dict[str, np.ndarray], dict[str, float]]:
    """The study's reduced plan on :data:`LEVELS`, its samples as columns and its modal
    sample (the one whose step sequence the plan's runs share)."""
    parameters = study_parameters(study)
    plan = fuzzymbs.plan(parameters, method="reduced", levels=LEVELS)
    samples = {k: plan.samples[:, i] for i, k in enumerate(parameters)}
    modal = {k: float(plan.samples[plan.nominal_index, i]) for i, k in enumerate(parameters)}
    return plan, samples, modal


def band_deviation(bands: dict, reference: dict) -> dict[str, list[float]]:
    """Per output, per level with a cut of non-zero width: the largest deviation of either
    bound from the reference's, over max(reference width, 0.1 x its widest cut)."""
    found = {}
    for name in OUTPUTS:
        lower, upper = bands[name]
        ref_lower, ref_upper = reference[name]
        width = ref_upper - ref_lower
        widest = width.max(axis=1, keepdims=True)
        scale = np.maximum(width, 0.1 * widest)
        deviation = np.maximum(np.abs(lower - ref_lower), np.abs(upper - ref_upper))
        found[name] = [
            round(float(np.max(deviation[j] / scale[j])), 5)
            for j in range(len(width))
            if widest[j, 0] > 0
        ]
    return found


def plan_deviation(plan: Any, outputs: dict, reference: dict) -> dict[str, list[float]]:
    """:func:`band_deviation` of the bands ``plan`` retransforms from its runs' ``outputs``."""
    result = plan.retransform({k: outputs[k] for k in OUTPUTS}, check_monotonic=False)
    return band_deviation({k: (result[k].lower, result[k].upper) for k in OUTPUTS}, reference)


def shared_step_deviation(plan: Any, result: Any, steps: Any, reference: dict) -> dict:
    """:func:`plan_deviation` of the plan's runs on a shared sequence (``result`` of
    ``simulate``), corrected as a study corrects them: the modal sample's reference plus
    each run's deviation from the modal sample on the same steps (``steps``: the model's
    :class:`~fuzzymbs.mbs.shared_steps.SharedSteps`)."""
    outputs = {
        k: steps.reference[k][None, :] + result.outputs[k] - steps.modal_outputs[k][None, :]
        for k in OUTPUTS
    }
    return plan_deviation(plan, outputs, reference)


def evaluate_bands(
    study: int, t_end: float, settings: dict, shared: bool = False
) -> tuple[dict, float, float]:
    """The study's plan integrated in one call: ({output: (lower, upper)}, CPU s, wall s).

    ``shared``: every sample on the modal sample's step sequence, corrected by its run
    at rtol 1e-6 (``DiscBrake.share_steps``); the CPU time then includes the modal
    sample's logging, replay and two reference runs."""
    parameters = study_parameters(study)
    plan = fuzzymbs.plan(parameters, method="reduced", levels=LEVELS)
    model = DiscBrake(t_end=t_end, **settings)
    samples = {name: plan.samples[:, i] for i, name in enumerate(parameters)}
    model({name: values[:1] for name, values in samples.items()})  # compile / warm up
    cpu, wall = time.process_time(), time.perf_counter()
    if shared:
        nominal = plan.nominal_index
        model = model.share_steps({name: v[nominal : nominal + 1] for name, v in samples.items()})
    out = model(samples)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    if np.asarray(out["failed"]).any():
        raise RuntimeError(f"study {study} {settings}: samples failed")
    result = plan.retransform({name: out[name] for name in OUTPUTS}, check_monotonic=False)
    return {name: (result[name].lower, result[name].upper) for name in OUTPUTS}, cpu, wall


def default_runs_file(study: int, t_end: float) -> Path:
    """Where ``cost`` saves the default study's bands and runs and ``default-runs`` reads
    them: named by the digest of the study's and the brake model's source, so that runs
    saved by other code are never read as this code's."""
    modules = ["fuzzymbs.study.study", "fuzzymbs.models.brake.model"]
    return _cache_file(f"brake_bands_default_study{study}_t{t_end:g}", modules)


def _cache_file(stem: str, modules: list[str]) -> Path:
    """``benchmarks/.cache/<stem>_<digest>.npz``, the digest that of ``modules``' source
    and the fuzzymbs modules they import (:func:`~fuzzymbs.study.code_version.source_digest`)."""
    digest = (source_digest(modules) or "unknown")[:16]
    return BENCH_DIR / ".cache" / f"{stem}_{digest}.npz"


def reference_bands(study: int, t_end: float) -> dict:
    """The study's reduced-plan bands at rtol ``REFERENCE_RTOL`` on each sample's own steps.

    Kept in ``benchmarks/.cache/`` under the digest of the brake model's source (any edit
    of the model or the engine it imports computes them afresh), written whole or not at
    all, so that the scripts and their smoke tests that need the same reference compute
    it once (about a minute of two cores for 1 ms of study 1)."""
    stem = f"brake_bands_s{study}_t{t_end:g}_r{REFERENCE_RTOL:g}"
    path = _cache_file(stem, ["fuzzymbs.models.brake.model"])
    path.parent.mkdir(exist_ok=True)
    with open(path.with_suffix(".lock"), "w") as lock:
        if fcntl is not None:  # a second process waits for the first one's reference
            fcntl.flock(lock, fcntl.LOCK_EX)
        if path.exists():
            with np.load(path) as data:
                return {n: (data[f"{n}_lower"], data[f"{n}_upper"]) for n in OUTPUTS}
        bands, _, _ = evaluate_bands(study, t_end, {"rtol": REFERENCE_RTOL})
        arrays = {
            f"{n}_{side}": bands[n][k] for n in OUTPUTS for k, side in enumerate(("lower", "upper"))
        }
        partial = path.with_suffix(f".{os.getpid()}.npz")
        np.savez(partial, **arrays)
        os.replace(partial, path)  # a reader never sees a half-written file
    return bands


_NOISE = """
import json, numpy as np, fuzzymbs
from fuzzymbs.models.brake import DiscBrake
p = {{"pad_spring_stiffness": fuzzymbs.Triangular.relative(200e3, 0.1),
     "caliper_spring_stiffness": fuzzymbs.Triangular.relative(1e3, 0.1),
     "nodal_force": fuzzymbs.Triangular.relative(16e3, 0.01)}}
plan = fuzzymbs.plan(p, method="reduced", levels=[0.0, 0.25, 0.5, 0.75, 1.0])
S, model = plan.samples, DiscBrake(t_end={t_end})
def run(rows):
    return model({{k: S[rows, i] for i, k in enumerate(p)}})
nominal = plan.nominal_index
alone, mixed = run([nominal]), run([5, nominal, 12, 20])
print(json.dumps({{k: float(np.abs(mixed[k][1] - alone[k][0]).max() / np.abs(alone[k][0]).max())
                  for k in ("y_lpad", "y_upad", "y_cali")}}))
"""

_SIMD = """
import json, time, numpy as np, fuzzymbs
from fuzzymbs.models.brake import DiscBrake
p = {{"pad_spring_stiffness": fuzzymbs.Triangular.relative(200e3, 0.1),
     "caliper_spring_stiffness": fuzzymbs.Triangular.relative(1e3, 0.1),
     "nodal_force": fuzzymbs.Triangular.relative(16e3, 0.01)}}
plan = fuzzymbs.plan(p, method="reduced", levels=[0.0, 0.25, 0.5, 0.75, 1.0])
samples = {{k: plan.samples[:, i] for i, k in enumerate(p)}}
found = {{}}
for kernel in ("lanes", "samples"):
    model = DiscBrake(t_end={t_end}, rtol=1e-3, kernel=kernel, chunk_size=64)
    model({{k: v[:1] for k, v in samples.items()}})
    cpu = time.process_time()
    model(samples)
    found[kernel + "_cpu_s"] = time.process_time() - cpu
found["samples_over_lanes"] = found["samples_cpu_s"] / found["lanes_cpu_s"]
print(json.dumps(found))
"""

_STUDY = """
import json, time, warnings
import numpy as np
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.study.study import Study
parameters = {{
    "pad_spring_stiffness": {{"type": "triangular", "modal": 200e3, "spread": 0.1}},
    "caliper_spring_stiffness": {{"type": "triangular", "modal": 1e3, "spread": 0.1}},
    {third},
}}
levels = [0.0, 0.25, 0.5, 0.75, 1.0]
warnings.simplefilter("ignore")
settings = {settings}
options = {options}
Study(DiscBrake(t_end=2e-5, **settings), parameters, levels=levels, **options).run(progress=False)
wall, cpu = time.perf_counter(), time.process_time()
result = Study(DiscBrake(t_end={t_end}, **settings), parameters, levels=levels, **options).run(
    chunk_size=33, progress=False
)
attrs = result.dataset.attrs
if {save!r}:
    data = result.dataset
    arrays = {{f"{{n}}_{{side}}": data[f"{{n}}_{{side}}"].values
        for n in ("y_lpad", "y_upad", "y_cali") for side in ("lower", "upper")}}
    if "samples" in data:  # every run (kept with the raw outputs)
        arrays["samples"] = data["samples"].values
        arrays.update({{f"{{n}}_samples": data[f"{{n}}_samples"].values
            for n in ("y_lpad", "y_upad", "y_cali")}})
    np.savez({save!r}, **arrays)
print(json.dumps({{"wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu,
    "time_integration": str(attrs.get("time_integration", "")),
    "time_integration_error": float(attrs.get("time_integration_error", float("nan"))),
    "time_integration_error_peak": float(attrs.get("time_integration_error_peak", float("nan"))),
    "integration_pilot_error": float(attrs.get("integration_pilot_error", float("nan"))),
    "integration_reference_error": float(
        attrs.get("time_integration_reference_error", float("nan"))),
    "integration_reference_error_pilot": float(
        attrs.get("integration_reference_error", float("nan"))),
    "integration_reference_error_predicted": float(
        attrs.get("integration_reference_error_predicted", float("nan"))),
    "integration_pilot_runs": int(attrs.get("integration_pilot_runs", 0)),
    "method_error": float(attrs.get("method_error", float("nan"))),
    "runs": int(attrs.get("adaptive_runs", attrs.get("runs", -1))),
    "validation_runs": int(attrs.get("validation_runs", 0)),
    "integration_tolerance_factor": float(attrs.get("integration_tolerance_factor", 1.0))}}))
"""


_THIRD = {
    1: '"nodal_force": {"type": "triangular", "modal": 16e3, "spread": 0.01}',
    2: '"disc_speed": {"type": "triangular", "modal": 1.0, "spread": 0.1}',
}


def measure_cost(
    before: Path | None,
    t_end: float,
    rounds: int,
    reference: dict,
    study: int = 1,
    quick: bool = False,
) -> dict:
    sides = {
        # the demo study: adaptive method, shared steps, tolerance chosen by the study
        "default": (REPO, {}, {"method": "adaptive"}),
        # the method of the earlier default (reduced, 6 validation runs) on the same
        # integration: the integration's cost on the earlier default's plan
        "reduced": (REPO, {}, {"validation_runs": 6}),
        "rk4_1us": (REPO, {"integrator": "rk4", "dt": 1e-6}, {"validation_runs": 6}),
    }
    if before is not None:
        sides["before_default"] = (before.resolve(), {}, {})
    if study != 1:  # the other studies: the default's bands and cost alone
        sides = {"default": sides["default"]}
    elif quick:
        del sides["reduced"]
    runs: dict[str, list[dict]] = {name: [] for name in sides}
    saved = default_runs_file(study, t_end)
    saved.parent.mkdir(exist_ok=True)
    third = _THIRD[study].replace("{", "{{").replace("}", "}}")
    for _ in range(rounds):
        for name, (checkout, settings, options) in sides.items():
            save = str(saved) if name == "default" else ""
            code = _STUDY.replace("{third}", third).format(
                settings=repr(settings), options=repr(options), t_end=t_end, save=save
            )
            runs[name].append(run_in_checkout(code, checkout))
    cost = {name: min(runs[name], key=lambda r: r["wall_s"]) for name in sides}
    figures = {"runs": runs, "best": cost}
    data = np.load(saved)
    bands = {n: (data[f"{n}_lower"], data[f"{n}_upper"]) for n in OUTPUTS}
    figures["default_study_band_deviation"] = band_deviation(bands, reference)
    figures["reduced_misses"] = reduced_misses(study, data, reference)
    for name in ("rk4_1us", "reduced", "before_default"):
        if name in cost:
            for unit in ("wall_s", "cpu_s"):
                key = f"default_over_{name}" + ("_cpu" if unit == "cpu_s" else "")
                figures[key] = cost["default"][unit] / cost[name][unit]
    if "before_default" in cost and "reduced" in cost:
        figures["reduced_over_before_default"] = (
            cost["reduced"]["wall_s"] / cost["before_default"]["wall_s"]
        )
        figures["reduced_over_before_default_cpu"] = (
            cost["reduced"]["cpu_s"] / cost["before_default"]["cpu_s"]
        )
    return figures


def run_bounds(study: int, samples: np.ndarray, outputs: dict) -> dict:
    """Per output, the cut bounds among the runs inside each of the study's cut boxes
    (:func:`~fuzzymbs.study.integration_check.run_cut_bounds`: where the adaptive
    method's bounds are decided), with the runs that give them."""
    numbers = list(study_parameters(study).values())
    cuts = np.stack([number.cuts(LEVELS) for number in numbers], axis=1)
    failed = np.zeros(len(samples), dtype=bool)
    return run_cut_bounds(samples, outputs, cuts[:, :, 0], cuts[:, :, 1], failed)[1]


def reduced_misses(study: int, data: Any, reference: dict) -> dict[str, list[float]]:
    """How far the default study's runs (true values of the model, each inside the cut
    boxes that hold it) lie beyond the reduced plan's bands at rtol 1e-6, per output and
    level, on the cut-width scale of those bands: what the reduced method misses."""
    if "samples" not in data:
        return {}
    runs = run_bounds(study, data["samples"], {n: data[f"{n}_samples"] for n in OUTPUTS})
    misses = {}
    for name in OUTPUTS:
        lower, upper = reference[name]
        beyond = np.maximum(lower - runs[name].lower, 0.0) + np.maximum(
            runs[name].upper - upper, 0.0
        )
        ratio = width_relative(beyond, lower, upper)
        misses[name] = [float(np.nanmax(r)) if np.isfinite(r).any() else 0.0 for r in ratio]
    return misses


def default_runs_at_reference(study: int, t_end: float) -> dict:
    """The default (adaptive) study's own runs, saved by ``cost``, integrated once more
    at rtol 1e-6 on each sample's own steps: the cut bounds among the runs inside each
    box (:func:`run_bounds`) at the default against the same at rtol 1e-6, per output
    and level with a cut of non-zero width, on the cut-width scale."""
    saved = default_runs_file(study, t_end)
    if not saved.exists():
        raise FileNotFoundError(
            f"{saved.name}: no runs of the default study {study} saved by this code; run "
            f"the 'cost' part first (--parts cost default-runs --cost-studies {study})"
        )
    data = np.load(saved)
    samples = data["samples"]
    names = list(study_parameters(study))
    model = DiscBrake(t_end=t_end, rtol=REFERENCE_RTOL)
    cpu = time.process_time()
    out = model({name: samples[:, i] for i, name in enumerate(names)})
    cpu = time.process_time() - cpu
    default = run_bounds(study, samples, {n: data[f"{n}_samples"] for n in OUTPUTS})
    converged = run_bounds(study, samples, {n: out[n] for n in OUTPUTS})
    runs = {n: (default[n].lower[:-1], default[n].upper[:-1]) for n in OUTPUTS}
    reference = {n: (converged[n].lower[:-1], converged[n].upper[:-1]) for n in OUTPUTS}
    return {
        "runs": len(samples),
        "cpu_s": round(cpu, 1),
        "run_bounds_deviation": band_deviation(runs, reference),
    }


def plot(bands: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8.0, 3.6), sharey=True)
    kinds = {  # label prefix -> marker, colour, legend, label offset
        "rk4": ("s", "k", "RK4 (the paper)", (4, 2)),
        "sha": ("^", "C1", "ROS34PW2 on shared steps (default)", (4, -9)),
        "rod": ("v", "C2", "RODAS4 on shared steps", (4, -9)),
        "rto": ("o", "C0", "ROS34PW2, own steps per sample", (4, 2)),
    }
    for ax, (study, entries) in zip(axes, bands.items(), strict=False):
        shown = set()
        for label, entry in entries.items():
            worst = max(max(v) for v in entry["deviation"].values())
            marker, color, legend, offset = kinds.get(label[:3], kinds["rto"])
            ax.loglog(
                entry["cpu_s"],
                100 * worst,
                marker,
                color=color,
                label=None if legend in shown else legend,
            )
            shown.add(legend)
            ax.annotate(
                label.replace("rodas4 ", "")
                .replace("shared rtol ", "")
                .replace("rtol ", "")
                .replace("rk4 ", ""),
                (entry["cpu_s"], 100 * worst),
                fontsize=7,
                xytext=offset,
                textcoords="offset points",
            )
        ax.axhline(2.0, color="C3", lw=0.8, ls="--")
        ax.axhline(1.0, color="C2", lw=0.8, ls=":")
        ax.set_title(f"brake study {study[-1]} (33 runs, 10 ms)", fontsize=9)
        ax.set_xlabel("CPU time of the 33 runs [s]")
        ax.grid(True, which="both", lw=0.3)
    axes[0].legend(fontsize=6.5, loc="lower left")
    axes[0].set_ylabel("band error [% of the cut width]")
    fig.tight_layout()
    fig.savefig(path, dpi=150)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, help="another checkout for 'noise' and 'cost'")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--figure", action="store_true")
    parser.add_argument(
        "--figure-from",
        type=Path,
        nargs="+",
        help="draw the figure from the 'bands' of earlier runs' JSON lines (merged)",
    )
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--skip-cost", action="store_true")
    parser.add_argument(
        "--parts",
        nargs="+",
        default=["noise", "simd", "bands", "cost"],
        choices=["noise", "simd", "bands", "cost", "default-runs"],
    )
    parser.add_argument(
        "--rtol", type=float, nargs="*", default=[1e-2, 1e-3, 1e-4, 1e-5], help="tolerances"
    )
    parser.add_argument(
        "--shared-rtol",
        type=float,
        nargs="*",
        default=[1e-2, 1e-3, 1e-4],
        help="tolerances on the modal sample's shared steps",
    )
    parser.add_argument(
        "--shared-integrators",
        nargs="+",
        default=["ros34pw2"],
        choices=["ros34pw2", "rodas4"],
        help="Rosenbrock methods of the shared-step variants",
    )
    parser.add_argument("--no-rk4", action="store_true", help="leave out the paper's RK4 at 1 us")
    parser.add_argument("--studies", type=int, nargs="+", default=[1, 2], help="studies of 'bands'")
    parser.add_argument(
        "--cost-studies", type=int, nargs="+", default=[1], help="studies whose default to time"
    )
    args = parser.parse_args(argv)
    if args.figure_from:
        merged: dict = {}
        for path in args.figure_from:
            for study, entries in json.loads(path.read_text())["bands"].items():
                merged.setdefault(study, {}).update(entries)
        plot(merged, REPO / "docs" / "figures" / "brake_band_precision.png")
        return {"bands": merged}
    t_end = QUICK_T_END if args.quick else 1e-2
    studies = (1,) if args.quick else tuple(args.studies)
    rtols = (1e-2, 1e-3) if args.quick else tuple(args.rtol)
    figures: dict = {"load_average_start": load_average(), "t_end_s": t_end}
    parts = set(args.parts)
    if "noise" in parts:
        figures["noise"] = {"this": run_in_checkout(_NOISE.format(t_end=t_end), REPO)}
        if args.before is not None:
            figures["noise"]["before"] = run_in_checkout(_NOISE.format(t_end=t_end), args.before)
    if "simd" in parts:
        figures["simd"] = {"this": run_in_checkout(_SIMD.format(t_end=t_end), REPO)}
        if args.before is not None:
            figures["simd"]["before"] = run_in_checkout(_SIMD.format(t_end=t_end), args.before)
    figures["bands"] = {}
    references = {}
    for study in studies if parts & {"bands", "cost"} else ():
        reference = reference_bands(study, t_end)
        references[study] = reference
        if "bands" not in parts:
            continue
        entries = {}
        variants = [(f"rtol {r:g}", {"rtol": r}, False) for r in rtols]
        for method in args.shared_integrators:
            prefix = "shared" if method == "ros34pw2" else f"{method} shared"
            variants += [
                (f"{prefix} rtol {r:g}", {"rtol": r, "integrator": method}, True)
                for r in args.shared_rtol
            ]
        if not args.no_rk4:
            variants.append(("rk4 1 us", {"integrator": "rk4", "dt": 1e-6}, False))
        for label, settings, shared in variants:
            bands, cpu, wall = evaluate_bands(study, t_end, settings, shared)
            entries[label] = {
                "cpu_s": round(cpu, 2),
                "wall_s": round(wall, 2),
                "deviation": band_deviation(bands, reference),
            }
        figures["bands"][f"study{study}"] = entries
    if "cost" in parts and not args.skip_cost:
        rounds = 1 if args.quick else args.rounds
        for study in args.cost_studies if not args.quick else (1,):
            if study not in references:
                references[study] = reference_bands(study, t_end)
            key = "cost" if study == 1 else f"cost_study{study}"
            figures[key] = measure_cost(
                args.before, t_end, rounds, references[study], study, quick=args.quick
            )
    if "default-runs" in parts:  # after 'cost' (or an earlier run of it) saved the runs
        figures["default_runs"] = {
            f"study{study}": default_runs_at_reference(study, t_end) for study in args.cost_studies
        }
    if args.figure and figures["bands"]:
        plot(figures["bands"], REPO / "docs" / "figures" / "brake_band_precision.png")
    figures["load_average_end"] = load_average()
    return figures


if __name__ == "__main__":
    print(json.dumps(main()))
