"""Model registry: lookups, error messages, lazily imported factories."""

import sys

import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.study import registry
from fuzzymbs.study.registry import (
    LazyFactory,
    ParameterInfo,
    available_models,
    get_model,
    load_callable,
    register_model,
)


def test_builtin_closed_form_models_are_registered():
    models = available_models()
    assert {"product", "damped-oscillator"} <= set(models)
    assert models["damped-oscillator"].parameters["stiffness"].unit == "N/m"


def test_lazy_factory_imports_only_when_called(tmp_path, monkeypatch):
    module = tmp_path / "lazy_model_module.py"
    module.write_text("def make(scale=1.0):\n    return lambda s: {'z': scale * s['x']}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    available_models()  # load the built-ins, then register into a copy undone after the test
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    spec = register_model(
        "lazy-test-model",
        "lazy_model_module:make",
        parameters={"x": ParameterInfo("1", "input", 1.0)},
        outputs={"z": "1"},
        description="test",
    )
    assert isinstance(spec.factory, LazyFactory)
    assert "lazy_model_module" not in sys.modules
    model = get_model("lazy-test-model").factory(scale=2.0)
    assert model({"x": 3.0})["z"] == 6.0


def test_bad_references_and_names():
    with pytest.raises(InvalidParameterError, match="not of the form"):
        load_callable("no_colon")
    with pytest.raises(InvalidParameterError, match="cannot import module"):
        load_callable("surely_not_a_module_xyz:make")
    with pytest.raises(InvalidParameterError, match="has no attribute"):
        load_callable("fuzzymbs.models.closed_form:nothing_here")
    with pytest.raises(InvalidParameterError, match=r"registered models are: .*product"):
        get_model("prodcut")


def test_registered_name_is_found_without_importing_packages(monkeypatch):
    available_models()
    monkeypatch.setattr(registry, "_imported", set())
    monkeypatch.setattr(registry, "_import_errors", {})
    imported = []
    monkeypatch.setattr(registry, "_import_builtin", imported.append)
    registry.get_model("product")  # already registered: nothing is imported
    assert imported == []


def test_broken_builtin_package_is_reported_not_fatal(monkeypatch, caplog):
    monkeypatch.setattr(registry, "_imported", set())
    monkeypatch.setattr(registry, "_import_errors", {})
    monkeypatch.setattr(
        registry, "BUILTIN_PACKAGES", (*registry.BUILTIN_PACKAGES, "fuzzymbs.models.no_such_pkg")
    )
    assert "product" in available_models()  # the others still load
    assert "no_such_pkg failed to import" in caplog.text
    with pytest.raises(InvalidParameterError, match=r"no_such_pkg failed to import \("):
        get_model("nope")


def test_closed_form_study_does_not_import_gear_or_brake_packages(fresh_python):
    code = (
        "import sys; from fuzzymbs.study.registry import get_model; get_model('product'); "
        "print(any(m.startswith(('fuzzymbs.models.gears', 'fuzzymbs.models.brake')) "
        "for m in sys.modules))"
    )
    assert fresh_python(code).strip() == "False"
