"""A full disk: one line naming the disk and the room needed, the project unchanged, no working copy
left. On real small tmpfs disks where this process may mount one (diskfull.py), and everywhere by
fault injection in Python: the free-space check told a small number, and ENOSPC raised by the copy,
by a dataset write inside the transaction and by the final fsync."""

from __future__ import annotations

import collections
import errno
import re
import shutil

import numpy as np
import pytest

from odsuite.cli import main
from odsuite.store import diskspace
from odsuite.store import storage
from tests.reliability.diskfull import COMMANDS, can_mount, run_full_disks, summary
from tests.reliability.harness import units

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")

LINE = re.compile(r"^error: (?P<project>\S+): no space left on (?P<device>\S+): needed ~(?P<mb>[0-9.]+) MB"
                  r"(, (?P<free>[0-9.]+) MB free)?; project unchanged$")


@pytest.fixture(scope="module")
def master(tmp_path_factory):
    path = tmp_path_factory.mktemp("diskfull") / "master.h5"
    for argv in (["new", str(path)], ["acquire", str(path), "--daq", "sim", "--name", "s1", "--samples", "4096"]):
        assert main(argv) == 0
    return path


@pytest.fixture
def project(master, tmp_path):
    path = tmp_path / "p.h5"
    shutil.copyfile(master, path)
    return path


def _enospc(*_a, **_k):
    raise OSError(errno.ENOSPC, "No space left on device")


def _assert_refused(project, before, capsys, free_mb=None):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    m = LINE.match(err)
    assert m, err
    assert m["project"] == str(project) and m["device"] == str(diskspace.mount_point(project.parent))
    if free_mb is not None:
        assert float(m["free"]) == pytest.approx(free_mb, abs=0.05)
    assert units(project) == before
    assert sorted(p.name for p in project.parent.iterdir()) == ["p.h5"]  # no copy, no lock file


def test_too_little_room_is_refused_before_writing(project, capsys, monkeypatch):
    before = units(project)
    free = 300_000  # bytes: less than the project's own copy
    assert project.stat().st_size > free
    monkeypatch.setattr(diskspace.shutil, "disk_usage",
                        lambda p: collections.namedtuple("u", "total used free")(10**9, 10**9 - free, free))
    copies = []
    monkeypatch.setattr(storage.shutil, "copyfile", lambda *a: copies.append(a))
    assert main(["acquire", str(project), "--daq", "sim", "--name", "s2", "--samples", "4096"]) == 1
    assert copies == []  # not a byte written
    _assert_refused(project, before, capsys, free_mb=0.3)
    # the room asked for: the project's copy and the 1 MiB reserve for HDF5's own records
    err_mb = (project.stat().st_size + diskspace.METADATA_RESERVE) / 1e6
    monkeypatch.undo()
    assert main(["acquire", str(project), "--daq", "sim", "--name", "s2", "--samples", "4096"]) == 0
    assert err_mb > 1.0


def test_room_for_the_copy_but_not_for_the_record(project, capsys, monkeypatch):
    """The record (4096 x 11 float64 = 360 kB) is checked when its dataset is created, after the copy."""
    before = units(project)
    size = project.stat().st_size
    free = size + diskspace.METADATA_RESERVE + 100_000  # the copy fits; the record then does not
    real = shutil.disk_usage

    def usage(p):
        left = free - sum(f.stat().st_size for f in project.parent.glob(".p.h5.odsuite-tmp-*"))
        return collections.namedtuple("u", "total used free")(real(p).total, 0, left)

    monkeypatch.setattr(diskspace.shutil, "disk_usage", usage)
    assert main(["acquire", str(project), "--daq", "sim", "--name", "s2", "--samples", "4096"]) == 1
    _assert_refused(project, before, capsys)


@pytest.mark.parametrize("where", ["copy", "dataset", "fsync"])
def test_enospc_raised_by_the_write_itself(project, capsys, monkeypatch, where):
    """The free-space check passed, yet the disk fills meanwhile (another program writing)."""
    before = units(project)
    if where == "copy":
        def half_copy(src, dst):
            with open(src, "rb") as a, open(dst, "wb") as b:
                b.write(a.read(1000))
            _enospc()
        monkeypatch.setattr(storage.shutil, "copyfile", half_copy)
    elif where == "dataset":
        monkeypatch.setattr(diskspace, "ensure_room_in", _enospc)
    else:
        monkeypatch.setattr(storage, "fsync_path", _enospc)
    assert main(["acquire", str(project), "--daq", "sim", "--name", "s2", "--samples", "4096"]) == 1
    _assert_refused(project, before, capsys)


def _half_write(path, data):
    """A write that stops half-way on a full disk."""
    with open(path, "wb") as fh:
        fh.write(data[:len(data) // 2])
    _enospc()


def test_an_output_file_on_a_full_disk_is_one_line(project, tmp_path, capsys, monkeypatch):
    """The disk fills while the output is written: one line, nothing of it left, an older file
    of that name as it was."""
    assert main(["process", str(project)]) == 0
    capsys.readouterr()
    out = tmp_path / "s1.COD"
    assert main(["export-legacy", str(project), "s1", "--cod", str(out)]) == 0
    cod = out.read_bytes()
    capsys.readouterr()
    out.unlink()
    for existing in (False, True):
        if existing:
            out.write_bytes(b"an older file\n")
        monkeypatch.setattr("pathlib.Path.write_bytes", lambda self, data: _half_write(self, data))
        assert main(["export-legacy", str(project), "s1", "--cod", str(out)]) == 1
        monkeypatch.undo()
        err = capsys.readouterr().err.strip()
        needed = (len(cod) + diskspace.METADATA_RESERVE) / 1e6
        assert re.fullmatch(rf"error: {out}: no space left on \S+: needed ~{needed:.1f} MB; nothing written", err), err
        assert sorted(p.name for p in tmp_path.iterdir() if "COD" in p.name) == (["s1.COD"] if existing else [])
        assert not existing or out.read_bytes() == b"an older file\n"


@pytest.mark.parametrize("command", ["export-legacy", "export-uff", "history", "render"])
def test_outputs_are_refused_before_writing_on_a_full_disk(project, tmp_path, capsys, monkeypatch, command):
    """Too little room for an output: refused in one line before a byte is written."""
    assert main(["process", str(project)]) == 0
    out = tmp_path / "o"
    argv = {"export-legacy": ["export-legacy", str(project), "s1", "--cod", f"{out}.COD"],
            "export-uff": ["export-uff", str(project), "s1", "-o", f"{out}.uff"],
            "history": ["history", str(project), "--figure", f"{out}.png"],
            "render": ["render", str(project), "s1", "-o", f"{out}.gif", "--frame-step", "64"]}[command]
    capsys.readouterr()
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(diskspace.shutil, "disk_usage", lambda p: usage(1 << 30, (1 << 30) - 500_000, 500_000))
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert re.fullmatch(r"error: \S+: no space left on \S+: needed ~[0-9.]+ MB, 0.5 MB free; nothing written",
                        err), err
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(("o.", ".o."))] == []


needs_mount = pytest.mark.skipif(not can_mount(), reason="mounting a tmpfs needs root (mount -t tmpfs)")


@needs_mount
def test_one_small_disk_per_command(tmp_path):
    outcomes = run_full_disks(tmp_path, len(COMMANDS), seed_value=5)
    assert [o.problems for o in outcomes] == [[]] * len(COMMANDS), summary(outcomes)


@needs_mount
@pytest.mark.slow
def test_thirty_six_small_disks(tmp_path):
    outcomes = run_full_disks(tmp_path, 36, seed_value=19)
    assert [o.problems for o in outcomes] == [[]] * 36, summary(outcomes)
    # the seeded levels reach both sides: commands refused for a full disk and commands that fit
    assert sum("no space left" in o.line for o in outcomes) >= 8, summary(outcomes)
    assert sum(o.code == 0 for o in outcomes) >= 8, summary(outcomes)


def test_reserved_blocks_are_trimmed_on_commit(project):
    """The room reserved before HDF5 writes (1 MiB beyond the data) does not stay in the project."""
    from odsuite.store.project import open_project
    from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

    size = project.stat().st_size
    with open_project(project, "a") as p:
        p.add_experiment("tiny", np.ones((16, 2)), sampling_rate=1000.0,
                         systeminfo=Systeminfo([ChannelInfo() for _ in range(2)]), excitation=None)
    grown = project.stat().st_size - size
    assert 0 < grown < diskspace.METADATA_RESERVE / 4, grown  # 256 B of data and HDF5's records
    assert oct(project.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    import os

    mask = os.umask(0)
    os.umask(mask)
    return mask


@pytest.mark.skipif(not __import__("os").path.exists("/dev/full"), reason="no /dev/full")
def test_a_full_standard_output_is_named_as_such(master, tmp_path):
    """Output redirected onto a full device (`> /dev/full`): one line naming the standard output
    (a write names no file), not a file '-' in the working folder; exit code 1; the project unchanged."""
    import os
    import subprocess
    import sys

    program = os.path.join(os.path.dirname(sys.executable), "odsuite")
    before = master.read_bytes()
    for argv in (["info", str(master)], ["plugins"], ["history", str(master), "--json"]):
        with open("/dev/full", "w") as full:
            run = subprocess.run([program, *argv], stdout=full, stderr=subprocess.PIPE, text=True, timeout=300,
                                 cwd=tmp_path)
        assert (run.returncode, run.stderr.splitlines()) == (
            1, ["error: no space left on the device written to (the standard output, or a file odsuite does not name)"]), argv
    assert master.read_bytes() == before and os.listdir(tmp_path) == []
