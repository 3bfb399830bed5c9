"""Local (Hertzian) flattening of a line contact between a surface and a point below it.

Two elastic cylinders pressed together by a force F over the face width b touch
over a strip of half-width a = sqrt(4 F R / (pi b E*)) (Hertz), 1/R = 1/rho_1 +
1/rho_2. Each body's surface point at the centre of the strip approaches a point
at depth d on the strip's axis by (derived below, valid for d >> a)

    plane strain:  w = 2 F (1 - nu^2) / (pi E b) [ln(2 d / a) - nu / (2 (1 - nu))]
    plane stress:  w = 2 F / (pi E b) [ln(2 d / a) - nu / 2]

Derivation: a line load P on a half-plane gives Flamant's radial stress
sigma_r = -2 P cos(theta) / (pi r); on the axis under a load at lateral offset
xi the strains integrate in closed form to
w(xi) = P / (pi E) [(1 - nu^2) ln(1 + d^2/xi^2) - (1 + nu) d^2 / (xi^2 + d^2)]
(plane strain; plane stress replaces 1 - nu^2 by 1). Integrated over the Hertz
pressure p(xi) = 2 F / (pi a b) sqrt(1 - xi^2/a^2), with
(2 / (pi a)) int sqrt(1 - x^2/a^2) ln|x| dx = ln(a/2) - 1/2 over |x| < a, this
gives the formulas above: in plane strain they are Weber & Banaschek's (1953)
contact approach. 1/E* = sum of (1 - nu_i^2)/E_i in plane strain and of 1/E_i in
plane stress.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["contact_half_width", "depth_approach", "flamant_axis_approach"]


def _compliance(youngs_modulus: float, poisson_ratio: float, analysis: str) -> float:
    factor = 1.0 - poisson_ratio**2 if analysis == "plane-strain" else 1.0
    return factor / youngs_modulus


def contact_half_width(
    force: np.ndarray,
    face_width: float,
    radius: np.ndarray,
    materials: tuple[tuple[float, float], tuple[float, float]],
    analysis: str = "plane-strain",
) -> np.ndarray:
    """Hertz half-width a [m] of a line contact.

    Parameters
    ----------
    force : array
        Normal force F [N] over the face width.
    face_width : float
        b [m].
    radius : array
        Relative radius of curvature R = rho_1 rho_2 / (rho_1 + rho_2) [m].
    materials : ((E_1, nu_1), (E_2, nu_2))
        Young's moduli [Pa] and Poisson's ratios.
    analysis : {"plane-strain", "plane-stress"}
    """
    e_star = 1.0 / sum(_compliance(e, nu, analysis) for e, nu in materials)
    return np.sqrt(4.0 * np.asarray(force) * np.asarray(radius) / (math.pi * face_width * e_star))


def depth_approach(
    force: np.ndarray,
    face_width: float,
    half_width: np.ndarray,
    depth: float,
    youngs_modulus: float,
    poisson_ratio: float,
    analysis: str = "plane-strain",
) -> np.ndarray:
    """Approach [m] of one body's contact centre and the point at ``depth`` [m] below it."""
    nu = poisson_ratio
    shift = nu / (2.0 * (1.0 - nu)) if analysis == "plane-strain" else nu / 2.0
    compliance = _compliance(youngs_modulus, nu, analysis)
    force = np.asarray(force, dtype=float)
    return (
        2.0
        * force
        * compliance
        / (math.pi * face_width)
        * (np.log(2.0 * depth / np.asarray(half_width)) - shift)
    )


def flamant_axis_approach(
    force: float,
    face_width: float,
    half_width: float,
    depth: float,
    youngs_modulus: float,
    poisson_ratio: float,
    analysis: str = "plane-strain",
    points: int = 20000,
) -> float:
    """The same approach by numerical integration of Flamant's field over the Hertz pressure.

    The second method behind :func:`depth_approach` (no large-depth approximation):
    Gauss-Chebyshev-like midpoint quadrature of w(xi) p(xi) over |xi| < a.
    """
    nu = poisson_ratio
    c_log = 1.0 - nu**2 if analysis == "plane-strain" else 1.0
    # substitute xi = a sin(t): p dxi = 2 F/(pi b) cos^2(t) dt, singular log integrable
    t = (np.arange(points) + 0.5) * math.pi / points - math.pi / 2.0
    xi = half_width * np.sin(t)
    weight = 2.0 * force / (math.pi * face_width) * np.cos(t) ** 2 * (math.pi / points)
    kernel = (c_log * np.log1p(depth**2 / xi**2) - (1.0 + nu) * depth**2 / (xi**2 + depth**2)) / (
        math.pi * youngs_modulus
    )
    return float(np.sum(weight * kernel))
