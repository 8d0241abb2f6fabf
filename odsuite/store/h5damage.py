"""What a damaged project file's bytes make h5py raise, turned into one-line ProjectFileErrors."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py

from odsuite.domain.errors import OdsuiteError, ProjectFileError
from odsuite.store.h5contained import refuse_outside

#: What h5py raises on damaged bytes: an object that cannot be found or opened (KeyError), an HDF5
#: read error (OSError, RuntimeError), metadata of the wrong type or shape (ValueError, TypeError,
#: IndexError; JSON and UTF-8 decoding errors are ValueErrors).
DAMAGE = (KeyError, OSError, RuntimeError, ValueError, TypeError, IndexError)


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (a KeyError's without its quotes)."""
    text = exc.args[0] if len(exc.args) == 1 and isinstance(exc.args[0], str) else str(exc)
    return (text.strip().splitlines() or [type(exc).__name__])[0]


@contextmanager
def reading(path: Path, what: str = "") -> Iterator[None]:
    """Turn h5py/HDF5 errors raised while reading ``path`` into a one-line ProjectFileError
    "<path>: project file is damaged (<what>: <error>)"; odsuite's own errors pass unchanged."""
    try:
        yield
    except OdsuiteError:
        raise
    except DAMAGE as exc:
        where = f"{what}: " if what else ""
        raise ProjectFileError(f"{path}: project file is damaged ({where}{first_line(exc)})") from None


def open_h5(path: Path, where: Path, mode: str = "r") -> h5py.File:
    """Open ``path`` (the project ``where`` or a copy of it) without HDF5's own file locking; read
    only if it holds nothing outside itself (see ``odsuite.store.h5contained``)."""
    try:
        f = h5py.File(path, mode, locking=False)
    except OSError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ProjectFileError(f"{where}: file is truncated or damaged and cannot be opened ({first})") from None
    if mode == "r":
        try:
            with reading(where, "links"):
                refuse_outside(f, where)
        except BaseException:
            f.close()
            raise
    return f
