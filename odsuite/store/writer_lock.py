"""The writer lock of a project: one writer at a time, on every operating system.

An OS lock (flock on POSIX, LockFileEx on Windows, both through filelock) on the hidden sidecar
``.<name>.odsuite-lock`` beside the project's real file: links are resolved first, so a symbolic link
and its target take the same lock. The OS drops the lock when its process dies, and the file is
removed on release, so no lock file stays beside a project after a command. filelock opens the file
without following a link there and without truncating it; a file at that name that odsuite did not
write is refused, never overwritten or deleted.
"""

from __future__ import annotations

import os
import warnings
from contextlib import suppress
from pathlib import Path

from odsuite.domain.errors import ProjectFileError, ProjectLockedError

#: First word of every lock file odsuite writes: tells its own (maybe stale) lock files from a user's.
MARK = "odsuite-lock"


def _filelock():
    """filelock, imported by the first writer: a command that only reads never pays for it."""
    with warnings.catch_warnings():  # where the system has no OS lock, filelock says so at import
        warnings.simplefilter("ignore", UserWarning)
        import filelock
    return filelock


def lock_path(project: Path) -> Path:
    """The lock file of ``project``: beside its real file, hidden, in odsuite's own name space."""
    real = Path(os.path.realpath(project))
    return real.with_name(f".{real.name}.odsuite-lock")



def _host() -> str:
    import socket  # here, not at the top: a command that only reads never imports it

    return socket.gethostname()

class WriterLock:
    """The held writer lock of one project (see ``acquire``)."""

    def __init__(self, project: Path) -> None:
        self.project = project
        self.path = lock_path(project)
        self._pid = os.getpid()
        self._fd: int | None = None
        # thread_local=False: a command may release from another thread than it acquired in. Where
        # the system has no OS lock (neither flock nor LockFileEx), filelock's FileLock is its
        # existence lock, which writes the file itself and reclaims it from a dead process.
        filelock = _filelock()
        native = filelock.FileLock is not filelock.SoftFileLock
        self._lock = filelock.FileLock(self.path, thread_local=False, blocking=False,
                                       **({"on_acquired": self._claim} if native else {}))

    def _claim(self, fd: int) -> None:
        """With the lock held: adopt the file (empty, or left by an odsuite writer that died) and
        write this process's pid and host into it for the message a second writer gets."""
        os.lseek(fd, 0, os.SEEK_SET)
        head = os.read(fd, 256)
        if head and not head.startswith(MARK.encode()):
            raise ProjectFileError(f"{self.project}: {self.path} is in the way of the writer lock and was not "
                                   "written by odsuite; move it elsewhere")
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{MARK} {os.getpid()} {_host()}\n".encode())
        self._fd = fd

    def acquire(self) -> WriterLock:
        if self.path.is_symlink():
            raise ProjectFileError(f"{self.project}: lock file {self.path} is a link, which odsuite never follows; "
                                   "remove it")
        try:
            self._lock.acquire()
        except _filelock().Timeout:
            if not os.path.lexists(self.path):  # held by no one: filelock could not create it, and says only Timeout
                raise ProjectFileError(f"{self.project}: cannot create lock file {self.path}: "
                                       f"{self._why_not_created()}") from None
            holder = self._holder()
            if holder == f"pid {os.getpid()}":  # this process's own lock: "another process" sent people looking
                raise ProjectLockedError(f"{self.project}: project is already open for writing in this process; "
                                         "close that one first (or use it)") from None
            raise ProjectLockedError(f"{self.project}: project is open in another process ({holder}); "
                                     "close it there first") from None
        except OSError as exc:
            if isinstance(exc, ProjectFileError):
                raise
            raise ProjectFileError(f"{self.project}: cannot create lock file {self.path}: "
                                   f"{exc.strerror or exc}") from None
        return self

    def _why_not_created(self) -> str:
        """The system's reason the lock file cannot be created (a read-only or virtual folder)."""
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
        except OSError as exc:
            return exc.strerror or str(exc)
        os.close(fd)
        os.unlink(self.path)
        return "the folder refused it"

    def _holder(self) -> str:
        """"pid N" of the process holding the lock (and its host when it is another)."""
        try:
            fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
            try:
                words = os.read(fd, 256).decode("utf-8", "replace").split()
            finally:
                os.close(fd)
        except OSError:  # e.g. Windows: the holder's byte range cannot be read
            words = []
        pid = words[1] if len(words) > 1 and words[0] == MARK else "?"
        host = f" on host {words[2]}" if len(words) > 2 and words[2] != _host() else ""
        return f"pid {pid}{host}"

    def fileno(self) -> int | None:
        """The descriptor holding the lock (tests inspect it)."""
        return self._fd

    def release(self) -> None:
        """Remove the lock file and release the lock. In a forked child nothing happens: the lock
        is the parent's (filelock closed the child's copy of the descriptor at the fork)."""
        if os.getpid() != self._pid or not self._lock.is_locked:
            return
        try:
            # removed while still held: a writer that opened the old file finds it unlinked once it
            # gets the lock, and filelock then starts over on the new one. Windows cannot unlink
            # an open file; filelock removes it there after the release.
            if os.name != "nt" and self._fd is not None:
                with suppress(OSError):
                    if os.path.samestat(os.lstat(self.path), os.fstat(self._fd)):
                        os.unlink(self.path)
        finally:
            self._fd = None
            self._lock.release()


def acquire(project: Path) -> WriterLock:
    """Take the writer lock of ``project`` or raise ProjectLockedError naming the holder."""
    return WriterLock(Path(project)).acquire()
