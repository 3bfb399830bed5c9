"""The package's version (its one home: the build reads it here, ``fuzzymbs.__version__``
and the modules that record it import it from here)."""

__version__ = "0.2.0"
