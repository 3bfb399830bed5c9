"""Assembly of bodies and force elements into the flat arrays the kernels read.

Bodies are the general engine's :class:`~fuzzymbs.mbs.spatial.FlexibleBody`, each
held to the ground by one joint (:mod:`fuzzymbs.mbs.frame_motion`: Fixed, Prismatic,
or a Revolute driven at a constant rate); the System solves them in minimal
coordinates (the joint's free coordinate and the modes). Usage::

    from fuzzymbs.mbs.spatial import FlexibleBody, Prismatic, Revolute, ConstantRate
    from fuzzymbs.mbs.spatial import frame_with_z, ground

    y = frame_with_z((0.0, 1.0, 0.0))  # joint axes: z along the global y
    disc, pad = FlexibleBody("disc", disc_modal), FlexibleBody("pad", pad_modal)
    system = System()
    system.add_body(disc)
    system.add_joint(Revolute(ground.point(axes=y), disc.point(axes=y),
                              drive=ConstantRate(Parameter("omega", 1.0))))
    system.add_body(pad)
    system.add_joint(Prismatic(ground.point(axes=y), pad.point(axes=y)))
    system.add(NodalForce("press", "pad", "back", "-y", Parameter("F_n", 16e3)))
    system.add(PenaltyContact("pad-disc", "pad", "contact", "disc", "patch",
                              PolarChart("y"), penalty=1e8, friction=Parameter("mu", 0.7)))
    compiled = system.compile()

Layout of ``CompiledSystem.data`` (the tuple passed to every kernel):

``(ndof, bi, bf, node_xbar, dof_k2, dof_c, fpool, ipool, ptab, lg, nfi, ci, cf)``

* ``bi`` (bodies, 11) int: kind, first dof, n translations, n modes, tracked-node
  range, offset of the tracked nodes' Psi block (node, xyz, mode) in ``fpool``,
  offset of the body matrices (translating: S^-1 then B = P C_t; rotating: G, C,
  centrifugal load, Euler load), speed slot, speed profile index, offset of the
  transposed Psi block (mode, node * 3).
* ``bf`` (bodies, 15) float: origin, translation axes (3 rows), rotation axis.
* ``node_xbar`` (tracked, 3): undeformed positions of the nodes contact needs.
* ``dof_k2``, ``dof_c``: omega^2 and 2 zeta omega per coordinate (0 for translations).
* ``ptab`` (profiles, 2): start and knot count; knots t, values, integrals in ``fpool``.
* ``lg`` (spring groups, 5): dof list offset (``ipool``), size n, offset of the unit
  stiffness and unit damping matrices (n x n each), stiffness slot, damping slot.
* ``nfi`` (nodal forces, 5): body, offset of the generalised force vector(s), profile
  index (-1: constant), magnitude slot, rotating flag (then 3 vectors, see kernels).
* ``ci`` (contact passes, 14) / ``cf`` (contact passes, 15): see
  :mod:`fuzzymbs.mbs.kernels.layout` (``C_*``) and the chart frame (origin, two
  in-plane axes), eps, normal damping, then the cell look-up constants
  (``CF_*``: u scale, u uniform, v scale, v uniform).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import (
    Body,
    FixedBody,
    RotatingBody,
    TranslatingBody,
    node_row,
    unit_vector,
)
from fuzzymbs.mbs.compile_context import TABLES, CompileContext
from fuzzymbs.mbs.contact import PenaltyContact
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.frame_motion import frame_motions, initial_coordinates
from fuzzymbs.mbs.kernels import layout as K
from fuzzymbs.mbs.parameters import ParameterTable

Element = NodalForce | Spring | PenaltyContact


@dataclass(frozen=True)
class NodeDisplacement:
    """Output: displacement of a node along ``direction`` [m].

    For a non-rotating body, the inertial displacement (frame translation plus
    elastic deformation). For a rotating body, the elastic displacement in the
    body frame (the rigid rotation is prescribed and not an output).
    """

    body: str
    node: int
    direction: ArrayLike | str


@dataclass(frozen=True)
class Coordinate:
    """Output: one generalised coordinate of a body (translation a, or mode ``n_tr + j``)."""

    body: str
    index: int = 0
    velocity: bool = False


Output = NodeDisplacement | Coordinate


class System:
    """A collection of bodies and force elements, compiled into kernel arrays."""

    def __init__(self) -> None:
        self.bodies: dict[str, Body] = {}
        self.joints: list = []
        self.elements: list[Element] = []

    def add_body(self, body):
        """Add a body; its name must be unique.

        A :class:`~fuzzymbs.mbs.spatial.FlexibleBody` (then give it one joint to the
        ground with :meth:`add_joint`), or a frame motion given directly
        (:class:`FixedBody`, :class:`TranslatingBody`, :class:`RotatingBody`).
        """
        is_flexible = getattr(body, "role", None) == "body" and hasattr(body, "modal")
        if not (is_flexible or isinstance(body, FixedBody | TranslatingBody | RotatingBody)):
            raise InvalidParameterError(
                f"add_body needs a spatial.FlexibleBody (or a FixedBody, TranslatingBody or "
                f"RotatingBody), got {type(body).__name__}"
            )
        if getattr(body, "engine", "spatial") != "spatial":
            raise InvalidParameterError(f"body {body.name!r} is a planar body; a System is spatial")
        if body.name in self.bodies:
            raise InvalidParameterError(f"a body named {body.name!r} exists already")
        self.bodies[body.name] = body
        return body

    def add_joint(self, joint):
        """Hold a body to the ground: a spatial Fixed, Prismatic or driven Revolute joint
        (see :mod:`fuzzymbs.mbs.frame_motion`)."""
        if getattr(joint, "role", None) != "joint" or getattr(joint, "engine", "") != "spatial":
            raise InvalidParameterError(
                f"add_joint needs a spatial joint (Fixed, Prismatic, Revolute), got "
                f"{type(joint).__name__}"
            )
        self.joints.append(joint)
        return joint

    def add(self, *elements: Element) -> None:
        """Add force elements (NodalForce, Spring, PenaltyContact); each compiles itself
        (:mod:`fuzzymbs.mbs.compile_context`)."""
        names = {e.name for e in self.elements}
        for e in elements:
            if not (hasattr(e, "compile") and getattr(e, "table", None) in TABLES):
                raise InvalidParameterError(
                    f"unknown element type {type(e).__name__}; use NodalForce, Spring or "
                    "PenaltyContact (an element compiles itself into one of the tables "
                    f"{TABLES}, fuzzymbs.mbs.compile_context)"
                )
            if e.name in names:
                raise InvalidParameterError(f"an element named {e.name!r} exists already")
            names.add(e.name)
            self.elements.append(e)

    def as_mechanism(self, sample=None):
        """This system in absolute coordinates, a :class:`~fuzzymbs.mbs.spatial.Mechanism`
        at one sample (:func:`fuzzymbs.mbs.system_mechanism.as_mechanism`)."""
        # imported here: the spatial engine's modules are not needed to build or run a System
        from fuzzymbs.mbs.system_mechanism import as_mechanism

        return as_mechanism(self, sample)

    def compile(self) -> CompiledSystem:
        """Flatten into kernel arrays (see the module docstring)."""
        motions = frame_motions(self.bodies, self.joints)
        compiled = _compile(motions, self.elements)
        starts = [initial_coordinates(self.bodies[n], motions[n]) for n in motions]
        compiled.initial = np.concatenate(
            [np.concatenate([q for q, _ in starts]), np.concatenate([v for _, v in starts])]
        )
        return compiled


@dataclass
class CompiledSystem:
    """Kernel arrays plus what is needed to read and label them."""

    data: tuple
    parameters: ParameterTable
    n_dofs: int
    body_dofs: dict[str, slice]
    bodies: dict[str, Body]
    translation_axes: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    initial: NDArray[np.float64] | None = None

    @property
    def n_state(self) -> int:
        return 2 * self.n_dofs

    def output_functional(self, spec: Output) -> NDArray[np.float64]:
        """Row vector w with output = w . state."""
        w = np.zeros(self.n_state)
        if spec.body not in self.bodies:
            raise InvalidParameterError(
                f"output: unknown body {spec.body!r}; bodies are {sorted(self.bodies)}"
            )
        body = self.bodies[spec.body]
        dofs = self.body_dofs[spec.body]
        if isinstance(spec, Coordinate):
            if not 0 <= spec.index < body.n_dofs:
                raise InvalidParameterError(
                    f"output: body {spec.body!r} has {body.n_dofs} coordinates, index "
                    f"{spec.index} is out of range"
                )
            w[dofs.start + spec.index + (self.n_dofs if spec.velocity else 0)] = 1.0
            return w
        d = unit_vector(spec.direction, f"output direction of body {spec.body!r}")
        if not 0 <= spec.node < body.modal.n_nodes:
            raise InvalidParameterError(
                f"output: body {spec.body!r} has {body.modal.n_nodes} nodes, node {spec.node} "
                "is out of range"
            )
        w[dofs] = node_row(body, spec.node, d)
        return w

    def zero_state(self, batch: int = 1) -> NDArray[np.float64]:
        """Zero initial conditions for ``batch`` samples, shape (batch, 2n)."""
        return np.zeros((batch, self.n_state))

    def initial_state(self, batch: int = 1) -> NDArray[np.float64]:
        """The bodies' initial coordinates and rates (a FlexibleBody's ``coordinates``,
        ``rates`` and slide velocity; zero otherwise), shape (batch, 2n)."""
        if self.initial is None:
            return self.zero_state(batch)
        return np.tile(self.initial, (batch, 1))


def _compile(motions: dict[str, Body], elements: list[Element]) -> CompiledSystem:
    if not motions:
        raise InvalidParameterError("the system has no bodies")
    bodies = list(motions.values())

    # coordinates
    body_dofs: dict[str, slice] = {}
    ndof = 0
    for body in bodies:
        body_dofs[body.name] = slice(ndof, ndof + body.n_dofs)
        ndof += body.n_dofs
    dof_k2 = np.zeros(ndof)
    dof_c = np.zeros(ndof)
    for body in bodies:
        q = slice(body_dofs[body.name].start + body.n_translations, body_dofs[body.name].stop)
        dof_k2[q] = body.modal.frequencies**2
        dof_c[q] = 2.0 * body.damping_ratio * body.modal.frequencies
    ctx = CompileContext(motions, body_dofs, ndof)
    pools, table = ctx.pools, ctx.table

    # tracked nodes: every node an element reads (contact passes), grouped by body
    for e in elements:
        e.track(ctx)
    node_xbar = []
    bi = np.zeros((len(bodies), 11), dtype=np.int64)
    bf = np.zeros((len(bodies), 15))
    translation_axes = {}
    for b, body in enumerate(bodies):
        modal = body.modal
        nodes = sorted(ctx.tracked[body.name])
        bi[b, K.B_NODE0] = len(node_xbar)
        for n in nodes:
            ctx.tracked_id[(body.name, n)] = len(node_xbar)
            node_xbar.append(modal.node_positions[n])
        bi[b, K.B_NODE1] = len(node_xbar)
        block = modal.mode_shapes[nodes]  # (node, xyz, mode)
        bi[b, K.B_PSI0] = pools.addf(block) if nodes else 0
        bi[b, K.B_PSIT0] = pools.addf(block.reshape(3 * len(nodes), -1).T) if nodes else 0
        bi[b, K.B_DOF0] = body_dofs[body.name].start
        bi[b, K.B_NTR] = body.n_translations
        bi[b, K.B_NM] = modal.n_modes
        bi[b, K.B_PROF] = -1
        bf[b, 0:3] = body.origin
        if isinstance(body, TranslatingBody):
            bi[b, K.B_KIND] = K.KIND_TRANSLATING
            bf[b, 3 : 3 + 3 * body.n_translations] = body.axes.reshape(-1)
            coupling = body.axes @ modal.translation_coupling  # (na, r)
            schur = modal.mass * body.axes @ body.axes.T - coupling @ coupling.T
            if np.linalg.eigvalsh(schur).min() <= 1e-12 * modal.mass:
                raise InvalidParameterError(
                    f"body {body.name!r}: mass matrix [[m P P^T, P C_t], [C_t^T P^T, I]] is not "
                    "positive definite (check mass and translation_coupling)"
                )
            bi[b, K.B_MAT0] = pools.addf(np.linalg.inv(schur))
            pools.addf(coupling)
            translation_axes[body.name] = body.axes
        elif isinstance(body, RotatingBody):
            bi[b, K.B_KIND] = K.KIND_ROTATING
            bf[b, 12:15] = body.axis
            mats = body.rotated_matrices()
            bi[b, K.B_MAT0] = pools.addf(mats["gyroscopic"])
            pools.addf(mats["centrifugal"])
            pools.addf(mats["centrifugal_load"])
            pools.addf(mats["euler_load"])
            bi[b, K.B_SPEED] = table.add(body.speed, f"body {body.name!r} rotation speed")
            bi[b, K.B_PROF] = ctx.add_profile(body.profile)
        else:
            bi[b, K.B_KIND] = K.KIND_FIXED

    # the element tables, in the layout's order (rows and slots keep it)
    for name in TABLES:
        for e in elements:
            if e.table == name:
                e.compile(ctx)
    contacts = ctx.rows["contacts"]

    if not table.slots:
        table.add(0.0, "unused")
    data = (
        ndof,
        bi,
        bf,
        np.array(node_xbar, dtype=np.float64).reshape(-1, 3),
        dof_k2,
        dof_c,
        np.concatenate(pools.f) if pools.f else np.zeros(1),
        np.concatenate(pools.i) if pools.i else np.zeros(1, dtype=np.int64),
        np.array(ctx.profiles, dtype=np.int64).reshape(-1, 2),
        np.array(ctx.rows["springs"], dtype=np.int64).reshape(-1, 5),
        np.array(ctx.rows["nodal_forces"], dtype=np.int64).reshape(-1, 5),
        np.array([row for row, _ in contacts], dtype=np.int64).reshape(-1, 14),
        np.array([floats for _, floats in contacts], dtype=np.float64).reshape(-1, 15),
    )
    return CompiledSystem(data, table, ndof, body_dofs, dict(motions), translation_axes)
