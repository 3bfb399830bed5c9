"""Command line: ``fuzzymbs run | demo | plot | report | identify | info``.

Heavy modules (NumPy, xarray, matplotlib, models) are imported inside the
commands so that ``fuzzymbs --help`` and ``fuzzymbs info`` start quickly.
"""

from __future__ import annotations

import atexit
import functools
import gc
import logging
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

app = typer.Typer(
    name="fuzzymbs",
    help="Fuzzy-arithmetical uncertainty analysis of multibody contact models.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

EXIT_ERROR = 1
#: environment variable that, set to a non-empty value other than 0, shows tracebacks
DEBUG_ENV = "FUZZYMBS_DEBUG"
_debug = {"on": False}


def _debugging() -> bool:
    return _debug["on"] or os.environ.get(DEBUG_ENV, "") not in ("", "0")


def _describe(exc: BaseException) -> str:
    """One line for an error: the message of fuzzymbs's own errors, the file of an OSError."""
    from fuzzymbs.errors import FuzzymbsError

    if isinstance(exc, FuzzymbsError):
        text = str(exc)
    elif isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        text = f"{where}{exc.strerror or exc}"
    else:
        text = (
            f"unexpected {type(exc).__name__}: {exc} (rerun with --debug for the traceback, "
            "and please report it)"
        )
    return " ".join(text.split())  # one line


def _control_exceptions() -> tuple[type[BaseException], ...]:
    """typer's own exit and usage exceptions, which typer reports itself. Recent typer
    has its own (and no dependency on click); older typer raises click's."""
    found: list[type[BaseException]] = [typer.Exit, typer.Abort]
    if hasattr(typer, "TyperException"):
        found.append(typer.TyperException)
    try:
        import click
    except ImportError:  # typer without click: nothing more to pass through
        return tuple(found)
    return (*found, click.exceptions.Exit, click.ClickException)


_PASSED_THROUGH = _control_exceptions()


def _one_line_errors(command: Callable[..., Any]) -> Callable[..., Any]:
    """Every error of ``command`` ends it with one line on stderr and exit status 1
    (``--debug`` or ``FUZZYMBS_DEBUG=1``: the traceback instead)."""

    @functools.wraps(command)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return command(*args, **kwargs)
        except _PASSED_THROUGH:
            raise
        except Exception as exc:
            if _debugging():
                raise
            raise _fail(_describe(exc)) from None

    return wrapper


def _print_version(value: bool) -> None:
    if value:
        from fuzzymbs.version import __version__

        typer.echo(f"fuzzymbs {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_print_version, is_eager=True, help="Print the version and exit."
        ),
    ] = False,
    debug: Annotated[
        bool,
        typer.Option(
            "--debug",
            help=f"Show the traceback of an error instead of one line (also: {DEBUG_ENV}=1).",
        ),
    ] = False,
) -> None:
    """Fuzzy-arithmetical uncertainty analysis of multibody contact models."""
    _debug["on"] = debug


def _setup_logging(quiet: bool, verbose: bool) -> None:
    from rich.console import Console
    from rich.logging import RichHandler

    level = logging.WARNING if quiet else (logging.DEBUG if verbose else logging.INFO)
    # A Rich console on stderr prints log records above a running progress bar.
    handler = RichHandler(console=Console(stderr=True), show_time=False, show_path=False)
    logging.basicConfig(level=level, format="%(name)s: %(message)s", handlers=[handler], force=True)
    logging.getLogger("distributed").setLevel(max(level, logging.WARNING))


def _fail(message: str) -> typer.Exit:
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(EXIT_ERROR)


def _run_one(study_file: Path, out: Path, **options: object) -> None:
    from fuzzymbs.study.pipeline import run_study_file

    # errors: one line from _one_line_errors (the traceback with --debug)
    written = run_study_file(study_file, out, **options)  # type: ignore[arg-type]
    report = f", report: {written.report_path}" if written.report_path else ""
    typer.echo(
        f"{written.result_path}  ({len(written.plots)} plots, summary: {written.summary_path}"
        f"{report})"
    )


def _command(*arguments: str, **options: object) -> str:
    """The fuzzymbs command line of the given arguments and the options that were set."""
    import shlex

    words = ["fuzzymbs", *arguments]
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        if value is True:
            words.append(flag)
        elif isinstance(value, list):  # a repeatable option
            for item in value:
                words += [flag, str(item)]
        elif value is not None and value is not False:
            words += [flag, str(value)]
    return shlex.join(words)


def _study_options(items: list[str] | None) -> dict[str, object]:
    """``--option NAME=VALUE`` as ``{NAME: VALUE}``, each VALUE read as a TOML value (as
    under ``[study]``); the names and values are checked by the study options'
    declaration when the file is loaded."""
    import tomllib

    given: dict[str, object] = {}
    for item in items or []:
        name, equals, text = item.partition("=")
        if not equals or not name.strip():
            raise _fail(
                f"--option {item!r}: give NAME=VALUE, e.g. --option validation_runs=0 "
                "(fuzzymbs info lists the study options)"
            )
        try:
            given[name.strip()] = tomllib.loads(f"value = {text.strip()}")["value"]
        except tomllib.TOMLDecodeError:
            raise _fail(f"--option {item!r}: {text!r} is not a TOML value") from None
    return given


QuietOption = Annotated[
    bool, typer.Option("--quiet", "-q", help="No progress bar; warnings and errors only.")
]
VerboseOption = Annotated[bool, typer.Option("--verbose", "-v", help="Debug logging.")]
FormatOption = Annotated[
    list[str] | None,
    typer.Option("--format", help="Plot file format: png (the default), pdf, svg; repeatable."),
]


def _formats(fmt: list[str] | None) -> tuple[str, ...]:
    """The plot formats asked for (PNG when none), checked before anything runs."""
    from fuzzymbs.plot import DEFAULT_FORMATS, FORMATS

    formats = tuple(dict.fromkeys(fmt)) if fmt else DEFAULT_FORMATS
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise _fail(f"--format {unknown}; allowed: {', '.join(FORMATS)}")
    return formats


@app.command()
@_one_line_errors
def run(
    study_file: Annotated[Path, typer.Argument(help="Study file (TOML).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (also the store).")],
    executor: Annotated[
        str | None,
        typer.Option(help="inline | processes[:N] | dask://HOST:PORT (default: the file's)."),
    ] = None,
    chunk_size: Annotated[
        int | None, typer.Option(min=1, help="Samples per task (default: the file's or 256).")
    ] = None,
    on_failure: Annotated[
        str | None, typer.Option(help="raise | fail-fast | partial (default: the file's).")
    ] = None,
    fresh: Annotated[
        bool, typer.Option("--fresh", help="Discard stored chunks of this study; do not resume.")
    ] = False,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip the plots.")] = False,
    fmt: FormatOption = None,
    no_report: Annotated[
        bool, typer.Option("--no-report", help="Skip OUT/report.html (the HTML report).")
    ] = False,
    allow_code: Annotated[
        bool,
        typer.Option(
            "--allow-code",
            help="Let the study file run code it names: a 'module:callable' model, an FMU or "
            "a program. Only for files you trust.",
        ),
    ] = False,
    timeout: Annotated[
        float | None,
        typer.Option(
            "--timeout",
            help="Seconds a sample of a Python model may take on the inline or process "
            "executors; a slower sample fails (default: the file's [run] timeout, else none).",
        ),
    ] = None,
    max_runs: Annotated[
        int | None,
        typer.Option(
            "--max-runs",
            min=1,
            help="Refuse a plan needing more model runs than this, before it is built "
            "(default: the file's [study] max_runs, else the study options' default; "
            "fuzzymbs info lists it).",
        ),
    ] = None,
    option: Annotated[
        list[str] | None,
        typer.Option(
            "--option",
            help="A study or method option NAME=VALUE overriding the file's [study] one, "
            "e.g. validation_runs=0 or gradients=false (fuzzymbs info lists them); "
            "repeatable.",
        ),
    ] = None,
    quiet: QuietOption = False,
    verbose: VerboseOption = False,
) -> None:
    """Run STUDY_FILE; write OUT/result.nc, plots, OUT/summary.txt and OUT/report.html
    (rerun resumes).

    A study file is data: one that names code to run (a module reference, an FMU, a
    program) is refused unless --allow-code is given or the code is in your trust file.
    """
    from fuzzymbs.study.study import ON_FAILURE

    _setup_logging(quiet, verbose)
    if on_failure is not None and on_failure not in ON_FAILURE:
        raise _fail(f"--on-failure {on_failure!r}; allowed: {', '.join(ON_FAILURE)}")
    formats = _formats(fmt)
    study_options = _study_options(option)
    _run_one(
        study_file,
        out,
        study_options=study_options,
        executor=executor,
        chunk_size=chunk_size,
        on_failure=on_failure,
        resume=not fresh,
        progress=not quiet,
        plots=not no_plots,
        formats=formats,
        allow_code=allow_code,
        max_runs=max_runs,
        timeout=timeout,
        report=not no_report,
        command=_command(
            "run",
            str(study_file),
            "--out",
            str(out),
            executor=executor,
            chunk_size=chunk_size,
            on_failure=on_failure,
            allow_code=allow_code,
            timeout=timeout,
            max_runs=max_runs,
            option=option,
        ),
    )


@app.command()
@_one_line_errors
def demo(
    name: Annotated[str, typer.Argument(help="Demo name, e.g. quickstart.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")],
    executor: Annotated[str | None, typer.Option(help="Executor (default: inline).")] = None,
    fresh: Annotated[
        bool, typer.Option("--fresh", help="Discard stored chunks; do not resume.")
    ] = False,
    fmt: FormatOption = None,
    quiet: QuietOption = False,
    verbose: VerboseOption = False,
) -> None:
    """Run the shipped demo NAME into OUT/<study name>/ for each of its study files."""
    import tempfile
    from importlib import resources

    from fuzzymbs.errors import FuzzymbsError
    from fuzzymbs.study.pipeline import demo_estimate, demo_files, demo_has_timing
    from fuzzymbs.study.studyfile import study_file_name

    _setup_logging(quiet, verbose)
    formats = _formats(fmt)
    try:
        files = demo_files(name)
    except FuzzymbsError as exc:
        raise _fail(str(exc)) from None
    if not quiet and demo_has_timing(name):
        typer.echo(
            f"fuzzymbs demo {name}: timing one sample-step of its model here (on the first run "
            "after the install, Numba compiles its kernels first: about a minute)",
            err=True,
        )
        typer.echo(f"fuzzymbs demo {name}: {demo_estimate(name).describe()}", err=True)
    for entry in files:
        with resources.as_file(entry) as path:
            try:
                study_name = study_file_name(path)  # the model is built once, by the run
            except FuzzymbsError as exc:
                raise _fail(str(exc)) from None
            # a copy keeps the shipped file untouched and gives errors a readable name
            with tempfile.TemporaryDirectory() as scratch:
                copy = Path(scratch) / Path(path).name
                copy.write_bytes(Path(path).read_bytes())
                _run_one(
                    copy,
                    out / study_name,
                    executor=executor,
                    resume=not fresh,
                    progress=not quiet,
                    formats=formats,
                    command=_command("demo", name, "--out", str(out), executor=executor),
                )


@app.command()
@_one_line_errors
def plot(
    result_file: Annotated[Path, typer.Argument(help="A result.nc written by run or demo.")],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Folder for the plots (default: beside).")
    ] = None,
    fmt: FormatOption = None,
) -> None:
    """(Re)draw the plots of a result file."""
    from fuzzymbs.errors import FuzzymbsError
    from fuzzymbs.plot import write_plots
    from fuzzymbs.study.result import StudyResult

    if not result_file.is_file():
        raise _fail(f"{result_file}: no such file")
    formats = _formats(fmt)
    try:  # checks every name that becomes a file name (a result file is data from anywhere)
        result = StudyResult.open(result_file)
    except FuzzymbsError as exc:
        raise _fail(str(exc)) from None
    written = write_plots(result.dataset, out or result_file.parent, formats=formats)
    for path in written:
        typer.echo(str(path))


@app.command()
@_one_line_errors
def report(
    result: Annotated[
        Path, typer.Argument(help="A study's output folder (holding result.nc) or a result file.")
    ],
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="The HTML file (default: report.html beside the result)."),
    ] = None,
) -> None:
    """Write the study's report: one self-contained HTML file (figures embedded)."""
    from fuzzymbs.report import REPORT_FILE, write_report
    from fuzzymbs.study.pipeline import RESULT_FILE
    from fuzzymbs.study.result import StudyResult

    result_file = result / RESULT_FILE if result.is_dir() else result
    if not result_file.exists():
        raise _fail(f"{result_file}: no such file")
    try:
        dataset = StudyResult.open(result_file).dataset
    except (OSError, ValueError) as exc:
        raise _fail(f"{result_file}: not a readable result file ({exc})") from None
    if "outputs" not in dataset.attrs or "provenance" not in dataset.attrs:
        raise _fail(f"{result_file}: not a fuzzymbs study result (no 'outputs' attribute)")
    typer.echo(str(write_report(dataset, out or result_file.parent / REPORT_FILE)))


@app.command()
@_one_line_errors
def identify(
    identification_file: Annotated[Path, typer.Argument(help="Identification file (TOML).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")],
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip the plots.")] = False,
    allow_code: Annotated[
        bool,
        typer.Option(
            "--allow-code",
            help="Let the file run a 'module:callable' model it names. Only for files you trust.",
        ),
    ] = False,
    quiet: QuietOption = False,
    verbose: VerboseOption = False,
) -> None:
    """Identify fuzzy parameters from fuzzy (measured) outputs: inverse fuzzy arithmetic.

    Writes OUT/identified.toml (a [parameters] table for a study file), OUT/identified.nc,
    OUT/summary.txt and membership plots. A measured uncertainty the model cannot reproduce
    ends with exit status 1 after the best fit has been written.
    """
    from fuzzymbs.errors import FuzzymbsError
    from fuzzymbs.study.inverse_file import run_identification_file

    _setup_logging(quiet, verbose)
    try:
        written = run_identification_file(
            identification_file, out, plots=not no_plots, allow_code=allow_code
        )
    except FuzzymbsError as exc:
        raise _fail(str(exc)) from None
    if not quiet:
        typer.echo(written.result.summary())
    typer.echo(f"{written.toml_path}  ({written.result_path}, {len(written.plots)} plots)")


@app.command()
@_one_line_errors
def info(
    model: Annotated[
        str | None, typer.Argument(help="Show only this model, or an FMU file's variables.")
    ] = None,
) -> None:
    """List the registered models (parameters with units, outputs, options), methods, the
    study options, demos.

    With a .fmu file: its settable real parameters and its outputs, with units.
    """
    from fuzzymbs.errors import FuzzymbsError
    from fuzzymbs.fuzzy.methods import METHODS
    from fuzzymbs.study.options import StudyOptions
    from fuzzymbs.study.pipeline import demo_names
    from fuzzymbs.study.registry import available_models, get_model

    if model is not None and model.lower().endswith(".fmu"):
        from fuzzymbs.models.external.fmu import describe_fmu

        try:
            typer.echo("\n".join(describe_fmu(model).lines()))
        except FuzzymbsError as exc:
            raise _fail(str(exc)) from None
        return
    try:
        specs = {model: get_model(model)} if model else available_models()
    except FuzzymbsError as exc:
        raise _fail(str(exc)) from None
    lines = ["Models:"]
    for name, spec in specs.items():
        lines.append(f"  {name}: {spec.description}")
        if spec.dynamic:
            lines.append("    parameters, outputs: those of the FMU or program it runs")
        else:
            lines.append("    parameters:")
            for parameter, meta in spec.parameters.items():
                default = "" if meta.default is None else f" (default {meta.default:g})"
                lines.append(f"      {parameter} [{meta.unit}]: {meta.description}{default}")
            outputs = ", ".join(f"{o} [{u}]" for o, u in spec.outputs.items())
            lines.append(f"    outputs: {outputs}")
        if spec.runs_code:
            lines.append("    in a study file: needs fuzzymbs run --allow-code (runs named code)")
        if spec.options:
            lines.append("    options:")
            lines += [f"      {k}: {v}" for k, v in spec.options.items()]
    lines.append(f"Methods: {', '.join(METHODS)}")
    for name, method in METHODS.items():
        lines.append(f"  {name}: {method.summary}")
        lines += [
            f"    {declared.name} ({declared.default_text()}): {declared.help}"
            for declared in method.options()
        ]
    lines.append("Study options ([study] keys of a study file, keywords of Study):")
    lines += [
        f"  {declared.name} ({declared.default_text()}): {declared.help}"
        for declared in StudyOptions.options()
    ]
    lines.append("Executors: inline, processes[:N], dask://HOST:PORT")
    lines.append(f"Demos: {', '.join(demo_names()) or '(none)'}")
    typer.echo("\n".join(lines))


def main() -> None:
    """The console entry (``fuzzymbs``, ``python -m fuzzymbs.cli``): :data:`app` with a
    quick exit.

    At exit, after the exit handlers registered while the command ran (Dask's client,
    temporary folders), the objects alive are frozen out of the garbage collector: the
    interpreter's last collections then skip the few hundred thousand objects NumPy,
    xarray, Numba and matplotlib leave behind. A ``fuzzymbs run`` then exits in 0.04 s
    instead of 0.25-0.45 s (docs/benchmarks.md). Every exit handler still runs, and
    every object whose reference count drops to zero is still freed; only reference
    cycles are left to the operating system (Python never promised to collect them at
    exit).
    """
    atexit.register(gc.freeze)  # before the command's own: runs after them
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
