"""The flexible slider-crank against a second code: Exudyn, on the same mechanism.

The registered ``slider-crank`` (a floating frame on the rod's chord with 6 pinned-pinned
modes and foreshortening) and Exudyn's geometrically exact ANCF cable elements (8 of them,
generalized-alpha at 20 us), built by ``benchmarks/slider_crank_exudyn.py`` -- the model
the speed benchmark times, whose docstring gives both codes' convergence. Where both models
are the same (a steel rod of Euler-Bernoulli kinematics without rotary inertia, the same
crank spin-up and slider) they agree to the difference of their beam theories: measured
over 0-100 ms at 64 samples, 1.1e-3 of the midpoint deflection's peak and 2.7e-6 m on the
slider position (docs/benchmarks.md, "Mechanisms").
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzymbs.models.mechanisms.slider_crank import slider_crank

pytest.importorskip("exudyn")
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
from slider_crank_exudyn import exudyn_slider_crank

# slow: the planar kernels take about 25 s to compile; CI runs these with -m slow
pytestmark = pytest.mark.slow


@pytest.mark.parametrize(
    "sample",
    [{}, {"youngs_modulus": 1.9e11, "rod_height": 0.00588, "slider_mass": 0.11}],
    ids=["nominal", "corner"],
)
def test_slider_crank_agrees_with_exudyns_ancf_rod(sample):
    model = slider_crank()
    ours = model({k: np.array([v]) for k, v in sample.items()})
    assert not ours["failed"].any()
    theirs, _ = exudyn_slider_crank(model.sample_parameters(sample)[0], model.times)
    deflection = ours["midpoint_deflection"][0]
    peak = np.abs(theirs["midpoint_deflection"]).max()
    assert peak > 1e-3  # the rod really bends (2.8e-3 m and 3.2e-3 m here)
    # measured 8.4e-4 and 1.1e-3 of the peak: the models' beam theories differ by that
    np.testing.assert_allclose(deflection, theirs["midpoint_deflection"], atol=2e-3 * peak)
    # measured 2.3e-6 m and 2.7e-6 m: fuzzymbs's one axial mode against the exact axial strain
    np.testing.assert_allclose(ours["slider_position"][0], theirs["slider_position"], atol=5e-6)
