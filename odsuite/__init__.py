"""odsuite: experimental vibration analysis of rigid plates, with model comparison and diagnosis."""

from odsuite.domain.errors import OdsuiteError
from odsuite.contracts.hookspecs import hookimpl
from odsuite.domain.version import __version__


def open_project(path, mode: str = "r", *, registries=None):
    """Open an odsuite project file (``mode`` "r" to read, "a" to read and write; ``registries``:
    the providers to work with, default the installed plugins')."""
    from odsuite.store.project import open_project as _open

    return _open(path, mode, registries=registries)


__all__ = ["OdsuiteError", "hookimpl", "open_project", "__version__"]
