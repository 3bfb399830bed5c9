"""One source for a sample and for a vector of them: element access that compiles per array shape.

The planar physics (:mod:`fuzzymbs.mbs.planar.kernels`) reads and writes its
arrays through the functions here. For one sample's arrays (data, z, v as 1-d,
the mass matrix 2-d) they are plain indexing, and the kernels compile to the
scalar code they always were; for LANES samples' arrays, one more trailing axis
of :data:`LANES` (data (D, L), z (n, L), the mass matrix (n, n, L), all
C-ordered), every read is one vector of the lanes'
values (:mod:`fuzzymbs.mbs.kernels.simd`) and the same expressions run the
samples in each vector instruction. Every lane then does exactly the scalar
arithmetic (no fast-math: no contraction into FMA, no reassociation), so a
sample's numbers do not depend on its lane or its lane mates; a negation of a
vector is 0 - x, which differs from the scalar -x only in the sign of a zero.
The integer layout (which body, which marker) is shared by the lanes; nothing
in the physics compiled here branches on a lane's values, except the drive
profiles (:func:`drive`), which are evaluated lane by lane.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import overload

from fuzzymbs.mbs.kernels import simd as V

LANES = V.LANES


def _lanes(arr, ndim: int) -> bool:
    """True if ``arr`` is a lane array: one sample's ``ndim``-d array with a lane axis."""
    return isinstance(arr, types.Array) and arr.ndim == ndim + 1


def at(arr, i):
    """``arr[i]`` of a sample's 1-d array, or the lanes' values of row ``i``."""
    raise NotImplementedError("compiled only")


def at2(arr, i, j):
    """``arr[i, j]`` of a sample's 2-d array, or the lanes' values there."""
    raise NotImplementedError("compiled only")


def put(arr, i, value):
    """``arr[i] = value`` (a scalar value goes to every lane)."""
    raise NotImplementedError("compiled only")


def add(arr, i, value):
    """``arr[i] += value``."""
    raise NotImplementedError("compiled only")


def add2(arr, i, j, value):
    """``arr[i, j] += value``."""
    raise NotImplementedError("compiled only")


def zero(arr):
    """0.0, or a vector of zeros if ``arr`` is a lane array (1-d per sample)."""
    raise NotImplementedError("compiled only")


def rows(arr, count):
    """A new 1-d array of ``count`` values, or (count, lanes) if ``arr`` is a lane array."""
    raise NotImplementedError("compiled only")


def cos(x):
    """math.cos of a float or of each lane (the scalar library call, lane by lane)."""
    raise NotImplementedError("compiled only")


def sin(x):
    """math.sin of a float or of each lane."""
    raise NotImplementedError("compiled only")


@overload(at)
def _at(arr, i):
    if _lanes(arr, 1):
        return lambda arr, i: V.load(arr, LANES * i)
    return lambda arr, i: arr[i]


@overload(at2)
def _at2(arr, i, j):
    if _lanes(arr, 2):
        return lambda arr, i, j: V.load(arr, LANES * (arr.shape[1] * i + j))
    return lambda arr, i, j: arr[i, j]


def widen(value):
    """``value`` as a vector (a scalar in every lane)."""
    raise NotImplementedError("compiled only")


@overload(widen)
def _widen(value):
    if value == V.vec4:
        return lambda value: value
    return lambda value: V.splat(value)


@overload(put)
def _put(arr, i, value):
    if _lanes(arr, 1):

        def impl(arr, i, value):
            V.store(arr, LANES * i, widen(value))

        return impl

    def scalar(arr, i, value):
        arr[i] = value

    return scalar


@overload(add)
def _add(arr, i, value):
    if _lanes(arr, 1):

        def impl(arr, i, value):
            V.store(arr, LANES * i, V.load(arr, LANES * i) + value)

        return impl

    def scalar(arr, i, value):
        arr[i] += value

    return scalar


@overload(add2)
def _add2(arr, i, j, value):
    if _lanes(arr, 2):

        def impl(arr, i, j, value):
            at = LANES * (arr.shape[1] * i + j)
            V.store(arr, at, V.load(arr, at) + value)

        return impl

    def scalar(arr, i, j, value):
        arr[i, j] += value

    return scalar


@overload(zero)
def _zero(arr):
    if _lanes(arr, 1):
        return lambda arr: V.splat(0.0)
    return lambda arr: 0.0


@overload(rows)
def _rows(arr, count):
    if _lanes(arr, 1):
        return lambda arr, count: np.empty((count, LANES))
    return lambda arr, count: np.empty(count)


def _lanewise(function):
    """The overload of a float function that applies it lane by lane to a vector."""

    def typer(x):
        if x == V.vec4:

            def lanes(x):
                out = V.splat(0.0)
                for lane in range(LANES):
                    out = V.insert(out, lane, function(V.get(x, lane)))
                return out

            return lanes
        return lambda x: function(x)

    return typer


overload(cos)(_lanewise(math.cos))
overload(sin)(_lanewise(math.sin))
