"""Modal reduction of an elastic body: modal truncation, static correction, Craig-Bampton.

Every method builds a full-DOF basis T (3n x m) and then re-orthonormalises it
with the reduced eigenproblem ``(T^T K T) Q = (T^T M T) Q Lambda`` so that the
final basis ``Psi = T Q`` is mass-normalised (``Psi^T M Psi = I``) with diagonal
stiffness (``Psi^T K Psi = diag(omega^2)``), frequencies ascending.

- ``"modal"``: the lowest ``n_modes`` elastic eigenmodes (modal truncation).
- ``"static"``: modal truncation plus one static (attachment) mode per interface
  DOF (``K^{-1}`` of a unit load; inertia-relief attachment modes on a free body:
  the load minus its rigid-body resultant, solved with the rigid motion
  constrained by ``R^T M x = 0``). Exact for static loads at the interface.
- ``"craig_bampton"``: constraint modes of the interface DOFs plus ``n_modes``
  fixed-interface eigenmodes (Craig & Bampton, AIAA J. 6 (1968) 1313).

Eigenproblems use shift-invert ``eigsh`` with a negative shift
(``sigma = -(2 pi 100 Hz)^2``): ``K - sigma M`` is positive definite even for a
free-free body, and the eigenvalues nearest sigma are the lowest ones. With
``sigma = 0`` the factorisation of a singular K returns wrong, run-to-run
varying frequencies (THEORY section 3). The start vector is fixed, so repeated
calls give identical results.

Rigid-body modes of a free-free body (six, found by their mass-weighted
projection on the exact rigid-body fields) are excluded from the elastic basis
by default: the multibody engine carries rigid motion itself.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal, ParamSpec, TypeVar

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.linalg import LinearOperator, eigsh, splu

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fe import cache as fe_cache
from fuzzymbs.fe.inertia import cross_axis, inertia_integrals
from fuzzymbs.fe.reducible import ReducibleBody
from fuzzymbs.fe.stress_stiffening import stress_stiffening as centrifugal_stiffening
from fuzzymbs.fe.surfaces import boundary_faces
from fuzzymbs.mbs.modal_body import ModalBody

__all__ = [
    "DEFAULT_SHIFT",
    "METHODS",
    "ReducedBasis",
    "craig_bampton",
    "modal_truncation",
    "reduce_body",
    "rigid_body_basis",
    "static_correction",
]

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: shift of the shift-invert eigensolver [rad^2/s^2]: -(2 pi 100 Hz)^2
DEFAULT_SHIFT = -((2.0 * np.pi * 100.0) ** 2)

METHODS = ("modal", "static", "craig_bampton")

RigidOption = Literal["exclude", "include"]

#: a mode is a rigid-body mode when its mass-weighted projection on the rigid fields exceeds this
_RIGID_PROJECTION = 0.5


@dataclass(frozen=True)
class ReducedBasis:
    """A mass-normalised full-DOF reduced basis.

    Attributes
    ----------
    modes : ndarray, shape (3n, r)
        Psi on all DOFs (zero at clamped DOFs).
    frequencies : ndarray, shape (r,)
        Angular frequencies omega [rad/s], ascending.
    method : str
        ``"modal"``, ``"static"`` or ``"craig_bampton"``.
    rigid_frequencies : ndarray
        Angular frequencies of the rigid-body modes found and excluded [rad/s]
        (free-free bodies; near zero).
    dropped_frequencies : ndarray
        Angular frequencies removed by ``max_frequency`` [rad/s].
    """

    modes: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    method: str
    rigid_frequencies: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    dropped_frequencies: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))


# ---------------------------------------------------------------------------- helpers


def rigid_body_basis(nodes: NDArray[np.float64], mass_matrix: sp.spmatrix) -> NDArray[np.float64]:
    """Mass-orthonormal rigid-body fields R (3n x 6): three translations, three rotations."""
    n_dofs = 3 * nodes.shape[0]
    translations = np.zeros((n_dofs, 3))
    for i in range(3):
        translations[i::3, i] = 1.0
    total_mass = float(translations[:, 0] @ (mass_matrix @ translations[:, 0]))
    centre = (translations.T @ (mass_matrix @ nodes.reshape(n_dofs))) / total_mass
    relative = (nodes - centre).reshape(n_dofs)
    rotations = np.column_stack([cross_axis(relative, i) for i in range(3)])
    fields = np.hstack([translations, rotations])
    gram = fields.T @ (mass_matrix @ fields)
    factor = la.cholesky(0.5 * (gram + gram.T), lower=True)
    return la.solve_triangular(factor, fields.T, lower=True).T


def _single_threaded_blas() -> contextlib.AbstractContextManager[Any]:
    """Pin BLAS to one thread while reducing, when threadpoolctl is installed.

    The reduction is dominated by level-1/2 BLAS on tall vectors; on a loaded
    machine (or inside a busy Dask worker) multi-threaded OpenBLAS spin-waits and
    was measured 5-13x slower than one thread (3744-node disc, 2 cores).
    Without threadpoolctl this is a no-op: set OPENBLAS_NUM_THREADS=1 instead.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def _blas_pinned(function: Callable[_P, _R]) -> Callable[_P, _R]:
    """Run ``function`` under :func:`_single_threaded_blas`."""

    @functools.wraps(function)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with _single_threaded_blas():
            return function(*args, **kwargs)

    return wrapper


def _factorise(matrix: sp.spmatrix) -> Any:
    """Sparse LU of a symmetric matrix; minimum-degree ordering on A^T + A.

    For FE matrices this fills in ~5x less and factorises ~20x faster than
    SuperLU's default COLAMD ordering.
    """
    return splu(sp.csc_matrix(matrix), permc_spec="MMD_AT_PLUS_A")


def _lowest_eigenpairs(
    stiffness: sp.spmatrix, mass: sp.spmatrix, count: int, sigma: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ``count`` lowest eigenpairs of K x = lambda M x by shift-invert about ``sigma < 0``."""
    n = stiffness.shape[0]
    if count > n:
        raise InvalidParameterError(
            f"{count} eigenmodes requested (n_modes plus the rigid-body modes of a free body), "
            f"but the body has only {n} free DOFs; lower n_modes or refine the mesh"
        )
    if count >= n - 1:
        # tiny problems: dense solver (eigsh needs k < n)
        values, vectors = la.eigh(stiffness.toarray(), mass.toarray())
        return values[:count], vectors[:, :count]
    factor = _factorise((stiffness - sigma * mass).tocsc())
    shifted_inverse = LinearOperator((n, n), matvec=factor.solve, dtype=np.float64)
    start = np.random.default_rng(20240917).standard_normal(n)  # fixed: reproducible results
    values, vectors = eigsh(
        stiffness, k=count, M=mass, sigma=sigma, which="LM", OPinv=shifted_inverse, v0=start
    )
    order = np.argsort(values)
    return values[order], vectors[:, order]


def _angular(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """omega = sqrt(lambda), with round-off negatives of rigid modes clipped to 0."""
    return np.sqrt(np.clip(values, 0.0, None))


def _orthonormalise(
    basis: NDArray[np.float64],
    stiffness: sp.spmatrix,
    mass: sp.spmatrix,
    block_size: int = 32,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Re-orthonormalise a basis with the reduced eigenproblem.

    The columns are first made mass-orthonormal by block classical Gram-Schmidt
    with re-orthogonalisation (CGS2): each block of columns is projected twice
    against the accepted ones (matrix-matrix products), then orthonormalised
    column by column (again twice), and finally polished against the accepted
    columns once more. This is accurate to round-off whatever the conditioning
    of the basis: attachment modes of neighbouring nodes are nearly parallel,
    and a Gram-matrix (``T^T M T``) approach would square that conditioning.
    Columns whose remainder falls below 1e-10 of their mass norm are linearly
    dependent on the earlier ones and dropped. Then ``Q^T K Q = V diag(omega^2)
    V^T`` and ``Psi = Q V``.

    Returns (omega^2 ascending, Psi).
    """
    n_dofs, n_columns = basis.shape
    norms = np.sqrt(np.einsum("ij,ij->j", basis, mass @ basis))
    if not np.all(np.isfinite(norms)) or np.any(norms <= 0.0):
        raise InvalidParameterError("reduced basis has a zero or non-finite column")
    basis = basis / norms
    q_all = np.empty((n_dofs, n_columns))  # accepted columns q_all[:, :accepted]
    mass_q_all = np.empty((n_dofs, n_columns))
    accepted = 0
    for start in range(0, n_columns, block_size):
        q, mass_q = q_all[:, :accepted], mass_q_all[:, :accepted]
        block = basis[:, start : start + block_size].copy()
        for _ in range(2):
            block -= q @ (mass_q.T @ block)
        local = np.empty((n_dofs, block.shape[1]))
        mass_local = np.empty((n_dofs, block.shape[1]))
        kept = 0
        for column in range(block.shape[1]):
            vector = block[:, column]
            for _ in range(2):
                vector = vector - local[:, :kept] @ (mass_local[:, :kept].T @ vector)
            mass_vector = mass @ vector
            norm = np.sqrt(max(float(vector @ mass_vector), 0.0))
            if norm < 1e-10:
                continue  # linearly dependent on the columns before it
            local[:, kept] = vector / norm
            mass_local[:, kept] = mass_vector / norm
            kept += 1
        local, mass_local = local[:, :kept], mass_local[:, :kept]
        if kept and q.shape[1]:
            # polish: remove the round-off components along earlier blocks, then restore
            # unit norms with the (near-identity) Gram matrix of the block
            local -= q @ (mass_q.T @ local)
            mass_local = mass @ local
            gram = local.T @ mass_local
            factor = la.cholesky(0.5 * (gram + gram.T), lower=True)
            local = la.solve_triangular(factor, local.T, lower=True).T
            mass_local = la.solve_triangular(factor, mass_local.T, lower=True).T
        q_all[:, accepted : accepted + kept] = local
        mass_q_all[:, accepted : accepted + kept] = mass_local
        accepted += kept
    q = q_all[:, :accepted]
    reduced_stiffness = q.T @ (stiffness @ q)
    values, rotation = la.eigh(0.5 * (reduced_stiffness + reduced_stiffness.T))
    return values, q @ rotation


def _split_rigid(
    values: NDArray[np.float64],
    modes: NDArray[np.float64],
    rigid: NDArray[np.float64] | None,
    mass: sp.spmatrix,
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Mask of rigid-body modes (projection on the rigid fields) and their frequencies."""
    if rigid is None:
        return np.zeros(values.size, dtype=bool), np.zeros(0)
    projection = np.linalg.norm(rigid.T @ (mass @ modes), axis=0)
    is_rigid = projection > _RIGID_PROJECTION
    return is_rigid, _angular(values[is_rigid])


def _expand(body: ReducibleBody, free_vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    full = np.zeros((body.n_dofs, free_vectors.shape[1]))
    full[body.free_dofs] = free_vectors
    return full


def _interface_dofs(
    body: ReducibleBody, interface_nodes: NDArray[np.int64], components: Sequence[int]
) -> NDArray[np.int64]:
    components = sorted({int(c) for c in components})
    if not components or not set(components) <= {0, 1, 2}:
        raise InvalidParameterError(
            f"interface_components must be a non-empty subset of (0, 1, 2), got {components!r}"
        )
    if interface_nodes.size == 0:
        raise InvalidParameterError("the interface selects no node; give interface=...")
    # clamped interface nodes do not move: their DOFs need no static/constraint mode
    interface_nodes = np.setdiff1d(interface_nodes, body.fixed_nodes)
    if interface_nodes.size == 0:
        raise InvalidParameterError(
            "every interface node is clamped; interface nodes must include free nodes"
        )
    return (3 * interface_nodes[:, None] + np.asarray(components)).ravel()


def _finish(
    body: ReducibleBody,
    basis: NDArray[np.float64],
    method: str,
    rigid_body_modes: RigidOption,
    max_frequency: float | None,
    expect_rigid: int | None,
) -> ReducedBasis:
    """Orthonormalise, split off rigid-body modes and apply the frequency limit."""
    stiffness, mass = body.stiffness, body.mass_matrix
    values, modes = _orthonormalise(basis, stiffness, mass)
    rigid = body.rigid_body_modes() if body.is_free else None
    is_rigid, rigid_frequencies = _split_rigid(values, modes, rigid, mass)
    if expect_rigid is not None and int(is_rigid.sum()) != expect_rigid:
        raise InvalidParameterError(
            f"body {body.name!r}: found {int(is_rigid.sum())} rigid-body modes, expected "
            f"{expect_rigid}; is the mesh connected and the body either free or clamped?"
        )
    if rigid_body_modes == "exclude" and rigid is not None:
        elastic = modes[:, ~is_rigid]
        # remove round-off rigid content so that C_t = int rho Psi dV vanishes exactly
        elastic = elastic - rigid @ (rigid.T @ (mass @ elastic))
        values, modes = _orthonormalise(elastic, stiffness, mass)
    omega = _angular(values)
    # deterministic sign: the largest-magnitude entry of each mode is positive
    largest = np.argmax(np.abs(modes), axis=0)
    modes = modes * np.where(modes[largest, np.arange(modes.shape[1])] < 0, -1.0, 1.0)
    dropped = np.zeros(0)
    if max_frequency is not None:
        keep = omega <= 2.0 * np.pi * max_frequency
        dropped = omega[~keep]
        omega, modes = omega[keep], modes[:, keep]
        if omega.size == 0:
            raise InvalidParameterError(
                f"max_frequency={max_frequency} Hz removes every mode of body {body.name!r}"
            )
    return ReducedBasis(
        modes=modes,
        frequencies=omega,
        method=method,
        rigid_frequencies=rigid_frequencies,
        dropped_frequencies=dropped,
    )


def _check_options(n_modes: int, rigid_body_modes: str, max_frequency: float | None) -> None:
    if isinstance(n_modes, bool) or not isinstance(n_modes, int | np.integer) or n_modes < 0:
        raise InvalidParameterError(f"n_modes must be an integer >= 0, got {n_modes!r}")
    if rigid_body_modes not in ("exclude", "include"):
        raise InvalidParameterError(
            f"rigid_body_modes must be 'exclude' or 'include', got {rigid_body_modes!r}"
        )
    if max_frequency is not None and (
        isinstance(max_frequency, bool)
        or not isinstance(max_frequency, int | float | np.number)
        or not (np.isfinite(max_frequency) and max_frequency > 0)
    ):
        raise InvalidParameterError(
            f"max_frequency must be > 0 [Hz] or None, got {max_frequency!r}"
        )


# ---------------------------------------------------------------------------- methods


@_blas_pinned
def modal_truncation(
    body: ReducibleBody,
    n_modes: int,
    rigid_body_modes: RigidOption = "exclude",
    max_frequency: float | None = None,
    sigma: float = DEFAULT_SHIFT,
) -> ReducedBasis:
    """The ``n_modes`` lowest elastic eigenmodes (plus the rigid ones if ``"include"``).

    Parameters
    ----------
    body
        The elastic body (clamped or free-free).
    n_modes
        Number of elastic modes.
    rigid_body_modes
        ``"exclude"`` (default) or ``"include"`` the six rigid-body modes of a
        free-free body (ignored for a clamped body).
    max_frequency
        Drop modes above this frequency [Hz].
    sigma
        Shift of the shift-invert solver [rad^2/s^2], must be < 0.
    """
    _check_options(n_modes, rigid_body_modes, max_frequency)
    if not sigma < 0:
        raise InvalidParameterError(f"sigma must be negative [rad^2/s^2], got {sigma!r}")
    if n_modes == 0:
        raise InvalidParameterError("modal truncation needs n_modes >= 1")
    free = body.free_dofs
    stiffness = body.stiffness[free][:, free]
    mass = body.mass_matrix[free][:, free]
    n_rigid = 6 if body.is_free else 0
    values, vectors = _lowest_eigenpairs(stiffness, mass, n_modes + n_rigid, sigma)
    modes = _expand(body, vectors)
    rigid = body.rigid_body_modes() if body.is_free else None
    is_rigid, rigid_frequencies = _split_rigid(values, modes, rigid, body.mass_matrix)
    if int(is_rigid.sum()) != n_rigid:
        raise InvalidParameterError(
            f"body {body.name!r}: found {int(is_rigid.sum())} rigid-body modes among the "
            f"lowest eigenmodes, expected {n_rigid}; is the mesh connected?"
        )
    if rigid_body_modes == "exclude":
        modes = modes[:, ~is_rigid]
    # eigsh vectors are M-orthonormal already; _finish polishes them and orders them
    result = _finish(
        body,
        modes,
        "modal",
        rigid_body_modes,
        max_frequency,
        expect_rigid=0 if rigid_body_modes == "exclude" else n_rigid,
    )
    return replace(result, rigid_frequencies=rigid_frequencies)


@_blas_pinned
def static_correction(
    body: ReducibleBody,
    n_modes: int,
    interface_nodes: NDArray[np.int64],
    interface_components: Sequence[int] = (0, 1, 2),
    max_frequency: float | None = None,
    sigma: float = DEFAULT_SHIFT,
) -> ReducedBasis:
    """Modal truncation enriched with static (attachment) modes of the interface DOFs.

    On a clamped body the attachment modes are ``K^{-1} e_d`` for each interface
    DOF d. On a free-free body they are inertia-relief attachment modes: the unit
    load minus its rigid-body resultant ``M R R^T e_d``, solved with
    ``[[K, M R], [R^T M, 0]] [x; l] = [e_d - M R R^T e_d; 0]``.
    Rigid-body modes are excluded.
    """
    _check_options(n_modes, "exclude", max_frequency)
    dofs = _interface_dofs(body, interface_nodes, interface_components)
    loads = np.zeros((body.n_dofs, dofs.size))
    loads[dofs, np.arange(dofs.size)] = 1.0
    stiffness, mass = body.stiffness, body.mass_matrix
    if body.is_free:
        rigid = body.rigid_body_modes()
        mass_rigid = mass @ rigid
        loads = loads - mass_rigid @ (rigid.T @ loads)
        bordered = sp.bmat(
            [[stiffness, sp.csr_matrix(mass_rigid)], [sp.csr_matrix(mass_rigid.T), None]]
        ).tocsc()
        rhs = np.vstack([loads, np.zeros((6, dofs.size))])
        attachment = _factorise(bordered).solve(rhs)[: body.n_dofs]
    else:
        free = body.free_dofs
        factor = _factorise(stiffness[free][:, free].tocsc())
        attachment = _expand(body, factor.solve(np.ascontiguousarray(loads[free])))
    parts = [attachment]
    if n_modes > 0:
        parts.insert(0, modal_truncation(body, n_modes, "exclude", None, sigma).modes)
    return _finish(body, np.hstack(parts), "static", "exclude", max_frequency, expect_rigid=0)


@_blas_pinned
def craig_bampton(
    body: ReducibleBody,
    n_modes: int,
    interface_nodes: NDArray[np.int64],
    interface_components: Sequence[int] = (0, 1, 2),
    rigid_body_modes: RigidOption = "exclude",
    max_frequency: float | None = None,
    sigma: float = DEFAULT_SHIFT,
) -> ReducedBasis:
    """Craig-Bampton basis: interface constraint modes plus fixed-interface eigenmodes.

    The interior DOFs I (all free DOFs but the interface DOFs B) follow
    ``x_I = -K_II^{-1} K_IB x_B`` in the constraint modes; the fixed-interface
    modes are the lowest ``n_modes`` eigenmodes of ``(K_II, M_II)``. On a
    free-free body the interface must hold the body statically (e.g. three
    non-collinear nodes with all components), otherwise ``K_II`` is singular.
    """
    _check_options(n_modes, rigid_body_modes, max_frequency)
    boundary = _interface_dofs(body, interface_nodes, interface_components)
    free = body.free_dofs
    interior = np.setdiff1d(free, boundary)
    stiffness, mass = body.stiffness, body.mass_matrix
    if body.is_free:
        # K_II is singular exactly when some rigid motion leaves the interface DOFs at rest
        restricted = body.rigid_body_modes()[boundary]
        singular_values = np.linalg.svd(restricted, compute_uv=False)
        if singular_values.size < 6 or singular_values[-1] < 1e-8 * singular_values[0]:
            raise InvalidParameterError(
                f"body {body.name!r}: the interior stiffness K_II is singular, the interface "
                "does not hold the free body (some rigid motion leaves it at rest); use three "
                "or more non-collinear interface nodes with all components, or clamp the body"
            )
    k_ii = stiffness[interior][:, interior].tocsc()
    k_ib = stiffness[interior][:, boundary]
    try:
        factor = _factorise(k_ii)
        interior_response = -factor.solve(np.ascontiguousarray(k_ib.toarray()))
    except RuntimeError as error:
        raise InvalidParameterError(
            f"body {body.name!r}: the interior stiffness K_II is singular, the interface "
            "does not hold the body; add interface nodes/components or clamp the body"
        ) from error
    residual = k_ii @ interior_response + k_ib
    if (
        not np.all(np.isfinite(interior_response))
        or np.abs(residual).max() > 1e-6 * abs(k_ib).max()
    ):
        raise InvalidParameterError(
            f"body {body.name!r}: the interior stiffness K_II is singular, the interface "
            "does not hold the body; add interface nodes/components or clamp the body"
        )
    constraint = np.zeros((body.n_dofs, boundary.size))
    constraint[boundary, np.arange(boundary.size)] = 1.0
    constraint[interior] = interior_response
    parts = [constraint]
    if n_modes > 0:
        _, fixed_interface = _lowest_eigenpairs(k_ii, mass[interior][:, interior], n_modes, sigma)
        normal = np.zeros((body.n_dofs, n_modes))
        normal[interior] = fixed_interface
        parts.append(normal)
    return _finish(
        body,
        np.hstack(parts),
        "craig_bampton",
        rigid_body_modes,
        max_frequency,
        expect_rigid=None,
    )


# ---------------------------------------------------------------------------- ModalBody


NodeSpec = str | Callable[[NDArray[np.float64]], NDArray[np.bool_]] | ArrayLike


@_blas_pinned
def reduce_body(
    body: ReducibleBody,
    n_modes: int,
    method: str = "modal",
    interface: NodeSpec | None = None,
    interface_components: Sequence[int] = (0, 1, 2),
    node_sets: Mapping[str, NodeSpec] | None = None,
    face_sets: Mapping[str, str | ArrayLike] | None = None,
    max_frequency: float | None = None,
    rigid_body_modes: RigidOption = "exclude",
    cache: bool = True,
    stress_stiffening: bool = False,
) -> ModalBody:
    """Reduce a body and package it as a :class:`~fuzzymbs.mbs.modal_body.ModalBody`.

    Parameters
    ----------
    body
        The elastic body.
    n_modes
        ``"modal"``: elastic eigenmodes kept; ``"static"``: eigenmodes before the
        attachment modes are added; ``"craig_bampton"``: fixed-interface modes.
    method
        ``"modal"``, ``"static"`` or ``"craig_bampton"``.
    interface
        Interface nodes for ``"static"``/``"craig_bampton"``: boundary name,
        coordinate predicate or node indices. Kept as node set ``"interface"``.
    interface_components
        Displacement components (0, 1, 2 = x, y, z) of the interface nodes that
        get static/constraint modes (e.g. ``(1,)`` for normal loads along y only).
    node_sets
        ``name -> nodes`` (boundary name, predicate on coordinates (3, n) or node
        indices): the nodes forces and contacts act on. Only these nodes (and the
        face and interface nodes) are kept in the ModalBody; with no sets at all,
        every node is kept.
    face_sets
        ``name -> faces``: a boundary name or rows of node indices (e.g. from
        :func:`fuzzymbs.fe.surfaces.faces_in_region`), in the local node order of
        :mod:`fuzzymbs.fe.surfaces`.
    max_frequency
        Drop reduced modes above this frequency [Hz] (explicit RK4 is stable while
        omega_max dt < 2.8).
    rigid_body_modes
        ``"exclude"`` (default) or ``"include"`` the rigid-body modes of a
        free-free body in the basis.
    cache
        Load/store the result in the on-disk cache (:mod:`fuzzymbs.fe.cache`).
    stress_stiffening
        Also compute the geometric stiffness of the body's own centrifugal prestress
        (``ModalBody.stress_stiffening``, :mod:`fuzzymbs.fe.stress_stiffening`): a
        clamped body turning about its frame origin, a rotor blade, a spin-up beam.

    Returns
    -------
    ModalBody
        Node sets and face sets index into the kept nodes.
    """
    if method not in METHODS:
        raise InvalidParameterError(f"method must be one of {METHODS}, got {method!r}")
    _check_options(n_modes, rigid_body_modes, max_frequency)

    sets = {name: body.node_set(spec) for name, spec in (node_sets or {}).items()}
    interface_nodes = body.node_set(interface) if interface is not None else None
    if method != "modal":
        if interface_nodes is None or interface_nodes.size == 0:
            raise InvalidParameterError(f"method {method!r} needs interface nodes (interface=...)")
        sets.setdefault("interface", interface_nodes)
    faces: dict[str, NDArray[np.int64]] = {}
    for name, spec in (face_sets or {}).items():
        rows = boundary_faces(body.mesh, spec) if isinstance(spec, str) else np.asarray(spec)
        if (
            rows.ndim != 2
            or rows.shape[1] not in (3, 4, 6, 9)
            or not np.issubdtype(rows.dtype, np.integer)
        ):
            raise InvalidParameterError(
                f"face set {name!r} must be a boundary name or an integer array (faces, 3|4|6|9)"
            )
        if rows.size and (rows.min() < 0 or rows.max() >= body.n_nodes):
            raise InvalidParameterError(f"face set {name!r} has node indices outside the mesh")
        faces[name] = rows.astype(np.int64)

    key_inputs: dict[str, Any] = {
        "n_modes": int(n_modes),
        "method": method,
        "interface": interface_nodes,
        "interface_components": sorted({int(c) for c in interface_components}),
        "max_frequency": max_frequency,
        "rigid_body_modes": rigid_body_modes,
        "node_sets": sets,
        "face_sets": faces,
    }
    if stress_stiffening:  # only then: the keys of the bodies cached before stay valid
        key_inputs["stress_stiffening"] = True
    key = fe_cache.reduction_key(body, key_inputs) if cache else None
    if key is not None:
        stored = fe_cache.load(key, name=body.name)
        # an entry without the stiffening asked for (an older file) is computed again
        if stored is not None and (not stress_stiffening or stored.stress_stiffening is not None):
            return stored

    if method == "modal":
        basis = modal_truncation(body, n_modes, rigid_body_modes, max_frequency)
    elif method == "static":
        assert interface_nodes is not None
        if rigid_body_modes == "include" and body.is_free:
            raise InvalidParameterError("method 'static' supports rigid_body_modes='exclude' only")
        basis = static_correction(
            body, n_modes, interface_nodes, interface_components, max_frequency
        )
    else:
        assert interface_nodes is not None
        basis = craig_bampton(
            body, n_modes, interface_nodes, interface_components, rigid_body_modes, max_frequency
        )
    modal_body = assemble_modal_body(body, basis, sets, faces)
    if stress_stiffening:
        modal_body = dataclasses.replace(
            modal_body, stress_stiffening=centrifugal_stiffening(body, basis.modes)
        )
    if key is not None:
        fe_cache.store(key, modal_body)
    return modal_body


def assemble_modal_body(
    body: ReducibleBody,
    basis: ReducedBasis,
    node_sets: Mapping[str, NDArray[np.int64]],
    face_sets: Mapping[str, NDArray[np.int64]],
) -> ModalBody:
    """Inertia integrals from the full basis; mode shapes kept at the used nodes only."""
    used = [np.asarray(v, dtype=np.int64).ravel() for v in node_sets.values()]
    used += [v.ravel() for v in face_sets.values()]
    kept = np.unique(np.concatenate(used)) if used else np.arange(body.n_nodes)
    integrals = inertia_integrals(body.mass_matrix, body.nodes, basis.modes)
    shapes = basis.modes.reshape(body.n_nodes, 3, -1)[kept]
    return ModalBody(
        name=body.name,
        node_ids=kept,
        node_positions=body.nodes[kept].copy(),
        mode_shapes=np.ascontiguousarray(shapes),
        frequencies=basis.frequencies.copy(),
        node_sets={k: np.searchsorted(kept, v).astype(np.int64) for k, v in node_sets.items()},
        face_sets={k: np.searchsorted(kept, v).astype(np.int64) for k, v in face_sets.items()},
        **integrals,
    )
