"""Inertia shape integrals of a modally reduced body (floating frame of reference).

All integrals are evaluated with the consistent FE mass matrix M on full-DOF
vectors (node j holds DOFs 3 j .. 3 j + 2), following the Standard Input Data
(SID) of Wallrapp / Schwertassek, Wallrapp & Shabana (1999):

    int rho u . v dV = U^T M V

``E_i`` applies ``skew(e_i)`` (the cross product ``e_i x``) node by node, so
``int rho skew(xbar) Psi dV`` has rows ``(E_i xbar)^T M Psi`` (because
``e_i . (x x psi) = (e_i x x) . psi``) and the inertia tensor is
``J_ij = (E_i xbar)^T M (E_j xbar)``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

__all__ = ["cross_axis", "inertia_integrals"]


def cross_axis(vectors: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    """Apply ``E_axis``: ``e_axis x v`` at every node of full-DOF vectors (3n,) or (3n, r)."""
    shape = vectors.shape
    v = vectors.reshape(-1, 3, *shape[1:])
    out = np.zeros_like(v)
    # e_0 x v = (0, -v_z, v_y); e_1 x v = (v_z, 0, -v_x); e_2 x v = (-v_y, v_x, 0)
    j, k = (axis + 1) % 3, (axis + 2) % 3
    out[:, j] = -v[:, k]
    out[:, k] = v[:, j]
    return out.reshape(shape)


def inertia_integrals(
    mass_matrix: sp.spmatrix, nodes: NDArray[np.float64], modes: NDArray[np.float64]
) -> dict[str, NDArray[np.float64] | float]:
    """Mass, first moment, inertia tensor and the modal inertia shape integrals.

    Parameters
    ----------
    mass_matrix
        Consistent mass matrix M (3n x 3n) [kg] of the unconstrained body.
    nodes
        Undeformed node positions xbar (n, 3) [m] in the body frame.
    modes
        Full-DOF reduced basis Psi (3n, r), mass-normalised.

    Returns
    -------
    dict
        Keys and shapes as the fields of :class:`fuzzymbs.mbs.modal_body.ModalBody`:
        ``mass`` (float, kg), ``first_moment`` (3,), ``inertia_tensor`` (3, 3),
        ``translation_coupling`` (3, r), ``rotation_coupling`` (3, r),
        ``gyroscopic`` (3, r, r), ``centrifugal`` (3, 3, r, r),
        ``centrifugal_load`` (3, 3, r).
    """
    n_dofs = 3 * nodes.shape[0]
    xbar = np.ascontiguousarray(nodes, dtype=np.float64).reshape(n_dofs)
    psi = np.asarray(modes, dtype=np.float64).reshape(n_dofs, -1)

    translations = np.zeros((n_dofs, 3))
    for i in range(3):
        translations[i::3, i] = 1.0
    rotated_positions = np.column_stack([cross_axis(xbar, i) for i in range(3)])  # E_i xbar
    m_translations = mass_matrix @ translations
    m_rotated = mass_matrix @ rotated_positions
    m_psi = mass_matrix @ psi  # M Psi, reused by every modal integral (M symmetric)

    mass = float(translations[:, 0] @ m_translations[:, 0])
    first_moment = m_translations.T @ xbar
    inertia_tensor = rotated_positions.T @ m_rotated
    translation_coupling = translations.T @ m_psi
    rotation_coupling = rotated_positions.T @ m_psi
    rotated_modes = [cross_axis(psi, i) for i in range(3)]  # E_i Psi
    # Psi^T M E_i Psi
    gyroscopic = np.stack([m_psi.T @ rotated_modes[i] for i in range(3)])
    # Psi^T M E_i E_j Psi = (E_i^T M Psi)^T (E_j Psi) = -(E_i M Psi)^T (E_j Psi)
    m_psi_rotated = [cross_axis(m_psi, i) for i in range(3)]
    centrifugal = np.stack(
        [np.stack([-(m_psi_rotated[i].T @ rotated_modes[j]) for j in range(3)]) for i in range(3)]
    )
    # Psi^T M E_i E_j xbar
    centrifugal_load = np.stack(
        [
            np.stack([m_psi.T @ cross_axis(rotated_positions[:, j], i) for j in range(3)])
            for i in range(3)
        ]
    )
    return {
        "mass": mass,
        "first_moment": first_moment,
        "inertia_tensor": 0.5 * (inertia_tensor + inertia_tensor.T),
        "translation_coupling": translation_coupling,
        "rotation_coupling": rotation_coupling,
        "gyroscopic": gyroscopic,
        "centrifugal": centrifugal,
        "centrifugal_load": centrifugal_load,
    }
