"""Force elements: nodal forces, linear springs and dampers.

Elements refer to bodies by name and to nodes by index into the body's kept
nodes or by the name of a node set. Scalars may be :class:`Parameter` objects
(bound to sample columns).

Springs and dampers are linear (small displacements about the reference
configuration, unstretched there): the elongation of a pair along a unit
direction d is ``d . (u_b - u_a)`` with u the node displacement; a 3D spring
(``direction=None``) is an isotropic bushing, i.e. three such springs along x,
y, z. Because they are linear the compiled system folds each spring element into
a small dense matrix over the coordinates it touches (see system.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import RotatingBody, TranslatingBody, node_row, unit_vector
from fuzzymbs.mbs.modal_body import ModalBody
from fuzzymbs.mbs.parameters import Scalar
from fuzzymbs.mbs.profiles import TimeProfile

NodeRef = str | ArrayLike


@dataclass(frozen=True, eq=False)
class NodalForce:
    """The same force ``magnitude * profile(t) * direction`` [N] on each of ``nodes``.

    Parameters
    ----------
    name : str
        Element name (used in messages).
    body : str
        Body name.
    nodes : str or array_like of int
        Node set name or node indices.
    direction : axis name or 3-vector
        Direction in the inertial frame (normalised).
    magnitude : float or Parameter
        Force per node [N] (sign along ``direction``).
    profile : TimeProfile, optional
        Time history multiplier (default constant 1).
    """

    name: str
    body: str
    nodes: NodeRef
    direction: ArrayLike | str
    magnitude: Scalar
    profile: TimeProfile | None = None

    table = "nodal_forces"

    def unit_direction(self) -> NDArray[np.float64]:
        return unit_vector(self.direction, f"nodal force {self.name!r} direction")

    def track(self, ctx) -> None:
        """No node needs tracking: the force folds into a generalised force vector."""

    def compile(self, ctx) -> None:
        """Row (body, vector offset, profile, magnitude slot, rotating flag): on a rotating
        body the inertial direction d enters through three vectors (see the kernels)."""
        body = ctx.body(self.body, f"nodal force {self.name!r} body")
        nodes = ctx.nodes(body, self.nodes, f"nodal force {self.name!r} nodes")
        d = self.unit_direction()
        psi_sum = body.modal.mode_shapes[nodes].sum(axis=0)  # (3, r)
        slot = ctx.table.add(self.magnitude, f"nodal force {self.name!r} magnitude")
        prof = -1 if self.profile is None else ctx.add_profile(self.profile)
        pools = ctx.pools
        if isinstance(body, RotatingBody):
            ax = body.axis
            v0 = pools.addf(d @ psi_sum)
            pools.addf((ax @ d) * (ax @ psi_sum))
            pools.addf(np.cross(ax, d) @ psi_sum)
            ctx.rows[self.table].append((ctx.index[body.name], v0, prof, slot, 1))
        else:
            vec = [body.axes @ d * nodes.size] if isinstance(body, TranslatingBody) else []
            vec.append(d @ psi_sum)
            row = (ctx.index[body.name], pools.addf(np.concatenate(vec)), prof, slot, 0)
            ctx.rows[self.table].append(row)


@dataclass(frozen=True, eq=False)
class Spring:
    """Linear springs/dampers between node pairs, or from nodes to ground.

    Pair i joins ``nodes_a[i]`` of ``body_a`` and ``nodes_b[i]`` of ``body_b``
    (``body_b=None``: the ground, fixed at the node's reference position).

    Parameters
    ----------
    name : str
        Element name.
    body_a, nodes_a : str, node reference
        First end.
    body_b, nodes_b : str or None, node reference or None
        Second end (None for ground).
    stiffness : float or Parameter
        Stiffness k of each pair [N/m], >= 0.
    damping : float or Parameter
        Viscous coefficient c of each pair [N s/m], >= 0.
    direction : axis name, 3-vector or None
        Line of action (inertial frame); None for an isotropic 3D spring.
    """

    name: str
    body_a: str
    nodes_a: NodeRef
    body_b: str | None = None
    nodes_b: NodeRef | None = None
    stiffness: Scalar = 0.0
    damping: Scalar = 0.0
    direction: ArrayLike | str | None = None

    table = "springs"

    def directions(self) -> NDArray[np.float64]:
        """Rows of unit directions the springs act along (1 row, or 3 for 3D)."""
        if self.direction is None:
            return np.eye(3)
        return unit_vector(self.direction, f"spring {self.name!r} direction")[None, :]

    def track(self, ctx) -> None:
        """No node needs tracking: the springs fold into a small matrix."""

    def compile(self, ctx) -> None:
        """Row (dof list, size, unit matrices, stiffness slot, damping slot): the pairs'
        unit stiffness sum_k w_k w_k^T over the coordinates the springs touch."""
        ba = ctx.body(self.body_a, f"spring {self.name!r} body_a")
        na = ctx.nodes(ba, self.nodes_a, f"spring {self.name!r} nodes_a")
        ends = [(ba, na, -1.0)]
        if self.body_b is not None:
            bb = ctx.body(self.body_b, f"spring {self.name!r} body_b")
            if self.nodes_b is None:
                raise InvalidParameterError(f"spring {self.name!r}: body_b given without nodes_b")
            nb_ = ctx.nodes(bb, self.nodes_b, f"spring {self.name!r} nodes_b")
            if nb_.size != na.size:
                raise InvalidParameterError(
                    f"spring {self.name!r}: nodes_a and nodes_b must pair up, got {na.size} "
                    f"and {nb_.size} nodes"
                )
            if bb is ba:
                raise InvalidParameterError(
                    f"spring {self.name!r}: both ends on body {ba.name!r}; "
                    "internal stiffness belongs in the modal body"
                )
            ends.append((bb, nb_, 1.0))
        for body, _, _ in ends:
            if isinstance(body, RotatingBody):
                raise InvalidParameterError(
                    f"spring {self.name!r}: springs on rotating body {body.name!r} are not "
                    "supported (their geometry would be time-varying); use contact or a "
                    "fixed body"
                )
        dofs = np.concatenate([np.arange(ctx.n_dofs)[ctx.body_dofs[b.name]] for b, _, _ in ends])
        if dofs.size == 0:
            return  # both ends without coordinates: nothing moves
        unit = np.zeros((dofs.size, dofs.size))
        for d in self.directions():
            for k in range(na.size):
                w = np.concatenate(
                    [sign * node_row(body, nodes[k], d) for body, nodes, sign in ends]
                )
                unit += np.outer(w, w)
        d0 = ctx.pools.addi(dofs)
        m0 = ctx.pools.addf(unit)
        ctx.pools.addf(unit)
        ks = ctx.table.add(self.stiffness, f"spring {self.name!r} stiffness", 0.0)
        cs = ctx.table.add(self.damping, f"spring {self.name!r} damping", 0.0)
        ctx.rows[self.table].append((d0, dofs.size, m0, ks, cs))


def resolve_nodes(modal: ModalBody, ref: NodeRef, what: str) -> NDArray[np.int64]:
    """Node indices of ``modal``'s kept nodes from a node-set name or an index array,
    checked against the body (``what`` names the input in the error)."""
    node_sets = modal.node_sets
    modal_nodes = modal.n_nodes
    if isinstance(ref, str):
        if ref not in node_sets:
            raise InvalidParameterError(
                f"{what}: unknown node set {ref!r}; available: {sorted(node_sets)}"
            )
        idx = np.asarray(node_sets[ref], dtype=np.int64).reshape(-1)
    else:
        idx = np.asarray(ref).reshape(-1)
        if idx.dtype.kind not in "iu":
            raise InvalidParameterError(f"{what}: node indices must be integers, got {ref!r}")
        idx = idx.astype(np.int64)
    if idx.size == 0 or idx.min() < 0 or idx.max() >= modal_nodes:
        raise InvalidParameterError(
            f"{what}: node indices must be non-empty and in [0, {modal_nodes}), got {idx}"
        )
    return idx
