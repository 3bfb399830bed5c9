"""Plots of study results: memberships, fuzzy signals as alpha-level bands, influence.

Every function takes the result dataset (layout in :mod:`fuzzymbs.study.result`)
and returns a :class:`matplotlib.figure.Figure` built without pyplot (no GUI
backend, safe in worker threads). :func:`write_plots` writes the standard set
(:func:`standard_figures`) as PNG, and as PDF or SVG on request, drawn side by side
on an executor's workers when it is given one.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.units import Scale, engineering_scale

if TYPE_CHECKING:  # pragma: no cover
    import xarray
    from matplotlib.figure import Figure

logger = logging.getLogger(__name__)

#: Colour map of the alpha-level bands: light at mu = 0, dark at mu = 1 (every figure).
BAND_COLORMAP = "Blues"
#: Bands narrower than this fraction of their signal's range get the extra views.
NARROW_BANDS = 0.1
#: Readable names of the coordinates the built-in models use.
COORDINATE_NAMES = {"time": "time", "position": "mesh position", "harmonic": "mesh harmonic"}
REFERENCE_COLOR = "tab:red"


def _figure(width: float = 6.4, height: float = 4.0) -> Figure:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def _panels(count: int) -> tuple[Figure, np.ndarray]:
    """A figure with ``count`` small panels, three per row (axes flattened)."""
    columns = min(3, count)
    rows = int(np.ceil(count / columns))
    figure = _figure(3.2 * columns, 2.8 * rows + 0.4)
    axes = np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()
    for ax in axes[count:]:
        ax.set_visible(False)
    return figure, axes


def _band_color(mu: float) -> Any:
    from matplotlib import colormaps

    return colormaps[BAND_COLORMAP](0.15 + 0.75 * float(mu))


def _level_name(mu: float) -> str:
    name = f"μ = {mu:.3g}"
    return name + (" (support)" if mu == 0 else " (core)" if mu == 1 else "")


def _level_handles(levels: Sequence[float]) -> list[Any]:
    """Legend entries of the level colours (every level up to six, else the ends)."""
    from matplotlib.patches import Patch

    shown = [m for j, m in enumerate(levels) if len(levels) <= 6 or j in (0, len(levels) - 1)]
    return [Patch(color=_band_color(m), label=_level_name(m)) for m in shown]


def _title(figure: Figure, dataset: xarray.Dataset, partial: bool = False) -> None:
    """The study's description (its name if it has none) as the figure's title."""
    import textwrap

    text = str(dataset.attrs.get("description") or dataset.attrs.get("study_name", ""))
    if partial:
        text += " (PARTIAL: incomplete levels omitted)"
    # about 13 characters per inch of figure width at the medium font size
    width = int(13 * figure.get_figwidth())
    figure.suptitle("\n".join(textwrap.wrap(text, width)), fontsize="medium")


def _units(dataset: xarray.Dataset, output: str) -> str:
    return str(dataset[f"{output}_lower"].attrs.get("units", ""))


def scaled_coordinate(
    dataset: xarray.Dataset, dim: str, size: int
) -> tuple[np.ndarray, Scale, str]:
    """The values of coordinate ``dim`` in engineering units, their scale and readable name.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study result (layout in :mod:`fuzzymbs.study.result`).
    dim : str
        The name of an output's own axis (``"time"``, ``"position"``, ...).
    size : int
        The axis' length, used when the dataset has no coordinate of that name.

    Returns
    -------
    values : numpy.ndarray
        The coordinate in the unit of ``scale`` (the sample indices 0 .. size - 1
        when the axis has no coordinate).
    scale : Scale
        The SI prefix chosen from the values (:func:`fuzzymbs.units.engineering_scale`).
    name : str
        The readable name: the coordinate's ``long_name``, else the built-in name of
        :data:`COORDINATE_NAMES`, else ``dim`` with spaces ("DIM (index)" without a
        coordinate).
    """
    if dim not in dataset.coords:
        return np.arange(size, dtype=float), Scale(1.0, ""), f"{dim} (index)"
    coordinate = dataset[dim]
    scale = engineering_scale(coordinate.values, coordinate.attrs.get("units"))
    name = coordinate.attrs.get("long_name") or COORDINATE_NAMES.get(dim, dim.replace("_", " "))
    return scale(coordinate.values), scale, str(name)


def _reference_label(dataset: xarray.Dataset, output: str) -> str:
    """The reference's name as the model gives it (``long_name`` of ``{output}_reference``)."""
    name = dataset[f"{output}_reference"].attrs.get("long_name")
    return f"reference: {name}" if name else "reference (model's own)"


def _variable(dataset: xarray.Dataset, output: str, suffix: str) -> xarray.DataArray:
    """``dataset[f"{output}_{suffix}"]``, or an error naming the outputs that can be plotted."""
    name = f"{output}_{suffix}"
    if name not in dataset:
        available = sorted(
            str(key)[: -len(f"_{suffix}")]
            for key in dataset.data_vars
            if str(key).endswith(f"_{suffix}") and str(key) != f"parameter_{suffix}"
        )
        raise InvalidParameterError(
            f"the result has no {name!r}; outputs with {suffix!r}: {', '.join(available) or 'none'}"
        )
    return dataset[name]


def _at(array: xarray.DataArray, coord: str, value: float) -> xarray.DataArray:
    """The slice of ``array`` nearest to ``coord = value``, or an error naming its coords."""
    if coord not in array.dims:
        raise InvalidParameterError(
            f"{array.name!r} has no coordinate {coord!r}; its coordinates: "
            f"{', '.join(map(str, array.dims[1:])) or 'none (scalar output)'}"
        )
    return array.sel({coord: value}, method="nearest")


def _membership_polygon(
    levels: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """x and mu of the piecewise-linear membership through the cuts (NaN levels dropped)."""
    keep = np.isfinite(lower) & np.isfinite(upper)
    levels, lower, upper = levels[keep], lower[keep], upper[keep]
    x = np.concatenate([lower, upper[::-1]])
    mu = np.concatenate([levels, levels[::-1]])
    return x, mu


def _draw_membership(
    ax: Any, levels: np.ndarray, lower: np.ndarray, upper: np.ndarray, label: str | None = None
) -> None:
    """A membership function: light fill, dark outline through the cuts, and each cut as
    a bar in its level's colour (the colours of the bands)."""
    x, mu = _membership_polygon(levels, lower, upper)
    ax.fill(x, mu, color=_band_color(0.0), linewidth=0)
    ax.plot(x, mu, color=_band_color(1.0), marker="o", markersize=3, label=label)
    for mu_j, lo, hi in zip(levels, lower, upper, strict=True):
        if np.isfinite(lo) and np.isfinite(hi):
            ax.plot([lo, hi], [mu_j, mu_j], color=_band_color(mu_j), linewidth=2.5)
    ax.set_ylabel("membership μ")
    ax.set_ylim(0, 1.05)
    ax.ticklabel_format(axis="x", useOffset=False)


def plot_input_memberships(dataset: xarray.Dataset) -> Figure:
    """Membership functions of the fuzzy parameters (through their alpha-cuts), each in
    engineering units of its parameter."""
    names = [str(n) for n in dataset["parameter"].values]
    units = json.loads(dataset.attrs.get("parameter_units", "{}"))
    figure, axes = _panels(len(names))
    levels = dataset["level"].values
    for i, name in enumerate(names):
        lower = dataset["parameter_lower"].values[:, i]
        upper = dataset["parameter_upper"].values[:, i]
        scale = engineering_scale(np.concatenate([lower, upper]), units.get(name))
        _draw_membership(axes[i], levels, scale(lower), scale(upper))
        axes[i].set_xlabel(scale.label(name.replace("_", " ")))
    _title(figure, dataset)
    return figure


def plot_inverse_outputs(dataset: xarray.Dataset) -> Figure:
    """Measured outputs (filled) and the forward propagation of the identified
    parameters (line) of an inverse fuzzy-arithmetic result
    (:meth:`fuzzymbs.fuzzy.inverse.InverseResult.to_dataset`)."""
    names = [str(n) for n in dataset["output"].values]
    units = json.loads(dataset.attrs.get("output_units", "{}"))
    figure, axes = _panels(len(names))
    levels = dataset["level"].values
    for i, name in enumerate(names):
        ax = axes[i]
        measured = dataset["measured_lower"].values[:, i], dataset["measured_upper"].values[:, i]
        forward = dataset["forward_lower"].values[:, i], dataset["forward_upper"].values[:, i]
        scale = engineering_scale(np.concatenate([*measured, *forward]), units.get(name))
        _draw_membership(ax, levels, scale(measured[0]), scale(measured[1]), label="measured")
        x, mu = _membership_polygon(levels, scale(forward[0]), scale(forward[1]))
        ax.plot(x, mu, color="black", linestyle="--", label="identified, propagated")
        ax.set_xlabel(scale.label(name.replace("_", " ")))
    figure.legend(
        *axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize="small"
    )
    _title(figure, dataset)
    return figure


def plot_output_membership(
    dataset: xarray.Dataset,
    output: str,
    coord: str | None = None,
    value: float | None = None,
) -> Figure:
    """Membership function of a scalar output, or of a signal at ``coord = value``.

    The nearest coordinate value is used; the title states which one.
    """
    lower = _variable(dataset, output, "lower")
    upper = _variable(dataset, output, "upper")
    nominal = dataset[f"{output}_nominal"]
    reference = dataset.get(f"{output}_reference")
    title = f"membership of {output}"
    if coord is not None:
        lower = _at(lower, coord, value)
        upper = _at(upper, coord, value)
        nominal = nominal.sel({coord: value}, method="nearest")
        if reference is not None:
            reference = reference.sel({coord: value}, method="nearest")
        at = float(lower[coord])
        _, coord_scale, coord_name = scaled_coordinate(dataset, coord, 1)
        where = f"{coord_scale(at).item():.4g} {coord_scale.unit}".strip()
        title += f" at {coord_name} = {where}"
    if lower.ndim != 1:
        raise InvalidParameterError(
            f"output {output!r} has dims {lower.dims[1:]}; choose coord and value to plot "
            "a membership function"
        )
    scale = engineering_scale(np.concatenate([lower.values, upper.values]), _units(dataset, output))
    figure = _figure(6.4, 4.0)
    ax = figure.subplots()
    levels = dataset["level"].values
    _draw_membership(ax, levels, scale(lower.values), scale(upper.values), label="fuzzy result")
    if np.isfinite(nominal.values):
        ax.axvline(scale(nominal.values).item(), color="black", linewidth=0.9, label="nominal")
    if reference is not None and reference.ndim == 0 and np.isfinite(reference.values):
        ax.axvline(
            scale(reference.values).item(),
            color=REFERENCE_COLOR,
            linestyle="--",
            linewidth=0.9,
            label=_reference_label(dataset, output),
        )
    complete = dataset["level_complete"].values.astype(bool)
    ax.set_xlabel(scale.label(output))
    ax.set_title(title, fontsize="medium")
    ax.legend(loc="upper left", fontsize="small")
    _title(figure, dataset, partial=not complete.all())
    return figure


def _draw_bands(
    ax: Any, x: np.ndarray, lower: np.ndarray, upper: np.ndarray, levels: np.ndarray
) -> int:
    """One filled band per level with known bounds, light to dark; returns how many."""
    drawn = 0
    for j, mu in enumerate(levels):
        if np.isfinite(lower[j]).any():
            ax.fill_between(x, lower[j], upper[j], color=_band_color(mu), linewidth=0)
            drawn += 1
    return drawn


def _zoom_windows(width: np.ndarray, nominal: np.ndarray) -> list[tuple[slice, bool]]:
    """Up to two windows in which the bands can be seen, each with whether it shows them
    relative to the nominal signal.

    The first is around the widest band, grown while the nominal signal moves by no
    more than a few band widths. Where it moves more within a few points (a ringing
    signal sampled a few points per period), no absolute window can show the bands:
    the window then spans a fiftieth of the coordinate and shows the bands relative
    to the nominal signal. The second is the end of the signal (for a transient:
    where it has settled). Windows span at most a tenth of the coordinate and do not
    overlap.
    """
    size = width.size
    if size < 20 or not np.isfinite(width).any():
        return []
    longest = max(5, size // 10)
    centre = int(np.nanargmax(width))
    start, stop = max(centre - 2, 0), min(centre + 3, size)
    while stop - start < longest:
        grown = slice(max(start - 1, 0), min(stop + 1, size))
        moved = np.ptp(nominal[grown])
        if moved > 4.0 * np.nanmax(width[grown]) or (grown.start, grown.stop) == (start, stop):
            break
        start, stop = grown.start, grown.stop
    relative = stop - start < 10
    if relative:
        half = max(5, size // 100)
        start, stop = max(centre - half, 0), min(centre + half, size)
    windows = [(slice(start, stop), relative)]
    if stop <= size - longest:
        windows.append((slice(size - longest, size), False))
    elif start >= longest:
        windows.insert(0, (slice(0, longest), False))
    return windows


def plot_fuzzy_signal(dataset: xarray.Dataset, output: str) -> Figure:
    """A fuzzy signal as alpha-level bands over its coordinate (light mu = 0 to dark mu = 1).

    The nominal signal is drawn on top, and the model's reference curve (if the
    result holds ``{output}_reference``) on top of that, named in the legend.
    Where the widest band is narrower than :data:`NARROW_BANDS` of the signal's
    range, two more views show it: the bands relative to the nominal signal, and
    zoomed windows (around the widest band and at the end of the signal) whose
    axes fit the bands. The windows are shaded on the full view.
    """
    lower_array = _variable(dataset, output, "lower")
    upper = _variable(dataset, output, "upper").values
    if lower_array.ndim != 2:
        raise InvalidParameterError(f"output {output!r} is not a signal over one coordinate")
    lower = lower_array.values
    dim = lower_array.dims[1]
    x, _, coord_name = scaled_coordinate(dataset, dim, lower.shape[1])
    coord_label = scaled_coordinate(dataset, dim, lower.shape[1])[1].label(coord_name)
    levels = dataset["level"].values
    nominal = dataset[f"{output}_nominal"].values
    reference = dataset[f"{output}_reference"].values if f"{output}_reference" in dataset else None
    curves = [lower, upper, nominal] + ([reference] if reference is not None else [])
    scale = engineering_scale(
        np.concatenate([np.ravel(c) for c in curves]), _units(dataset, output)
    )
    known = np.flatnonzero(np.isfinite(lower).any(axis=1))
    width = upper[known[0]] - lower[known[0]] if known.size else np.full(x.shape, np.nan)
    narrow = False
    if np.isfinite(nominal).all() and np.isfinite(width).any():  # else nothing to zoom on
        signal_range = max(np.nanmax(upper[known]), nominal.max()) - min(
            np.nanmin(lower[known]), nominal.min()
        )
        narrow = bool(np.nanmax(width) < NARROW_BANDS * signal_range)
    windows = _zoom_windows(width, nominal) if narrow else []
    rows = 1 + narrow + bool(windows)
    figure = _figure(7.0, 1.2 + 3.0 * rows)
    if narrow:
        grid = figure.add_gridspec(rows, max(1, len(windows)))
        ax = figure.add_subplot(grid[0, :])
        relative_ax = figure.add_subplot(grid[1, :], sharex=ax)
        zoom_axes = [figure.add_subplot(grid[2, k]) for k in range(len(windows))]
    else:
        ax, relative_ax, zoom_axes = figure.subplots(), None, []

    def draw(axis: Any, part: slice) -> None:
        _draw_bands(axis, x[part], scale(lower[:, part]), scale(upper[:, part]), levels)
        if np.isfinite(nominal).any():
            axis.plot(x[part], scale(nominal[part]), color="black", linewidth=0.9)
        if reference is not None:
            axis.plot(
                x[part], scale(reference[part]), color=REFERENCE_COLOR, linewidth=0.9, ls="--"
            )
        axis.ticklabel_format(axis="y", useOffset=False)

    draw(ax, slice(None))
    ax.set_ylabel(scale.label(output))
    ax.set_title(f"{output}: alpha-level bands", fontsize="medium")
    deviation_lower, deviation_upper = lower - nominal, upper - nominal
    relative_scale = engineering_scale(
        np.concatenate([deviation_lower.ravel(), deviation_upper.ravel()]), _units(dataset, output)
    )
    if relative_ax is not None:
        _draw_bands(
            relative_ax, x, relative_scale(deviation_lower), relative_scale(deviation_upper), levels
        )
        relative_ax.axhline(0.0, color="black", linewidth=0.9)
        relative_ax.set_ylabel(relative_scale.label(f"{output} − nominal"))
        relative_ax.set_title("the bands relative to the nominal signal", fontsize="medium")
        relative_ax.set_xlabel(coord_label)
    for letter, (part, relative), zoom in zip("ABCD", windows, zoom_axes, strict=False):
        if relative:
            _draw_bands(
                zoom,
                x[part],
                relative_scale(deviation_lower[:, part]),
                relative_scale(deviation_upper[:, part]),
                levels,
            )
            zoom.axhline(0.0, color="black", linewidth=0.9)
            zoom.set_ylabel(relative_scale.label(f"{output} − nominal"))
            zoom.set_title(f"window {letter}, relative to the nominal", fontsize="medium")
        else:
            draw(zoom, part)
            band = scale(np.concatenate([lower[known, part].ravel(), upper[known, part].ravel()]))
            low, high = np.nanmin(band), np.nanmax(band)
            zoom.set_ylim(low - 0.15 * (high - low), high + 0.15 * (high - low))
            zoom.set_ylabel(scale.label(output))
            zoom.set_title(f"window {letter}", fontsize="medium")
        zoom.set_xlim(x[part][0], x[part][-1])
        zoom.set_xlabel(coord_label)
        ax.axvspan(x[part][0], x[part][-1], color="0.85", zorder=0)
        ax.text(x[part][0], 1.0, f" {letter}", transform=ax.get_xaxis_transform(), va="top")
    ax.set_xlabel(coord_label)
    handles = _level_handles(levels[known])
    from matplotlib.lines import Line2D

    if np.isfinite(nominal).any():
        handles.append(Line2D([], [], color="black", linewidth=0.9, label="nominal"))
    if reference is not None:
        handles.append(
            Line2D([], [], color=REFERENCE_COLOR, ls="--", label=_reference_label(dataset, output))
        )
    figure.legend(handles=handles, loc="outside lower center", ncol=3, fontsize="small")
    _title(figure, dataset, partial=not dataset["level_complete"].values.all())
    return figure


def plot_influence(dataset: xarray.Dataset, output: str) -> Figure:
    """Absolute and relative influence per parameter: stacked areas over the
    coordinate for a signal, bars for a scalar output."""
    absolute = _variable(dataset, output, "absolute_influence")
    relative = _variable(dataset, output, "relative_influence")
    names = [str(n) for n in dataset["parameter"].values]
    if absolute.ndim > 2:
        raise InvalidParameterError(
            f"influence of {output!r} has more than one coordinate; not plotted"
        )
    scale = engineering_scale(absolute.values, _units(dataset, output))
    colors = [f"C{i}" for i in range(len(names))]
    figure = _figure(7.0, 3.4 + 0.2 * len(names) if absolute.ndim == 1 else 4.0)
    left, right = figure.subplots(1, 2)
    if absolute.ndim == 1:
        left.barh(names, scale(absolute.values), color=colors)
        right.barh(names, relative.values, color=colors)
        right.set_xlim(0, 1)
        right.set_yticklabels([])
        left.invert_yaxis()
        right.invert_yaxis()
        left.set_xlabel(scale.label("absolute influence κ"))
        right.set_xlabel("relative influence ρ")
    else:
        dim = absolute.dims[1]
        x, coord_scale, coord_name = scaled_coordinate(dataset, dim, absolute.shape[1])
        # no edge lines: on a fast-oscillating signal they wash the areas out
        areas = {"colors": colors, "linewidth": 0}
        left.stackplot(x, np.nan_to_num(scale(absolute.values)), labels=names, **areas)
        right.stackplot(x, np.nan_to_num(relative.values), **areas)
        for ax in (left, right):
            ax.set_xlabel(coord_scale.label(coord_name))
        right.set_ylim(0, 1)
        left.set_ylabel(scale.label("absolute influence κ"))
        right.set_ylabel("relative influence ρ")
        figure.legend(loc="outside lower center", ncol=min(3, len(names)), fontsize="small")
    left.set_title(f"absolute influence on {output}", fontsize="medium")
    right.set_title("relative influence", fontsize="medium")
    _title(figure, dataset)
    return figure


#: What :func:`write_plots` writes unless asked for more: PNG only (PDF and SVG on request;
#: a PDF costs as much again as the PNG, and the report embeds the PNG).
DEFAULT_FORMATS: tuple[str, ...] = ("png",)
#: Every format :func:`write_plots` can write.
FORMATS: tuple[str, ...] = ("png", "pdf", "svg")
#: Resolution of the PNG files (the report embeds these very images).
PNG_DPI = 120
#: File stem of the input memberships figure.
INPUTS_STEM = "inputs_membership"


def membership_stem(output: str, coord: str | None = None, value: float | None = None) -> str:
    """File stem of the membership figure of ``output`` (at ``coord = value``)."""
    return f"{output}_membership" + ("" if coord is None else f"_{coord}_{value:g}")


def bands_stem(output: str) -> str:
    """File stem of the alpha-level bands figure of the signal ``output``."""
    return f"{output}_bands"


def influence_stem(output: str) -> str:
    """File stem of the influence figure of ``output``."""
    return f"{output}_influence"


@dataclass(frozen=True)
class StandardFigure:
    """One figure of a result's standard set, built only when asked for."""

    stem: str
    build: Callable[[], Figure]


def standard_figures(
    dataset: xarray.Dataset, membership: Sequence[Mapping[str, Any]] | None = None
) -> list[StandardFigure]:
    """The standard figures of a result, in the order they are written.

    Input memberships; per scalar output its membership; per signal the
    alpha-level bands; influence where the dataset holds it; and one membership
    figure per entry of ``membership`` (``{"output", "coord", "value"}``;
    default: the ``plots`` attribute of the dataset, i.e. the study file's
    ``[[plots.membership]]``). Nothing is drawn until a figure's ``build`` is called.
    """
    figures = [StandardFigure(INPUTS_STEM, partial(plot_input_memberships, dataset))]
    outputs = json.loads(dataset.attrs["outputs"])
    influence_outputs = set(json.loads(dataset.attrs.get("influence_outputs", "[]")))
    for output in outputs:
        ndim = dataset[f"{output}_lower"].ndim - 1
        if ndim == 0:
            figures.append(
                StandardFigure(
                    membership_stem(output), partial(plot_output_membership, dataset, output)
                )
            )
        elif ndim == 1:
            figures.append(
                StandardFigure(bands_stem(output), partial(plot_fuzzy_signal, dataset, output))
            )
        else:
            logger.info("output %r has %d coordinates; no standard plot", output, ndim)
        if output in influence_outputs and ndim <= 1:
            figures.append(
                StandardFigure(influence_stem(output), partial(plot_influence, dataset, output))
            )
    if membership is None:
        membership = json.loads(dataset.attrs.get("plots", "{}")).get("membership", [])
    for spec in membership:
        coord, value = spec.get("coord"), spec.get("value")
        figures.append(
            StandardFigure(
                membership_stem(spec["output"], coord, value),
                partial(plot_output_membership, dataset, spec["output"], coord, value),
            )
        )
    return figures


#: Attributes of a result that change from run to run but are drawn in no figure.
_UNDRAWN_ATTRIBUTES = frozenset({"provenance", "command"})


def result_digest(dataset: xarray.Dataset) -> str:
    """A digest of everything a figure of ``dataset`` may draw: every variable and
    coordinate (name, type, shape, values, attributes) and the dataset's attributes but
    the run's own record (provenance, command), with the versions of fuzzymbs and
    matplotlib. Two results with equal digests give the same figures."""
    from importlib.metadata import version

    from fuzzymbs.version import __version__

    digest = hashlib.sha256(f"{__version__} {version('matplotlib')} {PNG_DPI}".encode())
    for name in sorted(map(str, dataset.variables)):
        array = dataset.variables[name]
        values = np.asarray(array.values)
        header = (name, str(values.dtype), values.shape, array.dims, sorted(array.attrs.items()))
        digest.update(repr(header).encode())
        # the array's own buffer (no copy: a large study's raw outputs are hundreds of MB)
        digest.update(
            repr(values.tolist()).encode()
            if values.dtype == object
            else np.ascontiguousarray(values).data
        )
    attributes = {k: v for k, v in dataset.attrs.items() if k not in _UNDRAWN_ATTRIBUTES}
    digest.update(repr(sorted((k, str(v)) for k, v in attributes.items())).encode())
    return digest.hexdigest()


def _target(directory: Path, stem: str, extension: str) -> Path:
    path = directory / f"{stem}.{extension}"
    if path.parent != directory or path.name.startswith("."):  # never outside directory
        raise ValueError(f"plot name {stem!r} is not a plain file name")
    return path


def figure_files(figure: Figure, formats: Sequence[str]) -> dict[str, bytes]:
    """The contents of ``figure``'s files by extension (PNG at :data:`PNG_DPI`), in the
    order of ``formats``."""
    import io

    files = {}
    for extension in formats:
        buffer = io.BytesIO()
        figure.savefig(buffer, format=extension, dpi=PNG_DPI)
        # the first save placed the axes; keep that layout instead of solving it again
        figure.set_layout_engine("none")
        files[extension] = buffer.getvalue()
    return files


def render_figure(figure: StandardFigure, formats: Sequence[str]) -> dict[str, bytes]:
    """Build a standard figure and return its files' contents by extension (a task that
    runs where the study's samples ran: only bytes travel back)."""
    return figure_files(figure.build(), formats)


def save_figure(figure: Figure, directory: Path, stem: str, formats: Sequence[str]) -> list[Path]:
    """Write ``figure`` as ``directory/stem.EXTENSION``, one file per format.

    Parameters
    ----------
    figure : matplotlib.figure.Figure
        The figure to write (PNG at :data:`PNG_DPI`).
    directory : Path
        An existing folder.
    stem : str
        The file name without extension; a plain name (no folder, no leading dot).
    formats : sequence of str
        File extensions, any of :data:`FORMATS`, written in this order.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ValueError
        ``stem`` would place a file outside ``directory`` or hide it.
    """
    targets = [_target(directory, stem, extension) for extension in formats]
    for path, data in zip(targets, figure_files(figure, formats).values(), strict=True):
        path.write_bytes(data)
    return targets


def write_plots(
    dataset: xarray.Dataset,
    directory: str | Path,
    membership: Sequence[Mapping[str, Any]] | None = None,
    formats: Sequence[str] = DEFAULT_FORMATS,
    cache: str | Path | None = None,
    executor: Executor | None = None,
    meanwhile: Callable[[], Any] | None = None,
) -> list[Path]:
    """Write the standard plots of a result (:func:`standard_figures`) into ``directory``.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study result.
    directory : str or Path
        Where the files go (created if missing).
    membership : sequence of mapping, optional
        Membership figures at given coordinates (see :func:`standard_figures`).
    formats : sequence of str
        Any of :data:`FORMATS`; PNG only by default.
    cache : str or Path, optional
        A folder of figure files by content (:func:`result_digest`): a figure whose
        result, stem and format it holds is copied from it instead of drawn (a rerun
        that resumes every run draws nothing), and what is drawn is kept there.
        Entries this call did not use are removed, so the folder holds one result's.
    executor : concurrent.futures.Executor, optional
        Draws the figures side by side (:func:`render_figure` tasks, e.g. on the
        workers that ran the study); None: one after another in this process.
    meanwhile : callable, optional
        Called once the figures are handed to ``executor``, before waiting for
        them (the study pipeline writes ``result.nc`` while the workers draw).

    Returns
    -------
    list of Path
        The files written.
    """
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise InvalidParameterError(f"plot formats {unknown}; allowed: {', '.join(FORMATS)}")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    digest = None if cache is None else result_digest(dataset)
    if cache is not None:
        Path(cache).mkdir(parents=True, exist_ok=True)
    # no figure draws the raw runs: the tasks carry the bands, not every sample's outputs
    drawn = dataset.drop_dims(["sample", "validation"], errors="ignore")
    jobs = []
    for figure in standard_figures(drawn, membership):
        kept = {}
        if cache is not None:
            key = hashlib.sha256(f"{digest} {figure.stem}".encode()).hexdigest()[:32]
            kept = {extension: Path(cache) / f"{key}.{extension}" for extension in formats}
        missing = [e for e in formats if e not in kept or not kept[e].is_file()]
        job: Future | None = None
        if missing and executor is not None:
            try:
                job = executor.submit(render_figure, figure, missing)
            except Exception as exc:  # e.g. a broken pool: drawn here instead
                logger.warning("figure %s drawn here: %s", figure.stem, exc)
        jobs.append(_FigureJob(figure, kept, missing, job))
    if meanwhile is not None:
        meanwhile()
    return _write_files(directory, formats, None if cache is None else Path(cache), jobs)


@dataclass
class _FigureJob:
    figure: StandardFigure
    kept: dict[str, Path]  # the cache's file per format
    missing: list[str]  # the formats to draw
    job: Future | None  # drawing elsewhere, or None: drawn here when waited for

    def files(self) -> dict[str, bytes]:
        if self.missing and self.job is not None:
            try:
                return self.job.result()
            except Exception as exc:  # a lost worker must not lose a finished study
                logger.warning("figure %s drawn here: %s", self.figure.stem, exc)
        return render_figure(self.figure, self.missing) if self.missing else {}


def _write_files(
    directory: Path, formats: Sequence[str], cache: Path | None, jobs: list[_FigureJob]
) -> list[Path]:
    """Wait for the figures of ``jobs`` and write their files (and the cache's)."""
    from fuzzymbs.files import write_bytes_atomically

    written = []
    for job in jobs:
        files = job.files()
        for extension in formats:
            target = _target(directory, job.figure.stem, extension)
            if extension in files:
                write_bytes_atomically(target, files[extension])
                if extension in job.kept:
                    write_bytes_atomically(job.kept[extension], files[extension])
            else:
                write_bytes_atomically(target, job.kept[extension].read_bytes())
            written.append(target)
    if cache is not None:
        used = {path.name for job in jobs for path in job.kept.values()}
        for entry in cache.iterdir():
            if entry.is_file() and entry.name not in used and not entry.name.startswith("."):
                entry.unlink(missing_ok=True)
    return written
