"""One writer at a time: an OS lock on the hidden .<name>.h5.odsuite-lock, stale locks clear themselves, readers never block."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from odsuite.domain.errors import ProjectFileError, ProjectLockedError
from odsuite.store.project import create_project, open_project
from odsuite.domain.systeminfo import ChannelInfo, Systeminfo


def _si(n):
    return Systeminfo([ChannelInfo() for _ in range(n)])


def test_second_writer_is_refused_readers_are_not(tmp_path):
    path = tmp_path / "p.h5"
    with create_project(path, rig=None) as writer:
        with pytest.raises(ProjectLockedError) as err:
            open_project(path, "a")
        # this process's own writer: "another process (pid <our pid>)" sent people looking for one
        assert str(err.value) == (f"{path}: project is already open for writing in this process; close that one "
                                  "first (or use it)")
        writer.add_experiment("e", np.ones((4, 2)), sampling_rate=1.0, systeminfo=_si(2), excitation=None)
        with open_project(path) as reader:  # a reader opens while the writer holds the lock
            assert reader.experiment_names() == ["e"]
    with open_project(path, "a") as again:  # released on close
        assert again.experiment_names() == ["e"]


def test_killed_writer_releases_lock_and_its_temp_file_is_removed(tmp_path, caplog):
    path = tmp_path / "p.h5"
    create_project(path, rig=None).close()
    code = textwrap.dedent(f"""
        import shutil, sys, time
        from odsuite.store.project import open_project
        p = open_project({str(path)!r}, "a")
        shutil.copyfile({str(path)!r}, {str(tmp_path / ".p.h5.odsuite-tmp-999999")!r})  # as if killed mid-write
        print("locked", flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "locked"
        with pytest.raises(ProjectLockedError, match=f"pid {proc.pid}\\)"):
            open_project(path, "a")
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    with caplog.at_level(logging.WARNING, logger="odsuite.store.storage"), open_project(path, "a") as p:
        assert p.experiment_names() == []
    assert not (tmp_path / ".p.h5.odsuite-tmp-999999").exists()
    assert ".p.h5.odsuite-tmp-999999 left by an interrupted write" in caplog.text


def test_no_lock_file_stays_beside_a_project(tmp_path):
    path = tmp_path / "p.h5"
    create_project(path, rig=None).close()
    with open_project(path, "a") as p:
        assert (tmp_path / ".p.h5.odsuite-lock").read_text().split()[:2] == ["odsuite-lock", str(os.getpid())]
        p.add_experiment("e", np.ones((4, 2)), sampling_rate=1.0, systeminfo=_si(2), excitation=None)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["p.h5"]


def test_a_link_at_the_lock_name_is_never_followed(tmp_path):
    path = tmp_path / "p.h5"
    create_project(path, rig=None).close()
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (tmp_path / ".p.h5.odsuite-lock").symlink_to(victim)
    with pytest.raises(ProjectFileError, match=r"lock file .*\.p\.h5\.odsuite-lock is a link, which odsuite never "
                                               r"follows; remove it$"):
        open_project(path, "a")
    dangling = tmp_path / ".q.h5.odsuite-lock"
    dangling.symlink_to(tmp_path / "nowhere.txt")  # a dangling link must not create its target either
    with pytest.raises(ProjectFileError, match="is a link"):
        create_project(tmp_path / "q.h5", rig=None)
    assert victim.read_text() == "precious\n" and (tmp_path / ".p.h5.odsuite-lock").is_symlink()
    assert not (tmp_path / "nowhere.txt").exists() and not (tmp_path / "q.h5").exists()


def test_a_users_file_at_the_lock_name_is_left_alone(tmp_path):
    path = tmp_path / "p.h5"
    create_project(path, rig=None).close()
    (tmp_path / ".p.h5.odsuite-lock").write_text("my notes\n")
    with pytest.raises(ProjectFileError, match="was not written by odsuite; move it elsewhere$"):
        open_project(path, "a")
    assert (tmp_path / ".p.h5.odsuite-lock").read_text() == "my notes\n"


def test_a_link_and_its_target_take_one_lock(tmp_path):
    target = tmp_path / "data" / "p.h5"
    target.parent.mkdir()
    create_project(target, rig=None).close()
    link = tmp_path / "link.h5"
    link.symlink_to(target)
    with open_project(link, "a") as p:
        assert (target.parent / ".p.h5.odsuite-lock").exists() and not (tmp_path / ".link.h5.odsuite-lock").exists()
        with pytest.raises(ProjectLockedError):
            open_project(target, "a")
        p.add_experiment("e", np.ones((4, 2)), sampling_rate=1.0, systeminfo=_si(2), excitation=None)
    with open_project(link, "a"):
        with pytest.raises(ProjectLockedError):
            open_project(target, "a")
    assert link.is_symlink() and open_project(target).experiment_names() == ["e"]
    assert sorted(x.name for x in target.parent.iterdir()) == ["p.h5"]


def test_a_project_with_two_hard_links_is_not_split(tmp_path):
    """A write replaces the file; a second name would keep the old one. Refused, both names kept."""
    path, other = tmp_path / "p.h5", tmp_path / "q.h5"
    create_project(path, rig=None).close()
    os.link(path, other)
    for name in (path, other):
        with pytest.raises(ProjectFileError, match="project has 2 hard links"):
            open_project(name, "a")
    assert os.path.samefile(path, other) and sorted(x.name for x in tmp_path.iterdir()) == ["p.h5", "q.h5"]
    with open_project(other) as reader:  # reading stays possible
        assert reader.experiment_names() == []


def test_odsuite_runs_without_fcntl(tmp_path):
    """Windows has no fcntl: odsuite itself never imports it (the lock goes through filelock, which
    uses LockFileEx there). Simulated by hiding the module: filelock then has no OS lock and falls
    back to its existence lock; reading, writing and the second writer's refusal all still work."""
    path = tmp_path / "p.h5"
    create_project(path).close()
    code = textwrap.dedent(f"""
        import sys
        sys.modules["fcntl"] = None  # import fcntl now raises ImportError, as on Windows
        from odsuite.cli import main
        from odsuite.domain.errors import ProjectLockedError
        from odsuite.store.project import open_project
        assert open_project({str(path)!r}).experiment_names() == []
        assert main(["info", {str(path)!r}]) == 0
        with open_project({str(path)!r}, "a"):
            try:
                open_project({str(path)!r}, "a")
                raise SystemExit("a second writer got in")
            except ProjectLockedError:
                pass
        sys.exit(main(["acquire", {str(path)!r}, "--name", "x", "--samples", "1024", "--pretrigger", "100"]))
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert open_project(path).experiment_names() == ["x"]
    assert sorted(x.name for x in tmp_path.iterdir()) == ["p.h5"]
    for module in ("storage.py", "writer_lock.py", "project.py"):
        assert "import fcntl" not in (Path(__file__).resolve().parents[2] / "odsuite" / "store" / module).read_text()
