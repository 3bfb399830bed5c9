"""The time a demo announces before it runs, and the progress lines of a study's checks."""

import json
import math
from importlib import resources

import pytest

from fuzzymbs.study import pipeline
from fuzzymbs.study.execution import progress_phase


def test_brake_demo_estimate_scales_the_recorded_time_by_the_sample_step_cost(monkeypatch):
    recorded = json.loads(
        (resources.files("fuzzymbs") / "demos" / "brake" / pipeline.DEMO_TIMING_FILE).read_text()
    )
    assert recorded["calibration"] in pipeline.CALIBRATIONS
    # a machine whose sample-step costs 1.5 times the recorded one takes 1.5 times as long
    slower = 1.5 * recorded["sample_step_seconds"]
    monkeypatch.setitem(pipeline.CALIBRATIONS, recorded["calibration"], lambda: slower)
    estimate = pipeline.demo_estimate("brake")
    assert estimate.seconds == pytest.approx(1.5 * recorded["seconds"], rel=1e-12)
    assert estimate.recorded_seconds == recorded["seconds"]
    text = estimate.describe()
    minutes, seconds = divmod(round(1.5 * recorded["seconds"]), 60)
    assert text.startswith(f"about {minutes} min {seconds} s on this machine")
    assert f"{slower * 1e6:.3g} us" in text


def test_demos_without_a_recorded_time_announce_nothing():
    assert pipeline.demo_has_timing("brake") and not pipeline.demo_has_timing("quickstart")
    assert pipeline.demo_estimate("quickstart") is None
    assert pipeline.demo_estimate("no-such-demo") is None


def test_the_brake_calibration_counts_the_steps_it_times():
    from fuzzymbs.models.brake.calibration import seconds_per_sample_step

    # a short stretch: a positive, finite cost per sample-step (its size is the
    # machine's: never asserted); a run that took no step would divide by zero
    cost = seconds_per_sample_step(t_end=2e-5, repeat=1)
    assert math.isfinite(cost) and cost > 0


def test_progress_phase_shows_its_label_and_is_silent_when_disabled(capsys):
    with progress_phase(False, "hidden phase", 3):
        pass
    assert "hidden phase" not in capsys.readouterr().err
    with progress_phase(True, "pilot runs", 3):
        pass
    assert "pilot runs" in capsys.readouterr().err
