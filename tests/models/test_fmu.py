"""FMU models (fuzzymbs.models.external.fmu) with real FMUs built from C in the tests.

The FMUs are the example damped oscillator (examples/fmu): m x'' + c x' + k x = F,
x(0) = x0, x'(0) = 0, compiled for FMI 2.0 and 3.0 with FMPy's FMI headers. Its
co-simulation interface steps the closed-form solution, so a study of it must equal the
same model written as a NumPy callable to rounding; model exchange integrates the ODE
with FMPy's CVODE, so there the reference is the closed form within CVODE's error.
"""

import hashlib
import importlib.util
import re
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fuzzymbs import Study
from fuzzymbs.cli import app
from fuzzymbs.errors import InvalidParameterError, UntrustedCodeError
from fuzzymbs.models.external import fmu as fmu_module
from fuzzymbs.models.external.fmu import FmuModel, describe_fmu
from fuzzymbs.study.integration_check import TimeIntegrationWarning
from fuzzymbs.study.pipeline import run_study_file
from fuzzymbs.study.studyfile import load_study_file

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "fmu"
PARAMETERS = {
    "k": {"type": "triangular", "modal": 100.0, "spread": 0.1},
    "c": {"type": "triangular", "modal": 0.4, "spread": 0.25},
}
INTERFACES = ["co-simulation", "model-exchange"]
STOP, INTERVAL = 0.25, 0.0025  # 101 points: the first quarter period (x monotonic in k, c)


def _build_module():
    spec = importlib.util.spec_from_file_location(
        "build_oscillator_fmu", EXAMPLES / "build_oscillator_fmu.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def fmus(tmp_path_factory):
    """{2: FMI 2.0 FMU, 3: FMI 3.0 FMU}, each with co-simulation and model exchange."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler (cc) to build the test FMUs")
    folder = tmp_path_factory.mktemp("fmus")
    build = _build_module().build
    return {version: build(folder / f"oscillator{version}.fmu", version) for version in (2, 3)}


class ClosedFormOscillator:
    """The same oscillator as a batched NumPy model (the independent reference)."""

    def __init__(self, time):
        self.coords = {"time": np.asarray(time)}

    def __call__(self, samples):
        k, c = samples["k"][:, None], samples["c"][:, None]
        m, x0, force = 1.0, 0.01, 0.0  # the FMU's start values
        t = self.coords["time"][None, :]
        sigma = c / (2.0 * m)
        wd = np.sqrt(k / m - sigma**2)
        static = force / k
        decay = np.exp(-sigma * t)
        x = static + (x0 - static) * decay * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))
        return {"x": x}


def _grid():
    return INTERVAL * np.arange(round(STOP / INTERVAL) + 1)


def _fmu_study(path, **options):
    return Study(
        "fmu",
        PARAMETERS,
        method="reduced",
        levels=4,
        outputs=["x"],
        model_options={"path": path, "stop_time": STOP, "output_interval": INTERVAL, **options},
        validation_runs=0,
    )


def _reference_result():
    study = Study(ClosedFormOscillator(_grid()), PARAMETERS, "reduced", 4, ["x"], validation_runs=0)
    return study.run(progress=False)


@pytest.mark.parametrize("version", [2, 3])
def test_co_simulation_study_equals_the_callable(fmus, version):
    result = _fmu_study(fmus[version], interface="co-simulation").run(progress=False)
    reference = _reference_result()
    np.testing.assert_allclose(result.dataset["time"].values, _grid(), rtol=0, atol=1e-15)
    for bound in ("x_lower", "x_upper"):
        # same closed form in C and NumPy: equal to rounding (1e-12 of the 0.01 m amplitude)
        np.testing.assert_allclose(
            result.dataset[bound].values, reference.dataset[bound].values, rtol=0, atol=1e-14
        )
    assert result.dataset["x_lower"].attrs.get("units", "m") == "m"
    # a co-simulation FMU integrating in closed form: the tightened rerun changes nothing
    assert result.dataset.attrs["time_integration_error"] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("version", [2, 3])
def test_model_exchange_study_within_cvode_error(fmus, version):
    result = _fmu_study(fmus[version], interface="model-exchange").run(progress=False)
    reference = _reference_result()
    peak = 0.01
    error = max(
        np.abs(result.dataset[b].values - reference.dataset[b].values).max() / peak
        for b in ("x_lower", "x_upper")
    )
    # CVODE at rtol 1e-6: measured 4e-5 of the peak (docs/studies.md, "FMU models");
    # the bound 2e-4 leaves room for other CVODE builds
    assert error < 2e-4
    # the study's own peak-relative estimate (rerun at rtol 1e-7) is of the same size as
    # the true error of its modal sample: within a factor 3 either way
    model = FmuModel(fmus[version], STOP, INTERVAL, interface="model-exchange")
    modal = {"k": np.array([100.0]), "c": np.array([0.4])}
    true_error = np.abs(model(modal)["x"][0] - ClosedFormOscillator(_grid())(modal)["x"][0]).max()
    estimate = result.dataset.attrs["time_integration_error_peak"]
    assert true_error / peak / 3.0 < estimate < 3.0 * true_error / peak
    assert "CVODE" in result.dataset.attrs["time_integration"]


def test_coarse_model_exchange_warns_about_its_error(fmus):
    study = _fmu_study(fmus[2], interface="model-exchange", solver_tolerance=1e-3)
    with pytest.warns(TimeIntegrationWarning):
        result = study.run(progress=False)
    # on the scale of the cut width (the band-relative figure), well above 1 %
    assert result.dataset.attrs["time_integration_error"] > 0.01


def test_process_pool_gives_the_inline_result(fmus):
    study = _fmu_study(fmus[2], interface="co-simulation")
    inline = study.run(progress=False, chunk_size=4)
    pooled = study.run(executor="processes:2", progress=False, chunk_size=4)
    for bound in ("x_lower", "x_upper"):
        np.testing.assert_array_equal(pooled.dataset[bound].values, inline.dataset[bound].values)


def test_one_instance_per_thread_reset_between_samples(fmus, monkeypatch):
    import fmpy

    created = []
    original = fmpy.instantiate_fmu

    def counting(*args, **kwargs):
        created.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(fmpy, "instantiate_fmu", counting)
    monkeypatch.setattr(fmu_module, "_local", threading.local())  # a fresh per-thread cache
    study = _fmu_study(fmus[3], interface="co-simulation")
    result = study.run(progress=False, chunk_size=5)
    assert result.dataset.sizes["sample"] == 17 and len(created) == 1  # 4 chunks, 1 instance
    # reset between samples leaves nothing behind: the result equals the callable's
    reference = _reference_result()
    np.testing.assert_allclose(
        result.dataset["x_upper"].values, reference.dataset["x_upper"].values, atol=1e-14
    )


@pytest.mark.parametrize("interface", ["co-simulation", "model-exchange"])
def test_failed_sample_has_the_fmu_log_and_later_samples_are_fine(fmus, interface):
    model = FmuModel(fmus[2], STOP, INTERVAL, interface=interface)
    samples = {"k": np.array([100.0, -1.0, 120.0]), "c": np.array([0.4, 0.4, 0.5])}
    out = model(samples)
    np.testing.assert_array_equal(out["failed"], [False, True, False])
    reason = out["failure_reason"][1]
    assert "oscillator2.fmu" in reason and "stiffness k = -1 must be positive" in reason
    assert out["failure_reason"][0] == out["failure_reason"][2] == ""
    assert np.isnan(out["x"][1]).all()
    valid = {name: values[[0, 2]] for name, values in samples.items()}
    reference = ClosedFormOscillator(_grid())(valid)["x"]
    tolerance = 1e-14 if interface == "co-simulation" else 2e-6  # 2e-4 of the 0.01 m peak
    np.testing.assert_allclose(out["x"][[0, 2]], reference, rtol=0, atol=tolerance)


def test_failures_reach_the_study(fmus):
    study = Study(
        "fmu",
        {"k": {"type": "triangular", "modal": 1.0, "spread": 2.0}, "c": 0.1},
        "reduced",
        2,
        ["x"],
        model_options={"path": fmus[2], "stop_time": STOP, "output_interval": INTERVAL},
        validation_runs=0,
    )
    result = study.run(progress=False, on_failure="partial")
    assert result.failed.any() and not result.failed.all()
    reasons = result.dataset["failure_reason"].values[result.failed]
    assert all("must be positive" in str(reason) for reason in reasons)


@pytest.mark.parametrize(
    ("name", "fragment"),
    [
        ("stiffness", "has no variable 'stiffness'; its settable real parameters: m [kg]"),
        ("x", "variable 'x' is a variable of causality 'output', not a parameter"),
        ("order", "variable 'order' is of type Integer; only real parameters"),
        ("omega0", "variable 'omega0' is a variable of causality 'calculatedParameter'"),
    ],
)
def test_parameters_that_cannot_be_fuzzy_are_refused(fmus, name, fragment):
    with pytest.raises(InvalidParameterError, match=re.escape(fragment)):
        Study(
            "fmu",
            {name: {"type": "triangular", "modal": 1.0, "spread": 0.1}},
            model_options={"path": fmus[2], "stop_time": STOP, "output_interval": INTERVAL},
        )


def test_description_units_and_info(fmus):
    description = describe_fmu(fmus[3])
    assert description.fmi_version.startswith("3.")
    assert description.interfaces == ("co-simulation", "model-exchange")
    assert list(description.parameters) == ["m", "c", "k", "x0", "F"]
    assert description.parameters["k"].unit == "N/m" and description.outputs["v"].unit == "m/s"
    result = CliRunner().invoke(app, ["info", str(fmus[3])])
    assert result.exit_code == 0, result.output
    assert "k [N/m]: stiffness (start 100)" in result.output
    assert "x [m]: displacement" in result.output


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"stop_time": 0.0}, "stop_time = 0.0 must be after start_time"),
        ({"output_interval": -1.0}, "output_interval must be positive"),
        ({"output_interval": 0.003}, "whole multiple of output_interval"),
        ({"step_size": 0.001}, "whole multiple of step_size"),
        ({"solver_tolerance": float("nan")}, "solver_tolerance must be finite"),
        ({"interface": "hybrid"}, "interface = 'hybrid'; allowed: auto, co-simulation"),
        ({"outputs": ["y"]}, "no output variable(s) ['y']; its outputs: x, v"),
        ({"path": "missing.fmu"}, "missing.fmu not found"),
    ],
)
def test_bad_options_are_refused(fmus, options, fragment):
    arguments = {"path": fmus[2], "stop_time": STOP, "output_interval": INTERVAL, **options}
    with pytest.raises(InvalidParameterError, match=re.escape(fragment)):
        FmuModel(**arguments)


def test_not_an_fmu_is_refused(tmp_path):
    bogus = tmp_path / "bogus.fmu"
    bogus.write_bytes(b"not a zip archive")
    with pytest.raises(InvalidParameterError, match=r"bogus\.fmu is not a readable FMU"):
        describe_fmu(bogus)


def _study_file(folder, fmu):
    shutil.copy(fmu, folder / "oscillator.fmu")
    text = (EXAMPLES / "oscillator-fmu.toml").read_text()
    (folder / "study.toml").write_text(text)
    return folder / "study.toml"


def test_study_file_needs_allow_code_and_resolves_paths(fmus, tmp_path):
    study_file = _study_file(tmp_path, fmus[2])
    with pytest.raises(UntrustedCodeError) as refused:
        load_study_file(study_file)
    message = str(refused.value)
    assert f"the FMU {tmp_path / 'oscillator.fmu'}" in message
    assert "--allow-code" in message and "trust file" in message
    # allowed: the relative path is the study file's folder's, not the working directory's
    written = run_study_file(
        study_file, tmp_path / "out", progress=False, plots=False, allow_code=True
    )
    assert written.result_path.is_file()
    reference = _reference_result()  # the example's parameters, levels and grid
    np.testing.assert_allclose(
        written.result.dataset["x_lower"].values, reference.dataset["x_lower"].values, atol=1e-14
    )


def test_trust_file_by_sha256(fmus, tmp_path, monkeypatch):
    study_file = _study_file(tmp_path, fmus[2])
    trusted = tmp_path / "trusted.toml"
    sha = hashlib.sha256((tmp_path / "oscillator.fmu").read_bytes()).hexdigest()
    trusted.write_text(f'fmus = ["{sha}"]\n')
    monkeypatch.setenv("FUZZYMBS_TRUST_FILE", str(trusted))
    assert load_study_file(study_file).study.model_name == "fmu"
    # another FMU under the same name is not trusted by that digest
    (tmp_path / "oscillator.fmu").write_bytes(Path(fmus[3]).read_bytes())
    with pytest.raises(UntrustedCodeError):
        load_study_file(study_file)


def test_each_instance_keeps_its_own_log(fmus):
    # FMPy routes FMI 2.0 log messages through one process-wide proxy; two instances of
    # one FMU in a thread (co-simulation and model exchange) must each report their own
    failing = {"k": np.array([-1.0]), "c": np.array([0.4])}
    models = [FmuModel(fmus[2], STOP, INTERVAL, interface=i) for i in INTERFACES * 2]
    for model in models:
        reason = model(failing)["failure_reason"][0]
        assert reason.endswith("(FMU log: [ERROR] stiffness k = -1 must be positive)"), reason
