"""Which code computes a study's samples: the fuzzymbs version and a digest of the model source.

A chunk store records this next to the study identity, so that a resumed run
does not mix chunks computed by an older fuzzymbs, or by an edited model, with
new ones (see :mod:`fuzzymbs.study.store`).

The source digest covers models defined inside the fuzzymbs package (the
built-in models, or a model object or ``"fuzzymbs...:factory"`` reference whose
code lives in fuzzymbs): the SHA-256 of the ``.py`` files of the model's
modules and of every fuzzymbs module they import, followed transitively
through the ``import`` statements (their lines read with :mod:`ast`, nothing
is imported). Names a package re-exports lazily by string (``fuzzymbs.mbs``'s
``_LAZY`` table) are not followed, so model code imports the defining module
itself. Any edit of those files, comments included, changes the digest.

A model defined outside fuzzymbs (a function or class in the user's own
module, a ``"my_models:factory"`` reference) is covered by the bytes of the
file of the module that defines it (and of its factory); defined where there
is no file (an interactive session), by its compiled code (bytecode, constants
and names of its functions). The modules that file imports are not followed:
a model whose physics lives in another module of the user's states it in
``identity()``. FMUs and programs are covered by their models' ``identity()``
(the digest of the FMU file, of the program and its input template).
"""

from __future__ import annotations

import ast
import bisect
import hashlib
import inspect
import logging
import os
import re
import sys
from collections.abc import Iterable
from pathlib import Path
from types import CodeType
from typing import Any

logger = logging.getLogger(__name__)

_PACKAGE = "fuzzymbs"
#: Imported module names per parsed file, keyed by path, valid while (mtime_ns, size)
#: match: the digest itself always reads the current bytes.
_IMPORTS: dict[Path, tuple[tuple[int, int], frozenset[str]]] = {}


def fuzzymbs_version() -> str:
    """The version string of the running fuzzymbs (``fuzzymbs.__version__``)."""
    from fuzzymbs.version import __version__

    return __version__


def _package_root() -> Path:
    import fuzzymbs

    return Path(fuzzymbs.__file__).resolve().parent


def _module_file(root: Path, module: str) -> Path | None:
    """Source file of a fuzzymbs module or package, or None if ``module`` names no file."""
    parts = module.split(".")
    if parts[0] != _PACKAGE or len(parts) < 2:  # the root package only holds lazy names
        return None
    base = root.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


#: The start of a line that may begin an import statement (ruff's formatter leaves one
#: statement per line)
_IMPORT_START = re.compile(rb"^[ \t]*(?:import|from)[ \t]", re.MULTILINE)
#: Triple double quotes: a line after an odd number of them lies in a docstring (ruff's
#: formatter writes docstrings so), whose examples import what the module itself does not
_TRIPLE_QUOTES = re.compile(rb'"""')


def _import_statements(source: bytes) -> list[ast.stmt]:
    """The import statements of ``source``, parsed one by one.

    Only the lines that start like one outside a docstring are parsed (with their
    parenthesised or backslashed continuation lines): parsing and walking the whole
    modules took ten times as long (0.46-0.71 s against 0.04-0.07 s for the brake's 77
    files in a fresh process, ``benchmarks/startup.py``).
    ``tests/study/test_store_version.py`` checks that every module of the package
    gives the imports of its full syntax tree.
    """
    quotes = [match.start() for match in _TRIPLE_QUOTES.finditer(source)]
    statements: list[ast.stmt] = []
    for match in _IMPORT_START.finditer(source):
        start = match.start()
        if bisect.bisect(quotes, start) % 2:
            continue  # inside a docstring
        line_end = source.find(b"\n", start)
        line_end = len(source) if line_end < 0 else line_end
        end = line_end
        line = source[start:end]
        if b"(" in line and b")" not in line:
            close = source.find(b")", end)
            end = len(source) if close < 0 else close + 1
        else:
            while source[start:end].rstrip().endswith(b"\\") and end < len(source):
                following = source.find(b"\n", end + 1)
                end = len(source) if following < 0 else following
        # the statement with its continuation; failing that its line alone (a "(" in a
        # comment); failing both, a line of a string that starts like an import
        for stop in dict.fromkeys((end, line_end)):
            try:
                parsed = ast.parse(source[start:stop].strip())
            except (SyntaxError, ValueError):
                continue
            statements.extend(
                node for node in parsed.body if isinstance(node, (ast.Import, ast.ImportFrom))
            )
            break
    return statements


def _imported_modules(statements: Iterable[ast.stmt], module: str, is_package: bool) -> set[str]:
    """Every module name the import ``statements`` may load.

    ``from a.b import c`` yields ``a.b`` and ``a.b.c`` (c may be a submodule);
    names that are no file are dropped by the caller.
    """
    names: set[str] = set()
    package = module if is_package else module.rpartition(".")[0]
    for node in statements:
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative import: resolve against this module's package
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, node.module] if node.module else anchor)
            else:
                base = node.module or ""
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def source_files(modules: Iterable[str]) -> list[Path] | None:
    """Files of the fuzzymbs ``modules`` and of the fuzzymbs modules they import, sorted.

    Returns None when a module's source cannot be read (e.g. an installation without
    ``.py`` files), so that no partial digest is recorded. A file that does not parse
    still counts with its bytes, and its import lines that do parse are followed.
    """
    root = _package_root()
    queue = [m for m in modules if m.startswith(_PACKAGE + ".")]
    seen: dict[str, Path] = {}
    while queue:
        module = queue.pop()
        if module in seen:
            continue
        path = _module_file(root, module)
        if path is None:
            continue
        seen[module] = path
        imports = _file_imports(path, module)
        if imports is None:
            return None
        queue.extend(name for name in imports if name not in seen)
    return sorted(set(seen.values()))


def _file_imports(path: Path, module: str) -> frozenset[str] | None:
    """The fuzzymbs modules ``path`` (module ``module``) may import; None if unreadable."""
    try:
        stat = path.stat()
        key = (stat.st_mtime_ns, stat.st_size)
        cached = _IMPORTS.get(path)
        if cached is not None and cached[0] == key:
            return cached[1]
        statements = _import_statements(path.read_bytes())
    except OSError as exc:
        logger.warning("cannot read the source of %s (%s); no model source digest", module, exc)
        return None
    names = _imported_modules(statements, module, path.name == "__init__.py")
    imports = frozenset(name for name in names if name.startswith(_PACKAGE + "."))
    _IMPORTS[path] = (key, imports)
    return imports


def source_digest(modules: Iterable[str]) -> str | None:
    """SHA-256 (hex) of the source files of ``modules`` and their fuzzymbs imports.

    Each file contributes its path relative to the package and its bytes, so
    a renamed file changes the digest too. None if no module lies inside
    fuzzymbs or a source file is unreadable.
    """
    files = source_files(modules)
    if not files:
        return None
    root = _package_root()
    digest = hashlib.sha256()
    try:
        for path in files:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    except OSError as exc:
        logger.warning("cannot read model source (%s); no model source digest", exc)
        return None
    return digest.hexdigest()


def model_modules(model: Any, factory: Any = None) -> list[str]:
    """Modules defining ``model`` (its class or function) and its ``factory``, if any.

    A :class:`~fuzzymbs.study.registry.LazyFactory` contributes the module of
    its ``"package.module:callable"`` reference.
    """
    modules = []
    for obj in (model, factory):
        if obj is None:
            continue
        reference = getattr(obj, "reference", None)
        if isinstance(reference, str) and ":" in reference:
            modules.append(reference.partition(":")[0])
        kind = obj if hasattr(obj, "__qualname__") else type(obj)
        module = getattr(kind, "__module__", None)
        if isinstance(module, str):
            modules.append(module)
    return sorted(set(modules))


def _feed_code(code: CodeType, digest: Any) -> None:
    """Bytecode, names and constants of ``code`` and of the code objects nested in it."""
    digest.update(code.co_code)
    digest.update(repr((code.co_names, code.co_varnames)).encode())
    for constant in code.co_consts:
        if isinstance(constant, CodeType):
            _feed_code(constant, digest)
        else:
            digest.update(repr(constant).encode())


def _feed_object_code(obj: Any, digest: Any) -> None:
    """The compiled code of a function, or of every function of an object's class."""
    target = obj if inspect.isfunction(obj) or inspect.ismethod(obj) else None
    if target is not None:
        _feed_code(target.__code__, digest)
        return
    kind = obj if inspect.isclass(obj) else type(obj)
    for name, member in sorted(vars(kind).items()):
        function = getattr(member, "__func__", member)
        if inspect.isfunction(function):
            digest.update(name.encode() + b"\0")
            _feed_code(function.__code__, digest)


def user_source_digest(model: Any, factory: Any = None) -> str | None:
    """SHA-256 (hex) of the user code behind ``model`` (and ``factory``), or None.

    For each object defined outside fuzzymbs: the bytes of its module's file,
    or its compiled code where the module has no file. None if both are
    defined inside fuzzymbs (see :func:`source_digest`).
    """
    digest = hashlib.sha256()
    found = False
    for obj in (model, factory):
        if obj is None:
            continue
        kind = obj if hasattr(obj, "__qualname__") else type(obj)
        module = getattr(kind, "__module__", None)
        reference = getattr(obj, "reference", None)
        if isinstance(reference, str) and ":" in reference:  # a LazyFactory of "module:callable"
            module = reference.partition(":")[0]
        if isinstance(module, str) and (module == _PACKAGE or module.startswith(_PACKAGE + ".")):
            continue  # covered by source_digest
        file = getattr(sys.modules.get(module or ""), "__file__", None)
        path = Path(file) if isinstance(file, str) else None
        digest.update(str(module).encode() + b"\0")
        if path is not None and path.suffix == ".py" and path.is_file():
            digest.update(path.read_bytes() + b"\0")
        else:  # no source file (an interactive session, exec, a compiled module)
            _feed_object_code(obj, digest)
        found = True
    return digest.hexdigest() if found else None


def model_python_path(reference: str) -> str | None:
    """The ``PYTHONPATH`` a model loaded by a module path was imported through, or None.

    A ``"package.module:callable"`` model imports only where its folder is on
    Python's path; a command finds a user's folder through ``PYTHONPATH``
    (``PYTHONPATH=examples fuzzymbs run examples/cantilever.toml ...``), so a
    command that reproduces the study must set it again.

    Parameters
    ----------
    reference : str
        The model as the study names it: a registered name or ``"package.module:callable"``.

    Returns
    -------
    str or None
        ``PYTHONPATH`` as this process has it (all of it: the model's module may import
        from its other entries), if one of its entries is the folder the model's
        top-level package or module was imported from. None for a registered model,
        a module not imported yet, or one found without ``PYTHONPATH`` (installed).
    """
    module_name, sep, _ = reference.partition(":")
    if not sep or not module_name:
        return None
    module = sys.modules.get(module_name.split(".")[0])
    if module is None:
        return None
    if hasattr(module, "__path__"):  # a package: its folders sit in the path entry
        roots = {Path(folder).resolve().parent for folder in module.__path__}
    elif isinstance(getattr(module, "__file__", None), str):
        roots = {Path(module.__file__).resolve().parent}
    else:
        return None
    value = os.environ.get("PYTHONPATH", "")
    # relative entries are relative to the working folder, as when Python started
    entries = {Path(entry).resolve() for entry in value.split(os.pathsep) if entry}
    return value if roots & entries else None


def code_version(model: Any, factory: Any = None) -> dict[str, Any]:
    """What a chunk store records about the code: fuzzymbs version and model source digest.

    Returns
    -------
    dict
        ``{"fuzzymbs_version": str, "model_source": str or None}``: the digest
        of the fuzzymbs source the model uses (:func:`source_digest`), of the
        user's code (:func:`user_source_digest`), or of both together.
    """
    inside = source_digest(model_modules(model, factory))
    outside = user_source_digest(model, factory)
    if inside is not None and outside is not None:
        source: str | None = hashlib.sha256(f"{inside}:{outside}".encode()).hexdigest()
    else:
        source = inside if outside is None else outside
    return {"fuzzymbs_version": fuzzymbs_version(), "model_source": source}
