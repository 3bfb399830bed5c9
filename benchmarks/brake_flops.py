"""Floating-point operations per sample-step of the brake formulation.

Counted from the sizes of the compiled system (modal coordinates, tracked and
contact nodes, spring groups) term by term as the equations need them -- the
work any implementation of this formulation must do, not the instructions a
particular kernel executes. Conventions: a multiply-add is 2 operations; sqrt,
division, arctan2 and hypot count as 1 each (their real cost is higher, which
makes the bound optimistic for the contact part). Contact work depends on how
many slave nodes touch: ``active_fraction`` (measured on the trajectory by the
NumPy baseline, :class:`brake_numpy.ContactStats`) weights the in-contact part.

The Rosenbrock path (ROS34PW2, RODAS4) and the forward sensitivities are counted per
call in the same way (:func:`jacobian_flops`, :func:`lu_flops`,
:func:`stage_solve_flops`) and multiplied by the kernel's own work counters of a
sample (:func:`rosenbrock_flops`, :func:`sensitivity_flops`); benchmarks/ros_flops.py
measures the rates.
"""

from __future__ import annotations

from typing import Any

from fuzzymbs.mbs.kernels import layout as K

#: Operations per checked slave node: chart coordinates (12), polar (2), locating
#: the cell on both grids (10), bilinear weights (8), master point (21), gap (8).
CONTACT_CHECK = 61
#: Extra per checked node when the master body rotates (patch normal A m).
CONTACT_ROTATING_MASTER = 15
#: Per node in contact: relative velocity (24), normal rate (5), normal force (3),
#: tangential velocity (6), friction scale (9), force (9), scatter to 5 nodes (27).
CONTACT_ACTIVE = 83
#: Rigid-frame transform per tracked node: rotating body (y, Omega e x y, A y, A z).
FRAME_ROTATING = 51
FRAME_TRANSLATING = 6
#: RK4 per state entry: three stage states (2 each) and the weighted update (7).
RK4_COMBINE = 13
RK4_STAGES = 4


def rhs_flops(data: tuple, active_fraction: float = 1.0) -> dict[str, float]:
    """Operations of one right-hand-side evaluation, by term.

    Parameters
    ----------
    data : tuple
        ``CompiledSystem.data``.
    active_fraction : float
        Share of checked slave nodes that are in contact (0..1).
    """
    _, bi, _, _, _, _, _, _, _, lg, nfi, ci, _ = data
    terms = {"springs": 0.0, "nodal_forces": 0.0, "kinematics": 0.0, "contact": 0.0}
    terms.update({"force_mapping": 0.0, "equations_of_motion": 0.0})
    for _, n, _, _, _ in lg:
        terms["springs"] += 2.0 * n * n + n  # unit stiffness matvec, scale, subtract
    for b, _, _, _, rotating in nfi:
        size = bi[b, K.B_NTR] + bi[b, K.B_NM]
        terms["nodal_forces"] += 2.0 * size + (6.0 * bi[b, K.B_NM] if rotating else 0.0)
    for row in bi:
        kind, ntr, nm = row[K.B_KIND], row[K.B_NTR], row[K.B_NM]
        nodes = row[K.B_NODE1] - row[K.B_NODE0]
        if nodes > 0:
            # U = Psi q and Udot = Psi qdot over 3 components of every tracked node
            terms["kinematics"] += 2 * 2.0 * 3 * nodes * nm
            frame = FRAME_ROTATING if kind == K.KIND_ROTATING else FRAME_TRANSLATING
            terms["kinematics"] += nodes * frame + 12.0 * ntr
            # generalised forces: Psi^T F (modal), P^T F (translations), A^T F (rotating)
            terms["force_mapping"] += 2.0 * 3 * nodes * nm + 6.0 * nodes * ntr
            if kind == K.KIND_ROTATING:
                terms["force_mapping"] += 15.0 * nodes
        terms["equations_of_motion"] += 4.0 * nm
        if kind == K.KIND_ROTATING:
            terms["equations_of_motion"] += 6.0 * nm * nm + 8.0 * nm
        elif kind == K.KIND_TRANSLATING:
            terms["equations_of_motion"] += 4.0 * ntr * nm + 2.0 * ntr * ntr
    for row in ci:
        checked = row[K.C_NSLAVE]
        per_node = CONTACT_CHECK + active_fraction * CONTACT_ACTIVE
        if bi[row[K.C_MBODY], K.B_KIND] == K.KIND_ROTATING:
            per_node += CONTACT_ROTATING_MASTER
        terms["contact"] += checked * per_node
    return terms


def step_flops(data: tuple, active_fraction: float = 1.0) -> dict[str, Any]:
    """Operations per sample and RK4 step, with the per-term breakdown of one RHS call."""
    terms = rhs_flops(data, active_fraction)
    ndof = int(data[0])
    rhs_total = sum(terms.values())
    total = RK4_STAGES * rhs_total + RK4_COMBINE * 2 * ndof
    bi, ci = data[1], data[11]
    return {
        "flops_per_sample_step": total,
        "flops_per_rhs": rhs_total,
        "rhs_terms": terms,
        "modal_coordinates": int(sum(bi[:, K.B_NM])),
        "coordinates": ndof,
        "tracked_nodes": int(data[3].shape[0]),
        "contact_checks_per_rhs": int(sum(ci[:, K.C_NSLAVE])),
        "active_fraction": active_fraction,
    }


# ------------------------------------------------------------------ Rosenbrock path
# The linearly implicit kernel (fuzzymbs.mbs.kernels.rosenbrock, jacobian, linalg,
# sensitivities) counted the same way, from the sizes, per sample. What it does is
# counted as the formulation's work where it is the formulation (the analytic Jacobian,
# the velocity-reduced stage solve); the LU is counted as the kernel runs it (dense rows,
# a row skipped when it does not couple to the pivot column, ``lu_flops``), the dense
# 2/3 n^3 beside it. Selects, abs, max and the pivot search count 0.

#: Jacobian record per checked node (contact.contact_pass with ``record``): the sliding
#: direction and friction direction (18), the masked c_p, d (2) and the force law's
#: K, C (12 per entry of the two 3 x 3 blocks, 108)
JACOBIAN_RECORD = 128
#: per mode of a contact point's slave map: a rotating body's Omega e x u (12) and the
#: three rotated rows of W and W_q (39); a translating body's 3 rows (6)
SLAVE_MAP_ROTATING = 51
SLAVE_MAP_TRANSLATING = 6
#: per mode of the four master nodes' map: the weighted sum (21), then as the slave
#: (rotating: 51; translating: the 3 rows added, 3); plus 7 per point (the weights)
MASTER_SUM = 21
#: per column of a contact point's gathered rows: C W (15), K W + C W_q (33)
POINT_ROW = 48
#: Hermite interpolant per state entry (4 multiplies, 3 additions)
HERMITE = 7


def jacobian_flops(data: tuple, active_fraction: float = 1.0) -> dict[str, float]:
    """Operations of one Jacobian evaluation (:func:`fuzzymbs.mbs.kernels.jacobian.jacobian`),
    by term, per sample: its right-hand side with the contact record, the modal and
    rotating-body terms, the springs, the contact points' ``W^T (K W + C W_q)`` and
    ``W^T C W`` (points in contact only: ``active_fraction`` of the checked ones) and the
    translating bodies' mass inverse on the rows of both ``da/dq`` and ``da/dv``.

    Parameters
    ----------
    data : tuple
        ``CompiledSystem.data``.
    active_fraction : float
        Share of checked slave nodes in contact (0..1).
    """
    ndof, bi, _, _, _, _, _, _, _, lg, _, ci, _ = data
    n = int(ndof)
    rhs_total = sum(rhs_flops(data, active_fraction).values())
    checked = float(sum(ci[:, K.C_NSLAVE]))
    terms = {"rhs": rhs_total, "record": JACOBIAN_RECORD * checked}
    terms.update({"modal_and_rotating": 0.0, "springs": 0.0, "contact_maps": 0.0})
    terms.update({"contact_products": 0.0, "mass_inverse": 0.0})
    for row in bi:
        nm, ntr = row[K.B_NM], row[K.B_NTR]
        terms["modal_and_rotating"] += 4.0 * nm
        if row[K.B_KIND] == K.KIND_ROTATING:
            terms["modal_and_rotating"] += 8.0 * nm * nm + 1.0
        elif row[K.B_KIND] == K.KIND_TRANSLATING:
            # r (2 nm per row), the Schur block (2 ntr), the modal rows (2 ntr per mode),
            # for each of n columns of both matrices
            terms["mass_inverse"] += 2.0 * n * (4.0 * nm * ntr + 2.0 * ntr * ntr)
    for group in lg:
        terms["springs"] += 6.0 * group[1] * group[1]
    for row in ci:
        slave, master = bi[row[K.C_SBODY]], bi[row[K.C_MBODY]]
        columns = slave[K.B_NTR] + slave[K.B_NM]
        if row[K.C_MBODY] != row[K.C_SBODY]:
            columns += master[K.B_NTR] + master[K.B_NM]
        points = active_fraction * row[K.C_NSLAVE]
        rotating = slave[K.B_KIND] == K.KIND_ROTATING
        per_point = 6.0 * slave[K.B_NTR] + slave[K.B_NM] * (
            SLAVE_MAP_ROTATING if rotating else SLAVE_MAP_TRANSLATING
        )
        rotating = master[K.B_KIND] == K.KIND_ROTATING
        per_point += (
            7.0
            + 6.0 * master[K.B_NTR]
            + master[K.B_NM] * (MASTER_SUM + (SLAVE_MAP_ROTATING if rotating else 3.0))
        )
        per_point += POINT_ROW * columns
        terms["contact_maps"] += points * per_point
        # three rows per point into both matrices (2 flops each), then the pass's sums
        terms["contact_products"] += points * 12.0 * columns * columns
        terms["contact_products"] += 2.0 * columns * columns if points > 0 else 0.0
    return terms


def lu_flops(pattern: Any = None, n: int | None = None) -> float:
    """Operations of :func:`fuzzymbs.mbs.kernels.linalg.lu_factor_lanes` for one sample.

    Per elimination step k: the pivot's inverse (1), the factors of the rows below (1
    each) and, for every row that couples to column k (its entry nonzero after the
    previous steps), the update of its columns ``k + 1 ..`` (2 each). ``pattern`` (n, n
    bool) is the matrix's nonzero pattern (fill-in followed, row swaps not); None: dense,
    ``n (n - 1) / 2 + n + 2 sum_m m^2``, about 2/3 n^3.
    """
    import numpy as np

    if pattern is None:
        pattern = np.ones((n, n), dtype=bool)
    a = np.array(pattern, dtype=bool)
    size = a.shape[0]
    total = 0.0
    for k in range(size):
        below = size - k - 1
        total += 1.0 + below
        rows = np.flatnonzero(a[k + 1 :, k]) + k + 1
        total += 2.0 * below * rows.size
        a[np.ix_(rows, np.arange(k + 1, size))] |= a[k, k + 1 :]
    return total


def rosenbrock_step_flops(n: int, stages: int = 4) -> dict[str, float]:
    """Operations of one tried step besides the right-hand sides, Jacobians and LUs,
    per sample (:func:`fuzzymbs.mbs.kernels.rosenbrock.advance_block_ros`): each stage's
    state (2 s per entry) and right-hand side of its system (2 + 2 s), its velocity-
    reduced solve (:func:`stage_solve_flops`), then the new state and the error norm
    (4 per stage and entry, 5 per entry)."""
    size = 2 * n
    combine = sum(2.0 * s + 2.0 + 2.0 * s for s in range(stages)) * size
    combine += (4.0 * stages + 5.0) * size
    return {"combinations": combine, "stage_solves": stages * stage_solve_flops(n)}


def stage_solve_flops(n: int) -> float:
    """Operations of one velocity-reduced stage solve (``linalg.reduced_stage_solve``):
    ``r_v + gamma h A_q r_q`` (2 n^2 + 2 n), the two triangular solves with the LU
    (2 n^2 - n, n divisions included) and ``u_q = gamma h (r_q + u_v)`` (2 n)."""
    return 4.0 * n * n + 3.0 * n


def rosenbrock_flops(
    data: tuple,
    counts: dict[str, float],
    active_fraction: float = 1.0,
    lu: float | None = None,
    stages: int = 4,
    records: float = 0.0,
) -> dict[str, float]:
    """Operations of one sample's Rosenbrock run from the kernel's work counters, by part.

    Parameters
    ----------
    data : tuple
        ``CompiledSystem.data``.
    counts : dict
        The sample's ``accepted``, ``rejected`` steps, ``rhs``, ``jacobians``, ``lus``
        (``SimulationResult.step_counts`` and ``work_counts``).
    active_fraction : float
        Share of checked slave nodes in contact.
    lu : float, optional
        Operations of one LU (:func:`lu_flops`); default dense.
    stages : int
        The method's stages (ROS34PW2: 4).
    records : float
        Recording times (each one Hermite interpolant of the state).
    """
    n = int(data[0])
    rhs_total = sum(rhs_flops(data, active_fraction).values())
    jac = jacobian_flops(data, active_fraction)
    lu = lu_flops(n=n) if lu is None else lu
    tries = counts["accepted"] + counts["rejected"]
    step = rosenbrock_step_flops(n, stages)
    contact = jac["contact_maps"] + jac["contact_products"]
    return {
        "rhs": counts["rhs"] * rhs_total,
        # the Jacobian's own right-hand side with the record, and the f_t difference
        "jacobian_rhs": counts["jacobians"] * (jac["rhs"] + jac["record"] + 4.0 * n),
        "jacobian_contact": counts["jacobians"] * contact,
        "jacobian_other": counts["jacobians"]
        * (jac["modal_and_rotating"] + jac["springs"] + jac["mass_inverse"]),
        # the stage matrix I / (gamma h) - B_v - gamma h A_q, then its LU
        "lu": counts["lus"] * (2.0 * n * n + n + lu),
        "stage_solves": tries * step["stage_solves"],
        "combinations": tries * step["combinations"] + records * HERMITE * 2 * n,
    }


def sensitivity_flops(
    data: tuple,
    accepted: float,
    sens_rhs: float,
    parameters: int,
    active_fraction: float = 1.0,
    stages: int = 4,
    records: float = 0.0,
) -> dict[str, float]:
    """Operations of one sample's forward sensitivities (``kernels.sensitivities``), by part:
    ``sens_rhs`` directional differences (a right-hand side, ``x + eps S`` and the
    difference quotient, 4 per entry), and per parameter and accepted step each stage's
    ``S_s`` (2 s per entry, s > 0), its system's right-hand side (2 s), a stage solve with
    the state's LU, and ``S_new`` (2 per stage and entry); per record a Hermite
    interpolant."""
    n = int(data[0])
    size = 2 * n
    rhs_total = sum(rhs_flops(data, active_fraction).values())
    per_step = sum(4.0 * s for s in range(stages)) * size + 2.0 * stages * size
    return {
        "rhs": sens_rhs * (rhs_total + 4.0 * size),
        "stage_solves": parameters * accepted * stages * stage_solve_flops(n),
        "combinations": parameters * (accepted * per_step + records * HERMITE * size),
    }
