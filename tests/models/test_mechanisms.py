"""The registered mechanism models against independent references."""

from pathlib import Path

import numpy as np
import pytest

from fuzzymbs.models.mechanisms import pendulum
from fuzzymbs.models.mechanisms.pendulum import flexible_pendulum
from fuzzymbs.models.mechanisms.spin_up_beam import spin_up_beam
from fuzzymbs.study.registry import get_model

DATA = Path(__file__).resolve().parents[1] / "data"


def spin_up_reference():
    # geometrically nonlinear co-rotational beam (Crisfield's element, 64 elements, Radau at
    # rtol 1e-8), tests/mbs/nonlinear_beam.py; within 4e-4 of its converged mesh
    return np.load(DATA / "spin_up_beam_reference.npz")


@pytest.mark.slow  # the planar kernels take 25 to 35 s to compile
def test_spin_up_beam_follows_the_geometrically_nonlinear_beam():
    # the bound is 5 % of the peak over the whole run at 1, 2.5 and 4 rad/s; measured
    # 0.014 %, 0.042 % and 0.12 % (6 clamped modes, geometric stiffening by foreshortening)
    reference = spin_up_reference()
    model = spin_up_beam(duration=20.0, time_steps=201)
    out = model({"spin_speed": [1.0, 2.5, 4.0, 10.0]})
    assert not out["failed"].any()
    for row, key in enumerate(["tip_deflection_1", "tip_deflection_2_5", "tip_deflection_4"]):
        ref = reference[key]
        assert np.abs(out["tip_deflection"][row] - ref).max() < 0.005 * np.abs(ref).max(), key
    # bounded above the first bending frequency (2.91 rad/s): at 10 rad/s within 0.5 % too
    ref = reference["tip_deflection_10"]
    assert np.abs(out["tip_deflection"][3] - ref).max() < 0.01 * np.abs(ref).max()


@pytest.mark.slow  # the planar kernels take 25 to 35 s to compile
def test_spin_up_beam_without_stiffening_diverges():
    # linear modes alone show only spin softening: above the first bending frequency the tip
    # runs away (what Kane, Ryan & Banerjee showed of the "conventional" approach)
    from fuzzymbs.mbs.planar import simulate
    from fuzzymbs.models.mechanisms.spin_up_beam import PARAMETERS, build

    mechanism = build({**PARAMETERS, "spin_speed": 4.0})
    mechanism.bodies[0].geometric_stiffening = False
    result = simulate(mechanism, np.linspace(0.0, 10.0, 101))
    body = result.coordinates("beam")[0, :, 3:]
    tip = body @ mechanism.bodies[0].beam.node_modes[-1, 1]
    assert result.failed[0] or np.nanmax(np.abs(tip)) > 1.0


@pytest.mark.slow  # the planar kernels take 25 to 35 s to compile
def test_flexible_pendulum_swings_at_its_linearised_period():
    # small release angle: the period of the time integration against the lowest frequency of the
    # mechanism linearised at rest (hanging, gravity prestress included), corrected for the
    # amplitude 0.05 rad by T = T0 (1 + theta0^2 / 16)
    from fuzzymbs.mbs.planar import linearize

    model = flexible_pendulum(duration=12.0, time_steps=2401)
    angle = model({"initial_angle": [0.05]})["angle"][0]
    t = model.times
    index = np.flatnonzero(np.diff(np.sign(angle)) != 0)
    step = (t[index + 1] - t[index]) / (angle[index + 1] - angle[index])
    period = 2 * np.mean(np.diff(t[index] - angle[index] * step))

    def linear_period(modulus):
        values = {**pendulum.PARAMETERS, "initial_angle": 0.0, "youngs_modulus": modulus}
        hanging = pendulum.build(values)
        return 2 * np.pi / linearize(hanging).frequencies()[0]

    correction = 1 + 0.05**2 / 16
    # the release excites the elastic modes, whose beat moves the zero crossings: 1.3e-4 over 12 s
    assert period == pytest.approx(linear_period(2.1e11) * correction, rel=3e-4)
    # the rigid compound pendulum's 2 pi sqrt(2 L / (3 g)) (closed form) is the stiff limit: the
    # elastic beam swings slower by its compliance (measured 2.9e-4), which falls as 1 / E
    rigid = 2 * np.pi * np.sqrt(2 * 1.0 / (3 * pendulum.GRAVITY))
    compliance = linear_period(2.1e11) / rigid - 1
    assert 1e-4 < compliance < 2e-3
    assert linear_period(2.1e13) / rigid - 1 == pytest.approx(compliance / 100, rel=0.02)


def test_registered_parameters_and_outputs_are_the_models():
    for name, factory in [
        ("flexible-pendulum", flexible_pendulum),
        ("spin-up-beam", spin_up_beam),
    ]:
        spec = get_model(name)
        model = factory(time_steps=3, duration=0.01)
        assert set(spec.parameters) == set(model.parameters)
        assert dict(spec.outputs) == model.outputs
        for parameter, info in spec.parameters.items():
            assert info.default == pytest.approx(model.defaults[parameter])


@pytest.mark.slow  # the co-rotational reference takes about 8 s
def test_flexible_slider_crank_follows_a_geometrically_nonlinear_rod():
    # a second code: the rod as 16 co-rotational beam elements (Crisfield's element, Radau at
    # rtol 1e-7; tests/mbs/nonlinear_beam.py), the crank's spin-up and the slider the same; over
    # the spin-up and 3 ms beyond it. Measured: deflection 0.38 % of its peak, slider position
    # 5e-6, pin force 2e-4 (the reference's 16 elements are part of that)
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "mbs"))
    from nonlinear_beam import slider_crank_reference

    from fuzzymbs.models.mechanisms.slider_crank import slider_crank

    times = np.linspace(0.0, 0.05, 251)
    reference = slider_crank_reference(times, elements=16, rtol=1e-7, atol=1e-9)
    out = slider_crank(duration=0.05, time_steps=251)({})
    tolerance = {"midpoint_deflection": 1e-2, "slider_position": 2e-5, "slider_pin_force_x": 1e-3}
    for name, relative in tolerance.items():
        peak = np.abs(reference[name]).max()
        assert np.abs(out[name][0] - reference[name]).max() < relative * peak, name


@pytest.mark.slow  # the planar kernels take 25 to 35 s to compile
def test_slider_crank_takes_fewer_dop853_steps_than_dormand_prince_for_the_same_answer():
    # the rod's fifth bending mode (24 krad/s) holds Dormand-Prince 5(4) at the edge of its
    # stability region (near |h lambda| = 1 on the imaginary axis; DOP853's reaches 5.9):
    # measured 1,979 against 884 accepted steps at rtol 1e-6 / atol 1e-8, with the midpoint
    # deflection 1.1e-6 and 3.7e-8 of its peak off a DOP853 run at rtol 1e-12
    # (docs/mechanisms.md, "Integrator")
    from fuzzymbs.models.mechanisms.outputs import deflection_in_frame
    from fuzzymbs.models.mechanisms.slider_crank import slider_crank

    runs = {
        pair: slider_crank(integrator=pair, rtol=1e-6, atol=1e-8).run({})
        for pair in ("dopri5", "auto")
    }
    assert runs["auto"].accepted[0] < 0.5 * runs["dopri5"].accepted[0]
    deflections = {m: deflection_in_frame(r, "rod", "midpoint")[0] for m, r in runs.items()}
    peak = np.abs(deflections["auto"]).max()
    assert np.abs(deflections["auto"] - deflections["dopri5"]).max() < 3e-6 * peak
