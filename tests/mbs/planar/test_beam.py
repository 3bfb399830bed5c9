"""Planar beam reduction (fuzzymbs.fe.beam) against closed forms and published values."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe.beam import PlanarBeam

# Kane, Ryan & Banerjee (1987) spin-up beam data
KANE = dict(
    length=8.0, youngs_modulus=6.8952e10, density=2766.7, area=7.2968e-5, second_moment=8.2189e-9
)


def reference_frequency(beam: PlanarBeam) -> float:
    """sqrt(EI / (rho A L^4)) [rad/s]."""
    return np.sqrt(
        beam.youngs_modulus * beam.second_moment / (beam.mass_per_length * beam.length**4)
    )


def test_clamped_frequencies_match_euler_bernoulli():
    # Euler-Bernoulli clamped-free: (beta_n L)^2 with beta L = 1.8751, 4.6941, 7.8548
    # (Blevins, Formulas for Natural Frequency and Mode Shape, table 8-1); 16 cubic
    # elements are within 1e-4 of the continuum for the first three.
    beam = PlanarBeam(**KANE)
    reduced = beam.reduce(3)
    exact = np.array([1.87510407, 4.69409113, 7.85475744]) ** 2 * reference_frequency(beam)
    np.testing.assert_allclose(reduced.frequencies, exact, rtol=1e-4)


def test_pinned_pinned_frequencies_match_euler_bernoulli():
    # simply supported: (n pi)^2 sqrt(EI / (rho A L^4)) (Blevins, table 8-1)
    beam = PlanarBeam(
        length=0.3,
        youngs_modulus=2e11,
        density=7800,
        area=5e-5,
        second_moment=1e-11,
        support="pinned-pinned",
    )
    reduced = beam.reduce(2)
    exact = (np.array([1, 2]) * np.pi) ** 2 * reference_frequency(beam)
    np.testing.assert_allclose(reduced.frequencies, exact, rtol=1e-4)


def test_invariants_of_a_uniform_beam():
    # closed forms: m = rho A L, first moment m L / 2, inertia about the root m L^2 / 3;
    # mass-normalised modes give the identity modal mass
    beam = PlanarBeam(**KANE)
    reduced = beam.reduce(6)
    mass = beam.mass_per_length * beam.length
    assert reduced.mass == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(reduced.first_moment, [mass * beam.length / 2, 0.0], atol=1e-12)
    assert reduced.inertia == pytest.approx(mass * beam.length**2 / 3, rel=1e-12)
    np.testing.assert_allclose(reduced.modal_mass, np.eye(6), atol=1e-10)
    np.testing.assert_allclose(reduced.modal_gyroscopic, -reduced.modal_gyroscopic.T, atol=1e-12)


def test_southwell_coefficient_of_the_first_mode():
    # Southwell coefficient of a uniform clamped-free beam's first mode, hub radius 0:
    # K_s = 1.1933 (Hodges & Rutkowski, AIAA J. 19 (1981) 1459; Wright et al., J. Appl.
    # Mech. 49 (1982) 197): the modal geometric stiffness per unit Omega^2
    reduced = PlanarBeam(**KANE).reduce(1)
    assert reduced.geometric_spin[0, 0] == pytest.approx(1.1933, abs=5e-4)


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(length=-1.0), "length"),
        (dict(youngs_modulus=np.nan), "youngs_modulus"),
        (dict(elements=0), "elements"),
        (dict(support="free"), "support"),
    ],
)
def test_bad_beam_input_is_refused_by_name(change, match):
    with pytest.raises(InvalidParameterError, match=match):
        PlanarBeam(**{**KANE, **change})


def test_too_many_modes_is_refused():
    with pytest.raises(InvalidParameterError, match="modes"):
        PlanarBeam(**KANE, elements=2).reduce(7)
