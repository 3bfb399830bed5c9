"""Chunk store and code version: chunks of other fuzzymbs versions or model sources never mix."""

import ast
import json
import logging
import shutil
from pathlib import Path

import pytest

import fuzzymbs
from fuzzymbs import Triangular
from fuzzymbs.errors import StoreMismatchError
from fuzzymbs.study import code_version
from fuzzymbs.study.study import Study

PARAMETERS = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}
PACKAGE = Path(fuzzymbs.__file__).resolve().parent


def _study(model="product"):
    return Study(model, PARAMETERS, levels=2, name="versioned")  # 9 samples


def _edit_manifest(store, **code):
    path = store / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["code"].update(code)
    path.write_text(json.dumps(manifest))


def _manifest_code(store):
    return json.loads((store / "manifest.json").read_text())["code"]


def test_manifest_records_version_and_model_source(tmp_path):
    _study().run(store=tmp_path, progress=False)
    code = _manifest_code(tmp_path)
    assert code["fuzzymbs_version"] == fuzzymbs.__version__
    assert len(code["model_source"]) == 64 and int(code["model_source"], 16) >= 0  # SHA-256 hex


def test_result_provenance_records_the_same_code_as_the_store(tmp_path):
    result = _study().run(store=tmp_path, progress=False)
    assert result.provenance["code"] == _manifest_code(tmp_path)
    assert _study().run(progress=False).provenance["code"] == _manifest_code(tmp_path)


def test_other_fuzzymbs_version_is_refused_until_resume_false(tmp_path):
    first = _study().run(store=tmp_path, progress=False)
    _edit_manifest(tmp_path, fuzzymbs_version="0.0.1")
    with pytest.raises(StoreMismatchError) as error:
        _study().run(store=tmp_path, progress=False)
    message = str(error.value)
    assert "fuzzymbs version" in message and "model's source" not in message
    assert "fuzzymbs 0.0.1" in message and f"fuzzymbs {fuzzymbs.__version__}" in message
    assert "resume=False" in message and "--fresh" in message and "new store directory" in message
    assert len(list(tmp_path.glob("chunk-*.npz"))) == 1  # the refusal deletes nothing

    fresh = _study().run(store=tmp_path, progress=False, resume=False)
    assert fresh.provenance["evaluated"] == 9 and fresh.provenance["reused_from_store"] == 0
    assert _manifest_code(tmp_path)["fuzzymbs_version"] == fuzzymbs.__version__
    assert first.dataset["z_upper"].values.tolist() == fresh.dataset["z_upper"].values.tolist()
    again = _study().run(store=tmp_path, progress=False)  # same version: resumes
    assert again.provenance["evaluated"] == 0 and again.provenance["reused_from_store"] == 9


def test_same_version_resumes(tmp_path):
    _study().run(store=tmp_path, progress=False)
    again = _study().run(store=tmp_path, progress=False)
    assert again.provenance["evaluated"] == 0


def test_changed_model_source_is_refused(tmp_path):
    _study().run(store=tmp_path, progress=False)
    stored = _manifest_code(tmp_path)["model_source"]
    _edit_manifest(tmp_path, model_source="0" * 64)
    with pytest.raises(StoreMismatchError) as error:
        _study().run(store=tmp_path, progress=False)
    message = str(error.value)
    assert "model's source code changed" in message and "fuzzymbs version" not in message
    assert "model source 000000000000" in message and f"model source {stored[:12]}" in message


def test_model_outside_fuzzymbs_records_its_module_file(tmp_path):
    def product(samples):
        return {"z": samples["x1"] * samples["x2"]}

    _study(product).run(store=tmp_path, progress=False)
    code = _manifest_code(tmp_path)
    # this test file defines the model: its bytes are the model's source
    assert code["model_source"] == code_version.user_source_digest(product)
    assert code["model_source"] is not None
    _edit_manifest(tmp_path, fuzzymbs_version="9.9")
    with pytest.raises(StoreMismatchError, match=r"fuzzymbs 9\.9, model source"):
        _study(product).run(store=tmp_path, progress=False)


def test_user_module_edit_changes_the_digest(tmp_path, monkeypatch):
    module = tmp_path / "edited_model.py"
    module.write_text("def model(samples):\n    return {'z': samples['x1'] * samples['x2']}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib

    loaded = importlib.import_module("edited_model")
    before = code_version.code_version(loaded.model)["model_source"]
    module.write_text(module.read_text() + "# edited\n")
    assert code_version.code_version(loaded.model)["model_source"] != before


def test_model_without_a_file_is_identified_by_its_code():
    namespace: dict = {}
    exec("def model(s):\n    return {'z': s['x1'] * 2}", namespace)  # no module file
    other: dict = {}
    exec("def model(s):\n    return {'z': s['x1'] * 3}", other)
    first = code_version.user_source_digest(namespace["model"])
    assert first is not None and first != code_version.user_source_digest(other["model"])


def test_store_without_code_record_is_reopened_and_gets_one(tmp_path, caplog):
    _study().run(store=tmp_path, progress=False)
    path = tmp_path / "manifest.json"
    manifest = json.loads(path.read_text())
    del manifest["code"]  # as written before the code version was recorded
    path.write_text(json.dumps(manifest))
    with caplog.at_level(logging.WARNING, logger="fuzzymbs.study.store"):
        again = _study().run(store=tmp_path, progress=False)
    assert again.provenance["evaluated"] == 0
    assert "does not record the code" in caplog.text
    assert _manifest_code(tmp_path)["fuzzymbs_version"] == fuzzymbs.__version__


def test_other_study_and_other_code_names_both(tmp_path):
    _study().run(store=tmp_path, progress=False)
    _edit_manifest(tmp_path, fuzzymbs_version="0.0.1")
    other = Study("product", {"x1": Triangular(1, 2, 4), "x2": PARAMETERS["x2"]}, levels=2)
    with pytest.raises(StoreMismatchError, match=r"different study.*also written by other code"):
        other.run(store=tmp_path, progress=False, resume=False)  # resume=False: still refused


def test_source_files_follow_imports():
    product = code_version.source_files(["fuzzymbs.models.closed_form.product"])
    oscillator = code_version.source_files(["fuzzymbs.models.closed_form.oscillator"])
    assert [p.relative_to(PACKAGE).as_posix() for p in product] == ["models/closed_form/product.py"]
    assert "errors.py" in [p.relative_to(PACKAGE).as_posix() for p in oscillator]
    brake = {
        p.relative_to(PACKAGE).as_posix()
        for p in code_version.source_files(["fuzzymbs.models.brake"])
    }
    # the brake's digest covers the FE and multibody code it is built from, not other models
    assert "fe/elastic_body.py" in brake and "models/brake/model.py" in brake
    assert any(name.startswith("mbs/") for name in brake)
    assert not any(name.startswith(("models/gears/", "models/closed_form/")) for name in brake)
    assert code_version.source_files(["numpy", "tests.study"]) == []
    assert code_version.source_digest(["numpy"]) is None


def test_digest_changes_with_imported_source_only(tmp_path, monkeypatch):
    # a copy of the package, so that its files can be edited
    copy = tmp_path / "fuzzymbs"
    for name in ("errors.py", "models/closed_form/oscillator.py", "models/gears/geometry.py"):
        (copy / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(PACKAGE / name, copy / name)
    monkeypatch.setattr(code_version, "_package_root", lambda: copy)
    modules = ["fuzzymbs.models.closed_form.oscillator"]
    before = code_version.source_digest(modules)
    assert before == code_version.source_digest(modules)  # deterministic

    with (copy / "models/gears/geometry.py").open("a") as handle:  # not imported by the model
        handle.write("\n# unrelated edit\n")
    assert code_version.source_digest(modules) == before
    with (copy / "errors.py").open("a") as handle:  # imported by the model
        handle.write("\n# edit\n")
    assert code_version.source_digest(modules) != before

    # the import graph is cached per file (mtime, size): a new import is followed at once
    with (copy / "models/closed_form/oscillator.py").open("a") as handle:
        handle.write("\nfrom fuzzymbs.models.gears import geometry  # noqa\n")
    files = code_version.source_files(modules)
    assert copy / "models/gears/geometry.py" in files
    linked = code_version.source_digest(modules)
    with (copy / "models/gears/geometry.py").open("a") as handle:
        handle.write("\n# now imported\n")
    assert code_version.source_digest(modules) != linked

    # a file that does not parse still counts with its bytes
    (copy / "errors.py").write_text("def broken(:\n")
    assert code_version.source_digest(modules) not in (None, before, linked)
    # one that cannot be read: no digest rather than a partial one
    read_bytes = Path.read_bytes

    def refuse_errors_py(path):
        if path == copy / "errors.py":
            raise PermissionError(f"cannot read {path}")
        return read_bytes(path)

    monkeypatch.setattr(Path, "read_bytes", refuse_errors_py)
    assert code_version.source_digest(modules) is None


def _imports_of_the_syntax_tree(path, module):
    """The fuzzymbs modules ``path`` may import, from every import statement of its whole
    syntax tree (the reference for the line scan of fuzzymbs.study.code_version; the names
    resolved by the same ``_imported_modules``, so that only the finding of the
    statements is compared)."""
    statements = [
        node
        for node in ast.walk(ast.parse(path.read_bytes()))
        if isinstance(node, (ast.Import, ast.ImportFrom))
    ]
    names = code_version._imported_modules(statements, module, path.name == "__init__.py")
    return {name for name in names if name.startswith("fuzzymbs.")}


def test_the_import_scan_finds_what_the_syntax_tree_holds_in_every_module():
    # the digest follows imports found by scanning import lines outside docstrings
    # (twelve times faster than parsing whole files); in this package it must find
    # exactly the imports of each file's full syntax tree, docstring examples left out
    checked = 0
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        scanned = code_version._imported_modules(
            code_version._import_statements(path.read_bytes()),
            module,
            path.name == "__init__.py",
        )
        found = {name for name in scanned if name.startswith("fuzzymbs.")}
        assert found == _imports_of_the_syntax_tree(path, module), module
        checked += 1
    assert checked > 150


def test_cli_refuses_other_code_and_fresh_recomputes(tmp_path):
    from importlib import resources

    from typer.testing import CliRunner

    from fuzzymbs.cli import app

    runner = CliRunner()
    study = resources.files("fuzzymbs") / "demos" / "quickstart" / "01-product.toml"
    out = tmp_path / "out"
    with resources.as_file(study) as path:
        command = ["run", str(path), "--out", str(out), "-q", "--no-plots"]
        assert runner.invoke(app, command).exit_code == 0
        _edit_manifest(out / "chunks", fuzzymbs_version="0.0.1")
        refused = runner.invoke(app, command)
        assert refused.exit_code == 1 and "Traceback" not in refused.output
        assert "fuzzymbs 0.0.1" in refused.output and "--fresh" in refused.output
        assert runner.invoke(app, [*command, "--fresh"]).exit_code == 0
        assert runner.invoke(app, command).exit_code == 0  # recorded again: resumes
    assert _manifest_code(out / "chunks")["fuzzymbs_version"] == fuzzymbs.__version__


def test_the_import_scan_reads_continued_indented_and_commented_imports_only():
    source = b'''"""A module.

    import fuzzymbs.fe
"""
from fuzzymbs.fuzzy import (
    numbers,
    transform,
)
from fuzzymbs.errors import \\
    InvalidParameterError
from fuzzymbs import version  # (a "(" in a comment

TEXT = """
from fuzzymbs.study import store
"""


def late():
    import fuzzymbs.mbs.system
'''
    statements = code_version._import_statements(source)
    names = code_version._imported_modules(statements, "fuzzymbs.sample", False)
    assert {name for name in names if name.count(".") == 1} == {
        "fuzzymbs.fuzzy",
        "fuzzymbs.errors",
        "fuzzymbs.version",
    }
    assert {"fuzzymbs.fuzzy.numbers", "fuzzymbs.fuzzy.transform"} <= names
    assert "fuzzymbs.mbs.system" in names  # inside a function
    # inside the docstring and the string: not code
    assert not {"fuzzymbs.fe", "fuzzymbs.study.store"} & names
