"""The headline large study (examples/gear_tolerances_117649.toml).

Its full run (117,649 MUBOCO-PR runs, about 80 s on 2 cores) is measured in
docs/benchmarks.md; here: the file gives exactly 7^6 runs (the closed form of the
full alpha-bound grid, (2m + 1)^n with m = 3, n = 6, docs/theory.md), and the same
study on its mu = 0 and mu = 1 cuts only (3^6 = 729 runs: the support-box corners and
edges, where a tolerance combination would jam or break the pair) completes without
a failed run and with influence measures for every parameter.
"""

from pathlib import Path

import numpy as np

from fuzzymbs import Study
from fuzzymbs.study.studyfile import load_study_file

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gear_tolerances_117649.toml"


def test_the_file_plans_117649_runs():
    definition = load_study_file(EXAMPLE)  # registered model: no --allow-code
    study = definition.study
    assert len(study.plan) == 7**6 == 117_649
    assert study.plan.method == "grid" and len(study.plan.names) == 6


def test_support_corners_run_and_give_influence_measures():
    study = load_study_file(EXAMPLE).study
    small = Study(
        "gear-pair",
        {name: study.plan.parameters[name] for name in study.plan.names},
        "grid",
        1,  # mu = 0 and 1: 3^6 = 729 runs, the support corners and edges and the core
        ["ste"],
        model_options=study.model_options,
        validation_runs=0,
    )
    result = small.run(progress=False, chunk_size=256).dataset
    assert result.sizes["sample"] == 729 and not result["sample_failed"].values.any()
    assert result.attrs["status"] == "complete"
    gain = result["ste_gain"].values[:, 0]  # (parameter, position) at mu = 0
    assert np.isfinite(gain).all()
    # every tolerance moves the STE somewhere over the mesh period
    assert (np.abs(gain).max(axis=1) > 0).all()
