"""A writer that forks (a worker pool, a library's subprocess) and is then killed must not leave
its children holding the project's writer lock: flock belongs to the open file, which a forked child
shares, so the child closes its copy of the lock file right after the fork."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from odsuite.domain.errors import ProjectLockedError
from odsuite.store.project import create_project, open_project

# The writer forks a child that outlives it, reports the child's pid, then is SIGKILLed (no cleanup).
# With keep=1 the child deliberately keeps a duplicate of the lock descriptor: the negative control.
FORKING_WRITER = textwrap.dedent("""
    import os, signal, sys, time
    from odsuite.store.project import open_project
    p = open_project(sys.argv[1], "a")
    lock_fd = p._lock.fileno()
    keep = os.dup(lock_fd) if sys.argv[2] == "1" else None
    child = os.fork()
    if child == 0:
        null = os.open(os.devnull, os.O_RDWR)
        os.dup2(null, 1)  # let the test's pipe reach end of file
        os.dup2(null, 2)
        time.sleep(60)
        os._exit(0)
    print(child, flush=True)
    os.kill(os.getpid(), signal.SIGKILL)
""")


def _run_forking_writer(project: Path, keep: bool) -> int:
    proc = subprocess.run([sys.executable, "-c", FORKING_WRITER, str(project), "1" if keep else "0"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    return int(proc.stdout.split()[0])


def _open_files(pid: int) -> set[str]:
    fd_dir = Path(f"/proc/{pid}/fd")
    out = set()
    for fd in fd_dir.iterdir():
        try:
            out.add(os.readlink(fd))
        except OSError:  # closed meanwhile
            pass
    return out


def _reap(pid: int) -> None:
    os.kill(pid, signal.SIGKILL)
    for _ in range(100):  # an orphan is reaped by init, not by us
        if not Path(f"/proc/{pid}").exists() or "Z" in Path(f"/proc/{pid}/stat").read_text().split()[2]:
            return
        time.sleep(0.05)


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc to list a process's open files")
@pytest.mark.parametrize("keep", [False, True], ids=["forked-child", "negative-control-dup"])
def test_a_killed_writers_forked_child_does_not_hold_the_lock(tmp_path, keep):
    project = tmp_path / "p.h5"
    create_project(project, rig=None).close()
    child = _run_forking_writer(project, keep)
    try:
        lock_file = str(project.with_name(f".{project.name}.odsuite-lock"))
        assert (lock_file in _open_files(child)) is keep
        if keep:
            with pytest.raises(ProjectLockedError, match="project is open in another process"):
                open_project(project, "a")
        else:
            with open_project(project, "a") as p:
                assert p.mode == "a"
    finally:
        _reap(child)


def test_a_forked_child_closing_its_project_leaves_the_parents_lock(tmp_path):
    """The child's copy is closed without unlocking: the parent still holds the lock after the child
    closes the project object it inherited."""
    project = tmp_path / "p.h5"
    create_project(project, rig=None).close()
    with open_project(project, "a") as p:
        child = os.fork()
        if child == 0:
            code = 0
            try:
                p.close()
            except BaseException:
                code = 1
            os._exit(code)
        _, status = os.waitpid(child, 0)
        assert os.waitstatus_to_exitcode(status) == 0
        probe = subprocess.run([sys.executable, "-c", "import sys; from odsuite.store.project import open_project; "
                                "open_project(sys.argv[1], 'a')", str(project)], capture_output=True, text=True,
                               timeout=60)
        assert "project is open in another process" in probe.stderr
