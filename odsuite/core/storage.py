"""Writing a project file safely: one writer at a time, and every write a copy-on-write transaction.

The writer holds an flock on ``<name>.h5.lock`` (released by the OS if the process dies). A write
copies the committed file to ``<name>.h5.tmp-<pid>``, changes the copy, fsyncs it and atomically
renames it over the project, so a killed process leaves either the old or the new committed state;
the next writer removes copies left by an interrupted write.
"""

from __future__ import annotations

import fcntl
import logging
import os
import shutil
import signal
import socket
import stat
import threading
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

import h5py

from odsuite.core import h5text
from odsuite.core.errors import OdsuiteError, ProjectFileError, ProjectLockedError
from odsuite.core.project_format import LIBVER, now

#: Tests set this to a crash-point name (see ``crash_point``) to SIGKILL the writer there.
CRASH_ENV = "ODSUITE_TEST_CRASH_AT"

log = logging.getLogger(__name__)


def crash_point(name: str) -> None:
    """Kill this process here when the test hook asks for it (crash-safety tests)."""
    if os.environ.get(CRASH_ENV) == name:
        os.kill(os.getpid(), signal.SIGKILL)


def fsync_path(path: Path, directory: bool = False) -> None:
    fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def tmp_path(path: Path) -> Path:
    """This process's working copy of the project ``path``."""
    return path.with_name(f"{path.name}.tmp-{os.getpid()}")


def replace_atomically(tmp: Path, path: Path) -> None:
    """Make the finished copy ``tmp`` the project ``path``: on disk first, then renamed over it."""
    fsync_path(tmp)
    os.replace(tmp, path)
    fsync_path(path.parent, directory=True)


# ----------------------------------------------------------------------------- the writer lock


def _lock_path(path: Path) -> Path:
    return path.with_name(path.name + ".lock")


#: Lock files this process holds open. A forked child shares their flock, which would outlive a
#: killed parent, so the child closes its copies (closing never unlocks the parent's descriptor).
_HELD_LOCKS: weakref.WeakSet[IO[str]] = weakref.WeakSet()


def _close_inherited_locks() -> None:
    for fh in list(_HELD_LOCKS):
        fh.close()
    _HELD_LOCKS.clear()


os.register_at_fork(after_in_child=_close_inherited_locks)


def acquire_lock(path: Path) -> IO[str]:
    """Take the writer lock of ``path`` (flock: released by the OS if the process dies)."""
    try:
        # never through a symbolic link: the lock must not truncate a file someone planted there
        fd = os.open(_lock_path(path), os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
        fh = open(fd, "a+", encoding="utf-8")
    except OSError as exc:
        raise ProjectFileError(f"{path}: cannot create lock file {_lock_path(path)}: {exc.strerror}") from None
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.seek(0)
        holder = fh.read().split()
        fh.close()
        pid = holder[0] if holder else "?"
        host = f" on host {holder[1]}" if len(holder) > 1 and holder[1] != socket.gethostname() else ""
        raise ProjectLockedError(
            f"{path}: project is open in another process (pid {pid}{host}); close it there first"
        ) from None
    fh.truncate(0)
    fh.write(f"{os.getpid()} {socket.gethostname()}\n")
    fh.flush()
    _HELD_LOCKS.add(fh)
    for stale in sorted(path.parent.glob(f"{path.name}.tmp-*")):
        if _is_our_copy(stale):
            log.warning("%s: removing %s left by an interrupted write", path, stale.name)
            stale.unlink(missing_ok=True)
    return fh


def _is_our_copy(candidate: Path) -> bool:
    """A working copy an interrupted write left: ``<name>.tmp-<pid>``, a regular file (not a link)
    holding an HDF5 file. A user's ``p.h5.tmp-backup`` or a link of that name is left alone."""
    if not candidate.name.rsplit(".tmp-", 1)[1].isdigit() or candidate.is_symlink() or not candidate.is_file():
        return False
    try:
        with open(candidate, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


def check_output(output: Path, project: Path | None, option: str) -> Path:
    """Refuse an output path that is the project, one of its sidecar files, a folder, or inside a
    folder that does not exist; one line naming the option and the path."""
    output = Path(output)
    if output.is_dir():
        raise ProjectFileError(f"{option} {output}: is a folder; give a file name")
    if not output.parent.is_dir():
        raise ProjectFileError(f"{option} {output}: folder {output.parent} does not exist")
    if project is not None:
        project = Path(project)
        real_output, real_project = os.path.realpath(output), os.path.realpath(project)  # no error on loops
        same = output.exists() and project.exists() and os.path.samefile(output, project)
        sidecar = Path(real_output).parent == Path(real_project).parent and (
            output.name == _lock_path(project).name or output.name.startswith(f"{project.name}.tmp-"))
        if same or real_output == real_project or sidecar:
            raise ProjectFileError(f"{option} {output}: that is the project {project} or one of its own files; "
                                   "give another file name")
    return output


def release_lock(fh: IO[str]) -> None:
    _HELD_LOCKS.discard(fh)
    if fh.closed:  # closed in a forked child: the lock belongs to the parent
        return
    fh.truncate(0)
    fh.flush()
    fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
    fh.close()


# ----------------------------------------------------------------------------- transactions

#: Projects this process has committed a write to, in order: what an interrupted command reports
#: as stored.
COMMITS: list[Path] = []


@contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT back (it arrives right after the block), e.g. so a Ctrl-C never falls between a
    commit and its record. Processes started inside inherit the block."""
    main_thread = threading.current_thread() is threading.main_thread()
    if main_thread:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if main_thread:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@contextmanager
def copy_on_write(path: Path) -> Iterator[h5py.File]:
    """A writable copy of the project ``path`` that replaces it when the block exits without
    error (its file_update_time set); on error or a crash the project is left as it was."""
    # a project reached through a link is written where the link points, the link kept
    path = Path(os.path.realpath(path))
    # the owner's write bit, not access(): an administrator could write, yet the file says read-only
    if not os.stat(path).st_mode & stat.S_IWUSR or not os.access(path, os.W_OK):
        raise ProjectFileError(f"{path}: project is read-only; make it writable (chmod u+w) to change it")
    tmp = tmp_path(path)
    try:
        shutil.copyfile(path, tmp)
        shutil.copymode(path, tmp)  # the project keeps its permissions
        crash_point("copied")
        f = h5py.File(tmp, "r+", locking=False, libver=LIBVER)
    except BaseException as exc:  # an interrupt during the copy leaves no copy behind either
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise ProjectFileError(f"{path}: cannot start a write ({exc})") from None
        raise
    try:
        yield f
        h5text.set_attrs(f, {"file_update_time": now()})
        f.close()
        crash_point("written")
        fsync_path(tmp)
        crash_point("synced")
        with interrupts_deferred():  # the commit and its record in COMMITS happen together
            os.replace(tmp, path)
            COMMITS.append(path)
        crash_point("replaced")
        fsync_path(path.parent, directory=True)
    except BaseException as exc:
        if f:  # still open
            f.close()
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError) and not isinstance(exc, OdsuiteError):  # e.g. disk full
            raise ProjectFileError(f"{path}: write failed, project left unchanged: {exc}") from exc
        raise
