"""Room on the disk before a write: a write that would not fit is refused in one line before any
byte reaches the file ("no space left on DEVICE: needed ~N MB"), because HDF5 running into a full
disk half-way leaves a library state that can fail again at exit, up to a crash."""

from __future__ import annotations

import errno
import os
import shutil
import stat
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from odsuite.domain.errors import DiskFullError

#: Room HDF5 needs beyond the data itself (object headers, chunk indices, free-space records, the
#: attributes of a new experiment: a few 10 kB measured); 1 MiB leaves a wide margin.
METADATA_RESERVE = 1 << 20

MB = 1e6


def mount_point(path: Path) -> Path:
    """The mount point of the file system holding ``path`` (the "device" a user recognises)."""
    path = Path(os.path.realpath(path))
    while not path.exists() or not os.path.ismount(path):
        if path.parent == path:
            break
        path = path.parent
    return path


def ensure_space(target: Path, needed: int, whose: Path | str, outcome: str = "project unchanged") -> None:
    """Refuse to write ``needed`` bytes (plus ``METADATA_RESERVE``) into the folder of ``target``
    when its disk has less room; ``whose`` starts the message (the project or output path),
    ``outcome`` ends it."""
    needed = int(needed) + METADATA_RESERVE
    folder = Path(target).parent
    try:
        usage = shutil.disk_usage(folder)
    except OSError:  # the folder's disk does not say: the write itself will tell
        return
    free = usage.free
    if usage.total == 0:  # /proc, /sys: no disk at all, not a full one
        raise DiskFullError(f"{whose}: {mount_point(folder)} is a virtual file system that holds no files; "
                            f"give a path in another folder; {outcome}")
    if free < needed:
        raise DiskFullError(full_message(whose, folder, needed, free, outcome))


def write_output(path: Path, needed: int, write: Callable[[Path], object]) -> Path:
    """Write an output file (movie, figure, report, export) all or nothing: refused in one line
    when its disk lacks room for ``needed`` bytes (an estimate), else ``write(tmp)`` fills a
    private file beside it that then replaces ``path`` in one rename (a symlinked output is written
    through to its target; an existing file keeps its mode). A write that fails, runs into a full
    disk or is interrupted leaves ``path`` as it was and nothing beside it."""
    path = Path(path)
    target = Path(os.path.realpath(path))
    ensure_space(target, needed, path, outcome="nothing written")
    import secrets  # here, not at import: every command imports this module for its error lines

    # the suffix given stays last (a link's target may have another): writers pick the format from it
    tmp = target.with_name(f".{target.stem}.odsuite-out-{secrets.token_hex(4)}{path.suffix}")
    try:
        write(tmp)
        if target.exists():
            os.chmod(tmp, stat.S_IMODE(os.stat(target).st_mode))
        os.replace(tmp, target)
    except BaseException as exc:
        written = written_so_far(tmp)
        tmp.unlink(missing_ok=True)
        if isinstance(exc, Exception) and is_disk_full(exc):
            raise DiskFullError(full_message(path, target.parent, max(written, int(needed) + METADATA_RESERVE),
                                             outcome="nothing written")) from None
        raise
    return path


def full_message(whose: Path | str, folder: Path, needed: int, free: int | None = None,
                 outcome: str = "project unchanged") -> str:
    """The one line of a full disk: where, how much the write needed (and had), what became of it."""
    room = f", {free / MB:.1f} MB free" if free is not None else ""
    return f"{whose}: no space left on {mount_point(folder)}: needed ~{max(needed / MB, 0.1):.1f} MB{room}; {outcome}"


def written_so_far(path: Path) -> int:
    """Bytes a failed write had reached in ``path`` plus the reserve: what it needed at least."""
    try:
        return os.stat(path).st_size + METADATA_RESERVE
    except OSError:
        return METADATA_RESERVE


def is_disk_full(exc: BaseException) -> bool:
    """``exc`` (or what caused it) says the disk or the user's quota is full."""
    while exc is not None:
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return True
        if "No space left on device" in str(exc) or "Disk quota exceeded" in str(exc):  # HDF5 wraps errno
            return True
        exc = exc.__cause__ or exc.__context__
    return False


#: Working copies being written -> the project a message names (the copy's name means nothing to a user).
_SHOWN_AS: dict[str, Path] = {}


@contextmanager
def shown_as(copy: Path, project: Path) -> Iterator[None]:
    """While the block runs, a full disk met writing ``copy`` is reported as ``project``'s."""
    _SHOWN_AS[str(copy)] = project
    try:
        yield
    finally:
        _SHOWN_AS.pop(str(copy), None)


def ensure_room_in(h5file, nbytes: int) -> None:
    """Room for ``nbytes`` more in the open HDF5 file ``h5file``, checked and reserved before HDF5
    writes them (``reserve``)."""
    name = h5file.filename
    reserve(Path(name), h5file.id.get_filesize() + nbytes, nbytes, _SHOWN_AS.get(name, name))


def reserve(path: Path, upto: int, nbytes: int, whose: Path | str) -> bool:
    """Check the room for ``nbytes`` more, then allocate the disk blocks of ``path`` up to ``upto``
    bytes plus ``METADATA_RESERVE`` (posix_fallocate): HDF5 then writes into blocks the disk has
    already given, and another program filling the disk meanwhile cannot make it fail half-way.
    The file grows beyond HDF5's end; reopening it for writing trims it (``trim``). Returns
    whether blocks were reserved (not where the system lacks posix_fallocate, e.g. Windows)."""
    ensure_space(path, nbytes, whose)
    if not hasattr(os, "posix_fallocate"):
        return False
    fd = os.open(path, os.O_WRONLY)
    try:
        os.posix_fallocate(fd, 0, int(upto) + METADATA_RESERVE)
    except OSError as exc:
        if not is_disk_full(exc):
            return False  # a file system that cannot reserve: the check above stands alone
        raise DiskFullError(full_message(whose, path.parent, nbytes + METADATA_RESERVE,
                                         shutil.disk_usage(path.parent).free)) from None
    finally:
        os.close(fd)
    return True
