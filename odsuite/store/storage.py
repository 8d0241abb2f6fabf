"""Writing a project file safely: one writer at a time, and every write a copy-on-write transaction.

The writer holds the project's writer lock (``writer_lock``: released by the OS if the process dies).
A write copies the committed file to ``.<name>.h5.odsuite-tmp-<pid>``, changes the copy, fsyncs it and atomically
renames it over the project, so a killed process leaves either the old or the new committed state;
the next writer removes copies left by an interrupted write.
"""

from __future__ import annotations

import errno
import logging
import os
import shutil
import signal
import stat
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py

from odsuite.store import diskspace
from odsuite.store import h5text
from odsuite.store import writer_lock
from odsuite.domain.errors import DiskFullError, OdsuiteError, ProjectFileError
from odsuite.store.writer_lock import WriterLock, lock_path
from odsuite.store.project_format import LIBVER, now

#: Tests set this to a crash-point name (see ``crash_point``) to SIGKILL the writer there.
CRASH_ENV = "ODSUITE_TEST_CRASH_AT"

log = logging.getLogger(__name__)


def crash_point(name: str) -> None:
    """Kill this process here when the test hook asks for it (crash-safety tests)."""
    if os.environ.get(CRASH_ENV) == name:
        os.kill(os.getpid(), getattr(signal, "SIGKILL", signal.SIGTERM))  # Windows: TerminateProcess


def fsync_path(path: Path, directory: bool = False) -> None:
    if directory and not hasattr(os, "O_DIRECTORY"):  # Windows: folders cannot be opened; NTFS journals renames
        return
    fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def tmp_path(path: Path) -> Path:
    """This process's working copy of the project ``path``: hidden, in odsuite's own name space."""
    return path.with_name(f".{path.name}.odsuite-tmp-{os.getpid()}")


def replace_atomically(tmp: Path, path: Path) -> None:
    """Make the finished copy ``tmp`` the project ``path``: on disk first, then renamed over it."""
    fsync_path(tmp)
    os.replace(tmp, path)
    fsync_path(path.parent, directory=True)


# ----------------------------------------------------------------------------- the writer lock


def acquire_lock(path: Path) -> WriterLock:
    """Take the writer lock of ``path`` (see ``writer_lock``) and remove the working copies that
    interrupted writes left."""
    lock = writer_lock.acquire(path)
    real = Path(os.path.realpath(path))
    links = os.stat(real).st_nlink if real.exists() else 1
    if links > 1:
        # a write replaces the file by a new one: the other names would keep the old state
        lock.release()
        raise ProjectFileError(f"{path}: project has {links} hard links (names of one file), which a write would "
                               "split; keep one name or give each a copy (cp) to change it")
    for stale in sorted(real.parent.glob(f".{real.name}.odsuite-tmp-*")):
        if _is_our_copy(stale):
            log.warning("%s: removing %s left by an interrupted write", path, stale.name)
            stale.unlink(missing_ok=True)
    return lock


def release_lock(lock: WriterLock) -> None:
    lock.release()


def _is_our_copy(candidate: Path) -> bool:
    """A working copy an interrupted write left: ``.<name>.odsuite-tmp-<pid>``, a regular file (not a
    link) holding an HDF5 file. Anything else of that name is left alone."""
    if not candidate.name.rsplit("-", 1)[1].isdigit() or candidate.is_symlink() or not candidate.is_file():
        return False
    try:
        with open(candidate, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


def reserve_private(tmp: Path, project: Path) -> None:
    """Create the empty working copy ``tmp``: a new file, never one that exists or a link (O_EXCL)."""
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o666))
    except FileExistsError:
        raise ProjectFileError(f"{project}: {tmp} is in the way of the working copy and was not written by "
                               "odsuite; move it elsewhere") from None


def check_output(output: Path, project: Path | None, option: str) -> Path:
    """Refuse an output path that is the project, one of its sidecar files, a folder, a link that
    loops, or inside a folder that does not exist (also as a link's target); one line naming the
    option and the path."""
    output = Path(output)
    if output.is_dir():
        raise ProjectFileError(f"{option} {output}: is a folder; give a file name")
    if output.is_symlink():
        try:
            os.stat(output)
        except OSError as exc:
            # a link leading back to itself has no target to write through to: the write replaced it
            if exc.errno == errno.ELOOP:
                raise ProjectFileError(f"{option} {output}: is a symbolic link that leads back to itself (a loop), "
                                       "which has no file to write to; remove it or give another file name") from None
    # a link is written where it points (write_output), so the folder that must exist is its target's
    folder = Path(os.path.realpath(output)).parent if output.parent.is_dir() else output.parent
    if not folder.is_dir():
        raise ProjectFileError(f"{option} {output}: folder {folder} does not exist")
    if project is not None:
        project = Path(project)
        real_output, real_project = os.path.realpath(output), os.path.realpath(project)  # no error on loops
        same = output.exists() and project.exists() and os.path.samefile(output, project)
        real_name = Path(real_output).name
        sidecar = Path(real_output).parent == Path(real_project).parent and (
            real_name == lock_path(project).name or real_name.startswith(f".{Path(real_project).name}.odsuite-tmp-"))
        if same or real_output == real_project or sidecar:
            raise ProjectFileError(f"{option} {output}: that is the project {project} or one of its own files; "
                                   "give another file name")
    return output


# ----------------------------------------------------------------------------- transactions

#: Projects this process has committed a write to, in order: what an interrupted command reports
#: as stored.
COMMITS: list[Path] = []


#: the signals the command line answers like Ctrl-C (SIGTERM: what kill and service managers send)
INTERRUPTS = {signal.SIGINT, signal.SIGTERM} if hasattr(signal, "SIGTERM") else {signal.SIGINT}


@contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT back (it arrives right after the block), e.g. so a Ctrl-C never falls between a
    commit and its record. Processes started inside inherit the block."""
    # Windows has no signal masks; a Ctrl-C there may fall between the commit and its record
    main_thread = threading.current_thread() is threading.main_thread() and hasattr(signal, "pthread_sigmask")
    if main_thread:
        signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTS)
    try:
        yield
    finally:
        if main_thread:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, INTERRUPTS)


@contextmanager
def interrupts_held() -> Iterator[None]:
    """Receive a Ctrl-C but hold it back until the block ends, then hand it to the SIGINT handler
    that was in place (KeyboardInterrupt, or the command line's line and exit code 130).

    For calls into C libraries that must not see a Python exception inside their calls, callbacks
    or imports (VTK: an interrupted import or a half-built off-screen plotter can crash the
    interpreter at exit). Unlike :func:`interrupts_deferred` it works whichever thread the system
    delivers the signal to (VTK's rasteriser threads may not block it)."""
    if threading.current_thread() is not threading.main_thread():
        yield  # only the main thread receives Python's signals
        return
    held: list[tuple[int, object]] = []
    previous = {s: signal.signal(s, lambda signum, frame: held.append((signum, frame))) for s in INTERRUPTS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if held and callable(previous[held[0][0]]):
            previous[held[0][0]](*held[0])
        elif held and held[0][0] == signal.SIGINT and previous[signal.SIGINT] == signal.SIG_DFL:
            raise KeyboardInterrupt
        elif held:
            signal.raise_signal(held[0][0])


def _discard(f: h5py.File | None, tmp: Path) -> None:
    """Close (if open) and delete the working copy of a write that failed."""
    try:
        if f:  # still open
            f.close()
    except Exception:  # noqa: BLE001 - a copy that cannot be closed is deleted all the same
        log.debug("closing %s failed", tmp, exc_info=True)
    finally:
        tmp.unlink(missing_ok=True)


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
    size = os.stat(path).st_size
    diskspace.ensure_space(tmp, size, path)  # room for the copy, before a byte is written
    f = None
    reserve_private(tmp, path)  # before the try: a file in the way is not ours to delete
    try:
        shutil.copyfile(path, tmp)
        shutil.copymode(path, tmp)  # the project keeps its permissions
        crash_point("copied")
        reserved = diskspace.reserve(tmp, size, 0, path)  # room for HDF5's own records
        f = h5py.File(tmp, "r+", locking=False, libver=LIBVER)
    except BaseException as exc:  # an interrupt during the copy leaves no copy behind either
        _discard(f, tmp)
        if diskspace.is_disk_full(exc):
            raise DiskFullError(diskspace.full_message(path, path.parent, size)) from None
        if isinstance(exc, OSError) and not isinstance(exc, OdsuiteError):
            raise ProjectFileError(f"{path}: cannot start a write ({exc})") from None
        raise
    try:
        with diskspace.shown_as(tmp, path):
            yield f
        h5text.set_attrs(f, {"file_update_time": now()})
        f.close()
        if reserved:  # reopened for writing, HDF5 cuts the reserved blocks it did not use
            h5py.File(tmp, "r+", locking=False, libver=LIBVER).close()
        crash_point("written")
        fsync_path(tmp)
        crash_point("synced")
        with interrupts_deferred():  # the commit and its record in COMMITS happen together
            os.replace(tmp, path)
            COMMITS.append(path)
        crash_point("replaced")
        fsync_path(path.parent, directory=True)
    except BaseException as exc:
        reached = diskspace.written_so_far(tmp)
        _discard(f, tmp)
        if diskspace.is_disk_full(exc) and not isinstance(exc, DiskFullError):  # the estimate fell short
            raise DiskFullError(diskspace.full_message(path, path.parent, reached)) from None
        if isinstance(exc, OSError) and not isinstance(exc, OdsuiteError):
            raise ProjectFileError(f"{path}: write failed, project left unchanged: {exc}") from exc
        raise
