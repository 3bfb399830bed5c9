"""Plots: files are written and non-empty; drawn data equal the result's cuts."""

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.plot import (
    plot_fuzzy_signal,
    plot_influence,
    plot_input_memberships,
    plot_output_membership,
    write_plots,
)
from fuzzymbs.study.study import Study


@pytest.fixture(scope="module")
def oscillator():
    study = Study(
        "damped-oscillator",
        {"mass": Triangular.relative(1.0, 0.05), "stiffness": Triangular.relative(1000.0, 0.1)},
        method="reduced",
        levels=3,
        model_options={"time_steps": 51, "duration": 0.3},
        name="osc",
    )
    return study.run(progress=False).dataset


def test_write_plots_png_and_pdf(oscillator, tmp_path):
    written = write_plots(
        oscillator, tmp_path, membership=[{"output": "displacement", "coord": "time", "value": 0.1}]
    )
    names = {p.name for p in written}
    for stem in (
        "inputs_membership",
        "displacement_bands",
        "displacement_influence",
        "natural_frequency_membership",
        "natural_frequency_influence",
        "displacement_membership_time_0.1",
    ):
        assert {f"{stem}.png", f"{stem}.pdf"} <= names
    for path in written:
        head = path.read_bytes()[:8]
        assert head.startswith(b"\x89PNG" if path.suffix == ".png" else b"%PDF")
        assert path.stat().st_size > 1000


def test_bands_light_to_dark_with_nominal_and_reference(oscillator):
    figure = plot_fuzzy_signal(oscillator, "displacement")
    ax = figure.axes[0]
    bands = ax.collections
    assert len(bands) == len(oscillator["level"])  # one fill_between per alpha level
    # colour darkens with mu: the sum of RGB decreases from mu = 0 to mu = 1
    brightness = [band.get_facecolor()[0][:3].sum() for band in bands]
    assert all(b > a for a, b in zip(brightness[1:], brightness[:-1], strict=True))
    # the outermost band spans exactly the mu = 0 cut
    outer = bands[0].get_paths()[0].vertices[:, 1]
    lower = oscillator["displacement_lower"].values[0]
    upper = oscillator["displacement_upper"].values[0]
    assert outer.min() == pytest.approx(lower.min()) and outer.max() == pytest.approx(upper.max())
    labels = [line.get_label() for line in ax.get_lines()]
    assert labels == ["nominal", "reference"]


def test_membership_of_scalar_and_of_signal_at_coordinate(oscillator):
    figure = plot_output_membership(oscillator, "natural_frequency")
    x, mu = figure.axes[0].get_lines()[0].get_data()
    levels = oscillator["level"].values
    np.testing.assert_allclose(mu, np.concatenate([levels, levels[::-1]]))
    np.testing.assert_allclose(x[: len(levels)], oscillator["natural_frequency_lower"].values)
    figure = plot_output_membership(oscillator, "displacement", "time", 0.1)
    assert "time = 0.1" in figure.axes[0].get_title()
    with pytest.raises(ValueError, match="choose coord and value"):
        plot_output_membership(oscillator, "displacement")


def test_influence_and_inputs(oscillator):
    figure = plot_influence(oscillator, "natural_frequency")
    bars = figure.axes[1].patches
    np.testing.assert_allclose(
        [b.get_height() for b in bars], oscillator["natural_frequency_relative_influence"].values
    )
    figure = plot_influence(oscillator, "displacement")
    assert len(figure.axes[0].collections) == 2  # one stacked area per parameter
    figure = plot_input_memberships(oscillator)
    assert len([ax for ax in figure.axes if ax.get_visible()]) == 2


def test_partial_result_is_plotted_without_incomplete_levels(tmp_path):
    # mass support reaches -0.2 kg: samples at mu = 0 fail; at mu = 1/3 the lower cut is 0.2 kg
    study = Study(
        "damped-oscillator",
        {"mass": Triangular(-0.2, 1.0, 1.5)},
        levels=3,
        model_options={"time_steps": 21, "duration": 0.1},
    )
    dataset = study.run(progress=False, on_failure="partial").dataset
    np.testing.assert_array_equal(dataset["level_complete"].values, [False, True, True, True])
    figure = plot_fuzzy_signal(dataset, "displacement")
    assert len(figure.axes[0].collections) == 3  # the mu = 0 band is missing, not drawn as NaN
    assert "PARTIAL" in figure.axes[0].get_title()
    written = write_plots(dataset, tmp_path, formats=("png",))
    assert all(path.stat().st_size > 1000 for path in written)


def test_unknown_output_or_coordinate_is_named(oscillator):
    from fuzzymbs.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match=r"no 'velocity_lower'.*displacement"):
        plot_fuzzy_signal(oscillator, "velocity")
    with pytest.raises(InvalidParameterError, match=r"no coordinate 'position'.*time"):
        plot_output_membership(oscillator, "displacement", "position", 0.1)
    with pytest.raises(InvalidParameterError, match=r"no 'velocity_absolute_influence'"):
        plot_influence(oscillator, "velocity")
