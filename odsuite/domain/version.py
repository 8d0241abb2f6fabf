"""odsuite's version, read from the installed distribution (a module of its own so that every
module can import it without importing the ``odsuite`` package's entry points)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("odsuite")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"
