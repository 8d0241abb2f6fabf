"""Older project files: the frozen file of every format version still reads with equal values;
migrations run on read."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import re
import shutil
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest

from odsuite.store import migrations
from odsuite.domain.errors import ProjectVersionError
from odsuite.store.project import DerivedArray, create_project, open_project
from odsuite.store.project_format import FORMAT_VERSION
from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

BACK_COMPAT = Path(__file__).resolve().parents[1] / "data" / "back_compat"


def _make_files():
    spec = importlib.util.spec_from_file_location("make_files", BACK_COMPAT / "make_files.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


FROZEN = sorted(BACK_COMPAT.glob("project-*.h5"))


def test_a_frozen_file_exists_for_the_current_version():
    assert f"project-{FORMAT_VERSION}.h5" in [f.name for f in FROZEN]


@pytest.mark.parametrize("mode", ["r", "a"])
@pytest.mark.parametrize("frozen_file", FROZEN, ids=lambda f: f.stem)
def test_frozen_file_reads_with_equal_values(frozen_file, mode, tmp_path):
    frozen = tmp_path / frozen_file.name
    shutil.copyfile(frozen_file, frozen)
    e = _make_files().expected()
    with open_project(frozen, mode) as p:
        assert p.format_version == FORMAT_VERSION  # migrated: a private copy in "r", the file itself in "a"
        assert p.rig.name == "thesis-dynamometer" and len(p.rig.sensors) == 9
        x = p.experiment("hit-z")
        assert np.array_equal(x.raw(), e["raw"])
        # row 7 was written at 0 Hz: it reads as the experiment's rate, which the file keeps
        si = e["systeminfo"]
        assert x.systeminfo == Systeminfo([replace(ch, sampling_rate=5000.0) for ch in si.channels], si.rig)
        assert x.excitation.force_channel == 0
        assert np.array_equal(x.excitation.point, e["excitation"].point)
        assert np.array_equal(x.excitation.direction, e["excitation"].direction)
        assert (x.sampling_rate, x.pretrigger, x.source) == (5000.0, 200, "make_files.py")
        assert np.array_equal(p.read_derived("hit-z", "gencoords")["q"], e["derived"])
        assert p.derived_info("hit-z", "gencoords")["provenance"]["parameters"] == {"at": "center"}
        effects, params, metrics = e["revision"]
        r = p.model_revisions()[1]
        assert (r["effects"], r["parameters"], r["metrics"], r["parent"]) == (effects, params, metrics, 0)
        assert p.current_revision == 1
        assert p.verify() == {"hit-z": 2}


def test_1_0_0_variable_length_text_becomes_fixed_length(tmp_path):
    """1.0.0 stored text as variable-length strings (HDF5's global heap); the 1.1.0 migration
    rewrites every such attribute and table column."""
    from odsuite.store.h5text import is_variable_text

    def variable(path):
        with h5py.File(path, "r") as f:
            objects = [f]
            f.visititems(lambda _n, o: objects.append(o))
            return ([(o.name, k) for o in objects for k in o.attrs if is_variable_text(o.attrs.get_id(k).dtype)]
                    + [o.name for o in objects if isinstance(o, h5py.Dataset) and is_variable_text(o.dtype)])

    old = tmp_path / "old.h5"
    shutil.copyfile(BACK_COMPAT / "project-1.0.0.h5", old)
    assert len(variable(old)) > 50 and "/experiments/hit-z/systeminfo/channels" in variable(old)
    with open_project(old, "a"):
        pass
    assert variable(old) == []


@pytest.fixture
def old_file(tmp_path, monkeypatch):
    """A project rewritten as a fictitious format 0.9.0 that called the sampling rate 'fs'."""
    path = tmp_path / "old.h5"
    with create_project(path, rig=None) as p:
        p.add_experiment("e", np.arange(8.0).reshape(4, 2), sampling_rate=250.0,
                         systeminfo=Systeminfo([ChannelInfo(), ChannelInfo()]), excitation=None)
    with h5py.File(path, "r+") as f:
        f.attrs["odsuite_format_version"] = "0.9.0"
        g = f["experiments/e"]
        g.attrs["fs"] = g.attrs.pop("sampling_rate")

    def rename_fs(f):
        for g in f["experiments"].values():
            g.attrs["sampling_rate"] = g.attrs.pop("fs")

    monkeypatch.setitem(migrations.MIGRATIONS, "0.9.0", migrations.Migration("0.9.0", FORMAT_VERSION, rename_fs))
    return path


def test_read_migrates_a_private_copy(old_file):
    before = hashlib.sha256(old_file.read_bytes()).hexdigest()
    p = open_project(old_file)
    try:
        assert p.format_version == FORMAT_VERSION and p.experiment("e").sampling_rate == 250.0
        migrated_copy = p._read_path
        assert migrated_copy != old_file and migrated_copy.exists()
    finally:
        p.close()
    assert not migrated_copy.exists()
    assert hashlib.sha256(old_file.read_bytes()).hexdigest() == before


def test_write_mode_upgrades_the_file(old_file):
    with open_project(old_file, "a") as p:
        assert p.experiment("e").sampling_rate == 250.0
    with h5py.File(old_file, "r") as f:
        assert f.attrs["odsuite_format_version"].decode() == FORMAT_VERSION and "fs" not in f["experiments/e"].attrs


def test_version_without_migration_is_refused(old_file):
    with h5py.File(old_file, "r+") as f:
        f.attrs["odsuite_format_version"] = "0.8.0"
    for mode in ("r", "a"):
        with pytest.raises(ProjectVersionError, match=f"format 0.8.0 is older than {FORMAT_VERSION} and no migration from 0.8.0"):
            open_project(old_file, mode)


def test_1_0_0_large_text_and_text_datasets_migrate(tmp_path):
    """What 1.0.0 transactions could write: objects with old-style headers (no room for a
    fixed-length attribute over 64 KiB), text up to hundreds of KiB, and derived text datasets."""
    old = tmp_path / "old.h5"
    shutil.copyfile(BACK_COMPAT / "project-1.0.0.h5", old)
    metrics = {"per_channel": {f"ch{i}": "é" * 400 for i in range(300)}}  # ~240 KB of JSON
    labels = ["a", "bé", "", "Δf"]
    with h5py.File(old, "r+") as f:  # no libver: old-style headers, as 1.0.0 transactions made them
        g = f["models/revisions"].create_group("2")
        for k, v in {"odsuite_type": "model_revision", "object_id": "x", "model": "thesis", "parent": 1,
                     "created": "2026-01-01T00:00:00+00:00", "effects": "[]", "parameters": "{}",
                     "metrics": json.dumps(metrics)}.items():
            g.attrs[k] = v
        d = f["experiments/hit-z/derived/gencoords"]
        ds = d.create_dataset("labels", data=np.array(labels, dtype=object), dtype=h5py.string_dtype(),
                              chunks=(2,), maxshape=(None,))
        ds.attrs["units"], ds.attrs["dims"] = "", np.array(["label"], dtype=h5py.string_dtype())
    for mode in ("r", "a"):
        with open_project(old, mode) as p:
            assert p.model_revisions()[2]["metrics"] == metrics
            got = p.read_derived("hit-z", "gencoords")
            assert [v.decode() for v in got["labels"]] == labels and got["q"].shape == (2000, 6)
    with h5py.File(old, "r") as f:
        ds = f["experiments/hit-z/derived/gencoords/labels"]
        assert (ds.chunks, ds.maxshape) == ((2,), (None,))
        assert list(ds.attrs["dims"]) == [b"label"] and not h5py.check_string_dtype(ds.dtype).length is None


def test_large_text_round_trips(tmp_path):
    """Fixed-length text over 64 KiB written by transactions (dense attribute storage)."""
    metrics = {"table": ["ζ" * 50] * 2000}  # ~200 KB of JSON
    with create_project(tmp_path / "p.h5", rig=None) as p:
        p.add_experiment("e", np.zeros((4, 2)), sampling_rate=10.0,
                         systeminfo=Systeminfo([ChannelInfo(), ChannelInfo()]), excitation=None)
        n = p.add_model_revision([], {}, metrics, None)
        p.write_derived("e", "d", {"x": DerivedArray(np.zeros(3), "s", ("t",))},
                        provenance={"plugin": "t", "parameters": metrics})
    with open_project(tmp_path / "p.h5") as p:
        assert p.model_revisions()[n]["metrics"] == metrics
        assert p.derived_info("e", "d")["provenance"]["parameters"] == metrics


def test_write_mode_migration_that_cannot_write_leaves_the_project(tmp_path, monkeypatch):
    from odsuite.store import storage
    from odsuite.domain.errors import ProjectFileError

    old = tmp_path / "old.h5"
    shutil.copyfile(BACK_COMPAT / "project-1.0.0.h5", old)
    before = old.read_bytes()

    def disk_full(*_args, **_kw):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(storage, "fsync_path", disk_full)
    with pytest.raises(ProjectFileError) as info:
        open_project(old, "a")
    assert re.fullmatch(rf"{re.escape(str(old))}: no space left on \S+: needed ~[0-9.]+ MB; project unchanged",
                        str(info.value)), str(info.value)
    assert old.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.h5"]  # no copy or lock file left behind
