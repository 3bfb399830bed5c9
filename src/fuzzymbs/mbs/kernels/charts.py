"""Master-surface charts: the four-quadrant arctangent of polar charts and the cell look-up.

A contact pass maps each slave node to chart coordinates (u, v) of its master
surface (plane: two in-plane axes; polar: radius and angle) and finds the grid
cell that holds it. :func:`atan2` runs on lane vectors; :func:`locate` finds
the cell of one lane (the general path: any grid, lanes in different cells).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.layout import CF_USCALE, CF_UUNIFORM, CF_VSCALE, CF_VUNIFORM

TWO_PI = 2.0 * np.pi
_TAN_PI_8 = 0.41421356237309503
# atan(t) / t as a polynomial in t^2 on |t| <= tan(pi/8): least-squares Chebyshev fit of
# degree 9 (our fit, checked against numpy.arctan: max error 5e-15 rad, tests/mbs)
_ATAN_COEF = (
    1.0,
    -0.3333333333346282,
    0.20000000018777836,
    -0.14285715131378893,
    0.11111124648605722,
    -0.0909084267663382,
    0.07686907598160936,
    -0.065852479637107,
    0.05277364458123443,
    -0.02865878388466727,
)


@nb.njit(cache=True, fastmath=V.FAST, inline="always")
def atan2(y, x):
    """Four-quadrant arctangent [rad] per lane, in (-pi, pi]; 0 where x = y = 0.

    Octant reduction to t = min/max in [0, 1], then t > tan(pi/8) shifted by pi/4 via
    (t - 1) / (t + 1), then the polynomial ``_ATAN_COEF`` (max error 5e-15 rad). Both
    quotients come from one division and the polynomial from Estrin's scheme: the
    contact pass's charts wait on this chain (docs/benchmarks.md).
    Selects instead of branches, so that lanes in different octants share each
    instruction; about three times cheaper than libm's per lane in the contact loop.
    """
    zero = V.splat(0.0)
    ax = V.vabs(x)
    ay = V.vabs(y)
    num = V.where_lt(ax, ay, ax, ay)
    den = V.where_lt(ax, ay, ay, ax)
    safe_den = V.where_eq(den, zero, V.splat(1.0), den)
    # t = num / den > tan(pi/8) is reduced by pi/4 to (t - 1) / (t + 1) = (num - den) /
    # (num + den): the test and both quotients from num and den, one division per lane
    beyond = _TAN_PI_8 * safe_den
    shift = V.where_lt(beyond, num, V.splat(0.25 * np.pi), zero)
    top = V.where_lt(beyond, num, num - den, num)
    bottom = V.where_lt(beyond, num, num + den, safe_den)
    t = top / bottom
    z = t * t
    # the polynomial by Estrin's scheme: four dependent multiply-adds instead of nine
    z2 = z * z
    z4 = z2 * z2
    c = _ATAN_COEF
    p01 = V.fma(V.splat(c[1]), z, V.splat(c[0]))
    p23 = V.fma(V.splat(c[3]), z, V.splat(c[2]))
    p45 = V.fma(V.splat(c[5]), z, V.splat(c[4]))
    p67 = V.fma(V.splat(c[7]), z, V.splat(c[6]))
    p89 = V.fma(V.splat(c[9]), z, V.splat(c[8]))
    p03 = V.fma(p23, z2, p01)
    p47 = V.fma(p67, z2, p45)
    poly = V.fma(V.fma(p89, z4, p47), z4, p03)
    angle = V.fma(t, poly, shift)
    angle = V.where_lt(ax, ay, 0.5 * np.pi - angle, angle)
    angle = V.where_lt(x, zero, np.pi - angle, angle)
    angle = V.where_lt(y, zero, -angle, angle)
    return V.where_eq(den, zero, zero, angle)


@nb.njit(cache=True)
def pass_scales(cf, c):
    """``(u_scale, u_uniform, v_scale, v_uniform)`` of contact pass c, for :func:`locate`."""
    return (
        cf[c, CF_USCALE],
        cf[c, CF_UUNIFORM] != 0.0,
        cf[c, CF_VSCALE],
        cf[c, CF_VUNIFORM] != 0.0,
    )


@nb.njit(cache=True)
def locate(u, v, ugrid, vgrid, periodic, scales):
    """Master cell of the chart point (u, v): ``(on the patch, i, j, xi, eta)``.

    ``scales = (u_scale, u_uniform, v_scale, v_uniform)`` (``cf`` columns CF_*).
    On a uniform grid the cell and the local coordinate follow from one multiply
    and a truncation; otherwise that is the start of a short walk. A periodic v
    (polar angle) is wrapped into the grid's turn first. Off the patch:
    ``(False, 0, 0, 0.0, 0.0)``.
    """
    nu = ugrid.shape[0]
    nv = vgrid.shape[0]
    v_cells = nv if periodic else nv - 1
    u_scale, u_uniform, v_scale, v_uniform = scales
    u_first = ugrid[0]
    v_first = vgrid[0]
    on = False
    i = 0
    j = 0
    xi = 0.0
    eta = 0.0
    fu = (u - u_first) * u_scale
    if 0.0 <= fu <= nu - 1:
        if periodic:
            if v < v_first:
                v += TWO_PI
            elif v >= v_first + TWO_PI:
                v -= TWO_PI
        fv = (v - v_first) * v_scale
        if 0.0 <= fv <= v_cells:
            on = True
            i = min(int(fu), nu - 2)
            j = min(int(fv), v_cells - 1)
            if u_uniform:
                xi = fu - i
            else:
                while i > 0 and u < ugrid[i]:
                    i -= 1
                while i < nu - 2 and u > ugrid[i + 1]:
                    i += 1
                xi = (u - ugrid[i]) / (ugrid[i + 1] - ugrid[i])
            if v_uniform:
                eta = fv - j
            else:
                while j > 0 and v < vgrid[j]:
                    j -= 1
                while j < v_cells - 1 and v > (vgrid[j + 1] if j + 1 < nv else v_first + TWO_PI):
                    j += 1
                upper = vgrid[j + 1] if j + 1 < nv else v_first + TWO_PI
                eta = (v - vgrid[j]) / (upper - vgrid[j])
    return on, i, j, xi, eta
