"""The HTML report: content, verdicts, no external resources, and a real browser renders it."""

import base64
import re
import shutil
import subprocess

import numpy as np
import pytest

from fuzzymbs import Triangular
from fuzzymbs.report import checks, render_report, write_report
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
        description="free vibration of a damped oscillator",
    )
    return study.run(progress=False).dataset


def _images(page: str) -> list[bytes]:
    return [base64.b64decode(d) for d in re.findall(r'src="data:image/png;base64,([^"]+)"', page)]


def test_report_holds_every_section_and_only_embedded_resources(oscillator, tmp_path):
    path = write_report(oscillator, tmp_path / "report.html")
    page = path.read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") and page.rstrip().endswith("</html>")
    assert "<title>free vibration of a damped oscillator</title>" in page
    for heading in ("Checks", "Fuzzy inputs", "Outputs", "Failures", "Provenance"):
        assert f"<h2>{heading}</h2>" in page
    # inputs in engineering units: the stiffness support is 900 to 1100 N/m, mass in kg
    assert "<td>stiffness</td>" in page and "1.1 kN/m" in page
    # figures: inputs, displacement bands + influence, natural frequency membership + influence
    images = _images(page)
    assert len(images) == 5 and all(image.startswith(b"\x89PNG") for image in images)
    # nothing is fetched: no script, no link, no URL in a src, href or CSS url()
    assert not re.search(r"<script|<link|(src|href)=\"(?!data:)|url\(|@import", page)
    assert "fuzzymbs run STUDY_FILE.toml --out" in page  # built in Python: a template
    assert "No sample failed." in page


def test_verdicts_against_the_tolerances(oscillator):
    dataset = oscillator.copy()
    dataset.attrs.update(
        {
            "method_error": 0.004,
            "method_tolerance": 0.01,
            "validation_runs": 3,
            "time_integration_error": 0.02,
            "time_integration_tolerance": 0.01,
            "time_integration": "ros34pw2, rtol 0.01",
            "time_integration_note": "",
        }
    )
    found = {check.name: check for check in checks(dataset)}
    assert found["status"].verdict == "pass"
    # from 3 sampled validation runs: a lower bound, never a plain pass
    method = found["method error"]
    assert method.verdict == "sampled" and "at least 0.4 % of the cut width" in method.text
    assert "(from 3 sampled validation runs)" in method.text
    integration = found["time-integration error"]
    assert integration.verdict == "fail" and "2 % of the cut width" in integration.text
    assert "EXCEEDS the tolerance 1 %" in integration.text
    assert '<tr class="fail"><td>time-integration error</td>' in render_report(dataset)
    dataset.attrs["method_error"] = np.nan
    assert {c.name: c for c in checks(dataset)}["method error"].verdict == "none"
    del dataset.attrs["time_integration_error"]
    assert {c.name: c for c in checks(dataset)}["time-integration error"].verdict == "none"


def test_partial_result_reports_its_failures(tmp_path):
    study = Study(
        "damped-oscillator",
        {"mass": Triangular(-0.2, 1.0, 1.5)},
        levels=3,
        model_options={"time_steps": 21, "duration": 0.1},
    )
    dataset = study.run(progress=False, on_failure="partial").dataset
    page = render_report(dataset)
    assert '<tr class="fail"><td>status</td>' in page
    failed = int(dataset["sample_failed"].sum())
    assert f"{failed} of {dataset.sizes['sample']} samples failed" in page
    assert "not bounded (incomplete level)" in page


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _chromium(page, tmp_path, *arguments):
    """Run headless Chromium on the file ``page``; returns (stdout, stderr)."""
    command = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--enable-logging=stderr",
        "--v=0",
        *arguments,
        page.as_uri(),
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    return done.stdout, done.stderr


def _console_errors(stderr: str) -> list[str]:
    # Chromium logs the page's console as ":CONSOLE(line)]" records; JS errors as "Uncaught"
    return [
        line
        for line in stderr.splitlines()
        if ("CONSOLE" in line and ("error" in line.lower() or "Uncaught" in line))
        or "Not allowed to load local resource" in line
    ]


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (apt-get install chromium)")
def test_chromium_renders_the_report_without_console_errors(oscillator, tmp_path):
    from matplotlib.image import imread

    # the check can fail: a page with a script error is caught
    broken = tmp_path / "broken.html"
    broken.write_text("<html><body><script>console.error('boom'); nope();</script></body></html>")
    assert _console_errors(_chromium(broken, tmp_path, "--dump-dom")[1])

    page = write_report(oscillator, tmp_path / "report.html")
    dom, stderr = _chromium(page, tmp_path, "--dump-dom")
    assert "Fuzzy inputs" in dom and "Provenance" in dom
    assert _console_errors(stderr) == []
    screenshot = tmp_path / "screenshot.png"
    _chromium(page, tmp_path, f"--screenshot={screenshot}", "--window-size=1000,1800")
    pixels = imread(screenshot)[..., :3]
    # not blank: dark text and the blue bands cover a share of the page, in several colours
    ink = (pixels.sum(axis=-1) < 2.4).mean()
    assert 0.02 < ink < 0.8, ink
    assert len(np.unique((pixels * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 50
