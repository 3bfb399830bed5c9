"""fuzzymbs.numba_cache: cached kernels are dropped when a file they may hold changed."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from numba.core.caching import UserProvidedCacheLocator

from fuzzymbs.numba_cache import drop_stale_kernel_caches

KERNEL = "import numba as nb\n\n\n@nb.njit(cache=True)\ndef f():\n    return 1\n"


def _package(root: Path) -> Path:
    package = root / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text('"""a package"""\n')
    (package / "kernel.py").write_text(KERNEL)
    # the words alone do not make a kernel file
    (package / "sub" / "helper.py").write_text("# no jit here, cache=True in a comment\nX = 1\n")
    return package


def _fake_caches(folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    files = [folder / "kernel.f-4.py311.nbi", folder / "kernel.f-4.py311.1.nbc"]
    for path in files:
        path.write_bytes(b"cached")
    return files


def _edit(path: Path, text: str) -> None:
    path.write_text(text)
    info = path.stat()
    os.utime(path, ns=(info.st_atime_ns, info.st_mtime_ns + 1_000_000))


def test_only_a_changed_kernel_file_drops_the_caches(tmp_path):
    package = _package(tmp_path)
    caches = _fake_caches(package / "__pycache__") + _fake_caches(package / "sub" / "__pycache__")
    bytecode = package / "__pycache__" / "kernel.cpython-311.pyc"
    bytecode.write_bytes(b"pyc")
    # no record yet: the caches' sources are unknown, so they go; Python's own stay
    assert drop_stale_kernel_caches(package, cache_dir="") is True
    assert not any(path.exists() for path in caches) and bytecode.exists()
    caches = _fake_caches(package / "__pycache__")
    assert drop_stale_kernel_caches(package, cache_dir="") is False
    assert all(path.exists() for path in caches)
    _edit(package / "sub" / "helper.py", "X = 2  # another value, no kernel\n")
    assert drop_stale_kernel_caches(package, cache_dir="") is False
    assert all(path.exists() for path in caches)
    _edit(package / "kernel.py", KERNEL.replace("return 1", "return 22"))
    assert drop_stale_kernel_caches(package, cache_dir="") is True
    assert not any(path.exists() for path in caches)
    # a kernel file that appears, and one that goes
    caches = _fake_caches(package / "__pycache__")
    (package / "sub" / "more.py").write_text(KERNEL)
    assert drop_stale_kernel_caches(package, cache_dir="") is True
    assert not any(path.exists() for path in caches)
    caches = _fake_caches(package / "__pycache__")
    (package / "sub" / "more.py").unlink()
    assert drop_stale_kernel_caches(package, cache_dir="") is True
    assert not any(path.exists() for path in caches)


def test_under_numba_cache_dir_only_the_packages_caches_go(tmp_path):
    package = _package(tmp_path)
    cache_dir = tmp_path / "numba-cache"

    def folder(source_folder: Path) -> Path:
        # where Numba puts the caches of a source folder under NUMBA_CACHE_DIR
        return cache_dir / UserProvidedCacheLocator.get_suitable_cache_subpath(
            str(source_folder / "kernel.py")
        )

    assert drop_stale_kernel_caches(package, cache_dir=cache_dir) is True
    ours = _fake_caches(folder(package)) + _fake_caches(folder(package / "sub"))
    other_package = tmp_path / "other"
    other_package.mkdir()
    theirs = _fake_caches(folder(other_package))
    assert drop_stale_kernel_caches(package, cache_dir=cache_dir) is False
    _edit(package / "kernel.py", KERNEL.replace("return 1", "return 333"))
    assert drop_stale_kernel_caches(package, cache_dir=cache_dir) is True
    assert not any(path.exists() for path in ours)
    assert all(path.exists() for path in theirs)
    # the record lives beside the cache, one per package folder: the in-tree one is untouched
    assert not (package / "__pycache__").exists()


def test_a_cache_it_cannot_write_is_left_alone(tmp_path):
    package = _package(tmp_path)
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    assert drop_stale_kernel_caches(package, cache_dir=blocker / "cache") is False


def _run(package_root: Path, guard: bool) -> str:
    code = textwrap.dedent(
        f"""
        import sys
        sys.path.insert(0, {str(package_root)!r})
        if {guard!r}:
            from fuzzymbs.numba_cache import drop_stale_kernel_caches
            drop_stale_kernel_caches({str(package_root / "twomods")!r}, cache_dir="")
        from twomods.caller import caller
        print(caller())
        """
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    )
    return done.stdout.strip()


def test_numba_keeps_an_old_helper_and_the_guard_does_not(tmp_path):
    # Numba's documented limitation (its docs, "Cache invalidation fails to recognize
    # changes in functions defined in a different file"), reproduced: the caller's cache
    # holds the helper it was compiled with
    package = tmp_path / "twomods"
    package.mkdir()
    (package / "__init__.py").write_text("")
    helper = package / "helper.py"
    helper.write_text("import numba as nb\n\n\n@nb.njit(cache=True)\ndef helper():\n    return 1\n")
    (package / "caller.py").write_text(
        "import numba as nb\n\nfrom twomods.helper import helper\n\n\n"
        "@nb.njit(cache=True)\ndef caller():\n    return helper()\n"
    )
    assert _run(tmp_path, guard=True) == "1"  # compiled, cached, the sources recorded
    _edit(helper, helper.read_text().replace("return 1", "return 20"))
    assert _run(tmp_path, guard=False) == "1"  # stale: the old helper compiled in
    assert _run(tmp_path, guard=True) == "20"  # the guard saw the change, dropped the caches
