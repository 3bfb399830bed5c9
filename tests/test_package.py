"""The package imports and exposes its version and lazy public names."""

import pytest

import fuzzymbs
from fuzzymbs import errors


def test_version_is_a_string():
    assert isinstance(fuzzymbs.__version__, str)
    assert fuzzymbs.__version__.count(".") >= 2


def test_unknown_attribute_raises():
    with pytest.raises(AttributeError, match="no_such_name"):
        fuzzymbs.no_such_name  # noqa: B018


def test_errors_are_builtin_subclasses():
    assert issubclass(errors.InvalidFuzzyNumberError, ValueError)
    assert issubclass(errors.UnsupportedOperationError, TypeError)


def test_version_is_the_changelogs_latest():
    # the CHANGELOG's first "## [x.y.z]" heading is the version the package reports
    # (above it at most the "## [Unreleased]" section of Keep a Changelog)
    from pathlib import Path

    changelog = Path(__file__).parents[1] / "CHANGELOG.md"
    headings = [line for line in changelog.read_text().splitlines() if line.startswith("## [")]
    if headings and headings[0] == "## [Unreleased]":
        headings = headings[1:]
    assert headings and headings[0].startswith(f"## [{fuzzymbs.__version__}]")
