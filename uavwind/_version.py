"""The library's version (one place; the package and the cache stamps read it)."""

__version__ = "0.2.0"
