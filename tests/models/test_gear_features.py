"""STE features of the gear pair: closed forms, documented values, monotonicity, fuzzy spread."""

import itertools
import math
import pickle

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.gears import iso_pair_stiffness, make_pair
from fuzzymbs.models.gears.features import (
    DEFAULT_MARGIN,
    FEATURES,
    SteFeatureModel,
    contact_zones,
    reference_feature_spread,
    reference_features,
    ste_features,
)
from fuzzymbs.study.registry import get_model

UM = 1e-6
STIFFNESSES = ("pinion_tooth_stiffness", "wheel_tooth_stiffness", "contact_stiffness")


@pytest.fixture(scope="module")
def pair():
    return make_pair()  # z 20/40, m 4.5 mm, b 20 mm, steel; eps_alpha = 1.635


@pytest.fixture(scope="module")
def model():
    return SteFeatureModel(torque=100.0)


@pytest.fixture(scope="module")
def references(pair):
    return reference_features(pair, 100.0)


@pytest.fixture(scope="module")
def modal(model):
    kt = model.base.identified.tooth_stiffness
    return np.array([kt, kt, model.base.identified.contact_stiffness])


def evaluate(model, stiffness):
    """Features (F, B) for stiffness rows (B, 3) in STIFFNESSES order."""
    stiffness = np.atleast_2d(stiffness)
    out = model({name: stiffness[:, i] for i, name in enumerate(STIFFNESSES)})
    assert not out["failed"].any()
    return np.stack([out[name] for name in FEATURES])


# ---- zones and features of a synthetic STE (closed form) ---------------------------------


def test_zones_follow_the_contact_ratio_with_the_margin(pair):
    eps = pair.contact_ratio
    positions = np.arange(100) / 100
    single, double = contact_zones(pair, positions, margin=0.08)
    # double contact on [0, eps - 1], single on (eps - 1, 1) (potential_energy.contact_positions)
    assert np.all(positions[double] >= 0.08 - 1e-12)
    assert np.all(positions[double] <= eps - 1 - 0.08 + 1e-12)
    assert np.all(positions[single] >= eps - 1 + 0.08 - 1e-12)
    assert np.all(positions[single] <= 1 - 0.08 + 1e-12)
    # counts by hand for eps = 1.63519: double k = 8..55, single k = 72..92
    assert double.sum() == 48 and single.sum() == 21
    assert not np.any(single & double)
    with pytest.raises(InvalidParameterError, match="margin"):
        contact_zones(pair, positions, margin=0.3)
    with pytest.raises(InvalidParameterError, match="more positions"):
        contact_zones(pair, np.array([0.1, 0.2]), margin=0.08)


def test_features_of_a_step_with_a_ramp_match_the_closed_form(pair):
    # STE = a on the double-contact zone [0, eps-1], b on the single zone, plus g*pos.
    # Continuous-period closed forms (integrals of the piecewise-linear profile):
    #   mean = a (eps-1) + b (2-eps) + g/2;  peak-to-peak = b + g - a (g > 0, b > a);
    #   single = b + g * eps/2 (zone centre); double = a + g * (eps-1)/2.
    # Discrete sampling at P positions errs by O((b - a + g)/P): rtol 1e-3 at P = 4000.
    eps = pair.contact_ratio
    a, b, g = 5.0 * UM, 9.0 * UM, 0.4 * UM
    positions = np.arange(4000) / 4000
    step = np.where(positions <= eps - 1, a, b) + g * positions
    single, double = contact_zones(pair, positions, DEFAULT_MARGIN)
    got = ste_features(step, single, double)
    expected = {
        "ste_mean": a * (eps - 1) + b * (2 - eps) + g / 2,
        "ste_peak_to_peak": b + g - a,
        "ste_single": b + g * eps / 2,
        "ste_double": a + g * (eps - 1) / 2,
    }
    for name in FEATURES:
        assert got[name].shape == ()
        assert float(got[name]) == pytest.approx(expected[name], rel=1e-3), name
    # a batch: the rows are independent; NaN stays in its row
    batch = np.stack([step, 2 * step, np.full_like(step, np.nan)])
    rows = ste_features(batch, single, double)
    for name in FEATURES:
        assert rows[name][1] == pytest.approx(2 * float(got[name]), rel=1e-12)
        assert np.isnan(rows[name][2])


def test_ste_features_refuses_bad_masks():
    ste = np.ones((2, 10))
    single = np.zeros(10, dtype=bool)
    single[6:9] = True
    with pytest.raises(InvalidParameterError, match="positions"):
        ste_features(np.ones((2, 9)), single)
    with pytest.raises(InvalidParameterError, match="both"):
        ste_features(ste, single, np.ones(10, dtype=bool))
    with pytest.raises(InvalidParameterError, match="empty"):
        ste_features(ste, np.zeros(10, dtype=bool))


def test_margin_keeps_the_extended_contact_out_of_the_zones(model, modal):
    # The rigid-kinematics zones must not contain MUBOCO-PR's tip-corner contact (pair
    # kinds 2, 3), else ste_single would average the rounded steps; checked at the
    # modal values and the 8 corners of a +-30 % box on the three stiffnesses.
    factors = np.array([[1.0, 1.0, 1.0], *itertools.product([0.7, 1.3], repeat=3)])
    stiffness = modal * factors
    solved = model.base.solve({name: stiffness[:, i] for i, name in enumerate(STIFFNESSES)})
    tip_corner = (solved["pair_kind"] >= 2).any(axis=2)  # (B, P)
    assert not tip_corner[:, model.single | model.double].any()
    # ... and the margin is needed: 5 % would let it in at the softest corner
    soft_single, _ = contact_zones(model.base.pair, model.base.positions, margin=0.05)
    assert tip_corner[:, soft_single].any()


# ---- the feature model -----------------------------------------------------------------


def test_feature_model_declares_the_gear_pair_parameters(model):
    assert model.parameters == get_model("gear-pair").parameters
    assert model.outputs == dict.fromkeys(FEATURES, "m")
    assert model.output_dims == {name: () for name in FEATURES} and model.coords == {}
    assert set(model.reference) == set(FEATURES)
    out = model({"tooth_stiffness": [1.5e4, 2.0e4]})
    assert all(out[name].shape == (2,) for name in FEATURES)
    clone = pickle.loads(pickle.dumps(model))
    assert clone.identity() == model.identity()
    assert SteFeatureModel(margin=0.06).identity() != model.identity()
    with pytest.raises(InvalidParameterError, match="count"):
        SteFeatureModel(positions=np.linspace(0, 0.9, 10))
    with pytest.raises(InvalidParameterError, match="unknown gear-pair option"):
        SteFeatureModel(teeth=20)


def test_feature_model_passes_failures_through(model):
    # a contact stiffness so low that the teeth would pass through each other
    out = model({"contact_stiffness": [8e8, 1e2]})
    assert out["failed"].tolist() == [False, True]
    assert out["failure_reason"][1] != ""
    for name in FEATURES:
        assert np.isfinite(out[name][0]) and np.isnan(out[name][1])


def test_modal_sample_reproduces_the_model_source(model, references):
    out = model({})
    for name in FEATURES:
        assert float(out[name][0]) == pytest.approx(references["model"][name], rel=1e-12)


# ---- documented values (docs/gears.md, "Validation" and "Comparison of the curves") ---------


def test_features_agree_with_the_documented_values(pair):
    # docs/gears.md (T1 = 100 N m, 100 positions, identified modal values): mean STE
    # MUBOCO-PR 6.38 um, PE 6.96 um, ISO F/(c_gamma_alpha b) 6.31 um; peak-to-peak
    # 3.6 um (PE 4.4 um). Tolerance: half a unit of the last quoted digit.
    refs = reference_features(pair, 100.0, positions=100)
    assert refs["model"]["ste_mean"] / UM == pytest.approx(6.38, abs=0.005)
    assert refs["potential_energy"]["ste_mean"] / UM == pytest.approx(6.96, abs=0.005)
    assert refs["iso6336"]["ste_mean"] / UM == pytest.approx(6.31, abs=0.005)
    assert refs["model"]["ste_peak_to_peak"] / UM == pytest.approx(3.6, abs=0.05)
    assert refs["potential_energy"]["ste_peak_to_peak"] / UM == pytest.approx(4.4, abs=0.05)
    # "In the double-contact zone MUBOCO-PR and PE agree within 2 %; in the
    # single-contact zone the hinge model is about 10 % stiffer"
    double = refs["potential_energy"]["ste_double"] / refs["model"]["ste_double"] - 1
    single = refs["potential_energy"]["ste_single"] / refs["model"]["ste_single"] - 1
    assert abs(double) < 0.02
    assert 0.08 < single < 0.13


def test_iso_features_from_the_documented_stiffness(pair, references):
    # docs/gears.md: ISO gives c' = 12.69, c_gamma_alpha = 18.74 N/(mm um) for this pair;
    # F = T1 / r_b1 = 100 / (0.045 cos 20 deg) N, b = 20 mm (4 digits quoted: rtol 5e-4).
    force = 100.0 / (0.045 * math.cos(math.radians(20.0)))
    iso = references["iso6336"]
    assert set(iso) == {"ste_mean", "ste_single"}
    assert iso["ste_single"] / UM == pytest.approx(force / (12.69 * 20.0), rel=5e-4)
    assert iso["ste_mean"] / UM == pytest.approx(force / (18.74 * 20.0), rel=5e-4)
    stiffness = iso_pair_stiffness(pair, 100.0)
    assert iso["ste_single"] / iso["ste_mean"] == pytest.approx(
        stiffness.mesh / stiffness.single, rel=1e-12
    )


# ---- monotonicity ------------------------------------------------------------------------


def test_features_fall_when_a_stiffness_rises(model, modal):
    # Finite differences (+-2 % in ln k) at the modal values and on a 3 x 3 x 3 grid of a
    # +-30 % box: mean, single and double STE fall with every stiffness everywhere;
    # the peak-to-peak value falls with the contact stiffness everywhere and with both
    # tooth stiffnesses at the modal values, but not with one gear's tooth stiffness
    # where the other gear's teeth are much softer (its maximum and minimum move
    # together there): there the gain changes sign.
    h = 0.02
    centres = np.log(modal) + np.log(np.array(list(itertools.product([0.7, 1.0, 1.3], repeat=3))))
    rows = []
    for centre in centres:
        rows += [centre + h * e for e in np.eye(3)] + [centre - h * e for e in np.eye(3)]
    features = np.log(evaluate(model, np.exp(np.array(rows)))).reshape(4, len(centres), 2, 3)
    gain = (features[:, :, 0, :] - features[:, :, 1, :]) / (2 * h)  # (F, C, stiffness)
    mean, p2p, single, double = gain
    assert np.all(mean < -0.1) and np.all(single < -0.1) and np.all(double < -0.1)
    assert np.all(p2p[:, 2] < -0.1)
    at_modal = p2p[13]  # the centre of the grid
    assert np.all(at_modal < -0.03)
    stiff_pinion_soft_wheel = 2 * 9 + 0 * 3 + 1  # factors (1.3, 0.7, 1.0)
    assert p2p[stiff_pinion_soft_wheel, 0] > 0.0


def test_feature_gains_at_the_modal_values(model, modal):
    # d ln feature / d ln k at the modal values (central differences, +-1 %); the rows of
    # ste_mean sum to about -1 (STE ~ compliance, linear contact; the extended contact
    # makes it slightly less). Measured values to 0.02 (for the report / docs table).
    h = 0.01
    rows = [np.log(modal) + s * h * e for e in np.eye(3) for s in (1, -1)]
    features = np.log(evaluate(model, np.exp(np.array(rows)))).reshape(4, 3, 2)
    gain = (features[:, :, 0] - features[:, :, 1]) / (2 * h)
    expected = np.array(
        [
            [-0.365, -0.348, -0.273],  # ste_mean
            [-0.072, -0.555, -0.372],  # ste_peak_to_peak
            [-0.332, -0.357, -0.311],  # ste_single
            [-0.394, -0.352, -0.254],  # ste_double
        ]
    )
    np.testing.assert_allclose(gain, expected, atol=0.02)
    assert gain[0].sum() == pytest.approx(-1.0, abs=0.03)
    # three stiffnesses from four features: rank 3, but poorly conditioned
    singular = np.linalg.svd(gain, compute_uv=False)
    assert singular[-1] > 0.02 and singular[0] / singular[-1] > 20


# ---- fuzzy reference features ------------------------------------------------------------


def test_fuzzy_features_span_all_sources(pair, references):
    spread = reference_feature_spread(references=references)
    assert list(spread) == list(FEATURES)
    for name, (lower, modal, upper) in spread.items():
        assert modal == references["model"][name]
        values = [src[name] for src in references.values() if name in src]
        assert lower == min(values) and upper == max(values)
        assert lower <= modal <= upper
    # plain numbers (a model imports no part of the fuzzy engine), fuzzy numbers on demand
    assert all(type(value) is float for triple in spread.values() for value in triple)
    numbers = triangular_numbers(spread)
    assert [numbers[name].support for name in FEATURES] == [
        (spread[name][0], spread[name][2]) for name in FEATURES
    ]
    # two sources give the mean and the single-zone level, three give the mean
    assert spread["ste_mean"][0] == references["iso6336"]["ste_mean"]
    assert spread["ste_mean"][2] == references["potential_energy"]["ste_mean"]
    # computing from the pair gives the same numbers
    assert reference_feature_spread(pair, 100.0) == spread
    with pytest.raises(InvalidParameterError, match="lacks"):
        reference_feature_spread(references=references, modal_source="iso6336")
    with pytest.raises(InvalidParameterError, match="not a source"):
        reference_feature_spread(references=references, modal_source="fe")
