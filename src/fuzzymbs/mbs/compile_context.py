"""What a System's force element writes into when the System is compiled.

Every element of a :class:`~fuzzymbs.mbs.system.System` compiles itself: it names
the nodes it needs tracked (``track``) and then appends its row to its table
(``compile``) -- the linear springs' (``lg``), the nodal forces' (``nfi``) or the
contact passes' (``ci``, ``cf``) -- with its numbers in the shared pools and its
scalars as parameter slots. Adding a kind of element is a class with those two
methods and its rows in the kernels, not an edit of the System. ``table`` says
which table an element writes; the System compiles the tables in their layout
order, so the slots and rows keep that order whatever order the elements were
added in.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import Body
from fuzzymbs.mbs.forces import resolve_nodes
from fuzzymbs.mbs.parameters import ParameterTable
from fuzzymbs.mbs.profiles import SpinUpProfile, TimeProfile

#: The element tables, in the order of the kernels' layout.
TABLES = ("springs", "nodal_forces", "contacts")


class Pools:
    """The float and int pools every table's rows point into."""

    def __init__(self) -> None:
        self.f: list[NDArray[np.float64]] = []
        self.nf = 0
        self.i: list[NDArray[np.int64]] = []
        self.ni = 0

    def addf(self, arr: ArrayLike) -> int:
        a = np.ascontiguousarray(arr, dtype=np.float64).reshape(-1)
        self.f.append(a)
        self.nf += a.size
        return self.nf - a.size

    def addi(self, arr: ArrayLike) -> int:
        a = np.ascontiguousarray(arr, dtype=np.int64).reshape(-1)
        self.i.append(a)
        self.ni += a.size
        return self.ni - a.size


@dataclass
class CompileContext:
    """The bodies (their frame motions), their coordinates and tracked nodes, the shared
    pools, the parameter slots and the element tables' rows of one compilation."""

    motions: dict[str, Body]
    body_dofs: dict[str, slice]
    n_dofs: int
    table: ParameterTable = field(default_factory=ParameterTable)
    pools: Pools = field(default_factory=Pools)
    profiles: list[tuple[int, int]] = field(default_factory=list)
    tracked: dict[str, set[int]] = field(default_factory=dict)
    tracked_id: dict[tuple[str, int], int] = field(default_factory=dict)
    rows: dict[str, list] = field(default_factory=lambda: {name: [] for name in TABLES})

    def __post_init__(self) -> None:
        self.tracked = {name: set() for name in self.motions}
        self.index = {name: i for i, name in enumerate(self.motions)}

    def body(self, name: str, what: str) -> Body:
        """The body ``name``, or an error naming ``what`` refers to it."""
        try:
            return self.motions[name]
        except KeyError:
            raise InvalidParameterError(
                f"{what}: unknown body {name!r}; bodies are {sorted(self.motions)}"
            ) from None

    def nodes(self, body: Body, ref, what: str) -> NDArray[np.int64]:
        """Node indices of ``body`` from a node-set name or indices."""
        return resolve_nodes(body.modal, ref, what)

    def add_profile(self, profile: TimeProfile | SpinUpProfile) -> int:
        """Store a time profile (its own ``store``); its index in ``ptab``."""
        self.profiles.append(profile.store(self.pools))
        return len(self.profiles) - 1
