"""Steady sliding state, Jacobian and complex eigenvalue analysis (batched over samples).

Steady sliding state: time is frozen at ``t_lin`` (rotation angle and speed of
every rotating body held at their values there, so the master keeps sliding
under the slave nodes) and the static equations ``a(x, v = 0) = 0`` (all
accelerations zero) are solved by Newton's method. The Jacobian is formed by
central differences of the compiled right-hand side; contact is piecewise
linear in the coordinates, so Newton settles the active set in a few steps.
This is exact for a master that is the same at every angle in the contact
region (a disc patch, a belt); otherwise it is the state at the frozen angle.

Linearisation: ``A = d f / d (x, v)`` at ``(x*, 0)`` (central differences
again: exact up to rounding for the linear parts, second-order accurate for
the regularised friction law), then ``eig(A)``. Eigenvalues
``lambda = sigma + i omega_d``: damping ratio ``-sigma / |lambda|``, damped
frequency ``omega_d / (2 pi)``; ``sigma > 0`` marks a growing (unstable) mode.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.integrate import evaluate_rhs
from fuzzymbs.mbs.system import CompiledSystem, System


@dataclass
class SteadyState:
    """Static equilibrium of a batch (coordinates ``x`` (B, n)), Newton convergence per sample."""

    x: NDArray[np.float64]
    converged: NDArray[np.bool_]
    iterations: NDArray[np.int64]
    residual: NDArray[np.float64]  # max |acceleration| at the solution


@dataclass
class Eigenanalysis:
    """Complex eigenvalues of the linearised system per sample.

    Attributes
    ----------
    eigenvalues : (B, 2n) complex [1/s], sorted by |imag| then by real part.
    damping_ratio : (B, 2n) ``-Re / |lambda|``.
    frequency : (B, 2n) damped frequency ``|Im| / (2 pi)`` [Hz].
    mode_shapes : (B, n, 2n) complex coordinate part of the eigenvectors (max-norm 1).
    unstable : (B, 2n) bool, ``Re lambda > tolerance * |lambda|``.
    failed : (B,) bool, the steady state did not converge: that sample's eigenvalues,
        ratios, frequencies and shapes are NaN (never numbers from a wrong state).
    jacobian : (B, 2n, 2n) state matrix A.
    steady_state : SteadyState it was linearised about.
    """

    eigenvalues: NDArray[np.complex128]
    damping_ratio: NDArray[np.float64]
    frequency: NDArray[np.float64]
    mode_shapes: NDArray[np.complex128]
    unstable: NDArray[np.bool_]
    jacobian: NDArray[np.float64]
    steady_state: SteadyState
    failed: NDArray[np.bool_]

    @property
    def stable(self) -> NDArray[np.bool_]:
        """(B,) True when no eigenvalue grows (False for failed samples)."""
        return ~self.unstable.any(axis=1) & ~self.failed


def _velocity_step(compiled: CompiledSystem) -> float:
    cf = compiled.data[12]
    eps = cf[:, 9].min() if cf.shape[0] else 1e-3
    return max(1e-3 * float(eps), 1e-8)  # m/s: well inside the regularisation scale eps


def jacobian(
    compiled: CompiledSystem,
    params: NDArray[np.float64],
    states: NDArray[np.float64],
    t_lin: float = 0.0,
    columns: str = "all",
) -> NDArray[np.float64]:
    """Finite-difference Jacobian of the state derivative, (B, 2n, 2n) (or (B, n, n) of the
    accelerations w.r.t. the coordinates when ``columns="positions"``).

    Central differences: exact up to rounding where the right-hand side is linear
    (springs, penalty contact away from g = 0); at a node with gap ~ 0 they average the
    two sides, which still gives Newton a usable (non-singular) direction.
    """
    batch, nstate = states.shape
    n = nstate // 2
    cols = np.arange(n) if columns == "positions" else np.arange(nstate)
    scale = np.maximum(np.abs(states[:, :n]).max(axis=1), 1e-9)
    h = np.empty((batch, cols.size))
    h[:, : min(cols.size, n)] = 1e-5 * scale[:, None]
    if cols.size > n:
        h[:, n:] = _velocity_step(compiled)
    idx = np.arange(cols.size)
    pert = np.repeat(states[:, None, :], 2 * cols.size, axis=1)
    pert[:, 2 * idx, cols] += h
    pert[:, 2 * idx + 1, cols] -= h
    rows = np.repeat(np.arange(batch), 2 * cols.size)
    f = evaluate_rhs(
        compiled, params, rows, np.full(rows.size, t_lin), pert.reshape(-1, nstate)
    ).reshape(batch, 2 * cols.size, nstate)
    jac = (f[:, 0::2, :] - f[:, 1::2, :]) / (2.0 * h[:, :, None])  # (B, col, row)
    jac = np.swapaxes(jac, 1, 2)
    if columns == "positions":
        return jac[:, n:, :]
    return jac


def steady_state(
    system: System | CompiledSystem,
    samples: Mapping[str, NDArray[np.float64]] | None = None,
    *,
    t_lin: float = 0.0,
    guess: NDArray[np.float64] | None = None,
    tol: float = 1e-10,
    max_iter: int = 60,
) -> SteadyState:
    """Newton solution of the static equations with the masters sliding (frozen time).

    Parameters
    ----------
    tol : float
        Converged when the Newton step is below ``tol * max|x|`` (relative).
    """
    compiled = system.compile() if isinstance(system, System) else system
    params = compiled.parameters.values(samples or {})
    batch = params.shape[0]
    n = compiled.n_dofs
    x = np.zeros((batch, n)) if guess is None else np.array(np.broadcast_to(guess, (batch, n)))
    converged = np.zeros(batch, dtype=bool)
    near = np.zeros(batch, dtype=bool)  # one more Newton step after the criterion holds:
    # coordinates of very different size (a 1e-2 m offset next to a 1e-5 m penetration)
    iterations = np.zeros(batch, dtype=np.int64)

    def accel(xs: NDArray[np.float64], rows: NDArray[np.int64]) -> NDArray[np.float64]:
        st = np.concatenate([xs, np.zeros_like(xs)], axis=1)
        return evaluate_rhs(compiled, params, rows, np.full(rows.size, t_lin), st)[:, n:]

    rows_all = np.arange(batch)
    res = accel(x, rows_all)
    for it in range(max_iter):
        active = ~converged
        if not active.any():
            break
        rows = rows_all[active]
        st = np.concatenate([x[active], np.zeros((rows.size, n))], axis=1)
        jac = jacobian(compiled, params[rows], st, t_lin, columns="positions")
        try:
            step = -np.linalg.solve(jac, res[active][..., None])[..., 0]
        except np.linalg.LinAlgError as exc:
            raise InvalidParameterError(
                "steady_state: singular static Jacobian (a body without support? add springs "
                "or contact so every coordinate is held)"
            ) from exc
        # backtracking on the residual norm keeps Newton safe across contact kinks
        lam = np.ones(rows.size)
        base = np.abs(res[active]).max(axis=1)
        trial = x[active] + step
        new_res = accel(trial, rows)
        for _ in range(20):
            worse = np.abs(new_res).max(axis=1) > base * (1 - 1e-4 * lam)
            worse &= lam > 1e-3
            if not worse.any():
                break
            lam[worse] *= 0.5
            trial[worse] = x[active][worse] + lam[worse, None] * step[worse]
            new_res[worse] = accel(trial[worse], rows[worse])
        x[active] = trial
        res[active] = new_res
        iterations[active] = it + 1
        small = np.abs(lam[:, None] * step).max(axis=1) <= tol * np.maximum(
            np.abs(trial).max(axis=1), 1e-300
        )
        converged[rows[small & near[rows]]] = True
        near[rows] = small
    return SteadyState(x, converged, iterations, np.abs(res).max(axis=1))


def eigenanalysis(
    system: System | CompiledSystem,
    samples: Mapping[str, NDArray[np.float64]] | None = None,
    *,
    t_lin: float = 0.0,
    state: SteadyState | None = None,
    tolerance: float = 1e-6,
) -> Eigenanalysis:
    """Linearise about the steady sliding state and compute complex eigenvalues.

    Parameters
    ----------
    tolerance : float
        Relative growth threshold: a mode is unstable when ``Re > tolerance |lambda|``
        (guards against round-off of undamped modes).
    """
    compiled = system.compile() if isinstance(system, System) else system
    params = compiled.parameters.values(samples or {})
    st = state or steady_state(compiled, samples, t_lin=t_lin)
    n = compiled.n_dofs
    x = np.concatenate([st.x, np.zeros_like(st.x)], axis=1)
    jac = jacobian(compiled, params, x, t_lin)
    lam, vec = np.linalg.eig(jac)
    order = np.lexsort((lam.real, np.round(np.abs(lam.imag), 9)), axis=-1)
    lam = np.take_along_axis(lam, order, axis=-1)
    vec = np.take_along_axis(vec, order[:, None, :], axis=-1)[:, :n, :]
    norm = np.abs(vec).max(axis=1, keepdims=True)
    vec = vec / np.where(norm > 0, norm, 1.0)
    mag = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(mag > 0, -lam.real / np.where(mag > 0, mag, 1.0), 0.0)
    failed = ~st.converged
    if failed.any():
        lam[failed] = np.nan
        zeta[failed] = np.nan
        vec[failed] = np.nan
    return Eigenanalysis(
        eigenvalues=lam,
        damping_ratio=zeta,
        frequency=np.abs(lam.imag) / (2 * np.pi),
        mode_shapes=vec,
        unstable=lam.real > tolerance * mag,
        jacobian=jac,
        steady_state=st,
        failed=failed,
    )
