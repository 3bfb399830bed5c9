"""The constrained equations' linear algebra, shared by the planar and spatial engines.

Both engines' accelerations solve the saddle-point system [[M, G^T], [G, 0]]
(:func:`solve_constrained`), and their projections onto the joints remove a
residual by the least change G^T (G G^T)^-1 g (:func:`project_rows`,
:func:`remove_velocity_excess`). The systems are small (tens of rows), so a
compiled loop is used rather than LAPACK's wrappers.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
def solve_in_place(a, b):
    """Solve a x = b by Gaussian elimination with partial pivoting; x into ``b``.

    ``a`` is overwritten. Returns False if a pivot is zero or not finite. (The
    systems are small, tens of rows; a loop compiles in a fraction of the time
    NumPy's LAPACK wrapper takes.)
    """
    n = b.size
    columns = np.empty(n, dtype=np.int64)  # the pivot row's nonzero columns
    for k in range(n):
        best = k
        largest = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > largest:
                best = i
                largest = abs(a[i, k])
        if not (largest > 0.0 and math.isfinite(largest)):
            return False
        if best != k:
            for j in range(n):
                a[k, j], a[best, j] = a[best, j], a[k, j]
            b[k], b[best] = b[best], b[k]
        # a constrained system is mostly zeros (the slider-crank's 24 x 24: 127 nonzeros);
        # the elimination touches only the pivot row's nonzero columns
        count = 0
        for j in range(k + 1, n):
            if a[k, j] != 0.0:
                columns[count] = j
                count += 1
        inverse = 1.0 / a[k, k]
        for i in range(k + 1, n):
            factor = a[i, k] * inverse
            if factor == 0.0:
                continue
            for index in range(count):
                j = columns[index]
                a[i, j] -= factor * a[k, j]
            b[i] -= factor * b[k]
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= a[i, j] * b[j]
        b[i] = acc / a[i, i]
    return True


@nb.njit(cache=True)
def project_rows(jac, excess, target):
    """target -= G^T (G G^T)^-1 excess (the least change that removes ``excess``)."""
    c, n = jac.shape
    gram = np.empty((c, c))
    for i in range(c):
        for j in range(c):
            acc = 0.0
            for k in range(n):
                acc += jac[i, k] * jac[j, k]
            gram[i, j] = acc
    weights = excess.copy()
    if not solve_in_place(gram, weights):
        return False
    for k in range(n):
        acc = 0.0
        for i in range(c):
            acc += jac[i, k] * weights[i]
        target[k] -= acc
    return True


@nb.njit(cache=True)
def remove_velocity_excess(jac, rate, v, excess):
    """v -= G^T (G G^T)^-1 (G v - f'): the least change that meets the joints' velocity
    equations; False if G G^T is singular."""
    c, n = jac.shape
    for r in range(c):
        acc = -rate[r]
        for k in range(n):
            acc += jac[r, k] * v[k]
        excess[r] = acc
    return project_rows(jac, excess, v)


@nb.njit(cache=True)
def joint_buffers(c, n):
    """(residual, quadratic, rate, acceleration, jac): the arrays an engine's ``joint_terms``
    fills for ``c`` joint equations on ``n`` velocities (``jac`` zeroed)."""
    return np.empty(c), np.empty(c), np.empty(c), np.empty(c), np.zeros((c, n))


@nb.njit(cache=True)
def largest_magnitude(values):
    """max |values| (0 for none): the largest joint residual."""
    worst = 0.0
    for r in range(values.size):
        worst = max(worst, abs(values[r]))
    return worst


@nb.njit(cache=True)
def finish_projection(jac, rate, v, excess, worst):
    """The velocities' part of a projection onto the joints, after the positions'
    (``worst``: the largest residual they left; ``jac`` and ``rate`` evaluated there):
    :func:`remove_velocity_excess`, then ``worst``, or inf if G G^T is singular."""
    if not remove_velocity_excess(jac, rate, v, excess):
        return np.inf
    return worst


@nb.njit(cache=True)
def solve_constrained(mass, jac, quadratic, acceleration, system, solution):
    """Solve [[M, G^T], [G, 0]] (a, lambda) = (f, f'' - zeta) into ``solution``.

    On entry ``solution[:n]`` holds the generalised forces f; ``system`` is an
    (n + c, n + c) scratch matrix (both engines' :func:`accelerations` end here).
    Returns False if the matrix is singular or the result not finite.
    """
    n = mass.shape[0]
    c = jac.shape[0]
    system[:n, :n] = mass
    system[n:, n:] = 0.0
    for r in range(c):
        for x in range(n):
            system[n + r, x] = jac[r, x]
            system[x, n + r] = jac[r, x]
        solution[n + r] = -quadratic[r] + acceleration[r]
    if not solve_in_place(system, solution):
        return False
    for i in range(n + c):
        if not math.isfinite(solution[i]):
            return False
    return True
