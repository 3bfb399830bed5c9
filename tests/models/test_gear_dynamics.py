"""Dynamic mode: quasi-static limit, spectrum extraction, settings."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears import MubocoPR, make_pair
from fuzzymbs.models.gears.dynamics import (
    DynamicSettings,
    harmonic_amplitudes,
    penetration_rate,
)
from fuzzymbs.models.gears.flank_contact import (
    PHI_REF2,
    PITCH1,
    PITCH2,
    RELIEF,
    THETA_REF1,
    pair_contact,
    sample_geometry,
)


@pytest.fixture(scope="module")
def pair():
    return make_pair()


def test_slow_running_dte_approaches_the_static_ste(pair):
    # At a mesh frequency far below the mesh resonance (100 Hz vs ~5 kHz) the dynamic
    # TE follows the quasi-static STE; the residual ringing after each change of the
    # number of pairs in contact is damped by the contact damping (zeta 0.11-0.14).
    settings = {"speed_rpm": 300.0, "mesh_periods": 4, "output_periods": 2}
    dynamic = MubocoPR(pair, torque=100.0, mode="dynamic", damping=3000.0, dynamic=settings)
    out = dynamic({})
    assert not out["failed"].any()
    static = MubocoPR(pair, torque=100.0, positions=64, reference=False)({})["ste"][0]
    dte = out["dte"][0].reshape(2, 64)
    # the output starts at an integer number of mesh periods: same phase as positions
    assert np.mean(dte) == pytest.approx(np.mean(static), rel=0.03)
    # pointwise: the ringing (~0.5 um right after a zone change) stays within 12 %
    np.testing.assert_allclose(np.median(dte, axis=0), static, rtol=0.12)
    # the spectrum's fundamental is the STE's first harmonic within the ringing
    ste_amp = harmonic_amplitudes(static[None, :], 1, 3)[0]
    assert out["dte_spectrum"][0, 0] == pytest.approx(ste_amp[0], rel=0.15)
    assert out["dte"].shape == (1, dynamic.coords["time"].size)


def test_harmonic_amplitudes_recover_a_synthetic_signal():
    t = np.arange(3 * 32) / 32.0  # three periods, 32 samples each
    signal = 2.0 + 0.5 * np.sin(2 * np.pi * t + 0.3) + 0.2 * np.cos(2 * np.pi * 3 * t)
    amp = harmonic_amplitudes(signal[None, :], 3, 4)[0]
    np.testing.assert_allclose(amp, [0.5, 0.0, 0.2, 0.0], atol=1e-12)


def test_dynamic_settings_validation(pair):
    with pytest.raises(InvalidParameterError, match="output_periods"):
        DynamicSettings(mesh_periods=4, output_periods=4)
    with pytest.raises(InvalidParameterError, match="speed_rpm"):
        DynamicSettings(speed_rpm=-1.0)
    with pytest.raises(InvalidParameterError, match="harmonics"):
        DynamicSettings(points_per_mesh=16, harmonics=8)
    grid = DynamicSettings(speed_rpm=600.0, mesh_periods=5, output_periods=2).time_grid(pair)
    assert grid[0] == pytest.approx(3 / (20 * 600 / 60))


def test_torque_history_scales_like_the_torque_and_pickles(pair):
    # A constant factor 2 on the input torque (load torque follows its mean) must give
    # the same DTE as doubling the sample torque: checks the torque-history plumbing.
    import pickle

    base = {"speed_rpm": 3000.0, "mesh_periods": 3, "output_periods": 1}
    doubled = MubocoPR(
        pair,
        torque=100.0,
        mode="dynamic",
        damping=3000.0,
        dynamic={**base, "torque_variation": lambda t: np.full_like(t, 2.0)},
    )
    clone = pickle.loads(pickle.dumps(doubled))  # the lambda is sampled, then dropped
    plain = MubocoPR(pair, torque=100.0, mode="dynamic", damping=3000.0, dynamic=base)
    a = clone({})["dte"]
    b = plain({"torque": [200.0]})["dte"]
    np.testing.assert_allclose(a, b, rtol=1e-12)


def upward_crossing_frequency(signal, dt):
    """Mean frequency [Hz] from linearly interpolated upward zero crossings."""
    x = signal - signal.mean()
    idx = np.nonzero((x[:-1] < 0) & (x[1:] >= 0))[0]
    times = (idx - x[idx] / (x[idx + 1] - x[idx])) * dt
    return 1.0 / np.mean(np.diff(times))


@pytest.mark.parametrize(("tooth_stiffness", "tolerance"), [(np.inf, 0.005), (None, 0.02)])
def test_torque_step_rings_at_the_mesh_natural_frequency(pair, tooth_stiffness, tolerance):
    # Undamped response to a torque step (x2 at t > 0) in the double-contact zone rings
    # at f = sqrt(k_mesh (r_b1^2/J1 + r_b2^2/J2)) / (2 pi), k_mesh of the closed form
    # (pairs in parallel, 1/k_con + d1^2/k_t + d2^2/k_t). Rigid teeth: exact up to the
    # frequency estimate (0.5 %); elastic teeth: tooth inertia (modes ~9x higher) and
    # the drift of k_mesh along the zone allow 2 %.
    import math

    from fuzzymbs.models.gears.identification import hinge_lever_arm
    from fuzzymbs.models.gears.potential_energy import contact_positions

    settings = {
        "speed_rpm": 1500.0,
        "mesh_periods": 2,
        "output_periods": 1,
        "points_per_mesh": 1024,
        "torque_variation": lambda t: np.where(t > 0, 2.0, 1.0),
    }
    model = MubocoPR(pair, torque=100.0, mode="dynamic", damping=0.0, dynamic=settings)
    samples = {} if tooth_stiffness is None else {"tooth_stiffness": [tooth_stiffness]}
    out = model(samples)
    assert not out["failed"].any()
    time = model.coords["time"]
    position = np.arange(time.size) / 1024  # output starts at a whole mesh period
    double = position < pair.contact_ratio - 1.0 - 0.02
    measured = upward_crossing_frequency(out["dte"][0][double], time[1] - time[0])
    k_con = model.defaults["contact_stiffness"]
    k_t = model.defaults["tooth_stiffness"] if tooth_stiffness is None else tooth_stiffness
    s = contact_positions(pair, np.array([0.3]))[0]
    s = s[np.isfinite(s)]
    d1 = hinge_lever_arm(pair.pinion, s)
    d2 = hinge_lever_arm(pair.wheel, pair.line_of_action_length - s)
    k_mesh = np.sum(1.0 / (1.0 / k_con + d1**2 / k_t + d2**2 / k_t))
    inv_mass = (
        pair.pinion.base_radius**2 / pair.pinion.body_inertia
        + pair.wheel.base_radius**2 / pair.wheel.body_inertia
    )
    expected = math.sqrt(k_mesh * inv_mass) / (2 * math.pi)
    assert measured == pytest.approx(expected, rel=tolerance)


def test_a_sample_does_not_depend_on_its_batch(pair):
    # the dynamic mode's RK4 step comes from the model's defaults (not from the batch),
    # and each sample is integrated on its own: a sample alone, in a batch and in
    # another order gives bit-identical DTE, so fuzzy bands carry no batch noise
    model = MubocoPR(
        pair,
        torque=100.0,
        mode="dynamic",
        dynamic={"speed_rpm": 3000.0, "mesh_periods": 2, "output_periods": 1},
    )
    stiffness = np.array([7.0e8, 8.8e8, 1.05e9, 9.5e8, 8.0e8])
    together = model({"contact_stiffness": stiffness})["dte"]
    order = np.array([3, 0, 4, 1, 2])
    shuffled = model({"contact_stiffness": stiffness[order]})["dte"]
    np.testing.assert_array_equal(shuffled, together[order])
    alone = model({"contact_stiffness": stiffness[2:3]})["dte"]
    np.testing.assert_array_equal(alone[0], together[2])
    assert np.ptp(together[:, 0]) > 0  # premise: the samples differ


@pytest.mark.parametrize(
    "deviation, relief, bound",
    [
        (0.0, 0.0, 1e-6),  # exact: measured 1.2e-7 (the differences' round-off)
        (5e-5, 0.0, 1e-6),  # a wider centre distance: measured 6.5e-8
        (0.0, 2e-5, 1e-6),  # tip relief (a 1 ns forward difference): measured 1.4e-7
    ],
)
def test_penetration_rate_is_the_derivative_of_the_penetration(pair, deviation, relief, bound):
    # The damping term's delta' against central differences (h = 1e-9 s) of the
    # penetration along random gear and hinge rates, over a mesh period of pinion angles,
    # conjugate and tip-corner contacts both. Without relief it is n . (v1 - v2) at the
    # contact point; with relief the relief's depth moves with the roll lengths too.
    nominal = MubocoPR(pair, torque=100.0, mode="dynamic").geometry
    g = np.empty_like(nominal)
    assert sample_geometry(nominal, deviation, relief, g) == 0
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    rng = np.random.default_rng(7)
    unrelieved = g.copy()  # the same contact, its rate as n . (v1 - v2)
    unrelieved[RELIEF] = 0.0
    kinds, worst, rigid_worst = set(), 0.0, 0.0
    for theta1 in np.linspace(0.0, g[PITCH1], 60, endpoint=False):
        for index in (0, 1):
            th = theta1 + g[THETA_REF1] + index * g[PITCH1]
            kinematic = -theta1 * z1 / z2 + g[PHI_REF2] - index * g[PITCH2]
            for lag in np.linspace(-5e-4, 5e-4, 401):  # the wheel turned into contact
                contact = pair_contact(th, 2e-4, kinematic + lag, -1e-4, g)
                if contact[0] != 0 and contact[1] > 1e-7:
                    break
            else:
                continue
            kind, delta = contact[0], contact[1]
            w1, w2, r1, r2 = rng.normal(size=4) * (100.0, 80.0, 5.0, 5.0)
            h = 1e-9
            moved = [
                pair_contact(
                    th + s * h * w1, 2e-4 + s * h * r1, kinematic + lag + s * h * w2,
                    -1e-4 + s * h * r2, g,
                )[1]
                for s in (1.0, -1.0)
            ]  # fmt: skip
            numeric = (moved[0] - moved[1]) / (2 * h)
            rate = penetration_rate(
                th, 2e-4, kinematic + lag, -1e-4, delta, contact[2:], g, w1, r1, w2, r2
            )
            kinds.add(int(kind))
            worst = max(worst, abs(rate - numeric) / abs(numeric))
            rigid = penetration_rate(
                th, 2e-4, kinematic + lag, -1e-4, delta, contact[2:], unrelieved, w1, r1, w2, r2
            )
            rigid_worst = max(rigid_worst, abs(rigid - numeric) / abs(numeric))
    assert {1, 2} <= kinds  # conjugate and pinion tip-corner contact
    assert worst <= bound
    if relief > 0.0:
        # why relieved flanks keep the difference: n . (v1 - v2) alone misses the relief's
        # depth moving with the roll lengths (measured 2.4e-2 of the rate here)
        assert rigid_worst > 100 * bound


def test_hunt_crossley_damping_takes_the_step_of_its_viscous_equivalent(pair):
    # c delta'^m2 delta^m3 with m3 = 1 and c = c_v / (margin delta_design) damps like
    # the viscous c_v at the margin times the design penetration, so RK4's step is that
    # of c_v (read as N s/m, this c would ask a 2e5 times smaller step: hundreds of GB of
    # torque history)
    viscous = MubocoPR(pair, torque=100.0, mode="dynamic", damping=3000.0)
    kc = viscous.defaults["contact_stiffness"]
    depth = 2.0 * 100.0 / pair.pinion.base_radius / kc  # stiffness_margin 2, m1 = 1
    hunt_crossley = MubocoPR(
        pair, torque=100.0, mode="dynamic", damping=3000.0 / depth, damping_exponents=(1.0, 1.0)
    )
    assert hunt_crossley.dynamic_plan.dt == pytest.approx(viscous.dynamic_plan.dt, rel=1e-12)
