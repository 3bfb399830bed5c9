"""Outputs between the steps of an integrator with error control: the cubic Hermite
interpolant of the step that covers a recording time, and the lanes' records.

The Rosenbrock kernel (:mod:`fuzzymbs.mbs.kernels.rosenbrock`) steps past the
recording times and writes the records each step covers from ``x`` and ``f`` at
both of its ends (O(h^4), the method's local error; docs/theory.md, "ROS34PW2");
the sensitivities' records (:mod:`fuzzymbs.mbs.kernels.sensitivities`) take the
same interpolant of ``S`` and ``f_x S + f_p``.
"""

from __future__ import annotations

import numba as nb

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.rk4 import output_value, store_output

L = V.LANES


@nb.njit(cache=True, fastmath=V.FAST, _nrt=V.NO_REFCOUNT)
def hermite(xa, fa, xb, fb, h, theta, dst):
    """``dst`` <- the cubic Hermite interpolant at ``t_a + theta h`` of a step of length h
    from (x_a, f_a) to (x_b, f_b); ``h`` and ``theta`` are lane vectors (a step and a
    point in it per lane)."""
    t2 = theta * theta
    t3 = t2 * theta
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = (t3 - 2.0 * t2 + theta) * h
    h01 = 3.0 * t2 - 2.0 * t3
    h11 = (t3 - t2) * h
    for i in range(xa.shape[0] // L):
        at = L * i
        value = h00 * V.load(xa, at) + h10 * V.load(fa, at)
        value = value + h01 * V.load(xb, at) + h11 * V.load(fb, at)
        V.store(dst, at, value)


@nb.njit(cache=True, _nrt=V.NO_REFCOUNT)
def record_lanes(x, recording, first, lanes, records, times):
    """Outputs of the lanes marked in ``lanes`` into their own record ``records[lane]``
    at ``times[lane]``; a lane whose output leaves its bound (or is not finite) is
    flagged (``recording`` as for :func:`fuzzymbs.mbs.kernels.rk4.rk4`)."""
    out_w = recording[0]
    for o in range(out_w.shape[0]):
        y = output_value(x, out_w, o)
        for lane in range(L):
            if lanes[lane]:
                store_output(recording, first + lane, o, records[lane], V.get(y, lane), times[lane])
