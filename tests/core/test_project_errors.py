"""Bad input and damaged files: one-line OdsuiteErrors, and the project file left byte-identical."""

from __future__ import annotations

import hashlib
import shutil

import h5py
import numpy as np
import pytest

from odsuite.domain.errors import (
    ConfigError,
    DimensionError,
    NotAProjectError,
    OdsuiteError,
    ProjectFileError,
    ProjectVersionError,
)
from odsuite.store.project import Excitation, create_project, open_project
from odsuite.store.project_format import FORMAT_VERSION
from odsuite.domain.systeminfo import ChannelInfo, Systeminfo


def _si(n=3):
    return Systeminfo([ChannelInfo() for _ in range(n)])


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def project_path(tmp_path):
    path = tmp_path / "p.h5"
    with create_project(path, rig=None) as p:
        p.add_experiment("e1", np.arange(30.0).reshape(10, 3), sampling_rate=100.0, systeminfo=_si(),
                         excitation=Excitation(0, np.zeros(3), np.array([0, 0, 1.0])))
        p.add_experiment("e2", np.arange(600_000.0).reshape(200_000, 3), sampling_rate=100.0, systeminfo=_si(),
                         excitation=None)
    return path


def _one_line(exc: OdsuiteError) -> str:
    text = str(exc)
    assert "\n" not in text
    return text


def _add(p, name="new", raw=None, **kw):
    args = dict(sampling_rate=100.0, systeminfo=_si(), excitation=None)
    args.update(kw)
    return p.add_experiment(name, np.zeros((5, 3)) if raw is None else raw, **args)


BAD_ADDS = [
    (dict(name="e1"), ConfigError, "experiment 'e1' already exists"),
    (dict(raw=np.zeros(5)), DimensionError, r"2-D \(samples x channels\), got shape \(5,\)"),
    (dict(raw=np.zeros((5, 3, 1))), DimensionError, r"got shape \(5, 3, 1\)"),
    (dict(raw=np.array([[0.0, 1.0, np.inf]])), ConfigError, "raw sample 0, channel 2 .* is inf"),
    (dict(raw=iter([np.zeros((4, 3)), np.array([[0.0, np.nan, 0.0]])])), ConfigError,
     "raw sample 4, channel 1 .* is nan"),
    (dict(raw=np.array([["a", "b", "c"]])), ConfigError, "real numbers .* dtype <U1"),
    (dict(raw=np.zeros((5, 4))), DimensionError, "systeminfo describes 3 channels but the raw data have 4"),
    (dict(raw=iter([np.zeros((4, 3)), np.zeros((4, 2))])), DimensionError, "sample 4 has 2 channels, expected 3"),
    (dict(sampling_rate=0.0), ConfigError, "sampling_rate must be a finite number > 0 Hz, got 0.0"),
    (dict(sampling_rate=-5), ConfigError, "got -5"),
    (dict(excitation=Excitation(0, np.zeros(3), np.zeros(3))), ConfigError, r"force direction must be a non-zero vector of 3 finite numbers, got \[0.0, 0.0, 0.0\]"),
    (dict(excitation=Excitation(0, np.array([0.0, np.nan, 0.0]), np.array([1.0, 0, 0]))), ConfigError,
     r"force point must be 3 finite numbers \(m\), got \[0.0, nan, 0.0\]"),
    (dict(excitation=Excitation(3, np.zeros(3), np.array([1.0, 0, 0]))), ConfigError,
     "force channel must be a channel index 0..2, got 3"),
    (dict(name="a/b"), ConfigError, "without '/'"),
    (dict(systeminfo=Systeminfo([ChannelInfo(), ChannelInfo(sampling_rate=5000.0), ChannelInfo()])), ConfigError,
     r"systeminfo channel 1 row 7 \(sampling rate\) is 5000 Hz but the record is sampled at 100 Hz"),
    (dict(channel_names=["a", "a", "b"]), DimensionError, "3 distinct names"),
]


@pytest.mark.parametrize(("kw", "error", "match"), BAD_ADDS, ids=[m for _, _, m in BAD_ADDS])
def test_bad_experiment_is_refused_and_project_unchanged(project_path, kw, error, match):
    before = _digest(project_path)
    with open_project(project_path, "a") as p:
        with pytest.raises(error, match=match) as err:
            _add(p, **kw)
        _one_line(err.value)
        assert str(project_path) in str(err.value)
        assert p.experiment_names() == ["e1", "e2"]
    assert _digest(project_path) == before
    assert sorted(x.name for x in project_path.parent.iterdir()) == ["p.h5"]


def test_unset_row_7_is_stored_as_the_records_rate(project_path):
    with open_project(project_path, "a") as p:
        _add(p, systeminfo=Systeminfo([ChannelInfo(), ChannelInfo(sampling_rate=100.0), ChannelInfo()]))
    with open_project(project_path) as p:
        assert [ch.sampling_rate for ch in p.experiment("new").systeminfo.channels] == [100.0] * 3
    with h5py.File(project_path, "r") as f:
        assert f["experiments/new/systeminfo/channels"]["sampling_rate"].tolist() == [100.0] * 3


def test_unknown_experiment_names_the_known_ones(project_path):
    with open_project(project_path) as p, pytest.raises(ConfigError) as err:
        p.experiment("e3")
    assert _one_line(err.value) == f"{project_path}: no experiment named 'e3' (experiments: e1, e2)"


def test_missing_file(tmp_path):
    for mode in ("r", "a"):
        with pytest.raises(ProjectFileError) as err:
            open_project(tmp_path / "nope.h5", mode)
        assert _one_line(err.value) == f"{tmp_path / 'nope.h5'}: no such project file"
    assert list(tmp_path.iterdir()) == []


def test_not_a_project(tmp_path):
    text = tmp_path / "notes.h5"
    text.write_bytes(b"just some bytes, not HDF5\n" * 10)
    plain = tmp_path / "plain.h5"
    with h5py.File(plain, "w") as f:
        f["x"] = np.arange(3)
    for path, match in ((text, "not an HDF5 file"), (plain, "without the root attribute odsuite_format")):
        before = _digest(path)
        for mode in ("r", "a"):
            with pytest.raises(NotAProjectError, match=match) as err:
                open_project(path, mode)
            assert str(path) in _one_line(err.value)
        assert _digest(path) == before
    with pytest.raises(ProjectFileError, match="already exists"):
        create_project(plain, rig=None)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["notes.h5", "plain.h5"]


def test_newer_versions(project_path, tmp_path):
    newer = tmp_path / "newer.h5"
    shutil.copyfile(project_path, newer)
    with h5py.File(newer, "r+") as f:
        f.attrs["odsuite_format_version"] = "2.0.0"
    before = _digest(newer)
    for mode in ("r", "a"):
        with pytest.raises(ProjectVersionError) as err:
            open_project(newer, mode)
        msg = _one_line(err.value)
        assert "2.0.0" in msg and FORMAT_VERSION in msg and str(newer) in msg
    assert _digest(newer) == before
    # a newer minor version of the same major is readable, but not writable
    with h5py.File(newer, "r+") as f:
        f.attrs["odsuite_format_version"] = "1.3.0"
    with open_project(newer) as p:
        assert np.array_equal(p.experiment("e1").raw(), np.arange(30.0).reshape(10, 3))
    with pytest.raises(ProjectVersionError, match="can read it but not change it"):
        open_project(newer, "a")


def test_truncated_file(project_path, tmp_path):
    cut = tmp_path / "cut.h5"
    data = project_path.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    before = _digest(cut)
    for mode in ("r", "a"):
        with pytest.raises(ProjectFileError, match="truncated or damaged") as err:
            open_project(cut, mode)
        assert str(cut) in _one_line(err.value)
    assert _digest(cut) == before


def test_corrupted_raw_chunk_is_named_by_verify(project_path, tmp_path):
    bad = tmp_path / "bad.h5"
    shutil.copyfile(project_path, bad)
    with h5py.File(bad, "r") as f:
        ds = f["experiments/e2/raw"]
        info = ds.id.get_chunk_info(1)  # the second chunk of e2's raw volts
        n_chunks = ds.id.get_num_chunks()
    assert n_chunks > 2
    with open(bad, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        byte = fh.read(1)
        fh.seek(-1, 1)
        fh.write(bytes([byte[0] ^ 0xFF]))
    with open_project(project_path) as p:
        assert p.verify() == {"e1": 1, "e2": 1}
    with open_project(bad) as p:
        with pytest.raises(ProjectFileError) as err:
            p.verify()
        assert "experiment 'e2'" in _one_line(err.value) and "/experiments/e2/raw" in str(err.value)
        assert np.array_equal(p.experiment("e1").raw(), np.arange(30.0).reshape(10, 3))  # untouched
        rows = info.chunk_offset[0]
        assert np.array_equal(p.experiment("e2").raw(0, rows), np.arange(3.0 * rows).reshape(rows, 3))
        with pytest.raises(ProjectFileError, match="experiment 'e2': raw data cannot be read"):
            p.experiment("e2").raw(rows, rows + 10)


@pytest.mark.parametrize("damage, named", [
    (lambda f: f.__delitem__("experiments/e2/raw"), "experiment 'e2'"),
    (lambda f: f["experiments/e2"].attrs.__setitem__("pretrigger", 10**6), "field 'pretrigger'"),
    (lambda f: f["experiments/e1"].attrs.__setitem__("sampling_rate", "fast"), "field 'sampling_rate'"),
])
def test_verify_runs_the_readers_checks(project_path, tmp_path, damage, named):
    # verify said "intact" (exit 0) for a project whose record was deleted or whose fields `info`
    # refuses: it read the checksummed datasets alone
    bad = tmp_path / "bad.h5"
    shutil.copyfile(project_path, bad)
    with h5py.File(bad, "r+") as f:
        damage(f)
    with open_project(bad) as p:
        with pytest.raises(ProjectFileError) as err:
            p.verify()
    assert named in _one_line(err.value) and str(bad) in str(err.value)


def test_verify_names_a_derived_dataset_rewritten_without_its_checksum(project_path, tmp_path):
    from odsuite.store.project import DerivedArray

    with open_project(project_path, "a") as p:
        p.write_derived("e1", "processed", {"acceleration": DerivedArray(np.ones((10, 3)), "m/s^2", ("sample", "channel"))},
                        provenance={"plugin": "test", "version": "1", "parameters": {}, "inputs": []})
    with open_project(project_path) as p:
        assert p.verify() == {"e1": 2, "e2": 1}
    with h5py.File(project_path, "r+") as f:
        g = f["experiments/e1/derived/processed"]
        attrs = dict(g["acceleration"].attrs)
        del g["acceleration"]
        g.create_dataset("acceleration", data=np.zeros((10, 3)))  # no checksum: the count dropped it
        g["acceleration"].attrs.update(attrs)
    with open_project(project_path) as p:
        with pytest.raises(ProjectFileError, match=r"experiment 'e1': dataset /experiments/e1/derived/processed/"
                                                   r"acceleration has no checksum"):
            p.verify()


def test_failed_write_is_a_project_error_and_changes_nothing(project_path, monkeypatch):
    before = _digest(project_path)
    with open_project(project_path, "a") as p:
        def disk_full(*_a, **_k):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr("odsuite.store.storage.fsync_path", disk_full)
        with pytest.raises(ProjectFileError, match=r"p.h5: no space left on /\S*: needed ~[0-9.]+ MB; project unchanged$"):
            _add(p)
        monkeypatch.undo()
        assert p.experiment_names() == ["e1", "e2"]
    assert _digest(project_path) == before
    assert sorted(x.name for x in project_path.parent.iterdir()) == ["p.h5"]
