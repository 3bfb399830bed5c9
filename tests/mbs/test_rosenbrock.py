"""ROS34PW2 (the linearly implicit block integrator) against closed forms and fine RK4."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from fuzzymbs.mbs.bodies import FixedBody
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels.layout import OK
from fuzzymbs.mbs.kernels.linalg import lu_factor_lanes, lu_solve_lanes
from fuzzymbs.mbs.kernels.rosenbrock import ros34pw2
from fuzzymbs.mbs.kernels.rosenbrock_methods import (
    COEFFICIENTS,
    GAMMA,
    METHODS,
    TABLEAU_A,
    TABLEAU_B,
    TABLEAU_BHAT,
    TABLEAU_GAMMA,
    tableau,
)
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.mbs.lumped import lumped_modal_body
from fuzzymbs.mbs.system import Coordinate, System
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance


def run(compiled, outputs, t_end, interval, rtol, x0=None, samples=None, bound=1.0):
    """Outputs (B, n_out, T) and accepted / rejected steps (B, 2) of ros34pw2."""
    params = compiled.parameters.values(samples or {})
    batch = params.shape[0]
    x0 = compiled.zero_state(batch) if x0 is None else np.tile(x0, (batch, 1))
    out_w = np.array([compiled.output_functional(spec) for spec in outputs.values()])
    n_rec = round(t_end / interval) + 1
    out = np.empty((batch, out_w.shape[0], n_rec))
    status = np.zeros(batch, dtype=np.int64)
    fail_t = np.zeros(batch)
    counts = np.zeros((batch, 2), dtype=np.int64)
    ros34pw2(
        compiled.data,
        params,
        np.ascontiguousarray(x0),
        (0.0, interval, n_rec, 1e-7),
        (out_w, np.full(out_w.shape[0], bound), out, status, fail_t),
        (np.full(batch, rtol), np.full(batch, 1e-4 * rtol), 1e-14),
        4,
        counts,
        np.empty(0),
        np.empty(0),
        np.empty((1, 1)),
    )
    assert (status == OK).all()
    return out, counts


def test_tableau_meets_the_order_conditions():
    # Rosenbrock order conditions (Hairer & Wanner, Solving ODEs II, Sec. IV.7, Table 7.1)
    # with beta = A + Gamma below the diagonal, beta'_i = sum_j beta_ij: order 1
    # sum b = 1; order 2 sum b beta' = 1/2 - gamma; order 3 sum b alpha^2 = 1/3 and
    # sum b beta beta' = 1/6 - gamma + gamma^2 (b: order 3, bhat: order 2); stiffly
    # accurate: b is the last row of A + Gamma (Rang & Angermann 2005)
    a, g, b, bhat = TABLEAU_A, TABLEAU_GAMMA, TABLEAU_B, TABLEAU_BHAT
    beta = np.tril(a + g, -1)
    beta1 = beta.sum(axis=1)
    alpha = a.sum(axis=1)
    for weights in (b, bhat):
        np.testing.assert_allclose(weights.sum(), 1.0, atol=1e-14)
        np.testing.assert_allclose(weights @ beta1, 0.5 - GAMMA, atol=1e-14)
    np.testing.assert_allclose(b @ alpha**2, 1.0 / 3.0, atol=1e-14)
    np.testing.assert_allclose(b @ (beta @ beta1), 1.0 / 6.0 - GAMMA + GAMMA**2, atol=1e-14)
    np.testing.assert_allclose(b, (a + g)[3], atol=1e-15)
    assert np.allclose(np.diag(g), GAMMA) and np.allclose(COEFFICIENTS[5], g.sum(axis=1))


def test_rodas4_tableau_meets_the_order_conditions():
    # the W-form (A, Gamma, b, bhat) reconstructed from the transformed coefficients
    # (Hairer & Wanner, Sec. IV.7: Gamma^-1 = diag(1 / gamma) - C, A = at Gamma, b = m
    # Gamma) meets the conditions of order 4 with b and of order 3 with bhat (Table 7.1:
    # order 4 adds sum b alpha^3 = 1/4, sum b alpha a beta' = 1/8 - gamma/3, sum b beta
    # alpha^2 = 1/12 - gamma/3, sum b beta beta beta' = 1/24 - gamma/2 + 3/2 gamma^2 -
    # gamma^3); both are stiffly accurate (b and bhat the last two rows of A + Gamma);
    # the stage times and gamma_i are the row sums of A and Gamma. Measured residuals
    # below 4e-15.
    a, g, b, bhat, alpha, gsum = tableau(METHODS["rodas4"])
    gamma = METHODS["rodas4"][6][0]
    beta = np.tril(a + g, -1)
    beta1 = beta.sum(axis=1)
    np.testing.assert_allclose(a.sum(axis=1), alpha, atol=1e-14)
    np.testing.assert_allclose(g.sum(axis=1), gsum, atol=1e-14)
    np.testing.assert_allclose(np.diag(g), gamma, atol=1e-15)

    def conditions(w: np.ndarray, order: int) -> list[float]:
        residuals = [
            w.sum() - 1.0,
            w @ beta1 - (0.5 - gamma),
            w @ alpha**2 - 1.0 / 3.0,
            w @ (beta @ beta1) - (1.0 / 6.0 - gamma + gamma**2),
            w @ alpha**3 - 0.25,
            (w * alpha) @ (a @ beta1) - (1.0 / 8.0 - gamma / 3.0),
            w @ (beta @ alpha**2) - (1.0 / 12.0 - gamma / 3.0),
            w @ (beta @ (beta @ beta1)) - (1.0 / 24.0 - gamma / 2 + 1.5 * gamma**2 - gamma**3),
        ]
        return residuals[: {3: 4, 4: 8}[order]]

    np.testing.assert_allclose(conditions(b, 4), 0.0, atol=1e-13)
    np.testing.assert_allclose(conditions(bhat, 3), 0.0, atol=1e-13)
    assert abs(conditions(bhat, 4)[4]) > 1e-3  # the embedded solution is of order 3 only
    np.testing.assert_allclose(b, (a + g)[5], atol=1e-14)
    np.testing.assert_allclose(bhat, (a + g)[4], atol=1e-14)


@pytest.mark.parametrize(("integrator", "order"), [("ros34pw2", 3), ("rodas4", 4)])
def test_order_on_a_stiff_linear_mode(integrator, order):
    # the oscillator at zeta = 10 (eigenvalues -5.01 and -1995 1/s, q0 = 1e-3 m, v0 = 0)
    # over 1 s on uniform steps of 1/20 .. 1/160 s (a shared step sequence; the loose
    # rtol 0.5 rejects none of them), the stiff mode stepped over (h |lambda| = 100 ..
    # 12): the error at the end against the closed form falls with the method's order,
    # 3 for ROS34PW2, 4 for RODAS4 (exact Jacobian); observed order between successive
    # halvings within 0.35 of it (measured 2.91-2.97 and 4.01-4.02)
    zeta, w = 10.0, 100.0
    compiled = oscillator(zeta).compile()
    root = w * np.sqrt(zeta**2 - 1)
    l1, l2 = -zeta * w + root, -zeta * w - root
    exact = 1e-3 * (l2 * np.exp(l1) - l1 * np.exp(l2)) / (l2 - l1)
    errors = []
    for steps in (20, 40, 80, 160):
        result = simulate(
            compiled,
            t_end=1.0,
            dt=0.05,
            record_interval=1.0,
            outputs={"q": Coordinate("osc")},
            initial_state=np.array([1e-3, 0.0]),
            integrator=integrator,
            tolerance=Tolerance(0.5),
            step_sequence=np.arange(1, steps + 1) / steps,
        )
        assert result.step_counts[0].tolist() == [steps, 0]
        errors.append(abs(result.outputs["q"][0, -1] - exact))
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.35), observed


def test_lane_lu_solves_a_system_per_lane_against_numpy():
    # a different 12 x 12 system in each lane, one needing row swaps (zero leading
    # entry) and one ill-conditioned: each lane pivots on its own; numpy.linalg.solve is
    # the reference (rtol 1e-10, cond < 1e4)
    rng = np.random.default_rng(3)
    n = 12
    mats = rng.normal(size=(LANES, n, n))
    mats[1, 0, 0] = 0.0
    mats[2] += np.diag(np.logspace(0, 3, n))
    rhs = rng.normal(size=(LANES, n))
    lanes = np.ascontiguousarray(np.moveaxis(mats, 0, -1)).ravel()
    b = np.ascontiguousarray(rhs.T).ravel()
    piv = np.empty(n * LANES, dtype=np.int64)
    lu_factor_lanes(lanes, n, piv)
    lu_solve_lanes(lanes, n, piv, b)
    for lane in range(LANES):
        expected = np.linalg.solve(mats[lane], rhs[lane])
        np.testing.assert_allclose(b[lane::LANES], expected, rtol=1e-10, atol=1e-12)
    assert (piv.reshape(n, LANES)[0] != 0).any()  # some lane swapped rows
    # the pivots are LAPACK's (getrf: the first largest magnitude of the column), also
    # where the vector test lets a lane keep its diagonal without the scalar search
    for lane in range(LANES):
        expected_rows = scipy.linalg.lu_factor(mats[lane])[1]
        np.testing.assert_array_equal(piv.reshape(n, LANES)[:, lane], expected_rows)


def oscillator(zeta: float) -> System:
    """One mode, omega = 100 rad/s, damping ratio zeta (tests/mbs/test_elements.py)."""
    body = lumped_modal_body("osc", [(0, 0, 0)], [1.0], np.diag([1e4, 0, 0]), free_dofs=[0])
    system = System()
    system.add_body(FixedBody(body, damping_ratio=zeta))
    return system


def test_free_decay_converges_with_the_tolerance():
    # reference: the closed form q0 e^(-zeta w t) (cos w_d t + zeta / sqrt(1 - zeta^2)
    # sin w_d t); the error falls with rtol and stays near it: measured 1.1e-4 / 1.2e-6 /
    # 1.2e-8 of q0 at rtol 1e-4 / 1e-6 / 1e-8 with 267 / 1229 / 5711 steps
    compiled = oscillator(0.05).compile()
    w, z = 100.0, 0.05
    wd = w * np.sqrt(1 - z**2)
    t = np.arange(201) * 1e-3
    ref = 1e-3 * np.exp(-z * w * t) * (np.cos(wd * t) + z / np.sqrt(1 - z**2) * np.sin(wd * t))
    errors = []
    for rtol in (1e-4, 1e-6, 1e-8):
        out, _ = run(compiled, {"q": Coordinate("osc")}, 0.2, 1e-3, rtol, np.array([1e-3, 0]))
        errors.append(np.abs(out[0, 0] - ref).max() / 1e-3)
        assert errors[-1] < 20 * rtol
    assert errors[0] > errors[1] > errors[2]


def test_dense_output_between_steps_matches_the_closed_form():
    # the steps do not depend on the recording times (only the last step is cut), and
    # records between the step ends come from the cubic Hermite interpolant: at rtol 1e-6
    # the steps are about 0.16 ms; recorded every 10 us (16 records per step) the largest
    # error against the closed form is that at the step ends (measured 1.1576e-6 against
    # 1.1576e-6 of q0 recorded every 1 ms, the same 1229 steps)
    compiled = oscillator(0.05).compile()
    w, z = 100.0, 0.05
    wd = w * np.sqrt(1 - z**2)
    errors, steps = [], []
    for interval in (1e-3, 1e-5):
        t = np.arange(round(0.2 / interval) + 1) * interval
        ref = 1e-3 * np.exp(-z * w * t) * (np.cos(wd * t) + z / np.sqrt(1 - z**2) * np.sin(wd * t))
        out, counts = run(
            compiled, {"q": Coordinate("osc")}, 0.2, interval, 1e-6, np.array([1e-3, 0])
        )
        errors.append(np.abs(out[0, 0] - ref).max() / 1e-3)
        steps.append(counts[0].tolist())
    assert steps[0] == steps[1]
    assert errors[1] < 1.1 * errors[0] < 20 * 1e-6


def test_stiff_overdamped_mode_takes_large_steps():
    # zeta = 1e5: eigenvalues -2e7 and -5e-3 1/s; explicit RK4 would need dt < 1.4e-7 s,
    # i.e. 1.4 million steps for 0.2 s. The L-stable method follows the slow mode with a
    # few hundred steps (measured 232, error 1.7e-13 m).
    # Reference: q0 (l2 e^(l1 t) - l1 e^(l2 t)) / (l2 - l1), v0 = 0.
    zeta, w = 1e5, 100.0
    compiled = oscillator(zeta).compile()
    root = w * np.sqrt(zeta**2 - 1)
    l1, l2 = -zeta * w + root, -zeta * w - root
    t = np.arange(201) * 1e-3
    ref = 1e-3 * (l2 * np.exp(l1 * t) - l1 * np.exp(l2 * t)) / (l2 - l1)
    out, counts = run(compiled, {"q": Coordinate("osc")}, 0.2, 1e-3, 1e-6, np.array([1e-3, 0]))
    assert counts[0, 0] < 1000
    np.testing.assert_allclose(out[0, 0], ref, rtol=0, atol=1e-6 * 1e-3)


@pytest.fixture(scope="module")
def brake():
    return DiscBrake(t_end=1e-4).compiled


def test_brake_against_fine_rk4(brake):
    # reference: RK4 at dt = 1 us / 64 (15.6 ns, the converged reference of
    # docs/brake.md) over the first 0.1 ms (the pads close on the disc: contact and
    # friction events); rtol 1e-4: measured 6.4e-5 of the peak (1700 steps and 112
    # rejected over the 0.1 ms), bound 1e-3
    outputs = {"y_lpad": Coordinate("lower_pad", 0), "y_upad": Coordinate("upper_pad", 0)}
    samples = {"nodal_force": np.array([16e3, 16.16e3])}
    ref = simulate(brake, samples, t_end=1e-4, dt=1e-6 / 64, record_interval=1e-5, outputs=outputs)
    out, counts = run(brake, outputs, 1e-4, 1e-5, 1e-4, samples=samples, bound=1e-3)
    for i, name in enumerate(outputs):
        r = ref.outputs[name]
        error = np.abs(out[:, i] - r).max() / np.abs(r).max()
        assert error < 1e-3, (name, error)
    assert (counts[:, 0] > 0).all()


def test_simulate_with_ros34pw2_matches_fine_rk4(brake):
    # the public path: simulate(integrator="ros34pw2") and the DiscBrake option; reference
    # RK4 at 15.6 ns as above (measured 5e-5 .. 7e-5 of the peak at rtol 1e-4), bound 1e-3
    outputs = {"y_lpad": Coordinate("lower_pad", 0)}
    samples = {"nodal_force": np.array([16e3, 15.84e3, 16.16e3])}
    ref = simulate(brake, samples, t_end=1e-4, dt=1e-6 / 64, record_interval=1e-5, outputs=outputs)
    got = simulate(
        brake,
        samples,
        t_end=1e-4,
        dt=1e-7,
        record_interval=1e-5,
        outputs=outputs,
        integrator="ros34pw2",
        tolerance=Tolerance(1e-4),
    )
    assert not got.failed.any()
    assert got.step_counts.shape == (3, 2) and (got.step_counts[:, 0] > 0).all()
    assert ref.step_counts is None
    np.testing.assert_array_equal(got.time, ref.time)
    scale = np.abs(ref.outputs["y_lpad"]).max()
    assert np.abs(got.outputs["y_lpad"] - ref.outputs["y_lpad"]).max() < 1e-3 * scale


def test_rodas4_on_the_brake_against_fine_rk4(brake):
    # RODAS4 through simulate, the first 0.1 ms against RK4 at 15.6 ns as above (measured
    # 6.5e-5 and 7.0e-5 of the peak at rtol 1e-3, 546 and 540 steps), bound 5e-4;
    # its work counts: a fresh Jacobian every accepted step (which gives f at the step's
    # start), five more right-hand sides per try and the f_t difference per Jacobian
    outputs = {"y_lpad": Coordinate("lower_pad", 0), "y_upad": Coordinate("upper_pad", 0)}
    samples = {"nodal_force": np.array([16e3, 16.16e3])}
    ref = simulate(brake, samples, t_end=1e-4, dt=1e-6 / 64, record_interval=1e-5, outputs=outputs)
    got = simulate(
        brake,
        samples,
        t_end=1e-4,
        dt=1e-7,
        record_interval=1e-5,
        outputs=outputs,
        integrator="rodas4",
        tolerance=Tolerance(1e-3),
    )
    assert not got.failed.any()
    for name in outputs:
        r = ref.outputs[name]
        assert np.abs(got.outputs[name] - r).max() < 5e-4 * np.abs(r).max(), name
    accepted, rejected = got.step_counts.T
    rhs, jacobians, lus = got.work_counts.T
    np.testing.assert_array_equal(jacobians, accepted)  # the first one's and one per step
    assert np.all(rhs >= 5 * (accepted + rejected) + accepted) and np.all(lus >= accepted)


def test_integrator_options_are_checked_and_reach_the_brake():
    from fuzzymbs.errors import InvalidParameterError
    from fuzzymbs.models.brake import brake_model

    model = brake_model(integrator="ros34pw2", rtol=1e-3, t_end=1e-5, dt=1e-7)
    assert model.simulation.settings["integrator"] == "ros34pw2"
    assert model.simulation.tolerance.rtol == 1e-3
    with pytest.raises(InvalidParameterError, match="integrator must be one of"):
        brake_model(integrator="euler", t_end=1e-5)
    with pytest.raises(InvalidParameterError, match="rtol must be in"):
        brake_model(integrator="ros34pw2", rtol=0.0, t_end=1e-5)
    with pytest.raises(InvalidParameterError, match="atol must be"):
        brake_model(integrator="ros34pw2", atol=-1.0, t_end=1e-5)
