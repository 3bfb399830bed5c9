"""The source tree keeps the structural rules of docs/architecture.md.

No private name (``_x``) is used across modules of ``src/fuzzymbs``: neither imported
(``from fuzzymbs.a import _x``), nor read off an imported module (``a._x``), nor read
off another module's object (``obj._x`` where only another module defines ``_x``).
No source file is over 800 lines.
"""

import ast
import functools
from pathlib import Path

SOURCE = Path(__file__).resolve().parents[1] / "src" / "fuzzymbs"
MAX_LINES = 800


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SOURCE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


FILES = sorted(SOURCE.rglob("*.py"))
MODULES = {_module_name(path) for path in FILES}


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _defined(tree: ast.AST) -> set[str]:
    """The private names a module defines: functions, classes, assigned names and
    attributes (``self._x = ...``), arguments."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
    return {name for name in names if _private(name)}


@functools.cache
def _parsed() -> tuple[dict[Path, ast.AST], dict[Path, set[str]], set[str]]:
    """Every source file's tree, the private names each defines, and all of those names
    (parsed on first use, not when the module is collected: only the process that runs
    these tests pays for it)."""
    trees = {path: ast.parse(path.read_text(encoding="utf-8")) for path in FILES}
    defined = {path: _defined(tree) for path, tree in trees.items()}
    return trees, defined, set().union(*defined.values())


def _private_uses(path: Path) -> list[str]:
    trees, defined, defined_anywhere = _parsed()
    tree = trees[path]
    own = defined[path]
    modules: set[str] = set()  # local names bound to a fuzzymbs module
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules.update(
                (alias.asname or alias.name.split(".")[0])
                for alias in node.names
                if alias.name.split(".")[0] == "fuzzymbs"
            )
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("fuzzymbs"):
            for alias in node.names:
                if f"{node.module}.{alias.name}" in MODULES:
                    modules.add(alias.asname or alias.name)
                if _private(alias.name):
                    found.append(f"line {node.lineno}: from {node.module} import {alias.name}")
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and _private(node.attr)):
            continue
        base = node.value
        while isinstance(base, ast.Attribute):
            base = base.value
        if isinstance(base, ast.Name) and base.id in {"self", "cls"} and node.value is base:
            continue
        on_module = isinstance(base, ast.Name) and base.id in modules
        # a name no module of the package defines is a third party's (os._exit)
        foreign = node.attr in defined_anywhere and node.attr not in own
        if on_module or foreign:
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
    return found


def test_no_private_name_is_used_across_modules():
    found = {str(path.relative_to(SOURCE)): _private_uses(path) for path in FILES}
    assert {name: uses for name, uses in found.items() if uses} == {}


def test_the_check_finds_a_private_name_used_across_modules():
    # the check itself, on a module written for it: all three kinds are found
    module = SOURCE / "fuzzy" / "_structure_probe.py"
    trees, defined, _ = _parsed()
    trees[module] = ast.parse(
        "from fuzzymbs.fuzzy.chebyshev_grid import _positions\n"
        "from fuzzymbs.fuzzy import chebyshev_grid\n"
        "chebyshev_grid._to_coefficients(1)\n"
        "def f(grid):\n    return grid._index_set\n"
    )
    defined[module] = _defined(trees[module])
    try:
        assert len(_private_uses(module)) == 3
    finally:
        del trees[module], defined[module]


def test_no_source_file_is_over_800_lines():
    lines = {str(path.relative_to(SOURCE)): len(path.read_text().splitlines()) for path in FILES}
    assert {name: count for name, count in lines.items() if count > MAX_LINES} == {}
