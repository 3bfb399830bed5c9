"""Stress stiffening of FE bodies: the geometric stiffness of a prestress and the
centrifugal stiffening of a clamped body, against closed forms and published coefficients.

* K_G of a compressed cantilever column: K + P K_G(unit load) is singular at Euler's
  buckling loads P = (2k - 1)^2 pi^2 E I / (4 L^2), in either bending direction.
* A clamped beam turning about an axis through its root (zero hub radius): the first
  flapwise (out-of-plane) frequency rises as omega^2 = omega_0^2 + K1 Omega^2 with
  Southwell's coefficient K1 = 1.193, the first lead-lag (in-plane) one by (K1 - 1) Omega^2
  (Wright, Smith, Thresher & Wang, J. Appl. Mech. 49 (1982) 197; also Hodges & Rutkowski,
  AIAA J. 19 (1981) 1459). Without the stress stiffening, linear floating-frame theory gives
  0 and -1.
"""

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import ElasticBody, box_mesh
from fuzzymbs.fe.stress_stiffening import geometric_stiffness, stress_stiffening

from .conftest import STEEL


def face_load(body, x_face, total):
    """A uniform traction on the end face x = x_face of a 27-node hex mesh with one element
    across, as consistent nodal loads along x summing to ``total`` (Simpson weights)."""
    nodes = body.nodes
    face = np.flatnonzero(np.isclose(nodes[:, 0], x_face))
    weights = np.ones(face.size)
    for axis in (1, 2):
        values = nodes[face, axis]
        middle = 0.5 * (values.min() + values.max())
        weights *= np.where(np.isclose(values, middle), 4.0, 1.0)
    loads = np.zeros(body.n_dofs)
    loads[3 * face] = total * weights / weights.sum()
    return loads


def test_geometric_stiffness_buckles_a_column_at_eulers_loads(cantilever):
    # the cantilever fixture: 1.0 x 0.02 x 0.03 m steel, clamped at x = 0
    u = cantilever.static_deflection(face_load(cantilever, 1.0, -1.0))  # 1 N of compression
    k_g = geometric_stiffness(cantilever, u)
    free = cantilever.free_dofs
    stiffness = cantilever.stiffness[free][:, free].tocsc()
    geometric = k_g[free][:, free].tocsc()
    solve = sla.splu(stiffness).solve
    operator = sla.LinearOperator(stiffness.shape, matvec=lambda v: solve(-(geometric @ v)))
    mu = sla.eigs(operator, k=4, which="LR", return_eigenvectors=False)
    loads = np.sort(1.0 / mu.real[mu.real > 0])[:3]
    e = STEEL["youngs_modulus"]
    weak, strong = 0.03 * 0.02**3 / 12, 0.02 * 0.03**3 / 12
    euler = np.pi**2 * e / 4.0 * np.array([weak, strong, 9 * weak])
    # measured: 0.21 %, 0.14 % and 0.005 % above (3D solid against Euler-Bernoulli)
    np.testing.assert_allclose(loads, euler, rtol=5e-3)


def spin_stiffened_beam():
    """A steel beam 1.0 x 0.02 (y) x 0.03 (z) m clamped at x = 0, its section centred on the
    x axis, turning about z: lead-lag is bending along y, flapping along z."""
    mesh = box_mesh(1.0, 0.02, 0.03, 40, 1, 1, origin=(0.0, -0.01, -0.015))
    body = ElasticBody(mesh, STEEL["youngs_modulus"], 0.0, STEEL["density"], fixed="x_min")
    return body.reduce(6, cache=False, stress_stiffening=True)


def test_a_turning_beam_stiffens_by_southwells_coefficients():
    # to first order in the spin, a mass-normalised mode's d omega^2 / d Omega^2 is its
    # diagonal entry of K_zz + C_zz (stress stiffening plus spin softening): Southwell's
    # coefficient (the System's eigenvalues at 25 rad/s give 1.1923 and 0.1926, the
    # turning-body tests check that path)
    modal = spin_stiffened_beam()
    spin_z = modal.stress_stiffening.spin[2, 2] + modal.centrifugal[2, 2]
    lag, flap = np.diag(spin_z)[:2]
    # Southwell's K1 = 1.193 (flap) and K1 - 1 (lead-lag); measured 1.1927 and 0.1934
    assert flap == pytest.approx(1.193, rel=2e-3)
    assert lag == pytest.approx(0.193, rel=1e-2)
    lag, flap = np.diag(modal.centrifugal[2, 2])[:2]  # linear floating-frame theory alone
    assert flap == pytest.approx(0.0, abs=1e-3) and lag == pytest.approx(-1.0, rel=1e-3)


def test_a_body_force_along_the_beam_stiffens_it_by_the_rayleigh_quotient():
    # A uniform body force b per unit mass along the beam (from the root to the tip) stretches
    # it by N(x) = rho A b (L - x); the first cantilever mode phi (mass-normalised) stiffens
    # by d omega^2 / d b = int rho A (L - x) phi'^2 dx, quadrature of the exact mode shape.
    modal = spin_stiffened_beam()
    length, line_mass = 1.0, STEEL["density"] * 0.02 * 0.03
    beta = 1.8751040687 / length
    sigma = (np.cosh(beta) + np.cos(beta)) / (np.sinh(beta) + np.sin(beta))
    x = np.linspace(0.0, length, 20001)
    shape = np.cosh(beta * x) - np.cos(beta * x) - sigma * (np.sinh(beta * x) - np.sin(beta * x))
    slope = np.gradient(shape, x)
    expected = np.trapezoid(line_mass * (length - x) * slope**2, x) / np.trapezoid(
        line_mass * shape**2, x
    )
    k = modal.stress_stiffening.acceleration
    # the first lead-lag and flap modes (0, 1): measured 3e-5 from the quadrature (1.5709)
    np.testing.assert_allclose(np.diag(k[0])[:2], expected, rtol=2e-4)
    # across the beam the load bends it: its stress is odd across the section, no stiffening
    assert np.abs(k[1:]).max() < 1e-6 * np.abs(k[0]).max()


def test_stress_stiffening_is_symmetric_cached_and_refused_for_free_bodies(free_pad, tmp_path):
    modal = spin_stiffened_beam()
    k = modal.stress_stiffening.spin
    assert k.shape == (3, 3, 6, 6) and modal.stress_stiffening.acceleration.shape == (3, 6, 6)
    np.testing.assert_array_equal(k, k.transpose(1, 0, 2, 3))
    np.testing.assert_array_equal(k, k.transpose(0, 1, 3, 2))
    # turning about the beam's own axis x stretches nothing: no stiffening of bending
    assert np.abs(k[0, 0]).max() < 1e-3 * np.abs(k[2, 2]).max()
    mesh = box_mesh(1.0, 0.02, 0.03, 8, 1, 1)
    body = ElasticBody(mesh, **STEEL, fixed="x_min")
    first = body.reduce(3, stress_stiffening=True)
    second = ElasticBody(mesh, **STEEL, fixed="x_min")
    again = second.reduce(3, stress_stiffening=True)
    assert not second.is_assembled  # read from the cache, stiffening included
    np.testing.assert_array_equal(again.stress_stiffening.spin, first.stress_stiffening.spin)
    np.testing.assert_array_equal(
        again.stress_stiffening.acceleration, first.stress_stiffening.acceleration
    )
    assert body.reduce(3).stress_stiffening is None  # not asked for: not computed
    with pytest.raises(InvalidParameterError, match="'pad' is free-free"):
        stress_stiffening(free_pad, np.zeros((free_pad.n_dofs, 1)))
