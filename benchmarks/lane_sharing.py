"""How often the four lanes of a lockstep block find a contact slave in the same master cell.

    python benchmarks/lane_sharing.py [--quick]

The lockstep kernel (:mod:`fuzzymbs.mbs.kernels`) interpolates the master
surface with vector loads when all four lanes of a block share the slave's
master cell, and gathers lane by lane otherwise. This script integrates the
blocks of brake study 1 (the 33 samples of the reduced method; 8 full blocks)
over 10 ms at dt = 1 us (1 ms with ``--quick``) and, every 10th step, looks up
the cell of every slave of every contact pass in every lane with the scalar
:func:`fuzzymbs.mbs.kernels.charts.locate`, from the chart coordinates the kernel
itself computed. It prints one JSON line: the share of look-ups whose four
lanes agree (on the patch and in the same cell), per pass and overall.
"""

from __future__ import annotations

import argparse
import json

import numba as nb
import numpy as np

from fuzzymbs.mbs.kernels import charts, contact, rhs
from fuzzymbs.mbs.kernels import layout as K
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.study.study import Study

STUDY1 = {
    "pad_spring_stiffness": {"type": "triangular", "modal": 200e3, "spread": 0.1},
    "caliper_spring_stiffness": {"type": "triangular", "modal": 1e3, "spread": 0.1},
    "nodal_force": {"type": "triangular", "modal": 16e3, "spread": 0.01},
}


@nb.njit(cache=True)
def _count_shared(sysdata, rows, n_steps, dt, every, counts):
    """RK4 of one block (rows: 4 parameter rows); counts[c] += (shared, looked up)."""
    lanes = LANES
    nstate = 2 * sysdata[0]
    ci, cf, fpool = sysdata[11], sysdata[12], sysdata[6]
    work = rhs.make_work(sysdata)
    x = np.zeros(nstate * lanes)
    p = np.empty(rows.shape[1] * lanes)
    for lane in range(lanes):
        for i in range(rows.shape[1]):
            p[lanes * i + lane] = rows[lane, i]
    k1 = np.empty_like(x)
    k2 = np.empty_like(x)
    k3 = np.empty_like(x)
    k4 = np.empty_like(x)
    xt = np.empty_like(x)
    clock = np.empty(lanes)  # the lanes' time, as the package's RK4 passes it
    for step in range(n_steps):
        t = step * dt
        clock[:] = t
        rhs.rhs(clock, x, k1, p, sysdata, work)  # also the node kinematics of x
        if step % every == 0:
            chart_uv = work[9]
            for c in range(ci.shape[0]):
                contact.contact_pass(c, x, p, sysdata, work)  # chart coordinates of pass c
                nu, nv = ci[c, K.C_NU], ci[c, K.C_NV]
                ugrid = fpool[ci[c, K.C_U0] : ci[c, K.C_U0] + nu]
                vgrid = fpool[ci[c, K.C_V0] : ci[c, K.C_V0] + nv]
                periodic = ci[c, K.C_PERIODIC] == 1
                scales = charts.pass_scales(cf, c)
                nslave = ci[c, K.C_NSLAVE]
                for k in range(nslave):
                    first = (False, -1, -1)
                    same = True
                    for lane in range(lanes):
                        u = chart_uv[lanes * k + lane]
                        v = chart_uv[lanes * (nslave + k) + lane]
                        on, i, j, _, _ = charts.locate(u, v, ugrid, vgrid, periodic, scales)
                        if lane == 0:
                            first = (on, i, j)
                        elif (on, i, j) != first:
                            same = False
                    counts[c, 0] += 1 if (same and first[0]) else 0
                    counts[c, 1] += 1
        for m in range(x.size):
            xt[m] = x[m] + 0.5 * dt * k1[m]
        clock[:] = t + 0.5 * dt
        rhs.rhs(clock, xt, k2, p, sysdata, work)
        for m in range(x.size):
            xt[m] = x[m] + 0.5 * dt * k2[m]
        rhs.rhs(clock, xt, k3, p, sysdata, work)
        for m in range(x.size):
            xt[m] = x[m] + dt * k3[m]
        clock[:] = t + dt
        rhs.rhs(clock, xt, k4, p, sysdata, work)
        for m in range(x.size):
            x[m] += dt / 6.0 * (k1[m] + 2.0 * k2[m] + 2.0 * k3[m] + k4[m])


def run(quick: bool = False) -> dict:
    """Share of contact look-ups whose four lanes share the master cell, study 1."""
    model = DiscBrake(integrator="rk4")
    study = Study(model, STUDY1, method="reduced", levels=[0.0, 0.25, 0.5, 0.75, 1.0])
    names = list(STUDY1)
    samples = np.asarray(study.plan.samples)
    params = model.compiled.parameters.values({name: samples[:, i] for i, name in enumerate(names)})
    data = model.compiled.data
    n_steps = 1000 if quick else 10_000
    counts = np.zeros((data[11].shape[0], 2), dtype=np.int64)
    blocks = params.shape[0] // LANES
    for b in range(blocks):
        rows = np.ascontiguousarray(params[LANES * b : LANES * (b + 1)])
        _count_shared(data, rows, n_steps, 1e-6, 10, counts)
    return {
        "blocks": blocks,
        "steps": n_steps,
        "lookups": int(counts[:, 1].sum()),
        "shared_fraction": float(counts[:, 0].sum() / counts[:, 1].sum()),
        "shared_fraction_per_pass": [float(a / n) for a, n in counts],
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 ms instead of 10 ms")
    print(json.dumps(run(parser.parse_args().quick)))
