"""Fixtures of the finite-element tests: a private cache directory and shared small bodies."""

from __future__ import annotations

import pytest

from fuzzymbs.fe import ElasticBody, box_mesh

STEEL = {"youngs_modulus": 210e9, "poisson_ratio": 0.3, "density": 7850.0}


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    """Every test writes its FE cache into its own temporary directory."""
    monkeypatch.setenv("FUZZYMBS_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture(scope="session")
def cantilever() -> ElasticBody:
    """Steel cantilever 1.0 x 0.02 x 0.03 m clamped at x = 0, 40 x 1 x 1 27-node hexahedra."""
    mesh = box_mesh(1.0, 0.02, 0.03, 40, 1, 1)
    return ElasticBody(mesh, **STEEL, fixed="x_min", name="cantilever")


@pytest.fixture(scope="session")
def free_pad() -> ElasticBody:
    """Free-free brake-pad-like block 0.06 x 0.04 x 0.015 m (2 x 2 x 1 27-node hexahedra)."""
    mesh = box_mesh(0.06, 0.04, 0.015, 2, 2, 1, origin=(-0.03, -0.02, 0.0))
    return ElasticBody(mesh, 10e9, 0.25, 2500.0, name="pad")
