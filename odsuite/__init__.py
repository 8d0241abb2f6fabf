"""odsuite: experimental vibration analysis of rigid plates, with model comparison and diagnosis."""

from odsuite.domain.errors import OdsuiteError
from odsuite.contracts.hookspecs import hookimpl
from odsuite.domain.version import __version__


def open_project(path, mode: str = "r"):
    """Open an odsuite project file (``mode`` "r" to read, "a" to read and write)."""
    from odsuite.store.project import open_project as _open

    return _open(path, mode)


__all__ = ["OdsuiteError", "hookimpl", "open_project", "__version__"]
