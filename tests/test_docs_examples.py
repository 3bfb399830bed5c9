"""Every Python example in docs/ runs as written.

The blocks of one page run in order as one script, as a reader pastes them into one
file (later blocks use names the earlier ones define), in a temporary folder (some
write results and figures). A page whose examples run for long is in the slow suite;
the pages whose examples have tests of their own (``OWN_TESTS``) are left to those.
"""

from __future__ import annotations

import re
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

TESTS = Path(__file__).resolve().parent
DOCS = TESTS.parent / "docs"
#: pages whose examples have tests of their own, which also check what the text says
OWN_TESTS = {
    "fe.md": TESTS / "fe" / "test_docs.py",
    "gears.md": TESTS / "models" / "test_gear_docs.py",
    "mechanisms.md": TESTS / "mbs" / "planar" / "test_docs.py",
}
#: pages whose examples the default suite cannot spare (brake.md: 12 s with its kernels
#: compiled; the others take 0.2-2.5 s)
SLOW_PAGES = {"brake.md"}


def python_blocks(page: Path) -> list[tuple[int, str]]:
    """``(line, code)`` of each fenced Python block of a page."""
    text = page.read_text()
    return [
        (text[: m.start()].count("\n") + 2, m.group(1))
        for m in re.finditer(r"```python\n(.*?)```", text, re.S)
    ]


def run_page(page: Path) -> dict:
    """Run a page's blocks in order in one module's namespace; returns the namespace.

    The module is registered while it runs, as a script's ``__main__`` is (dataclasses
    defined in an example look their module up)."""
    module = types.ModuleType(f"docs_{page.stem}")
    sys.modules[module.__name__] = module
    try:
        for line, code in python_blocks(page):
            # a block's line offset, so that a traceback names the page and its line
            exec(compile("\n" * (line - 1) + code, str(page), "exec"), module.__dict__)
    finally:
        del sys.modules[module.__name__]
    return module.__dict__


PAGES = [
    pytest.param(page, id=page.name, marks=[pytest.mark.slow] if page.name in SLOW_PAGES else [])
    for page in sorted(DOCS.glob("*.md"))
    if python_blocks(page) and page.name not in OWN_TESTS
]


def test_every_page_with_examples_is_run():
    names = {param.values[0].name for param in PAGES}
    # the pages a reader starts from; a page losing its examples would drop out silently
    assert {"fuzzy.md", "studies.md", "embs.md", "brake.md"} <= names
    for page, test in OWN_TESTS.items():
        assert python_blocks(DOCS / page) and test.is_file(), page


@pytest.mark.parametrize("page", PAGES)
def test_docs_examples_run(page, tmp_path):
    # as a script of the reader's (a user force element is cached from its module file)
    script = tmp_path / f"docs_{page.stem}.py"
    script.write_text("\n".join(code for _, code in python_blocks(page)))
    run = subprocess.run(
        [sys.executable, script.name], cwd=tmp_path, capture_output=True, text=True
    )
    assert run.returncode == 0, f"{page.name}'s examples failed:\n{run.stderr[-3000:]}"


def test_embs_example_gives_what_its_comments_say(tmp_path, monkeypatch):
    # the engine's page: a disc under one pad, two samples over 2 ms recorded every 10 us
    monkeypatch.chdir(tmp_path)
    namespace = run_page(DOCS / "embs.md")
    out, stab = namespace["out"], namespace["stab"]
    assert out["y_pad"].shape == (2, 201)
    assert namespace["model"].coords["time"].shape == (201,)
    assert not np.any(out["failed"])
    np.testing.assert_array_equal(stab.unstable.any(axis=1), [False, True])
