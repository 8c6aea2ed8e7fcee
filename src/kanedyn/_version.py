"""The version of kanedyn."""

__version__ = "0.1.0"
