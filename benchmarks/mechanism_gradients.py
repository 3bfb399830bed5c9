"""Derivatives of the registered mechanisms' outputs: convergence in the step, what the
replayed steps remove, and the cost per parameter; one JSON line.

    python benchmarks/mechanism_gradients.py [--samples 4] [--steps 1e-2 1e-3 1e-4 1e-5 1e-6 1e-7]

For each registered mechanism (``flexible-pendulum``, ``spin-up-beam``,
``slider-crank``, each at its defaults) and each of its parameters, over
``--samples`` samples (the defaults, then each parameter moved by -4 % to +4 %,
the same draw in every run):

* **step**: the derivatives ``model(samples, wrt=all)["gradients"]`` at each relative
  step ``delta`` of :data:`fuzzymbs.mbs.central_differences.GRADIENT_STEP`; per
  parameter the largest change to the next smaller step over every output, sample and
  time, on the scale of that derivative's largest value (a central difference's
  truncation falls as delta^2 until round-off and the inputs' own noise take over);
* **own steps**: the same quotient at the default step from runs that each chose their
  own steps (``model(p +- delta)``), its largest distance from the replayed one on the
  same scale (what the replay removes: the step control's jumps over 2 delta);
* **tighter**: the replayed derivative against the same at a hundredth of the model's
  tolerance (the derivative's own integration error);
* **size**: the largest ``|p dy/dp|`` over the output's largest ``|y|`` (the change of
  the output for a 100 % change of the parameter, to first order), over the outputs: a
  parameter the outputs hardly depend on has derivatives of round-off, whose changes
  above are relative to that;
* **second difference**: at steps 1e-2, 1e-3 and the default, the largest ``|y+ + y- - 2 y|``
  of any parameter's pair over the output's largest ``|y|``, for pairs on the replayed
  steps and on their own (what the check of a pair,
  :data:`fuzzymbs.mbs.central_differences.LEFT_TRAJECTORY`, bounds; a replay that grows
  shows on the replayed side only);
* **failed**: samples whose derivatives failed at each step (a pair that left the
  sample's trajectory, :data:`fuzzymbs.mbs.central_differences.LEFT_TRAJECTORY`);
* **cost**: CPU of the call with every parameter's derivatives over the call without,
  the smaller of ``--repeats`` rounds (the runs per parameter: two replays).
"""

from __future__ import annotations

import argparse
import itertools
import json
import time

import numpy as np
from bench_common import load_average

import fuzzymbs.mbs.central_differences as central_differences
from fuzzymbs.models.mechanisms.pendulum import flexible_pendulum
from fuzzymbs.models.mechanisms.slider_crank import slider_crank
from fuzzymbs.models.mechanisms.spin_up_beam import spin_up_beam

MODELS = {
    "flexible-pendulum": flexible_pendulum,
    "spin-up-beam": spin_up_beam,
    "slider-crank": slider_crank,
}


def samples_of(model, count: int) -> dict[str, np.ndarray]:
    """The defaults, then ``count - 1`` samples with every parameter within +-4 %."""
    rng = np.random.default_rng(20261130)
    names = model.parameters
    factors = np.vstack([np.ones(len(names)), rng.uniform(0.96, 1.04, (count - 1, len(names)))])
    return {n: model.defaults[n] * factors[:, i] for i, n in enumerate(names)}


def derivatives(model, samples, step: float) -> tuple[dict[str, np.ndarray], int]:
    """The derivatives at relative step ``step`` and the samples whose derivatives failed
    (NaN in the derivatives)."""
    saved = central_differences.GRADIENT_STEP
    central_differences.GRADIENT_STEP = step
    try:
        out = model(samples, wrt=model.parameters)
    finally:
        central_differences.GRADIENT_STEP = saved
    gradients = out["gradients"]
    for output in gradients:
        gradients[output][out["failed"]] = np.nan
    return gradients, int(np.count_nonzero(out["failed"]))


def size(model, samples, gradients: dict, k: int) -> float:
    """The largest |p dy/dp| / max |y| of parameter k over the outputs."""
    values = model(samples)
    p = samples[model.parameters[k]][:, None]
    return max(
        float(np.nanmax(np.abs(p * gradients[o][..., k])) / np.nanmax(np.abs(values[o])))
        for o in model.outputs
    )


def relative_change(a: dict, b: dict, k: int) -> float:
    """Largest |a - b| of parameter k over the outputs, on the scale of b's largest value
    (NaN where either failed everywhere)."""
    if any(all(np.isnan(x[o][..., k]).all() for o in b) for x in (a, b)):
        return float("nan")
    worst = 0.0
    for output in b:
        scale = np.nanmax(np.abs(b[output][..., k]))
        if scale > 0:
            worst = max(
                worst, float(np.nanmax(np.abs(a[output][..., k] - b[output][..., k]))) / scale
            )
    return worst


def own_steps(model, samples, step: float) -> dict[str, np.ndarray]:
    """Central differences of runs on their own steps, every parameter."""
    out: dict[str, list] = {o: [] for o in model.outputs}
    for name in model.parameters:
        delta = step * np.where(samples[name] != 0, np.abs(samples[name]), 1.0)
        up = model({**samples, name: samples[name] + delta})
        down = model({**samples, name: samples[name] - delta})
        for o in model.outputs:
            out[o].append((up[o] - down[o]) / (2 * delta[:, None]))
    return {o: np.stack(v, axis=-1) for o, v in out.items()}


def second_differences(model, samples, step: float) -> dict[str, float]:
    """The largest second difference ``|y+ + y- - 2 y|`` of any parameter's pair at relative
    ``step``, over the outputs' largest ``|y|`` (the quantity
    :data:`fuzzymbs.mbs.central_differences.LEFT_TRAJECTORY` bounds), for pairs replaying
    each sample's steps and pairs on their own steps."""
    nominal = model.run(samples, log_steps=True)
    values = {o: np.asarray(r(nominal)) for o, (r, _) in model.readers.items()}
    worst = {"replayed": 0.0, "own_steps": 0.0}
    for name in model.parameters:
        delta = step * np.where(samples[name] != 0, np.abs(samples[name]), 1.0)
        for label, options in (
            ("replayed", {"step_sequences": nominal.step_logs}),
            ("own_steps", {}),
        ):
            up = model.run({**samples, name: samples[name] + delta}, **options)
            down = model.run({**samples, name: samples[name] - delta}, **options)
            for o, (reader, _) in model.readers.items():
                second = np.abs(reader(up) + reader(down) - 2.0 * values[o])
                scale = np.abs(values[o]).max()
                worst[label] = max(worst[label], float(np.nanmax(second)) / scale)
    return worst


def cpu(call) -> float:
    start = time.process_time()
    call()
    return time.process_time() - start


def measure(name: str, count: int, steps: list[float], repeats: int, **options) -> dict:
    model = MODELS[name](**options)
    samples = samples_of(model, count)
    model(samples, wrt=model.parameters)  # compile and warm up
    runs = {step: derivatives(model, samples, step) for step in steps}
    found = {step: gradients for step, (gradients, _) in runs.items()}
    default = central_differences.GRADIENT_STEP
    base = found[default] if default in found else derivatives(model, samples, default)[0]
    own = own_steps(model, samples, default)
    tight = model.tightened(100.0)
    tighter = derivatives(tight, samples, default)[0]
    plain = min(cpu(lambda: model(samples)) for _ in range(repeats))
    with_all = min(cpu(lambda: model(samples, wrt=model.parameters)) for _ in range(repeats))
    parameters = {}
    for k, parameter in enumerate(model.parameters):
        parameters[parameter] = {
            "step_change": {
                f"{a:g}->{b:g}": relative_change(found[a], found[b], k)
                for a, b in itertools.pairwise(steps)
            },
            "own_steps_vs_replayed": relative_change(own, base, k),
            "replayed_vs_tighter": relative_change(base, tighter, k),
            "size": size(model, samples, base, k),
        }
    seconds = {
        f"{step:g}": second_differences(model, samples, step) for step in (1e-2, 1e-3, default)
    }
    return {
        "samples": count,
        "parameters": parameters,
        "largest_second_difference": seconds,
        "failed_samples": {f"{step:g}": failed for step, (_, failed) in runs.items()},
        "cpu_plain_s": plain,
        "cpu_with_all_s": with_all,
        "cost_ratio": with_all / plain,
        "runs_per_parameter": (with_all / plain - 1.0) / len(model.parameters),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument(
        "--steps", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
    )
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS))
    args = parser.parse_args()
    report = {
        "load_average_start": load_average(),
        "default_step": central_differences.GRADIENT_STEP,
    }
    for name in args.models:
        report[name] = measure(name, args.samples, args.steps, args.repeats)
        row = report[name]
        print(
            f"{name}: cost {row['cost_ratio']:.2f} "
            f"({row['runs_per_parameter']:.2f} runs per parameter); failed samples per step "
            f"{row['failed_samples']}; largest second differences "
            f"{row['largest_second_difference']}"
        )
        for parameter, entry in row["parameters"].items():
            changes = " ".join(f"{v:.1e}" for v in entry["step_change"].values())
            print(
                f"  {parameter:16s} step changes {changes}"
                f" | own steps {entry['own_steps_vs_replayed']:.1e}"
                f" | tighter {entry['replayed_vs_tighter']:.1e} | size {entry['size']:.1e}"
            )
    report["load_average_end"] = load_average()
    print(json.dumps(report))


if __name__ == "__main__":
    main()
