"""The adaptive method stops, and says so, when the model's own noise is what remains."""

import hashlib
import warnings

import numpy as np
import pytest

from fuzzymbs.fuzzy import Triangular, plan
from fuzzymbs.fuzzy.methods.adaptive import AdaptiveWarning

NUMBERS = {"a": Triangular(0.0, 1.0, 2.0), "b": Triangular(1.0, 2.0, 3.0)}
BUDGET = 2000


def _smooth(a, b):
    # non-monotonic in a: an interior maximum for the surrogate to resolve
    return np.sin(1.5 * a) * b + 0.5 * a**2


def _support_width() -> float:
    # the widest cut (mu = 0) of the smooth model, from a dense grid
    grid = np.linspace(0.0, 2.0, 401)
    a, b = np.meshgrid(grid, grid + 1.0)
    return float(np.ptp(_smooth(a, b)))


def _pseudo_noise(a, b):
    """A deterministic value in [-1, 1] per point: a hash of its parameter values (as a
    fixed-step integrator's error, it changes at any offset and no refinement removes it)."""
    out = np.empty(len(a))
    for i, point in enumerate(zip(a, b, strict=True)):
        digest = hashlib.sha256(np.array(point, dtype="<f8").tobytes()).digest()
        out[i] = int.from_bytes(digest[:8], "little") / 2**64 * 2.0 - 1.0
    return out


def _noisy(relative):
    amplitude = relative * _support_width()

    def model(s):
        return {"z": _smooth(s["a"], s["b"]) + amplitude * _pseudo_noise(s["a"], s["b"])}

    return model


def _adaptive(model, levels):
    scheme = plan(NUMBERS, method="adaptive", levels=levels, max_runs=BUDGET)
    outputs = scheme.evaluate(model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = scheme.outcome()
    return scheme, outputs, outcome, [str(w.message) for w in caught]


@pytest.mark.parametrize(
    "levels, relative",
    # noise 30 and 10 times the 1 % tolerance (on the widest cut's width); measured: 299
    # runs, noise 0.20; 200 runs, noise 0.16 (the narrower cuts read it larger) on an AVX2
    # host, 169 and 165 runs on an AVX-512 one: the points' last bits, and so the hashed
    # noise, differ. Before the stop stopped needing the stall to last, the first case
    # ran 1,123 runs on the AVX2 host (a chance new smallest error after the twins)
    [(1, 0.3), (4, 0.1)],
)
def test_noise_above_the_tolerance_stops_the_rounds_early_and_is_reported(levels, relative):
    scheme, _, outcome, messages = _adaptive(_noisy(relative), levels)
    assert outcome.status == "noise" and not outcome.converged
    assert outcome.runs < 0.25 * BUDGET
    # the spread between twin runs, on the cut-width scale, is the injected amplitude's order
    assert relative / 3 <= outcome.noise <= 3 * relative
    noise_lines = [m for m in messages if "the model's own noise" in m]
    assert len(noise_lines) == 1
    assert noise_lines[0].startswith(f"adaptive method stopped after {outcome.runs} runs")
    assert f"about {100 * outcome.noise:.3g} % of the cut width" in noise_lines[0]
    assert "(tolerance 1 %)" in noise_lines[0] and "raise method_tolerance" in noise_lines[0]
    attrs = scheme.attrs()
    assert attrs["adaptive_status"] == "noise" and attrs["method_converged"] == 0
    assert attrs["adaptive_noise"] == outcome.noise


@pytest.mark.parametrize("levels, runs", [(1, 19), (4, 38)])
def test_without_noise_the_rounds_are_unchanged(levels, runs):
    # run counts as before the noise rule (measured on the method without it; with four
    # levels 33, plus the 4 probes of the extremum confirmation and its 1 isolated
    # extremum); the error never stalls, so no twin runs and no noise estimate
    _, _, outcome, messages = _adaptive(lambda s: {"z": _smooth(s["a"], s["b"])}, levels)
    assert outcome.status == "converged" and outcome.converged and outcome.error <= 0.01
    assert outcome.runs == runs
    assert np.isnan(outcome.noise)
    assert messages == []


@pytest.mark.parametrize("relative", [0.002, 0.005])
def test_noise_below_the_tolerance_does_not_stop_the_rounds(relative):
    _, _, outcome, messages = _adaptive(_noisy(relative), 4)
    assert outcome.status == "converged" and outcome.error <= 0.01
    assert not any("noise" in m for m in messages)


def test_a_study_records_and_summarises_the_noise_stop():
    from fuzzymbs import Study

    study = Study(_noisy(0.3), NUMBERS, method="adaptive", levels=1)
    with pytest.warns(AdaptiveWarning, match="the model's own noise"):
        result = study.run(progress=False)
    attrs = result.dataset.attrs
    assert attrs["adaptive_status"] == "noise" and attrs["adaptive_runs"] < 0.25 * BUDGET
    assert "stopped by the model's own noise" in result.summary()
    # report.html's checks table says so too
    from fuzzymbs.report import checks

    method = [c for c in checks(result.dataset) if c.name == "method error"]
    assert len(method) == 1 and "stopped by the model's own noise" in method[0].text
