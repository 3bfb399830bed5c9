"""ModalBody instances built from lumped point masses (rigid bodies, spring-mass chains).

These are exact modal bodies of discrete systems, used for rigid bodies (zero
modes), for minimal models (Hoffmann's two-degree-of-freedom friction model, a
point mass on springs in a rotating frame) and for tests until a finite-element
body is at hand. The inertia shape integrals are the lumped-mass sums of the
integrals listed in :class:`~fuzzymbs.mbs.modal_body.ModalBody`.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.modal_body import ModalBody


def skew(vector: ArrayLike) -> NDArray[np.float64]:
    """Cross-product matrix: ``skew(a) @ b == a x b``."""
    a = np.asarray(vector, dtype=float)
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def shape_integrals(
    positions: NDArray[np.float64], masses: NDArray[np.float64], modes: NDArray[np.float64]
) -> dict[str, NDArray[np.float64]]:
    """Inertia shape integrals of point masses at ``positions`` with ``modes`` (k, 3, r)."""
    r = modes.shape[2]
    unit = np.eye(3)
    skews = [skew(unit[i]) for i in range(3)]
    first_moment = masses @ positions
    inertia = np.zeros((3, 3))
    coupling_t = np.zeros((3, r))
    coupling_r = np.zeros((3, r))
    gyro = np.zeros((3, r, r))
    centri = np.zeros((3, 3, r, r))
    centri_load = np.zeros((3, 3, r))
    for m, x, psi in zip(masses, positions, modes, strict=True):
        inertia += m * (x @ x * unit - np.outer(x, x))
        coupling_t += m * psi
        coupling_r += m * skew(x) @ psi
        for i in range(3):
            gyro[i] += m * psi.T @ skews[i] @ psi
            for j in range(3):
                ee = skews[i] @ skews[j]
                centri[i, j] += m * psi.T @ ee @ psi
                centri_load[i, j] += m * psi.T @ ee @ x
    return {
        "first_moment": first_moment,
        "inertia_tensor": inertia,
        "translation_coupling": coupling_t,
        "rotation_coupling": coupling_r,
        "gyroscopic": gyro,
        "centrifugal": centri,
        "centrifugal_load": centri_load,
    }


def lumped_modal_body(
    name: str,
    positions: ArrayLike,
    masses: ArrayLike,
    stiffness: ArrayLike | None = None,
    *,
    free_dofs: ArrayLike | None = None,
    node_sets: dict[str, ArrayLike] | None = None,
    face_sets: dict[str, ArrayLike] | None = None,
) -> ModalBody:
    """Modal body of point masses joined by a stiffness matrix.

    Parameters
    ----------
    name : str
        Body name.
    positions : array_like, shape (k, 3)
        Node positions xbar in the body frame [m].
    masses : array_like, shape (k,)
        Point masses [kg], all > 0.
    stiffness : array_like, shape (3k, 3k), optional
        Symmetric positive semi-definite stiffness matrix [N/m] over the dofs
        ordered (node, x/y/z). ``None`` (or ``free_dofs`` empty) gives a rigid body.
    free_dofs : array_like of int, optional
        Dofs (indices into the 3k) that may deform; all others are held by the
        body frame. Default: all dofs when ``stiffness`` is given, none otherwise.
        Modes with zero frequency (rigid-body motions of the free dofs) are dropped.
    node_sets, face_sets : dict, optional
        Named node index sets and quadrilateral faces (rows of 4 node indices).

    Returns
    -------
    ModalBody
        Mass-normalised modes (``Psi^T M Psi = I``) sorted by frequency.
    """
    x = np.asarray(positions, dtype=float).reshape(-1, 3)
    m = np.asarray(masses, dtype=float).reshape(-1)
    if m.shape[0] != x.shape[0] or np.any(~(m > 0)):
        raise InvalidParameterError(
            f"body {name!r}: masses must be positive, one per node ({x.shape[0]} nodes), got {m}"
        )
    n = 3 * x.shape[0]
    if stiffness is None:
        free = np.zeros(0, dtype=np.int64)
    else:
        k_full = np.asarray(stiffness, dtype=float)
        if k_full.shape != (n, n) or not np.allclose(k_full, k_full.T, atol=0, rtol=1e-12):
            raise InvalidParameterError(
                f"body {name!r}: stiffness must be symmetric of shape ({n}, {n}), "
                f"got {k_full.shape}"
            )
        free = np.arange(n) if free_dofs is None else np.asarray(free_dofs, dtype=np.int64)
    modes = np.zeros((x.shape[0], 3, 0))
    omega = np.zeros(0)
    if free.size:
        mass_diag = np.repeat(m, 3)[free]
        k_red = k_full[np.ix_(free, free)]
        eigval, eigvec = scipy.linalg.eigh(k_red, np.diag(mass_diag))
        if eigval.min() < -1e-9 * max(abs(eigval).max(), 1.0):
            raise InvalidParameterError(f"body {name!r}: stiffness is not positive semi-definite")
        keep = eigval > 1e-10 * max(eigval.max(), 1e-300)
        full = np.zeros((n, int(keep.sum())))
        full[free] = eigvec[:, keep]  # eigh normalises to phi^T M phi = 1
        modes = full.reshape(x.shape[0], 3, -1)
        omega = np.sqrt(eigval[keep])
    return ModalBody(
        name=name,
        mass=float(m.sum()),
        node_ids=np.arange(x.shape[0], dtype=np.int64),
        node_positions=x,
        mode_shapes=modes,
        frequencies=omega,
        **shape_integrals(x, m, modes),
        node_sets={k: np.asarray(v, dtype=np.int64) for k, v in (node_sets or {}).items()},
        face_sets={k: np.asarray(v, dtype=np.int64) for k, v in (face_sets or {}).items()},
    )


def rigid_body(
    name: str,
    mass: float,
    positions: ArrayLike = ((0.0, 0.0, 0.0),),
    *,
    node_sets: dict[str, ArrayLike] | None = None,
) -> ModalBody:
    """A rigid body (zero modes) of total ``mass`` [kg] whose nodes are ``positions`` [m].

    The mass is spread evenly over the nodes (it only matters through the total
    for a translating body; nodes are attachment points).
    """
    x = np.asarray(positions, dtype=float).reshape(-1, 3)
    if not mass > 0:
        raise InvalidParameterError(f"body {name!r}: mass must be > 0 kg, got {mass!r}")
    return lumped_modal_body(
        name, x, np.full(x.shape[0], mass / x.shape[0]), None, node_sets=node_sets
    )
