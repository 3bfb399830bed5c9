"""Cost per run of the external models: FMU (FMPy) and command models.

Builds the example damped-oscillator FMU (examples/fmu, FMI 2.0 and 3.0, needs a C
compiler) and times, warm, per sample: co-simulation and model exchange (CVODE,
default tolerance) through :class:`~fuzzymbs.models.external.fmu.FmuModel`; one
extraction plus instantiation of the FMU (what a model without instance reuse
would pay per sample, so ``reuse_factor`` = (sample + instantiation) / sample);
and one run of the command-model example (examples/command: a Python solver
reading an input deck, most of it the interpreter's start-up). Also the model-
exchange error against the closed form at CVODE tolerances 1e-4 ... 1e-8
(docs/studies.md, "FMU models"; the default 1e-6 is chosen from this table).

Usage::

    python benchmarks/external_models.py [--quick]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import tempfile
import time
from pathlib import Path

import numpy as np

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
STOP, INTERVAL = 0.25, 0.0025


def _build(folder: Path, version: int) -> Path:
    spec = importlib.util.spec_from_file_location(
        "build_oscillator_fmu", EXAMPLES / "fmu" / "build_oscillator_fmu.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build(folder / f"oscillator{version}.fmu", version)


def _samples(count: int) -> dict[str, np.ndarray]:
    return {"k": 100.0 + 0.01 * np.arange(count), "c": np.full(count, 0.4)}


def _per_sample(model, count: int) -> float:
    model(_samples(2))  # warm: the instance exists
    started = time.perf_counter()
    model(_samples(count))
    return (time.perf_counter() - started) / count


def closed_form(time_grid: np.ndarray, k: float = 100.0, c: float = 0.4) -> np.ndarray:
    """x(t) of m x'' + c x' + k x = 0, m = 1, x(0) = 0.01, x'(0) = 0 (underdamped)."""
    sigma = c / 2.0
    wd = np.sqrt(k - sigma**2)
    return (
        0.01
        * np.exp(-sigma * time_grid)
        * (np.cos(wd * time_grid) + sigma / wd * np.sin(wd * time_grid))
    )


def cvode_errors(fmu: Path) -> dict[str, float]:
    """Model-exchange error of x against the closed form, relative to its peak, by rtol."""
    from fuzzymbs.models.external.fmu import FmuModel

    errors = {}
    for rtol in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8):
        model = FmuModel(fmu, STOP, INTERVAL, interface="model-exchange", solver_tolerance=rtol)
        x = model({"k": np.array([100.0]), "c": np.array([0.4])})["x"][0]
        errors[f"{rtol:g}"] = float(np.abs(x - closed_form(model.coords["time"])).max() / 0.01)
    return errors


def main(argv: list[str] | None = None) -> dict:
    from fuzzymbs.models.external import fmu as fmu_module
    from fuzzymbs.models.external.command import CommandModel
    from fuzzymbs.models.external.fmu import FmuModel

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples")
    args = parser.parse_args(argv)
    count = 10 if args.quick else 100
    figures: dict = {"samples": count}
    with tempfile.TemporaryDirectory() as scratch:
        for version in (2, 3):
            fmu = _build(Path(scratch), version)
            for interface in ("co-simulation", "model-exchange"):
                model = FmuModel(fmu, STOP, INTERVAL, interface=interface)
                figures[f"fmi{version}_{interface}_ms"] = 1e3 * _per_sample(model, count)
            model = FmuModel(fmu, STOP, INTERVAL, interface="co-simulation")
            started = time.perf_counter()
            for _ in range(count // 5):
                fmu_module._Loaded(model).close()
            instantiate = (time.perf_counter() - started) / (count // 5)
            figures[f"fmi{version}_extract_and_instantiate_ms"] = 1e3 * instantiate
            sample = figures[f"fmi{version}_co-simulation_ms"] / 1e3
            figures[f"fmi{version}_reuse_factor"] = (sample + instantiate) / sample
        figures["cvode_error_by_rtol"] = cvode_errors(Path(scratch) / "oscillator2.fmu")
    command = CommandModel(
        ["./oscillator_solver.py", "{input}", "{output}"],
        template="oscillator.deck",
        base_dir=EXAMPLES / "command",
    )
    figures["command_run_ms"] = 1e3 * _per_sample(command, max(count // 5, 2))
    print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in figures.items()}))
    return figures


if __name__ == "__main__":
    main()
