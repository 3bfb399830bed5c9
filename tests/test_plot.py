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
        oscillator,
        tmp_path,
        membership=[{"output": "displacement", "coord": "time", "value": 0.1}],
        formats=("png", "pdf"),
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


def test_bands_light_to_dark_with_nominal_and_named_reference(oscillator):
    figure = plot_fuzzy_signal(oscillator, "displacement")
    ax = figure.axes[0]
    assert len(figure.axes) == 1  # bands wide against the signal: no extra views
    bands = ax.collections
    assert len(bands) == len(oscillator["level"])  # one fill_between per alpha level
    # colour darkens with mu: the sum of RGB decreases from mu = 0 to mu = 1
    brightness = [band.get_facecolor()[0][:3].sum() for band in bands]
    assert all(b > a for a, b in zip(brightness[1:], brightness[:-1], strict=True))
    # the outermost band spans exactly the mu = 0 cut, drawn in mm (about 10 mm of swing)
    assert ax.get_ylabel() == "displacement [mm]" and ax.get_xlabel() == "time [ms]"
    outer = bands[0].get_paths()[0].vertices[:, 1]
    lower = oscillator["displacement_lower"].values[0] * 1e3
    upper = oscillator["displacement_upper"].values[0] * 1e3
    assert outer.min() == pytest.approx(lower.min()) and outer.max() == pytest.approx(upper.max())
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    assert labels[-2:] == ["nominal", "reference: solve_ivp at the default parameters"]
    assert labels[0] == "μ = 0 (support)" and labels[-3] == "μ = 1 (core)"
    # the title is the study's description, or its name when it has none
    assert figure._suptitle.get_text() == (oscillator.attrs["description"] or "osc")


def test_membership_of_scalar_and_of_signal_at_coordinate(oscillator):
    figure = plot_output_membership(oscillator, "natural_frequency")
    x, mu = figure.axes[0].get_lines()[0].get_data()
    levels = oscillator["level"].values
    np.testing.assert_allclose(mu, np.concatenate([levels, levels[::-1]]))
    np.testing.assert_allclose(x[: len(levels)], oscillator["natural_frequency_lower"].values)
    figure = plot_output_membership(oscillator, "displacement", "time", 0.1)
    assert "time = 102 ms" in figure.axes[0].get_title()
    with pytest.raises(ValueError, match="choose coord and value"):
        plot_output_membership(oscillator, "displacement")


def test_influence_and_inputs(oscillator):
    figure = plot_influence(oscillator, "natural_frequency")
    bars = figure.axes[1].patches
    np.testing.assert_allclose(
        [b.get_width() for b in bars], oscillator["natural_frequency_relative_influence"].values
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
    assert "PARTIAL" in figure._suptitle.get_text()
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


def _narrow_ringing_dataset(size=2001, duration=0.01):
    """A synthetic result: a decaying 35 kHz ringing of 50 um about 57 um whose bands
    (up to 2 um either side) are narrow against it."""
    import xarray as xr

    t = np.linspace(0.0, duration, size)
    ringing = np.exp(-t / 1.5e-3) * np.sin(2 * np.pi * 35e3 * t)
    nominal = 57e-6 + 50e-6 * ringing
    levels = np.array([0.0, 0.5, 1.0])
    spread = (1.0 - levels)[:, None]
    lower = nominal - spread * (1e-6 + 1e-6 * np.abs(ringing))
    upper = nominal + spread * (1e-6 + 1e-6 * np.abs(ringing))
    attrs = {"units": "m"}
    return xr.Dataset(
        {
            "y_lower": (("level", "time"), lower, attrs),
            "y_upper": (("level", "time"), upper, attrs),
            "y_nominal": (("time",), nominal, attrs),
            "level_complete": (("level",), np.ones(3, dtype=bool)),
        },
        coords={"level": levels, "time": ("time", t, {"units": "s"})},
        attrs={"study_name": "ringing", "description": "a ringing signal with narrow bands"},
    )


def test_narrow_bands_get_relative_view_and_zoomed_windows():
    dataset = _narrow_ringing_dataset()
    figure = plot_fuzzy_signal(dataset, "y")
    full, relative, ringing, settled = figure.axes
    assert full.get_ylabel() == "y [µm]" and full.get_xlabel() == "time [ms]"
    assert relative.get_ylabel() == "y − nominal [µm]"
    # the relative view's outer band is the mu = 0 cut minus the nominal, in um
    outer = relative.collections[0].get_paths()[0].vertices[:, 1]
    deviation = (dataset["y_upper"].values[0] - dataset["y_nominal"].values) * 1e6
    assert outer.max() == pytest.approx(deviation.max())
    # the nominal moves 100 um between samples 5 us apart: the window at the widest band
    # (the start, where the ringing is largest) shows the bands relative to the nominal
    assert "relative to the nominal" in ringing.get_title()
    assert ringing.get_xlim()[0] == pytest.approx(0.0) and ringing.get_xlim()[1] < 0.25
    # the settled end is shown absolute, its y range fitted to the bands (about 2 um)
    assert settled.get_xlim()[1] == pytest.approx(10.0)
    low, high = settled.get_ylim()
    assert 1.5 < high - low < 4.0 and low < 57.0 < high
    assert figure._suptitle.get_text() == "a ringing signal with narrow bands"


def test_engineering_units_from_the_data():
    from fuzzymbs.units import Scale, engineering_scale, format_quantity

    assert engineering_scale([1.2e-5, 3e-6], "m").unit == "µm"
    assert engineering_scale([0.0, 0.01], "s").unit == "ms"
    assert engineering_scale([2e5], "N/m") == engineering_scale([2e5], "N/m")
    assert engineering_scale([2e5], "N/m").unit == "kN/m"
    assert engineering_scale([14732.9], "N m/rad").unit == "kN m/rad"
    assert engineering_scale([3.5e4], "Hz").unit == "kHz"
    # units that take no prefix: already prefixed, powers, free text, dimensionless
    for unit in ("kg", "m^2", "periods", "1", ""):
        assert engineering_scale([1e-5, 2e3], unit).factor == 1.0
    assert engineering_scale([np.nan, 0.0], "m").factor == 1.0
    # a unit without prefix takes a power of ten outside [0.01, 1e4), so axes need no offset
    assert engineering_scale([-5.5e-5], "1/s") == Scale(1e-6, "10⁻⁶ 1/s")
    assert engineering_scale([0.5], "periods") == Scale(1.0, "periods")
    assert engineering_scale([-5.5e-5], "1/s", powers=False).factor == 1.0
    assert format_quantity(-5.5e-5, "1/s") == "-5.5e-05 1/s"
    assert format_quantity(1.2345e-5, "m") == "12.35 µm"
    assert format_quantity(np.nan, "m") == "n/a"


def test_gear_figures_name_the_mesh_position_and_the_reference(tmp_path):
    study = Study(
        "gear-pair",
        {"contact_stiffness": Triangular.relative(8.82418e8, 0.3)},
        method="reduced",
        levels=2,
        model_options={"positions": 20},
        name="gear",
        description="fuzzy STE of the demo pair",
    )
    dataset = study.run(progress=False).dataset
    figure = plot_fuzzy_signal(dataset, "ste")
    assert figure.axes[0].get_xlabel() == "mesh position [periods]"
    assert figure.axes[0].get_ylabel() == "ste [µm]"
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    assert "reference: potential-energy method" in labels


def test_identify_figures_use_the_output_units():
    import json

    import xarray as xr

    from fuzzymbs.plot import plot_inverse_outputs

    levels = np.array([0.0, 0.5, 1.0])
    measured = (
        np.array([[6.31e-6], [6.34e-6], [6.37e-6]]),
        np.array([[6.95e-6], [6.66e-6], [6.37e-6]]),
    )
    forward = measured[0] + 1e-8, measured[1] - 1e-8
    dataset = xr.Dataset(
        {
            "measured_lower": (("level", "output"), measured[0]),
            "measured_upper": (("level", "output"), measured[1]),
            "forward_lower": (("level", "output"), forward[0]),
            "forward_upper": (("level", "output"), forward[1]),
        },
        coords={"level": levels, "output": ["ste_mean"]},
        attrs={"study_name": "id", "output_units": json.dumps({"ste_mean": "m"})},
    )
    figure = plot_inverse_outputs(dataset)
    assert figure.axes[0].get_xlabel() == "ste mean [µm]"
    # the measured membership is drawn in um: its support is [6.31, 6.95]
    x, _ = figure.axes[0].get_lines()[0].get_data()
    assert min(x) == pytest.approx(6.31) and max(x) == pytest.approx(6.95)
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    assert labels == ["measured", "identified, propagated"]


def test_a_signal_without_any_bounded_level_is_drawn_empty_without_warnings():
    import warnings

    dataset = _narrow_ringing_dataset(size=50)
    for name in ("y_lower", "y_upper", "y_nominal"):
        dataset[name].values[...] = np.nan
    dataset["level_complete"].values[:] = False
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        figure = plot_fuzzy_signal(dataset, "y")
    assert len(figure.axes) == 1 and not figure.axes[0].collections
    assert "PARTIAL" in figure._suptitle.get_text()


def test_figure_cache_copies_the_figures_of_an_unchanged_result(oscillator, tmp_path, monkeypatch):
    import fuzzymbs.plot as plot_module

    cache = tmp_path / "cache"
    first = write_plots(oscillator, tmp_path / "a", cache=cache)
    drawn = {p.name: p.read_bytes() for p in first}
    kept = sorted(cache.iterdir())
    assert len(kept) == len(first)

    def no_drawing(*args, **kwargs):
        raise AssertionError("a figure was drawn although its result is in the cache")

    with monkeypatch.context() as patched:
        patched.setattr(plot_module, "render_figure", no_drawing)
        # the run's own record changes from run to run; the figures do not draw it
        again = oscillator.copy()
        again.attrs["provenance"] = '{"wall_time_s": 1.0}'
        second = write_plots(again, tmp_path / "b", cache=cache)
    assert {p.name: p.read_bytes() for p in second} == drawn
    # a changed result is drawn anew and replaces the cache's entries
    changed = oscillator.copy(deep=True)
    changed["displacement_upper"] = changed["displacement_upper"] * 1.5
    third = write_plots(changed, tmp_path / "c", cache=cache)
    assert (tmp_path / "c" / "displacement_bands.png").read_bytes() != drawn[
        "displacement_bands.png"
    ]
    assert (tmp_path / "c" / "inputs_membership.png").read_bytes() == drawn[
        "inputs_membership.png"
    ]  # the inputs' figure is drawn from unchanged data: the same image
    assert len(list(cache.iterdir())) == len(third)
    assert not set(kept) & set(cache.iterdir())  # the earlier result's entries are gone


def test_figures_drawn_on_workers_are_the_files_drawn_here(oscillator, tmp_path):
    # the reference is this process's own drawing: a pool only moves where it happens
    from concurrent.futures import ProcessPoolExecutor

    here = write_plots(oscillator, tmp_path / "here")
    with ProcessPoolExecutor(2) as pool:
        there = write_plots(oscillator, tmp_path / "there", executor=pool)
    assert [p.name for p in there] == [p.name for p in here]
    assert [p.read_bytes() for p in there] == [p.read_bytes() for p in here]


def test_a_failing_executor_leaves_the_figures_to_this_process(oscillator, tmp_path):
    from concurrent.futures import Executor, Future

    class LostWorkers(Executor):
        def submit(self, fn, /, *args, **kwargs):
            future = Future()
            future.set_exception(OSError("worker lost"))
            return future

    here = write_plots(oscillator, tmp_path / "here")
    there = write_plots(oscillator, tmp_path / "there", executor=LostWorkers())
    assert [p.read_bytes() for p in there] == [p.read_bytes() for p in here]
