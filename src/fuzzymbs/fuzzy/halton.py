"""Halton points in the unit cube, plain or scrambled by random digit permutations.

The Halton sequence takes, for the i-th point and axis ``a``, the radical
inverse of ``i`` in the a-th prime base ``b``: the base-b digits of ``i``
mirrored behind the radix point. Scrambling replaces digit position ``k`` of
every point by ``pi_k(digit)``, one random permutation ``pi_k`` of the digits
per base and position (Braaten and Weller 1979; Mascagni and Chi 2004): the
low-dimensional projections lose the plain sequence's correlations in high
bases, and every base-b stratification of the plain sequence is kept (the first
``b^m`` points put one point into each interval of width ``b^-m`` on that axis).

Written here rather than taken from :mod:`scipy.stats.qmc` because importing
``scipy.stats`` costs about a second, paid by every study whose method check
draws a few points.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["halton", "primes"]


def primes(count: int) -> list[int]:
    """The first ``count`` prime numbers."""
    found: list[int] = []
    candidate = 2
    while len(found) < count:
        if all(candidate % p for p in found if p * p <= candidate):
            found.append(candidate)
        candidate += 1
    return found


def halton(
    count: int, dimension: int, *, start: int = 0, seed: int | None = None
) -> NDArray[np.float64]:
    """Points ``start`` to ``start + count - 1`` of the Halton sequence in [0, 1)^dimension.

    Parameters
    ----------
    count : number of points.
    dimension : number of axes (the first ``dimension`` primes are the bases).
    start : index of the first point (point 0 of the plain sequence is the origin).
    seed : None: the plain sequence; an integer: scrambled by random digit
        permutations drawn from ``numpy.random.default_rng(seed)`` (the same seed,
        the same sequence, whatever ``start`` and ``count``).

    Returns
    -------
    ndarray
        (count, dimension).
    """
    if count < 0 or dimension < 1 or start < 0:
        raise ValueError(
            f"halton needs count >= 0, dimension >= 1 and start >= 0, got {count}, "
            f"{dimension}, {start}"
        )
    rng = None if seed is None else np.random.default_rng(seed)
    points = np.zeros((count, dimension))
    for axis, base in enumerate(primes(dimension)):
        # digits until the next one is below double precision
        digits = math.ceil(53 / math.log2(base))
        permutations = (
            None if rng is None else np.array([rng.permutation(base) for _ in range(digits)])
        )
        index = np.arange(start, start + count, dtype=np.int64)
        scale = 1.0
        for position in range(digits):
            scale /= base
            digit = index % base
            if permutations is not None:
                digit = permutations[position][digit]
            elif not np.any(index):
                break  # plain: the remaining digits are zero
            points[:, axis] += scale * digit
            index //= base
    # a scrambled point's digits may all be b - 1: keep the sum's rounding below 1
    return np.minimum(points, np.nextafter(1.0, 0.0), out=points)
