"""An external program as a batched fuzzymbs model: one run per sample, files in and out.

For each sample the model makes a fresh run directory, writes the input file
from a template, runs the program (never through a shell: the arguments are a
list) and reads the CSV file the program wrote::

    command  = ["my-solver", "--deck", "{input}", "--result", "{output}"]
    template = "deck.tpl"          # "{stiffness}" in it becomes the sample's value

- ``{input}`` and ``{output}`` in the arguments become the paths of the input
  file and of the CSV file to write, in the run directory (also the working
  directory of the program); ``{run}`` becomes the run directory and
  ``{study_dir}`` the folder relative paths refer to (``base_dir``: the study
  file's folder).
- An argument without placeholders that names an existing file relative to
  ``base_dir`` (``["python", "run_solver.py", ...]``) is given as that file's
  absolute path (the program runs in its run directory, where a relative path
  would not find it); its content is part of :meth:`CommandModel.identity`.
- Every other ``{name}`` in the template or the arguments is a parameter of
  the model and becomes the sample's value, written with full precision
  (``repr`` of the float: it reads back to the same number).
- The CSV file has a header row. A column named like the ``coordinate``
  option (default ``time``) becomes the coordinate of the other columns (time
  signals); without it the file must have one row (scalar outputs).

A run that exits with a non-zero status, times out, or writes no or a
malformed output file is flagged failed with the reason (exit status and the
last lines of the program's stderr); the other samples are kept.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
import shutil
import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.study.registry import ParameterInfo

__all__ = ["CommandModel", "make_command_model"]

#: ``{name}`` placeholders: a parameter name (letters, digits, _ and ., not first a digit)
PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_.]*)\}")
#: placeholders that are not parameters
RESERVED = ("input", "output", "run", "study_dir")
#: lines of a failed program's stderr quoted in the failure reason
STDERR_LINES = 5
INPUT_FILE = "input.txt"
OUTPUT_FILE = "output.csv"


class RunFailed(Exception):
    """One run of the program failed; the message says why."""


def _placeholders(text: str) -> list[str]:
    return [name for name in dict.fromkeys(PLACEHOLDER.findall(text)) if name not in RESERVED]


def _fill(text: str, values: Mapping[str, str]) -> str:
    return PLACEHOLDER.sub(lambda m: values.get(m.group(1), m.group(0)), text)


def _tail(text: str, lines: int = STDERR_LINES) -> str:
    kept = [line for line in text.strip().splitlines() if line.strip()][-lines:]
    return " | ".join(kept)


def read_output_csv(path: Path, coordinate: str) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """Outputs and coordinate values of a run's CSV file.

    Returns
    -------
    outputs : dict
        Column -> (T,) values (time signals) or () values (one row, no coordinate).
    coordinate : (T,) ndarray or None
        The coordinate column, if the file has one.

    Raises
    ------
    RunFailed
        Missing file, no header, no data, ragged rows, non-numeric or non-finite values,
        duplicate column names, or several rows without a coordinate column.
    """
    if not path.is_file():
        raise RunFailed(f"the program wrote no output file {path.name}")
    with path.open(newline="", encoding="utf-8", errors="replace") as handle:
        rows = [row for row in csv.reader(handle) if any(cell.strip() for cell in row)]
    if not rows:
        raise RunFailed(f"output file {path.name} is empty (expected a header row and data)")
    header = [cell.strip() for cell in rows[0]]
    if any(not name for name in header) or len(set(header)) != len(header):
        raise RunFailed(f"output file {path.name}: header {header} has empty or repeated names")
    if len(rows) < 2:
        raise RunFailed(f"output file {path.name} has a header but no data rows")
    values = np.empty((len(rows) - 1, len(header)))
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise RunFailed(
                f"output file {path.name}, line {line}: {len(row)} values for {len(header)} columns"
            )
        for column, cell in enumerate(row):
            try:
                values[line - 2, column] = float(cell)
            except ValueError:
                raise RunFailed(
                    f"output file {path.name}, line {line}, column {header[column]!r}: "
                    f"{cell.strip()!r} is not a number"
                ) from None
    if not np.isfinite(values).all():
        raise RunFailed(f"output file {path.name} holds NaN or infinite values")
    if coordinate in header:
        index = header.index(coordinate)
        outputs = {name: values[:, i] for i, name in enumerate(header) if i != index}
        return outputs, values[:, index]
    if len(values) != 1:
        raise RunFailed(
            f"output file {path.name} has {len(values)} rows but no coordinate column "
            f"{coordinate!r} (several rows need one; one row gives scalar outputs)"
        )
    return {name: values[0, i] for i, name in enumerate(header)}, None


class CommandModel:
    """A batched model that runs an external program once per sample.

    Parameters
    ----------
    command : sequence of str
        The program and its arguments; ``{input}``, ``{output}``, ``{run}`` and
        ``{parameter}`` placeholders are replaced (see the module docstring).
        A relative program path containing a separator is taken relative to
        ``base_dir``.
    template : str or Path, optional
        Input file template (relative to ``base_dir``); written to ``{input}``
        with every ``{parameter}`` replaced.
    timeout : float, optional
        Seconds a run may take before it is killed and flagged failed.
    keep_runs : bool or str or Path
        Keep the run directories: True keeps them in a new folder under the
        system's temporary directory, a path keeps them there (relative to
        ``base_dir``); False (default) deletes each after reading its output.
    coordinate : str
        Name of the CSV column that is the coordinate of the others (default "time").
    base_dir : str or Path, optional
        Folder that relative paths are resolved against (the study file's
        folder; default the current directory).

    Raises
    ------
    InvalidParameterError
        An empty command, a missing template or program, a bad timeout.
    """

    def __init__(
        self,
        command: Sequence[str],
        template: str | Path | None = None,
        timeout: float | None = None,
        keep_runs: bool | str | Path = False,
        coordinate: str = "time",
        base_dir: str | Path | None = None,
    ) -> None:
        base = Path(base_dir).resolve() if base_dir is not None else Path.cwd()
        if isinstance(command, str) or not command or not all(isinstance(a, str) for a in command):
            raise InvalidParameterError(
                "model 'command': command must be a non-empty list of strings, e.g. "
                '["my-solver", "{input}", "{output}"] (it is never run through a shell)'
            )
        arguments = list(command)
        program = arguments[0]
        if ("/" in program or "\\" in program) and not Path(program).is_absolute():
            program = str(base / program)
        if shutil.which(program) is None:
            raise InvalidParameterError(
                f"model 'command': program {arguments[0]!r} not found (or not executable)"
                + (f" relative to {base}" if program != arguments[0] else " on PATH")
            )
        arguments[0] = program
        #: arguments naming files beside the study file, made absolute (see the module doc)
        self.files: list[Path] = []
        for position, argument in enumerate(arguments[1:], start=1):
            if PLACEHOLDER.search(argument) or not argument or Path(argument).is_absolute():
                continue
            candidate = base / argument
            if candidate.is_file():
                arguments[position] = str(candidate)
                self.files.append(candidate)
        self.base_dir = base
        self.command = arguments
        self.template_path: Path | None = None
        self.template = ""
        if template is not None:
            path = Path(template)
            path = path if path.is_absolute() else base / path
            if not path.is_file():
                raise InvalidParameterError(f"model 'command': template {path} not found")
            self.template_path = path
            self.template = path.read_text(encoding="utf-8")
        if timeout is not None and (
            isinstance(timeout, bool)
            or not isinstance(timeout, int | float)
            or not (math.isfinite(timeout) and timeout > 0)
        ):
            raise InvalidParameterError(
                f"model 'command': timeout must be a positive number of seconds, got {timeout!r}"
            )
        self.timeout = None if timeout is None else float(timeout)
        if isinstance(keep_runs, bool):
            self.keep_dir: Path | None = (
                Path(tempfile.mkdtemp(prefix="fuzzymbs-runs-")) if keep_runs else None
            )
        else:
            folder = Path(keep_runs)
            self.keep_dir = folder if folder.is_absolute() else base / folder
        if not isinstance(coordinate, str) or not coordinate:
            raise InvalidParameterError("model 'command': coordinate must be a column name")
        self.coordinate = coordinate
        names = _placeholders(self.template)
        for argument in arguments[1:]:
            names += [n for n in _placeholders(argument) if n not in names]
        self.parameters = {
            name: ParameterInfo("1", f"{{{name}}} in the input file or command", None)
            for name in names
        }
        self.output_dims: dict[str, tuple[str, ...]] = {}

    def identity(self) -> dict[str, Any]:
        """What a result store must match besides the options: the template and program."""
        digest = hashlib.sha256(self.template.encode("utf-8"))
        program = Path(shutil.which(self.command[0]) or self.command[0])
        if program.is_file():
            digest.update(program.read_bytes())
        for path in getattr(self, "files", []):  # scripts and decks named in the arguments
            if path.is_file():
                digest.update(str(path).encode() + b"\0" + path.read_bytes())
        return {"command_sha256": digest.hexdigest()}

    # ------------------------------------------------------------------ run
    def _run_directory(self, values: Mapping[str, str]) -> Path:
        if self.keep_dir is None:
            return Path(tempfile.mkdtemp(prefix="fuzzymbs-run-"))
        self.keep_dir.mkdir(parents=True, exist_ok=True)
        label = hashlib.sha256(repr(sorted(values.items())).encode()).hexdigest()[:10]
        return Path(tempfile.mkdtemp(prefix=f"run-{label}-", dir=self.keep_dir))

    def run_one(
        self, values: Mapping[str, float]
    ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
        """Run the program for one sample; its outputs and coordinate (or raise RunFailed)."""
        text = {name: repr(float(value)) for name, value in values.items()}
        directory = self._run_directory(text)
        input_path, output_path = directory / INPUT_FILE, directory / OUTPUT_FILE
        paths = {
            "input": str(input_path),
            "output": str(output_path),
            "run": str(directory),
            "study_dir": str(getattr(self, "base_dir", Path.cwd())),
        }
        try:
            if self.template_path is not None:
                input_path.write_text(
                    _fill(self.template, {**text, "study_dir": paths["study_dir"]}),
                    encoding="utf-8",
                )
            arguments = [self.command[0]] + [
                _fill(argument, {**text, **paths}) for argument in self.command[1:]
            ]
            try:
                finished = subprocess.run(
                    arguments,
                    cwd=directory,
                    stdin=subprocess.DEVNULL,
                    capture_output=True,
                    text=True,
                    errors="replace",
                    timeout=self.timeout,
                    check=False,
                )
            except subprocess.TimeoutExpired as exc:
                stderr = (
                    exc.stderr.decode(errors="replace")
                    if isinstance(exc.stderr, bytes)
                    else exc.stderr
                )
                tail = _tail(stderr or "")
                raise RunFailed(
                    f"timed out after {self.timeout:g} s" + (f"; stderr: {tail}" if tail else "")
                ) from None
            except OSError as exc:
                raise RunFailed(f"could not start {arguments[0]!r}: {exc}") from None
            if finished.returncode != 0:
                tail = _tail(finished.stderr or "")
                raise RunFailed(
                    f"exit status {finished.returncode}" + (f"; stderr: {tail}" if tail else "")
                )
            return read_output_csv(output_path, self.coordinate)
        except RunFailed as exc:
            where = f" (run directory kept: {directory})" if self.keep_dir is not None else ""
            raise RunFailed(f"{Path(self.command[0]).name}: {exc}{where}") from None
        finally:
            if self.keep_dir is None:
                shutil.rmtree(directory, ignore_errors=True)

    def __call__(self, samples: Mapping[str, np.ndarray]) -> dict[str, Any]:
        """Run every sample; outputs ``(B, ...)``, ``failed``, ``failure_reason`` and
        the coordinate found (``coords``)."""
        missing = [name for name in self.parameters if name not in samples]
        if missing:
            raise InvalidParameterError(f"model 'command': no values for parameter(s) {missing}")
        columns = {name: np.asarray(samples[name], dtype=float) for name in self.parameters}
        size = len(next(iter(samples.values())))
        failed = np.zeros(size, dtype=bool)
        reasons = np.full(size, "", dtype=object)
        results: list[dict[str, np.ndarray] | None] = []
        reference: tuple[list[str], np.ndarray | None] | None = None
        for i in range(size):
            try:
                outputs, coordinate = self.run_one({n: c[i] for n, c in columns.items()})
                if reference is None:
                    reference = (list(outputs), coordinate)
                elif list(outputs) != reference[0]:
                    raise RunFailed(
                        f"output columns {list(outputs)} differ from the first run's {reference[0]}"
                    )
                elif (coordinate is None) != (reference[1] is None) or (
                    coordinate is not None
                    and (
                        coordinate.shape != reference[1].shape
                        or not np.allclose(coordinate, reference[1], rtol=1e-9, atol=0)
                    )
                ):
                    raise RunFailed(
                        f"the {self.coordinate!r} column differs from the first run's; every "
                        "run must write the same coordinate values"
                    )
            except RunFailed as exc:
                failed[i] = True
                reasons[i] = str(exc)
                results.append(None)
                continue
            results.append(outputs)
        if reference is None:  # every run failed: nothing to shape the outputs by
            return {"failed": failed, "failure_reason": reasons.astype(str)}
        names, coordinate = reference
        data: dict[str, Any] = {}
        for name in names:
            shape = () if coordinate is None else coordinate.shape
            merged = np.full((size, *shape), np.nan)
            for i, outputs in enumerate(results):
                if outputs is not None:
                    merged[i] = outputs[name]
            data[name] = merged
            self.output_dims[name] = () if coordinate is None else (self.coordinate,)
        data["failed"] = failed
        data["failure_reason"] = reasons.astype(str)
        if coordinate is not None:
            data["coords"] = {self.coordinate: coordinate}
        return data

    def __repr__(self) -> str:
        return f"CommandModel({self.command!r}, parameters={list(self.parameters)})"


def make_command_model(**options: Any) -> CommandModel:
    """Factory of the registered model ``command`` (options as in :class:`CommandModel`)."""
    if "command" not in options:
        raise InvalidParameterError(
            'model \'command\' needs the option command, e.g. ["my-solver", "{input}", "{output}"]'
        )
    return CommandModel(**options)
