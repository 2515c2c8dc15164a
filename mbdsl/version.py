"""The package's version (also in pyproject.toml), a leaf module: the result
files record it."""

__version__ = "0.1.0"
