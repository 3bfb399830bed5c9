"""Shared pytest configuration."""

import os

# BLAS pinned to one thread: kernels parallelise over samples, not inside BLAS.
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
# No user trust file (fuzzymbs.study.trust): a study file's code runs only where a test allows it.
os.environ["FUZZYMBS_TRUST_FILE"] = os.path.join(os.path.dirname(__file__), "no-trust-file.toml")
