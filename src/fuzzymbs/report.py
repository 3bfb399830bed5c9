"""A study result as one self-contained HTML page (``report.html``).

The page holds everything a reader needs without the code or a network: the
study's description, the fuzzy inputs, the bands and memberships of every
output, the influence measures, the method error and the time-integration
error with a verdict against their tolerances (a fixed method's method error comes
from sampled validation runs: a lower bound, whose verdict within the tolerance is
"no miss found", never "OK"), failed samples, provenance and
the command that reproduces the result. Figures are PNG images embedded as
base64 data; the style sheet is inline; nothing is loaded from elsewhere.
"""

from __future__ import annotations

import base64
import html
import io
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fuzzymbs.fuzzy.band_scale import CERTIFIED
from fuzzymbs.study.summary import method_error_bound, sampled_method_error
from fuzzymbs.units import Scale, engineering_scale, format_quantity

if TYPE_CHECKING:  # pragma: no cover
    import xarray

    from fuzzymbs.plot import StandardFigure

REPORT_FILE = "report.html"
# "sampled": a sampled check found nothing above its tolerance, which is no proof of a pass
_VERDICTS = {"pass": "OK", "fail": "FAILED", "sampled": "NO MISS FOUND", "none": "—"}

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 60em; margin: 2em auto; padding: 0 1em;
       color: #1a1a1a; line-height: 1.45; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }
.meta { color: #555; }
table { border-collapse: collapse; margin: 0.8em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
img { max-width: 100%; height: auto; display: block; margin: 0.8em 0; }
pre, code { background: #f4f4f4; }
pre { padding: 0.6em; overflow-x: auto; white-space: pre-wrap; }
.pass { background: #d9f2d9; } .fail { background: #f8d0d0; } .none { background: #eee; }
.sampled { background: #fdf1cc; }
.verdict { font-weight: bold; }
"""


@dataclass(frozen=True)
class Check:
    """One numerical check of a result and its verdict."""

    name: str
    # "pass", "fail", "sampled" (a sample found nothing above the tolerance: a lower
    # bound, not a pass) or "none" (not checked / not applicable)
    verdict: str
    text: str


def _e(value: Any) -> str:
    return html.escape(str(value))


@dataclass(frozen=True)
class _Figures:
    """The result's standard figures (:func:`fuzzymbs.plot.standard_figures`) by file
    stem, and the PNG images of those already drawn (the plot files just written)."""

    standard: Mapping[str, StandardFigure]
    images: Mapping[str, bytes]

    def html(self, stem: str, caption: str) -> str:
        """The figure as an embedded PNG with its caption (drawn now if not drawn yet)."""
        png = self.images.get(stem)
        if png is None:
            from fuzzymbs.plot import PNG_DPI

            buffer = io.BytesIO()
            self.standard[stem].build().savefig(buffer, format="png", dpi=PNG_DPI)
            png = buffer.getvalue()
        data = base64.b64encode(png).decode("ascii")
        return (
            f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>"
        )


def _table(header: Sequence[str], rows: Iterable[Sequence[Any]], numeric: int = 0) -> str:
    """An HTML table; the last ``numeric`` columns are right-aligned."""
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = []
    for row in rows:
        cells = [
            f'<td class="num">{_e(c)}</td>' if i >= len(row) - numeric else f"<td>{_e(c)}</td>"
            for i, c in enumerate(row)
        ]
        body.append(f"<tr>{''.join(cells)}</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def checks(dataset: xarray.Dataset) -> list[Check]:
    """The result's status, method check and time-integration check with verdicts."""
    attrs = dataset.attrs
    failed = int(np.count_nonzero(dataset["sample_failed"].values))
    found = [
        Check("status", "pass", "complete: every level is bounded")
        if attrs["status"] == "complete"
        else Check(
            "status",
            "fail",
            f"PARTIAL: {failed} samples failed; the levels they touch are not bounded",
        )
    ]
    if "method_error" in attrs:
        error, tolerance = float(attrs["method_error"]), float(attrs["method_tolerance"])
        if not np.isfinite(error):
            found.append(Check("method error", "none", "not checked: no validation run compared"))
        elif method_error_bound(attrs) == CERTIFIED:
            verdict = "pass" if error <= tolerance else "fail"
            found.append(
                Check(
                    "method error",
                    verdict,
                    f"{100 * error:.3g} % of the cut's width certified by the adaptive method "
                    f"({int(attrs['adaptive_runs'])} runs"
                    + (
                        f" with the model's gradients ({attrs['adaptive_gradients']})"
                        if attrs.get("adaptive_gradients", "none") != "none"
                        else ""
                    )
                    + f", {int(attrs['adaptive_rounds'])} "
                    f"rounds); {'within' if verdict == 'pass' else 'EXCEEDS'} the tolerance "
                    f"{100 * tolerance:.3g} %"
                    + (
                        f"; stopped by the model's own noise, about "
                        f"{100 * float(attrs['adaptive_noise']):.3g} % of the cut width "
                        "(integrate more accurately or raise method_tolerance)"
                        if attrs.get("adaptive_status") == "noise"
                        else ""
                    ),
                )
            )
        else:  # from sampled validation runs: a lower bound, never a plain pass
            runs = int(attrs.get("validation_runs", 0))
            lost = int(json.loads(attrs["provenance"]).get("method_check", {}).get("failed", 0))
            exceeds, text = sampled_method_error(error, tolerance, runs - lost, lost)
            found.append(Check("method error", "fail" if exceeds else "sampled", text))
    else:
        found.append(Check("method error", "none", "not checked (validation runs off)"))
    if "time_integration_error" in attrs:
        error = float(attrs["time_integration_error"])
        tolerance = float(attrs["time_integration_tolerance"])
        how = str(attrs.get("time_integration", ""))
        if not np.isfinite(error):
            note = attrs.get("time_integration_note", "")
            found.append(Check("time-integration error", "none", f"{how}; not checked: {note}"))
        else:
            verdict = "pass" if error <= tolerance else "fail"
            found.append(
                Check(
                    "time-integration error",
                    verdict,
                    f"{100 * error:.3g} % of the cut width ({how}; "
                    f"{int(attrs.get('time_integration_runs', 1))} samples that give the bounds "
                    f"re-run with a tenfold tighter tolerance); "
                    f"{'within' if verdict == 'pass' else 'EXCEEDS'} the "
                    f"tolerance {100 * tolerance:.3g} %",
                )
            )
    else:
        found.append(
            Check("time-integration error", "none", "not applicable (no time integration)")
        )
    return found


def reproduce_command(dataset: xarray.Dataset, directory: str | Path | None = None) -> str:
    """The command that reproduces the result.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study result.
    directory : str or Path, optional
        The result's folder, named in the template below.

    Returns
    -------
    str
        The command the CLI recorded (attribute ``command``: ``cd FOLDER && ...``, with
        the ``PYTHONPATH`` a model loaded by a module path needs;
        :func:`fuzzymbs.study.pipeline.reproducible_command`), which runs as written;
        else, for a study built in Python, the template
        ``fuzzymbs run STUDY_FILE --out DIR``.
    """
    if dataset.attrs.get("command"):
        return str(dataset.attrs["command"])
    study_file = dataset.attrs.get("study_file", "STUDY_FILE.toml")
    return f"fuzzymbs run {study_file} --out {directory or 'OUT'}"


def _inputs_section(dataset: xarray.Dataset, figures: _Figures) -> str:
    from fuzzymbs.plot import INPUTS_STEM

    units = json.loads(dataset.attrs.get("parameter_units", "{}"))
    lower, upper = dataset["parameter_lower"].values, dataset["parameter_upper"].values
    rows = []
    for i, name in enumerate(str(n) for n in dataset["parameter"].values):
        values = [lower[0, i], lower[-1, i], upper[-1, i], upper[0, i]]
        scale = engineering_scale(values, units.get(name), powers=False)  # one prefix per row
        rows.append([name, *(f"{scale(v).item():.5g} {scale.unit}".strip() for v in values)])
    table = _table(
        ["parameter", "support lower", "core lower", "core upper", "support upper"], rows, 4
    )
    figure = figures.html(INPUTS_STEM, "Membership functions of the inputs.")
    return f"<h2>Fuzzy inputs</h2>{table}{figure}"


def _cut_rows(dataset: xarray.Dataset, lower: np.ndarray, upper: np.ndarray, unit: str) -> list:
    scale = engineering_scale(np.concatenate([lower, upper]), unit, powers=False)
    complete = dataset["level_complete"].values.astype(bool)
    return [
        [
            f"{mu:.3g}" + ("" if complete[j] else " (incomplete)"),
            f"{scale(lower[j]).item():.5g} {scale.unit}".strip(),
            f"{scale(upper[j]).item():.5g} {scale.unit}".strip(),
        ]
        for j, mu in enumerate(dataset["level"].values)
    ]


def _signal_table(
    dataset: xarray.Dataset, name: str, lower: np.ndarray, upper: np.ndarray, unit: str
) -> str:
    """Per level: the band's range over the whole signal and its widest point."""
    from fuzzymbs.plot import scaled_coordinate

    dims = dataset[f"{name}_lower"].dims[1:]
    width = upper - lower
    finite = np.isfinite(width).reshape(width.shape[0], -1).any(axis=1)
    scale = engineering_scale(np.concatenate([lower.ravel(), upper.ravel()]), unit, powers=False)
    width_scale = (
        engineering_scale(width[finite], unit, powers=False) if finite.any() else Scale(1.0, unit)
    )
    rows = []
    for j, mu in enumerate(dataset["level"].values):
        if not finite[j]:
            rows.append([f"{mu:.3g}", "not bounded (incomplete level)", "", ""])
            continue
        where = np.unravel_index(int(np.nanargmax(width[j])), width[j].shape)
        at = []
        for dim, k in zip(dims, where, strict=True):
            values, coord_scale, coord_name = scaled_coordinate(dataset, dim, dataset.sizes[dim])
            at.append(f"{coord_name} = {values[k]:.4g} {coord_scale.unit}".strip())
        rows.append(
            [
                f"{mu:.3g}",
                f"[{scale(np.nanmin(lower[j])).item():.5g}, "
                f"{scale(np.nanmax(upper[j])).item():.5g}] {scale.unit}",
                f"{width_scale(width[j][where]).item():.4g} {width_scale.unit}",
                ", ".join(at),
            ]
        )
    nominal = dataset[f"{name}_nominal"].values
    note = (
        f"<p>Nominal signal (μ = 1 run) between {format_quantity(np.nanmin(nominal), unit)} "
        f"and {format_quantity(np.nanmax(nominal), unit)}.</p>"
        if np.isfinite(nominal).any()
        else ""
    )
    header = ["μ", "range of the band", "widest cut", "where"]
    return _table(header, rows) + note


def _influence_html(dataset: xarray.Dataset, name: str, figures: _Figures) -> str:
    from fuzzymbs.plot import influence_stem

    absolute = dataset[f"{name}_absolute_influence"].values
    unit = str(dataset[f"{name}_lower"].attrs.get("units", ""))
    parameters = [str(p) for p in dataset["parameter"].values]
    if absolute.ndim == 1:
        relative = dataset[f"{name}_relative_influence"].values
        rows = [
            [p, format_quantity(a, unit), f"{r:.3g}"]
            for p, a, r in zip(parameters, absolute, relative, strict=True)
        ]
        table = _table(["parameter", "absolute influence κ", "relative influence ρ"], rows, 2)
    else:
        # over a coordinate: each parameter's share of the averaged absolute influence
        means = np.nanmean(absolute.reshape(absolute.shape[0], -1), axis=1)
        shares = means / means.sum() if means.sum() > 0 else means * np.nan
        rows = [
            [p, format_quantity(m, unit), f"{s:.3g}"]
            for p, m, s in zip(parameters, means, shares, strict=True)
        ]
        table = _table(
            ["parameter", "mean absolute influence κ", "share of the mean influence"], rows, 2
        )
    if absolute.ndim > 2:
        return f"<h4>Influence</h4>{table}"
    figure = figures.html(influence_stem(name), f"Influence of the inputs on {name}.")
    return f"<h4>Influence</h4>{table}{figure}"


def _output_section(
    dataset: xarray.Dataset,
    name: str,
    memberships: Sequence[dict],
    figures: _Figures,
) -> str:
    from fuzzymbs.plot import bands_stem, membership_stem

    lower = dataset[f"{name}_lower"]
    unit = str(lower.attrs.get("units", ""))
    dims = lower.dims[1:]
    parts = [f"<h3>{_e(name)}" + (f" [{_e(unit)}]" if unit else "") + "</h3>"]
    upper = dataset[f"{name}_upper"].values
    if not dims:
        parts.append(_table(["μ", "lower", "upper"], _cut_rows(dataset, lower.values, upper, unit)))
        parts.append(figures.html(membership_stem(name), f"Membership function of {name}."))
    else:
        shape = " × ".join(f"{d} ({dataset.sizes[d]})" for d in dims)
        parts.append(f"<p>A signal over {_e(shape)}.</p>")
        parts.append(_signal_table(dataset, name, lower.values, upper, unit))
        if len(dims) == 1:
            parts.append(
                figures.html(
                    bands_stem(name),
                    f"{name}: alpha-level bands over {dims[0]}, light (μ = 0) to dark (μ = 1).",
                )
            )
        for spec in memberships:
            if spec.get("output") != name:
                continue
            coord, value = spec.get("coord"), spec.get("value")
            where = ""
            if coord is not None:
                unit = dataset[coord].attrs.get("units") if coord in dataset.coords else None
                where = f" at {coord} = {format_quantity(float(value), unit)}"
            parts.append(
                figures.html(
                    membership_stem(name, coord, value), f"Membership function of {name}{where}."
                )
            )
    if name in json.loads(dataset.attrs.get("influence_outputs", "[]")):
        parts.append(_influence_html(dataset, name, figures))
    return "".join(parts)


def _failures_section(dataset: xarray.Dataset, shown: int = 50) -> str:
    failed = np.flatnonzero(dataset["sample_failed"].values.astype(bool))
    if not failed.size:
        return "<h2>Failures</h2><p>No sample failed.</p>"
    names = [str(n) for n in dataset["parameter"].values]
    reasons = dataset["failure_reason"].values
    rows = [
        [
            int(i),
            ", ".join(
                f"{n} = {v:.6g}" for n, v in zip(names, dataset["samples"].values[i], strict=True)
            ),
            reasons[i],
        ]
        for i in failed[:shown]
    ]
    more = f"<p>… and {failed.size - shown} more.</p>" if failed.size > shown else ""
    return (
        f"<h2>Failures</h2><p>{failed.size} of {dataset.sizes['sample']} samples failed.</p>"
        + _table(["sample", "parameters", "reason"], rows)
        + more
    )


def _provenance_section(dataset: xarray.Dataset, command: str) -> str:
    attrs = dataset.attrs
    provenance = json.loads(attrs["provenance"])
    plan = provenance.get("plan", {})
    rows = [
        ["study", attrs.get("study_name", "")],
        ["study file", attrs.get("study_file", "(built in Python)")],
        ["model", attrs.get("model", "")],
        ["model options", json.dumps(provenance.get("model_options", {}))],
        ["crisp parameters", json.dumps(provenance.get("constants", {}))],
        ["method", f"{attrs.get('method', '')}, levels {plan.get('levels', '')}"],
        ["plan fingerprint (store identity)", provenance.get("plan_fingerprint", "")],
        ["code", json.dumps(provenance.get("code", {}))],
        [
            "samples",
            f"{provenance.get('samples')} (evaluated {provenance.get('evaluated')}, "
            f"reused from the store {provenance.get('reused_from_store')}, "
            f"failed {provenance.get('failed')})",
        ],
        [
            "executor",
            f"{provenance.get('executor')}, chunk size {provenance.get('chunk_size')}, "
            f"wall time {float(provenance.get('wall_time_s', float('nan'))):.3g} s",
        ],
        ["created", provenance.get("created", "")],
    ]
    versions = provenance.get("versions", {})
    return (
        "<h2>Provenance</h2>"
        + _table(["", ""], rows)
        + "<h3>Versions</h3>"
        + _table(["package", "version"], sorted(versions.items()))
        + "<h3>Reproduce</h3>"
        + f"<pre><code>{_e(command)}</code></pre>"
    )


def render_report(
    dataset: xarray.Dataset,
    directory: str | Path | None = None,
    images: Mapping[str, bytes] | None = None,
) -> str:
    """The HTML report of a study result.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study result (layout in :mod:`fuzzymbs.study.result`).
    directory : str or Path, optional
        The result's folder, used in the reproduce command when the result
        does not record the command that made it.
    images : mapping of str to bytes, optional
        PNG images of the standard figures already drawn, by file stem
        (:func:`fuzzymbs.plot.standard_figures`): embedded as they are instead of
        drawn again. Figures not in it are drawn.

    Returns
    -------
    str
        A complete HTML document without external resources.
    """
    attrs = dataset.attrs
    title = str(attrs.get("description") or attrs.get("study_name", "fuzzymbs study"))
    outputs = json.loads(attrs["outputs"])
    memberships = json.loads(attrs.get("plots", "{}")).get("membership", [])
    command = reproduce_command(dataset, directory)
    rows = "".join(
        f'<tr class="{c.verdict}"><td>{_e(c.name)}</td>'
        f'<td class="verdict">{_VERDICTS[c.verdict]}</td>'
        f"<td>{_e(c.text)}</td></tr>"
        for c in checks(dataset)
    )
    provenance = json.loads(attrs["provenance"])
    warnings = provenance.get("warnings", [])
    version = attrs.get("fuzzymbs_version") or provenance.get("versions", {}).get("fuzzymbs", "")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{_e(title)}</h1>",
        f'<p class="meta">Study <code>{_e(attrs.get("study_name", ""))}</code> · model '
        f"<code>{_e(attrs.get('model', ''))}</code> · method {_e(attrs.get('method', ''))} · "
        f"fuzzymbs {_e(version)}</p>",
        "<h2>Checks</h2>",
        f"<table><tr><th>check</th><th>verdict</th><th>detail</th></tr>{rows}</table>",
    ]
    if warnings:
        items = "".join(f"<li>{_e(w)}</li>" for w in warnings)
        parts.append(f"<h3>Warnings</h3><ul>{items}</ul>")
    from fuzzymbs.plot import standard_figures

    standard = {figure.stem: figure for figure in standard_figures(dataset, memberships)}
    figures = _Figures(standard, images or {})
    parts.append(_inputs_section(dataset, figures))
    parts.append("<h2>Outputs</h2>")
    parts += [_output_section(dataset, name, memberships, figures) for name in outputs]
    parts.append(_failures_section(dataset))
    parts.append(_provenance_section(dataset, command))
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def write_report(
    dataset: xarray.Dataset, path: str | Path, images: Mapping[str, bytes] | None = None
) -> Path:
    """Write :func:`render_report` of ``dataset`` (embedding ``images``, PNG by file stem,
    where given) to ``path`` (UTF-8); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(render_report(dataset, path.parent, images), encoding="utf-8")
    return path
