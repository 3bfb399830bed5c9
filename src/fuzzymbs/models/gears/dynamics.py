"""Dynamic mode of MUBOCO-PR: time integration of the gear pair with hinged teeth.

Degrees of freedom per sample: both gear angles theta1, theta2 (free, on fixed
axes) and the hinge angle of every tooth of both gears. Equations (rigid
foundation of inertia J including its teeth, tooth inertia J_h about its hinge,
small hinge angles; centrifugal stiffening of the teeth neglected):

    J theta'' + J_h sum_i beta_i'' = T + sum (contact moments about the centre)
    J_h (theta'' + beta_i'') = M_i - k_t beta_i - c_t beta_i'

with M_i the moment of the contact force about tooth i's hinge and
c_t = 2 zeta_t sqrt(k_t J_h) a light hinge damping (teeth out of mesh stop
ringing). The contact force is the full penalty law
F = k delta^m1 + c sign(delta')|delta'|^m2 delta^m3 (>= 0); delta' by a
directional difference of the penetration along the velocity.

The pinion carries the input torque T1 (constant or T1 f(t)); the wheel the
load torque (default T1 z2/z1 against its rotation). Fixed-step RK4; the step
resolves the stiffest tooth-contact mode (omega dt <= 1). The run starts from
the quasi-static solution at mesh position 0 at the nominal speeds, runs in,
and records the dynamic transmission error DTE = r_b1 theta1 + r_b2 theta2 [m]
over the last mesh periods, and its amplitude at the mesh frequency and its
harmonics (one-sided DFT amplitude).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numba
import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.flank_contact import (
    CENTER,
    PHI_REF2,
    PITCH1,
    PITCH2,
    RB1,
    RB2,
    RELIEF,
    THETA_REF1,
    contact_force,
    pair_contact,
    sample_geometries,
)
from fuzzymbs.models.gears.geometry import GearPair
from fuzzymbs.models.gears.identification import hinge_lever_arm
from fuzzymbs.models.gears.muboco import STATUS_TEXT, solve_static_batch_tolerances

STATUS_DIVERGED = 3


@dataclass(frozen=True)
class DynamicSettings:
    """Settings of the dynamic mode.

    Parameters
    ----------
    speed_rpm : float
        Nominal pinion speed [1/min]; mesh frequency z1 n / 60.
    mesh_periods : int
        Simulated mesh periods in total (run-in included).
    output_periods : int
        Last mesh periods recorded (the DTE output and its spectrum).
    points_per_mesh : int
        Output samples per mesh period.
    harmonics : int
        Mesh-frequency harmonics in ``dte_spectrum``.
    pinion_inertia, wheel_inertia : float, optional
        Polar inertia of each gear with its shaft [kg m^2]; default the gear body
        (:attr:`SpurGear.body_inertia`).
    load_torque : float, optional
        Wheel load torque [N m] (resisting); default T1 z2 / z1 per sample.
    torque_variation : callable, optional
        f(t) -> factor on the sample's pinion torque (picklable callables only, or
        leave None for a constant torque). Evaluated once on the time grid.
    hinge_damping_ratio : float
        zeta_t of the tooth hinge dampers.
    stiffness_margin : float
        Step chosen for stiffnesses up to this factor above the identified ones.
    step_scale : float
        RK4's step is chosen so that ``omega_max dt <= step_scale`` (default 1; at
        most 2, inside RK4's stability interval). The study runner's check of the
        time integration re-runs at a divided step (:meth:`MubocoPR.tightened`: the
        step division of :data:`fuzzymbs.tolerance.DEFAULT_TOLERANCE`, half).
    """

    speed_rpm: float = 1000.0
    mesh_periods: int = 40
    output_periods: int = 8
    points_per_mesh: int = 64
    harmonics: int = 5
    pinion_inertia: float | None = None
    wheel_inertia: float | None = None
    load_torque: float | None = None
    torque_variation: Callable[[np.ndarray], np.ndarray] | None = None
    hinge_damping_ratio: float = 0.02
    stiffness_margin: float = 2.0
    step_scale: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed_rpm) and self.speed_rpm > 0):
            raise InvalidParameterError(f"speed_rpm must be positive, got {self.speed_rpm!r}")
        if self.output_periods < 1 or self.mesh_periods <= self.output_periods:
            raise InvalidParameterError(
                f"need 1 <= output_periods < mesh_periods, got {self.output_periods}, "
                f"{self.mesh_periods}"
            )
        if self.points_per_mesh < 8:
            raise InvalidParameterError("points_per_mesh must be >= 8")
        if not 1 <= self.harmonics <= self.points_per_mesh // 2 - 1:
            raise InvalidParameterError(
                f"harmonics must be in [1, points_per_mesh/2 - 1], got {self.harmonics}"
            )
        for name in ("pinion_inertia", "wheel_inertia"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise InvalidParameterError(f"{name} must be positive, got {value!r}")
        if not 0.0 <= self.hinge_damping_ratio < 1.0:
            raise InvalidParameterError("hinge_damping_ratio must be in [0, 1)")
        if self.stiffness_margin < 1.0:
            raise InvalidParameterError("stiffness_margin must be >= 1")
        if not (math.isfinite(self.step_scale) and 0.0 < self.step_scale <= 2.0):
            raise InvalidParameterError(f"step_scale must be in (0, 2], got {self.step_scale!r}")

    def mesh_frequency(self, pair: GearPair) -> float:
        """f_z = z1 n / 60 [Hz]."""
        return pair.pinion.teeth * self.speed_rpm / 60.0

    def time_grid(self, pair: GearPair) -> np.ndarray:
        """Times [s] of the recorded DTE samples."""
        period = 1.0 / self.mesh_frequency(pair)
        start = (self.mesh_periods - self.output_periods) * period
        count = self.output_periods * self.points_per_mesh
        return start + np.arange(count) * period / self.points_per_mesh


@dataclass(frozen=True)
class DynamicPlan:
    """Everything the kernel needs that does not depend on the sample."""

    steps_per_output: int
    dt: float
    n_steps: int
    first_output_step: int
    inertia1: float
    inertia2: float
    tooth_inertia1: float
    tooth_inertia2: float
    torque_factor: np.ndarray | None  # (2 n_steps + 1,) at half steps; None: constant
    speed: float  # pinion rad/s


class DynamicModel(Protocol):
    """What the dynamic mode reads from its gear-pair model.

    :class:`~fuzzymbs.models.gears.model.MubocoPR` meets it; stating it here lets
    the model call :func:`make_plan` and :func:`simulate` without this module
    importing the model's.

    Attributes
    ----------
    pair : GearPair
        The gears.
    torque : float
        Design pinion torque T1 [N m].
    contact_exponent : float
        m1 of the penalty law.
    damping : float
        Contact damping c [N s^m2 / m^(m2+m3)].
    damping_exponents : (float, float)
        (m2, m3) of the damping term.
    defaults : dict of str to float
        Stiffness values used when a sample does not carry them (``tooth_stiffness``
        [N m/rad], ``contact_stiffness`` [N/m^m1], optionally per gear).
    pairs : ndarray of int
        Tooth-pair indices of one mesh period.
    dynamic : DynamicSettings
        Settings of the dynamic mode.
    dynamic_plan : DynamicPlan
        The result of :func:`make_plan` (read by :func:`simulate`).
    geometry : ndarray
        The nominal geometry vector (:func:`~fuzzymbs.models.gears.flank_contact.pack_geometry`).
    """

    pair: GearPair
    torque: float
    contact_exponent: float
    damping: float
    damping_exponents: tuple[float, float]
    defaults: dict[str, float]
    pairs: np.ndarray
    dynamic: DynamicSettings
    dynamic_plan: DynamicPlan
    geometry: np.ndarray

    def stiffness_columns(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Per-sample torque, stiffnesses and tolerances, defaults filled."""
        ...

    def batch_pairs(self, center_deviation: np.ndarray) -> np.ndarray:
        """Tooth-pair indices covering every sample's contact ratio."""
        ...


def make_plan(model: DynamicModel) -> DynamicPlan:
    """Time step, inertias and torque history for a dynamic model."""
    settings: DynamicSettings = model.dynamic
    pair = model.pair
    _, jh1 = pair.pinion.tooth_mass_properties
    _, jh2 = pair.wheel.tooth_mass_properties
    inertia1 = settings.pinion_inertia or pair.pinion.body_inertia
    inertia2 = settings.wheel_inertia or pair.wheel.body_inertia
    if inertia1 <= pair.pinion.teeth * jh1 or inertia2 <= pair.wheel.teeth * jh2:
        raise InvalidParameterError("gear inertia must exceed the sum of its teeth's hinge inertia")
    s = np.linspace(*pair.path_of_contact, 21)
    d1 = np.max(np.abs(hinge_lever_arm(pair.pinion, s)))
    d2 = np.max(np.abs(hinge_lever_arm(pair.wheel, pair.line_of_action_length - s)))
    margin = settings.stiffness_margin
    kt1 = model.defaults.get("pinion_tooth_stiffness", model.defaults["tooth_stiffness"])
    kt2 = model.defaults.get("wheel_tooth_stiffness", model.defaults["tooth_stiffness"])
    kc = model.defaults["contact_stiffness"]
    # tangent contact stiffness m1 k delta^(m1-1) at the design load (one pair)
    m1 = model.contact_exponent
    design_delta = (model.torque / pair.pinion.base_radius / kc) ** (1.0 / m1)
    kc_lin = m1 * kc * design_delta ** (m1 - 1.0)
    omega_sq = max(
        (kt1 + kc_lin * d1**2) / jh1,
        (kt2 + kc_lin * d2**2) / jh2,
        kc_lin * (pair.pinion.base_radius**2 / inertia1 + pair.wheel.base_radius**2 / inertia2),
    )
    # explicit RK4 also needs dt * (damping rate) below its real-axis limit; the damping
    # term c |delta'|^m2 delta^m3 is bounded as viscous (m2 = 1) with the coefficient
    # c delta^m3 at the margin times the design penetration (m3 = 0: c itself)
    _, m3 = model.damping_exponents
    viscous = model.damping * (margin * design_delta) ** m3
    damping_rate = viscous * max(d1**2 / jh1, d2**2 / jh2)
    omega_max = max(math.sqrt(margin * omega_sq), margin * damping_rate)
    period = 1.0 / settings.mesh_frequency(pair)
    output_dt = period / settings.points_per_mesh
    steps_per_output = max(1, math.ceil(output_dt * omega_max / settings.step_scale))
    dt = output_dt / steps_per_output
    n_steps = settings.mesh_periods * settings.points_per_mesh * steps_per_output
    first_output = (settings.mesh_periods - settings.output_periods) * (
        settings.points_per_mesh * steps_per_output
    )
    half_times = np.arange(2 * n_steps + 1) * dt / 2
    factor = None
    if settings.torque_variation is not None:
        factor = np.asarray(settings.torque_variation(half_times), dtype=float)
        if factor.shape != half_times.shape or not np.all(np.isfinite(factor)):
            raise InvalidParameterError(
                "torque_variation(t) must return finite factors of the shape of t"
            )
    return DynamicPlan(
        steps_per_output=steps_per_output,
        dt=dt,
        n_steps=n_steps,
        first_output_step=first_output,
        inertia1=inertia1,
        inertia2=inertia2,
        tooth_inertia1=jh1,
        tooth_inertia2=jh2,
        torque_factor=factor,
        speed=settings.speed_rpm * 2 * math.pi / 60.0,
    )


@numba.njit(cache=True)
def _derivatives(state, torque_in, torque_load, g, pairs, z1, z2, p, out):
    """d(state)/dt; returns False when the state is non-physical (diverged).

    state = [theta1, theta2, omega1, omega2, beta1 (z1), beta2 (z2), rate1 (z1), rate2 (z2)]
    p = [k_con, m1, c, m2, m3, kt1, kt2, ct1, ct2, J1, J2, Jh1, Jh2]
    """
    k_con, m1, damping, m2, m3 = p[0], p[1], p[2], p[3], p[4]
    kt1, kt2, ct1, ct2 = p[5], p[6], p[7], p[8]
    inertia1, inertia2, jh1, jh2 = p[9], p[10], p[11], p[12]
    theta1, theta2, omega1, omega2 = state[0], state[1], state[2], state[3]
    b1 = np.int64(4)  # not a literal 4: _gear_rates would compile once per call site
    b2 = 4 + z1
    r1 = 4 + z1 + z2
    r2 = 4 + 2 * z1 + z2
    hinge1 = np.zeros(z1)
    hinge2 = np.zeros(z2)
    moment1 = torque_in
    moment2 = torque_load
    mesh = math.floor(theta1 / g[PITCH1])
    for i in range(pairs.shape[0]):
        index = pairs[i] - mesh  # pair k sits k base pitches after point A
        i1 = index % z1
        i2 = index % z2
        th = theta1 + g[THETA_REF1] + index * g[PITCH1]
        ph = theta2 + g[PHI_REF2] - index * g[PITCH2]
        be1 = state[b1 + i1]
        be2 = state[b2 + i2]
        kind, delta, qx, qy, nx, ny, h1x, h1y, h2x, h2y = pair_contact(th, be1, ph, be2, g)
        if kind == 0 or delta <= 0.0:
            continue
        rate = 0.0
        if damping != 0.0:
            rate = penetration_rate(
                th, be1, ph, be2, delta, (qx, qy, nx, ny, h1x, h1y, h2x, h2y), g,
                omega1, state[r1 + i1], omega2, state[r2 + i2],
            )  # fmt: skip
        force = contact_force(delta, rate, k_con, m1, damping, m2, m3)
        fx, fy = force * nx, force * ny  # on the wheel tooth
        moment1 -= qx * fy - qy * fx
        moment2 += (qx - g[CENTER]) * fy - qy * fx
        hinge1[i1] -= (qx - h1x) * fy - (qy - h1y) * fx
        hinge2[i2] += (qx - h2x) * fy - (qy - h2y) * fx
    acc1 = _gear_rates(state, hinge1, moment1, b1, r1, z1, kt1, ct1, inertia1, jh1, out)
    acc2 = _gear_rates(state, hinge2, moment2, b2, r2, z2, kt2, ct2, inertia2, jh2, out)
    out[0] = omega1
    out[1] = omega2
    out[2] = acc1
    out[3] = acc2
    return math.isfinite(acc1) and math.isfinite(acc2)


@numba.njit(cache=True, inline="always")
def penetration_rate(th, be1, ph, be2, delta, contact, g, omega1, rate1, omega2, rate2):
    """d delta / dt [m/s] of a pair in contact (``contact`` = the contact point q, the
    normal n towards the wheel and both hinge points, as :func:`pair_contact` gives them
    for tooth angles ``th``, ``ph``, hinge angles ``be1``, ``be2`` and penetration
    ``delta``) at the gears' and hinges' rates.

    Unrelieved flanks: n . (v1 - v2), each tooth's velocity at q from its gear's rotation
    about its centre (pinion at the origin, wheel at (center, 0)) and its hinge's rate
    about the hinge point h (exact; one contact evaluation less than a difference).
    With tip relief the penetration also loses the relief's depth at the roll lengths,
    which move with the gears, so the rate is a forward difference of the penetration
    over 1 ns (its round-off, about 1e-7 of the rate, is far below the damping's scale).
    """
    if g[RELIEF] > 0.0:
        h = 1e-9
        _, moved, _, _, _, _, _, _, _, _ = pair_contact(
            th + h * omega1, be1 + h * rate1, ph + h * omega2, be2 + h * rate2, g
        )
        return (moved - delta) / h
    qx, qy, nx, ny, h1x, h1y, h2x, h2y = contact
    v1x = -omega1 * qy - rate1 * (qy - h1y)
    v1y = omega1 * qx + rate1 * (qx - h1x)
    v2x = -omega2 * qy - rate2 * (qy - h2y)
    v2y = omega2 * (qx - g[CENTER]) + rate2 * (qx - h2x)
    return nx * (v1x - v2x) + ny * (v1y - v2y)


@numba.njit(cache=True)
def _gear_rates(state, hinge, moment, angles, rates, teeth, kt, ct, inertia, jh, out):
    """Foundation acceleration theta'' [rad/s^2] of one gear; writes its hinge rows of ``out``.

    ``hinge[i]``: contact moment about tooth i's hinge [N m] (the spring and damper
    are added here); ``moment``: torque plus contact moments about the centre [N m];
    ``angles``, ``rates``: first state index of the gear's hinge angles and rates.
    Reduced foundation equation: (J - z J_h) theta'' = T + sum m_c - sum R_i; a rigid
    tooth (kt = inf) does not move relative to its gear.
    """
    rigid = not math.isfinite(kt)
    if not rigid:
        total = 0.0
        for i in range(teeth):
            hinge[i] += -kt * state[angles + i] - ct * state[rates + i]
            total += hinge[i]
        acceleration = (moment - total) / (inertia - teeth * jh)
    else:
        acceleration = moment / inertia
    for i in range(teeth):
        out[angles + i] = 0.0 if rigid else state[rates + i]
        out[rates + i] = 0.0 if rigid else hinge[i] / jh - acceleration
    return acceleration


@numba.njit(cache=True, parallel=True)
def simulate_batch(
    g, pairs, z1, z2, initial, torque, load, params, torque_factor, dt, n_steps, first, every,
    center_deviation, tip_relief,
):  # fmt: skip
    """RK4 of a batch; returns DTE (B, n_out) [m] and status (B,) (0 ok, 3 diverged, or
    a geometry status of ``sample_geometry``).

    g the nominal geometry; initial (B, S) states; torque, load (B,) [N m]; params
    (B, 13) (see _derivatives); torque_factor (2 n_steps + 1,) at half steps;
    center_deviation, tip_relief (B,) [m] (each sample's geometry is made here).
    """
    n_samples = initial.shape[0]
    size = initial.shape[1]
    n_out = (n_steps - first) // every
    dte = np.full((n_samples, n_out), np.nan)
    status = np.zeros(n_samples, dtype=np.int64)
    geometry = sample_geometries(g, center_deviation, tip_relief, status)
    for b in numba.prange(n_samples):
        if status[b] != 0:
            continue
        gb = geometry[b]
        y = initial[b].copy()
        k1 = np.empty(size)
        k2 = np.empty(size)
        k3 = np.empty(size)
        k4 = np.empty(size)
        tmp = np.empty(size)
        p = params[b]
        ok = True
        for step in range(n_steps):
            if step >= first and (step - first) % every == 0:
                dte[b, (step - first) // every] = g[RB1] * y[0] + g[RB2] * y[1]
            t_in0 = torque[b] * torque_factor[2 * step]
            t_in1 = torque[b] * torque_factor[2 * step + 1]
            t_in2 = torque[b] * torque_factor[2 * step + 2]
            ok = _derivatives(y, t_in0, load[b], gb, pairs, z1, z2, p, k1)
            for i in range(size):
                tmp[i] = y[i] + 0.5 * dt * k1[i]
            ok &= _derivatives(tmp, t_in1, load[b], gb, pairs, z1, z2, p, k2)
            for i in range(size):
                tmp[i] = y[i] + 0.5 * dt * k2[i]
            ok &= _derivatives(tmp, t_in1, load[b], gb, pairs, z1, z2, p, k3)
            for i in range(size):
                tmp[i] = y[i] + dt * k3[i]
            ok &= _derivatives(tmp, t_in2, load[b], gb, pairs, z1, z2, p, k4)
            for i in range(size):
                y[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            # diverged: NaN, or a transmission error beyond a base pitch / hinge > 0.1 rad
            if not ok or abs(g[RB1] * y[0] + g[RB2] * y[1]) > 0.5 * g[RB1] * g[PITCH1]:
                ok = False
            if ok:
                for i in range(4, 4 + z1 + z2):
                    if not abs(y[i]) < 0.1:
                        ok = False
                        break
            if not ok:
                status[b] = STATUS_DIVERGED
                for j in range(n_out):
                    dte[b, j] = np.nan
                break
    return dte, status


def harmonic_amplitudes(signal: np.ndarray, periods: int, harmonics: int) -> np.ndarray:
    """One-sided amplitudes of harmonics 1..H of a signal spanning ``periods`` periods.

    Parameters
    ----------
    signal : (B, N) uniformly sampled over exactly ``periods`` fundamental periods.
    """
    spectrum = np.fft.rfft(signal - signal.mean(axis=-1, keepdims=True), axis=-1)
    bins = periods * np.arange(1, harmonics + 1)
    return 2.0 * np.abs(spectrum[..., bins]) / signal.shape[-1]


def simulate(model: DynamicModel, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Dynamic transmission error of a batch of samples (the model's dynamic mode)."""
    plan: DynamicPlan = model.dynamic_plan
    settings: DynamicSettings = model.dynamic
    pair = model.pair
    cols = model.stiffness_columns(samples)
    size = cols["torque"].shape[0]
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    g = model.geometry
    deviation, relief = cols["center_distance_deviation"], cols["tip_relief"]
    pairs = model.batch_pairs(deviation)
    factor = np.ones(2 * plan.n_steps + 1) if plan.torque_factor is None else plan.torque_factor
    # initial state: quasi-static equilibrium at mesh position 0 under the initial torque
    ste, _, _, _, status0, beta1, beta2 = solve_static_batch_tolerances(
        g, np.zeros(1), pairs, cols["torque"] * factor[0], cols["contact_stiffness"],
        model.contact_exponent,
        cols["pinion_tooth_stiffness"], cols["wheel_tooth_stiffness"], deviation, relief,
    )  # fmt: skip
    initial = np.zeros((size, 4 + 2 * (z1 + z2)))
    initial[:, 0] = np.nan_to_num(ste[:, 0]) / pair.pinion.base_radius
    for i, k in enumerate(pairs):  # at mesh 0 pair k holds tooth k of both gears
        initial[:, 4 + k % z1] = beta1[:, i]
        initial[:, 4 + z1 + k % z2] = beta2[:, i]
    initial[:, 2] = plan.speed
    initial[:, 3] = -plan.speed * z1 / z2
    mean_factor = float(np.mean(factor))
    if settings.load_torque is None:
        load = cols["torque"] * mean_factor * z2 / z1
    else:
        load = np.full(size, float(settings.load_torque))
    m2, m3 = model.damping_exponents
    kt1, kt2 = cols["pinion_tooth_stiffness"], cols["wheel_tooth_stiffness"]
    zeta = settings.hinge_damping_ratio
    params = np.column_stack(
        [
            cols["contact_stiffness"],
            np.full(size, model.contact_exponent),
            np.full(size, model.damping),
            np.full(size, m2),
            np.full(size, m3),
            kt1,
            kt2,
            np.where(np.isfinite(kt1), 2 * zeta * np.sqrt(kt1 * plan.tooth_inertia1), 0.0),
            np.where(np.isfinite(kt2), 2 * zeta * np.sqrt(kt2 * plan.tooth_inertia2), 0.0),
            np.full(size, plan.inertia1),
            np.full(size, plan.inertia2),
            np.full(size, plan.tooth_inertia1),
            np.full(size, plan.tooth_inertia2),
        ]
    )
    dte, status = simulate_batch(
        g, pairs, z1, z2, initial, cols["torque"], load, params, factor,
        plan.dt, plan.n_steps, plan.first_output_step, plan.steps_per_output,
        deviation, relief,
    )  # fmt: skip
    status = np.where(status0 != 0, status0, status)
    failed = status != 0
    dte[failed] = np.nan
    spectrum = harmonic_amplitudes(np.nan_to_num(dte), settings.output_periods, settings.harmonics)
    spectrum[failed] = np.nan
    texts = {
        **{code: f"no quasi-static start ({text})" for code, text in STATUS_TEXT.items()},
        **{code: text for code, text in STATUS_TEXT.items() if code > STATUS_DIVERGED},
        STATUS_DIVERGED: "time integration diverged",
    }
    reasons = np.array([texts.get(int(code), "") for code in status], dtype=str)
    return {"dte": dte, "dte_spectrum": spectrum, "failed": failed, "failure_reason": reasons}
