"""The adaptive method's global certificate (``certify="global"``) against the truth of
random models where the default certificate of the bounds misses a feature."""

import warnings

import numpy as np
import pytest

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy import plan
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.methods.adaptive import Adaptive
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.random_models import random_case
from fuzzymbs.models.closed_form.resonance import polished_truth

LEVELS = np.linspace(0.0, 1.0, 6)
# polished_truth: a dense grid polished by L-BFGS-B (the optimiser's tolerance, far below
# 0.1 % of the cut width), so a miss within the 1 % tolerance is at most 0.011
TOLERANCE = 0.011


def _certified(case, certify: str):
    method = Adaptive(max_runs=8000, certify=certify)
    scheme = plan(triangular_numbers(case.triangles), method=method, levels=LEVELS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cuts = scheme.retransform(scheme.evaluate(case.model))
    truth = polished_truth(case, LEVELS)
    miss = max(band_miss(c.lower, c.upper, *truth[k]) for k, c in cuts.items())
    return scheme.outcome(), miss


def test_the_global_certificate_finds_a_corner_flank_the_bounds_certificate_misses():
    # random_case(8, 4, 1) (benchmarks/random_honesty.py): the support level's minimum lies
    # on an edge near the corner (-1, -1, 1, -1) of the unit box, 0.7 from every run of the
    # default rounds, where their surrogate is 30 % of the cut width too high and predicts
    # no extremum: said converged in 130 runs with 25 % missed. The global certificate
    # sees the surrogate's error at an exploration run there: 208 runs, 0.00 % (docs/fuzzy.md,
    # "Models it was never tuned on")
    case = random_case(8, 4, 1)
    bounds, bounds_miss = _certified(case, "bounds")
    assert bounds.converged and bounds.error <= 0.01 and bounds_miss > 0.2  # the hole
    outcome, miss = _certified(case, "global")
    assert outcome.converged and outcome.error <= 0.01
    assert miss <= TOLERANCE
    assert outcome.runs > bounds.runs


def test_a_confirmation_without_face_or_local_candidates_finishes():
    # random_case(23, 2, 1): at its confirmation no extremum had a face point or local
    # probe, and the near ties' step took the argmin of an empty array (a crash); now
    # 23 runs, within the tolerance
    outcome, miss = _certified(random_case(23, 2, 1), "bounds")
    assert outcome.converged and miss <= TOLERANCE


def test_certify_is_checked_and_kept_out_of_a_default_plans_fingerprint():
    assert "certify" not in Adaptive().describe()  # stores of earlier studies stay valid
    assert Adaptive(certify="global").describe()["certify"] == "global"
    with pytest.raises(InvalidPlanError, match='certify must be "bounds" or "global"'):
        Adaptive(certify="everywhere")
    from fuzzymbs.fuzzy.adaptive import AdaptiveTransformation

    numbers = triangular_numbers(random_case(1, 2, 1).triangles)
    with pytest.raises(ValueError, match="certify must be"):
        AdaptiveTransformation(numbers, LEVELS, 0.01, 100, 400, certify="everywhere")


def test_a_study_file_and_the_command_line_set_the_certificate(tmp_path):
    from fuzzymbs.study.studyfile import StudyFileError, load_study_file

    path = tmp_path / "study.toml"
    path.write_text(
        '[study]\nmethod = "adaptive"\nlevels = 2\ncertify = "global"\n'
        '[model]\nname = "sdof-resonance"\n'
        '[parameters.stiffness]\ntype = "triangular"\nlower = 900.0\nmodal = 1000.0\n'
        "upper = 1100.0\n"
    )
    assert load_study_file(path).study.plan.scheme.certify == "global"
    loaded = load_study_file(path, study_options={"certify": "bounds"})  # --option
    assert loaded.study.plan.scheme.certify == "bounds"
    with pytest.raises(StudyFileError, match="certify"):
        load_study_file(path, study_options={"certify": "everywhere"})


def test_the_result_and_its_summary_say_which_certificate():
    from fuzzymbs import Study, Triangular

    def model(samples):
        return {"z": samples["a"] * samples["b"] + 0.1 * samples["a"] ** 2}

    numbers = {"a": Triangular(1.0, 2.0, 3.0), "b": Triangular(-1.0, 0.0, 1.0)}
    for certify, phrase in (("bounds", "certified method error"), ("global", "certified (global")):
        study = Study(model, numbers, method="adaptive", levels=2, certify=certify)
        result = study.run(progress=False)
        assert result.dataset.attrs["adaptive_certify"] == certify
        assert phrase in result.summary()
