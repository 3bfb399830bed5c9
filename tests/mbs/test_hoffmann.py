"""Friction-induced mode coupling (Hoffmann, Fischer, Allgaier, Gaul, MRC 29 (2002) 197).

The engine model (tests/mbs/systems.py) is assembled from a rotating rigid disc face
(the belt), a translating point mass, two inclined springs, a nodal preload and
penalty contact with regularised Coulomb friction. The independent reference is
the hand-written linear 2-dof ODE of the same model (systems.hoffmann_matrices)
and its closed-form flutter threshold mu_crit (systems.hoffmann_mu_crit):
eigenvalues of M^-1 K_lin merge when
(k_zz - k_yy - k3)^2 + 4 k_yz (k_zy - mu k3) = 0.
"""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.linearize import eigenanalysis, steady_state
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.system import Coordinate

from .systems import hoffmann_matrices, hoffmann_mu_crit, hoffmann_system


def reference_eigenvalues(mu: float, damping: float = 0.0) -> np.ndarray:
    mass, damp, stiff = hoffmann_matrices(mu, damping)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(mass, stiff), -damp]])
    lam = np.linalg.eigvals(a)
    return lam[np.lexsort((lam.real, np.round(np.abs(lam.imag), 9)))]


@pytest.fixture(scope="module")
def model():
    return hoffmann_system(Parameter("mu", 0.0), damping=0.0).compile()


def test_mu_crit_closed_form_is_the_merging_point():
    # sanity of the reference itself: the discriminant vanishes at mu_crit
    mu_c = hoffmann_mu_crit()
    lam_below = reference_eigenvalues(mu_c * (1 - 1e-9))
    lam_above = reference_eigenvalues(mu_c * (1 + 1e-6))
    assert np.abs(lam_below.real).max() < 1e-6
    assert lam_above.real.max() > 1e-3
    assert 0.2 < mu_c < 0.4


@pytest.mark.parametrize("damping", [0.0, 2.0])
def test_eigenvalues_match_hand_written_model(damping):
    mu_c = hoffmann_mu_crit()
    mus = np.array([0.0, 0.5 * mu_c, 1.5 * mu_c])
    system = hoffmann_system(Parameter("mu", 0.0), damping=damping).compile()
    result = eigenanalysis(system, {"mu": mus})
    assert result.steady_state.converged.all()
    for i, mu in enumerate(mus):
        ref = reference_eigenvalues(mu, damping)
        # tolerance 1e-7 relative to |lambda| (central differences of a linear-in-contact RHS).
        # Compared as sets: beyond mu_crit the two modes share one frequency (-+ a + i w),
        # so any order by frequency is decided by round-off (the last bits of the kernels)
        got = result.eigenvalues[i]
        rows, cols = linear_sum_assignment(np.abs(ref[:, None] - got[None, :]))
        np.testing.assert_allclose(got[cols], ref[rows], rtol=0, atol=1e-7 * abs(ref).max())


def test_linearised_threshold_matches_mu_crit(model):
    mu_c = hoffmann_mu_crit()
    rel = 1e-6  # the engine's threshold lies within mu_crit (1 +- 1e-6)
    result = eigenanalysis(model, {"mu": np.array([mu_c * (1 - rel), mu_c * (1 + rel)])})
    assert result.stable.tolist() == [True, False]
    # the unstable pair: one conjugate pair with positive real part
    assert result.unstable[1].sum() == 2


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_time_integration_grows_above_and_decays_below_threshold(kernel):
    mu_c = hoffmann_mu_crit()
    damping = 1.0  # N s/m per spring: zeta ~ 3e-3
    system = hoffmann_system(Parameter("mu", 0.0), damping=damping).compile()
    mus = np.array([0.9 * mu_c, 1.1 * mu_c])
    st = steady_state(system, {"mu": mus})
    x0 = np.concatenate([st.x, np.zeros_like(st.x)], axis=1)
    x0[:, 0] += 1e-7  # tangential kick, ~1e-4 of the static penetration: stays linear
    dt = 1e-4
    res = simulate(
        system,
        {"mu": mus},
        t_end=1.5,
        dt=dt,
        initial_state=x0,
        outputs={"z": Coordinate("block", 0)},
        kernel=kernel,
    )
    assert not res.failed.any()
    z = res.outputs["z"] - st.x[:, [0]]
    window = int(0.1 / dt)
    n_win = (z.shape[1] - 1) // window
    amp = np.abs(z[:, 1 : 1 + n_win * window]).reshape(2, n_win, window).max(axis=2)
    assert amp[0, -1] < 0.5 * amp[0, 1]  # stable side decays
    assert amp[1, -1] > 5.0 * amp[1, 1]  # unstable side grows
    # growth rate of the envelope vs the reference's max real part (within 3 %)
    rate = np.log(amp[1, -1] / amp[1, 5]) / ((n_win - 1 - 5) * window * dt)
    sigma = reference_eigenvalues(1.1 * mu_c, damping).real.max()
    assert sigma > 0
    assert rate == pytest.approx(sigma, rel=0.03)
