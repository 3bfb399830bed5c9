"""Load a fuzzymbs kernel module as plain, interpreted Python (Numba decorators removed).

The per-sample Python baselines run *the same source* as the compiled kernels,
so they compute the same equations with the same algorithm and tolerances; the
only difference is that CPython interprets every statement. This is the code a
user gets who writes the model as ordinary Python functions and loops over the
samples.
"""

from __future__ import annotations

import importlib.util
import sys
import types
from collections.abc import Mapping


def _numba_shim() -> types.ModuleType:
    """A stand-in ``numba`` module: ``njit``/``jit`` return the function unchanged."""
    shim = types.ModuleType("numba")

    def njit(*args, **kwargs):
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda func: func

    shim.njit = njit
    shim.jit = njit
    shim.prange = range
    return shim


def load_interpreted(
    module_name: str, replacements: Mapping[str, types.ModuleType] | None = None
) -> types.ModuleType:
    """Execute ``module_name``'s source with a no-op ``numba``; return the new module.

    Parameters
    ----------
    module_name : str
        Dotted name of the kernel module (e.g. ``fuzzymbs.models.gears.flank_contact``).
    replacements : mapping, optional
        Modules to substitute while the source runs (so that its ``from X import f``
        picks up other interpreted modules instead of compiled ones).
    """
    spec = importlib.util.find_spec(module_name)
    if spec is None or spec.origin is None:
        raise ImportError(f"cannot find module {module_name!r}")
    substitutes = {"numba": _numba_shim(), **dict(replacements or {})}
    saved = {name: sys.modules.get(name) for name in substitutes}
    module = types.ModuleType(module_name + "_interpreted")
    module.__file__ = spec.origin
    try:
        sys.modules.update(substitutes)
        with open(spec.origin, encoding="utf-8") as handle:
            code = compile(handle.read(), spec.origin, "exec")
        exec(code, module.__dict__)
    finally:
        for name, previous in saved.items():
            if previous is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = previous
    return module


def interpreted_gear_solver() -> types.ModuleType:
    """The MUBOCO-PR static solver module (and its flank contact) as plain Python."""
    flank = load_interpreted("fuzzymbs.models.gears.flank_contact")
    return load_interpreted(
        "fuzzymbs.models.gears.muboco", {"fuzzymbs.models.gears.flank_contact": flank}
    )
