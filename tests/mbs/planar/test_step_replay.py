"""Logged step sequences replayed, and a mechanism model's derivatives by internal numerical
differentiation, against closed forms."""

import numpy as np
import pytest

import fuzzymbs.mbs.central_differences as central_differences
import fuzzymbs.mbs.planar.step_sequences as step_sequences
from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs import spatial
from fuzzymbs.mbs.mechanism_model import MechanismModel
from fuzzymbs.mbs.planar import (
    Mechanism,
    Prismatic,
    Revolute,
    RigidBody,
    SpringDamper,
    ground,
    simulate,
)
from fuzzymbs.tolerance import Tolerance

# slow: the planar kernels take about 25 s to compile (test_elements.py says why)
pytestmark = pytest.mark.slow

#: few output times, so that the step control, not the output grid, sets the steps
TIMES = np.linspace(0.0, 2.0, 5)
FREE_LENGTH = 0.9
RELEASE = 0.1


def oscillator(p):
    """A block on a slide tied to the ground by a spring and damper, released RELEASE from
    the spring's free length at rest (the prismatic joint keeps the projection busy)."""
    block = RigidBody("block", mass=p["mass"], inertia=0.1, position=(FREE_LENGTH + RELEASE, 0.0))
    mechanism = Mechanism().add(block, Prismatic(ground.point(), block.point(), name="slide"))
    mechanism.add(
        SpringDamper(
            ground.point(),
            block.point(),
            stiffness=p["stiffness"],
            damping=p["damping"],
            free_length=FREE_LENGTH,
        )
    )
    return mechanism


def closed_form(stiffness, damping, mass, t):
    """x(t) of the damped oscillator (Rao, Mechanical Vibrations, sec. 2.6), any dtype: with
    complex parameters it gives complex-step derivatives (Squire & Trapp 1998)."""
    w = np.sqrt(stiffness / mass)
    zeta = damping / (2 * np.sqrt(stiffness * mass))
    wd = w * np.sqrt(1 - zeta**2)
    decay = np.exp(-zeta * w * t)
    return FREE_LENGTH + RELEASE * decay * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))


def oscillator_model(rtol=1e-10, **options):
    return MechanismModel(
        oscillator,
        parameters={"stiffness": 800.0, "damping": 4.0, "mass": 2.0},
        outputs={"x": (lambda result: result.coordinates("block")[..., 0], "m")},
        times=TIMES,
        tolerance=Tolerance(rtol=rtol, atol=rtol * 1e-2),
        **options,
    )


def pendulum(angle):
    rod = RigidBody("rod", mass=1.0, inertia=1.0 / 12, center=(0.5, 0.0), angle=-1.5 + angle)
    return Mechanism(gravity=(0.0, -9.81)).add(rod, Revolute(ground.point(), rod.point()))


@pytest.mark.parametrize("kernel", ["lanes", "samples"])
def test_a_replayed_log_repeats_the_run(kernel):
    mechanisms = [pendulum(a) for a in (0.5, 0.7, 0.9)]
    run = simulate(mechanisms, TIMES, rtol=1e-8, atol=1e-10, kernel=kernel, log_steps=True)
    assert run.step_logs is not None and [log.size for log in run.step_logs] == list(run.accepted)
    assert run.accepted.min() > 4 * TIMES.size  # the step control chose the steps
    replay = simulate(
        mechanisms, TIMES, rtol=1e-8, atol=1e-10, kernel=kernel, step_sequences=run.step_logs,
        log_steps=True,
    )  # fmt: skip
    assert not replay.failed.any() and np.array_equal(replay.rejected, [0, 0, 0])
    for logged, replayed in zip(run.step_logs, replay.step_logs, strict=True):
        assert np.array_equal(logged, replayed)  # the same end times, bit for bit
    # the step lengths are differences of the logged times: the same to round-off
    np.testing.assert_allclose(replay.states, run.states, rtol=0, atol=1e-12)


def test_replays_are_the_same_bits_in_lanes_and_alone():
    mechanisms = [pendulum(a) for a in (0.5, 0.7, 0.9)]
    run = simulate(mechanisms, TIMES, log_steps=True)
    sequences = [run.step_logs[0]] * 3  # every sample on the first one's steps
    lanes = simulate(mechanisms, TIMES, step_sequences=sequences)
    alone = simulate(mechanisms, TIMES, step_sequences=sequences, kernel="samples")
    assert np.array_equal(lanes.states, alone.states)
    assert np.array_equal(lanes.accepted, [run.accepted[0]] * 3)


def test_a_log_longer_than_its_capacity_is_taken_again(monkeypatch):
    mechanisms = [pendulum(a) for a in (0.5, 0.9)]
    whole = simulate(mechanisms, TIMES, log_steps=True)
    monkeypatch.setattr(step_sequences, "LOG_CAPACITY", 7)
    again = simulate(mechanisms, TIMES, log_steps=True)
    for a, b in zip(whole.step_logs, again.step_logs, strict=True):
        assert np.array_equal(a, b)
    assert np.array_equal(whole.states, again.states)


def spatial_oscillator(p):
    """:func:`oscillator` in the spatial engine (its slide runs along the markers' z axes)."""
    position = (FREE_LENGTH + RELEASE, 0.0, 0.0)
    block = spatial.RigidBody("block", mass=p["mass"], inertia=(0.1, 0.1, 0.1), position=position)
    along_x = spatial.frame_with_z((1.0, 0.0, 0.0))
    mechanism = spatial.Mechanism().add(
        block, spatial.Prismatic(spatial.ground.point(axes=along_x), block.point(axes=along_x))
    )
    mechanism.add(
        spatial.SpringDamper(
            spatial.ground.point(),
            block.point(),
            stiffness=p["stiffness"],
            damping=p["damping"],
            free_length=FREE_LENGTH,
        )
    )
    return mechanism


def test_the_spatial_engine_replays_its_log_and_differentiates():
    mechanism = spatial_oscillator({"stiffness": 800.0, "damping": 4.0, "mass": 2.0})
    run = spatial.simulate(mechanism, TIMES, rtol=1e-8, atol=1e-10, log_steps=True)
    replay = spatial.simulate(mechanism, TIMES, rtol=1e-8, atol=1e-10, step_sequences=run.step_logs)
    assert run.accepted[0] > 4 * TIMES.size
    np.testing.assert_allclose(replay.states, run.states, rtol=0, atol=1e-12)
    # the spatial model's derivatives against the closed form's complex step, as the
    # planar one's below (measured: within 4.2e-7 of their size; bound 1e-6)
    model = MechanismModel(
        spatial_oscillator,
        parameters={"stiffness": 800.0, "damping": 4.0, "mass": 2.0},
        outputs={"x": (lambda result: result.position("block")[..., 0], "m")},
        times=TIMES,
        tolerance=Tolerance(rtol=1e-10, atol=1e-12),
    )
    gradients = model({}, wrt=("stiffness", "mass"))["gradients"]["x"][0]
    for k, name in enumerate(("stiffness", "mass")):
        p = {"stiffness": 800.0, "damping": 4.0, "mass": 2.0}
        exact = closed_form(**{**p, name: p[name] + 1e-30j}, t=TIMES).imag / 1e-30
        np.testing.assert_allclose(gradients[:, k], exact, rtol=0, atol=1e-6 * np.abs(exact).max())


def test_a_step_an_ulp_past_an_output_time_records_it():
    # the step control's t + h may round past an output time, as a log then holds it: the
    # replay takes that step and records the output there, as the logged run did
    run = simulate([pendulum(0.5)], TIMES, rtol=1e-8, atol=1e-10, log_steps=True)
    log = run.step_logs[0].copy()
    at = np.flatnonzero(log == TIMES[2])[0]
    log[at] = np.nextafter(TIMES[2], np.inf)
    replay = simulate([pendulum(0.5)], TIMES, rtol=1e-8, atol=1e-10, step_sequences=[log])
    assert not replay.failed.any()
    np.testing.assert_allclose(replay.states, run.states, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "sequences, match",
    [
        ([np.array([0.5, 1.0, 1.5, 2.0])] * 2, "one sequence per sample"),
        ([np.array([0.5, 1.0, 1.5])], "ending at the last output time"),
        ([np.array([0.5, 0.4, 1.0, 1.5, 2.0])], "strictly increasing"),
        ([np.array([0.5, 1.2, 1.5, 2.0])], "every output time"),
        ([np.array([0.5, 1.0, np.nan, 2.0])], "finite"),
    ],
)
def test_a_sequence_that_cannot_be_replayed_is_refused(sequences, match):
    with pytest.raises(InvalidParameterError, match=match):
        simulate([pendulum(0.5)], TIMES, step_sequences=sequences)


def test_derivatives_match_the_complex_step_of_the_closed_form():
    model = oscillator_model()
    samples = {"stiffness": np.array([800.0, 900.0]), "mass": np.array([2.0, 1.8])}
    names = ("stiffness", "damping", "mass")
    out = model(samples, wrt=names)
    plain = model(samples)
    assert np.array_equal(out["x"], plain["x"])  # the outputs do not change with wrt
    gradients = out["gradients"]["x"]
    assert gradients.shape == (2, TIMES.size, 3) and not out["failed"].any()
    h = 1e-30
    for s in range(2):
        p = {"stiffness": samples["stiffness"][s], "damping": 4.0, "mass": samples["mass"][s]}
        for k, name in enumerate(names):
            shifted = {**p, name: p[name] + 1j * h}
            exact = closed_form(**shifted, t=TIMES).imag / h
            # tolerance: the integration error at rtol 1e-10 and the differences' O(delta^2)
            np.testing.assert_allclose(
                gradients[s, :, k], exact, rtol=0, atol=1e-6 * np.abs(exact).max()
            )


def test_replayed_differences_converge_as_the_step_falls(monkeypatch):
    # the two runs of a difference take the sample's own steps, so their quotient is the
    # derivative of one smooth discrete map: O(delta^2) until round-off, at any tolerance
    model = oscillator_model(rtol=1e-6)
    samples = {"stiffness": np.linspace(700.0, 900.0, 9)}
    found = {}
    for step in (1e-3, 1e-4, 1e-6):
        monkeypatch.setattr(central_differences, "GRADIENT_STEP", step)
        found[step] = model(samples, wrt=("stiffness",))["gradients"]["x"][..., 0]
    scale = np.abs(found[1e-6]).max()
    coarse = np.abs(found[1e-3] - found[1e-6]).max() / scale
    fine = np.abs(found[1e-4] - found[1e-6]).max() / scale
    assert fine < 1e-6 and fine < coarse / 50  # a hundredfold for a tenfold step: O(delta^2)


def test_unknown_or_repeated_names_are_refused():
    model = oscillator_model()
    with pytest.raises(InvalidParameterError, match="cannot differentiate"):
        model({"stiffness": np.array([800.0])}, wrt=("spring",))
    with pytest.raises(InvalidParameterError, match="twice"):
        model({"stiffness": np.array([800.0])}, wrt=("mass", "mass"))
    assert model.differentiable == ("stiffness", "damping", "mass")
    assert model.gradient_cost == 2.0


def test_a_pair_that_leaves_the_trajectory_fails_the_sample(monkeypatch):
    # the spin-up beam's steps sit at DOP853's stability edge for its stiffest mode: a beam
    # 1 % shorter (stiffer) replayed on them grows without bound (measured: a second
    # difference of 6e26 against the 0.53 m the tip deflects), and is reported, not used
    from fuzzymbs.models.mechanisms.spin_up_beam import spin_up_beam

    model = spin_up_beam()
    samples = {"length": np.array([8.0])}
    monkeypatch.setattr(central_differences, "GRADIENT_STEP", 1e-2)
    out = model(samples, wrt=("length",))
    assert out["failed"][0]
    assert "length +- 0.08 are too far from its own on 'tip_deflection'" in out["failure_reason"][0]
    monkeypatch.setattr(central_differences, "GRADIENT_STEP", 1e-4)  # the default: smooth
    out = model(samples, wrt=("length",))
    assert not out["failed"][0] and np.isfinite(out["gradients"]["tip_deflection"]).all()


def test_an_adaptive_study_takes_the_mechanism_gradients():
    # the oscillator through a study with gradients: the runs carry them, the bands
    # against the closed form's dense-grid truth miss at most the tolerance (1 %) plus
    # the truth's resolution (a 41 x 41 grid over each cut's box), and the study takes
    # fewer runs than without them (measured: 39 against 54; both miss by 3e-8)
    from fuzzymbs import Study
    from fuzzymbs.fuzzy.band_scale import band_miss
    from fuzzymbs.fuzzy.numbers import triangular_numbers

    numbers = triangular_numbers({"stiffness": (720.0, 800.0, 880.0), "mass": (1.9, 2.0, 2.1)})
    result = Study(
        oscillator_model(rtol=1e-9), numbers, method="adaptive", levels=2, gradients=True
    ).run(progress=False)
    attrs = result.dataset.attrs
    assert attrs["adaptive_gradients"] == "stiffness, mass" and attrs["method_converged"]
    levels = result.dataset["level"].values
    truth_lower, truth_upper = [], []
    for level in levels:
        k = np.linspace(*numbers["stiffness"].alpha_cut(level), 41)
        m = np.linspace(*numbers["mass"].alpha_cut(level), 41)
        kk, mm = np.meshgrid(k, m)
        x = closed_form(kk[..., None], 4.0, mm[..., None], TIMES)
        truth_lower.append(x.min(axis=(0, 1)))
        truth_upper.append(x.max(axis=(0, 1)))
    miss = band_miss(
        result.dataset["x_lower"].values, result.dataset["x_upper"].values,
        np.array(truth_lower), np.array(truth_upper),
    )  # fmt: skip
    assert miss <= 0.011
    without = Study(
        oscillator_model(rtol=1e-9), numbers, method="adaptive", levels=2, gradients=False
    ).run(progress=False)
    assert attrs["adaptive_runs"] < without.dataset.attrs["adaptive_runs"]


def test_named_steps_replace_the_relative_one():
    # an absolute step for the mass (2 % of it) against the default relative one (1e-4):
    # the central difference's truncation grows as the step squared, so the named step is
    # visibly the one taken (against the closed form's complex step, as above)
    samples = {"mass": np.array([2.0])}
    exact = closed_form(800.0, 4.0, 2.0 + 1e-30j, TIMES).imag / 1e-30
    errors = {}
    for steps in (None, {"mass": 0.04}):
        model = oscillator_model(gradient_steps=steps)
        found = model(samples, wrt=("mass",))["gradients"]["x"][0, :, 0]
        errors[steps is None] = np.abs(found - exact).max() / np.abs(exact).max()
    assert errors[True] < 1e-6 < 1e-4 < errors[False]
    with pytest.raises(InvalidParameterError, match="not a parameter of this model"):
        oscillator_model(gradient_steps={"spring": 1.0})
    with pytest.raises(InvalidParameterError, match="positive finite"):
        oscillator_model(gradient_steps={"mass": 0.0})
