"""The package's version, in a leaf module: it imports nothing, so any module can read it without importing the
package face (``tuner/__init__.py``), and ``pyproject.toml`` reads it as the distribution's version."""

__version__ = "0.1.0"
