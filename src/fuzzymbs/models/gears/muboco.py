"""MUBOCO-PR: the pseudo-rigid, contact-based spur-gear pair (quasi-static STE).

Each gear is a rigid foundation on a fixed axis; each tooth a rigid body
hinged where its centreline meets the root circle, with a rotational spring
(tooth stiffness k_t [N m/rad]). The drive flanks of every tooth pair that can
touch are checked for contact (conjugate or tip-corner, see
:mod:`fuzzymbs.models.gears.flank_contact`) and pushed apart by the penalty law
F = k_con delta^m1.

Quasi-static transmission error: the wheel is held at its kinematic angle, the
pinion carries the drive torque T1 and is free; at each mesh position Newton's
method solves the pinion angle and all hinge angles (the contact active set
follows from the penetrations). STE = r_b1 (theta1 - theta1_kinematic) [m],
positive when the pinion leads (the loaded wheel lags), i.e. theta1 r_b1 +
theta2 r_b2 with both angles counter-clockwise.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numba
import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.flank_contact import (
    PHI_REF2,
    PITCH1,
    PITCH2,
    RB1,
    THETA_REF1,
    pack_geometry,
    pair_moments,
)
from fuzzymbs.models.gears.geometry import GearPair

STATUS_OK, STATUS_NOT_CONVERGED, STATUS_NO_CONTACT = 0, 1, 2
STATUS_TEXT = {
    STATUS_NOT_CONVERGED: "Newton iteration did not converge",
    STATUS_NO_CONTACT: "no tooth pair in contact (cannot carry the torque)",
}

#: Model parameters a sample may carry (anything else is rejected).
SAMPLE_PARAMETERS = (
    "tooth_stiffness",
    "pinion_tooth_stiffness",
    "wheel_tooth_stiffness",
    "contact_stiffness",
    "torque",
)


def pair_indices(pair: GearPair) -> np.ndarray:
    """Tooth pairs that can touch during one mesh period (pair 0 starts at point A).

    Pair k is at s_A + (p + k) p_b on the line of action for mesh position p in
    [0, 1); one extra pair on each side catches extended (corner) contact.
    """
    return np.arange(-1, math.floor(pair.contact_ratio) + 2, dtype=np.int64)


@numba.njit(cache=True)
def _residual(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, out):
    """Equilibrium residuals [N m]: out[0] pinion, out[1+2i] / out[2+2i] hinges of pair i.

    Returns the largest penetration (negative when nothing touches).
    """
    out[0] = torque
    deepest = -1.0
    rigid1 = not math.isfinite(kt1)
    rigid2 = not math.isfinite(kt2)
    for i in range(pairs.shape[0]):
        k = pairs[i]
        theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
        phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
        kind, delta, _, m_p, _, m_h1, m_h2 = pair_moments(
            theta, beta1[i], phi, beta2[i], g, k_con, m1
        )
        if kind != 0 and delta > deepest:
            deepest = delta
        out[0] += m_p
        out[1 + 2 * i] = beta1[i] if rigid1 else m_h1 - kt1 * beta1[i]
        out[2 + 2 * i] = beta2[i] if rigid2 else m_h2 - kt2 * beta2[i]
    return deepest


@numba.njit(cache=True)
def _pair_jacobian(lag, theta_kin, theta2, b1, b2, k, g, k_con, m1, kt1, kt2, jac):
    """3x3 forward-difference Jacobian of (pinion moment, hinge1, hinge2) of one pair.

    Columns: d/d lag, d/d beta1, d/d beta2. Rows of a rigid tooth are the identity.
    """
    theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
    phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
    base = pair_moments(theta, b1, phi, b2, g, k_con, m1)
    steps = (1e-6 * abs(lag) + 1e-13, 1e-6 * abs(b1) + 1e-13, 1e-6 * abs(b2) + 1e-13)
    for col in range(3):
        h = steps[col]
        if col == 0:
            pert = pair_moments(theta + h, b1, phi, b2, g, k_con, m1)
        elif col == 1:
            pert = pair_moments(theta, b1 + h, phi, b2, g, k_con, m1)
        else:
            pert = pair_moments(theta, b1, phi, b2 + h, g, k_con, m1)
        jac[0, col] = (pert[3] - base[3]) / h
        jac[1, col] = (pert[5] - base[5]) / h
        jac[2, col] = (pert[6] - base[6]) / h
    jac[1, 1] -= kt1 if math.isfinite(kt1) else 0.0
    jac[2, 2] -= kt2 if math.isfinite(kt2) else 0.0
    if not math.isfinite(kt1):
        jac[1, 0], jac[1, 1], jac[1, 2], jac[0, 1] = 0.0, 1.0, 0.0, 0.0
    if not math.isfinite(kt2):
        jac[2, 0], jac[2, 1], jac[2, 2], jac[0, 2] = 0.0, 0.0, 1.0, 0.0


@numba.njit(cache=True)
def _solve_position(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2):
    """Newton with line search for one mesh position; updates beta1/beta2 in place.

    Returns (lag, status, iterations).
    """
    n_pairs = pairs.shape[0]
    res = np.empty(1 + 2 * n_pairs)
    trial = np.empty(1 + 2 * n_pairs)
    jac = np.empty((3, 3))
    x = np.empty((n_pairs, 2))
    y = np.empty((n_pairs, 2))
    b1_old = np.empty(n_pairs)
    b2_old = np.empty(n_pairs)
    rb1 = g[RB1]
    # residual floor: the penetration s1 + s2 - L cancels lengths ~ a_w, so moments carry
    # round-off ~ 1e-16 a_w k_con r_b; accept stagnation below a looser bound
    tol = 1e-9 * max(abs(torque), 1e-6)
    loose = 1e-6 * max(abs(torque), 1e-6)
    # penetration of one pair carrying the whole load: start/restart guess
    target = (abs(torque) / (rb1 * k_con)) ** (1.0 / m1)
    if lag == 0.0:  # cold start: turn the pinion until the deepest pair carries the load
        deepest = _residual(
            lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, res
        )
        lag = (target - deepest) / rb1
    for iteration in range(80):
        deepest = _residual(
            lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, res
        )
        norm = np.max(np.abs(res))
        if norm < tol:
            return lag, 0, iteration
        # Schur complement of the arrowhead system (pinion angle couples all pairs)
        j00 = 0.0
        r0 = res[0]
        for i in range(n_pairs):
            _pair_jacobian(
                lag, theta_kin, theta2, beta1[i], beta2[i], pairs[i], g, k_con, m1, kt1, kt2, jac
            )
            det = jac[1, 1] * jac[2, 2] - jac[1, 2] * jac[2, 1]
            ra, rb = res[1 + 2 * i], res[2 + 2 * i]
            x[i, 0] = (jac[2, 2] * ra - jac[1, 2] * rb) / det
            x[i, 1] = (-jac[2, 1] * ra + jac[1, 1] * rb) / det
            y[i, 0] = (jac[2, 2] * jac[1, 0] - jac[1, 2] * jac[2, 0]) / det
            y[i, 1] = (-jac[2, 1] * jac[1, 0] + jac[1, 1] * jac[2, 0]) / det
            j00 += jac[0, 0] - jac[0, 1] * y[i, 0] - jac[0, 2] * y[i, 1]
            r0 -= jac[0, 1] * x[i, 0] + jac[0, 2] * x[i, 1]
        if j00 >= 0.0 or deepest <= 0.0:
            # nothing carries load: turn the pinion until the closest pair touches
            if deepest < -0.5 * g[PITCH1] * rb1:
                return lag, 2, iteration
            lag += (target - deepest) / rb1
            continue
        d_lag = -r0 / j00
        for i in range(n_pairs):
            b1_old[i], b2_old[i] = beta1[i], beta2[i]
        scale = 1.0
        for _ in range(12):
            for i in range(n_pairs):
                beta1[i] = b1_old[i] - scale * (x[i, 0] + y[i, 0] * d_lag)
                beta2[i] = b2_old[i] - scale * (x[i, 1] + y[i, 1] * d_lag)
            _residual(
                lag + scale * d_lag,
                theta_kin,
                theta2,
                beta1,
                beta2,
                pairs,
                g,
                torque,
                k_con,
                m1,
                kt1,
                kt2,
                trial,
            )
            if np.max(np.abs(trial)) < norm:
                break
            scale *= 0.5
        else:
            # no descent along the Newton direction: round-off floor reached
            for i in range(n_pairs):
                beta1[i], beta2[i] = b1_old[i], b2_old[i]
            return lag, 0 if norm < loose else 1, iteration
        lag += scale * d_lag
    _residual(lag, theta_kin, theta2, beta1, beta2, pairs, g, torque, k_con, m1, kt1, kt2, res)
    if np.max(np.abs(res)) < tol:
        return lag, 0, 80
    return lag, 1, 80


@numba.njit(cache=True, parallel=True)
def solve_static_batch(g, positions, pairs, torque, k_con, m1, kt1, kt2):
    """Quasi-static STE of a batch of samples over the mesh positions.

    Parameters
    ----------
    g : (G,) geometry vector (``pack_geometry``)
    positions : (P,) mesh positions as fractions of the mesh period, increasing
    pairs : (K,) tooth-pair indices
    torque, k_con, kt1, kt2 : (B,) pinion torque [N m], contact stiffness
        [N/m^m1], pinion and wheel tooth stiffness [N m/rad] (inf = rigid)
    m1 : contact exponent

    Returns
    -------
    ste (B, P) [m], wheel_moment (B, P) [N m] (contact moment on the wheel about
    its centre, counter-clockwise), pair_force (B, P, K) [N], pair_kind (B, P, K),
    status (B,) 0 ok / 1 not converged / 2 no contact, and the hinge angles
    (B, K) of both gears' teeth at the last position.
    """
    n_samples = torque.shape[0]
    n_pos = positions.shape[0]
    n_pairs = pairs.shape[0]
    ste = np.full((n_samples, n_pos), np.nan)
    wheel_moment = np.full((n_samples, n_pos), np.nan)
    pair_force = np.zeros((n_samples, n_pos, n_pairs))
    pair_kind = np.zeros((n_samples, n_pos, n_pairs), dtype=np.int8)
    status = np.zeros(n_samples, dtype=np.int64)
    last1 = np.zeros((n_samples, n_pairs))
    last2 = np.zeros((n_samples, n_pairs))
    rb1 = g[RB1]
    for b in numba.prange(n_samples):
        beta1 = np.zeros(n_pairs)
        beta2 = np.zeros(n_pairs)
        lag = 0.0
        for j in range(n_pos):
            theta_kin = positions[j] * g[PITCH1]
            theta2 = -positions[j] * g[PITCH2]
            lag, flag, _ = _solve_position(
                lag, theta_kin, theta2, beta1, beta2, pairs, g, torque[b], k_con[b], m1,
                kt1[b], kt2[b],
            )  # fmt: skip
            if flag != 0:
                status[b] = flag
                break
            ste[b, j] = rb1 * lag
            total = 0.0
            for i in range(n_pairs):
                k = pairs[i]
                theta = theta_kin + lag + g[THETA_REF1] + k * g[PITCH1]
                phi = theta2 + g[PHI_REF2] - k * g[PITCH2]
                kind, _, force, _, m_w, _, _ = pair_moments(
                    theta, beta1[i], phi, beta2[i], g, k_con[b], m1
                )
                pair_force[b, j, i] = force
                pair_kind[b, j, i] = kind
                total += m_w
            wheel_moment[b, j] = total
        last1[b] = beta1
        last2[b] = beta2
        if status[b] != 0:
            for j in range(n_pos):
                ste[b, j] = np.nan
                wheel_moment[b, j] = np.nan
    return ste, wheel_moment, pair_force, pair_kind, status, last1, last2


#: Columns whose registered default is NaN, "not set": an all-NaN column means "use the fallback".
UNSET_BY_NAN = ("pinion_tooth_stiffness", "wheel_tooth_stiffness", "torque")
#: Columns that may be +inf (a rigid tooth).
MAY_BE_INFINITE = ("tooth_stiffness", "pinion_tooth_stiffness", "wheel_tooth_stiffness")


def _column(samples: Mapping[str, Any], name: str, size: int | None) -> np.ndarray | None:
    if name not in samples or samples[name] is None:
        return None
    values = np.asarray(samples[name], dtype=float)
    if values.ndim == 0:
        values = np.full(1 if size is None else size, float(values))
    if values.ndim != 1:
        raise InvalidParameterError(f"sample column {name!r} must be 1-D (B,), got {values.shape}")
    if name in UNSET_BY_NAN and np.isnan(values).all():
        return None
    allowed = np.isfinite(values) | (np.isposinf(values) if name in MAY_BE_INFINITE else False)
    if not np.all(allowed & (values > 0.0)):
        bad = values[~(allowed & (values > 0.0))]
        valid = (
            "positive (inf allowed: a rigid tooth)"
            if name in MAY_BE_INFINITE
            else ("positive and finite")
        )
        if name in UNSET_BY_NAN:
            valid += "; all NaN means not set"
        raise InvalidParameterError(f"{name} must be {valid}, got {bad[:3]!r}")
    return values


def _positions(positions: int | Sequence[float] | np.ndarray) -> np.ndarray:
    if np.ndim(positions) == 0:
        count = int(positions)
        if count < 2 or count != positions:
            raise InvalidParameterError(f"positions must be an integer >= 2, got {positions!r}")
        return np.arange(count) / count
    values = np.asarray(positions, dtype=float)
    if values.ndim != 1 or values.size < 1:
        raise InvalidParameterError("positions must be a count or a 1-D array of fractions")
    if not np.all(np.isfinite(values)) or np.any(values < 0) or np.any(values >= 1):
        raise InvalidParameterError("positions must lie in [0, 1) (fractions of the mesh period)")
    if np.any(np.diff(values) <= 0):
        raise InvalidParameterError("positions must be strictly increasing")
    return values


class MubocoPR:
    """Batched MUBOCO-PR gear-pair model.

    Parameters
    ----------
    pair : GearPair
        The gears.
    torque : float
        Pinion (drive) torque T1 [N m] used when a sample carries no ``torque``.
    positions : int or array
        Number of equally spaced mesh positions over one mesh period, or the
        positions themselves as fractions of the mesh period in [0, 1).
    mode : {"static", "dynamic"}
        Quasi-static STE, or time integration (see
        :class:`fuzzymbs.models.gears.dynamics.DynamicSettings`).
    contact_exponent : float
        m1 of the penalty law (1 = linear; 10/9, 1.5 common).
    damping : float
        Contact damping c [N s^m2 / m^(m2+m3)] (dynamic mode only).
    damping_exponents : (float, float)
        (m2, m3) of the damping term; default (1, 0): viscous while in contact,
        c in N s/m. (1, m1) is the Hunt-Crossley form (c then in N s/m^(1+m1)).
    tooth_stiffness, contact_stiffness : float, optional
        Values used when a sample does not carry them; default the identified
        modal values (:func:`fuzzymbs.models.gears.identification.identify`).
    dynamic : DynamicSettings or mapping, optional
        Settings of the dynamic mode.
    reference : bool
        Compute the potential-energy reference STE (``model.reference``).

    Notes
    -----
    ``model(samples)`` takes ``{"tooth_stiffness": (B,), "contact_stiffness": (B,),
    "torque": (B,)}``; ``pinion_tooth_stiffness`` / ``wheel_tooth_stiffness``
    override ``tooth_stiffness`` for one gear. Returns ``{"ste": (B, P)}`` [m]
    (dynamic mode: ``{"dte": (B, N), "dte_spectrum": (B, H)}``) plus ``failed``
    and ``failure_reason`` (B,).
    """

    def __init__(
        self,
        pair: GearPair,
        torque: float = 100.0,
        positions: int | Sequence[float] | np.ndarray = 60,
        mode: str = "static",
        contact_exponent: float = 1.0,
        damping: float = 0.0,
        damping_exponents: tuple[float, float] | None = None,
        tooth_stiffness: float | None = None,
        contact_stiffness: float | None = None,
        pinion_tooth_stiffness: float | None = None,
        wheel_tooth_stiffness: float | None = None,
        dynamic: Any = None,
        reference: bool = True,
    ) -> None:
        from fuzzymbs.models.gears.identification import identify

        if not isinstance(pair, GearPair):
            raise InvalidParameterError("pair must be a GearPair")
        if mode not in ("static", "dynamic"):
            raise InvalidParameterError(f"mode must be 'static' or 'dynamic', got {mode!r}")
        try:
            torque = float(torque)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"torque must be a number [N m], got {torque!r}") from None
        if not math.isfinite(torque) or torque <= 0.0:
            raise InvalidParameterError(f"torque must be a positive pinion torque, got {torque!r}")
        m1 = float(contact_exponent)
        if not 1.0 <= m1 <= 3.0:
            raise InvalidParameterError(f"contact_exponent must be in [1, 3], got {m1!r}")
        if not math.isfinite(damping) or damping < 0.0:
            raise InvalidParameterError(f"damping must be >= 0, got {damping!r}")
        m2, m3 = (1.0, 0.0) if damping_exponents is None else map(float, damping_exponents)
        if m2 < 0 or m3 < 0:
            raise InvalidParameterError(f"damping_exponents must be >= 0, got {(m2, m3)!r}")
        self.pair = pair
        self.mode = mode
        self.torque = torque
        self.contact_exponent = m1
        self.damping = float(damping)
        self.damping_exponents = (m2, m3)
        self.geometry = pack_geometry(pair)
        self.pairs = pair_indices(pair)
        self.identified = identify(pair, torque, contact_exponent=m1)
        self.defaults = {
            "tooth_stiffness": self.identified.tooth_stiffness,
            "contact_stiffness": self.identified.contact_stiffness,
            "torque": torque,
        }
        for name, value in (
            ("tooth_stiffness", tooth_stiffness),
            ("contact_stiffness", contact_stiffness),
            ("pinion_tooth_stiffness", pinion_tooth_stiffness),
            ("wheel_tooth_stiffness", wheel_tooth_stiffness),
        ):
            if value is not None:
                value = float(value)
                if not value > 0.0:
                    raise InvalidParameterError(f"{name} must be positive, got {value!r}")
                self.defaults[name] = value
        if mode == "static":
            self.positions = _positions(positions)
            self.coords = {"position": self.positions}
            self.output_dims = {"ste": ("position",)}
            self.reference = {}
            if reference:
                from fuzzymbs.models.gears.potential_energy import reference_ste

                # the PE reference is linear: its contact term is the linear secant
                # (k_con of a nonlinear law is in N/m^m1 and cannot be used there)
                linear_contact = (
                    self.defaults["contact_stiffness"]
                    if m1 == 1.0
                    else identify(pair, torque, contact_exponent=1.0).contact_stiffness
                )
                self.reference = {
                    "ste": reference_ste(
                        pair, torque, self.positions, contact_stiffness=linear_contact
                    )
                }
        else:
            from fuzzymbs.models.gears.dynamics import DynamicSettings

            if dynamic is None:
                dynamic = DynamicSettings()
            elif isinstance(dynamic, Mapping):
                allowed = [f.name for f in dataclasses.fields(DynamicSettings)]
                unknown = sorted(set(dynamic) - set(allowed))
                if unknown:
                    raise InvalidParameterError(
                        f"unknown dynamic setting(s) {unknown}; settings: {', '.join(allowed)}"
                    )
                dynamic = DynamicSettings(**dynamic)
            self.dynamic = dynamic
            from fuzzymbs.models.gears.dynamics import make_plan

            # the plan holds the torque history as an array: the model stays picklable
            # even when torque_variation is a lambda (it is dropped after sampling)
            self.dynamic_plan = make_plan(self)
            self.dynamic = dataclasses.replace(dynamic, torque_variation=None)
            self.coords = {"time": dynamic.time_grid(pair)}
            self.output_dims = {"dte": ("time",), "dte_spectrum": ("harmonic",)}
            self.coords["harmonic"] = np.arange(1, dynamic.harmonics + 1, dtype=float)
            self.reference = {}

    def identity(self) -> str:
        """SHA-256 digest of every setting that changes the outputs (for result stores).

        Two models with equal digests give equal outputs for equal samples, so a
        study store made with one is valid for the other.
        """
        import hashlib

        digest = hashlib.sha256()
        settings = (
            repr(self.pair),
            self.mode,
            self.torque,
            self.contact_exponent,
            self.damping,
            self.damping_exponents,
            sorted(self.defaults.items()),
        )
        digest.update(repr(settings).encode())
        if self.mode == "static":
            digest.update(np.ascontiguousarray(self.positions, dtype="<f8").tobytes())
        else:
            digest.update(repr(self.dynamic).encode())
            torque_factor = self.dynamic_plan.torque_factor
            if torque_factor is not None:
                digest.update(np.ascontiguousarray(torque_factor, dtype="<f8").tobytes())
        return digest.hexdigest()

    # ---- sample handling ---------------------------------------------------------------
    def stiffness_columns(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Per-sample torque, contact stiffness and both tooth stiffnesses, defaults filled."""
        unknown = set(samples) - set(SAMPLE_PARAMETERS)
        if unknown:
            raise InvalidParameterError(
                f"unknown gear-pair parameter(s) {sorted(unknown)}; "
                f"valid: {list(SAMPLE_PARAMETERS)}"
            )
        size = None
        for name in SAMPLE_PARAMETERS:
            if name in samples and samples[name] is not None and np.ndim(samples[name]) == 1:
                size = len(samples[name]) if size is None else size
                if len(samples[name]) != size:
                    raise InvalidParameterError("all sample columns must have the same length")
        size = 1 if size is None else size

        def pick(name: str, fallback: np.ndarray | None) -> np.ndarray | None:
            column = _column(samples, name, size)
            if column is not None:
                return column
            if name in self.defaults:
                return np.full(size, self.defaults[name])
            return fallback

        common = pick("tooth_stiffness", None)
        return {
            "torque": pick("torque", None),
            "contact_stiffness": pick("contact_stiffness", None),
            "pinion_tooth_stiffness": pick("pinion_tooth_stiffness", common),
            "wheel_tooth_stiffness": pick("wheel_tooth_stiffness", common),
        }

    # ---- evaluation ----------------------------------------------------------------------
    def solve(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Quasi-static solution with the details tests and plots need.

        Returns
        -------
        dict
            ``ste`` (B, P) [m]; ``wheel_torque`` (B, P) [N m], the torque that holds
            the wheel (T2 > 0); ``pair_force`` (B, P, K) [N]; ``pair_kind`` (B, P, K)
            (0 none, 1 conjugate, 2 pinion tip corner, 3 wheel tip corner);
            ``status`` (B,).
        """
        cols = self.stiffness_columns(samples)
        ste, wheel_moment, pair_force, pair_kind, status, _, _ = solve_static_batch(
            self.geometry,
            self.positions,
            self.pairs,
            cols["torque"],
            cols["contact_stiffness"],
            self.contact_exponent,
            cols["pinion_tooth_stiffness"],
            cols["wheel_tooth_stiffness"],
        )
        return {
            "ste": ste,
            "wheel_torque": -wheel_moment,
            "pair_force": pair_force,
            "pair_kind": pair_kind,
            "status": status,
        }

    def __call__(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Evaluate a batch of samples (the study-model interface).

        Parameters
        ----------
        samples : mapping of str to (B,) array
            Any of ``tooth_stiffness`` [N m/rad], ``pinion_tooth_stiffness``,
            ``wheel_tooth_stiffness`` [N m/rad] (inf: rigid teeth),
            ``contact_stiffness`` [N/m^m1] and ``torque`` [N m]; missing ones take
            the model's defaults.

        Returns
        -------
        dict
            Static mode: ``ste`` (B, P) [m] over ``coords["position"]``; dynamic mode:
            ``dte`` (B, N) [m] and ``dte_spectrum`` (B, H) [m]. Both: ``failed`` (B,)
            bool and ``failure_reason`` (B,) str (non-converged or no contact).
        """
        if self.mode == "dynamic":
            from fuzzymbs.models.gears.dynamics import simulate

            return simulate(self, samples)
        result = self.solve(samples)
        status = result["status"]
        failed = status != STATUS_OK
        reasons = np.array([STATUS_TEXT.get(int(s), "") for s in status], dtype=str)
        return {"ste": result["ste"], "failed": failed, "failure_reason": reasons}
