"""What a project file is: its format name and version, how its HDF5 objects are written, and the
check that a file is an odsuite project this version can read (see ``odsuite.store.project`` for
the layout)."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import h5py

from odsuite.store import h5text
from odsuite.store import migrations
from odsuite.domain.errors import NotAProjectError, ProjectFileError, ProjectVersionError, SchemaError
from odsuite.store.h5damage import open_h5, reading

FORMAT_NAME = "odsuite.project"
FORMAT_VERSION = "1.1.0"
#: Object headers that hold attributes over 64 KiB (dense attribute storage), for every object a
#: write creates: fixed-length text is stored in the header itself.
LIBVER = ("v110", "v110")
#: Target size of one raw-data chunk (the unit of checksumming and of partial reads).
CHUNK_BYTES = 1 << 20
#: The one format that kept its text in HDF5's global heap (variable-length strings).
HEAP_TEXT_VERSION = "1.0.0"


def now() -> str:
    """The time stamps of the file (file_time, created, ...): ISO 8601, local time zone."""
    return datetime.now(timezone.utc).astimezone().isoformat(timespec="seconds")


def _heap_text(f: h5py.File) -> bool:
    """Whether ``f`` keeps its root text in the global heap (format 1.0.0); reads no heap."""
    return "odsuite_format" in f.attrs and h5text.is_variable_text(f.attrs.get_id("odsuite_format").dtype)


def check_format(path: Path) -> str:
    """Check that ``path`` is an odsuite project this version can read; returns its version
    (format 1.0.0 without reading its text: the migration checks it)."""
    version, f = open_checked(path)
    if f is not None:
        f.close()
    return version


def open_checked(path: Path) -> tuple[str, h5py.File | None]:
    """``check_format``'s checks and version, with the file left open for reading: each open walks
    the file (``open_h5``), so a reader opens it once. None in place of the file for format 1.0.0,
    which is read through a migrated copy (see ``odsuite.store.project_migration``)."""
    if not path.exists():
        raise ProjectFileError(f"{path}: no such project file")
    if not path.is_file():
        raise ProjectFileError(f"{path}: not a file")
    if not h5py.is_hdf5(path):
        raise NotAProjectError(f"{path}: not an HDF5 file, so not an odsuite project")
    f = open_h5(path, path)
    try:
        with reading(path, "root attributes"):
            if _heap_text(f):
                f.close()
                return HEAP_TEXT_VERSION, None
            fmt = f.attrs.get("odsuite_format")
            version = f.attrs.get("odsuite_format_version")
        if fmt is None or h5text.text(fmt) != FORMAT_NAME:
            raise NotAProjectError(
                f"{path}: HDF5 file without the root attribute odsuite_format={FORMAT_NAME!r} "
                f"(found {None if fmt is None else h5text.text(fmt)!r}); not an odsuite project"
            )
        if version is None:
            raise SchemaError(f"{path}: root attribute odsuite_format_version is missing")
        version = h5text.text(version)
        have, ours = migrations.parse_version(version, str(path)), migrations.parse_version(FORMAT_VERSION)
        if have[0] > ours[0]:
            raise ProjectVersionError(
                f"{path}: project format {version} is newer than the format this odsuite reads "
                f"({FORMAT_VERSION}); upgrade odsuite"
            )
    except BaseException:
        f.close()
        raise
    return version, f
