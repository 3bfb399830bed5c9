"""Run a study file into an output folder: result.nc, plots, summary.txt, report.html.

``DIR/chunks/`` is the chunk store, so rerunning the same study into the same
folder resumes where an interrupted run stopped.

One run at a time writes into a folder: a run holds an exclusive lock on
``DIR/.fuzzymbs.lock`` (POSIX ``flock``, released by the system however the
run ends), and a second run into the busy folder stops at once with a one-line
error. A result in the folder is current or absent: when a run starts, an
earlier ``result.nc`` is moved to ``previous-result.nc`` and the plots the
earlier run wrote (listed in ``DIR/.plots``) are removed, and ``summary.txt``
says the run is under way; a run that fails says so in ``summary.txt`` and
writes no ``result.nc``; a run that succeeds removes ``previous-result.nc``.

``DIR/.figures`` keeps the figures of the last result by content: a rerun whose
result is the same (every run resumed from the store) copies them instead of
drawing them again.
"""

from __future__ import annotations

import json
import logging
import os
import shlex
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from fuzzymbs.errors import InvalidParameterError, OutputFolderError
from fuzzymbs.study.executors import KeptExecutor, check_executor_spec

logger = logging.getLogger(__name__)

RESULT_FILE = "result.nc"
SUMMARY_FILE = "summary.txt"
STORE_FOLDER = "chunks"
#: where an earlier result of the folder waits while a new run is under way or after it failed
PREVIOUS_RESULT_FILE = "previous-result.nc"
#: the plot files the last run wrote (one name a line), removed when the next run starts
PLOT_LIST = ".plots"
LOCK_FILE = ".fuzzymbs.lock"
#: the figures of the folder's last result by content (:func:`fuzzymbs.plot.write_plots`)
FIGURE_CACHE = ".figures"


def prepare_output_folder(out: Path) -> None:
    """Create ``out`` and check that files can be written into it, before any sample runs.

    Raises
    ------
    OutputFolderError
        ``out`` is a file, lies below a file, is a dangling link, or is not writable.
    """
    if out.is_symlink() and not out.exists():
        raise OutputFolderError(
            f"output folder {out} is a symbolic link to nothing ({os.readlink(out)}); "
            "remove it or choose another --out"
        )
    if out.exists() and not out.is_dir():
        raise OutputFolderError(
            f"output folder {out} exists and is not a directory; choose another --out"
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        raise OutputFolderError(
            f"output folder {out} cannot be written ({exc.strerror or exc}); choose a "
            "writable --out"
        ) from None


@contextmanager
def locked_output_folder(out: Path) -> Iterator[None]:
    """Hold the exclusive lock of ``out`` (see the module docstring) while the block runs.

    Raises
    ------
    OutputFolderError
        Another run holds the lock.
    """
    try:
        import fcntl
    except ImportError:  # Windows: no advisory locks here; one run per folder is up to the user
        yield
        return
    path = out / LOCK_FILE
    with path.open("a+") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            raise OutputFolderError(
                f"output folder {out} is in use by another fuzzymbs run (process {holder}); "
                "wait for it to end or choose another --out"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(str(os.getpid()))
        handle.flush()
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def _set_aside_earlier_result(out: Path) -> bool:
    """Move an earlier result.nc aside and remove the plots of the earlier run.

    Returns whether an earlier result was moved to ``previous-result.nc``.
    """
    listing = out / PLOT_LIST
    if listing.is_file():
        for name in listing.read_text(encoding="utf-8").splitlines():
            plot = out / name
            # only plain file names of this folder: the list is data, never a path elsewhere
            if name and Path(name).name == name and not name.startswith("."):
                plot.unlink(missing_ok=True)
        listing.unlink()
    result = out / RESULT_FILE
    if result.exists():
        os.replace(result, out / PREVIOUS_RESULT_FILE)
        return True
    return False


def _write_text(path: Path, text: str) -> None:
    """Write a small text file through a temporary file of its own (never half written)."""
    handle, name = tempfile.mkstemp(
        prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent
    )
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)
        os.replace(name, path)
    except BaseException:
        Path(name).unlink(missing_ok=True)
        raise


@dataclass
class StudyOutput:
    """What :func:`run_study_file` wrote."""

    directory: Path
    result: Any  # StudyResult
    result_path: Path
    summary_path: Path
    plots: list[Path]
    report_path: Path | None = None


def run_study_file(
    path: str | Path,
    out: str | Path,
    *,
    executor: Any = None,
    chunk_size: int | None = None,
    on_failure: str | None = None,
    resume: bool = True,
    progress: bool = True,
    plots: bool = True,
    allow_code: bool = False,
    max_runs: int | None = None,
    study_options: dict[str, Any] | None = None,
    timeout: float | None = None,
    report: bool = True,
    command: str | None = None,
    formats: tuple[str, ...] = ("png",),
) -> StudyOutput:
    """Load a study file, run it with ``out/chunks`` as store, and write the results.

    Settings given here override the file's ``[run]`` table (``timeout``: seconds
    a sample may take), ``max_runs`` its ``[study] max_runs`` and ``study_options``
    its other study options (:class:`~fuzzymbs.study.options.StudyOptions`). ``allow_code``
    lets the file run code its author named (a module reference, an FMU, a
    program; :mod:`fuzzymbs.study.trust`). ``report`` writes ``out/report.html``
    (:mod:`fuzzymbs.report`); ``command``, the command line that ran the study, is
    recorded in the result for its reproduction, with the folder it ran in and the
    ``PYTHONPATH`` a model loaded by a module path needs (:func:`reproducible_command`).
    ``formats``: the plot files' formats (png, pdf, svg); the report embeds the PNG
    images (drawn for it if png is not asked).

    Raises
    ------
    StudyFileError
        The study file is invalid, or its plan needs more runs than ``max_runs``
        (refused before anything is built).
    IncompleteResultError
        Samples failed (and on_failure is not "partial"); ``summary.txt`` then
        lists the failures and the stored chunks are kept for a rerun.
    StoreMismatchError
        ``out`` holds the store of a different study.
    OutputFolderError
        ``out`` cannot be created or written, or another run is writing into it
        (checked before any sample runs).
    """
    from fuzzymbs.study.studyfile import load_study_file

    check_executor_spec(executor)  # before the study is built or a folder touched

    definition = load_study_file(
        path,
        allow_code=allow_code,
        max_runs=max_runs,
        file_executor=executor is None,
        study_options=study_options,
    )
    if executor is None:
        check_executor_spec(definition.executor)  # the study file's own, likewise
    out = Path(out)
    prepare_output_folder(out)
    with locked_output_folder(out):
        return _run_locked(
            definition,
            Path(path),
            out,
            executor,
            chunk_size,
            on_failure,
            resume,
            progress,
            plots,
            timeout,
            report,
            command,
            formats,
        )


def reproducible_command(command: str, model: str, folder: str | Path | None = None) -> str:
    """``command`` as it runs from any folder: ``cd FOLDER && [PYTHONPATH=...] COMMAND``.

    The command's relative paths (the study file, ``--out``) are relative to the
    folder it was typed in, and a model loaded by a module path imports only with
    the ``PYTHONPATH`` it was imported through (:func:`model_python_path`), so both
    are part of the command that reproduces a result.

    Parameters
    ----------
    command : str
        The fuzzymbs command line as typed (POSIX shell quoting).
    model : str
        The study's model name (a registered name or ``"package.module:callable"``).
    folder : str or Path, optional
        The folder the command was typed in; the current working folder by default.

    Returns
    -------
    str
        A POSIX shell command line.
    """
    from fuzzymbs.study.code_version import model_python_path

    folder = Path.cwd() if folder is None else Path(folder).resolve()
    python_path = model_python_path(model)
    environment = f"PYTHONPATH={shlex.quote(python_path)} " if python_path else ""
    return f"cd {shlex.quote(str(folder))} && {environment}{command}"


def _run_locked(
    definition: Any,
    path: Path,
    out: Path,
    executor: Any,
    chunk_size: int | None,
    on_failure: str | None,
    resume: bool,
    progress: bool,
    plots: bool,
    timeout: float | None,
    report: bool = True,
    command: str | None = None,
    formats: tuple[str, ...] = ("png",),
) -> StudyOutput:
    """:func:`run_study_file` once the output folder is locked."""
    from fuzzymbs.study.store import remove_orphans

    summary_path = out / SUMMARY_FILE
    remove_orphans(out)  # temporary files of an ended run (a kill, a full disk)
    kept = _set_aside_earlier_result(out)
    earlier = (
        f"The earlier result of this folder is kept as {PREVIOUS_RESULT_FILE}.\n" if kept else ""
    )
    _write_text(
        summary_path,
        f"Study: {definition.name}\nStatus: RUNNING - started {time.strftime('%Y-%m-%d %H:%M:%S')}"
        f" (process {os.getpid()}); no result yet\n{earlier}",
    )
    result_path = out / RESULT_FILE
    # the study's executor stays open for the figures: they are drawn on its workers
    work = KeptExecutor(executor if executor is not None else definition.executor)
    try:
        result = definition.study.run(
            executor=work,
            chunk_size=chunk_size if chunk_size is not None else definition.chunk_size,
            store=out / STORE_FOLDER,
            resume=resume,
            progress=progress,
            on_failure=on_failure or definition.on_failure,
            timeout=definition.timeout if timeout is None else timeout,
        )
        result.dataset.attrs["plots"] = json.dumps({"membership": definition.membership_plots})
        result.dataset.attrs["study_file"] = str(path.name)
        if command:
            model = str(result.dataset.attrs.get("model", ""))
            result.dataset.attrs["command"] = reproducible_command(command, model)
        write_result = partial(result.to_netcdf, result_path)
        written = []
        if plots:
            from fuzzymbs.plot import write_plots

            # a rerun whose result is unchanged (every run resumed) copies its figures;
            # result.nc is written while the workers draw
            written = write_plots(
                result.dataset,
                out,
                formats=formats,
                cache=out / FIGURE_CACHE,
                executor=_figure_executor(work),
                meanwhile=write_result,
            )
        else:
            write_result()
        report_path = None
        if report:
            from fuzzymbs.report import REPORT_FILE, write_report

            # the report embeds the PNG files just written instead of drawing them again
            images = {p.stem: p.read_bytes() for p in written if p.suffix == ".png"}
            report_path = write_report(result.dataset, out / REPORT_FILE, images)
        listed = written + ([report_path] if report_path is not None else [])
        _write_text(out / PLOT_LIST, "".join(f"{p.name}\n" for p in listed))
        _write_text(summary_path, result.summary())
    except BaseException as exc:
        # whatever failed (the study, a full disk while writing), no result looks current
        result_path.unlink(missing_ok=True)
        interrupted = isinstance(exc, KeyboardInterrupt)
        status = (
            "INTERRUPTED - no result written; a rerun resumes from the stored chunks"
            if interrupted
            else f"FAILED - no result written\n{exc}"
        )
        try:
            _write_text(summary_path, f"Study: {definition.name}\nStatus: {status}\n{earlier}")
        except OSError:  # e.g. the disk is full: the error below says what happened
            pass
        raise
    finally:
        work.close()
    (out / PREVIOUS_RESULT_FILE).unlink(missing_ok=True)
    logger.info(
        "study %s: wrote %s, %s and %d plots",
        definition.name,
        result_path,
        summary_path,
        len(written),
    )
    return StudyOutput(out, result, result_path, summary_path, written, report_path)


def _figure_executor(work: KeptExecutor) -> Any:
    """Where the figures are drawn: on the study's workers if it started any (a Dask
    cluster, a process pool), else here."""
    started = work.started
    return None if started is None or started.label == "inline" else started.executor


def demo_names() -> list[str]:
    """Names of the demos shipped in ``fuzzymbs/demos`` (folders holding *.toml)."""
    from importlib import resources

    root = resources.files("fuzzymbs") / "demos"
    if not root.is_dir():
        return []
    return sorted(
        entry.name
        for entry in root.iterdir()
        if entry.is_dir() and any(f.name.endswith(".toml") for f in entry.iterdir())
    )


def demo_files(name: str) -> list[Any]:
    """The study files of demo ``name`` sorted by file name (importlib.resources traversables).

    Raises
    ------
    InvalidParameterError
        For an unknown demo name; the message lists the shipped demos.
    """
    from importlib import resources

    if name not in demo_names():  # never a path: only the shipped demos run
        raise InvalidParameterError(
            f"unknown demo {name!r}; shipped demos: {', '.join(demo_names()) or '(none)'}"
        )
    folder = resources.files("fuzzymbs") / "demos" / name
    files = (
        sorted((f for f in folder.iterdir() if f.name.endswith(".toml")), key=lambda f: f.name)
        if folder.is_dir()
        else []
    )
    if not files:
        raise InvalidParameterError(
            f"unknown demo {name!r}; shipped demos: {', '.join(demo_names()) or '(none)'}"
        )
    return files


#: A demo's recorded cost (beside its study files), for the estimate printed before it runs.
DEMO_TIMING_FILE = "timing.json"


@dataclass(frozen=True)
class DemoEstimate:
    """How long a demo takes here: its recorded wall time scaled by the cost of one
    sample-step here against the cost when it was recorded."""

    seconds: float
    recorded_seconds: float
    sample_step_seconds: float
    recorded_sample_step_seconds: float

    def describe(self) -> str:
        """One line for the user."""
        return (
            f"about {_duration(self.seconds)} on this machine (measured "
            f"{_duration(self.recorded_seconds)} where a sample-step took "
            f"{self.recorded_sample_step_seconds * 1e6:.3g} us; here it takes "
            f"{self.sample_step_seconds * 1e6:.3g} us)"
        )


def _duration(seconds: float) -> str:
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest} s" if minutes else f"{rest} s"


def _brake_sample_step() -> float:
    from fuzzymbs.models.brake.calibration import seconds_per_sample_step

    return seconds_per_sample_step()


#: Calibrations a demo's timing file may name: the seconds of one sample-step here.
CALIBRATIONS = {"brake": _brake_sample_step}


def _timing_entry(name: str) -> Any | None:
    from importlib import resources

    entry = resources.files("fuzzymbs") / "demos" / name / DEMO_TIMING_FILE
    return entry if name in demo_names() and entry.is_file() else None


def demo_has_timing(name: str) -> bool:
    """Whether demo ``name`` has a recorded timing (and :func:`demo_estimate` an estimate)."""
    return _timing_entry(name) is not None


def demo_estimate(name: str) -> DemoEstimate | None:
    """How long demo ``name`` will take on this machine, or None for a demo without a
    recorded timing (``fuzzymbs/demos/NAME/timing.json``: its wall time ``seconds``,
    the ``calibration`` it was measured with and that calibration's
    ``sample_step_seconds`` then). Runs the calibration (a second or less, after the
    compilation of its kernels on a first run, which the demo needs anyway)."""
    entry = _timing_entry(name)
    if entry is None:
        return None
    recorded = json.loads(entry.read_text(encoding="utf-8"))
    now = CALIBRATIONS[recorded["calibration"]]()
    ratio = now / float(recorded["sample_step_seconds"])
    return DemoEstimate(
        float(recorded["seconds"]) * ratio,
        float(recorded["seconds"]),
        now,
        float(recorded["sample_step_seconds"]),
    )
