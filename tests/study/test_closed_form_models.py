"""Closed-form demo models against independent references."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.closed_form import make_damped_oscillator, make_product
from fuzzymbs.models.closed_form.oscillator import free_response


def test_product_is_elementwise():
    model = make_product()
    out = model({"x1": np.array([1.0, -2.0]), "x2": np.array([3.0, 4.0])})
    np.testing.assert_array_equal(out["z"], [3.0, -8.0])


@pytest.mark.parametrize("damping", [6.0, 2 * np.sqrt(1000.0 * 2.0), 300.0])
def test_free_response_matches_numerical_integration(damping):
    # under-damped (zeta ~ 0.07), critically damped (zeta = 1) and over-damped (zeta ~ 3.4);
    # reference: DOP853 with rtol 1e-11 on m x'' + c x' + k x = 0, x(0) = 0.01, x'(0) = 0.
    mass, stiffness, x0 = 2.0, 1000.0, 0.01
    t = np.linspace(0.0, 0.5, 201)
    reference = solve_ivp(
        lambda _t, y: [y[1], -(damping * y[1] + stiffness * y[0]) / mass],
        (0.0, 0.5),
        [x0, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-15,
        method="DOP853",
    ).y[0]
    closed = free_response(t, np.array([mass]), np.array([stiffness]), np.array([damping]), x0)
    # tolerance: 1e-8 of the amplitude, well above the integrator error (rtol 1e-11)
    np.testing.assert_allclose(closed[0], reference, rtol=0, atol=1e-8 * x0)


def test_oscillator_outputs_reference_and_failures():
    model = make_damped_oscillator(duration=0.2, time_steps=21)
    assert list(model.coords) == ["time"] and model.coords["time"].shape == (21,)
    out = model(
        {
            "mass": np.array([1.0, -1.0, 1.0]),
            "stiffness": np.array([1000.0, 1000.0, 1000.0]),
            "damping": np.array([np.sqrt(1000.0) * 0.1, 1.0, -1.0]),
        }
    )
    assert out["displacement"].shape == (3, 21)
    # the first sample is the default oscillator: equal to the numerical reference curve
    np.testing.assert_allclose(out["displacement"][0], model.reference["displacement"], atol=1e-10)
    np.testing.assert_allclose(out["natural_frequency"][0], np.sqrt(1000.0) / (2 * np.pi))
    np.testing.assert_array_equal(out["failed"], [False, True, True])
    assert out["failure_reason"][1] == "mass <= 0 kg"
    assert out["failure_reason"][2] == "damping < 0 N s/m"
    assert np.isnan(out["displacement"][1:]).all()


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"time_steps": 1}, "time_steps must be an integer >= 2"),
        ({"time_steps": "many"}, "time_steps must be an integer >= 2"),
        ({"duration": float("nan")}, "duration must be a finite number > 0"),
        ({"duration": -1.0}, "duration must be a finite number > 0"),
        ({"initial_displacement": float("inf")}, "initial_displacement must be a finite"),
    ],
)
def test_oscillator_rejects_bad_options(options, fragment):
    with pytest.raises(InvalidParameterError, match=fragment):
        make_damped_oscillator(**options)
