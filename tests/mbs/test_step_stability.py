"""RK4 step limit from the linearised eigenvalues (fuzzymbs.mbs.step_stability).

References: the stability polynomial of classic RK4, R(z) = 1 + z + z^2/2 + z^3/6 +
z^4/24, with its interval -2.785293563405282 <= z <= 0 on the real axis (where
R = 1 again: the real root of 1 + z/2 + z^2/6 + z^3/24 = 0) and
|y| <= 2 sqrt(2) on the imaginary axis (Hairer & Wanner, Solving ODEs II, Sec. IV.2:
|R(iy)|^2 = 1 - y^6/72 + y^8/576, which is 1 at y^2 = 8), and the engine's own RK4
kernel integrating a linear system just inside and just outside the limit.
"""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.linearize import eigenanalysis, steady_state
from fuzzymbs.mbs.step_stability import rk4_amplification, rk4_step_limit, rk4_step_stability
from fuzzymbs.mbs.system import Coordinate

from .systems import hoffmann_system

REAL_AXIS_LIMIT = 2.785293563405282  # -z of the real root of 1 + z/2 + z^2/6 + z^3/24


def test_real_and_imaginary_axis_limits_match_the_closed_forms():
    limit, limiting = rk4_step_limit(np.array([-1.0 + 0j]))
    assert limit == pytest.approx(REAL_AXIS_LIMIT, rel=1e-13)
    assert limiting == -1.0
    # independent check of the constant: R(z) - 1 = z (1 + z/2 + z^2/6 + z^3/24) vanishes
    z = -REAL_AXIS_LIMIT
    assert 1 + z / 2 + z**2 / 6 + z**3 / 24 == pytest.approx(0.0, abs=1e-14)
    limit, _ = rk4_step_limit(np.array([2e3j, -2e3j]))
    assert limit == pytest.approx(2 * np.sqrt(2) / 2e3, rel=1e-13)


def test_limit_scales_with_the_eigenvalue_and_takes_the_smallest():
    lam = np.array([[-10.0 + 0j, -1e4 + 0j, 300j, -300j], [-1.0 + 0j, 0.0 + 0j, 5j, -5j]])
    limit, limiting = rk4_step_limit(lam)
    # row 0: the real -1e4 (2.785e-4 s) beats the undamped 300 rad/s (9.4e-3 s); row 1: the
    # undamped 5 rad/s (2 sqrt(2) / 5 = 0.566 s) beats the real -1 (2.785 s)
    np.testing.assert_allclose(limit, [REAL_AXIS_LIMIT / 1e4, 2 * np.sqrt(2) / 5], rtol=1e-13)
    np.testing.assert_array_equal(limiting, [-1e4, 5j])


@pytest.mark.parametrize("angle_deg", [100.0, 120.0, 135.0, 150.0, 170.0])
def test_limit_on_an_oblique_ray_is_the_boundary_of_the_region(angle_deg):
    direction = np.exp(1j * np.deg2rad(angle_deg))
    limit, _ = rk4_step_limit(np.array([direction]))
    # on the boundary, inside just below, outside just above
    assert rk4_amplification(limit * direction) == pytest.approx(1.0, abs=1e-12)
    assert rk4_amplification(0.999 * limit * direction) < 1.0
    assert rk4_amplification(1.001 * limit * direction) > 1.0
    # and nowhere on the ray before it (a scan independent of the implementation's)
    t = np.linspace(1e-6, 0.999 * limit, 20001)
    assert (rk4_amplification(t * direction) <= 1.0 + 1e-14).all()


def test_growing_rigid_undamped_and_failed_eigenvalues():
    # growing modes have no limit; a zero eigenvalue (rigid motion) neither
    limit, limiting = rk4_step_limit(np.array([[3.0 + 50j, 3.0 - 50j, 0j]]))
    assert np.isinf(limit[0]) and np.isnan(limiting[0])
    # an undamped mode with round-off in its real part is taken on the imaginary axis
    limit, _ = rk4_step_limit(np.array([1e-12 + 1e3j, 1e-12 - 1e3j]))
    assert limit == pytest.approx(2 * np.sqrt(2) / 1e3, rel=1e-13)
    limit, limiting = rk4_step_limit(np.array([[np.nan + 0j, -1.0 + 0j]]))
    assert np.isnan(limit[0]) and np.isnan(limiting[0])
    with pytest.raises(InvalidParameterError, match="at least one axis"):
        rk4_step_limit(-1.0)
    with pytest.raises(InvalidParameterError, match="dt must be > 0"):
        rk4_step_stability(hoffmann_system().compile(), dt=-1e-4)


def test_engine_rk4_is_stable_just_below_the_limit_and_blows_up_just_above():
    # Hoffmann's 2-dof model (mu = 0) with heavy spring damping: an overdamped mode with
    # a large real eigenvalue sets the step limit; the contact stays closed (linear).
    system = hoffmann_system(0.0, damping=2e3).compile()
    check = rk4_step_stability(system, dt=1e-4)
    limit = check.max_stable_dt[0]
    lam = check.limiting_eigenvalue[0]
    assert lam.imag == 0.0 and lam.real < -1e3  # the overdamped mode
    assert limit == pytest.approx(REAL_AXIS_LIMIT / abs(lam.real), rel=1e-12)
    st = steady_state(system)
    x0 = np.concatenate([st.x, np.zeros_like(st.x)], axis=1)[0]
    x0[0] += 1e-8  # tangential kick, far below the static penetration
    outputs = {"z": Coordinate("block", 0)}
    amplitude = {}
    for factor in (0.97, 1.03):
        dt = factor * limit
        result = simulate(
            system, t_end=150 * dt, dt=dt, outputs=outputs, initial_state=x0, displacement_bound=10
        )
        assert not result.failed[0]
        z = result.outputs["z"][0] - st.x[0, 0]
        amplitude[factor] = np.abs(z[-20:]).max() / 1e-8
        if factor > 1:  # the growing mode dominates: z gains |R(lambda dt)| per step
            rate = (z[-1] / z[-41]) ** (1 / 40)
            assert rate == pytest.approx(rk4_amplification(lam * dt), rel=1e-4)  # slow modes: 5e-6
        stability = rk4_step_stability(system, dt=dt)
        assert stability.stable[0] == (factor < 1)
        assert stability.amplified[0].any() == (factor > 1)
    # inside: the kick decays (the slow modes keep part of it); outside it grows
    assert amplitude[0.97] < 1.0
    assert amplitude[1.03] > 1e4


def test_disc_brake_at_the_paper_step_is_outside_the_region():
    # docs/brake.md, "Accuracy of the time integration": the friction-damped pad modes,
    # real eigenvalues down to about -8.9e6 1/s, limit RK4 to about 0.31 us
    from fuzzymbs.models.brake import DiscBrake

    brake = DiscBrake(t_end=1e-5)
    analysis = eigenanalysis(brake.compiled)
    check = brake.step_stability()
    assert not check.stable[0] and check.dt == 1e-6
    lam = analysis.eigenvalues[0]
    decaying_real = lam[(lam.imag == 0) & (lam.real < 0)]
    assert check.limiting_eigenvalue[0] == pytest.approx(decaying_real.min(), rel=1e-12)
    assert check.max_stable_dt[0] == pytest.approx(
        REAL_AXIS_LIMIT / abs(decaying_real.min()), rel=1e-12
    )
    assert 2.5e-7 < check.max_stable_dt[0] < 3.5e-7
    assert check.amplified[0].sum() >= 2
    assert brake.step_stability(dt=2.5e-7).stable[0]
    # the friction damping falls with the sliding speed: at 10 rad/s about ten times the limit
    fast = brake.step_stability({"disc_speed": np.array([10.0])})
    assert fast.stable[0] and 3.0e-6 < fast.max_stable_dt[0] < 3.4e-6
