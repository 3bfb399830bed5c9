"""Kinematics of the bodies' tracked nodes and the generalised forces of node forces.

LANES samples (lanes) per :mod:`~fuzzymbs.mbs.kernels.simd` vector, arrays
lane-minor (element ``i`` of lane ``l`` at ``L i + l``):

* :func:`frame_rotations`: angle, speed, acceleration and rotation matrix A(t)
  of every rotating body (prescribed speed profile times the speed parameter);
* :func:`node_kinematics`: inertial positions and velocities of the tracked
  nodes, ``x = r + A (xbar + Psi q)``, ``v = rdot + A (Omega e x y + Psi qdot)``;
* :func:`map_node_forces`: ``Q_t = sum F``, ``Q_q = sum Psi_k^T A^T F_k``.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba import types
from numba.extending import overload

from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.layout import (
    B_DOF0,
    B_KIND,
    B_NM,
    B_NODE0,
    B_NODE1,
    B_NTR,
    B_PROF,
    B_PSI0,
    B_PSIT0,
    B_SPEED,
    KIND_ROTATING,
)

L = V.LANES


@nb.njit(cache=True)
def profile_value(fpool, ptab, k, t):
    """Value, integral from t = 0, and slope (right-continuous) of profile k at time t:
    knots (``ptab[k, 1]`` of them), or Kane's spin-up over ``fpool[ptab[k, 0]]`` seconds
    (``ptab[k, 1] == -1``, :class:`~fuzzymbs.mbs.profiles.SpinUpProfile`)."""
    s = ptab[k, 0]
    m = ptab[k, 1]
    if m < 0:
        return spin_up(fpool[s], t)
    ts = fpool[s : s + m]
    vs = fpool[s + m : s + 2 * m]
    cs = fpool[s + 2 * m : s + 3 * m]
    value, integral, slope = segment(ts, vs, cs, t)
    _, integral0, _ = segment(ts, vs, cs, 0.0)
    return value, integral - integral0, slope


def profile_lanes(fpool, ptab, k, t):
    """Value, integral from t = 0 and slope of profile k as lane vectors.

    ``t`` is one time for every lane (a float) or a time per lane (an ``(L,)``
    array): the adaptive integrator advances each lane on its own clock, so that
    a sample's steps never depend on the samples beside it. Compiled code only.
    """
    raise NotImplementedError("profile_lanes is compiled by Numba only")


@overload(profile_lanes)
def _profile_lanes(fpool, ptab, k, t):
    if isinstance(t, types.Float):

        def one_time(fpool, ptab, k, t):
            value, integral, slope = profile_value(fpool, ptab, k, t)
            return V.splat(value), V.splat(integral), V.splat(slope)

        return one_time
    if isinstance(t, types.Array):

        def lane_times(fpool, ptab, k, t):
            shared = True
            for lane in range(1, L):
                shared = shared and t[lane] == t[0]
            if shared:  # lanes on one clock (RK4, shared steps): one evaluation serves all
                value, integral, slope = profile_value(fpool, ptab, k, t[0])
                return V.splat(value), V.splat(integral), V.splat(slope)
            value, integral, slope = V.splat(0.0), V.splat(0.0), V.splat(0.0)
            for lane in range(L):
                v, i, s = profile_value(fpool, ptab, k, t[lane])
                value = V.insert(value, lane, v)
                integral = V.insert(integral, lane, i)
                slope = V.insert(slope, lane, s)
            return value, integral, slope

        return lane_times
    return None


@nb.njit(cache=True)
def spin_up(duration, t):
    """p, its integral from 0 and its slope for Kane's spin-up over ``duration``: p = x -
    sin(2 pi x) / (2 pi), x = t / T, for t < T, then 1."""
    if t >= duration:
        return 1.0, t - 0.5 * duration, 0.0
    if t <= 0.0:
        return 0.0, 0.0, 0.0
    phase = 2.0 * np.pi * t / duration
    value = t / duration - np.sin(phase) / (2.0 * np.pi)
    integral = 0.5 * t * t / duration + duration / (4.0 * np.pi**2) * (np.cos(phase) - 1.0)
    return value, integral, (1.0 - np.cos(phase)) / duration


@nb.njit(cache=True)
def segment(ts, vs, cs, t):
    m = ts.shape[0]
    if t < ts[0]:
        return vs[0], cs[0] + vs[0] * (t - ts[0]), 0.0
    if t >= ts[m - 1]:
        return vs[m - 1], cs[m - 1] + vs[m - 1] * (t - ts[m - 1]), 0.0
    i = 0
    while ts[i + 1] < t:
        i += 1
    h = ts[i + 1] - ts[i]
    slope = (vs[i + 1] - vs[i]) / h
    tau = t - ts[i]
    return vs[i] + slope * tau, cs[i] + vs[i] * tau + 0.5 * slope * tau * tau, slope


@nb.njit(cache=True)
def rotation_matrix(axis, angle, out):
    """Rodrigues rotation matrix into out (3, 3)."""
    c = np.cos(angle)
    s = np.sin(angle)
    x, y, z = axis[0], axis[1], axis[2]
    v = 1.0 - c
    out[0, 0] = c + x * x * v
    out[0, 1] = x * y * v - z * s
    out[0, 2] = x * z * v + y * s
    out[1, 0] = y * x * v + z * s
    out[1, 1] = c + y * y * v
    out[1, 2] = y * z * v - x * s
    out[2, 0] = z * x * v - y * s
    out[2, 1] = z * y * v + x * s
    out[2, 2] = c + z * z * v


@nb.njit(cache=True, fastmath=V.FAST)
def frame_rotations(t, p, bi, bf, fpool, ptab, rot, rot_a, rot3):
    """Angle, speed, acceleration (``rot``, bodies 3 L) and A(t) (``rot_a``, bodies 9 L)
    of every rotating body at time t, per lane (the speed is a parameter, so A
    differs by lane); t is one time or a time per lane (:func:`profile_lanes`);
    ``rot3`` (3, 3) is scratch."""
    for b in range(bi.shape[0]):
        if bi[b, B_KIND] == KIND_ROTATING:
            speed = V.load(p, L * bi[b, B_SPEED])
            value, integral, slope = profile_lanes(fpool, ptab, bi[b, B_PROF], t)
            V.store(rot, L * (3 * b), speed * integral)
            V.store(rot, L * (3 * b + 1), speed * value)
            V.store(rot, L * (3 * b + 2), speed * slope)
            for lane in range(L):
                rotation_matrix(bf[b, 12:15], rot[L * 3 * b + lane], rot3)
                for r in range(3):
                    for c in range(3):
                        rot_a[L * (9 * b + 3 * r + c) + lane] = rot3[r, c]


@nb.njit(cache=True)
def frame_matrix(rot_a, b):
    """The nine entries of body b's rotation matrix A, row by row, as lane vectors."""
    r9 = L * 9 * b
    return (
        V.load(rot_a, r9),
        V.load(rot_a, r9 + L),
        V.load(rot_a, r9 + 2 * L),
        V.load(rot_a, r9 + 3 * L),
        V.load(rot_a, r9 + 4 * L),
        V.load(rot_a, r9 + 5 * L),
        V.load(rot_a, r9 + 6 * L),
        V.load(rot_a, r9 + 7 * L),
        V.load(rot_a, r9 + 8 * L),
    )


@nb.njit(cache=True)
def body_row(bi, b):
    """Kind, first coordinate, translations, modes, first and end tracked node of body b."""
    return bi[b, B_KIND], bi[b, B_DOF0], bi[b, B_NTR], bi[b, B_NM], bi[b, B_NODE0], bi[b, B_NODE1]


@nb.njit(cache=True, fastmath=V.FAST)
def node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v):
    """Inertial positions and velocities of the tracked nodes into ``node_x``, ``node_v``
    (tracked 3 L)."""
    for b in range(bi.shape[0]):
        kind, dof0, ntr, nm, n0, n1 = body_row(bi, b)
        if n1 <= n0:
            continue  # no tracked nodes
        psit = bi[b, B_PSIT0]
        qd0 = dof0 + ntr
        width = 3 * (n1 - n0)
        base = 3 * n0
        # U = Psi q: four entries k of the transposed block per sweep over the modes, so
        # that eight independent FMA chains keep both FMA pipes busy
        k = 0
        while k < width:
            k1 = min(k + 1, width - 1)
            k2 = min(k + 2, width - 1)
            k3 = min(k + 3, width - 1)
            p0 = V.splat(0.0)
            p1 = V.splat(0.0)
            p2 = V.splat(0.0)
            p3 = V.splat(0.0)
            w0 = V.splat(0.0)
            w1 = V.splat(0.0)
            w2 = V.splat(0.0)
            w3 = V.splat(0.0)
            for j in range(nm):
                q = V.load(x, L * (qd0 + j))
                v = V.load(x, L * (ndof + qd0 + j))
                row = psit + j * width
                r0 = V.broadcast(fpool, row + k)
                r1 = V.broadcast(fpool, row + k1)
                r2 = V.broadcast(fpool, row + k2)
                r3 = V.broadcast(fpool, row + k3)
                p0 = V.fma(r0, q, p0)
                w0 = V.fma(r0, v, w0)
                p1 = V.fma(r1, q, p1)
                w1 = V.fma(r1, v, w1)
                p2 = V.fma(r2, q, p2)
                w2 = V.fma(r2, v, w2)
                p3 = V.fma(r3, q, p3)
                w3 = V.fma(r3, v, w3)
            # tail entries (k1..k3 clamped to the last one) are written repeatedly, same value
            V.store(node_x, L * (base + k3), p3)
            V.store(node_v, L * (base + k3), w3)
            V.store(node_x, L * (base + k2), p2)
            V.store(node_v, L * (base + k2), w2)
            V.store(node_x, L * (base + k1), p1)
            V.store(node_v, L * (base + k1), w1)
            V.store(node_x, L * (base + k), p0)
            V.store(node_v, L * (base + k), w0)
            k += 4
        if kind == KIND_ROTATING:
            # x = o + A y, v = A (Omega e x y + ydot), y = xbar + u
            om = V.load(rot, L * (3 * b + 1))
            e0 = bf[b, 12]
            e1 = bf[b, 13]
            e2 = bf[b, 14]
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = frame_matrix(rot_a, b)
            o0 = bf[b, 0]
            o1 = bf[b, 1]
            o2 = bf[b, 2]
            for i in range(n0, n1):
                m = L * 3 * i
                u0 = V.load(node_x, m) + node_xbar[i, 0]
                u1 = V.load(node_x, m + L) + node_xbar[i, 1]
                u2 = V.load(node_x, m + 2 * L) + node_xbar[i, 2]
                z0 = V.load(node_v, m) + om * (e1 * u2 - e2 * u1)
                z1 = V.load(node_v, m + L) + om * (e2 * u0 - e0 * u2)
                z2 = V.load(node_v, m + 2 * L) + om * (e0 * u1 - e1 * u0)
                V.store(node_x, m, a00 * u0 + a01 * u1 + a02 * u2 + o0)
                V.store(node_x, m + L, a10 * u0 + a11 * u1 + a12 * u2 + o1)
                V.store(node_x, m + 2 * L, a20 * u0 + a21 * u1 + a22 * u2 + o2)
                V.store(node_v, m, a00 * z0 + a01 * z1 + a02 * z2)
                V.store(node_v, m + L, a10 * z0 + a11 * z1 + a12 * z2)
                V.store(node_v, m + 2 * L, a20 * z0 + a21 * z1 + a22 * z2)
        else:
            r0 = V.splat(bf[b, 0])
            r1 = V.splat(bf[b, 1])
            r2 = V.splat(bf[b, 2])
            w0 = V.splat(0.0)
            w1 = V.splat(0.0)
            w2 = V.splat(0.0)
            for a in range(ntr):
                sa = V.load(x, L * (dof0 + a))
                va = V.load(x, L * (ndof + dof0 + a))
                r0 = r0 + bf[b, 3 + 3 * a] * sa
                r1 = r1 + bf[b, 4 + 3 * a] * sa
                r2 = r2 + bf[b, 5 + 3 * a] * sa
                w0 = w0 + bf[b, 3 + 3 * a] * va
                w1 = w1 + bf[b, 4 + 3 * a] * va
                w2 = w2 + bf[b, 5 + 3 * a] * va
            for i in range(n0, n1):
                m = L * 3 * i
                V.store(node_x, m, V.load(node_x, m) + (r0 + node_xbar[i, 0]))
                V.store(node_x, m + L, V.load(node_x, m + L) + (r1 + node_xbar[i, 1]))
                V.store(node_x, m + 2 * L, V.load(node_x, m + 2 * L) + (r2 + node_xbar[i, 2]))
                V.store(node_v, m, V.load(node_v, m) + w0)
                V.store(node_v, m + L, V.load(node_v, m + L) + w1)
                V.store(node_v, m + 2 * L, V.load(node_v, m + 2 * L) + w2)


@nb.njit(cache=True, inline="always")
def _loaded(f0, f1, f2):
    """True if the force (f0, f1, f2) is not zero in some lane (NaN counts as loaded)."""
    size = V.vabs(f0) + V.vabs(f1) + V.vabs(f2)
    return not V.all_zero(size)


@nb.njit(cache=True, fastmath=V.FAST)
def map_node_forces(bi, bf, fpool, rot_a, node_f, q_gen):
    """Generalised forces of the tracked nodes' forces, all lanes per vector.

    ``node_f`` (tracked 3 L) is rotated to the body frames in place; the results
    are added to ``q_gen`` (n L): one axpy over the modes per node loaded in some
    lane. A node unloaded in one lane adds exact zeros there, so a lane's sum does
    not depend on the other lanes (a dense product chosen when many nodes are
    loaded in any lane would give a lane other roundings beside other samples).
    """
    zero = V.splat(0.0)
    for b in range(bi.shape[0]):
        kind, dof0, ntr, nm, n0, n1 = body_row(bi, b)
        if n1 <= n0:
            continue  # no tracked nodes
        qd0 = dof0 + ntr
        loaded = 0
        sum0 = zero
        sum1 = zero
        sum2 = zero
        for i in range(n0, n1):
            m = L * 3 * i
            f0 = V.load(node_f, m)
            f1 = V.load(node_f, m + L)
            f2 = V.load(node_f, m + 2 * L)
            sum0 = sum0 + f0
            sum1 = sum1 + f1
            sum2 = sum2 + f2
            loaded += _loaded(f0, f1, f2)
        if loaded == 0:
            continue
        for a in range(ntr):
            d = L * (dof0 + a)
            g = bf[b, 3 + 3 * a] * sum0 + bf[b, 4 + 3 * a] * sum1 + bf[b, 5 + 3 * a] * sum2
            V.store(q_gen, d, V.load(q_gen, d) + g)
        if kind == KIND_ROTATING:  # to the body frame, in place
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = frame_matrix(rot_a, b)
            for i in range(n0, n1):
                m = L * 3 * i
                f0 = V.load(node_f, m)
                f1 = V.load(node_f, m + L)
                f2 = V.load(node_f, m + 2 * L)
                V.store(node_f, m, a00 * f0 + a10 * f1 + a20 * f2)
                V.store(node_f, m + L, a01 * f0 + a11 * f1 + a21 * f2)
                V.store(node_f, m + 2 * L, a02 * f0 + a12 * f1 + a22 * f2)
        if nm == 0:
            continue
        # eight modes at a time, their sums in registers over the loaded nodes (in node
        # order: the sums of one mode at a time); modes past the last repeat it
        psi0 = bi[b, B_PSI0]
        j = 0
        while j < nm:
            last = nm - 1
            j1, j2, j3 = min(j + 1, last), min(j + 2, last), min(j + 3, last)
            j4, j5, j6, j7 = min(j + 4, last), min(j + 5, last), min(j + 6, last), min(j + 7, last)
            d = L * qd0
            s0, s1 = V.load(q_gen, d + L * j), V.load(q_gen, d + L * j1)
            s2, s3 = V.load(q_gen, d + L * j2), V.load(q_gen, d + L * j3)
            s4, s5 = V.load(q_gen, d + L * j4), V.load(q_gen, d + L * j5)
            s6, s7 = V.load(q_gen, d + L * j6), V.load(q_gen, d + L * j7)
            for i in range(n0, n1):
                m = L * 3 * i
                f0 = V.load(node_f, m)
                f1 = V.load(node_f, m + L)
                f2 = V.load(node_f, m + 2 * L)
                if not _loaded(f0, f1, f2):
                    continue
                row = psi0 + (i - n0) * 3 * nm
                s0 = s0 + _mode_force(fpool, row, nm, j, f0, f1, f2)
                s1 = s1 + _mode_force(fpool, row, nm, j1, f0, f1, f2)
                s2 = s2 + _mode_force(fpool, row, nm, j2, f0, f1, f2)
                s3 = s3 + _mode_force(fpool, row, nm, j3, f0, f1, f2)
                s4 = s4 + _mode_force(fpool, row, nm, j4, f0, f1, f2)
                s5 = s5 + _mode_force(fpool, row, nm, j5, f0, f1, f2)
                s6 = s6 + _mode_force(fpool, row, nm, j6, f0, f1, f2)
                s7 = s7 + _mode_force(fpool, row, nm, j7, f0, f1, f2)
            # repeated modes hold equal sums, so the order of these stores does not matter
            V.store(q_gen, d + L * j7, s7)
            V.store(q_gen, d + L * j6, s6)
            V.store(q_gen, d + L * j5, s5)
            V.store(q_gen, d + L * j4, s4)
            V.store(q_gen, d + L * j3, s3)
            V.store(q_gen, d + L * j2, s2)
            V.store(q_gen, d + L * j1, s1)
            V.store(q_gen, d + L * j, s0)
            j += 8


@nb.njit(cache=True, fastmath=V.FAST, inline="always")
def _mode_force(fpool, row, nm, j, f0, f1, f2):
    """Mode j's share ``Psi_j^T f`` of a node's force (f0, f1, f2); ``row``: the node's
    first mode-shape entry."""
    g = V.broadcast(fpool, row + j) * f0 + V.broadcast(fpool, row + nm + j) * f1
    return g + V.broadcast(fpool, row + 2 * nm + j) * f2
