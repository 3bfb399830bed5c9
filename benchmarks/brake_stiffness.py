"""Where the brake's stiffness comes from, and what follows for its integrators and
sensitivities; one JSON line.

    python benchmarks/brake_stiffness.py [--parts explicit eigen jvp jvp_cost] [--t-end S]

The nominal brake sample (``DiscBrake()``'s bound parameters) over ``t_end`` (1 ms):

* ``explicit``: ROS34PW2 at rtol 1e-3 ... 1e-5 (the studies' tolerances) against
  SciPy's explicit pairs ``RK45`` (Dormand-Prince 5(4)) and ``DOP853`` at the same rtol
  on the engine's compiled right-hand side (``rhs_sample``), and ``RK45`` once more with
  the friction coefficient at zero: right-hand sides, steps and the outputs' largest
  deviation from ROS34PW2 at rtol 1e-7 relative to their peaks. An explicit pair whose
  right-hand sides do not fall with its tolerance is bound by stability, not accuracy.
* ``eigen``: the eigenvalues of the analytic Jacobian (``kernels/jacobian.py``) on the
  trajectory (RK45 at rtol 1e-8) at five times, with and without friction: the most
  negative real part, the largest imaginary part, and the step bounds they put on the
  explicit methods (Dormand-Prince 5(4) 3.3 / |lambda|, RK4 2.785 / |lambda| on the
  negative real axis; 2.83 / omega for RK4 on the imaginary axis).
* ``jvp``: for the three parameters of study 1, the sensitivity direction ``S = p dx/dp``
  (a difference of two trajectories, RK45 at rtol 1e-8, the parameter moved by 1e-3 of
  its value) at the same five times, and the analytic Jacobian times S against the
  directional differences of the right-hand side the forward sensitivities take
  (``kernels/sensitivities.py``, eps 1e-4) and a central one (eps 1e-6): relative
  2-norm of the difference over the velocity rows (``resolved``: S is more than the two
  trajectories' noise, :data:`RESOLVED`). This is the accuracy a sensitivity
  right-hand side built from the contact's recorded force-law derivatives instead of a
  second right-hand side would have (docs/benchmarks.md, "Forward sensitivities").
* ``jvp_cost``: that product prototyped (:func:`linear_contact_forces`: the nodes'
  motion, the recorded force law per contact point, the force map) at the k direction's
  state moved by eps 1e-4, against the difference of the contact passes' generalised
  forces there (relative 2-norm), and timed against a right-hand side at the same state
  (one block of four equal lanes, the best of five rounds of 2,000 compiled calls); the
  product's time counts the right-hand side without contact (springs, nodal forces, the
  equations of motion) too.

SciPy's runs make one Python call per right-hand side: their CPU times are not the
engine's; the counts are what compares.
"""

from __future__ import annotations

import argparse
import json
import time

import numba as nb
import numpy as np
import scipy.integrate

from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels import simd as V
from fuzzymbs.mbs.kernels.contact import JREC, contact_pass
from fuzzymbs.mbs.kernels.jacobian import jacobian
from fuzzymbs.mbs.kernels.kinematics import map_node_forces, node_kinematics
from fuzzymbs.mbs.kernels.layout import C_NSLAVE, C_SLAVE0
from fuzzymbs.mbs.kernels.rhs import make_work, rhs, rhs_sample
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

OUTPUTS = {
    "y_lpad": Coordinate("lower_pad", 0),
    "y_upad": Coordinate("upper_pad", 0),
    "y_cali": Coordinate("caliper", 0),
}
RECORD = 1e-5  # s
RTOLS = (1e-3, 1e-4, 1e-5)
REFERENCE_RTOL = 1e-7
#: stability bounds on the negative real axis (|lambda| h at most this): Dormand-Prince
#: 5(4) about 3.3, classic RK4 2.785 (Hairer and Wanner, Solving ODEs II, IV.2); RK4 on
#: the imaginary axis 2 sqrt(2)
DOPRI5_REAL = 3.3
RK4_REAL = 2.785
RK4_IMAGINARY = 2.0 * np.sqrt(2.0)
#: the study-1 parameters and the relative change of their trajectory differences
STUDY1 = ("pad_spring_stiffness", "caliper_spring_stiffness", "nodal_force")
TRAJECTORY_CHANGE = 1e-3
#: the trajectories' tolerance: RK45 is bound by stability here, so a tight one costs
#: little (the ``explicit`` part: 5 % more right-hand sides from rtol 1e-3 to 1e-5), and
#: keeps the integration noise in the difference of two trajectories small
TRAJECTORY_RTOL = 1e-8
#: a direction S smaller than this fraction of the state is the two trajectories'
#: integration noise, not a sensitivity (the caliper springs' S at 10 and 25 us: 2e-12
#: and 1.3e-10 of the state, their comparisons 66 to 113 % off; every other S of the
#: 0.1 and 1 ms runs above this, the smallest of the 0.1 ms run 3.8e-5): such rows are
#: marked ``resolved = False``
RESOLVED = 1e-5
L = LANES


def eval_times(t_end: float) -> np.ndarray:
    """Five times on the run: a tenth, a quarter, half, three quarters and the end."""
    return t_end * np.array([0.1, 0.25, 0.5, 0.75, 1.0])


class Brake:
    """The compiled nominal brake and one sample's right-hand side and Jacobian."""

    def __init__(self, t_end: float) -> None:
        self.t_end = t_end
        self.compiled = DiscBrake(t_end=t_end).compiled
        self.n = self.compiled.n_dofs
        self.work = make_work(self.compiled.data)
        self.out_w = np.array([self.compiled.output_functional(s) for s in OUTPUTS.values()])
        self._trajectories: dict[bytes, np.ndarray] = {}

    def parameters(self, sample: dict[str, float] | None = None) -> np.ndarray:
        values = {k: np.atleast_1d(v) for k, v in (sample or {}).items()}
        return self.compiled.parameters.values(values)[0]

    def nominal(self, name: str) -> float:
        return float(self.compiled.parameters.defaults()[name])

    def rhs(self, p: np.ndarray):
        def f(t, x):
            return rhs_sample(t, np.ascontiguousarray(x), p, self.compiled.data, self.work)

        return f

    def jacobian(self, t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The full 2n x 2n Jacobian ``[[0, I], [A_q, B_v]]`` (lane 0 of a block)."""
        n = self.n
        dx, jq, jv = np.empty(2 * n * L), np.empty(n * n * L), np.empty(n * n * L)
        lanes = np.ascontiguousarray(np.repeat(x, L))
        jacobian(np.full(L, t), lanes, np.repeat(p, L), self.compiled.data, self.work, dx, jq, jv)
        full = np.zeros((2 * n, 2 * n))
        full[:n, n:] = np.eye(n)
        full[n:, :n] = jq.reshape(n, n, L)[:, :, 0]
        full[n:, n:] = jv.reshape(n, n, L)[:, :, 0]
        return full

    def scipy_run(self, p: np.ndarray, method: str, rtol: float, times: np.ndarray):
        """``solve_ivp`` from rest at ``rtol`` (atol 1e-5 rtol, as the engine's default)."""
        x0 = self.compiled.zero_state(1)[0]
        return scipy.integrate.solve_ivp(
            self.rhs(p),
            (0.0, self.t_end),
            x0,
            method=method,
            t_eval=times,
            rtol=rtol,
            atol=1e-5 * rtol,
            first_step=1e-8,
        )

    def trajectory(self, p: np.ndarray, times: np.ndarray) -> np.ndarray:
        """The states at ``times`` (2n, T), RK45 at ``TRAJECTORY_RTOL``; each parameter row
        and set of times integrated once (the parts share the nominal run)."""
        key = p.tobytes() + times.tobytes()
        if key not in self._trajectories:
            self._trajectories[key] = self.scipy_run(p, "RK45", TRAJECTORY_RTOL, times).y
        return self._trajectories[key]


def record_times(t_end: float) -> np.ndarray:
    times = np.arange(round(t_end / RECORD) + 1) * RECORD
    times[-1] = t_end
    return times


def deviation(outputs: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    """Largest deviation over the outputs relative to each reference output's peak."""
    return max(
        float(np.max(np.abs(outputs[k] - reference[k])) / np.max(np.abs(reference[k])))
        for k in OUTPUTS
    )


def explicit(brake: Brake) -> list[dict]:
    """ROS34PW2 against the explicit pairs (module docstring)."""

    def ros(rtol):
        cpu = time.process_time()
        result = simulate(
            brake.compiled,
            {},
            t_end=brake.t_end,
            dt=1e-7,
            record_interval=RECORD,
            outputs=OUTPUTS,
            integrator="ros34pw2",
            tolerance=Tolerance(rtol),
        )
        return result, time.process_time() - cpu

    ros(RTOLS[0])  # compiled
    tight = ros(REFERENCE_RTOL)[0]
    if tight.failed[0]:
        raise RuntimeError(
            f"the rtol {REFERENCE_RTOL:g} reference failed: {tight.failure_reason[0]}"
        )
    reference = {k: v[0] for k, v in tight.outputs.items()}
    rows = []
    for rtol in RTOLS:
        result, cpu = ros(rtol)
        accepted, rejected = (int(v) for v in result.step_counts[0])
        rhs, jacobians, lus = (int(v) for v in result.work_counts[0])
        rows.append(
            {
                "integrator": "ROS34PW2",
                "rtol": rtol,
                "rhs": rhs,
                "jacobians": jacobians,
                "lus": lus,
                "steps": accepted + rejected,
                "failed": bool(result.failed[0]),
                "error": deviation({k: v[0] for k, v in result.outputs.items()}, reference),
                "cpu_s": round(cpu, 3),
            }
        )
    times = record_times(brake.t_end)
    nominal = brake.parameters()
    frictionless = brake.parameters({"friction_coefficient": 0.0})
    cases = [(m, r, nominal, "") for m in ("RK45", "DOP853") for r in RTOLS]
    cases.append(("RK45", RTOLS[1], frictionless, "friction_coefficient 0"))
    for method, rtol, p, note in cases:
        cpu = time.process_time()
        solution = brake.scipy_run(p, method, rtol, times)
        cpu = time.process_time() - cpu
        y = brake.out_w @ solution.y
        row = {
            "integrator": f"SciPy {method}",
            "rtol": rtol,
            "rhs": int(solution.nfev),
            "success": bool(solution.success),
            "cpu_s": round(cpu, 3),
            "note": note,
        }
        if solution.success and not note:  # the frictionless model has another answer
            row["error"] = deviation({k: y[i] for i, k in enumerate(OUTPUTS)}, reference)
        rows.append(row)
    return rows


def eigen(brake: Brake) -> list[dict]:
    """The Jacobian's spectrum on the trajectory, with and without friction."""
    times = eval_times(brake.t_end)
    rows = []
    for note, sample in (("", {}), ("friction_coefficient 0", {"friction_coefficient": 0.0})):
        p = brake.parameters(sample)
        states = brake.trajectory(p, times)
        for i, t in enumerate(times):
            values = np.linalg.eigvals(brake.jacobian(t, states[:, i], p))
            most_negative = float(np.min(values.real))
            omega = float(np.max(np.abs(values.imag)))
            rows.append(
                {
                    "note": note,
                    "t_s": float(t),
                    "most_negative_real": most_negative,
                    "largest_real": float(np.max(values.real)),
                    "largest_imaginary": omega,
                    "dopri5_step_bound_s": DOPRI5_REAL / max(-most_negative, 1e-300),
                    "rk4_step_bound_s": min(
                        RK4_REAL / max(-most_negative, 1e-300), RK4_IMAGINARY / omega
                    ),
                }
            )
    return rows


def jvp(brake: Brake) -> list[dict]:
    """The analytic Jacobian times the sensitivity directions against the differences."""
    times = eval_times(brake.t_end)
    p0 = brake.parameters()
    base = brake.trajectory(p0, times)
    f = brake.rhs(p0)
    n = brake.n
    rows = []
    for name in STUDY1:
        value = brake.nominal(name)
        moved = brake.trajectory(brake.parameters({name: value * (1 + TRAJECTORY_CHANGE)}), times)
        for i, t in enumerate(times):
            x = np.ascontiguousarray(base[:, i])
            s = (moved[:, i] - x) / TRAJECTORY_CHANGE  # p dx/dp
            analytic = (brake.jacobian(t, x, p0) @ s)[n:]
            f0 = f(t, x)
            forward = ((f(t, x + 1e-4 * s) - f0) / 1e-4)[n:]
            central = ((f(t, x + 1e-6 * s) - f(t, x - 1e-6 * s)) / 2e-6)[n:]
            rows.append(
                {
                    "parameter": name,
                    "t_s": float(t),
                    "direction_norm": float(np.linalg.norm(s)),
                    "resolved": bool(np.linalg.norm(s) >= RESOLVED * np.linalg.norm(x)),
                    "vs_forward_1e-4": float(
                        np.linalg.norm(analytic - forward) / np.linalg.norm(forward)
                    ),
                    "vs_central_1e-6": float(
                        np.linalg.norm(analytic - central) / np.linalg.norm(central)
                    ),
                }
            )
    return rows


#: calls per timing of ``jvp_cost`` (each the best of ``TIMING_ROUNDS``)
TIMING_CALLS = 2000
TIMING_ROUNDS = 5


@nb.njit(fastmath=V.FAST)
def contact_forces(x, p, sysdata, work, q_out):
    """``q_out`` <- the generalised contact forces at the lane states ``x`` (the frames as
    the last right-hand side at the same time left them in ``work``)."""
    ndof, bi, bf, node_xbar, _, _, fpool, _, _, _, _, ci, _ = sysdata
    node_x, node_v, node_f, rot, rot_a = work[1], work[2], work[3], work[4], work[5]
    node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
    node_f[:] = 0.0
    for c in range(ci.shape[0]):
        contact_pass(c, x, p, sysdata, work)
    q_out[:] = 0.0
    map_node_forces(bi, bf, fpool, rot_a, node_f, q_out)


@nb.njit(fastmath=V.FAST)
def linear_contact_forces(x, sysdata, work, base_x, base_v, jrec, jnodes, q_out):
    """``q_out`` <- the change of the generalised contact forces from the recorded point
    (``base_x``, ``base_v``: its nodes' motion; ``jrec``, ``jnodes``: its contact record)
    to the lane states ``x``, by the recorded force law (the Jacobian's, held fixed): the
    nodes' motion at ``x``, per contact point ``K dx_rel + C dv_rel`` onto the slave and
    its four master nodes, the force map. The prototype of a sensitivity right-hand side
    without the contact passes' search (module docstring)."""
    ndof, bi, bf, node_xbar, _, _, fpool, ipool, _, _, _, ci, _ = sysdata
    node_x, node_v, node_f, rot, rot_a = work[1], work[2], work[3], work[4], work[5]
    node_kinematics(x, ndof, bi, bf, node_xbar, fpool, rot, rot_a, node_x, node_v)
    # the nodes' motion from the recorded point, once per node (then in node_x, node_v)
    for i in range(node_x.shape[0] // L):
        V.store(node_x, L * i, V.load(node_x, L * i) - V.load(base_x, L * i))
        V.store(node_v, L * i, V.load(node_v, L * i) - V.load(base_v, L * i))
    node_f[:] = 0.0
    dx = np.empty(3 * L)
    dv = np.empty(3 * L)
    row = 0
    for c in range(ci.shape[0]):
        first = ci[c, C_SLAVE0]
        for k in range(ci[c, C_NSLAVE]):
            at = L * JREC * row
            jn = L * 4 * row
            row += 1
            # no lane in contact: K = -c_p a n^T has the trace -c_p (a.n = 1) in contact and
            # is zero out of it, and C is zero with it (the record's masks)
            if V.all_zero(V.load(jrec, at)) and V.all_zero(V.load(jrec, at + L * 4)):
                if V.all_zero(V.load(jrec, at + L * 8)):
                    continue
            ms = L * 3 * ipool[first + k]
            shared = True
            for q in range(4):
                for lane in range(1, L):
                    shared = shared and jnodes[jn + L * q + lane] == jnodes[jn + L * q]
            dx0, dx1, dx2 = V.load(node_x, ms), V.load(node_x, ms + L), V.load(node_x, ms + 2 * L)
            dv0, dv1, dv2 = V.load(node_v, ms), V.load(node_v, ms + L), V.load(node_v, ms + 2 * L)
            if shared:  # the usual case: every lane's point in the same cell
                for q in range(4):
                    w = V.load(jrec, at + L * (18 + q))
                    m = L * 3 * jnodes[jn + L * q]
                    dx0 = dx0 - w * V.load(node_x, m)
                    dx1 = dx1 - w * V.load(node_x, m + L)
                    dx2 = dx2 - w * V.load(node_x, m + 2 * L)
                    dv0 = dv0 - w * V.load(node_v, m)
                    dv1 = dv1 - w * V.load(node_v, m + L)
                    dv2 = dv2 - w * V.load(node_v, m + 2 * L)
            else:
                for d in range(3):
                    V.store(dx, L * d, (dx0, dx1, dx2)[d])
                    V.store(dv, L * d, (dv0, dv1, dv2)[d])
                for q in range(4):
                    w = V.load(jrec, at + L * (18 + q))
                    for lane in range(L):
                        node = L * 3 * jnodes[jn + L * q + lane] + lane
                        for d in range(3):
                            dx[L * d + lane] -= V.get(w, lane) * node_x[node + L * d]
                            dv[L * d + lane] -= V.get(w, lane) * node_v[node + L * d]
                dx0, dx1, dx2 = V.load(dx, 0), V.load(dx, L), V.load(dx, 2 * L)
                dv0, dv1, dv2 = V.load(dv, 0), V.load(dv, L), V.load(dv, 2 * L)
            for r in range(3):
                kr = at + L * 3 * r
                cr = at + L * (9 + 3 * r)
                f = V.load(jrec, kr) * dx0 + V.load(jrec, kr + L) * dx1
                f = f + V.load(jrec, kr + 2 * L) * dx2 + V.load(jrec, cr) * dv0
                f = f + V.load(jrec, cr + L) * dv1 + V.load(jrec, cr + 2 * L) * dv2
                V.store(node_f, ms + L * r, V.load(node_f, ms + L * r) + f)
                for q in range(4):
                    w = V.load(jrec, at + L * (18 + q))
                    if shared:
                        e = L * 3 * jnodes[jn + L * q] + L * r
                        V.store(node_f, e, V.load(node_f, e) - w * f)
                    else:
                        for lane in range(L):
                            e = L * 3 * jnodes[jn + L * q + lane] + L * r + lane
                            node_f[e] -= V.get(w, lane) * V.get(f, lane)
    q_out[:] = 0.0
    map_node_forces(bi, bf, fpool, rot_a, node_f, q_out)


@nb.njit
def time_rhs(calls, t, x, dx, p, sysdata, work):
    for _ in range(calls):
        rhs(t, x, dx, p, sysdata, work)


@nb.njit
def time_linear(calls, x, sysdata, work, base_x, base_v, jrec, jnodes, q_out):
    for _ in range(calls):
        linear_contact_forces(x, sysdata, work, base_x, base_v, jrec, jnodes, q_out)


def best_time(loop, *args) -> float:
    """Seconds per call of a compiled ``loop(calls, *args)``: the best of
    ``TIMING_ROUNDS`` rounds of ``TIMING_CALLS`` calls."""
    best = np.inf
    for _ in range(TIMING_ROUNDS):
        start = time.perf_counter()
        loop(TIMING_CALLS, *args)
        best = min(best, time.perf_counter() - start)
    return best / TIMING_CALLS


def jvp_cost(brake: Brake) -> list[dict]:
    """The prototype product against its reference and a right-hand side's time."""
    times = eval_times(brake.t_end)
    p0 = brake.parameters()
    base = brake.trajectory(p0, times)
    name = "pad_spring_stiffness"
    moved = brake.trajectory(
        brake.parameters({name: brake.nominal(name) * (1 + TRAJECTORY_CHANGE)}), times
    )
    data = brake.compiled.data
    no_contact = (*data[:11], data[11][:0], *data[12:])
    work = make_work(data)
    work_nc = make_work(no_contact)
    p = np.ascontiguousarray(np.repeat(p0, L))
    n2 = 2 * brake.n
    dxl = np.empty(n2 * L)
    q_ref, q_base, q_lin = np.empty(brake.n * L), np.empty(brake.n * L), np.empty(brake.n * L)
    rows = []
    for i, t in enumerate(times):
        x = np.ascontiguousarray(np.repeat(base[:, i], L))
        s = np.repeat((moved[:, i] - base[:, i]) / TRAJECTORY_CHANGE, L)
        x_moved = x + 1e-4 * s  # the kernel's relative perturbation
        clock = np.full(L, t)
        work[12][0] = 1
        rhs(clock, x, dxl, p, data, work)  # the frames and the contact record at x
        work[12][0] = 0
        base_x, base_v = work[1].copy(), work[2].copy()
        jrec, jnodes = work[10].copy(), work[11].copy()
        contact_forces(x, p, data, work, q_base)
        contact_forces(x_moved, p, data, work, q_ref)
        linear_contact_forces(x_moved, data, work, base_x, base_v, jrec, jnodes, q_lin)
        change = q_ref - q_base
        rhs_s = best_time(time_rhs, clock, x_moved, dxl, p, data, work)
        nc_s = best_time(time_rhs, clock, x_moved, dxl, p, no_contact, work_nc)
        lin_s = best_time(time_linear, x_moved, data, work, base_x, base_v, jrec, jnodes, q_lin)
        rows.append(
            {
                "t_s": float(t),
                "vs_difference": float(np.linalg.norm(q_lin - change) / np.linalg.norm(change)),
                "rhs_us": 1e6 * rhs_s,
                "no_contact_rhs_us": 1e6 * nc_s,
                "linear_contact_us": 1e6 * lin_s,
                "product_over_rhs": (nc_s + lin_s) / rhs_s,
            }
        )
    return rows


PARTS = {"explicit": explicit, "eigen": eigen, "jvp": jvp, "jvp_cost": jvp_cost}


def main(parts: list[str], t_end: float) -> dict:
    brake = Brake(t_end)
    return {"t_end_s": t_end, **{part: PARTS[part](brake) for part in parts}}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", choices=sorted(PARTS), default=list(PARTS))
    parser.add_argument("--t-end", type=float, default=1e-3, help="s (default 1 ms)")
    args = parser.parse_args()
    print(json.dumps(main(args.parts, args.t_end)))
