"""A study file is data: code its author named runs only when its user allows it.

fuzzymbs.study.trust: module references, FMUs and programs named in a study file need
``--allow-code`` (``allow_code=True``) or an entry in the user's trust file; registered
models, including those of installed packages (entry-point group ``fuzzymbs.models``),
run as they are. tests/conftest.py points the trust file at a file that does not exist.
"""

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fuzzymbs.cli import app
from fuzzymbs.errors import StudyFileError, UntrustedCodeError
from fuzzymbs.study import registry
from fuzzymbs.study.pipeline import run_study_file
from fuzzymbs.study.studyfile import load_study_file
from fuzzymbs.study.trust import Trusted, trust_file

COMMAND_EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "command"

# a hostile study file: a bare module reference would run os.system("touch SOMEFILE")
HOSTILE = """
[study]
name = "innocent"
method = "reduced"
levels = 2

[model]
name = "os:system"

[model.options]
command = "touch SOMEFILE"

[parameters]
x = { type = "triangular", modal = 1.0, spread = 0.1 }
"""

PRODUCT_BY_REFERENCE = """
[study]
name = "product-by-reference"
method = "reduced"
levels = 2

[model]
name = "fuzzymbs.models.closed_form:make_product"

[parameters]
x1 = { type = "triangular", modal = 2.0, spread = 0.1 }
x2 = 10.0
"""


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_module_reference_is_refused_before_anything_runs(in_tmp):
    study_file = in_tmp / "study.toml"
    study_file.write_text(HOSTILE)
    with pytest.raises(UntrustedCodeError) as refused:
        load_study_file(study_file)
    assert not (in_tmp / "SOMEFILE").exists()
    message = str(refused.value)
    assert message.startswith(f"{study_file}: this study file would run the Python callable")
    assert "'os:system' (imports module 'os' and calls it)" in message
    assert f"fuzzymbs run --allow-code {study_file}" in message
    assert f"add 'os' to modules in your trust file {trust_file()}" in message
    assert isinstance(refused.value, StudyFileError)  # a ValueError naming the input


def test_cli_refuses_with_exit_status_1_and_the_message(in_tmp):
    study_file = in_tmp / "study.toml"
    study_file.write_text(HOSTILE)
    result = CliRunner().invoke(app, ["run", str(study_file), "--out", str(in_tmp / "out")])
    assert result.exit_code == 1
    assert "would run the Python callable 'os:system'" in result.output
    assert "--allow-code" in result.output
    assert not (in_tmp / "SOMEFILE").exists() and not (in_tmp / "out" / "result.nc").exists()


def test_allowed_module_reference_runs(in_tmp):
    study_file = in_tmp / "study.toml"
    study_file.write_text(PRODUCT_BY_REFERENCE)
    written = run_study_file(
        study_file, in_tmp / "out", progress=False, plots=False, allow_code=True
    )
    lower, upper = written.result.alpha_cut("z", 0.0)
    # z = x1 * 10 with x1 in [1.8, 2.2] at mu = 0 (spread 0.1 of 2): exact in binary to 1e-12
    assert (float(lower), float(upper)) == pytest.approx((18.0, 22.0), rel=1e-12)
    # the CLI's --allow-code takes the same path
    result = CliRunner().invoke(
        app, ["run", "--allow-code", str(study_file), "--out", str(in_tmp / "cli"), "-q"]
    )
    assert result.exit_code == 0, result.output
    assert (in_tmp / "cli" / "result.nc").is_file()


def _trust(tmp_path, monkeypatch, text):
    path = tmp_path / "trusted.toml"
    path.write_text(text)
    monkeypatch.setenv("FUZZYMBS_TRUST_FILE", str(path))
    return path


def test_trust_file_modules(in_tmp, monkeypatch):
    study_file = in_tmp / "study.toml"
    study_file.write_text(PRODUCT_BY_REFERENCE)
    _trust(in_tmp, monkeypatch, 'modules = ["fuzzymbs"]\n')
    assert load_study_file(study_file).study.model_name.endswith("make_product")
    study_file.write_text(HOSTILE)  # 'os' is not listed
    with pytest.raises(UntrustedCodeError, match="add 'os' to modules"):
        load_study_file(study_file)
    assert not (in_tmp / "SOMEFILE").exists()


def test_trust_file_programs(tmp_path, monkeypatch):
    folder = tmp_path / "example"
    shutil.copytree(COMMAND_EXAMPLE, folder)
    study_file = folder / "oscillator-command.toml"
    with pytest.raises(UntrustedCodeError, match="to programs in your trust file"):
        load_study_file(study_file)
    _trust(tmp_path, monkeypatch, f'programs = ["{folder / "oscillator_solver.py"}"]\n')
    assert list(load_study_file(study_file).study.model.parameters) == ["c", "k"]
    # the same program elsewhere is another entry
    other = tmp_path / "other"
    shutil.copytree(COMMAND_EXAMPLE, other)
    with pytest.raises(UntrustedCodeError):
        load_study_file(other / "oscillator-command.toml")


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("modules = [", "is not readable TOML"),
        ('module = ["x"]', "unknown key(s) ['module']; allowed: modules, fmus, programs"),
        ('modules = "fuzzymbs"', "modules must be a list of strings"),
        ("programs = [1]", "programs must be a list of strings"),
    ],
)
def test_bad_trust_file(tmp_path, monkeypatch, text, fragment):
    path = _trust(tmp_path, monkeypatch, text)
    with pytest.raises(UntrustedCodeError) as refused:
        Trusted.load()
    assert str(path) in str(refused.value) and fragment in str(refused.value)


def test_trust_file_location(tmp_path, monkeypatch):
    monkeypatch.delenv("FUZZYMBS_TRUST_FILE")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    assert trust_file() == tmp_path / "fuzzymbs" / "trusted.toml"
    assert Trusted.load() == Trusted()  # no file: nothing is trusted


def test_registered_models_need_no_permission(in_tmp):
    study_file = in_tmp / "study.toml"
    study_file.write_text(
        PRODUCT_BY_REFERENCE.replace('"fuzzymbs.models.closed_form:make_product"', '"product"')
    )
    assert load_study_file(study_file).study.model_name == "product"


class FakeEntryPoint:
    """What importlib.metadata gives for ``[project.entry-points."fuzzymbs.models"]``."""

    name = "gearbox"
    value = "my_gearbox.fuzzymbs_models:register"

    def __init__(self, target):
        self.target = target

    def load(self):
        return self.target


def test_entry_point_plugin_registers_a_model_usable_without_allow_code(in_tmp, monkeypatch):
    # an installed package declares its models through the entry-point group; installing it
    # was the user's choice, so its models run like built-in ones
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    monkeypatch.setattr(registry, "_imported", set(registry._imported))

    def register():
        from fuzzymbs.models.closed_form import make_product
        from fuzzymbs.study.registry import ParameterInfo, register_model

        register_model(
            "plugin-product",
            make_product,
            parameters={
                "x1": ParameterInfo("1", "first factor", 2.0),
                "x2": ParameterInfo("1", "second factor", 10.0),
            },
            outputs={"z": "1"},
            description="a model from an installed package",
        )

    monkeypatch.setattr(registry, "_plugin_entry_points", lambda: [FakeEntryPoint(register)])
    study_file = in_tmp / "study.toml"
    study_file.write_text(
        PRODUCT_BY_REFERENCE.replace(
            '"fuzzymbs.models.closed_form:make_product"', '"plugin-product"'
        )
    )
    definition = load_study_file(study_file)
    assert definition.study.model_name == "plugin-product"
    assert "plugin-product" in registry.available_models()


def test_broken_plugin_does_not_disable_the_others(monkeypatch, caplog):
    monkeypatch.setattr(registry, "_import_errors", dict(registry._import_errors))

    def broken():
        raise RuntimeError("missing licence server")

    monkeypatch.setattr(registry, "_plugin_entry_points", lambda: [FakeEntryPoint(broken)])
    assert "product" in registry.available_models()
    assert "missing licence server" in caplog.text


def test_python_api_is_unaffected():
    # Study(...) with a callable or a reference is code its author wrote: no permission
    from fuzzymbs import Study

    parameters = {"x1": {"type": "triangular", "modal": 2.0, "spread": 0.1}, "x2": 10.0}
    study = Study("fuzzymbs.models.closed_form:make_product", parameters)
    lower, upper = study.run(progress=False).alpha_cut("z", 0.0)
    assert (float(lower), float(upper)) == pytest.approx((18.0, 22.0), rel=1e-12)
