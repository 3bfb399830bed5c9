"""Inertia shape integrals of ModalBody against closed forms and identities."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.fe import ElasticBody, annulus_mesh, box_mesh, nodes_in_region
from fuzzymbs.fe.inertia import inertia_integrals


def test_box_mass_first_moment_and_inertia_tensor():
    # closed form, box [x0, x0 + a] x [y0, y0 + b] x [z0, z0 + c] of density rho:
    # m = rho a b c, first moment m * centre, J = J_centre + m (|c|^2 I - c c^T)
    a, b, c, origin = 0.3, 0.2, 0.1, np.array([0.05, -0.1, 0.2])
    mesh = box_mesh(a, b, c, 3, 2, 1, origin=origin)
    body = ElasticBody(mesh, 1e9, 0.3, 1200.0)
    reduced = body.reduce(4)
    mass = 1200.0 * a * b * c
    centre = origin + 0.5 * np.array([a, b, c])
    j_centre = mass / 12 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    inertia = j_centre + mass * (centre @ centre * np.eye(3) - np.outer(centre, centre))
    assert reduced.mass == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(reduced.first_moment, mass * centre, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(reduced.inertia_tensor, inertia, rtol=1e-12, atol=1e-14)


def test_annulus_mass_and_inertia_tensor():
    # closed form, annulus a < r < b, 0 < z < h: m = rho pi (b^2 - a^2) h,
    # J_zz = m (a^2 + b^2) / 2, J_xx = J_yy = m ((a^2 + b^2) / 4 + h^2 / 3) about the origin.
    # The 27-node mesh is isoparametric: the volume error falls as (element angle)^4,
    # measured -9.8e-6 with 24 and -6.1e-7 with 48 elements around; tolerance 2e-6.
    a, b, h, rho = 0.1, 0.2, 0.02, 7850.0
    mesh = annulus_mesh(a, b, h, 2, 48, 1)
    body = ElasticBody(mesh, 210e9, 0.3, rho, fixed="inner")
    reduced = body.reduce(3)
    mass = rho * np.pi * (b**2 - a**2) * h
    j_axial = mass * (a**2 + b**2) / 2
    j_diametral = mass * ((a**2 + b**2) / 4 + h**2 / 3)
    assert reduced.mass == pytest.approx(mass, rel=2e-6)
    np.testing.assert_allclose(reduced.first_moment, [0, 0, mass * h / 2], rtol=2e-6, atol=1e-10)
    np.testing.assert_allclose(
        reduced.inertia_tensor, np.diag([j_diametral, j_diametral, j_axial]), rtol=2e-6, atol=1e-9
    )


def test_modal_integrals_match_direct_sums(free_pad):
    # second method: integrals written out node by node, int rho u.v dV = U^T M V with the
    # 3 x 3 cross-product matrices built explicitly (independent of inertia.cross_axis)
    basis_body = free_pad.reduce(5, rigid_body_modes="exclude", cache=False)
    from fuzzymbs.fe.reduction import modal_truncation

    psi = modal_truncation(free_pad, 5).modes
    mass = free_pad.mass_matrix.toarray()
    nodes = free_pad.nodes
    n = free_pad.n_nodes

    def skew(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    e = [skew(axis) for axis in np.eye(3)]
    big_e = [np.kron(np.eye(n), e_i) for e_i in e]
    xbar = nodes.ravel()
    integrals = inertia_integrals(free_pad.mass_matrix, nodes, psi)
    for i in range(3):
        gyro = psi.T @ mass @ big_e[i] @ psi
        np.testing.assert_allclose(integrals["gyroscopic"][i], gyro, atol=1e-12)
        np.testing.assert_allclose(
            integrals["rotation_coupling"][i], (big_e[i] @ xbar) @ mass @ psi, atol=1e-14
        )
        for j in range(3):
            np.testing.assert_allclose(
                integrals["centrifugal"][i, j], psi.T @ mass @ big_e[i] @ big_e[j] @ psi, atol=1e-12
            )
            np.testing.assert_allclose(
                integrals["centrifugal_load"][i, j],
                psi.T @ mass @ big_e[i] @ big_e[j] @ xbar,
                atol=1e-14,
            )
    # the ModalBody carries the same integrals (same modes up to sign)
    np.testing.assert_allclose(
        np.abs(basis_body.rotation_coupling), np.abs(integrals["rotation_coupling"]), atol=1e-12
    )


def test_gyroscopic_matrices_are_skew_symmetric_and_free_modes_decouple(free_pad):
    contact = nodes_in_region(free_pad.mesh, "z_min")
    reduced = free_pad.reduce(6, method="static", interface=contact)
    for g in reduced.gyroscopic:
        np.testing.assert_allclose(g, -g.T, atol=1e-14 * max(1.0, np.abs(g).max()))
    # C_ij^T = C_ji (M commutes with E_i node-wise)
    np.testing.assert_allclose(
        reduced.centrifugal, np.swapaxes(np.swapaxes(reduced.centrifugal, 0, 1), 2, 3), atol=1e-10
    )
    # free-free elastic modes are mass-orthogonal to rigid translations: C_t = 0
    assert np.abs(reduced.translation_coupling).max() < 1e-10


def test_clamped_body_has_translation_coupling(cantilever):
    reduced = cantilever.reduce(3)
    assert np.abs(reduced.translation_coupling).max() > 1e-2
