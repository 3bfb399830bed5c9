"""Stress stiffening of a clamped elastic body under its own centrifugal load.

A body turning at angular velocity w about its frame origin carries the
centrifugal body force rho a(x), a(x) = -w x (w x x) = |w|^2 x - (w . x) w, which
is linear in the products w_i w_j:

    a(x) = sum_ij w_i w_j a_ij(x),   a_ij(x) = delta_ij x - (x_i e_j + x_j e_i) / 2.

Its static stress sigma(w) = sum_ij w_i w_j sigma_ij (sigma_ij: the stress of the
unit load state a_ij, a linear static solution of the clamped body) stiffens the
body by the geometric (stress) stiffness

    K_G(sigma)[3 m + c, 3 n + c] = int sigma_kl dN_m/dx_k dN_n/dx_l dV

(the same block for every component c; Cook, Malkus, Plesha & Witt, Concepts and
Applications of Finite Element Analysis, 4th ed., sec. 18.2; Bathe, Finite Element
Procedures, sec. 6.3 -- the second-order strain energy of the prestress). Projected on
the reduced basis, K_ij = Psi^T K_G(sigma_ij) Psi, so that a body turning at w has
the modal stiffness diag(omega^2) + sum_ij w_i w_j (C_ij + K_ij): C_ij the spin
softening (:class:`~fuzzymbs.mbs.modal_body.ModalBody` ``centrifugal``), K_ij the
stiffening that linear floating-frame theory misses (Kane, Ryan & Banerjee 1987).
A uniform body force b per unit mass (gravity, a frame's acceleration) stiffens it in
the same way by sum_i b_i K_i, K_i from the unit body force along e_i. This is stress
stiffness from the reference load state: exact to first order in the prestress, which
suffices while the deflection stays small against the body.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from skfem import BilinearForm, asm
from skfem.models.elasticity import lame_parameters

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.modal_body import StressStiffening

#: The six unit load states (i, j), i <= j, of the products w_i w_j.
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def unit_centrifugal_loads(body) -> NDArray[np.float64]:
    """Nodal loads (3n, 6) of the six unit states a_ij (:data:`PAIRS`): M a_ij(x) at the nodes,
    exact for the consistent mass because a_ij is linear in x."""
    x = np.asarray(body.nodes, dtype=float)
    loads = np.empty((3 * x.shape[0], len(PAIRS)))
    for column, (i, j) in enumerate(PAIRS):
        field = np.zeros_like(x)
        if i == j:
            field += x
        field[:, j] -= 0.5 * x[:, i]
        field[:, i] -= 0.5 * x[:, j]
        loads[:, column] = body.mass_matrix @ field.reshape(-1)
    return loads


def geometric_stiffness(body, displacement: NDArray[np.float64]) -> sp.csr_matrix:
    """K_G (3n x 3n) of the stress of ``displacement`` (3n,), isotropic linear elasticity."""
    basis = body.scalar_basis()
    u = np.asarray(displacement, dtype=float).reshape(-1, 3)
    grads = [basis.interpolate(u[:, c]).grad for c in range(3)]  # grads[c][k] = du_c/dx_k
    lam, mu = lame_parameters(body.youngs_modulus, body.poisson_ratio)
    strain = [[0.5 * (grads[a][b] + grads[b][a]) for b in range(3)] for a in range(3)]
    trace = strain[0][0] + strain[1][1] + strain[2][2]
    stress = {
        f"s{a}{b}": 2.0 * mu * strain[a][b] + (lam * trace if a == b else 0.0)
        for a in range(3)
        for b in range(3)
    }

    @BilinearForm
    def form(trial: Any, test: Any, w: Any) -> Any:
        total = 0.0
        for k in range(3):
            for m in range(3):
                total = total + w[f"s{k}{m}"] * test.grad[k] * trial.grad[m]
        return total

    scalar = asm(form, basis, **stress).tocoo()
    rows = np.concatenate([3 * scalar.row + c for c in range(3)])
    cols = np.concatenate([3 * scalar.col + c for c in range(3)])
    values = np.tile(scalar.data, 3)
    size = 3 * basis.N
    matrix = sp.csr_matrix((values, (rows, cols)), shape=(size, size))
    return ((matrix + matrix.T) * 0.5).tocsr()


def unit_body_force_loads(body) -> NDArray[np.float64]:
    """Nodal loads (3n, 3) of a unit body force per unit mass along x, y and z: M e_i."""
    loads = np.empty((body.n_dofs, 3))
    for i in range(3):
        field = np.zeros((body.n_nodes, 3))
        field[:, i] = 1.0
        loads[:, i] = body.mass_matrix @ field.reshape(-1)
    return loads


def stress_stiffening(body, modes: NDArray[np.float64]) -> StressStiffening:
    """K_i and K_ij (:class:`~fuzzymbs.mbs.modal_body.StressStiffening`) of a clamped
    ``body`` (:class:`~fuzzymbs.fe.elastic_body.ElasticBody`) on its full-DOF basis
    ``modes`` (3n, r): Psi^T K_G(sigma) Psi of the unit body forces along x, y, z and of
    the six centrifugal unit states."""
    if body.is_free:
        raise InvalidParameterError(
            f"body {body.name!r} is free-free: the stress of its inertia loads needs a "
            "clamped body (its inertia relief is not computed); use fixed=..."
        )
    loads = np.hstack([unit_body_force_loads(body), unit_centrifugal_loads(body)])
    deflections = body.static_deflection(loads)  # one factorisation for the nine states
    r = modes.shape[1]

    def projected(column: int) -> NDArray[np.float64]:
        k_g = geometric_stiffness(body, deflections[:, column])
        matrix = modes.T @ (k_g @ modes)
        return 0.5 * (matrix + matrix.T)

    acceleration = np.stack([projected(i) for i in range(3)])
    spin = np.zeros((3, 3, r, r))
    for column, (i, j) in enumerate(PAIRS):
        spin[i, j] = spin[j, i] = projected(3 + column)
    return StressStiffening(acceleration=acceleration, spin=spin)
