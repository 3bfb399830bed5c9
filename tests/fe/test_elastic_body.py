"""Assembly and natural frequencies of ElasticBody against independent references."""

from __future__ import annotations

import numpy as np
import pytest
from skfem import Basis, BilinearForm, ElementHex2, ElementVector, asm
from skfem.helpers import dot
from skfem.models.elasticity import lame_parameters, linear_elasticity

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import ElasticBody, annulus_mesh, box_mesh

from .conftest import STEEL
from .plate_reference import frequency_parameters


def test_assembly_equals_scikit_fem_vector_forms():
    # reference: scikit-fem's own vector linear-elasticity and mass forms on the same
    # curved 27-node mesh and quadrature (our assembly interleaves scalar forms)
    mesh = annulus_mesh(0.1, 0.2, 0.01, 2, 3, 1, angle_range=(0.0, 1.2))
    body = ElasticBody(mesh, **STEEL)
    basis = Basis(mesh, ElementVector(ElementHex2()), intorder=4)
    stiffness = asm(linear_elasticity(*lame_parameters(210e9, 0.3)), basis)

    @BilinearForm
    def mass(u, v, w):
        return 7850.0 * dot(u, v)

    reference_mass = asm(mass, basis)
    assert abs(body.stiffness - stiffness).max() <= 1e-12 * abs(stiffness).max()
    assert abs(body.mass_matrix - reference_mass).max() <= 1e-12 * abs(reference_mass).max()


def test_rigid_motions_are_stress_free_and_mass_is_exact(free_pad):
    # a rigid translation/rotation has zero elastic force; 1^T M 1 = rho V
    rigid = free_pad.rigid_body_modes()
    force = free_pad.stiffness @ rigid
    assert np.abs(force).max() <= 1e-8 * abs(free_pad.stiffness).max() * np.abs(rigid).max()
    ones = np.zeros(free_pad.n_dofs)
    ones[0::3] = 1.0
    assert ones @ free_pad.mass_matrix @ ones == pytest.approx(2500.0 * 0.06 * 0.04 * 0.015, 1e-12)


def _bending_direction(body: ElasticBody, modes: np.ndarray) -> np.ndarray:
    """Dominant displacement component (0, 1, 2) of each mode."""
    shape = modes.reshape(body.n_nodes, 3, -1)
    return np.argmax(np.sum(shape**2, axis=0), axis=0)


def test_cantilever_matches_euler_bernoulli(cantilever):
    # Euler-Bernoulli cantilever: omega_n = (beta_n L)^2 sqrt(E I / (rho A L^4)),
    # beta_n L = 1.8751, 4.6941, 7.8548 (Blevins, Formulas for natural frequency and mode
    # shape, table 8-1). L/h = 33..50: Timoshenko shear + rotary inertia lower mode 3 by
    # ~0.6 %, the 3D clamp stiffens slightly; tolerance 1.5 %.
    from fuzzymbs.fe.reduction import modal_truncation

    basis = modal_truncation(cantilever, 8)
    direction = _bending_direction(cantilever, basis.modes)
    length, width, height = 1.0, 0.02, 0.03
    area = width * height
    beta_l = np.array([1.87510407, 4.69409113, 7.85475744])
    for component, second_moment in ((1, height * width**3 / 12), (2, width * height**3 / 12)):
        reference = beta_l**2 * np.sqrt(210e9 * second_moment / (7850.0 * area * length**4))
        found = basis.frequencies[direction == component][:3]
        assert found.size == 3
        np.testing.assert_allclose(found, reference, rtol=0.015)


def _distinct(values: np.ndarray, tolerance: float = 1e-5) -> list[tuple[float, int]]:
    """Group (nearly) repeated frequencies: (value, multiplicity)."""
    groups: list[list[float]] = []
    for value in np.sort(values):
        if groups and value - groups[-1][0] <= tolerance * value:
            groups[-1].append(value)
        else:
            groups.append([value])
    return [(float(np.mean(g)), len(g)) for g in groups]


def _nodal_diameters(body: ElasticBody, mode: np.ndarray, radius: float, height: float) -> int:
    """Dominant circumferential harmonic of the axial displacement on the outer top edge."""
    nodes = body.nodes
    ring = np.flatnonzero(
        (np.hypot(nodes[:, 0], nodes[:, 1]) >= radius * (1 - 1e-9))
        & (nodes[:, 2] >= height * (1 - 1e-9))
    )
    angle = np.arctan2(nodes[ring, 1], nodes[ring, 0])
    axial = mode.reshape(-1, 3)[ring, 2]
    harmonics = [np.hypot(axial @ np.cos(n * angle), axial @ np.sin(n * angle)) for n in range(9)]
    return int(np.argmax(harmonics))


def _annular_plate_check(n_radial: int, n_circumferential: int, tolerance: float) -> None:
    from fuzzymbs.fe.reduction import modal_truncation

    outer, inner, thickness = 0.2, 0.1, 0.004  # h / a = 1/50
    nu = 0.3
    mesh = annulus_mesh(inner, outer, thickness, n_radial, n_circumferential, 1)
    body = ElasticBody(mesh, 210e9, nu, 7850.0, fixed="inner")
    basis = modal_truncation(body, 11)
    rigidity = 210e9 * thickness**3 / (12 * (1 - nu**2))
    parameter = basis.frequencies * outer**2 * np.sqrt(7850.0 * thickness / rigidity)
    groups = _distinct(parameter)
    reference = frequency_parameters(inner / outer, nu)[:6]
    # the six distinct modes: (0,0) single, (n,0) n = 1..5 double (cos/sin pairs)
    assert [g[1] for g in groups[:6]] == [1, 2, 2, 2, 2, 2]
    first_of_group = np.cumsum([0] + [g[1] for g in groups[:6]])[:-1]
    for (value, _), start, (expected, n, _) in zip(
        groups[:6], first_of_group, reference, strict=True
    ):
        assert _nodal_diameters(body, basis.modes[:, start], outer, thickness) == n
        assert value == pytest.approx(expected, rel=tolerance)


def test_annular_plate_clamped_inside_free_outside_matches_kirchhoff():
    # reference: exact Bessel-function characteristic equation (plate_reference.py; Leissa
    # 1969 sec. 2.2, Vogel & Skinner 1965). b/a = 0.5, h/a = 1/50, 6 x 48 27-node hexahedra:
    # measured errors +1.06 % (0,0) ... +0.80 % (5,0); tolerance 2 %.
    _annular_plate_check(6, 48, 0.02)


@pytest.mark.slow
def test_annular_plate_converges_to_kirchhoff():
    # 12 x 64 elements: measured errors +0.33 % (0,0) ... -0.01 % (5,0); tolerance 0.5 %
    _annular_plate_check(12, 64, 0.005)


def test_natural_frequencies_in_hz_free_free_excludes_rigid(free_pad):
    elastic = free_pad.natural_frequencies(3)
    with_rigid = free_pad.natural_frequencies(9, include_rigid=True)
    assert np.all(with_rigid[:6] < 1e-6 * elastic[0])
    np.testing.assert_allclose(with_rigid[6:], elastic, rtol=1e-10)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"youngs_modulus": -1.0}, "youngs_modulus"),
        ({"poisson_ratio": 0.5}, "poisson_ratio"),
        ({"density": float("nan")}, "density"),
        ({"fixed": "nowhere"}, "unknown boundary"),
        ({"fixed": lambda x: x[0] < -1.0}, "selects no node"),
        ({"fixed": [10**6]}, "node indices"),
    ],
)
def test_bad_inputs_are_named(kwargs, message):
    mesh = box_mesh(0.1, 0.1, 0.1, 1, 1, 1, order=1)
    arguments = {**STEEL, **kwargs}
    with pytest.raises(InvalidParameterError, match=message):
        ElasticBody(mesh, **arguments)


def test_static_deflection_of_free_body_is_refused(free_pad):
    with pytest.raises(InvalidParameterError, match="free-free"):
        free_pad.static_deflection(np.zeros(free_pad.n_dofs))


def test_static_deflection_checks_the_loads(cantilever):
    with pytest.raises(InvalidParameterError, match=r"loads must have shape \(\d+,\)"):
        cantilever.static_deflection(np.ones(5))
    loads = np.zeros(cantilever.n_dofs)
    loads[-1] = np.nan
    with pytest.raises(InvalidParameterError, match="finite"):
        cantilever.static_deflection(loads)
