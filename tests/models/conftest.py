"""Fixtures of the model tests."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def module_fe_cache(tmp_path_factory):
    """The module's FE tables go to its own cache directory (computed once per module)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("FUZZYMBS_CACHE_DIR", str(tmp_path_factory.mktemp("fe-cache")))
        yield
