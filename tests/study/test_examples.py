"""The user-facing examples run and give the closed-form answers."""

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

from fuzzymbs.study.pipeline import run_study_file

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_cantilever_user_model_study(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))
    written = run_study_file(
        EXAMPLES / "cantilever.toml", tmp_path, progress=False, plots=False, allow_code=True
    )
    ds = written.result.dataset
    # delta = F L^3 / (3 E I) is increasing in F and decreasing in E, so the reduced
    # method is exact: lower = F_lo / (3 E_hi I), upper = F_hi / (3 E_lo I) (rtol 1e-13)
    mu = ds["level"].values
    force_lo, force_hi = 100.0 * (0.8 + 0.2 * mu), 100.0 * (1.2 - 0.2 * mu)
    modulus_lo, modulus_hi = 190e9 + 15e9 * mu, 220e9 - 5e9 * mu
    inertia = 1e-8
    np.testing.assert_allclose(
        ds["tip_deflection_lower"].values, force_lo / (3 * modulus_hi * inertia), rtol=1e-13
    )
    np.testing.assert_allclose(
        ds["tip_deflection_upper"].values, force_hi / (3 * modulus_lo * inertia), rtol=1e-13
    )
    assert written.result.dataset["tip_deflection_lower"].attrs["units"] == "m"


def test_oscillator_study_file_is_valid(tmp_path):
    from fuzzymbs.study.studyfile import load_study_file

    definition = load_study_file(EXAMPLES / "oscillator.toml")
    assert definition.executor == "processes:2"
    assert definition.study.plan.names == ("mass", "stiffness", "damping")


@pytest.mark.slow
def test_study_api_script(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", ["study_api.py"])
    runpy.run_path(str(EXAMPLES / "study_api.py"), run_name="__main__")
    assert (tmp_path / "study-api-out" / "oscillator.nc").exists()


@pytest.mark.parametrize("n", [1, 2])
def test_paper_brake_studies_are_the_demo_studies_with_rk4_at_1us(n):
    from importlib import resources

    from fuzzymbs.study.studyfile import load_study_file

    demo_dir = resources.files("fuzzymbs.demos") / "brake"
    demo = load_study_file(Path(str(demo_dir / f"0{n}-study{n}.toml"))).study
    paper = load_study_file(EXAMPLES / f"brake_study{n}_paper.toml").study
    # the same fuzzy parameters and levels; the demo refines adaptively, the paper's
    # setting is the reduced method (33 runs) with RK4 at 1 us
    assert paper.plan.names == demo.plan.names
    np.testing.assert_array_equal(paper.plan.levels, demo.plan.levels)
    for name in demo.plan.names:
        assert paper.plan.parameters[name] == demo.plan.parameters[name]
    assert demo.plan.method == "adaptive" and paper.plan.method == "reduced"
    assert len(paper.plan) == 33
    assert demo.model.simulation.settings["integrator"] == "ros34pw2"
    assert demo.model.simulation.tolerance.rtol == 1e-2
    assert paper.model.simulation.settings["integrator"] == "rk4"
    assert paper.model.simulation.settings["dt"] == 1e-6
    # 1 us lies outside RK4's stability region of the brake linearised at steady
    # sliding (limit about 0.31 us at the modal point, docs/brake.md)
    assert not paper.model.step_stability().stable.any()


@pytest.mark.parametrize(
    "name, parameters",
    [
        ("spin_up_beam.toml", ("spin_speed", "youngs_modulus")),
        ("slider_crank.toml", ("youngs_modulus", "rod_height", "slider_mass")),
    ],
)
def test_mechanism_study_files_are_valid(name, parameters):
    # the study files of the registered mechanisms load: their model, fuzzy parameters and
    # outputs exist (building the model compiles nothing; running them is in the slow suite)
    from fuzzymbs.study.studyfile import load_study_file

    definition = load_study_file(EXAMPLES / name)
    assert definition.study.plan.names == parameters
