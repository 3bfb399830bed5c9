"""Kirchhoff reference: annular plate clamped at the inner edge, free at the outer edge.

Closed-form solution (Leissa, Vibration of Plates, NASA SP-160, 1969, section 2.2;
Vogel & Skinner, J. Appl. Mech. 32 (1965) 926): with k^4 = rho h omega^2 / D,

    W(r) cos(n theta),  W = A J_n(k r) + B Y_n(k r) + C I_n(k r) + D K_n(k r).

Boundary conditions (outer radius a, inner radius b):
    r = b (clamped): W = 0, W' = 0
    r = a (free):    M_r = W'' + nu (W'/r - n^2 W / r^2) = 0
                     V_r = (lap W)' - (1 - nu) n^2 / r^2 (W' - W / r) = 0,
where lap J_n(kr) = -k^2 J_n(kr), lap Y_n = -k^2 Y_n, lap I_n = +k^2 I_n,
lap K_n = +k^2 K_n. Non-trivial solutions need det = 0; the frequency parameter
is lambda^2 = (k a)^2 = omega a^2 sqrt(rho h / D), D = E h^3 / (12 (1 - nu^2)).

Computed here rather than read from a table: the roots are closed-form
solutions of the characteristic equation, found to 1e-12 with brentq.
For b/a = 0.5, nu = 0.3 the six lowest modes (n nodal diameters, s nodal
circles) are (0,0) 13.0243, (1,0) 13.2898, (2,0) 14.7038, (3,0) 18.5620,
(4,0) 25.5958, (5,0) 35.7301.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.special import iv, ivp, jv, jvp, kv, kvp, yv, yvp

# (function, derivative, sign of the Laplacian eigenvalue)
_FUNCTIONS = ((jv, jvp, -1.0), (yv, yvp, -1.0), (iv, ivp, 1.0), (kv, kvp, 1.0))


def characteristic_determinant(lam, n: int, radius_ratio: float, nu: float):
    """det of the 4 x 4 boundary-condition matrix (columns scaled to unit norm); a = 1, k = lam.

    ``lam`` may be an array (vectorised over it).
    """
    lam = np.asarray(lam, dtype=np.float64)
    b = radius_ratio
    columns = []
    for f, fp, sign in _FUNCTIONS:
        w = f(n, lam)
        w1 = lam * fp(n, lam, 1)
        w2 = lam**2 * fp(n, lam, 2)
        columns.append(
            [
                f(n, lam * b),  # W(b) = 0
                lam * fp(n, lam * b),  # W'(b) = 0
                w2 + nu * (w1 - n**2 * w),  # M_r(a) = 0
                sign * lam**2 * w1 - (1 - nu) * n**2 * (w1 - w),  # V_r(a) = 0
            ]
        )
    matrix = np.moveaxis(np.array(columns), (0, 1), (-1, -2))  # (..., row, column)
    matrix = matrix / np.linalg.norm(matrix, axis=-2, keepdims=True)
    return np.linalg.det(matrix)


def frequency_parameters(
    radius_ratio: float, nu: float, n_max: int = 6, lam_max: float = 12.0
) -> list[tuple[float, int, int]]:
    """Sorted (lambda^2, n, s) of all modes with k a < lam_max and n <= n_max."""
    grid = np.linspace(0.3, lam_max, 3000)
    modes = []
    for n in range(n_max + 1):
        values = characteristic_determinant(grid, n, radius_ratio, nu)
        change = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
        for s, i in enumerate(change):
            root = brentq(
                lambda x, n=n: float(characteristic_determinant(x, n, radius_ratio, nu)),
                grid[i],
                grid[i + 1],
                xtol=1e-13,
            )
            modes.append((root**2, n, s))
    return sorted(modes)
