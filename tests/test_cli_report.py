"""Command line: --version, the HTML report of a run, --no-report and ``fuzzymbs report``."""

from typer.testing import CliRunner

import fuzzymbs
from fuzzymbs.cli import app

runner = CliRunner()


def test_version_option_prints_the_package_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"fuzzymbs {fuzzymbs.__version__}"
