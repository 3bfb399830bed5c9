"""tests/conftest.py's KERNELS_FIRST names tests of the default suite that exist, and its
LONG_FIRST tests of the slow suite."""

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# read, not imported: "conftest" on sys.path may be another folder's


def _table(name: str) -> tuple:
    return next(
        ast.literal_eval(node.value)
        for node in ast.parse((ROOT / "tests" / "conftest.py").read_text()).body
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == name
    )


KERNELS_FIRST = _table("KERNELS_FIRST")
LONG_FIRST = _table("LONG_FIRST")


def _slow_marks(decorators: list[ast.expr]) -> list[str]:
    return [ast.unparse(d) for d in decorators if "slow" in ast.unparse(d)]


def test_every_kernels_first_entry_exists_and_is_in_the_default_suite():
    # a renamed or moved test would silently drop out of the table (the scheduler skips
    # what it does not find), and a slow one is never in the default suite's collection
    for group in KERNELS_FIRST:
        for entry in group:
            path, _, name = entry.partition("::")
            tree = ast.parse((ROOT / path).read_text())
            module_marks = [
                node.value
                for node in tree.body
                if isinstance(node, ast.Assign)
                and any(getattr(target, "id", "") == "pytestmark" for target in node.targets)
            ]
            assert not _slow_marks(module_marks), entry
            if not name:  # a whole module
                continue
            function = re.sub(r"\[.*\]$", "", name)
            found = [
                node
                for node in tree.body
                if isinstance(node, ast.FunctionDef) and node.name == function
            ]
            assert found, entry
            assert not _slow_marks(found[0].decorator_list), entry


def test_every_long_first_entry_is_a_slow_test_that_exists():
    # one group per process, as KERNELS_FIRST; an entry names one test (or one case of it)
    assert len(LONG_FIRST) == len(KERNELS_FIRST)
    for group in LONG_FIRST:
        for entry in group:
            path, _, name = entry.partition("::")
            tree = ast.parse((ROOT / path).read_text())
            function = re.sub(r"\[.*\]$", "", name)  # a case id is checked by eye
            found = [
                node
                for node in tree.body
                if isinstance(node, ast.FunctionDef) and node.name == function
            ]
            assert found, entry
            module_marks = [
                node.value
                for node in tree.body
                if isinstance(node, ast.Assign)
                and any(getattr(target, "id", "") == "pytestmark" for target in node.targets)
            ]
            assert _slow_marks(module_marks) or _slow_marks(found[0].decorator_list), entry
