"""MUBOCO-PR's stiffnesses identified from the FE reference (examples/gear_fe_identify.toml).

The measured outputs are the STE features of gear-pair-fe, modal value the default FE
model, support the variants of its 2D idealisation (docs/gears.md, "FE reference").
Slow: the FE variants and the identification (about 4400 MUBOCO-PR runs) take a minute.
"""

import itertools
import runpy
import warnings
from pathlib import Path

import numpy as np
import pytest

from fuzzymbs.fuzzy.inverse import InverseWarning, inverse
from fuzzymbs.models.gears import MubocoPR, make_pair
from fuzzymbs.models.gears.fe_model import GearPairFE
from fuzzymbs.models.gears.features import FEATURES
from fuzzymbs.study.inverse_file import load_identification_file

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("module_fe_cache")]


@pytest.fixture(scope="module")
def definition():
    return load_identification_file(EXAMPLES / "gear_fe_identify.toml")


def test_example_measures_the_fe_variants(definition):
    # the file's numbers are gears_fe_identify_data.measured() to 5 significant digits
    measured = runpy.run_path(str(EXAMPLES / "gears_fe_identify_data.py"))["measured"]()
    assert list(definition.measured) == list(FEATURES)
    for name in FEATURES:
        written = definition.measured[name]
        np.testing.assert_allclose(
            [written.lower, written.modal, written.upper], measured[name], rtol=1e-4
        )


def _band(model, box):
    """Support of the STE over a box of stiffnesses (monotonic: the corners bound it)."""
    corners = np.array(list(itertools.product(*box)))
    names = ("pinion_tooth_stiffness", "wheel_tooth_stiffness", "contact_stiffness")
    ste = model(dict(zip(names, corners.T, strict=True)))["ste"]
    return ste.min(axis=0), ste.max(axis=0)


def test_identified_spreads_against_the_assumed_ones(definition):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = inverse(
            definition.model,
            definition.measured,
            definition.modal,
            bounds=definition.bounds,
            **definition.options,
        )
    assert any(issubclass(w.category, InverseWarning) for w in caught)
    # four features, three stiffnesses: the FE shape is not reproduced exactly
    assert not result.converged and result.max_residual > 0.3
    # best fit (docs/gears.md): a softer pinion than wheel, a contact stiffer than the
    # Weber-Banaschek secant (8.82e8 N/m); the variants soften the teeth by 10-16 %
    # and leave the contact stiffness (nearly) crisp
    modal = result.modal
    assert modal["pinion_tooth_stiffness"] < modal["wheel_tooth_stiffness"]
    assert modal["contact_stiffness"] > 1.2 * 8.824e8
    box = []
    for name in ("pinion_tooth_stiffness", "wheel_tooth_stiffness", "contact_stiffness"):
        low, high = result.parameters[name].alpha_cut(0.0)
        box.append((low, high))
        if name != "contact_stiffness":
            assert 0.08 < (high - low) / high < 0.2
    assert (box[2][1] - box[2][0]) / box[2][1] < 0.01
    pair = make_pair()
    muboco = MubocoPR(pair, positions=60, reference=False)
    fe_default = GearPairFE(pair, positions=60)({})["ste"][0]
    fe_soft = GearPairFE(pair, positions=60, analysis="plane-stress", support="tangential")({})[
        "ste"
    ][0]
    k_t, k_con = 14732.9, 8.82418e8
    assumed = [(0.8 * k_t, 1.2 * k_t), (0.8 * k_t, 1.2 * k_t), (0.7 * k_con, 1.3 * k_con)]
    for box_, (cover_default, cover_soft) in ((box, (0.9, 0.5)), (assumed, (1.0, 1.0))):
        lower, upper = _band(muboco, box_)
        inside_default = np.mean((fe_default >= lower) & (fe_default <= upper))
        inside_soft = np.mean((fe_soft >= lower) & (fe_soft <= upper))
        if box_ is box:  # identified: covers the default FE curve, not the soft variant
            assert inside_default >= cover_default and inside_soft < cover_soft
        else:  # assumed: covers both everywhere
            assert inside_default == cover_default and inside_soft == cover_soft
