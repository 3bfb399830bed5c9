"""The central differences behind the mechanism and RK4 models' gradients, on plain
functions: their arithmetic, steps, and how failed and far-apart runs are reported
(the engines' runs themselves: tests/mbs/planar/test_step_replay.py)."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.central_differences import (
    GRADIENT_STEP,
    central_differences,
    checked_steps,
    perturbed_samples,
)

TIMES = np.linspace(0.0, 1.0, 5)


def cubic(p):
    """y(t) = a^3 t + b: central differences of a cubic in a carry a^2 delta^2 exactly."""
    return p["a"] ** 3 * TIMES + p["b"]


def runner(function, fail=()):
    """A :data:`~fuzzymbs.mbs.central_differences.PerturbedRuns` of ``function``; the
    perturbed runs numbered in ``fail`` fail."""

    def run(parameters, owners):
        values = np.array([function(p) for p in parameters])
        failed = np.array([i in fail for i in range(len(parameters))])
        values[failed] = np.nan
        return {"y": values}, failed, ["diverged" if f else "" for f in failed]

    return run


def test_the_quotient_is_the_central_difference_with_the_relative_step():
    parameters = [{"a": 2.0, "b": 0.0}, {"a": -1.0, "b": 3.0}]
    nominal = {"y": np.array([cubic(p) for p in parameters])}
    gradients, reasons = central_differences(
        nominal, np.zeros(2, dtype=bool), parameters, ("a", "b"), runner(cubic)
    )
    assert reasons == [None, None] and gradients["y"].shape == (2, TIMES.size, 2)
    for s, p in enumerate(parameters):
        delta = GRADIENT_STEP * abs(p["a"])
        # (a + d)^3 - (a - d)^3 = 6 a^2 d + 2 d^3: the quotient is 3 a^2 + d^2, exactly
        expected = (3 * p["a"] ** 2 + delta**2) * TIMES
        np.testing.assert_allclose(gradients["y"][s, :, 0], expected, rtol=1e-9)
        # b = 0 takes the step GRADIENT_STEP in its unit; the output is linear in it
        np.testing.assert_allclose(gradients["y"][s, :, 1], 1.0, rtol=1e-9)


def test_named_steps_are_absolute():
    _, _, deltas = perturbed_samples(
        [{"a": 2.0, "b": 0.0}], ("a", "b"), np.ones(1, dtype=bool), {"b": 1e-7}
    )
    np.testing.assert_array_equal(deltas, [[GRADIENT_STEP * 2.0, 1e-7]])
    assert checked_steps(None, ("a",)) == {}
    with pytest.raises(InvalidParameterError, match="'c', not a parameter"):
        checked_steps({"c": 1.0}, ("a", "b"))
    with pytest.raises(InvalidParameterError, match=r"gradient_steps\['a'\].*positive finite"):
        checked_steps({"a": float("nan")}, ("a", "b"))


def test_a_failed_sample_gets_nan_and_no_runs():
    parameters = [{"a": 2.0, "b": 0.0}, {"a": 1.0, "b": 0.0}]
    asked = []

    def run(rows, owners):
        asked.extend(owners)
        return runner(cubic)(rows, owners)

    nominal = {"y": np.array([cubic(p) for p in parameters])}
    gradients, reasons = central_differences(
        nominal, np.array([True, False]), parameters, ("a",), run
    )
    assert set(asked) == {1} and reasons == [None, None]
    assert np.isnan(gradients["y"][0]).all() and np.isfinite(gradients["y"][1]).all()


def test_a_failed_perturbed_run_fails_its_sample_naming_it():
    parameters = [{"a": 2.0, "b": 0.0}, {"a": 1.0, "b": 0.0}]
    nominal = {"y": np.array([cubic(p) for p in parameters])}
    # runs: sample 0 a+, a-, b+, b-, then sample 1 likewise; the fifth (sample 1, a+) fails
    _, reasons = central_differences(
        nominal, np.zeros(2, dtype=bool), parameters, ("a", "b"), runner(cubic, fail=(4,))
    )
    assert reasons[0] is None
    assert reasons[1] == "its run at a + 0.0001: diverged"


def test_a_pair_far_from_its_sample_fails_it():
    # y jumps by 1 between a and a + delta (as a run that left the sample's trajectory):
    # a second difference of 1 against an output of size 2, beyond a tenth of it
    def jump(p):
        return np.full(TIMES.size, 2.0 + (1.0 if p["a"] > 1.0 else 0.0))

    parameters = [{"a": 1.0, "b": 0.0}]
    _, reasons = central_differences(
        {"y": jump(parameters[0])[None]}, np.zeros(1, dtype=bool), parameters, ("a",),
        runner(jump),
    )  # fmt: skip
    assert reasons[0].startswith("its runs at a +- 0.0001 are too far from its own on 'y'")
    assert "second difference 1, the output's largest value 2" in reasons[0]
