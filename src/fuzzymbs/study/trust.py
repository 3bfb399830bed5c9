"""A study file is data: it runs code its user did not choose only when allowed.

What a study file may run without asking:

- registered models: the built-in ones and those that installed packages
  declare through the entry-point group ``fuzzymbs.models``
  (:mod:`fuzzymbs.study.registry`) -- installing a package is the user's choice.

What needs the user's explicit permission, because the study file's author
chose the code:

- a ``"package.module:callable"`` reference (imports any module, calls any callable);
- an FMU (model ``fmu``: its binary runs inside fuzzymbs);
- a program (model ``command``).

Permission is ``fuzzymbs run --allow-code`` (``allow_code=True`` in
:func:`~fuzzymbs.study.studyfile.load_study_file`), or an entry in the user's
trust file, ``$XDG_CONFIG_HOME/fuzzymbs/trusted.toml`` (default
``~/.config/fuzzymbs/trusted.toml``; ``$FUZZYMBS_TRUST_FILE`` overrides the
location)::

    modules = ["my_models"]                    # top-level module of "module:callable"
    fmus = ["/home/me/models/gearbox.fmu"]     # absolute paths, or the files' sha256
    programs = ["/opt/solver/bin/solve"]       # absolute paths as found on PATH

The Python API is unaffected: ``Study(...)`` with a callable or a reference
is code its author wrote.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fuzzymbs.errors import UntrustedCodeError

__all__ = ["TRUST_FILE_ENV", "Trusted", "check_study_code", "code_to_run", "trust_file"]

#: environment variable naming the trust file (overrides the default location)
TRUST_FILE_ENV = "FUZZYMBS_TRUST_FILE"


def trust_file() -> Path:
    """Where the user's list of trusted modules, FMUs and programs lives."""
    if os.environ.get(TRUST_FILE_ENV):
        return Path(os.environ[TRUST_FILE_ENV]).expanduser()
    config = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(config) / "fuzzymbs" / "trusted.toml"


@dataclass(frozen=True)
class Trusted:
    """The user's trusted code (empty without a trust file)."""

    modules: frozenset[str] = frozenset()
    fmus: frozenset[str] = frozenset()
    programs: frozenset[str] = frozenset()

    @classmethod
    def load(cls, path: Path | None = None) -> Trusted:
        """Read the trust file (missing: nothing is trusted).

        Raises
        ------
        UntrustedCodeError
            The trust file is not valid TOML or its entries are not lists of strings.
        """
        path = trust_file() if path is None else path
        if not path.is_file():
            return cls()
        try:
            raw = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise UntrustedCodeError(f"trust file {path} is not readable TOML: {exc}") from None
        unknown = sorted(set(raw) - {"modules", "fmus", "programs"})
        if unknown:
            raise UntrustedCodeError(
                f"trust file {path}: unknown key(s) {unknown}; allowed: modules, fmus, programs"
            )
        entries = {}
        for key in ("modules", "fmus", "programs"):
            value = raw.get(key, [])
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise UntrustedCodeError(f"trust file {path}: {key} must be a list of strings")
            entries[key] = frozenset(value)
        return cls(**entries)


@dataclass(frozen=True)
class CodeToRun:
    """Code a study file would run: what it is (for the message) and how to trust it."""

    description: str
    kind: str  # "modules" | "fmus" | "programs": the trust-file key
    entry: str  # what to list there
    digest: str | None = None  # an FMU's sha256 (also accepted in the trust file)

    def trusted_by(self, trusted: Trusted) -> bool:
        listed: frozenset[str] = getattr(trusted, self.kind)
        return self.entry in listed or (self.digest is not None and self.digest in listed)


def _resolve(path: str, base: Path) -> Path:
    candidate = Path(path).expanduser()
    return (candidate if candidate.is_absolute() else base / candidate).resolve()


def code_to_run(
    model: str, options: Mapping[str, Any], base: Path, runs_code: bool
) -> CodeToRun | None:
    """The code a study file's ``[model]`` would run on its author's say, or None.

    Parameters
    ----------
    model : the ``[model] name``; options : ``[model.options]``;
    base : the study file's folder (relative paths); runs_code : the registered
    model's :attr:`~fuzzymbs.study.registry.ModelSpec.runs_code` (False for references).
    """
    if ":" in model:
        module = model.partition(":")[0]
        return CodeToRun(
            f"the Python callable {model!r} (imports module {module!r} and calls it)",
            "modules",
            module.split(".")[0],
        )
    if not runs_code:
        return None
    if "path" in options and isinstance(options["path"], str):
        fmu = _resolve(options["path"], base)
        digest = None
        if fmu.is_file():
            digest = hashlib.sha256(fmu.read_bytes()).hexdigest()
        return CodeToRun(
            f"the FMU {fmu} (its binary runs inside fuzzymbs)", "fmus", str(fmu), digest
        )
    command = options.get("command")
    if isinstance(command, list) and command and isinstance(command[0], str):
        program = command[0]
        if "/" in program or "\\" in program:
            resolved = str(_resolve(program, Path(str(options.get("base_dir", base)))))
        else:
            resolved = shutil.which(program) or program
        arguments = " ".join([resolved, *map(str, command[1:])])
        return CodeToRun(f"the program {resolved!r} (as: {arguments})", "programs", resolved)
    return CodeToRun(f"code named by model {model!r}", "programs", model)


def check_study_code(
    study_file: Path,
    model: str,
    options: Mapping[str, Any],
    runs_code: bool,
    allow_code: bool,
    trusted: Trusted | None = None,
    command: str = "run",
) -> None:
    """Refuse a study file that would run code its user did not allow.

    Raises
    ------
    UntrustedCodeError
        Naming the study file, what it would run, and the two ways to allow it
        (``command``: the CLI command to name, ``run`` or ``identify``).
    """
    code = code_to_run(model, options, study_file.parent.resolve(), runs_code)
    if code is None or allow_code:
        return
    trusted = Trusted.load() if trusted is None else trusted
    if code.trusted_by(trusted):
        return
    raise UntrustedCodeError(
        f"{study_file}: this study file would run {code.description}. A study file is data "
        "and runs no code its user did not choose: if you trust this file, run it with "
        f"`fuzzymbs {command} --allow-code {study_file} ...`, or add {code.entry!r} to {code.kind} "
        f"in your trust file {trust_file()}"
    )
