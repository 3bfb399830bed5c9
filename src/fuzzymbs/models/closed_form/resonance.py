"""Forced oscillators near resonance: test models whose extremum lies on a ridge.

The steady-state amplitude of a harmonically forced, viscously damped
oscillator with fuzzy stiffness, mass and damping ratio peaks on the ridge
where a natural frequency meets the forcing frequency (``k = m Omega^2`` for a
single degree of freedom). Across the parameter box the ridge is narrow (its
width in ``k`` is about ``2 zeta k``), along it the height changes slowly, and
its highest point lies where the ridge leaves the box: a surrogate that finds
the ridge can still miss its highest point. These are the models the adaptive
method's extremum confirmation (:mod:`fuzzymbs.fuzzy.extremum_confirmation`)
is tested against.

- :func:`sdof_resonance`: ``X = F / sqrt((k - m Omega^2)^2 + (2 zeta sqrt(k m) Omega)^2)``
  (any vibration textbook, e.g. Rao, Mechanical Vibrations, sec. 3.4), with
  :func:`sdof_truth` its alpha-cuts from the closed form (the maximum over
  ``k`` at fixed ``m, zeta`` is at ``k = m Omega^2 (1 - 2 zeta^2)`` clipped to
  the box, the minimum at an end; ``X`` falls with ``zeta``; only ``m`` is
  searched, on a fine grid);
- :func:`two_dof_resonance`: two masses in a chain (ground - ``k1`` - ``m1`` -
  ``k2`` - ``m2``), the force on ``m1``, modal damping ratio ``zeta`` in both
  modes, the amplitudes of both masses by modal superposition (Rao, sec. 6.14):
  ``X = sum_r phi_r phi_r^T F / (omega_r^2 - Omega^2 + 2 i zeta omega_r Omega)``
  with mass-normalised modes of the 2 x 2 problem in closed form. Its truth is
  :func:`fuzzymbs.models.closed_form.hard_cases.dense_truth` polished by a local
  optimiser (:func:`polished_truth`).

Both carry analytic gradients (:func:`sdof_amplitude_gradient`,
:func:`two_dof_amplitudes_gradient`; ``case.gradient``). Like every model here, these
import no part of the fuzzy engine.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.closed_form.hard_cases import HardCase, Triangle, dense_truth, triangle_cut

__all__ = [
    "FORCE",
    "polished_truth",
    "resonance_cases",
    "sdof_amplitude",
    "sdof_amplitude_gradient",
    "sdof_resonance",
    "sdof_truth",
    "two_dof_amplitudes",
    "two_dof_amplitudes_gradient",
    "two_dof_resonance",
]

#: amplitude of the harmonic force [N]
FORCE = 1.0
#: the single-degree-of-freedom case's forcing angular frequency squared [rad^2/s^2]:
#: the ridge k = m Omega^2 runs from the face m = 0.95 kg (k = 969 N/m, the highest
#: point) to the face m = 1.05 kg (k = 1071 N/m) of the support box
SDOF_OMEGA_SQUARED = 1020.0
#: the two-degree-of-freedom case's Omega^2 [rad^2/s^2]: its first natural frequency
#: squared is 500 at the modal values and 443 to 559 over the support box
TWO_DOF_OMEGA_SQUARED = 520.0


def damping_triangle(damping_ratio: float) -> tuple[float, float, float]:
    """The fuzzy damping ratio of both resonance cases: +-20 % about ``damping_ratio``,
    which must lie in (0, 0.5]."""
    if not 0.0 < damping_ratio <= 0.5:
        raise InvalidParameterError(f"damping_ratio must lie in (0, 0.5], got {damping_ratio!r}")
    return (0.8 * damping_ratio, damping_ratio, 1.2 * damping_ratio)


def sdof_amplitude(
    stiffness: NDArray[np.float64],
    mass: NDArray[np.float64],
    damping_ratio: NDArray[np.float64],
    omega_squared: float = SDOF_OMEGA_SQUARED,
) -> NDArray[np.float64]:
    """Steady-state amplitude [m] of ``m x'' + c x' + k x = F cos(Omega t)``,
    ``c = 2 zeta sqrt(k m)``.

    Parameters
    ----------
    stiffness, mass, damping_ratio : ndarray (B,)
        k [N/m], m [kg], zeta [-], all positive.
    omega_squared : float
        Omega^2 of the forcing [rad^2/s^2].
    """
    k, m, zeta = (np.asarray(v, dtype=float) for v in (stiffness, mass, damping_ratio))
    damping = 2.0 * zeta * np.sqrt(k * m)
    return FORCE / np.sqrt((k - m * omega_squared) ** 2 + damping**2 * omega_squared)


def sdof_amplitude_gradient(
    stiffness: NDArray[np.float64],
    mass: NDArray[np.float64],
    damping_ratio: NDArray[np.float64],
    omega_squared: float = SDOF_OMEGA_SQUARED,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`sdof_amplitude` (B,) and its gradient (B, 3) with respect to ``(k, m, zeta)``.

    ``X = F Q^(-1/2)``, ``Q = (k - m Omega^2)^2 + 4 zeta^2 k m Omega^2``, so
    ``dX/dp = -X / (2 Q) dQ/dp`` with ``dQ/dk = 2 (k - m Omega^2) + 4 zeta^2 m Omega^2``,
    ``dQ/dm = -2 Omega^2 (k - m Omega^2) + 4 zeta^2 k Omega^2``, ``dQ/dzeta = 8 zeta k m Omega^2``.
    """
    k, m, zeta = (np.asarray(v, dtype=float) for v in (stiffness, mass, damping_ratio))
    detuning = k - m * omega_squared
    quadratic = detuning**2 + 4.0 * zeta**2 * k * m * omega_squared
    amplitude = sdof_amplitude(k, m, zeta, omega_squared)  # the model's values, bit for bit
    slope = np.stack(
        (
            2.0 * detuning + 4.0 * zeta**2 * m * omega_squared,
            -2.0 * omega_squared * detuning + 4.0 * zeta**2 * k * omega_squared,
            8.0 * zeta * k * m * omega_squared,
        ),
        axis=-1,
    )
    return amplitude, -(amplitude / (2.0 * quadratic))[:, None] * slope


def sdof_resonance(damping_ratio: float) -> HardCase:
    """The single-degree-of-freedom amplitude with ``k ~ TFN(900, 1000, 1100) N/m``,
    ``m ~ TFN(0.95, 1, 1.05) kg`` and ``zeta ~ TFN(0.8, 1, 1.2) x damping_ratio``,
    forced at ``Omega^2 = 1020 rad^2/s^2``: the ridge crosses every cut box but the
    core and is highest at its small-mass end (``X = F / (2 zeta m Omega^2)`` there).

    Raises
    ------
    InvalidParameterError
        A damping ratio outside (0, 0.5].
    """
    triangles = {
        "stiffness": (900.0, 1000.0, 1100.0),
        "mass": (0.95, 1.0, 1.05),
        "damping_ratio": damping_triangle(damping_ratio),
    }
    # dense_truth's grid (the ridge is about 2 zeta k wide: 1 % of k at zeta = 0.5 %)
    name, grid = f"sdof-{100 * damping_ratio:g}%", (2001, 201, 3)
    return _amplitude_case(name, triangles, grid, sdof_amplitude, sdof_amplitude_gradient)


def _amplitude_case(
    name: str,
    triangles: dict[str, Triangle],
    grid: tuple[int, ...],
    amplitude: Callable[..., NDArray[np.float64]],
    amplitude_gradient: Callable[..., tuple[NDArray[np.float64], NDArray[np.float64]]],
) -> HardCase:
    """A case whose output ``amplitude`` is ``amplitude(*parameters)`` in the order of
    ``triangles``, its gradient ``amplitude_gradient(*parameters)``."""

    def model(samples: Mapping[str, NDArray[np.float64]]) -> dict[str, NDArray[np.float64]]:
        return {"amplitude": amplitude(*(samples[key] for key in triangles))}

    def gradient(samples: Mapping[str, NDArray[np.float64]]) -> tuple[dict, dict]:
        value, slope = amplitude_gradient(*(samples[key] for key in triangles))
        return {"amplitude": value}, {"amplitude": slope}

    return HardCase(name, model, triangles, grid, gradient)


def sdof_truth(
    case: HardCase, levels: NDArray[np.float64] | list[float], masses: int = 20_001
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The single-degree-of-freedom case's true alpha-cuts from its closed form.

    At fixed ``m`` and ``zeta``, ``X^-2 = (k - m Omega^2)^2 + 4 zeta^2 k m Omega^2`` is a
    convex quadratic in ``k`` with its minimum at ``k* = m Omega^2 (1 - 2 zeta^2)``: the
    largest ``X`` over a cut's ``k`` interval is at ``k*`` clipped to it, the smallest at
    one of its ends; ``X`` falls as ``zeta`` grows (``c`` grows). Only ``m`` is searched,
    on ``masses`` points of each cut (spacing 5e-6 kg for the default: the bound's error
    is far below 1e-6 of the cut width).

    Returns
    -------
    dict
        ``{"amplitude": (lower, upper)}``, each (L,).
    """
    omega_squared = SDOF_OMEGA_SQUARED
    lower, upper = [], []
    for mu in np.atleast_1d(np.asarray(levels, dtype=float)):
        k_low, k_high = triangle_cut(case.triangles["stiffness"], float(mu))
        m_low, m_high = triangle_cut(case.triangles["mass"], float(mu))
        z_low, z_high = triangle_cut(case.triangles["damping_ratio"], float(mu))
        m = np.linspace(m_low, m_high, masses if m_high > m_low else 1)
        peak = np.clip(m * omega_squared * (1.0 - 2.0 * z_low**2), k_low, k_high)
        high = sdof_amplitude(peak, m, np.full_like(m, z_low), omega_squared)
        ends = [
            sdof_amplitude(np.full_like(m, k), m, np.full_like(m, z_high)) for k in (k_low, k_high)
        ]
        lower.append(np.minimum(*ends).min())
        upper.append(high.max())
    return {"amplitude": (np.array(lower), np.array(upper))}


def two_dof_amplitudes(
    stiffness_1: NDArray[np.float64],
    stiffness_2: NDArray[np.float64],
    mass_1: NDArray[np.float64],
    damping_ratio: NDArray[np.float64],
    *,
    mass_2: float = 0.5,
    omega_squared: float = TWO_DOF_OMEGA_SQUARED,
) -> NDArray[np.float64]:
    """(B, 2) steady-state amplitudes [m] of both masses of the two-mass chain.

    ``M = diag(m1, m2)``, ``K = [[k1 + k2, -k2], [-k2, k2]]``, force ``F cos(Omega t)``
    on mass 1, modal damping ratio ``zeta`` in both modes. The undamped modes solve
    ``det(K - w^2 M) = 0`` in closed form; mass-normalised, each adds
    ``phi_r phi_r1 F / (w_r^2 - Omega^2 + 2 i zeta w_r Omega)``.
    """
    k1, k2, m1, zeta = (
        np.asarray(v, dtype=float)[:, None]
        for v in (stiffness_1, stiffness_2, mass_1, damping_ratio)
    )
    m2 = float(mass_2)
    # det(K - l M) = m1 m2 l^2 - (m1 k2 + m2 (k1 + k2)) l + k1 k2
    b = m1 * k2 + m2 * (k1 + k2)
    root = np.sqrt(b * b - 4.0 * m1 * m2 * k1 * k2)
    eigen = np.concatenate(((b - root) / (2.0 * m1 * m2), (b + root) / (2.0 * m1 * m2)), axis=1)
    # mode shape (1, r): (k1 + k2 - l m1) - k2 r = 0; mass-normalised
    ratio = (k1 + k2 - eigen * m1) / k2  # (B, 2)
    norm = np.sqrt(m1 + m2 * ratio**2)
    first, second = 1.0 / norm, ratio / norm
    omega = np.sqrt(eigen)
    denominator = eigen - omega_squared + 2j * zeta * omega * np.sqrt(omega_squared)
    weight = first * FORCE / denominator  # phi_r1 F / d_r
    x1 = (first * weight).sum(axis=1)
    x2 = (second * weight).sum(axis=1)
    return np.abs(np.stack((x1, x2), axis=1))


def two_dof_amplitudes_gradient(
    stiffness_1: NDArray[np.float64],
    stiffness_2: NDArray[np.float64],
    mass_1: NDArray[np.float64],
    damping_ratio: NDArray[np.float64],
    *,
    mass_2: float = 0.5,
    omega_squared: float = TWO_DOF_OMEGA_SQUARED,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`two_dof_amplitudes` (B, 2) and its gradient (B, 2, 4) with respect to
    ``(k1, k2, m1, zeta)``: the same closed form differentiated step by step (forward
    mode: every intermediate carries its derivative, the last axis), and
    ``d|x| = Re(conj(x) dx) / |x|`` for the complex amplitudes."""
    k1, k2, m1, zeta = (
        np.asarray(v, dtype=float)[:, None]
        for v in (stiffness_1, stiffness_2, mass_1, damping_ratio)
    )
    m2, omega_forcing = float(mass_2), np.sqrt(omega_squared)
    unit = np.eye(4)[None, None, :, :]  # d(k1, k2, m1, zeta) / d(k1, k2, m1, zeta)
    dk1, dk2, dm1, dzeta = (unit[:, :, i, :] for i in range(4))  # each (1, 1, 4)
    b = m1 * k2 + m2 * (k1 + k2)
    db = dm1 * k2[..., None] + m1[..., None] * dk2 + m2 * (dk1 + dk2)
    product = m1 * k1 * k2
    dproduct = (dm1 * k1[..., None] + m1[..., None] * dk1) * k2[..., None] + (m1 * k1)[
        ..., None
    ] * dk2
    root = np.sqrt(b * b - 4.0 * m2 * product)
    droot = (2.0 * b[..., None] * db - 4.0 * m2 * dproduct) / (2.0 * root[..., None])
    sign = np.array([-1.0, 1.0])[None, :]
    eigen = (b + sign * root) / (2.0 * m1 * m2)  # (B, 2)
    deigen = (db + sign[..., None] * droot) / (2.0 * m1 * m2)[..., None] - (eigen / m1)[
        ..., None
    ] * dm1
    numerator = k1 + k2 - eigen * m1
    dnumerator = dk1 + dk2 - deigen * m1[..., None] - eigen[..., None] * dm1
    ratio = numerator / k2
    dratio = dnumerator / k2[..., None] - (numerator / k2**2)[..., None] * dk2
    norm = np.sqrt(m1 + m2 * ratio**2)
    dnorm = (dm1 + 2.0 * m2 * (ratio[..., None] * dratio)) / (2.0 * norm[..., None])
    first, second = 1.0 / norm, ratio / norm
    dfirst = -dnorm / (norm**2)[..., None]
    dsecond = dratio / norm[..., None] - (ratio / norm**2)[..., None] * dnorm
    omega = np.sqrt(eigen)
    domega = deigen / (2.0 * omega[..., None])
    denominator = eigen - omega_squared + 2j * zeta * omega * omega_forcing
    ddenominator = deigen + 2j * omega_forcing * (
        dzeta * omega[..., None] + zeta[..., None] * domega
    )
    weight = first * FORCE / denominator
    dweight = FORCE * (
        dfirst / denominator[..., None] - (first / denominator**2)[..., None] * ddenominator
    )
    amplitudes, slopes = [], []
    for shape, dshape in ((first, dfirst), (second, dsecond)):
        x = (shape * weight).sum(axis=1)
        dx = (dshape * weight[..., None] + shape[..., None] * dweight).sum(axis=1)
        size = np.abs(x)
        amplitudes.append(size)
        slopes.append(np.real(np.conj(x)[:, None] * dx) / size[:, None])
    return np.stack(amplitudes, axis=1), np.stack(slopes, axis=1)


def two_dof_resonance(damping_ratio: float) -> HardCase:
    """The two-mass chain with ``k1 ~ TFN(900, 1000, 1100)``, ``k2 ~ TFN(450, 500, 550) N/m``,
    ``m1 ~ TFN(0.95, 1, 1.05) kg``, ``m2 = 0.5 kg``, ``zeta ~ TFN(0.8, 1, 1.2) x
    damping_ratio``, forced at ``Omega^2 = 520 rad^2/s^2``, near the first natural
    frequency (``w_1^2 = 500`` at the modal values, 443 to 559 over the box): the first
    resonance is a curved ridge surface through the box. Output ``amplitude``, (B, 2):
    mass 1 and mass 2.

    Raises
    ------
    InvalidParameterError
        A damping ratio outside (0, 0.5].
    """
    triangles: dict[str, Triangle] = {
        "stiffness_1": (900.0, 1000.0, 1100.0),
        "stiffness_2": (450.0, 500.0, 550.0),
        "mass_1": (0.95, 1.0, 1.05),
        "damping_ratio": damping_triangle(damping_ratio),
    }
    name, grid = f"2dof-{100 * damping_ratio:g}%", (121, 61, 41, 3)
    return _amplitude_case(name, triangles, grid, two_dof_amplitudes, two_dof_amplitudes_gradient)


def polished_truth(
    case: HardCase, levels: NDArray[np.float64] | list[float], starts: int = 8
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """True alpha-cuts: :func:`~fuzzymbs.models.closed_form.hard_cases.dense_truth`, each
    bound then polished by a bounded local optimiser (SciPy L-BFGS-B) from the ``starts``
    best points of a coarser grid of the box, so that an extremum on a ridge narrower than
    the grid's spacing is found to the optimiser's tolerance.

    Returns
    -------
    dict
        output -> (lower, upper), each (L, *shape), at least as wide as the dense grid's.
    """
    from scipy.optimize import minimize  # only here: the registered models import this module

    names = list(case.triangles)
    truth = dense_truth(case, levels)
    mus = np.atleast_1d(np.asarray(levels, dtype=float))
    for j, mu in enumerate(mus):
        box = np.array([triangle_cut(case.triangles[n], float(mu)) for n in names])
        moving = box[:, 1] > box[:, 0]
        if not moving.any():
            continue
        axes = [
            np.linspace(lo, hi, 21 if m else 1) for (lo, hi), m in zip(box, moving, strict=True)
        ]
        grid = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
        values = case.model({n: grid[:, i] for i, n in enumerate(names)})
        for key, value in values.items():
            flat = np.asarray(value, dtype=float).reshape(len(grid), -1)
            lower, upper = truth[key][0][j].reshape(-1), truth[key][1][j].reshape(-1)
            for element in range(flat.shape[1]):
                for sign, bound in ((1.0, lower), (-1.0, upper)):
                    order = np.argsort(sign * flat[:, element])[:starts]
                    for start in grid[order]:

                        def objective(x, key=key, element=element, sign=sign):
                            point = {n: np.array([x[i]]) for i, n in enumerate(names)}
                            out = np.asarray(case.model(point)[key], dtype=float)
                            return sign * out.reshape(-1)[element]

                        scale = np.where(moving, box[:, 1] - box[:, 0], 1.0)
                        found = minimize(
                            lambda u, f=objective, s=scale, o=box[:, 0]: f(o + u * s),
                            (start - box[:, 0]) / scale,
                            method="L-BFGS-B",
                            bounds=[(0.0, 1.0) if m else (0.0, 0.0) for m in moving],
                        )
                        value_found = sign * found.fun
                        if sign > 0:
                            bound[element] = min(bound[element], value_found)
                        else:
                            bound[element] = max(bound[element], value_found)
            truth[key][0][j] = lower.reshape(truth[key][0][j].shape)
            truth[key][1][j] = upper.reshape(truth[key][1][j].shape)
    return truth


def resonance_cases() -> list[HardCase]:
    """The single- and two-degree-of-freedom cases at damping ratios 0.5, 2 and 5 %."""
    return [f(z) for f in (sdof_resonance, two_dof_resonance) for z in (0.005, 0.02, 0.05)]
