"""Older project files: the frozen file of every format version still reads with equal values;
migrations run on read."""

from __future__ import annotations

import hashlib
import importlib.util
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from odsuite.core import migrations
from odsuite.core.errors import ProjectVersionError
from odsuite.core.project import FORMAT_VERSION, create_project, open_project
from odsuite.core.systeminfo import ChannelInfo, Systeminfo

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
        assert x.systeminfo == e["systeminfo"]
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
    from odsuite.core.h5text import is_variable_text

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
