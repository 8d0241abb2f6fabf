"""One writer at a time: an OS lock on the hidden .<name>.h5.odsuite-lock, stale locks clear themselves, readers never block."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from odsuite.core.errors import ProjectLockedError
from odsuite.core.project import create_project, open_project
from odsuite.core.systeminfo import ChannelInfo, Systeminfo


def _si(n):
    return Systeminfo([ChannelInfo() for _ in range(n)])


def test_second_writer_is_refused_readers_are_not(tmp_path):
    path = tmp_path / "p.h5"
    with create_project(path, rig=None) as writer:
        with pytest.raises(ProjectLockedError) as err:
            open_project(path, "a")
        assert str(err.value) == f"{path}: project is open in another process (pid {os.getpid()}); close it there first"
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
        from odsuite.core.project import open_project
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
    with caplog.at_level(logging.WARNING, logger="odsuite.core.storage"), open_project(path, "a") as p:
        assert p.experiment_names() == []
    assert not (tmp_path / ".p.h5.odsuite-tmp-999999").exists()
    assert ".p.h5.odsuite-tmp-999999 left by an interrupted write" in caplog.text
