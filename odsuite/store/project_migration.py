"""Migrating a project file of an older format version to this odsuite's (the upgrades themselves
are in ``odsuite.store.migrations``).

The project itself is never changed in place: read mode migrates a private copy; write mode
migrates a copy that then replaces the project atomically. Format 1.0.0 kept its text in HDF5's
global heap, whose damaged bytes can send the HDF5 library into an endless loop or crash it: that
migration runs in a child process that is stopped after ``HEAP_TEXT_TIMEOUT``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py

from odsuite.store import diskspace
from odsuite.domain import errors
from odsuite.store import h5text
from odsuite.store import migrations
from odsuite.domain.errors import DiskFullError, NotAProjectError, OdsuiteError, ProjectFileError
from odsuite.store.h5damage import first_line, reading
from odsuite.store.project_format import FORMAT_NAME, FORMAT_VERSION, HEAP_TEXT_VERSION, LIBVER, now
from odsuite.store.storage import replace_atomically, reserve_private, tmp_path

#: Seconds a child process may take to migrate a format-1.0.0 file's text.
HEAP_TEXT_TIMEOUT = 60.0


def migrated_copy(path: Path, version: str) -> Path:
    """A private temporary copy of the project ``path`` (format ``version``) migrated to this
    odsuite's format; the caller deletes it."""
    migrations.migration_path(version, FORMAT_VERSION, str(path))  # refuse before copying
    fd, tmp_name = tempfile.mkstemp(prefix=path.name + ".", suffix=".migrated.h5")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        shutil.copyfile(path, tmp)
        _migrate(tmp, path, version)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def migrate_in_place(path: Path, version: str) -> None:
    """Replace the project ``path`` (format ``version``; its writer lock held) atomically by a
    migrated copy; on any failure the project is left unchanged."""
    migrations.migration_path(version, FORMAT_VERSION, str(path))  # refuse before copying
    tmp = tmp_path(path)
    diskspace.ensure_space(tmp, 2 * os.stat(path).st_size, path)  # the copy, and migrated text beside it
    reserve_private(tmp, path)  # before the try: a file in the way is not ours to delete
    try:  # a transaction: the migrated copy replaces the project atomically
        shutil.copyfile(path, tmp)
        _migrate(tmp, path, version, updated=True)
        replace_atomically(tmp, path)
    except OSError as exc:
        if isinstance(exc, OdsuiteError):
            raise
        if diskspace.is_disk_full(exc):
            raise DiskFullError(diskspace.full_message(path, path.parent, diskspace.written_so_far(tmp))) from None
        raise ProjectFileError(f"{path}: migration from format {version} failed, project left "
                               f"unchanged: {exc}") from exc  # e.g. disk full
    finally:
        tmp.unlink(missing_ok=True)


def _migrate(copy: Path, path: Path, version: str, *, updated: bool = False) -> None:
    """Migrate ``copy`` of the project ``path`` (format ``version``) to this odsuite's format;
    ``updated``: the copy will replace the project (its file_update_time is set)."""
    if version == HEAP_TEXT_VERSION:
        _migrate_heap_text_aside(copy, path)
        version = migrations.MIGRATIONS[HEAP_TEXT_VERSION].to_version
    with h5py.File(copy, "r+", locking=False, libver=LIBVER) as f, reading(path, f"migrating format {version}"):
        migrations.migrate(f, FORMAT_VERSION, str(path))
        if updated:
            h5text.set_attrs(f, {"file_update_time": now()})


def _migrate_heap_text(copy: str, where: str) -> None:
    """The child process of ``_migrate_heap_text_aside``: migrate ``copy`` to format 1.1.0; any
    error is one line "<class>\t<message>" on stderr and exit code 1."""
    try:
        with h5py.File(copy, "r+", locking=False, libver=LIBVER) as f:
            fmt = f.attrs.get("odsuite_format")
            if fmt is None or h5text.text(fmt) != FORMAT_NAME:
                raise NotAProjectError(f"{where}: HDF5 file without the root attribute "
                                       f"odsuite_format={FORMAT_NAME!r}; not an odsuite project")
            migrations.migrate(f, migrations.MIGRATIONS[HEAP_TEXT_VERSION].to_version, where)
    except Exception as exc:  # noqa: BLE001 - reported to the parent, which names the damage
        print(f"{type(exc).__name__}\t{first_line(exc)}", file=sys.stderr)
        sys.exit(1)


def _migrate_heap_text_aside(copy: Path, path: Path) -> None:
    """Migrate ``copy`` of the format-1.0.0 project ``path`` to 1.1.0 in a child process that can be
    stopped: damaged heap bytes can send the HDF5 library into an endless loop or crash it."""
    code = f"import sys; from {__name__} import _migrate_heap_text; _migrate_heap_text(*sys.argv[1:])"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}  # this very odsuite
    try:
        done = subprocess.run([sys.executable, "-P", "-c", code, str(copy), str(path)], capture_output=True,
                              text=True, timeout=HEAP_TEXT_TIMEOUT, check=False, env=env)
    except subprocess.TimeoutExpired:
        raise ProjectFileError(f"{path}: project file is damaged (reading its format-1.0.0 text did not finish "
                               f"within {HEAP_TEXT_TIMEOUT:g} s)") from None
    if done.returncode == 0:
        return
    kind, _, message = ((done.stderr.strip().splitlines() or [""])[-1]).partition("\t")
    error = getattr(errors, kind, None)
    if done.returncode == 1 and isinstance(error, type) and issubclass(error, OdsuiteError) and message:
        raise error(message)
    if done.returncode < 0:
        raise ProjectFileError(f"{path}: project file is damaged (reading its format-1.0.0 text crashed the HDF5 "
                               f"library with signal {-done.returncode})")
    why = f"{kind}: {message}" if message else kind or f"exit code {done.returncode}"
    raise ProjectFileError(f"{path}: cannot migrate format {HEAP_TEXT_VERSION}, project left unchanged ({why})")
