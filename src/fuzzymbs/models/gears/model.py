"""The batched MUBOCO-PR gear-pair model: samples of stiffness and torque in, STE or DTE out.

``MubocoPR(pair, ...)`` meets the study-model interface (``model(samples)`` on a
whole batch). Its static mode solves the quasi-static transmission error with
the compiled solver of :mod:`fuzzymbs.models.gears.muboco`; its dynamic mode
integrates the gear pair in time (:mod:`fuzzymbs.models.gears.dynamics`).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.dynamics import DynamicSettings, make_plan, simulate
from fuzzymbs.models.gears.flank_contact import (
    hpstc_radii,
    operating_geometry_batch,
    pack_geometry,
)
from fuzzymbs.models.gears.geometry import GearPair
from fuzzymbs.models.gears.identification import identify
from fuzzymbs.models.gears.muboco import (
    STATUS_OK,
    STATUS_TEXT,
    pair_indices,
    solve_static_batch_tolerances,
)
from fuzzymbs.models.gears.potential_energy import reference_ste
from fuzzymbs.tolerance import DEFAULT_TOLERANCE

__all__ = ["SAMPLE_PARAMETERS", "MubocoPR"]

#: Model parameters a sample may carry (anything else is rejected).
SAMPLE_PARAMETERS = (
    "tooth_stiffness",
    "pinion_tooth_stiffness",
    "wheel_tooth_stiffness",
    "contact_stiffness",
    "torque",
    "center_distance_deviation",
    "tip_relief",
)
#: Manufacturing tolerances a sample may carry (default 0): any finite value; relief >= 0.
TOLERANCE_PARAMETERS = ("center_distance_deviation", "tip_relief")


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
    if name in TOLERANCE_PARAMETERS:
        ok = np.isfinite(values) & ((values >= 0.0) if name == "tip_relief" else True)
        if not np.all(ok):
            valid = "finite and >= 0" if name == "tip_relief" else "finite"
            raise InvalidParameterError(f"{name} [m] must be {valid}, got {values[~ok][:3]!r}")
        return values
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


def mesh_positions(positions: int | Sequence[float] | np.ndarray) -> np.ndarray:
    """Mesh positions [fraction of the mesh period] from a count or given fractions, checked."""
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
    pinion_relief_start_diameter, wheel_relief_start_diameter : float, optional
        Diameters [m] at which the linear tip relief (sample parameter
        ``tip_relief``) starts on each gear, between the form and the tip diameter.
        Default: each gear's diameter at the highest point of single tooth contact
        (HPSTC) of the nominal pair, "long relief" (the relief spans the whole
        double-contact zone at the tooth tip, so that the relief matched to a design
        load hands the load over gradually across it: Harris 1958, Munro; see
        docs/gears.md).

    Notes
    -----
    ``model(samples)`` takes ``{"tooth_stiffness": (B,), "contact_stiffness": (B,),
    "torque": (B,)}``; ``pinion_tooth_stiffness`` / ``wheel_tooth_stiffness``
    override ``tooth_stiffness`` for one gear; the manufacturing tolerances
    ``center_distance_deviation`` (a_w - a [m], a the pair's ``center_distance``)
    and ``tip_relief`` (C_a [m], both gears) default to 0. Returns
    ``{"ste": (B, P)}`` [m] (dynamic mode: ``{"dte": (B, N), "dte_spectrum": (B,
    H)}``) plus ``failed`` and ``failure_reason`` (B,). Mesh position 0 is the start
    of contact A at each sample's own centre distance.
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
        pinion_relief_start_diameter: float | None = None,
        wheel_relief_start_diameter: float | None = None,
    ) -> None:
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
        default_starts = hpstc_radii(pair)
        self.relief_start_given = (pinion_relief_start_diameter, wheel_relief_start_diameter)
        starts = tuple(
            default if given is None else 0.5 * float(given)
            for default, given in zip(default_starts, self.relief_start_given, strict=True)
        )
        #: Diameters [m] where the tip relief starts on the pinion and the wheel.
        self.relief_start_diameters = (2.0 * starts[0], 2.0 * starts[1])
        self.geometry = pack_geometry(pair, starts)
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
            self.positions = mesh_positions(positions)
            self.coords = {"position": self.positions}
            self.coord_units = {"position": "periods"}
            self.output_dims = {"ste": ("position",)}
            self.reference = {}
            self.reference_labels = {"ste": "potential-energy method"}
            if reference:
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
            # the plan holds the torque history as an array: the model stays picklable
            # even when torque_variation is a lambda (it is dropped after sampling)
            self.dynamic_plan = make_plan(self)
            self.dynamic = dataclasses.replace(dynamic, torque_variation=None)
            self.coords = {"time": dynamic.time_grid(pair)}
            self.coord_units = {"time": "s", "harmonic": "× mesh frequency"}
            self.output_dims = {"dte": ("time",), "dte_spectrum": ("harmonic",)}
            self.coords["harmonic"] = np.arange(1, dynamic.harmonics + 1, dtype=float)
            self.reference = {}

    @property
    def time_integration(self) -> str:
        """The dynamic mode's time integration in words ("" in the static mode)."""
        if self.mode != "dynamic":
            return ""
        return f"rk4, dt {self.dynamic_plan.dt:.3g} s (omega_max dt <= {self.dynamic.step_scale:g})"

    def tightened(self) -> MubocoPR | None:
        """The dynamic mode at a divided step (the integrators' check tightening,
        :data:`fuzzymbs.tolerance.DEFAULT_TOLERANCE`'s ``step_division``: half), for the
        study runner's check of the time integration
        (:mod:`fuzzymbs.study.integration_check`); None in the static mode, which does
        not integrate in time. A torque history is interpolated linearly onto the finer
        grid."""
        if self.mode != "dynamic":
            return None
        tight = copy.copy(self)
        step_scale = self.dynamic.step_scale / DEFAULT_TOLERANCE.step_division
        tight.dynamic = dataclasses.replace(self.dynamic, step_scale=step_scale)
        plan = make_plan(tight)
        factor = self.dynamic_plan.torque_factor
        if factor is not None:
            coarse = np.arange(factor.size) * self.dynamic_plan.dt / 2
            fine = np.arange(2 * plan.n_steps + 1) * plan.dt / 2
            plan = dataclasses.replace(plan, torque_factor=np.interp(fine, coarse, factor))
        tight.dynamic_plan = plan
        return tight

    def identity(self) -> str:
        """SHA-256 digest of every setting that changes the outputs (for result stores).

        Two models with equal digests give equal outputs for equal samples, so a
        study store made with one is valid for the other.
        """
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
        if self.relief_start_given != (None, None):
            settings = (*settings, ("relief_start", self.relief_start_diameters))
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
        """Per-sample torque, contact stiffness, both tooth stiffnesses and the
        tolerances (``center_distance_deviation``, ``tip_relief``), defaults filled."""
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
            "center_distance_deviation": pick("center_distance_deviation", np.zeros(size)),
            "tip_relief": pick("tip_relief", np.zeros(size)),
        }

    def batch_pairs(self, center_deviation: np.ndarray) -> np.ndarray:
        """Tooth-pair indices for a batch: enough for its largest contact ratio.

        A negative centre-distance deviation raises the contact ratio; the batch's
        shortest valid centre distance (not below the zero-backlash one) sets it.
        """
        deviation = np.asarray(center_deviation, dtype=float)
        if deviation.size == 0 or deviation.min() >= 0.0:
            return self.pairs
        a = self.pair.center_distance
        shortest = max(a + deviation.min(), self.pair.zero_backlash_center_distance)
        ratio = operating_geometry_batch(self.geometry, np.array([shortest - a]))[3][0]
        return pair_indices(self.pair, float(ratio))

    def operating_geometry(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Each sample's operating geometry (its ``center_distance_deviation``).

        Returns
        -------
        dict of (B,) arrays
            ``center_distance`` a_w [m]; ``operating_pressure_angle`` alpha_w [rad],
            cos(alpha_w) = (r_b1 + r_b2) / a_w; ``contact_ratio`` eps_alpha;
            ``backlash``: circumferential backlash on the operating pitch circle
            j_wt [m] (negative: jammed); ``normal_backlash`` j_n = j_wt cos(alpha_w)
            [m]; ``wheel_backlash_angle`` j_n / r_b2 [rad], the wheel's free rotation
            with the pinion held; ``status`` (0 or the geometry failure code) and
            ``failure_reason``.
        """
        cols = self.stiffness_columns(samples)
        status, a_w, alpha_w, ratio, backlash = operating_geometry_batch(
            self.geometry, cols["center_distance_deviation"]
        )
        return {
            "center_distance": a_w,
            "operating_pressure_angle": alpha_w,
            "contact_ratio": ratio,
            "backlash": backlash / np.cos(alpha_w),
            "normal_backlash": backlash,
            "wheel_backlash_angle": backlash / self.pair.wheel.base_radius,
            "status": status,
            "failure_reason": np.array([STATUS_TEXT.get(int(c), "") for c in status], dtype=str),
        }

    # ---- evaluation ----------------------------------------------------------------------
    def solve(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Quasi-static solution with the details tests and plots need.

        Returns
        -------
        dict
            ``ste`` (B, P) [m]; ``wheel_torque`` (B, P) [N m], the torque that holds
            the wheel (T2 > 0); ``pair_force`` (B, P, K) [N] of the tooth pairs
            ``pairs`` (K,) (pair k starts contact at position -k; K grows when a
            negative centre-distance deviation raises the contact ratio);
            ``pair_kind`` (B, P, K) (0 none, 1 conjugate, 2 pinion tip corner, 3 wheel
            tip corner); ``status`` (B,) (0 ok, else a key of ``STATUS_TEXT``).
        """
        cols = self.stiffness_columns(samples)
        pairs = self.batch_pairs(cols["center_distance_deviation"])
        ste, wheel_moment, pair_force, pair_kind, status, _, _ = solve_static_batch_tolerances(
            self.geometry,
            self.positions,
            pairs,
            cols["torque"],
            cols["contact_stiffness"],
            self.contact_exponent,
            cols["pinion_tooth_stiffness"],
            cols["wheel_tooth_stiffness"],
            cols["center_distance_deviation"],
            cols["tip_relief"],
        )
        return {
            "ste": ste,
            "wheel_torque": -wheel_moment,
            "pair_force": pair_force,
            "pair_kind": pair_kind,
            "pairs": pairs,
            "status": status,
        }

    def __call__(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Evaluate a batch of samples (the study-model interface).

        Parameters
        ----------
        samples : mapping of str to (B,) array
            Any of ``tooth_stiffness`` [N m/rad], ``pinion_tooth_stiffness``,
            ``wheel_tooth_stiffness`` [N m/rad] (inf: rigid teeth),
            ``contact_stiffness`` [N/m^m1], ``torque`` [N m],
            ``center_distance_deviation`` [m] and ``tip_relief`` [m]; missing ones
            take the model's defaults (the tolerances 0).

        Returns
        -------
        dict
            Static mode: ``ste`` (B, P) [m] over ``coords["position"]``; dynamic mode:
            ``dte`` (B, N) [m] and ``dte_spectrum`` (B, H) [m]. Both: ``failed`` (B,)
            bool and ``failure_reason`` (B,) str (non-converged, no contact, or a
            centre distance at which the pair cannot run: jammed, interference, ...).
        """
        if self.mode == "dynamic":
            return simulate(self, samples)
        result = self.solve(samples)
        status = result["status"]
        failed = status != STATUS_OK
        reasons = np.array([STATUS_TEXT.get(int(s), "") for s in status], dtype=str)
        return {"ste": result["ste"], "failed": failed, "failure_reason": reasons}
