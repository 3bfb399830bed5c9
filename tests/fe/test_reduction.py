"""Modal truncation, static correction and Craig-Bampton bases."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import ElasticBody, craig_bampton, modal_truncation, nodes_in_region
from fuzzymbs.fe.reduction import static_correction


def _check_orthonormal(body: ElasticBody, basis) -> None:
    # Psi^T M Psi = I and Psi^T K Psi = diag(omega^2) (definition of the reduced basis)
    psi = basis.modes
    gram = psi.T @ (body.mass_matrix @ psi)
    np.testing.assert_allclose(gram, np.eye(psi.shape[1]), atol=1e-8)
    stiffness = psi.T @ (body.stiffness @ psi)
    scale = basis.frequencies.max() ** 2
    np.testing.assert_allclose(stiffness, np.diag(basis.frequencies**2), atol=1e-8 * scale)
    assert np.all(np.diff(basis.frequencies) >= 0)


def _modal_static_response(basis, load: np.ndarray) -> np.ndarray:
    """u = sum_j psi_j psi_j^T f / omega_j^2: the static solution within the basis."""
    return basis.modes @ ((basis.modes.T @ load) / basis.frequencies**2)


@pytest.mark.parametrize("method", ["modal", "static", "craig_bampton"])
def test_bases_are_mass_normalised_with_diagonal_stiffness(cantilever, method):
    tip = nodes_in_region(cantilever.mesh, "x_max")
    if method == "modal":
        basis = modal_truncation(cantilever, 10)
    elif method == "static":
        basis = static_correction(cantilever, 10, tip)
    else:
        basis = craig_bampton(cantilever, 10, tip)
    _check_orthonormal(cantilever, basis)
    assert np.all(basis.modes[cantilever.fixed_dofs] == 0.0)


def test_static_correction_and_craig_bampton_reproduce_static_deflection(cantilever):
    # reference: the full-DOF static solution K u = f (sparse direct solve) for a
    # transverse load at one interface node. A basis containing the interface's static
    # (attachment or constraint) modes holds u exactly (Galerkin projection of a solution
    # that lies in the span); measured 1.5e-10 and 2.1e-9 (round-off amplified by
    # cond(K) ~ 1e9), against 1.4e-3 for plain modal truncation.
    tip = nodes_in_region(cantilever.mesh, "x_max")
    load = np.zeros(cantilever.n_dofs)
    load[3 * tip[0] + 1] = 100.0
    load[3 * tip[-1] + 2] = -50.0
    exact = cantilever.static_deflection(load)
    scale = np.abs(exact).max()
    truncated = _modal_static_response(modal_truncation(cantilever, 10), load)
    static = _modal_static_response(static_correction(cantilever, 10, tip), load)
    bampton = _modal_static_response(craig_bampton(cantilever, 10, tip), load)
    assert np.abs(truncated - exact).max() > 1e-4 * scale
    assert np.abs(static - exact).max() < 1e-7 * scale
    assert np.abs(bampton - exact).max() < 1e-7 * scale


def test_free_free_static_correction_is_exact_under_inertia_relief(free_pad):
    # reference: inertia-relief static solution of the free body, solved with the
    # rigid motion constrained, [[K, M R], [R^T M, 0]] [u; l] = [f - M R R^T f; 0]
    contact = nodes_in_region(free_pad.mesh, "z_min")
    basis = static_correction(free_pad, 6, contact)
    _check_orthonormal(free_pad, basis)
    rigid = free_pad.rigid_body_modes()
    load = np.zeros(free_pad.n_dofs)
    load[3 * contact[4] + 2] = 1000.0
    relieved = load - free_pad.mass_matrix @ rigid @ (rigid.T @ load)
    mass_rigid = sp.csr_matrix(free_pad.mass_matrix @ rigid)
    system = sp.bmat([[free_pad.stiffness, mass_rigid], [mass_rigid.T, None]]).tocsc()
    exact = spsolve(system, np.concatenate([relieved, np.zeros(6)]))[: free_pad.n_dofs]
    reduced = _modal_static_response(basis, relieved)
    assert np.abs(reduced - exact).max() < 1e-8 * np.abs(exact).max()


def test_free_free_finds_and_excludes_six_rigid_modes(free_pad):
    basis = modal_truncation(free_pad, 8)
    assert basis.rigid_frequencies.size == 6
    assert np.all(basis.rigid_frequencies < 1e-6 * basis.frequencies[0])
    _check_orthonormal(free_pad, basis)
    # elastic modes carry no rigid motion: int rho Psi dV = 0 and R^T M Psi = 0
    rigid = free_pad.rigid_body_modes()
    assert np.abs(rigid.T @ (free_pad.mass_matrix @ basis.modes)).max() < 1e-10
    included = modal_truncation(free_pad, 8, rigid_body_modes="include")
    assert included.frequencies.size == 14
    np.testing.assert_allclose(included.frequencies[6:], basis.frequencies, rtol=1e-9)


def test_free_free_first_elastic_frequency_is_stable_across_calls(free_pad):
    # THEORY sec. 3: eigsh with sigma = 0 on a singular K gave run-to-run varying values;
    # the negative shift and the fixed start vector make repeated solves agree
    fresh = ElasticBody(free_pad.mesh, 10e9, 0.25, 2500.0)
    first = [modal_truncation(body, 4).frequencies for body in (free_pad, fresh, free_pad)]
    np.testing.assert_allclose(first[1], first[0], rtol=1e-10)
    np.testing.assert_allclose(first[2], first[0], rtol=1e-10)


def test_craig_bampton_frequencies_bound_the_full_ones_from_above(free_pad):
    # Rayleigh-Ritz: any reduced basis over-estimates each eigenfrequency (Courant-Fischer)
    full = modal_truncation(free_pad, 6).frequencies
    contact = nodes_in_region(free_pad.mesh, "z_min")
    reduced = craig_bampton(free_pad, 6, contact)
    assert reduced.rigid_frequencies.size == 6  # the constraint modes span rigid motion
    assert np.all(reduced.frequencies[:6] >= full * (1 - 1e-9))
    _check_orthonormal(free_pad, reduced)


def test_max_frequency_drops_modes_above_the_limit(cantilever):
    tip = nodes_in_region(cantilever.mesh, "x_max")
    full = static_correction(cantilever, 6, tip)
    limit = 2000.0  # Hz
    limited = static_correction(cantilever, 6, tip, max_frequency=limit)
    assert limited.frequencies.max() <= 2 * np.pi * limit
    assert limited.dropped_frequencies.size == full.frequencies.size - limited.frequencies.size
    assert limited.dropped_frequencies.size > 0
    np.testing.assert_allclose(limited.frequencies, full.frequencies[: limited.frequencies.size])


def test_craig_bampton_on_a_free_body_with_too_few_interface_dofs_is_refused(free_pad):
    one_node = nodes_in_region(free_pad.mesh, "z_min")[:1]
    with pytest.raises(InvalidParameterError, match="singular"):
        craig_bampton(free_pad, 4, one_node)


def test_interface_on_clamped_nodes_is_refused(cantilever):
    clamped = cantilever.fixed_nodes[:2]
    with pytest.raises(InvalidParameterError, match="clamped"):
        static_correction(cantilever, 4, clamped)
    with pytest.raises(InvalidParameterError, match="interface_components"):
        static_correction(cantilever, 4, nodes_in_region(cantilever.mesh, "x_max"), (3,))


def test_curved_disc_patch_static_load_is_exact_with_craig_bampton():
    # clamped annulus (curved 27-node mesh), interface = an annular-sector patch on the top
    # face with normal (z) components only; reference: full sparse static solve
    from fuzzymbs.fe import annulus_mesh

    mesh = annulus_mesh(0.1, 0.2, 0.01, 2, 12, 1)
    disc = ElasticBody(mesh, 210e9, 0.3, 7850.0, fixed="inner")

    def sector(x):
        return (np.hypot(x[0], x[1]) >= 0.15 * (1 - 1e-9)) & (np.abs(x[1]) <= 0.06)

    patch = nodes_in_region(mesh, "top", sector)
    basis = craig_bampton(disc, 8, patch, interface_components=(2,))
    _check_orthonormal(disc, basis)
    load = np.zeros(disc.n_dofs)
    load[3 * patch + 2] = -np.linspace(1.0, 2.0, patch.size) * 1e3  # uneven pressure
    exact = disc.static_deflection(load)
    reduced = _modal_static_response(basis, load)
    assert np.abs(reduced - exact).max() < 1e-7 * np.abs(exact).max()
    truncated = _modal_static_response(modal_truncation(disc, 8 + patch.size), load)
    assert np.abs(truncated - exact).max() > 1e-3 * np.abs(exact).max()


def test_more_modes_than_free_dofs_is_refused(free_pad):
    # 75 nodes x 3 = 225 DOFs: 225 elastic + 6 rigid modes cannot exist
    with pytest.raises(InvalidParameterError, match=r"231 eigenmodes requested.*only 225 free"):
        modal_truncation(free_pad, 225)


def test_unknown_reduction_option_is_named(free_pad):
    with pytest.raises(InvalidParameterError, match=r"unknown reduction option\(s\) \['modes'\]"):
        free_pad.reduce(4, modes=3)


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"n_modes": "4"}, "n_modes must be an integer >= 0"),
        ({"n_modes": 2.5}, "n_modes must be an integer >= 0"),
        ({"n_modes": 4, "max_frequency": "1 kHz"}, "max_frequency must be > 0"),
        ({"n_modes": 4, "max_frequency": float("nan")}, "max_frequency must be > 0"),
    ],
)
def test_bad_reduction_options_are_named(free_pad, options, fragment):
    with pytest.raises(InvalidParameterError, match=fragment):
        free_pad.reduce(**options, cache=False)
