"""The brake equations in plain NumPy, one sample at a time (baseline of the brake benchmark).

An independent implementation of the right-hand side that
:func:`fuzzymbs.mbs.kernels.rhs.rhs` evaluates, written the way a NumPy user would
write it: array expressions over nodes and modes (mode-shape products with
``@``, contact over all slave nodes at once with masks, ``np.add.at`` to
scatter forces), one sample per call, a Python RK4 loop around it. It reads the
same compiled system arrays (``CompiledSystem.data``: mode shapes, patch grids,
spring matrices; layout in :mod:`fuzzymbs.mbs.system`) so that the model is
identical; every operation on them is written here anew. The smoke test checks
that it reproduces the compiled kernel's trajectory.

Supported: what the brake uses -- rotating, translating and fixed bodies,
linear spring groups, nodal forces, penalty contact with regularised Coulomb
friction on polar or Cartesian charts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from fuzzymbs.mbs.kernels import layout as K

TWO_PI = 2.0 * np.pi


def _profile(fpool: np.ndarray, ptab: np.ndarray, k: int, t: float) -> tuple[float, float, float]:
    """Value, integral from t = 0 and slope of piecewise-linear profile k at time t."""
    start, count = ptab[k]
    times = fpool[start : start + count]
    values = fpool[start + count : start + 2 * count]
    integrals = fpool[start + 2 * count : start + 3 * count]

    def at(time: float) -> tuple[float, float, float]:
        if time <= times[0]:
            return values[0], integrals[0] + values[0] * (time - times[0]), 0.0
        if time >= times[-1]:
            return values[-1], integrals[-1] + values[-1] * (time - times[-1]), 0.0
        i = int(np.searchsorted(times, time) - 1)
        slope = (values[i + 1] - values[i]) / (times[i + 1] - times[i])
        tau = time - times[i]
        return (
            values[i] + slope * tau,
            integrals[i] + values[i] * tau + 0.5 * slope * tau * tau,
            slope,
        )

    value, integral, slope = at(t)
    return value, integral - at(0.0)[1], slope


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues rotation matrix about the unit ``axis``."""
    skew = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * skew + (1.0 - np.cos(angle)) * (skew @ skew)


def _locate(grid: np.ndarray, value: np.ndarray, periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Cell index (-1 outside) and local coordinate of each value on a (near-)uniform grid."""
    n = grid.size
    g0 = grid[0]
    if periodic:
        value = np.where(value < g0, value + TWO_PI, value)
        value = np.where(value >= g0 + TWO_PI, value - TWO_PI, value)
        i = np.minimum(((value - g0) * (n / TWO_PI)).astype(np.int64), n - 1)
        upper_all = np.append(grid[1:], g0 + TWO_PI)
        for _ in range(n):  # at most a cell or two on a near-uniform grid
            down = (i > 0) & (value < grid[i])
            up = (i < n - 1) & (value > upper_all[i])
            if not (down.any() or up.any()):
                break
            i = i - down + up
        return i, (value - grid[i]) / (upper_all[i] - grid[i])
    last = grid[-1]
    outside = (value < g0) | (value > last)
    inside = np.where(outside, g0, value)
    i = np.minimum(((inside - g0) * ((n - 1) / (last - g0))).astype(np.int64), n - 2)
    for _ in range(n):
        down = (i > 0) & (inside < grid[i])
        up = (i < n - 2) & (inside > grid[np.minimum(i + 1, n - 1)])
        if not (down.any() or up.any()):
            break
        i = i - down + up
    xi = (inside - grid[i]) / (grid[i + 1] - grid[i])
    return np.where(outside, -1, i), xi


@dataclass
class ContactStats:
    """Slave nodes checked and nodes in contact, summed over right-hand-side calls."""

    calls: int = 0
    checked: int = 0
    on_patch: int = 0
    active: int = 0


class NumpyRHS:
    """f(t, x) of one sample: plain NumPy on the compiled system arrays.

    Parameters
    ----------
    data : tuple
        ``CompiledSystem.data``.
    params : (n_slots,) array
        The sample's parameter row (``compiled.parameters.values(samples)[i]``).
    """

    def __init__(self, data: tuple, params: np.ndarray) -> None:
        (
            self.ndof,
            self.bi,
            self.bf,
            self.node_xbar,
            self.dof_k2,
            self.dof_c,
            self.fpool,
            self.ipool,
            self.ptab,
            self.lg,
            self.nfi,
            self.ci,
            self.cf,
        ) = data
        self.p = np.asarray(params, dtype=float)
        self.stats = ContactStats()
        fpool, ipool = self.fpool, self.ipool
        self.bodies = []
        for row in self.bi:
            kind, dof0, ntr, nm, n0, n1 = (int(v) for v in row[:6])
            body: dict[str, Any] = {"kind": kind, "dof0": dof0, "ntr": ntr, "nm": nm}
            body["nodes"] = slice(n0, n1)
            width = 3 * (n1 - n0)
            psit = int(row[K.B_PSIT0])
            # (mode, node*3) block -> (node*3, mode): U = Psi q
            body["psi"] = fpool[psit : psit + nm * width].reshape(nm, width).T if width else None
            m0 = int(row[K.B_MAT0])
            if kind == K.KIND_TRANSLATING:
                body["schur_inv"] = fpool[m0 : m0 + ntr * ntr].reshape(ntr, ntr)
                body["coupling"] = fpool[m0 + ntr * ntr : m0 + ntr * ntr + ntr * nm].reshape(
                    ntr, nm
                )
            elif kind == K.KIND_ROTATING and nm:
                body["gyro"] = fpool[m0 : m0 + nm * nm].reshape(nm, nm)
                body["centri"] = fpool[m0 + nm * nm : m0 + 2 * nm * nm].reshape(nm, nm)
                body["centri_load"] = fpool[m0 + 2 * nm * nm : m0 + 2 * nm * nm + nm]
                body["euler_load"] = fpool[m0 + 2 * nm * nm + nm : m0 + 2 * nm * nm + 2 * nm]
            self.bodies.append(body)
        self.springs = []
        for d0, n, m0, ks, cs in self.lg:
            self.springs.append(
                (
                    ipool[d0 : d0 + n],
                    fpool[m0 : m0 + n * n].reshape(n, n),
                    fpool[m0 + n * n : m0 + 2 * n * n].reshape(n, n),
                    self.p[ks],
                    self.p[cs],
                )
            )
        self.contacts = []
        for c, row in enumerate(self.ci):
            nu, nv = int(row[K.C_NU]), int(row[K.C_NV])
            periodic = bool(row[K.C_PERIODIC])
            ncv = nv if periodic else nv - 1
            n0 = int(row[K.C_NORMAL0])
            self.contacts.append(
                {
                    "master": int(row[K.C_MBODY]),
                    "slaves": ipool[row[K.C_SLAVE0] : row[K.C_SLAVE0] + row[K.C_NSLAVE]],
                    "polar": row[K.C_KIND] == 1,
                    "periodic": periodic,
                    "u": fpool[row[K.C_U0] : row[K.C_U0] + nu],
                    "v": fpool[row[K.C_V0] : row[K.C_V0] + nv],
                    "grid": ipool[row[K.C_GRID0] : row[K.C_GRID0] + nu * nv].reshape(nu, nv),
                    "normals": fpool[n0 : n0 + 3 * (nu - 1) * ncv].reshape(nu - 1, ncv, 3),
                    "penalty": self.p[row[K.C_PEN]],
                    "mu": self.p[row[K.C_MU]],
                    "origin": self.cf[c, 0:3],
                    "axis_u": self.cf[c, 3:6],
                    "axis_v": self.cf[c, 6:9],
                    "eps2": self.cf[c, 9] ** 2,
                    "damping": self.cf[c, 10],
                }
            )

    # ----------------------------------------------------------------------------- pieces
    def _rotations(self, t: float) -> dict[int, tuple[float, float, float, np.ndarray]]:
        rot = {}
        for b, body in enumerate(self.bodies):
            if body["kind"] == K.KIND_ROTATING:
                speed = self.p[self.bi[b, K.B_SPEED]]
                value, integral, slope = _profile(self.fpool, self.ptab, self.bi[b, K.B_PROF], t)
                angle = speed * integral
                rot[b] = (angle, speed * value, speed * slope, _rotation(self.bf[b, 12:15], angle))
        return rot

    def _kinematics(self, x: np.ndarray, rot: dict) -> tuple[np.ndarray, np.ndarray]:
        ndof = self.ndof
        pos = np.empty_like(self.node_xbar)
        vel = np.empty_like(self.node_xbar)
        for b, body in enumerate(self.bodies):
            nodes = body["nodes"]
            if nodes.stop <= nodes.start:
                continue
            q0 = body["dof0"] + body["ntr"]
            q = x[q0 : q0 + body["nm"]]
            v = x[ndof + q0 : ndof + q0 + body["nm"]]
            u = (body["psi"] @ q).reshape(-1, 3)
            udot = (body["psi"] @ v).reshape(-1, 3)
            if body["kind"] == K.KIND_ROTATING:
                _, omega, _, a = rot[b]
                y = self.node_xbar[nodes] + u
                z = udot + omega * np.cross(self.bf[b, 12:15], y)
                pos[nodes] = self.bf[b, 0:3] + y @ a.T
                vel[nodes] = z @ a.T
            else:
                axes = self.bf[b, 3 : 3 + 3 * body["ntr"]].reshape(-1, 3)
                s = x[body["dof0"] : body["dof0"] + body["ntr"]]
                sdot = x[ndof + body["dof0"] : ndof + body["dof0"] + body["ntr"]]
                pos[nodes] = self.node_xbar[nodes] + u + self.bf[b, 0:3] + s @ axes
                vel[nodes] = udot + sdot @ axes
        return pos, vel

    def _contact(self, c: dict, x: np.ndarray, rot: dict, pos, vel, force) -> None:
        mb = c["master"]
        body = self.bodies[mb]
        origin = self.bf[mb, 0:3].copy()
        if body["kind"] == K.KIND_TRANSLATING:
            axes = self.bf[mb, 3 : 3 + 3 * body["ntr"]].reshape(-1, 3)
            origin += x[body["dof0"] : body["dof0"] + body["ntr"]] @ axes
        rotating = body["kind"] == K.KIND_ROTATING
        a = rot[mb][3] if rotating else np.eye(3)
        axis_u = a @ c["axis_u"]
        axis_v = a @ c["axis_v"]
        cu = origin @ axis_u + c["origin"] @ c["axis_u"]
        cv = origin @ axis_v + c["origin"] @ c["axis_v"]
        slaves = c["slaves"]
        xs = pos[slaves]
        a1 = xs @ axis_u - cu
        a2 = xs @ axis_v - cv
        if c["polar"]:
            u, v = np.hypot(a1, a2), np.arctan2(a2, a1)
        else:
            u, v = a1, a2
        i, xi = _locate(c["u"], u, False)
        j, eta = _locate(c["v"], v, c["periodic"])
        on = (i >= 0) & (j >= 0)
        self.stats.checked += slaves.size
        self.stats.on_patch += int(on.sum())
        slaves, xs, i, j, xi, eta = slaves[on], xs[on], i[on], j[on], xi[on], eta[on]
        nv = c["v"].size
        j1 = np.where(j + 1 < nv, j + 1, 0)
        grid = c["grid"]
        corners = np.stack([grid[i, j], grid[i + 1, j], grid[i + 1, j1], grid[i, j1]], axis=1)
        weights = np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta], axis=1)
        normal = c["normals"][i, j]
        if rotating:
            normal = normal @ a.T
        xm = np.einsum("sk,skc->sc", weights, pos[corners])
        gap = np.einsum("sc,sc->s", normal, xs - xm)
        vr = vel[slaves] - np.einsum("sk,skc->sc", weights, vel[corners])
        vn = np.einsum("sc,sc->s", normal, vr)
        fn = -c["penalty"] * gap - c["damping"] * vn
        active = (gap < 0.0) & (fn > 0.0)
        self.stats.active += int(active.sum())
        if not active.any():
            return
        normal, vr, vn, fn = normal[active], vr[active], vn[active], fn[active]
        vt = vr - vn[:, None] * normal
        scale = -c["mu"] * fn / np.sqrt(np.einsum("sc,sc->s", vt, vt) + c["eps2"])
        f = fn[:, None] * normal + scale[:, None] * vt
        np.add.at(force, slaves[active], f)
        np.add.at(
            force,
            corners[active].reshape(-1),
            -(weights[active][:, :, None] * f[:, None, :]).reshape(-1, 3),
        )

    # ------------------------------------------------------------------------------- f(t, x)
    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        ndof = self.ndof
        dx = np.empty_like(x)
        dx[:ndof] = x[ndof:]
        q_gen = np.zeros(ndof)
        rot = self._rotations(t)
        for idx, stiff, damp, k, c in self.springs:
            q_gen[idx] -= k * (stiff @ x[idx]) + (c * (damp @ x[ndof + idx]) if c else 0.0)
        for b, v0, prof, slot, rotating in self.nfi:
            magnitude = self.p[slot]
            if prof >= 0:
                magnitude *= _profile(self.fpool, self.ptab, prof, t)[0]
            body = self.bodies[b]
            dof0, ntr, nm = body["dof0"], body["ntr"], body["nm"]
            if rotating == 0:
                q_gen[dof0 : dof0 + ntr + nm] += magnitude * self.fpool[v0 : v0 + ntr + nm]
            else:
                angle = rot[b][0]
                vecs = self.fpool[v0 : v0 + 3 * nm].reshape(3, nm)
                cos, sin = np.cos(angle), np.sin(angle)
                q_gen[dof0 : dof0 + nm] += magnitude * (
                    cos * vecs[0] + (1 - cos) * vecs[1] - sin * vecs[2]
                )
        if len(self.contacts):
            self.stats.calls += 1
            pos, vel = self._kinematics(x, rot)
            force = np.zeros_like(pos)
            for contact in self.contacts:
                self._contact(contact, x, rot, pos, vel, force)
            for b, body in enumerate(self.bodies):
                nodes = body["nodes"]
                if nodes.stop <= nodes.start:
                    continue
                f = force[nodes]
                dof0, ntr, nm = body["dof0"], body["ntr"], body["nm"]
                if ntr:
                    axes = self.bf[b, 3 : 3 + 3 * ntr].reshape(-1, 3)
                    q_gen[dof0 : dof0 + ntr] += axes @ f.sum(axis=0)
                if body["kind"] == K.KIND_ROTATING:
                    f = f @ rot[b][3]  # A^T f per node, to the body frame
                if nm:
                    q_gen[dof0 + ntr : dof0 + ntr + nm] += body["psi"].T @ f.reshape(-1)
        for b, body in enumerate(self.bodies):
            dof0, ntr, nm = body["dof0"], body["ntr"], body["nm"]
            modal = slice(dof0 + ntr, dof0 + ntr + nm)
            q = x[modal]
            v = x[ndof + modal.start : ndof + modal.stop]
            q_gen[modal] -= self.dof_c[modal] * v + self.dof_k2[modal] * q
            if body["kind"] == K.KIND_ROTATING and nm:
                _, omega, alpha, _ = rot[b]
                q_gen[modal] -= (
                    omega * omega * (body["centri_load"] + body["centri"] @ q)
                    + alpha * (body["euler_load"] + body["gyro"] @ q)
                    + 2.0 * omega * (body["gyro"] @ v)
                )
            if body["kind"] == K.KIND_TRANSLATING:
                coupling = body["coupling"]
                acc_s = body["schur_inv"] @ (q_gen[dof0 : dof0 + ntr] - coupling @ q_gen[modal])
                dx[ndof + dof0 : ndof + dof0 + ntr] = acc_s
                dx[ndof + modal.start : ndof + modal.stop] = q_gen[modal] - coupling.T @ acc_s
            else:
                dx[ndof + modal.start : ndof + modal.stop] = q_gen[modal]
        return dx


def rk4_numpy(
    rhs: Any, x0: np.ndarray, dt: float, n_steps: int, record_every: int, out_w: np.ndarray
) -> np.ndarray:
    """Classic RK4 in a Python loop; outputs ``out_w @ x`` every ``record_every`` steps.

    Returns (n_out, n_steps // record_every + 1).
    """
    x = np.array(x0, dtype=float)
    records = [out_w @ x]
    for step in range(n_steps):
        t = step * dt
        k1 = rhs(t, x)
        k2 = rhs(t + 0.5 * dt, x + 0.5 * dt * k1)
        k3 = rhs(t + 0.5 * dt, x + 0.5 * dt * k2)
        k4 = rhs(t + dt, x + dt * k3)
        x = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        if (step + 1) % record_every == 0:
            records.append(out_w @ x)
    return np.array(records).T
