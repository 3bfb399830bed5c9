"""The analytic Jacobian of the right-hand side against a closed form and finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.mbs.kernels.jacobian import jacobian
from fuzzymbs.mbs.kernels.rhs import make_work, set_lane
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.mbs.linearize import jacobian as finite_difference_jacobian
from fuzzymbs.mbs.linearize import steady_state
from fuzzymbs.models.brake import DiscBrake

from .systems import HOFFMANN, hoffmann_matrices, hoffmann_system


def analytic(compiled, params, states, t):
    """(B, 2n, 2n) Jacobians ``[[0, I], [A, B]]`` from the lane kernel, one sample per lane."""
    n = compiled.n_dofs
    out = []
    for first in range(0, states.shape[0], LANES):
        x = np.empty(2 * n * LANES)
        p = np.empty(params.shape[1] * LANES)
        for lane in range(LANES):
            row = min(first + lane, states.shape[0] - 1)
            set_lane(x, lane, states[row])
            set_lane(p, lane, params[row])
        dx = np.empty_like(x)
        jq = np.empty(n * n * LANES)
        jv = np.empty(n * n * LANES)
        # the time per lane, as the Rosenbrock kernel calls it (the signature it compiles)
        jacobian(np.full(LANES, t), x, p, compiled.data, make_work(compiled.data), dx, jq, jv)
        for lane in range(min(LANES, states.shape[0] - first)):
            full = np.zeros((2 * n, 2 * n))
            full[:n, n:] = np.eye(n)
            full[n:, :n] = jq[lane::LANES].reshape(n, n)
            full[n:, n:] = jv[lane::LANES].reshape(n, n)
            out.append(full)
    return np.array(out)


@pytest.mark.parametrize("mu", [0.0, 0.3, 0.6])
def test_hoffmann_jacobian_is_the_closed_form(mu):
    # reference: Hoffmann et al. (2002) minimal model, hand-written M, C, K about steady
    # sliding (tests/mbs/systems.hoffmann_matrices, no damping): A = -M^-1 K (measured to
    # 3e-11 of max |A|), B = 0 up to the friction regularisation, whose slope along the
    # slip is of order mu N eps^2 / |v|^3 (eps = 1e-7 m/s, belt 0.1 m/s; measured 6e-8)
    compiled = hoffmann_system(mu=mu).compile()
    static = steady_state(compiled, t_lin=0.0)
    n = compiled.n_dofs
    state = np.concatenate([static.x[0], np.zeros(n)])[None, :]
    params = compiled.parameters.values({})
    got = analytic(compiled, params, state, 0.0)[0]
    m, c, k = hoffmann_matrices(mu)
    assert not c.any()
    a = -np.linalg.solve(m, k)
    stiff = np.abs(a).max()
    np.testing.assert_allclose(got[n:, :n], a, rtol=0, atol=1e-9 * stiff)
    assert HOFFMANN["eps"] < 1e-6  # premise of the bound below
    assert np.abs(got[n:, n:]).max() < 1e-6


@pytest.fixture(scope="module")
def brake():
    return DiscBrake(t_end=1e-4).compiled


@pytest.mark.parametrize("speeds", [(1.0, 1.0), (1.0, 400.0)])
def test_brake_jacobian_against_finite_differences(brake, speeds):
    # reference: central differences of the same right-hand side (linearize.jacobian),
    # at two sliding states with every slave in contact (pads pressed 55 um into the
    # disc, random small deformations and velocities), two parameter rows; with the discs
    # at 1 and 400 rad/s the lanes are 0.8 rad apart at t = 2 ms, so their master cells
    # differ and the per-lane assembly runs, else the vector one. da/dv (the
    # friction and penalty damping): measured 1.2e-10 relative (Frobenius), bound 1e-8.
    # da/dq: measured 2.8e-4, bound 1e-3: the analytic form holds the master weights and
    # normal fixed, so the change of the master point with the slave's tangential
    # position (deformed master faces) is left out (docs/theory.md)
    rng = np.random.default_rng(5)
    params = brake.parameters.values(
        {"nodal_force": np.array([16e3, 17e3]), "disc_speed": np.array(speeds)}
    )
    n = brake.n_dofs
    states = np.zeros((2, 2 * n))
    for row in range(2):
        states[row, :n] = rng.normal(scale=1e-7, size=n)
        states[row, n:] = rng.normal(scale=1e-4, size=n)
        states[row, brake.body_dofs["lower_pad"].start] = 55e-6
        states[row, brake.body_dofs["upper_pad"].start] = -55e-6
    t = 2e-3
    got = analytic(brake, params, states, t)
    ref = finite_difference_jacobian(brake, params, states, t, columns="all")
    for row in range(2):
        for name, block, bound in (
            ("da/dq", (slice(n, None), slice(None, n)), 1e-3),
            ("da/dv", (slice(n, None), slice(n, None)), 1e-8),
        ):
            g, r = got[row][block], ref[row][block]
            error = np.linalg.norm(g - r) / np.linalg.norm(r)
            assert error < bound, (row, name, error)


def test_brake_jacobian_of_a_lane_does_not_depend_on_its_neighbours(brake):
    # a sample's Jacobian in a block of four copies of itself (the vector assembly,
    # every point gathered for all lanes) is bit for bit its Jacobian beside a sample
    # 0.8 rad further round the disc (other master cells: the per-lane assembly, its
    # points gathered lane by lane) and beside a sample with the pads lifted off (its
    # lanes out of contact: zero rows in the shared sums)
    rng = np.random.default_rng(8)
    n = brake.n_dofs
    params = brake.parameters.values(
        {"nodal_force": np.array([16e3, 17e3, 16e3]), "disc_speed": np.array([1.0, 400.0, 1.0])}
    )
    states = np.zeros((3, 2 * n))
    states[:, :n] = rng.normal(scale=1e-7, size=n)
    states[:, n:] = rng.normal(scale=1e-4, size=n)
    for row, press in ((0, 55e-6), (1, 55e-6), (2, -1e-3)):
        states[row, brake.body_dofs["lower_pad"].start] = press
        states[row, brake.body_dofs["upper_pad"].start] = -press
    alone = analytic(brake, params[[0]], states[[0]], 2e-3)[0]
    assert np.abs(alone[brake.n_dofs :, : brake.n_dofs]).max() > 1e6  # in contact
    for neighbour in (1, 2):
        mixed = analytic(brake, params[[0, neighbour]], states[[0, neighbour]], 2e-3)[0]
        assert np.array_equal(mixed, alone), neighbour
