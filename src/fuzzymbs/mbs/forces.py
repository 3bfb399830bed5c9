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
from fuzzymbs.mbs.bodies import unit_vector
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

    def unit_direction(self) -> NDArray[np.float64]:
        return unit_vector(self.direction, f"nodal force {self.name!r} direction")


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

    def directions(self) -> NDArray[np.float64]:
        """Rows of unit directions the springs act along (1 row, or 3 for 3D)."""
        if self.direction is None:
            return np.eye(3)
        return unit_vector(self.direction, f"spring {self.name!r} direction")[None, :]


def resolve_nodes(modal_nodes: int, node_sets: dict, ref: NodeRef, what: str) -> NDArray[np.int64]:
    """Node indices from a node-set name or an index array, checked against the body."""
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
