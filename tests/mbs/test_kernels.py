"""Small kernel helpers against NumPy references."""

import numba as nb
import numpy as np

from fuzzymbs.mbs.contact import is_uniform_grid
from fuzzymbs.mbs.kernels import charts, rk4, simd


@nb.njit
def _atan2_lanes(y, x, out):
    for k in range(0, y.size, simd.LANES):
        simd.store(out, k, charts.atan2(simd.load(y, k), simd.load(x, k)))


def _atan2(y, x):
    y = np.ascontiguousarray(y, dtype=float)
    x = np.ascontiguousarray(x, dtype=float)
    pad = -y.size % simd.LANES
    y = np.concatenate([y, np.ones(pad)])
    x = np.concatenate([x, np.ones(pad)])
    out = np.empty_like(y)
    _atan2_lanes(y, x, out)
    return out[: y.size - pad]


def test_fast_atan2_matches_numpy():
    # reference: numpy.arctan2 (libm); our polynomial is documented to 5e-15 rad
    rng = np.random.default_rng(7)
    y = np.concatenate([rng.normal(size=20000), [0.0, 1.0, -1.0, 0.0, 1e-300, 3.0, -2.0]])
    x = np.concatenate([rng.normal(size=20000), [1.0, 0.0, 0.0, -1.0, -1.0, 3.0, -2.0]])
    got = _atan2(y, x)
    ref = np.arctan2(y, x)
    assert np.abs(got - ref).max() < 1e-14
    # also right at the octant and pi/8 seams, lanes in different octants side by side
    t = np.tan(np.pi / 8)
    y = np.array([t, 1.0, 1.0, -t])
    x = np.array([1.0, 1.0, t, -1.0])
    assert np.abs(_atan2(y, x) - np.arctan2(y, x)).max() < 1e-14


def test_atan2_of_the_origin_is_zero():
    # the kernel's convention where the polar chart's centre is hit exactly (libm gives 0 too)
    assert _atan2(np.zeros(4), np.zeros(4)).tolist() == [0.0] * 4


def test_uniform_grid_detection():
    assert is_uniform_grid(np.linspace(0.0, 1.0, 5), 4)
    assert not is_uniform_grid(np.array([0.0, 0.1, 0.3]), 2)


@nb.njit
def _output_lanes(x, out_w, o, out):
    simd.store(out, 0, rk4.output_value(x, out_w, o))


def test_an_output_reads_its_weights_only_even_from_a_longer_row():
    # the forward sensitivities record from work rows longer than the state (as long as
    # the lanes' parameters where those outnumber it): the output's sum must stop at the
    # weights' last column. Here the memory after the weights holds NaN, so a sum over the
    # row's length reads a NaN weight and makes every lane's derivative NaN, depending on
    # what the allocator left there.
    # Reference: the weighted sum by NumPy, exact (two products)
    lanes = simd.LANES
    memory = np.full(8, np.nan)
    memory[:2] = (0.5, -2.0)
    out_w = memory[:2].reshape(1, 2)  # one output of a state of 2 entries
    row = np.arange(3 * lanes, dtype=float)  # the state's 2 entries, then one more
    out = np.empty(lanes)
    _output_lanes(row, out_w, 0, out)
    state = row[: 2 * lanes].reshape(2, lanes)
    np.testing.assert_array_equal(out, 0.5 * state[0] - 2.0 * state[1])
