"""Scalar features of the static transmission error (STE) for identifying the gear stiffnesses.

Four features of an STE curve over one mesh period (all in metres):

* ``ste_mean``: mean over the period;
* ``ste_peak_to_peak``: max - min over the period;
* ``ste_single``: mean over the single-contact zone (one tooth pair in contact);
* ``ste_double``: mean over the double-contact zone (two pairs in contact).

The zones come from the rigid-kinematics involute geometry (the contact ratio
eps_alpha), not from the sampled STE, so every feature is a smooth function of
the stiffnesses: position 0 is the start of contact of a pair (point A), two
pairs are in contact on [0, eps_alpha - 1] of the period and one on
(eps_alpha - 1, 1) (for 2 <= eps_alpha < 3 read "double" and "triple").

Margin (:data:`DEFAULT_MARGIN`, 8 % of the mesh period at each zone change):
MUBOCO-PR shows extended contact, loaded teeth bend, so the leaving pair keeps
its pinion tip on the wheel flank after the end of contact and the entering
pair touches with the wheel tip before the start of contact; this rounds the
steps of the STE inside the *single*-contact zone. For the default pair at
T1 = 100 N m (400 positions) the tip-corner contact reaches 0.052 of the period
past eps_alpha - 1 and starts 0.038 before the period's end at the modal
stiffnesses, and up to 0.062 / 0.045 at the corners of a +-30 % box on the three
stiffnesses. 5 % would leave part of that rounding inside ``ste_single``; 8 %
keeps it out over the box. The same zones are used for every source, so the
rigid-kinematics references (potential energy) and the model are compared on
the same positions.

Sources of reference values (:func:`reference_features`): the potential-energy
reference STE (all four features), ISO 6336-1 method B (``ste_mean`` and
``ste_single``) and MUBOCO-PR at its analytically identified modal values (all
four). :func:`reference_feature_spread` gives their spread as triangular
fuzzy numbers ``(lower, modal, upper)`` for an inverse fuzzy-arithmetic
identification of ``pinion_tooth_stiffness``, ``wheel_tooth_stiffness`` and
``contact_stiffness`` (plain numbers: a model imports no part of the fuzzy
engine; :func:`fuzzymbs.fuzzy.numbers.triangular_numbers` turns them into fuzzy
numbers).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.geometry import GearPair
from fuzzymbs.models.gears.iso6336 import iso_pair_stiffness
from fuzzymbs.models.gears.model import MubocoPR

__all__ = [
    "DEFAULT_MARGIN",
    "FEATURES",
    "SteFeatureModel",
    "contact_zones",
    "reference_feature_spread",
    "reference_features",
    "ste_features",
]

#: Feature names, in a fixed order.
FEATURES = ("ste_mean", "ste_peak_to_peak", "ste_single", "ste_double")
#: Distance [fraction of the mesh period] kept from every change of the number of
#: pairs in contact (see the module docstring for the measured extended contact).
DEFAULT_MARGIN = 0.08
#: Names of the sources returned by :func:`reference_features`.
SOURCES = ("model", "potential_energy", "iso6336")


def _equally_spaced(positions: Any) -> np.ndarray:
    """Equally spaced positions k/P over one period (the mean over them is the period mean)."""
    if np.ndim(positions) != 0:
        raise InvalidParameterError(
            "positions must be a count (equally spaced over the mesh period: the features "
            f"average over the period), got {type(positions).__name__}"
        )
    count = int(positions)
    if count != positions or count < 10:
        raise InvalidParameterError(f"positions must be an integer >= 10, got {positions!r}")
    return np.arange(count) / count


def contact_zones(
    pair: GearPair, positions: np.ndarray, margin: float = DEFAULT_MARGIN
) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the single- and double-contact positions, ``margin`` away from zone changes.

    Parameters
    ----------
    pair : GearPair
    positions : (P,) array
        Mesh positions as fractions of the mesh period in [0, 1); 0 is the start
        of contact A of a tooth pair (as in :class:`MubocoPR`).
    margin : float
        Distance [fraction of the period] kept from the zone changes at 0,
        eps_alpha - floor(eps_alpha) and 1, in [0, 0.25).

    Returns
    -------
    single, double : (P,) bool
        Rigid-kinematics zones: floor(eps_alpha) pairs in contact (``single``), one
        more (``double``).

    Raises
    ------
    InvalidParameterError
        Positions outside [0, 1), a margin out of range, an integer contact ratio
        (no zone change), or a zone without any position.
    """
    positions = np.asarray(positions, dtype=float)
    if positions.ndim != 1 or np.any(positions < 0.0) or np.any(positions >= 1.0):
        raise InvalidParameterError("positions must be a 1-D array of fractions in [0, 1)")
    if not 0.0 <= margin < 0.25:
        raise InvalidParameterError(f"margin must be in [0, 0.25), got {margin!r}")
    eps = pair.contact_ratio
    change = eps - math.floor(eps)  # end of the zone with one pair more
    if change <= 2.0 * margin or 1.0 - change <= 2.0 * margin:
        raise InvalidParameterError(
            f"contact ratio {eps:.4f}: a contact zone ({change:.3f} or {1 - change:.3f} of the "
            f"period) is not wider than twice the margin {margin!r}"
        )
    more_pairs = positions <= change  # as potential_energy.contact_positions
    distance = np.minimum(np.minimum(positions, np.abs(positions - change)), 1.0 - positions)
    clear = distance >= margin - 1e-12
    single, double = ~more_pairs & clear, more_pairs & clear
    if not single.any() or not double.any():
        raise InvalidParameterError(
            f"no mesh position in the {'single' if not single.any() else 'double'}-contact zone "
            f"with margin {margin!r}; use more positions"
        )
    return single, double


def ste_features(
    ste: np.ndarray, single: np.ndarray, double: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """The four scalar features of STE curves over one mesh period.

    Parameters
    ----------
    ste : (B, P) or (P,) array
        STE [m] at P equally spaced positions covering one mesh period (the
        period mean is then the plain mean).
    single : (P,) bool
        Positions averaged for ``ste_single`` (:func:`contact_zones`).
    double : (P,) bool, optional
        Positions averaged for ``ste_double``; default ``~single``.

    Returns
    -------
    dict
        ``ste_mean``, ``ste_peak_to_peak``, ``ste_single``, ``ste_double``, each
        (B,) (or a 0-d array for a (P,) input) [m]. A NaN in a row gives NaN
        features for that row.
    """
    values = np.asarray(ste, dtype=float)
    single = np.asarray(single, dtype=bool)
    double = ~single if double is None else np.asarray(double, dtype=bool)
    if values.ndim not in (1, 2) or values.shape[-1] != single.shape[0]:
        raise InvalidParameterError(
            f"ste must be (B, P) or (P,) with P = {single.shape[0]} positions, got {values.shape}"
        )
    if double.shape != single.shape:
        raise InvalidParameterError("single and double masks must have the same shape")
    if not single.any() or not double.any():
        raise InvalidParameterError("the single- and double-contact masks must not be empty")
    if np.any(single & double):
        raise InvalidParameterError("a position cannot be in both the single and double zone")
    return {
        "ste_mean": values.mean(axis=-1),
        "ste_peak_to_peak": values.max(axis=-1) - values.min(axis=-1),
        "ste_single": values[..., single].mean(axis=-1),
        "ste_double": values[..., double].mean(axis=-1),
    }


class SteFeatureModel:
    """The registered ``"gear-pair"`` model reduced to the four scalar STE features.

    ``SteFeatureModel(**options)`` takes the options of
    :func:`fuzzymbs.models.gears.gear_pair_model` (``torque``, ``positions``,
    ``contact_exponent`` and the gear data) plus ``margin``; ``positions`` must
    be a count (equally spaced over the period; default 120, as
    :func:`reference_features`, so that the modal sample reproduces its ``"model"``
    source exactly; the registered gear-pair model defaults to 60, which gives a
    1 % lower peak-to-peak value). ``model(samples)`` takes the
    gear-pair sample columns (``tooth_stiffness``, ``pinion_tooth_stiffness``,
    ``wheel_tooth_stiffness``, ``contact_stiffness``, ``torque`` and the
    manufacturing tolerances ``center_distance_deviation``, ``tip_relief``; missing
    ones take the defaults) and returns ``{feature: (B,)}`` [m] plus ``failed`` and
    ``failure_reason`` (B,) from MUBOCO-PR; features of failed samples are NaN. The
    zones are those of the nominal pair: a centre-distance deviation moves the end of
    the double-contact zone (contact ratio -0.21 per mm for the default pair); at
    T1 = 100 N m the loaded pairs still match the nominal zones up to +0.6 mm (400
    positions), from +0.8 mm single contact reaches into the nominal double zone.

    Attributes
    ----------
    base : MubocoPR
        The wrapped gear-pair model (``base.identified``: the modal values).
    parameters : dict of str to ParameterInfo
        As the registered ``"gear-pair"`` model declares them.
    outputs : dict
        ``{feature: "m"}``.
    coords, output_dims : dict
        Empty coordinates; scalar outputs.
    single, double : (P,) bool
        The zones over ``base.positions``.
    reference : dict
        The potential-energy reference features (scalars), like ``base.reference``.
    """

    def __init__(
        self,
        torque: float = 100.0,
        positions: int = 120,
        contact_exponent: float = 1.0,
        margin: float = DEFAULT_MARGIN,
        **gear_options: Any,
    ) -> None:
        from fuzzymbs.models.gears import gear_pair_model
        from fuzzymbs.study.registry import get_model

        _equally_spaced(positions)
        self.margin = float(margin)
        self.base: MubocoPR = gear_pair_model(
            torque=torque,
            positions=positions,
            contact_exponent=contact_exponent,
            **gear_options,
        )
        self.single, self.double = contact_zones(self.base.pair, self.base.positions, self.margin)
        self.parameters = dict(get_model("gear-pair").parameters)
        self.outputs = dict.fromkeys(FEATURES, "m")
        self.coords: dict[str, np.ndarray] = {}
        self.output_dims: dict[str, tuple[str, ...]] = {name: () for name in FEATURES}
        self.reference_labels = dict.fromkeys(FEATURES, "potential-energy method")
        self.reference = {
            name: float(value)
            for name, value in ste_features(
                self.base.reference["ste"], self.single, self.double
            ).items()
        }

    def identity(self) -> str:
        """Digest of the wrapped model's settings and the margin (for result stores)."""
        return f"{self.base.identity()}-features-margin-{self.margin!r}"

    def __call__(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Features of a batch of samples: ``{feature: (B,)}``, ``failed``, ``failure_reason``."""
        out = self.base(samples)
        features = ste_features(out["ste"], self.single, self.double)
        failed = np.asarray(out["failed"], dtype=bool)
        for values in features.values():
            values[failed] = np.nan
        return {**features, "failed": failed, "failure_reason": out["failure_reason"]}


def reference_features(
    pair: GearPair,
    torque: float = 100.0,
    positions: int = 120,
    *,
    contact_exponent: float = 1.0,
    margin: float = DEFAULT_MARGIN,
) -> dict[str, dict[str, float]]:
    """The STE features from the independent references and the model at its modal values.

    Parameters
    ----------
    pair : GearPair
    torque : float
        Pinion torque T1 [N m] (identification and all sources).
    positions : int
        Equally spaced mesh positions over the period.
    contact_exponent : float
        m1 of the model's penalty law (the PE reference always uses the linear
        secant contact stiffness, as :class:`MubocoPR` does).
    margin : float
        See :func:`contact_zones`.

    Returns
    -------
    dict
        ``source -> {feature: value [m]}`` with the sources

        * ``"model"``: MUBOCO-PR at the identified modal values
          (:func:`~fuzzymbs.models.gears.identification.identify`: the common
          tooth stiffness for both gears, the Weber-Banaschek secant contact
          stiffness), all four features;
        * ``"potential_energy"``: the potential-energy reference STE
          (:func:`~fuzzymbs.models.gears.potential_energy.reference_ste`, rigid
          kinematics, same contact stiffness), all four features;
        * ``"iso6336"``: ISO 6336-1 method B, ``ste_mean`` and ``ste_single`` only.

    Notes
    -----
    ISO 6336-1 defines the single stiffness c' as the maximum stiffness of one
    tooth pair and the mesh stiffness c_gamma_alpha = c' (0.75 eps_alpha + 0.25) as
    the mean over the period, both as the force in the base tangent plane per mm
    face width per um of deflection along the line of action [N/(mm um)]. With
    F = T1 / r_b1 (the normal force, along the line of action) and b in mm,

    * ``ste_mean`` = F / (c_gamma_alpha b) (the same as
      :func:`~fuzzymbs.models.gears.iso6336.iso_mean_ste`),
    * ``ste_single`` = F / (c' b),

    converted from um to m. Two approximations are inherent: F / c_gamma_alpha is the
    deflection under the *mean stiffness*, which is smaller than the mean STE
    (mean of F/k >= F / mean k; for a step STE such as the PE curve about 7 %),
    and c' is the *maximum* single-pair stiffness (near the pitch point), so
    F / (c' b) is the low end of the single-contact STE rather than its mean.
    ISO gives no double-contact level and no peak-to-peak value.
    """
    _equally_spaced(positions)
    model = MubocoPR(pair, torque=torque, positions=positions, contact_exponent=contact_exponent)
    single, double = contact_zones(pair, model.positions, margin)

    def scalars(ste: np.ndarray) -> dict[str, float]:
        return {k: float(v) for k, v in ste_features(ste, single, double).items()}

    out = model({})
    if out["failed"][0]:
        raise InvalidParameterError(
            f"MUBOCO-PR failed at its modal values: {out['failure_reason'][0]}"
        )
    iso = iso_pair_stiffness(pair, torque)
    width_mm = min(pair.pinion.face_width, pair.wheel.face_width) * 1e3
    force = torque / pair.pinion.base_radius  # N, along the line of action
    um = 1e-6
    return {
        "model": scalars(out["ste"][0]),
        "potential_energy": scalars(model.reference["ste"]),
        "iso6336": {
            "ste_mean": force / (iso.mesh * width_mm) * um,
            "ste_single": force / (iso.single * width_mm) * um,
        },
    }


def reference_feature_spread(
    pair: GearPair | None = None,
    torque: float = 100.0,
    positions: int = 120,
    *,
    contact_exponent: float = 1.0,
    margin: float = DEFAULT_MARGIN,
    references: Mapping[str, Mapping[str, float]] | None = None,
    modal_source: str = "model",
) -> dict[str, tuple[float, float, float]]:
    """The spread of the references as triangular fuzzy numbers, one per feature.

    Modal value: the feature of ``modal_source`` (the model at its identified
    modal stiffnesses); support: [min, max] over every source that gives the
    feature, the modal source included.

    Parameters
    ----------
    pair, torque, positions, contact_exponent, margin
        As :func:`reference_features` (``pair`` is not needed with ``references``).
    references : mapping, optional
        ``source -> {feature: value}`` already computed by :func:`reference_features`.
    modal_source : str
        The source of the modal values; it must give every feature.

    Returns
    -------
    dict
        ``feature -> (lower, modal, upper)`` [m], in :data:`FEATURES` order: a
        triangular fuzzy number (``triangular_numbers`` of :mod:`fuzzymbs.fuzzy.numbers`
        builds it).
    """
    if references is None:
        if pair is None:
            raise InvalidParameterError("give a GearPair or the references")
        references = reference_features(
            pair, torque, positions, contact_exponent=contact_exponent, margin=margin
        )
    if modal_source not in references:
        raise InvalidParameterError(
            f"modal_source {modal_source!r} is not a source; sources: {sorted(references)}"
        )
    modal = references[modal_source]
    missing = [name for name in FEATURES if name not in modal]
    if missing:
        raise InvalidParameterError(f"modal source {modal_source!r} lacks {missing}")
    result = {}
    for name in FEATURES:
        values = [float(src[name]) for src in references.values() if name in src]
        result[name] = (min(values), float(modal[name]), max(values))
    return result
