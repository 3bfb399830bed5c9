"""The lane LU and the Rosenbrock stage solve (fuzzymbs.mbs.kernels.linalg)."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.linalg import lu_factor_lanes, lu_solve_lanes, reduced_stage_solve
from fuzzymbs.mbs.kernels.simd import LANES

L = LANES


@nb.njit(fastmath={"contract"})
def unblocked_lu(a, n, piv):
    """The textbook elimination, one step at a time over the whole trailing matrix, with
    the kernel's pivot choice (LAPACK's) and its rule that a row whose multiplier is zero
    in every lane is left as it is: the reference the blocked kernel must equal bit for
    bit."""
    for k in range(n):
        for lane in range(L):
            best = k
            largest = abs(a[L * (n * k + k) + lane])
            for i in range(k + 1, n):
                value = abs(a[L * (n * i + k) + lane])
                if value > largest:
                    best = i
                    largest = value
            piv[L * k + lane] = best
            for j in range(n):
                top = L * (n * k + j) + lane
                other = L * (n * best + j) + lane
                a[top], a[other] = a[other], a[top]
        inverse = 1.0 / V.load(a, L * (n * k + k))
        for i in range(k + 1, n):
            factor = V.load(a, L * (n * i + k)) * inverse
            V.store(a, L * (n * i + k), factor)
            if V.all_zero(factor):
                continue
            for j in range(k + 1, n):
                at = L * (n * i + j)
                V.store(a, at, V.load(a, at) - factor * V.load(a, L * (n * k + j)))


def lane_matrices(mats: np.ndarray) -> np.ndarray:
    """(L, n, n) matrices -> the kernels' lane-minor layout."""
    return np.ascontiguousarray(np.moveaxis(mats, 0, -1)).ravel()


def test_the_blocked_lu_equals_the_unblocked_elimination_bit_for_bit():
    # two elimination steps per pass over the trailing rows must leave every entry with
    # the same roundings: sizes even and odd (the last single step, the unpaired row),
    # rows that do not couple to a step in any lane (the skip), row swaps, and singular
    # lanes (inf / NaN) among the others
    rng = np.random.default_rng(7)
    cases = 0
    for n in (1, 2, 3, 4, 5, 8, 9, 13, 41):
        for trial in range(12):
            mats = rng.normal(size=(L, n, n))
            if trial % 3 == 0:  # two bodies that do not touch
                mats[:, : n // 2, n // 2 :] = 0.0
                mats[:, n // 2 :, : n // 2] = 0.0
            if trial % 3 == 1:  # one coupling row only
                mats[:, n // 2 :, : n // 2] = 0.0
                mats[:, -1, 0] = rng.normal()
            if trial % 4 == 1:
                mats += 10.0 * np.eye(n)
            if trial % 5 == 2 and n > 1:
                mats[1, 0, 0] = 0.0  # a lane that must swap
            if trial % 7 == 3:
                mats[2, :, n - 1] = 0.0  # a singular lane
            blocked, reference = lane_matrices(mats), lane_matrices(mats)
            piv_blocked = np.zeros(n * L, dtype=np.int64)
            piv_reference = np.zeros(n * L, dtype=np.int64)
            lu_factor_lanes(blocked, n, piv_blocked)
            unblocked_lu(reference, n, piv_reference)
            np.testing.assert_array_equal(piv_blocked, piv_reference)
            np.testing.assert_array_equal(blocked.view(np.int64), reference.view(np.int64))
            cases += 1
    assert cases == 9 * 12


@nb.njit
def _stage_solve(jq, mat, piv, n, gh, r, solve, u):
    reduced_stage_solve(jq, mat, piv, n, V.splat(gh), r, solve, u)


@pytest.mark.parametrize("n", [1, 3, 4, 6, 41])
def test_the_reduced_stage_solve_solves_the_full_stage_system(n):
    # reference: the full 2n x 2n stage system (I / (gamma h) - J) u = r with
    # J = [[0, I], [A_q, B_v]], solved by numpy.linalg.solve per lane (rtol 1e-9; the
    # reduced matrix I / (gamma h) - B_v - gamma h A_q is factorised by the kernel)
    rng = np.random.default_rng(n)
    gh = 1e-3
    a_q = rng.normal(size=(L, n, n)) * 100.0
    b_v = rng.normal(size=(L, n, n))
    reduced = np.eye(n) / gh - b_v - gh * a_q
    mat = lane_matrices(reduced)
    piv = np.zeros(n * L, dtype=np.int64)
    lu_factor_lanes(mat, n, piv)
    r = rng.normal(size=(L, 2 * n))
    u = np.zeros(2 * n * L)
    _stage_solve(lane_matrices(a_q), mat, piv, n, gh, lane_matrices(r), np.zeros(n * L), u)
    for lane in range(L):
        jac = np.block([[np.zeros((n, n)), np.eye(n)], [a_q[lane], b_v[lane]]])
        expected = np.linalg.solve(np.eye(2 * n) / gh - jac, r[lane])
        np.testing.assert_allclose(u[lane::L], expected, rtol=1e-9, atol=1e-12)


def test_a_singular_lane_leaves_the_other_lanes_alone():
    # each lane pivots and divides on its own: a lane with a zero column gets inf / NaN,
    # the others the solution numpy.linalg.solve gives (rtol 1e-10)
    rng = np.random.default_rng(11)
    n = 9
    mats = rng.normal(size=(L, n, n)) + 3.0 * np.eye(n)
    mats[1, :, 4] = 0.0
    rhs = rng.normal(size=(L, n))
    a, b = lane_matrices(mats), lane_matrices(rhs)
    piv = np.zeros(n * L, dtype=np.int64)
    lu_factor_lanes(a, n, piv)
    lu_solve_lanes(a, n, piv, b)
    assert not np.all(np.isfinite(b[1::L]))
    for lane in (0, *range(2, L)):
        expected = np.linalg.solve(mats[lane], rhs[lane])
        np.testing.assert_allclose(b[lane::L], expected, rtol=1e-10, atol=1e-12)
