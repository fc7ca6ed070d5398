"""The package version (one place; read by setuptools and the reports)."""

__version__ = "0.1.0"
