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

from fuzzymbs.mbs.kernels import simd as V

L = V.LANES


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


@nb.njit(cache=True)
def solve_lanes(a, b, size, ok):
    """:func:`solve_in_place` of LANES systems at once, one per SIMD lane: a x = b into ``b``.

    ``a`` (size size L,) and ``b`` (size L,) are lane-minor (element (i, j) of lane l
    at ``L (size i + j) + l``); ``ok[lane]`` is set False where a pivot of that lane is
    zero or not finite (its lane then holds inf or NaN, the others are untouched).
    Every lane does exactly :func:`solve_in_place`'s arithmetic, in its order: a lane
    pivots on its own (the rows swap a vector at a time while all lanes pick the same
    pivot, as they do but for exceptions), and where a lane's scalar elimination skips
    a zero factor or a zero entry of the pivot row, a select keeps its old value, so the
    result is bit for bit :func:`solve_in_place`'s whatever the other lanes hold.
    """
    columns = np.empty(size, dtype=np.int64)
    zero = V.splat(0.0)
    for k in range(size):
        # the pivot search of every lane at once: the first strictly largest magnitude
        # (a NaN never wins, as in the scalar search)
        largest = V.vabs(V.load(a, L * (size * k + k)))
        best = V.splat(k)
        for i in range(k + 1, size):
            value = V.vabs(V.load(a, L * (size * i + k)))
            best = V.where_lt(largest, value, V.splat(i), best)
            largest = V.where_lt(largest, value, value, largest)
        uniform = True
        for lane in range(L):
            top = V.get(largest, lane)
            if not (top > 0.0 and math.isfinite(top)):
                ok[lane] = False
            uniform = uniform and V.get(best, lane) == V.get(best, 0)
        if uniform:  # the usual case: every lane swaps the same rows, a vector at a time
            other = int(V.get(best, 0))
            if other != k:
                for j in range(size):
                    top = V.load(a, L * (size * k + j))
                    V.store(a, L * (size * k + j), V.load(a, L * (size * other + j)))
                    V.store(a, L * (size * other + j), top)
                top = V.load(b, L * k)
                V.store(b, L * k, V.load(b, L * other))
                V.store(b, L * other, top)
        else:
            for lane in range(L):
                other = int(V.get(best, lane))
                if other != k:
                    for j in range(size):
                        top = L * (size * k + j) + lane
                        below = L * (size * other + j) + lane
                        a[top], a[below] = a[below], a[top]
                    top = L * k + lane
                    below = L * other + lane
                    b[top], b[below] = b[below], b[top]
        count = 0
        for j in range(k + 1, size):
            at = L * (size * k + j)
            if not V.all_zero(V.load(a, at)):
                columns[count] = j
                count += 1
        inverse = 1.0 / V.load(a, L * (size * k + k))
        bk = V.load(b, L * k)
        for i in range(k + 1, size):
            factor = V.load(a, L * (size * i + k)) * inverse
            if V.all_zero(V.load(a, L * (size * i + k))):
                continue
            for index in range(count):
                j = columns[index]
                pivot_row = V.load(a, L * (size * k + j))
                at = L * (size * i + j)
                old = V.load(a, at)
                new = V.where_eq(pivot_row, zero, old, old - factor * pivot_row)
                V.store(a, at, V.where_eq(factor, zero, old, new))
            old = V.load(b, L * i)
            V.store(b, L * i, V.where_eq(factor, zero, old, old - factor * bk))
    for i in range(size - 1, -1, -1):
        acc = V.load(b, L * i)
        for j in range(i + 1, size):
            acc = acc - V.load(a, L * (size * i + j)) * V.load(b, L * j)
        V.store(b, L * i, acc / V.load(a, L * (size * i + i)))
    for lane in range(L):
        for i in range(size):
            if not math.isfinite(b[L * i + lane]):
                ok[lane] = False
