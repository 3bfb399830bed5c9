"""Run a study file into an output folder: result.nc, plots, summary.txt.

``DIR/chunks/`` is the chunk store, so rerunning the same study into the same
folder resumes where an interrupted run stopped.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fuzzymbs.errors import IncompleteResultError, InvalidParameterError

logger = logging.getLogger(__name__)

RESULT_FILE = "result.nc"
SUMMARY_FILE = "summary.txt"
STORE_FOLDER = "chunks"


@dataclass
class StudyOutput:
    """What :func:`run_study_file` wrote."""

    directory: Path
    result: Any  # StudyResult
    result_path: Path
    summary_path: Path
    plots: list[Path]


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
) -> StudyOutput:
    """Load a study file, run it with ``out/chunks`` as store, and write the results.

    Settings given here override the file's ``[run]`` table, ``max_runs`` its
    ``[study] max_runs``. ``allow_code`` lets the file run code its author
    named (a module reference, an FMU, a program; :mod:`fuzzymbs.study.trust`).

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
    """
    from fuzzymbs.study.studyfile import load_study_file

    definition = load_study_file(
        path, allow_code=allow_code, max_runs=max_runs, file_executor=executor is None
    )
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InvalidParameterError(f"output folder {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    summary_path = out / SUMMARY_FILE
    try:
        result = definition.study.run(
            executor=executor if executor is not None else definition.executor,
            chunk_size=chunk_size if chunk_size is not None else definition.chunk_size,
            store=out / STORE_FOLDER,
            resume=resume,
            progress=progress,
            on_failure=on_failure or definition.on_failure,
        )
    except IncompleteResultError as exc:
        summary_path.write_text(
            f"Study: {definition.name}\nStatus: FAILED - no result written\n{exc}\n"
        )
        raise
    result.dataset.attrs["plots"] = json.dumps({"membership": definition.membership_plots})
    result.dataset.attrs["study_file"] = str(Path(path).name)
    result_path = result.to_netcdf(out / RESULT_FILE)
    summary_path.write_text(result.summary())
    written = result.plot(out) if plots else []
    logger.info(
        "study %s: wrote %s, %s and %d plots",
        definition.name,
        result_path,
        summary_path,
        len(written),
    )
    return StudyOutput(out, result, result_path, summary_path, written)


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
