"""Desktop tools of the flight computer (CPython only): ``python -m desktop --help``."""

__version__ = "0.1.0"  # the package version (pyproject.toml reads it from here)
