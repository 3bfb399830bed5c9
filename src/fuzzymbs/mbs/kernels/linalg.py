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


#: fast-math flags of the elimination's updates: contraction into FMAs only, so that LLVM
#: keeps ``(a - l_k u_k) - l_k1 u_k1`` as the two rounded steps the unblocked elimination
#: makes (reassociation could sum the two products first)
_UPDATE_FLAGS = {"contract"}


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def lu_factor_lanes(a, n, piv):
    """LU with partial pivoting of the L lane matrices in ``a`` (n n L,), in place.

    ``piv`` (n L,) receives each lane's row swaps: at elimination step k, lane l
    swapped rows k and ``piv[L k + l]``.

    The trailing rows take two elimination steps per pass (``a_ij - l_ik u_kj -
    l_ik1 u_k1j``, the intermediate in a register): the matrix (n = 41 on the brake,
    54 kB at four lanes) is read and written half as often, and every entry sees the
    same roundings in the same order as one step at a time, so the factors are bit for
    bit those of the unblocked elimination (tests/mbs/test_linalg.py).
    """
    k = 0
    while k < n:
        _pivot(a, n, k, piv)
        _multipliers(a, n, k)
        k1 = k + 1
        if k1 == n:
            break
        for i in range(k1, n):  # step k on column k1 below row k, which step k1 pivots on
            _one_step(a, n, k, i, k1, k1 + 1)
        _pivot(a, n, k1, piv)
        _one_step(a, n, k, k1, k1 + 1, n)  # row k1 of U: step k on its columns past k1
        _multipliers(a, n, k1)
        i = k1 + 1
        while i < n:
            if i + 1 < n and _both_coupled(a, n, k, i) and _both_coupled(a, n, k, i + 1):
                _two_steps_two_rows(a, n, k, i)
                i += 2
            else:
                _two_steps(a, n, k, i)
                i += 1
        k += 2


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def _pivot(a, n, k, piv):
    """Step k's row swap of every lane into ``piv``, made in ``a``: the largest magnitude
    of column k from row k down (LAPACK's choice: the first such row)."""
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


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def _multipliers(a, n, k):
    """Column k below the diagonal divided by the pivot: step k's multipliers."""
    inverse = 1.0 / V.load(a, L * (n * k + k))
    for i in range(k + 1, n):
        V.store(a, L * (n * i + k), V.load(a, L * (n * i + k)) * inverse)


@nb.njit(cache=True, inline="always", _nrt=V.NO_REFCOUNT)
def _both_coupled(a, n, k, i):
    """Row i's multipliers of steps k and k + 1 are both non-zero in some lane."""
    return not (
        V.all_zero(V.load(a, L * (n * i + k))) or V.all_zero(V.load(a, L * (n * i + k + 1)))
    )


@nb.njit(cache=True, fastmath=_UPDATE_FLAGS, _nrt=V.NO_REFCOUNT)
def _one_step(a, n, k, i, j0, j1):
    """Step k on row i, columns j0 to j1 - 1: ``a_ij -= l_ik u_kj``; nothing where ``l_ik``
    is zero in every lane (a row that does not couple to k: bodies that do not touch)."""
    lik = V.load(a, L * (n * i + k))
    if V.all_zero(lik):
        return
    for j in range(j0, j1):
        at = L * (n * i + j)
        V.store(a, at, V.load(a, at) - lik * V.load(a, L * (n * k + j)))


@nb.njit(cache=True, fastmath=_UPDATE_FLAGS, _nrt=V.NO_REFCOUNT)
def _two_steps(a, n, k, i):
    """Steps k and k + 1 on row i past column k + 1, each as :func:`_one_step` makes it."""
    l0 = V.load(a, L * (n * i + k))
    l1 = V.load(a, L * (n * i + k + 1))
    if V.all_zero(l0) or V.all_zero(l1):
        _one_step(a, n, k, i, k + 2, n)
        _one_step(a, n, k + 1, i, k + 2, n)
        return
    u0 = L * n * k
    u1 = L * n * (k + 1)
    for j in range(k + 2, n):
        at = L * (n * i + j)
        value = V.load(a, at) - l0 * V.load(a, u0 + L * j)
        V.store(a, at, value - l1 * V.load(a, u1 + L * j))


@nb.njit(cache=True, fastmath=_UPDATE_FLAGS, _nrt=V.NO_REFCOUNT)
def _two_steps_two_rows(a, n, k, i):
    """:func:`_two_steps` on rows i and i + 1 (all four multipliers non-zero in some
    lane), the pivot rows' entries loaded once for both."""
    l00 = V.load(a, L * (n * i + k))
    l01 = V.load(a, L * (n * i + k + 1))
    l10 = V.load(a, L * (n * (i + 1) + k))
    l11 = V.load(a, L * (n * (i + 1) + k + 1))
    u0 = L * n * k
    u1 = L * n * (k + 1)
    r0 = L * n * i
    r1 = L * n * (i + 1)
    for j in range(k + 2, n):
        v0 = V.load(a, u0 + L * j)
        v1 = V.load(a, u1 + L * j)
        x0 = V.load(a, r0 + L * j) - l00 * v0
        x1 = V.load(a, r1 + L * j) - l10 * v0
        V.store(a, r0 + L * j, x0 - l01 * v1)
        V.store(a, r1 + L * j, x1 - l11 * v1)


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
    # A_q r_q four rows at a time (four independent sums, r_q's entries loaded once for
    # them; each row's sum in the order of one row at a time); rows past the last repeat it
    last = n - 1
    i = 0
    while i < n:
        i1, i2, i3 = min(i + 1, last), min(i + 2, last), min(i + 3, last)
        acc0 = V.splat(0.0)
        acc1 = V.splat(0.0)
        acc2 = V.splat(0.0)
        acc3 = V.splat(0.0)
        for j in range(n):
            rj = V.load(r, L * j)
            acc0 = acc0 + V.load(jq, L * (n * i + j)) * rj
            acc1 = acc1 + V.load(jq, L * (n * i1 + j)) * rj
            acc2 = acc2 + V.load(jq, L * (n * i2 + j)) * rj
            acc3 = acc3 + V.load(jq, L * (n * i3 + j)) * rj
        V.store(solve, L * i3, V.load(r, L * (n + i3)) + gh * acc3)
        V.store(solve, L * i2, V.load(r, L * (n + i2)) + gh * acc2)
        V.store(solve, L * i1, V.load(r, L * (n + i1)) + gh * acc1)
        V.store(solve, L * i, V.load(r, L * (n + i)) + gh * acc0)
        i += 4
    lu_solve_lanes(mat, n, piv, solve)
    for i in range(n):
        solved = V.load(solve, L * i)
        V.store(u, L * (n + i), solved)
        V.store(u, L * i, gh * (V.load(r, L * i) + solved))
