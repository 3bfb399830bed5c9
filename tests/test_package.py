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
