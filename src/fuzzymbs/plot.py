"""Plots of study results: memberships, fuzzy signals as alpha-level bands, influence.

Every function takes the result dataset (layout in :mod:`fuzzymbs.study.result`)
and returns a :class:`matplotlib.figure.Figure` built without pyplot (no GUI
backend, safe in worker threads). :func:`write_plots` writes the standard set
as PNG and PDF.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError

if TYPE_CHECKING:  # pragma: no cover
    import xarray
    from matplotlib.figure import Figure

logger = logging.getLogger(__name__)

#: Colour map of the alpha-level bands: light at mu = 0, dark at mu = 1.
BAND_COLORMAP = "Blues"


def _figure(width: float = 6.4, height: float = 4.0) -> Figure:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def _panels(count: int) -> tuple[Figure, np.ndarray]:
    """A figure with ``count`` small panels, three per row (axes flattened)."""
    columns = min(3, count)
    rows = int(np.ceil(count / columns))
    figure = _figure(3.2 * columns, 2.6 * rows)
    return figure, np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()


def _band_color(mu: float) -> Any:
    from matplotlib import colormaps

    return colormaps[BAND_COLORMAP](0.15 + 0.75 * float(mu))


def _label(dataset: xarray.Dataset, name: str, variable: str | None = None) -> str:
    units = dataset[variable or f"{name}_lower"].attrs.get("units")
    return f"{name} [{units}]" if units else name


def _coord_label(dataset: xarray.Dataset, dim: str) -> str:
    units = dataset[dim].attrs.get("units") if dim in dataset.coords else None
    return f"{dim} [{units}]" if units else dim


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


def plot_input_memberships(dataset: xarray.Dataset) -> Figure:
    """Membership functions of the fuzzy parameters (through their alpha-cuts)."""
    names = [str(n) for n in dataset["parameter"].values]
    units = json.loads(dataset.attrs.get("parameter_units", "{}"))
    figure, axes = _panels(len(names))
    levels = dataset["level"].values
    for i, name in enumerate(names):
        ax = axes[i]
        x, mu = _membership_polygon(
            levels,
            dataset["parameter_lower"].values[:, i],
            dataset["parameter_upper"].values[:, i],
        )
        ax.fill(x, mu, color=_band_color(0.3), alpha=0.6, linewidth=0)
        ax.plot(x, mu, color=_band_color(1.0))
        ax.set_xlabel(f"{name} [{units[name]}]" if name in units else name)
        ax.set_ylabel("membership mu")
        ax.set_ylim(0, 1.05)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    figure.suptitle(f"{dataset.attrs.get('study_name', '')}: fuzzy parameters")
    return figure


def plot_inverse_outputs(dataset: xarray.Dataset) -> Figure:
    """Measured outputs (filled) and the forward propagation of the identified
    parameters (line) of an inverse fuzzy-arithmetic result
    (:meth:`fuzzymbs.fuzzy.inverse.InverseResult.to_dataset`)."""
    names = [str(n) for n in dataset["output"].values]
    figure, axes = _panels(len(names))
    levels = dataset["level"].values
    for i, name in enumerate(names):
        ax = axes[i]
        x, mu = _membership_polygon(
            levels, dataset["measured_lower"].values[:, i], dataset["measured_upper"].values[:, i]
        )
        ax.fill(x, mu, color=_band_color(0.3), alpha=0.6, linewidth=0, label="measured")
        x, mu = _membership_polygon(
            levels, dataset["forward_lower"].values[:, i], dataset["forward_upper"].values[:, i]
        )
        ax.plot(x, mu, color="black", linestyle="--", label="forward (identified)")
        ax.set_xlabel(name)
        ax.set_ylabel("membership mu")
        ax.set_ylim(0, 1.05)
    axes[0].legend(fontsize="small")
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    figure.suptitle(f"{dataset.attrs.get('study_name', '')}: measured and reproduced outputs")
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
    title = f"{dataset.attrs.get('study_name', '')}: membership of {output}"
    if coord is not None:
        lower = _at(lower, coord, value)
        upper = _at(upper, coord, value)
        title += f" at {coord} = {float(lower[coord]):.6g}"
    if lower.ndim != 1:
        raise InvalidParameterError(
            f"output {output!r} has dims {lower.dims[1:]}; choose coord and value to plot "
            "a membership function"
        )
    figure = _figure()
    ax = figure.subplots()
    x, mu = _membership_polygon(dataset["level"].values, lower.values, upper.values)
    ax.fill(x, mu, color=_band_color(0.3), alpha=0.6, linewidth=0)
    ax.plot(x, mu, color=_band_color(1.0), marker="o", markersize=3)
    nominal = dataset[f"{output}_nominal"]
    if coord is not None:
        nominal = nominal.sel({coord: value}, method="nearest")
    if np.isfinite(nominal.values):
        ax.axvline(float(nominal.values), color="black", linewidth=0.8, linestyle=":")
    complete = dataset["level_complete"].values.astype(bool)
    if not complete.all():
        title += " (PARTIAL: incomplete levels omitted)"
    ax.set_xlabel(_label(dataset, output))
    ax.set_ylabel("membership mu")
    ax.set_ylim(0, 1.05)
    ax.set_title(title)
    return figure


def plot_fuzzy_signal(dataset: xarray.Dataset, output: str) -> Figure:
    """A fuzzy signal as alpha-level bands over its coordinate (light mu = 0 to dark mu = 1).

    The nominal signal is drawn on top, and the model's reference curve (if
    the result holds ``{output}_reference``) on top of that.
    """
    lower = _variable(dataset, output, "lower")
    upper = _variable(dataset, output, "upper")
    if lower.ndim != 2:
        raise InvalidParameterError(f"output {output!r} is not a signal over one coordinate")
    dim = lower.dims[1]
    x = dataset[dim].values if dim in dataset.coords else np.arange(lower.shape[1])
    figure = _figure(7.0, 4.0)
    ax = figure.subplots()
    levels = dataset["level"].values
    for j, mu in enumerate(levels):
        if not np.isfinite(lower.values[j]).any():
            continue
        ax.fill_between(
            x,
            lower.values[j],
            upper.values[j],
            color=_band_color(mu),
            linewidth=0,
            label=f"mu = {mu:.3g}" if len(levels) <= 6 or j in (0, len(levels) - 1) else None,
        )
    nominal = dataset[f"{output}_nominal"].values
    if np.isfinite(nominal).any():
        ax.plot(x, nominal, color="black", linewidth=0.9, label="nominal")
    if f"{output}_reference" in dataset:
        ax.plot(
            x,
            dataset[f"{output}_reference"].values,
            color="tab:red",
            linewidth=0.9,
            linestyle="--",
            label="reference",
        )
    ax.set_xlabel(_coord_label(dataset, dim))
    ax.set_ylabel(_label(dataset, output))
    title = f"{dataset.attrs.get('study_name', '')}: fuzzy {output}"
    if not dataset["level_complete"].values.all():
        title += " (PARTIAL)"
    ax.set_title(title)
    ax.legend(loc="best", fontsize="small")
    return figure


def plot_influence(dataset: xarray.Dataset, output: str) -> Figure:
    """Absolute and relative influence per parameter: stacked areas over the
    coordinate for a signal, bars for a scalar output."""
    absolute = _variable(dataset, output, "absolute_influence")
    relative = _variable(dataset, output, "relative_influence")
    names = [str(n) for n in dataset["parameter"].values]
    figure = _figure(9.0, 3.6)
    left, right = figure.subplots(1, 2)
    colors = [f"C{i}" for i in range(len(names))]
    if absolute.ndim == 1:
        left.bar(names, absolute.values, color=colors)
        right.bar(names, relative.values, color=colors)
        right.set_ylim(0, 1)
    elif absolute.ndim == 2:
        dim = absolute.dims[1]
        x = dataset[dim].values if dim in dataset.coords else np.arange(absolute.shape[1])
        left.stackplot(x, np.nan_to_num(absolute.values), labels=names, colors=colors)
        right.stackplot(x, np.nan_to_num(relative.values), labels=names, colors=colors)
        left.set_xlabel(_coord_label(dataset, dim))
        right.set_xlabel(_coord_label(dataset, dim))
        right.set_ylim(0, 1)
        right.legend(loc="upper right", fontsize="small")
    else:
        raise InvalidParameterError(
            f"influence of {output!r} has more than one coordinate; not plotted"
        )
    units = dataset[f"{output}_lower"].attrs.get("units")
    left.set_title("absolute influence kappa")
    left.set_ylabel(f"kappa [{units}]" if units else "kappa")
    right.set_title("relative influence rho")
    right.set_ylabel("rho")
    figure.suptitle(f"{dataset.attrs.get('study_name', '')}: influence on {output}")
    return figure


def _save(figure: Figure, directory: Path, stem: str, formats: Sequence[str]) -> list[Path]:
    written = []
    for extension in formats:
        path = directory / f"{stem}.{extension}"
        if path.parent != directory or path.name.startswith("."):  # never outside directory
            raise ValueError(f"plot name {stem!r} is not a plain file name")
        figure.savefig(path, dpi=120)
        # the first save placed the axes; keep that layout instead of solving it again
        figure.set_layout_engine("none")
        written.append(path)
    return written


def write_plots(
    dataset: xarray.Dataset,
    directory: str | Path,
    membership: Sequence[Mapping[str, Any]] | None = None,
    formats: Sequence[str] = ("png", "pdf"),
) -> list[Path]:
    """Write the standard plots of a result into ``directory``.

    Written: input memberships; per scalar output its membership; per signal
    the alpha-level bands; influence where the dataset holds it; and one
    membership plot per entry of ``membership`` (``{"output", "coord",
    "value"}``; default: the ``plots`` attribute of the dataset, i.e. the
    study file's ``[[plots.membership]]``).

    Returns
    -------
    list of Path
        The files written.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    written = _save(plot_input_memberships(dataset), directory, "inputs_membership", formats)
    outputs = json.loads(dataset.attrs["outputs"])
    influence_outputs = set(json.loads(dataset.attrs.get("influence_outputs", "[]")))
    for output in outputs:
        ndim = dataset[f"{output}_lower"].ndim - 1
        if ndim == 0:
            figure = plot_output_membership(dataset, output)
            written += _save(figure, directory, f"{output}_membership", formats)
        elif ndim == 1:
            written += _save(
                plot_fuzzy_signal(dataset, output), directory, f"{output}_bands", formats
            )
        else:
            logger.info("output %r has %d coordinates; no standard plot", output, ndim)
        if output in influence_outputs and ndim <= 1:
            written += _save(
                plot_influence(dataset, output), directory, f"{output}_influence", formats
            )
    if membership is None:
        membership = json.loads(dataset.attrs.get("plots", "{}")).get("membership", [])
    for spec in membership:
        coord, value = spec.get("coord"), spec.get("value")
        figure = plot_output_membership(dataset, spec["output"], coord, value)
        stem = f"{spec['output']}_membership"
        if coord is not None:
            stem += f"_{coord}_{value:g}"
        written += _save(figure, directory, stem, formats)
    return written
