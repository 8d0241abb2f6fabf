"""odsuite's version, read from the installed distribution (a module of its own so that every
module can import it without importing the ``odsuite`` package's entry points)."""

from odsuite.domain.installed import version

# None: running from a source tree without installation
__version__ = version("odsuite") or "0+unknown"
