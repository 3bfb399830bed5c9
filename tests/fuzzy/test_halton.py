"""Halton points: the plain sequence against SciPy's, the scrambled one's stratification."""

import numpy as np
import pytest
from scipy.stats import qmc

from fuzzymbs.fuzzy.halton import halton, primes


def test_primes():
    assert primes(8) == [2, 3, 5, 7, 11, 13, 17, 19]


def test_plain_sequence_equals_scipys_unscrambled_halton():
    # reference: scipy.stats.qmc.Halton(scramble=False), an independent implementation
    ours = halton(500, 5, start=0)
    theirs = qmc.Halton(d=5, scramble=False).random(500)
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-15)


def test_start_continues_the_sequence():
    whole = halton(300, 3, seed=11)
    np.testing.assert_array_equal(halton(100, 3, start=200, seed=11), whole[200:])


@pytest.mark.parametrize("seed", [0, 7, 20260101])
def test_scrambled_points_keep_the_stratification(seed):
    # digit permutations keep the radical inverse's strata (Braaten and Weller 1979):
    # the first b^m points put exactly one point into each interval of width b^-m
    points = halton(3**5, 3, seed=seed)
    assert np.all((points >= 0.0) & (points < 1.0))
    for axis, base in enumerate((2, 3)):
        m = int(np.floor(np.log(3**5) / np.log(base)))
        cells = np.floor(points[: base**m, axis] * base**m).astype(int)
        assert sorted(cells) == list(range(base**m))


def test_scrambling_depends_on_the_seed_and_is_reproducible():
    assert not np.array_equal(halton(50, 2, seed=1), halton(50, 2, seed=2))
    np.testing.assert_array_equal(halton(50, 2, seed=1), halton(50, 2, seed=1))
    # plain point 0 is the origin; scrambled points are spread like the plain ones:
    # the L2-star discrepancy of 256 points within twice the plain sequence's
    plain = qmc.discrepancy(halton(256, 4, start=1), method="L2-star")
    assert qmc.discrepancy(halton(256, 4, seed=3), method="L2-star") < 2 * plain


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="count >= 0"):
        halton(-1, 2)
