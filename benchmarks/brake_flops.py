"""Floating-point operations per sample-step of the brake formulation.

Counted from the sizes of the compiled system (modal coordinates, tracked and
contact nodes, spring groups) term by term as the equations need them -- the
work any implementation of this formulation must do, not the instructions a
particular kernel executes. Conventions: a multiply-add is 2 operations; sqrt,
division, arctan2 and hypot count as 1 each (their real cost is higher, which
makes the bound optimistic for the contact part). Contact work depends on how
many slave nodes touch: ``active_fraction`` (measured on the trajectory by the
NumPy baseline, :class:`brake_numpy.ContactStats`) weights the in-contact part.
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
