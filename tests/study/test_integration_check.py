"""Every time-integrated study reports its own time-integration error."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError, StudyFileError
from fuzzymbs.mbs.bodies import FixedBody
from fuzzymbs.mbs.integrate import SimulationModel
from fuzzymbs.mbs.lumped import lumped_modal_body
from fuzzymbs.mbs.system import Coordinate, System
from fuzzymbs.study.integration_check import (
    TimeIntegrationWarning,
    check_time_integration,
    peak_relative_deviation,
)
from fuzzymbs.study.study import Study
from fuzzymbs.study.studyfile import load_study_file
from fuzzymbs.study.summary import summarize

TIME = np.linspace(0.0, 1.0, 51)


class Decay:
    """y = a exp(-t) with a known integration error ``error * sin(pi t)`` (the tightened
    model: a tenth of it), like an error-controlled integrator whose global error scales
    with its tolerance."""

    time_integration = "closed form with a made-up error"

    def __init__(self, error: float, fail_tight: bool = False) -> None:
        self.outputs = {"y": "m"}
        self.coords = {"time": TIME}
        self.output_dims = {"y": ("time",)}
        self.error = error
        self.fail_tight = fail_tight

    def __call__(self, samples):
        a = np.asarray(samples["a"], dtype=float)[:, None]
        y = a * np.exp(-TIME) + self.error * np.sin(np.pi * TIME)
        failed = np.zeros(a.shape[0], dtype=bool)
        if self.fail_tight and self.error < 0.01:
            failed[:] = True
            y[:] = np.nan
        return {"y": y, "failed": failed, "failure_reason": np.where(failed, "diverged", "")}

    def tightened(self) -> Decay:
        return Decay(self.error / 10, self.fail_tight)


def study(model, tolerance: float = 0.005) -> Study:
    fuzzy = {"a": {"type": "triangular", "modal": 2.0, "spread": 0.1}}
    return Study(model, fuzzy, levels=2, integration_tolerance=tolerance)


def test_study_stores_and_summarises_the_modal_samples_deviation():
    # closed form: the modal sample (a = 2, peak 2 at t = 0) and its tightened re-run differ
    # by 0.9 * error * sin(pi t), at most 0.9 * 0.004 = 0.0036, i.e. 0.18 % of the peak
    with warnings.catch_warnings():
        warnings.simplefilter("error", TimeIntegrationWarning)
        result = study(Decay(0.004)).run(progress=False)
    attrs = result.dataset.attrs
    assert attrs["time_integration_error"] == pytest.approx(0.9 * 0.004 / 2.0, rel=1e-12)
    assert attrs["time_integration_tolerance"] == 0.005
    assert attrs["time_integration"] == "closed form with a made-up error"
    text = summarize(result.dataset)
    assert "Time integration: closed form with a made-up error; error 0.18 % of the peak" in text
    assert "within the study's tolerance 0.5 %" in text


def test_error_above_the_tolerance_warns_and_is_marked():
    # 0.9 * 0.02 / 2 = 0.9 % > 0.5 %
    with pytest.warns(TimeIntegrationWarning, match="exceeds the study's tolerance"):
        result = study(Decay(0.02)).run(progress=False)
    assert result.dataset.attrs["time_integration_error"] == pytest.approx(0.009, rel=1e-12)
    assert "EXCEEDS the study's tolerance 0.5 %" in summarize(result.dataset)
    # the same study with a tolerance of 1 % accepts it silently
    with warnings.catch_warnings():
        warnings.simplefilter("error", TimeIntegrationWarning)
        study(Decay(0.02), tolerance=0.01).run(progress=False)


def test_failed_tightened_run_is_reported_not_hidden():
    with pytest.warns(TimeIntegrationWarning, match="not checked"):
        result = study(Decay(0.02, fail_tight=True)).run(progress=False)
    assert np.isnan(result.dataset.attrs["time_integration_error"])
    assert "diverged" in result.dataset.attrs["time_integration_note"]
    assert "NOT CHECKED" in summarize(result.dataset)


def test_models_without_time_integration_leave_it_out():
    def static(samples):
        return {"y": 3.0 * np.asarray(samples["a"])}

    result = Study(static, {"a": {"type": "triangular", "modal": 1.0, "spread": 0.1}}).run(
        progress=False
    )
    assert "time_integration_error" not in result.dataset.attrs
    assert "Time integration" not in summarize(result.dataset)


def test_bad_tolerance_is_rejected(tmp_path):
    with pytest.raises(InvalidParameterError, match="integration_tolerance"):
        study(Decay(0.0), tolerance=0.0)
    path = tmp_path / "bad.toml"
    path.write_text(
        '[study]\nintegration_tolerance = -1.0\n[model]\nname = "oscillator"\n'
        '[parameters.stiffness]\ntype = "triangular"\nmodal = 1.0\nspread = 0.1\n'
    )
    with pytest.raises(StudyFileError, match="integration_tolerance"):
        load_study_file(path)


def oscillator_model(**settings) -> SimulationModel:
    """One mode, omega = 100 rad/s, damping ratio 0.05, q(0) = 1 mm."""
    body = lumped_modal_body("osc", [(0, 0, 0)], [1.0], np.diag([1e4, 0, 0]), free_dofs=[0])
    system = System()
    system.add_body(FixedBody(body, damping_ratio=0.05))
    return SimulationModel(
        system,
        t_end=0.2,
        outputs={"q": Coordinate("osc")},
        record_interval=1e-3,
        initial_state=np.array([1e-3, 0.0]),
        **settings,
    )


@pytest.mark.parametrize(
    "settings", [{"dt": 1e-3, "integrator": "ros34pw2", "rtol": 1e-4}, {"dt": 1e-3}]
)
def test_the_check_estimates_the_true_error_of_the_engine(settings):
    # reference: the free decay's closed form q0 e^(-zeta w t) (cos w_d t + zeta /
    # sqrt(1 - zeta^2) sin w_d t). The tightened run's own error is a tenth (ROS34PW2,
    # error ~ rtol) or a sixteenth (RK4, error ~ dt^4) of the default's, so the check
    # lands within 0.5 ... 1.5 times the true error (measured: 0.80 and 0.94 times)
    model = oscillator_model(**settings)
    w, z = 100.0, 0.05
    wd = w * np.sqrt(1 - z**2)
    t = model.coords["time"]
    exact = 1e-3 * np.exp(-z * w * t) * (np.cos(wd * t) + z / np.sqrt(1 - z**2) * np.sin(wd * t))
    own = model({})["q"][0]
    true_error = peak_relative_deviation(own, exact)
    check = check_time_integration(model, {}, {"q": own}, ["q"], tolerance=1.0)
    assert check is not None and check.note == ""
    assert 0.5 * true_error < check.error < 1.5 * true_error
    assert true_error > 1e-9  # a real error to estimate, not rounding
