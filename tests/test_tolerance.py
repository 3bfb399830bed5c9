"""An integrator's tolerance has one home and one default (fuzzymbs.tolerance): simulate,
SimulationModel, the brake, the mechanisms, the gears' check and the study's pilot read
the same object, and its values are checked by name."""

import inspect

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import TranslatingBody
from fuzzymbs.mbs.forces import Spring
from fuzzymbs.mbs.integrate import SimulationModel, simulate
from fuzzymbs.mbs.lumped import rigid_body
from fuzzymbs.mbs.system import Coordinate, System
from fuzzymbs.tolerance import ATOL_PER_RTOL, DEFAULT_TOLERANCE, Tolerance, tolerance_of


def spring_model(**settings) -> SimulationModel:
    system = System()
    system.add_body(TranslatingBody(rigid_body("mass", 1.0), ["y"]))
    system.add(Spring("s", "mass", [0], stiffness=100.0, direction="y"))
    outputs = {"y": Coordinate("mass")}
    return SimulationModel(system, t_end=0.01, dt=1e-3, outputs=outputs, **settings)


def test_the_defaults_keep_their_measured_values():
    # docs/brake.md backs rtol 1e-2 and atol 1e-5 rtol; checks ten times tighter, RK4 halved
    assert (DEFAULT_TOLERANCE.rtol, DEFAULT_TOLERANCE.atol) == (1e-2, None)
    assert ATOL_PER_RTOL == 1e-5
    assert (DEFAULT_TOLERANCE.tightening, DEFAULT_TOLERANCE.step_division) == (10.0, 2)


def test_simulate_the_model_and_the_brake_read_the_one_default():
    from fuzzymbs.models.brake import OPTIONS, DiscBrake

    assert inspect.signature(simulate).parameters["tolerance"].default is DEFAULT_TOLERANCE
    assert spring_model().tolerance is DEFAULT_TOLERANCE
    brake = inspect.signature(DiscBrake).parameters
    assert (brake["rtol"].default, brake["atol"].default) == (
        DEFAULT_TOLERANCE.rtol,
        DEFAULT_TOLERANCE.atol,
    )
    assert f"default {DEFAULT_TOLERANCE.rtol:g}" in OPTIONS["rtol"]


def test_the_study_check_and_pilot_read_the_models_tolerance():
    from fuzzymbs.study import integration_check

    assert integration_check.MIN_SHARED_FACTOR == DEFAULT_TOLERANCE.tightening
    ros = spring_model(integrator="ros34pw2", tolerance=Tolerance(1e-3, 1e-9, tightening=4.0))
    assert tolerance_of(ros) is ros.tolerance
    tight = ros.tightened()  # what the study's check runs
    assert (tight.tolerance.rtol, tight.tolerance.atol) == (1e-3 / 4.0, 1e-9 / 4.0)
    rk4 = spring_model(tolerance=Tolerance(1e-2, step_division=4))
    assert rk4.tightened().settings["dt"] == 1e-3 / 4
    assert tolerance_of(object()) is DEFAULT_TOLERANCE


def test_the_mechanisms_defaults_are_tolerance_objects():
    from fuzzymbs.mbs.mechanism_model import ENGINE_TOLERANCE
    from fuzzymbs.models.mechanisms.slider_crank import TOLERANCE, slider_crank

    assert (ENGINE_TOLERANCE.rtol, ENGINE_TOLERANCE.atol) == (1e-6, 1e-8)
    assert (TOLERANCE.rtol, TOLERANCE.atol) == (1e-5, 1e-7)
    model = slider_crank(time_steps=3)
    assert model.tolerance == TOLERANCE
    tight = model.tightened()
    assert (tight.tolerance.rtol, tight.tolerance.atol) == (1e-5 / 10.0, 1e-7 / 10.0)


def test_the_gears_check_divides_its_step_by_the_step_division():
    from fuzzymbs.models.gears import MubocoPR, make_pair

    settings = {"speed_rpm": 300.0, "mesh_periods": 3, "output_periods": 1}
    gear = MubocoPR(make_pair(), torque=100.0, mode="dynamic", damping=3000.0, dynamic=settings)
    tight = gear.tightened()
    assert tight.dynamic.step_scale == gear.dynamic.step_scale / DEFAULT_TOLERANCE.step_division


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ({"rtol": 0.0}, "rtol must be in"),
        ({"rtol": np.array([1e-3, 1.0])}, "rtol must be in"),
        ({"rtol": 1e-3, "atol": -1.0}, "atol must be > 0"),
        ({"rtol": 1e-3, "tightening": 1.0}, "tightening must be > 1"),
        ({"rtol": 1e-3, "step_division": 1}, "step_division must be a whole number >= 2"),
    ],
)
def test_bad_values_are_refused_by_name(given, message):
    with pytest.raises(InvalidParameterError, match=message):
        Tolerance(**given)


def test_tightening_keeps_an_atol_that_scales_with_rtol():
    tight = DEFAULT_TOLERANCE.tightened()
    assert (tight.rtol, tight.atol) == (1e-2 / 10.0, None)
    rtol, atol = tight.arrays()
    np.testing.assert_array_equal(atol, ATOL_PER_RTOL * rtol)
    per_sample = Tolerance(np.array([1e-3, 1e-4]))
    np.testing.assert_array_equal(per_sample.arrays()[1], ATOL_PER_RTOL * np.array([1e-3, 1e-4]))
