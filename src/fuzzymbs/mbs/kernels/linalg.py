"""Dense LU factorisation and solves of LANES matrices at once, one per SIMD lane.

The linearly implicit integrator (:mod:`fuzzymbs.mbs.kernels.rosenbrock`)
factorises one n x n matrix per lane and step. The lanes' matrices are stored
lane-minor like every block array (element ``(i, j)`` of lane ``l`` at
``L (n i + j) + l``), so that elimination and substitution run all lanes per
vector instruction. Each lane pivots on its own (partial pivoting by rows): the
pivot search and the row swaps are scalar, O(n^2) per factorisation, and run
only in a lane whose diagonal is beaten (a vector comparison finds those); the
O(n^3) elimination is vectorised. A lane whose matrix is singular gets inf/NaN in its
own lane only.
"""

from __future__ import annotations

import numba as nb

from fuzzymbs.mbs.kernels import simd as V

L = V.LANES


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def lu_factor_lanes(a, n, piv):
    """LU with partial pivoting of the L lane matrices in ``a`` (n n L,), in place.

    ``piv`` (n L,) receives each lane's row swaps: at elimination step k, lane l
    swapped rows k and ``piv[L k + l]``.
    """
    for k in range(n):
        # the largest magnitude below the diagonal, all lanes per vector: a lane whose
        # diagonal is not beaten keeps row k, exactly as the search below would (it
        # takes only a strictly larger value; NaN never), without its scalar loads
        below = V.splat(0.0)
        for i in range(k + 1, n):
            value = V.vabs(V.load(a, L * (n * i + k)))
            below = V.where_lt(below, value, value, below)
        diagonal = V.vabs(V.load(a, L * (n * k + k)))
        for lane in range(L):
            if not V.get(below, lane) > V.get(diagonal, lane):
                piv[L * k + lane] = k
                continue
            best = k
            largest = abs(a[L * (n * k + k) + lane])
            for i in range(k + 1, n):
                value = abs(a[L * (n * i + k) + lane])
                if value > largest:
                    best = i
                    largest = value
            piv[L * k + lane] = best
            if best != k:
                for j in range(n):
                    top = L * (n * k + j) + lane
                    other = L * (n * best + j) + lane
                    a[top], a[other] = a[other], a[top]
        inverse = 1.0 / V.load(a, L * (n * k + k))
        for i in range(k + 1, n):
            factor = V.load(a, L * (n * i + k)) * inverse
            V.store(a, L * (n * i + k), factor)
            if V.all_zero(factor):
                continue  # row i does not couple to k in any lane (bodies that do not touch)
            for j in range(k + 1, n):
                at = L * (n * i + j)
                V.store(a, at, V.load(a, at) - factor * V.load(a, L * (n * k + j)))


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def lu_solve_lanes(lu, n, piv, b):
    """Solve in place, per lane: ``b <- A^-1 b`` for the factors of :func:`lu_factor_lanes`.

    ``b`` (n L,) holds the L right-hand sides lane-minor.
    """
    for k in range(n):
        for lane in range(L):
            p = piv[L * k + lane]
            if p != k:
                b[L * k + lane], b[L * p + lane] = b[L * p + lane], b[L * k + lane]
    for i in range(n):
        acc = V.load(b, L * i)
        for j in range(i):
            acc = acc - V.load(lu, L * (n * i + j)) * V.load(b, L * j)
        V.store(b, L * i, acc)
    for i in range(n - 1, -1, -1):
        acc = V.load(b, L * i)
        for j in range(i + 1, n):
            acc = acc - V.load(lu, L * (n * i + j)) * V.load(b, L * j)
        V.store(b, L * i, acc / V.load(lu, L * (n * i + i)))


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def reduced_stage_solve(jq, mat, piv, n, gh, r, solve, u):
    """A Rosenbrock stage's ``u`` for the state ``[q, v]`` with ``J = [[0, I], [A_q, B_v]]``:
    ``(I / (gamma h) - B_v - gamma h A_q) u_v = r_v + gamma h A_q r_q`` with the stage
    matrix's factors ``mat``, ``piv`` (:func:`lu_factor_lanes`), then ``u_q = gamma h (r_q
    + u_v)`` (docs/theory.md, "ROS34PW2"). ``jq``: ``A_q`` per lane; ``n``: coordinates;
    ``gh``: gamma h per lane (a vector); ``solve`` (at least n L): scratch; lane-minor
    arrays."""
    for i in range(n):
        acc = V.splat(0.0)
        for j in range(n):
            acc = acc + V.load(jq, L * (n * i + j)) * V.load(r, L * j)
        V.store(solve, L * i, V.load(r, L * (n + i)) + gh * acc)
    lu_solve_lanes(mat, n, piv, solve)
    for i in range(n):
        solved = V.load(solve, L * i)
        V.store(u, L * (n + i), solved)
        V.store(u, L * i, gh * (V.load(r, L * i) + solved))
