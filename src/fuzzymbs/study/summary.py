"""Plain-text summary of a study result (``summary.txt``)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from fuzzymbs.fuzzy.band_scale import CERTIFIED, LOWER_BOUND

if TYPE_CHECKING:  # pragma: no cover
    import xarray


def _fmt(value: float) -> str:
    return "nan" if not np.isfinite(value) else f"{value:.6g}"


def method_error_bound(attrs: Mapping[str, Any]) -> str:
    """What a result's ``method_error`` is: ``"lower"`` (a lower bound from sampled
    validation runs: the fixed methods) or ``"certified"`` (the adaptive method).

    Parameters
    ----------
    attrs : mapping
        The result dataset's attributes.

    Returns
    -------
    str
        The attribute ``method_error_bound``; for a result written before it, certified
        for the adaptive method and a lower bound for every other.
    """
    if "method_error_bound" in attrs:
        return str(attrs["method_error_bound"])
    return CERTIFIED if "adaptive_runs" in attrs else LOWER_BOUND


def sampled_method_error(
    error: float, tolerance: float, compared: int, failed: int = 0
) -> tuple[bool, str]:
    """The words for a method error found by sampled validation runs.

    A sample can show a miss but not its absence, so the error reads "at least", and a
    result within the tolerance is what the sample showed, never a plain pass.

    Parameters
    ----------
    error, tolerance : float
        The method error and the study's ``method_tolerance`` (cut-width scale).
    compared : int
        Validation runs compared with the cuts; failed : int, those that failed besides.

    Returns
    -------
    exceeds : bool
        The error is above the tolerance (then the method fails it for certain).
    text : str
        "at least X % of the cut width (from N sampled validation runs)" and the verdict.
    """
    exceeds = bool(error > tolerance)
    more = f"; {failed} more failed" if failed else ""
    found = (
        f"at least {100 * error:.3g} % of the cut width "
        f"(from {compared} sampled validation runs{more})"
    )
    if exceeds:
        return True, f"{found}, EXCEEDS the tolerance {100 * tolerance:.3g} %"
    return False, (
        f"{found}; no miss above the tolerance {100 * tolerance:.3g} % in {compared} "
        "sampled points (a lower bound; the error can be larger)"
    )


def _adaptive_line(attrs: dict) -> str:
    """The adaptive method's line: runs, rounds, certified error against the tolerance."""
    error = float(attrs["method_error"])
    tolerance = float(attrs["method_tolerance"])
    verdict = "within" if error <= tolerance else "EXCEEDS"
    stopped = "" if int(attrs["method_converged"]) else " (stopped at its run budget max_runs)"
    if attrs.get("adaptive_status") == "noise":
        stopped = (
            f" (stopped by the model's own noise, about {100 * float(attrs['adaptive_noise']):.3g} "
            "% of the cut width: integrate more accurately or raise method_tolerance)"
        )
    gradients = attrs.get("adaptive_gradients", "none")
    used = "" if gradients == "none" else f" with the model's gradients ({gradients})"
    scope = " (global: the surrogate wherever checked)"
    scope = scope if attrs.get("adaptive_certify") == "global" else ""
    return (
        f"Method check: adaptive, {int(attrs['adaptive_runs'])} runs{used} in "
        f"{int(attrs['adaptive_rounds'])} rounds{stopped}; certified{scope} method error "
        f"{100 * error:.3g} % of the cut's width, {verdict} the tolerance {100 * tolerance:.3g} %"
    )


def _method_line(attrs: dict, provenance: dict) -> str:
    """The method check's line: validation runs, method error, worst point."""
    if method_error_bound(attrs) == CERTIFIED:
        return _adaptive_line(attrs)
    check = provenance.get("method_check", {})
    runs = int(attrs["validation_runs"])
    failed = int(check.get("failed", 0))
    error = float(attrs["method_error"])
    tolerance = float(attrs["method_tolerance"])
    head = f"Method check: {runs} validation runs" + (f" ({failed} failed)" if failed else "")
    if not np.isfinite(error):
        return f"{head}; NOT CHECKED: no validation run could be compared"
    _, text = sampled_method_error(error, tolerance, runs - failed, failed)
    line = f"Method check: method error {text}"
    worst = check.get("worst")
    if worst and error > 0:
        where = ", ".join(f"{k}={_fmt(v)}" for k, v in worst["parameters"].items())
        line += f" (output {worst['output']}, mu = {_fmt(worst['level'])}, at {where})"
    if check.get("widened"):
        line += "; bounds widened with the validation outputs"
    return line


def summarize(dataset: xarray.Dataset) -> str:
    """Summarise a study result: setup, status, cuts, influence, failures.

    Parameters
    ----------
    dataset : xarray.Dataset
        A study result (layout in :mod:`fuzzymbs.study.result`).

    Returns
    -------
    str
        Several lines of text, ending with a newline.
    """
    attrs = dataset.attrs
    provenance = json.loads(attrs["provenance"])
    outputs = json.loads(attrs["outputs"])
    units = json.loads(attrs.get("parameter_units", "{}"))
    levels = dataset["level"].values
    complete = dataset["level_complete"].values.astype(bool)
    failed = dataset["sample_failed"].values.astype(bool)
    lines = [f"Study: {attrs['study_name']}"]
    if attrs.get("description"):
        lines.append(f"  {attrs['description']}")
    lines += [
        f"Model: {attrs['model']}"
        + (
            f"  options: {json.dumps(provenance['model_options'])}"
            if provenance["model_options"]
            else ""
        ),
        f"Method: {attrs['method']}  levels mu = {', '.join(_fmt(m) for m in levels)}",
        f"Samples: {provenance['samples']} (evaluated now: {provenance['evaluated']}, "
        f"reused from store: {provenance['reused_from_store']}, failed: {provenance['failed']})",
        f"Executor: {provenance['executor']}  chunk size: {provenance['chunk_size']}  "
        f"wall time: {provenance['wall_time_s']:.3g} s",
    ]
    if provenance.get("judging_from_store"):  # what no run made again this time
        taken = ", ".join(provenance["judging_from_store"]).replace("-", " ")
        lines.append(f"From the store, not run again: {taken}")
    screening = provenance.get("screening")
    if screening is not None:  # nonmonotonic="auto"
        found = ", ".join(screening["nonmonotonic"]) or "none"
        lines.append(
            f"Screening: {screening['runs']} runs along each parameter's axis; "
            f"non-monotonic: {found}"
        )
    if "time_integration_error" in attrs:
        error = float(attrs["time_integration_error"])
        tolerance = float(attrs["time_integration_tolerance"])
        if np.isfinite(error):
            verdict = "within" if error <= tolerance else "EXCEEDS"
            runs = int(attrs.get("time_integration_runs", 1))
            peak = float(attrs.get("time_integration_error_peak", np.nan))
            reference = float(attrs.get("time_integration_reference_error", np.nan))
            extra = ""
            if np.isfinite(reference):  # shared steps: the modal sample has no error left
                extra = f", of which the reference run's error {100 * reference:.2g} %"
            elif np.isfinite(peak):
                extra = f"; {100 * peak:.2g} % of the peak at the modal sample"
            lines.append(
                f"Time integration: {attrs['time_integration']}; error {100 * error:.3g} % of "
                f"the cut width ({runs} samples that give the bounds re-run with a tenfold "
                f"tighter tolerance{extra}), "
                f"{verdict} the study's tolerance {100 * tolerance:.3g} %"
            )
        else:
            lines.append(
                f"Time integration: {attrs['time_integration']}; NOT CHECKED: "
                f"{attrs['time_integration_note']}"
            )
        factor = float(attrs.get("integration_tolerance_factor", 1.0))
        if "integration_pilot_runs" in attrs and int(attrs["integration_pilot_runs"]) > 0:
            pilot = float(attrs["integration_pilot_error"])
            chosen = f"tightened {factor:.3g} times" if factor > 1 else "kept"
            if attrs.get("integration_choice_note"):
                chosen += f" ({attrs['integration_choice_note']})"
            measured = float(attrs.get("integration_measured_error", np.nan))
            tenth = f", {100 * measured:.3g} % measured at a tenth of it"
            tenth = tenth if np.isfinite(measured) else ""
            lines.append(
                f"Integrator tolerance chosen by a pilot of {int(attrs['integration_pilot_runs'])}"
                f" runs: {100 * pilot:.3g} % of the cut width expected at the model's own{tenth}, "
                f"so {chosen}"
            )
    if "method_error" in attrs:
        lines.append(_method_line(attrs, provenance))
    if attrs["status"] == "complete":
        lines.append("Status: complete")
    else:
        missing = ", ".join(_fmt(m) for m in levels[~complete])
        lines.append(
            f"Status: PARTIAL - {int(failed.sum())} samples failed; levels mu = {missing} "
            "are NOT bounded (NaN); influence measures omitted"
        )
    lines.append("")
    lines.append("Fuzzy parameters (support / core):")
    lower = dataset["parameter_lower"].values
    upper = dataset["parameter_upper"].values
    for i, name in enumerate(dataset["parameter"].values):
        unit = f" [{units[name]}]" if name in units else ""
        lines.append(
            f"  {name}{unit}: [{_fmt(lower[0, i])}, {_fmt(upper[0, i])}] / "
            f"[{_fmt(lower[-1, i])}, {_fmt(upper[-1, i])}]"
        )
    lines.append("")
    influence_outputs = set(json.loads(attrs.get("influence_outputs", "[]")))
    for name in outputs:
        lo = dataset[f"{name}_lower"]
        hi = dataset[f"{name}_upper"]
        unit = lo.attrs.get("units")
        label = f"{name}" + (f" [{unit}]" if unit else "")
        dims = lo.dims[1:]
        if not dims:
            lines.append(f"Output {label}: alpha-cuts")
            lines.append(f"  {'mu':>8}  {'lower':>14}  {'upper':>14}")
            for j, mu in enumerate(levels):
                mark = "" if complete[j] else "  (incomplete)"
                lines.append(
                    f"  {_fmt(mu):>8}  {_fmt(lo.values[j]):>14}  {_fmt(hi.values[j]):>14}{mark}"
                )
        else:
            shape = " x ".join(f"{d} ({dataset.sizes[d]})" for d in dims)
            lines.append(f"Output {label} over {shape}:")
            known = np.flatnonzero(complete)
            if known.size:
                j = int(known[0])  # the widest level with known bounds
                width = hi.values[j] - lo.values[j]
                where = np.unravel_index(int(np.nanargmax(width)), width.shape)
                at = ", ".join(
                    f"{d} = {_fmt(float(dataset[d].values[k]))}"
                    if d in dataset.coords
                    else f"{d} index {k}"
                    for d, k in zip(dims, where, strict=True)
                )
                what = (
                    "support (mu = 0)"
                    if j == 0
                    else f"lowest complete level mu = {_fmt(levels[j])}"
                )
                lines.append(
                    f"  {what} spans [{_fmt(np.nanmin(lo.values[j]))}, "
                    f"{_fmt(np.nanmax(hi.values[j]))}]; widest at {at}: "
                    f"[{_fmt(lo.values[j][where])}, {_fmt(hi.values[j][where])}]"
                )
                nominal = dataset[f"{name}_nominal"].values
                if np.isfinite(nominal).any():
                    lines.append(
                        f"  nominal (mu = 1) spans [{_fmt(np.nanmin(nominal))}, "
                        f"{_fmt(np.nanmax(nominal))}]"
                    )
        if name in influence_outputs:
            absolute = dataset[f"{name}_absolute_influence"].values
            if absolute.ndim == 1:
                relative = dataset[f"{name}_relative_influence"].values
                header = "relative influence rho"
            else:
                # over a coordinate: share of each parameter in the averaged absolute influence
                totals = np.nanmean(absolute.reshape(absolute.shape[0], -1), axis=1)
                # an output of zero width: no parameter has influence (0, as rho of a scalar)
                relative = totals / totals.sum() if totals.sum() > 0 else np.zeros_like(totals)
                header = "share of the coordinate-averaged absolute influence"
            pairs = ", ".join(
                f"{p} {_fmt(r)}" for p, r in zip(dataset["parameter"].values, relative, strict=True)
            )
            lines.append(f"  {header}: {pairs}")
        lines.append("")
    if failed.any():
        lines.append("Failed samples:")
        reasons = dataset["failure_reason"].values
        indices = np.flatnonzero(failed)
        names = dataset["parameter"].values
        for i in indices[:20]:
            point = ", ".join(
                f"{n}={_fmt(v)}" for n, v in zip(names, dataset["samples"].values[i], strict=True)
            )
            lines.append(f"  sample {i} ({point}): {reasons[i]}")
        if len(indices) > 20:
            lines.append(f"  ... and {len(indices) - 20} more")
        lines.append("")
    if provenance.get("warnings"):
        lines.append("Warnings:")
        lines += [f"  {w}" for w in provenance["warnings"]]
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"
