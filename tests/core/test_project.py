"""The project file: schema, round trips, derived data, transactions, revisions, summaries."""

from __future__ import annotations

import dataclasses
import shutil
import subprocess

import h5py
import numpy as np
import pytest

from odsuite.domain.errors import ConfigError, DimensionError, ProjectFileError
from odsuite.store.h5codecs import rig_to_dict
from odsuite.store.project import DerivedArray, Excitation, create_project, open_project
from odsuite.store.project_format import FORMAT_NAME, FORMAT_VERSION
from odsuite.domain.systeminfo import (
    ChannelInfo,
    FilterFamily,
    FilterType,
    Integration,
    RigInfo,
    SensorType,
    Systeminfo,
)

HIT = Excitation(0, np.array([0.01, -0.02, -0.011]), np.array([0.0, 0.0, 1.0]))


def systeminfo(n: int = 11, rate: float = 1000.0) -> Systeminfo:
    return Systeminfo([ChannelInfo(sensor_type=SensorType.ACCELEROMETER, sampling_rate=rate) for _ in range(n)])


def odd_systeminfo() -> Systeminfo:
    """Every field away from its default, None and non-None cut-offs, unicode text, lists."""
    chans = []
    for i in range(3):
        chans.append(ChannelInfo(
            sensor_type=list(SensorType)[i + 1], location=f"corner C, ±x {i}", serial=f"S{i}",
            sensitivity=0.0201 + i, integration=Integration.DOUBLE, filter_type=FilterType.BANDSTOP,
            filter_order=4 + i, sampling_rate=2048.5, cutoff_high=None if i == 0 else 300.0 + i,
            cutoff_low=None if i == 1 else 0.5 * i, ripple_db=0.5, attenuation_db=40.0 + i,
            filters_on=16, micro_units=True, invert=bool(i % 2), offset_start=3 + i, offset_length=50,
            daq_gain=2.5, filter_family=FilterFamily.BUTTERWORTH, limit_high=5.0, limit_low=-5.0 - i,
            zero_phase=True, integration_rule="trapezoid",
        ))
    rig = RigInfo(use_in_gcc=True, use_in_ag=True, plate_sizes=[(0.1, 0.2, 0.03), (0.5, 0.5, 0.0254)],
                  plate_origins=[(0.0, 0.0, 0.0), (-0.25, -0.25, 0.03)], plot_from_corner=True,
                  coordinate_columns=[1, 4], rx=0.09846, ry=None, rz=0.0221,
                  nine_channels=[2, 1, 0, 2, 1, 0, 2, 1, 0])  # of its 3 channels
    return Systeminfo(chans, rig)


def test_every_systeminfo_field_round_trips(tmp_path):
    si = odd_systeminfo()
    # the fixture really differs from the defaults in every field, so the round trip tests them all
    for f in dataclasses.fields(ChannelInfo):
        assert any(getattr(c, f.name) != f.default for c in si.channels), f.name
    for f in dataclasses.fields(RigInfo):
        if f.name == "ry":  # kept None here: the None <-> NaN path
            continue
        assert getattr(si.rig, f.name) != (f.default_factory() if f.default_factory is not dataclasses.MISSING
                                           else f.default), f.name
    raw = np.arange(30.0).reshape(10, 3)
    with create_project(tmp_path / "p.h5", rig=None) as p:
        p.add_experiment("e", raw, sampling_rate=2048.5, systeminfo=si, excitation=None)
        p.add_experiment("defaults", raw, sampling_rate=1000.0, systeminfo=systeminfo(3), excitation=None)
    with open_project(tmp_path / "p.h5") as p:
        back = p.experiment("e").systeminfo
        assert p.experiment("defaults").systeminfo == systeminfo(3)
    assert back == si
    for c in back.channels:
        assert type(c.sensor_type) is SensorType and type(c.filter_family) is FilterFamily
    assert back.rig.plate_sizes == [(0.1, 0.2, 0.03), (0.5, 0.5, 0.0254)]
    assert back.rig.ry is None and back.rig.rx == 0.09846


def test_schema_attrs_and_experiment_round_trip(tmp_path, thesis_rig):
    rng = np.random.default_rng(1)
    raw = rng.normal(size=(3000, 11))
    with create_project(tmp_path / "p.h5", rig=thesis_rig) as p:
        e = p.add_experiment("hit 1", raw, sampling_rate=1000, systeminfo=systeminfo(), pretrigger=100,
                             excitation=Excitation(0, np.array([0.01, 0.0, -0.011]), np.array([0, 0, 4.0])),
                             source="test")
        assert e.n_samples == 3000
    with h5py.File(tmp_path / "p.h5", "r") as f:  # text is fixed-length UTF-8: h5py reads bytes
        a = {k: v.decode() if isinstance(v, bytes) else v for k, v in f.attrs.items()}
        assert a["odsuite_format"] == FORMAT_NAME and a["odsuite_format_version"] == FORMAT_VERSION
        assert a["hdf5_version"] == h5py.version.hdf5_version and a["h5py_version"] == h5py.version.version
        assert a["creator"] == "odsuite" and a["creator_version"]
        assert a["file_time"][-6] in "+-"  # tz-aware ISO 8601
        g = f["experiments/hit 1"]
        assert g.attrs["odsuite_type"] == b"experiment" and len(g.attrs["object_id"]) == 36
        ds = g["raw"]
        assert ds.fletcher32 and ds.chunks is not None and ds.dtype == np.float64
        assert ds.attrs["units"] == b"V" and list(ds.attrs["dims"]) == [b"sample", b"channel"]
        # per-channel metadata readable by name without odsuite
        assert list(g["systeminfo/channels"]["name"][[0, 2]]) == [b"force", b"xC"]
    with open_project(tmp_path / "p.h5") as p:
        e = p.experiment("hit 1")
        assert np.array_equal(e.raw(), raw)
        assert np.array_equal(e.raw(10, 20, channels=["y3", 0]), raw[10:20][:, [10, 0]])
        assert np.array_equal(e.raw(5, 6, channels="xC"), raw[5:6, 2])
        assert e.channel_names[:3] == ["force", "ch1", "xC"]  # from the rig's sensors
        assert np.array_equal(e.excitation.direction, [0, 0, 1.0])  # stored as a unit vector
        assert (e.sampling_rate, e.pretrigger, e.rig_name, e.source) == (1000.0, 100, "thesis-dynamometer", "test")


def test_rig_sources(tmp_path, thesis_rig):
    # by registered name and by path: the stored rig parses back to the same rig, and the rig
    # file's own text is kept beside it
    for i, rig in enumerate(["thesis-dynamometer", thesis_rig.source]):
        with create_project(tmp_path / f"n{i}.h5", rig=rig) as p:
            assert rig_to_dict(p.rig) == rig_to_dict(thesis_rig)
        with h5py.File(tmp_path / f"n{i}.h5", "r") as f:
            assert f["rig"].attrs["source_text"].decode() == thesis_rig.source.read_text()
            assert f["rig"].attrs["definition_format"].decode() == "json"
    # a rig built in code has no TOML: stored as JSON, still self-contained
    code_rig = dataclasses.replace(thesis_rig, name="code-rig", source=None)
    with create_project(tmp_path / "c.h5", rig=code_rig) as p:
        pass
    with open_project(tmp_path / "c.h5") as p:
        back = p.rig
    assert back.name == "code-rig"
    assert np.allclose(back.body("platform").inertia, thesis_rig.body("platform").inertia)
    assert [s.position.tolist() for s in back.sensors] == [s.position.tolist() for s in thesis_rig.sensors]
    for none in (None, "none"):
        with create_project(tmp_path / f"x{none}.h5", rig=none) as p:
            assert p.rig is None and p.model_revisions() == [] and p.current_revision is None
    with pytest.raises(ConfigError, match="no-such-rig"):
        create_project(tmp_path / "u.h5", rig="no-such-rig")
    assert not (tmp_path / "u.h5").exists()


def test_streamed_add_equals_array_add(tmp_path):
    rng = np.random.default_rng(2)
    raw = rng.normal(size=(10_007, 4))
    with create_project(tmp_path / "p.h5", rig=None) as p:
        p.add_experiment("known", (raw[i:i + 1000] for i in range(0, len(raw), 1000)), n_samples=len(raw),
                         sampling_rate=500.0, systeminfo=systeminfo(4, rate=500.0), excitation=None)
        p.add_experiment("unknown", (raw[i:i + 999] for i in range(0, len(raw), 999)),
                         sampling_rate=500.0, systeminfo=systeminfo(4, rate=500.0), excitation=None)
        assert p.experiment("known").channel_names == ["ch0", "ch1", "ch2", "ch3"]
        assert np.array_equal(p.experiment("known").raw(), raw)
        assert np.array_equal(p.experiment("unknown").raw(), raw)
        with pytest.raises(DimensionError, match="10007 rows, expected 20000"):
            p.add_experiment("short", iter([raw]), n_samples=20_000, sampling_rate=500.0,
                             systeminfo=systeminfo(4, rate=500.0), excitation=None)
        assert p.experiment_names() == ["known", "unknown"]


def test_an_accented_name_is_one_experiment_however_it_is_spelled(tmp_path):
    # 'é' as one character (NFC, as typed) or as 'e' and a combining accent (NFD, a macOS file
    # name): two experiments that print alike, and a name typed one way missed the other
    composed, decomposed = "mesure-\u00e9", "mesure-e\u0301"
    raw = np.zeros((64, 2))
    with create_project(tmp_path / "p.h5", rig=None) as p:
        p.add_experiment(decomposed, raw, sampling_rate=500.0, systeminfo=systeminfo(2, rate=500.0), excitation=None)
        assert p.experiment_names() == [composed]
        assert p.experiment(decomposed).name == p.experiment(composed).name == composed
        with pytest.raises(ConfigError, match="already exists"):
            p.add_experiment(composed, raw, sampling_rate=500.0, systeminfo=systeminfo(2, rate=500.0), excitation=None)
        assert p.experiment_names() == [composed]


def test_derived_write_replace_stream_and_provenance(tmp_path):
    with create_project(tmp_path / "p.h5", rig=None) as p:
        e = p.add_experiment("e", np.zeros((100, 2)), sampling_rate=100.0, systeminfo=systeminfo(2, rate=100.0),
                             excitation=None)
        acc = np.linspace(0, 1, 200).reshape(100, 2)
        p.write_derived("e", "processed", {"acc": DerivedArray(acc, "m/s^2", ("sample", "channel")),
                                           "frf": DerivedArray(np.array([1 + 2j, 3j]), "m/s^2/N", ("f",))},
                        provenance={"plugin": "filters", "version": "0.1", "parameters": {"order": 4}},
                        attrs={"note": "ok", "chain": {"a": [1, 2]}})
        d = p.read_derived("e", "processed")
        assert np.array_equal(d["acc"], acc) and np.array_equal(d["frf"], [1 + 2j, 3j])
        info = p.derived_info("e", "processed")
        assert info["provenance"]["plugin"] == "filters" and info["provenance"]["parameters"] == {"order": 4}
        assert info["provenance"]["inputs"] == [e.object_id]
        assert info["units"] == {"acc": "m/s^2", "frf": "m/s^2/N"} and info["attrs"]["note"] == "ok"
        # replace with a streamed group; a failing writer leaves the previous group intact
        with p.derived_writer("e", "processed", provenance={"plugin": "filters"}) as w:
            ds = w.create("acc", (100, 2), np.float64, "m/s^2", ("sample", "channel"))
            ds[:50] = acc[:50] * 2
            ds[50:] = acc[50:] * 2
        with pytest.raises(RuntimeError), p.derived_writer("e", "processed", provenance={"plugin": "x"}) as w:
            w.create("acc", (100, 2), np.float64, "m/s^2", ("sample", "channel"))[:] = 0
            raise RuntimeError("plugin failed")
        assert p.derived_kinds("e") == ["processed"]
        assert np.array_equal(p.read_derived("e", "processed")["acc"], acc * 2)
        assert list(p.read_derived("e", "processed")) == ["acc"]
        with pytest.raises(DimensionError, match="2 dims"):
            p.write_derived("e", "bad", {"x": DerivedArray(np.zeros(3), "1", ("a", "b"))},
                            provenance={"plugin": "t"})
        with pytest.raises(ConfigError, match="provenance needs the plugin"):
            p.write_derived("e", "bad", {}, provenance={})
        assert p.derived_kinds("e") == ["processed"]


def test_transaction_batches_into_one_copy(tmp_path, monkeypatch):
    copies = []
    real = shutil.copyfile
    monkeypatch.setattr(shutil, "copyfile", lambda a, b: copies.append(a) or real(a, b))
    with create_project(tmp_path / "p.h5", rig=None) as p:
        copies.clear()
        with p.transaction():
            for i in range(5):
                p.add_experiment(f"e{i}", np.full((10, 2), i), sampling_rate=10.0, systeminfo=systeminfo(2, rate=10.0),
                                 excitation=None)
            with open_project(tmp_path / "p.h5") as reader:  # nothing visible before the commit
                assert reader.experiment_names() == []
            # a failed add inside the batch leaves no trace, the batch goes on
            with pytest.raises(ConfigError, match="channel 1"):
                p.add_experiment("bad", iter([np.zeros((3, 2)), np.array([[0, np.nan]])]),
                                 sampling_rate=10.0, systeminfo=systeminfo(2, rate=10.0), excitation=None)
        assert len(copies) == 1
        with open_project(tmp_path / "p.h5") as reader:
            assert reader.experiment_names() == [f"e{i}" for i in range(5)]
            assert reader.experiment("e3").raw()[0, 0] == 3.0


def test_read_only_project_refuses_writes(tmp_path):
    create_project(tmp_path / "p.h5", rig=None).close()
    with open_project(tmp_path / "p.h5") as p, pytest.raises(ProjectFileError, match="read-only"):
        p.add_experiment("e", np.zeros((2, 2)), sampling_rate=1.0, systeminfo=systeminfo(2, rate=1.0), excitation=None)


def test_a_reader_opens_and_walks_the_file_once(tmp_path, monkeypatch):
    """Each open walks every object of the file (``refuse_outside``): a reader checks the format on
    the file it then reads, instead of opening it again (a writer still checks before its lock)."""
    from odsuite.store import h5damage

    with create_project(tmp_path / "p.h5", rig=None) as p:
        p.add_experiment("e", np.ones((4, 2)), sampling_rate=1.0, systeminfo=systeminfo(2, rate=1.0), excitation=None)
    walked = []
    monkeypatch.setattr(h5damage, "refuse_outside", lambda f, where: walked.append(f.filename))
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment("e").raw().sum() == 8.0
    assert walked == [str(tmp_path / "p.h5")]


def test_model_revisions(tmp_path, thesis_rig):
    with create_project(tmp_path / "p.h5", rig=thesis_rig) as p:
        (r0,) = p.model_revisions()
        assert (r0["revision"], r0["effects"], r0["parameters"], r0["model"], r0["parent"]) == \
            (0, [], {}, "rigid-bodies", None)
        n = p.add_model_revision([{"effect": "stiffness", "k": 1.5e6}], {"k": 1.5e6}, {"error": 0.2}, parent=0)
        assert n == 1 and p.current_revision == 1
        p.set_revision_metrics(0, {"error": 0.4})
        p.set_current_revision(0)
        with pytest.raises(ConfigError, match="parent revision 7"):
            p.add_model_revision([], {}, {}, parent=7)
        with pytest.raises(ConfigError, match="no model revision 9"):
            p.set_current_revision(9)
        with pytest.raises(ConfigError, match="JSON"):
            p.add_model_revision([object()], {}, {}, parent=0)
    with open_project(tmp_path / "p.h5") as p:
        revs = p.model_revisions()
        assert [r["revision"] for r in revs] == [0, 1] and p.current_revision == 0
        assert revs[1]["effects"] == [{"effect": "stiffness", "k": 1.5e6}] and revs[1]["parent"] == 0
        assert revs[1]["model"] == "rigid-bodies" and revs[0]["metrics"] == {"error": 0.4}


def test_info_peaks_and_clipping(tmp_path):
    rng = np.random.default_rng(3)
    raw = rng.uniform(-4, 4, size=(20_000, 3))
    raw[100, 1] = 9.9995  # a 16-bit converter's top code on a +-10 V range
    raw[200, 2] = -5.0  # exactly at this channel's lower limit
    si = systeminfo(3, rate=2000.0)
    si.channels[2].limit_low = -5.0
    with create_project(tmp_path / "p.h5", rig=None) as p:
        p.add_experiment("e", raw, sampling_rate=2000.0, systeminfo=si, excitation=None)
        info = p.info()
    e = info["experiments"]["e"]
    assert e["n_samples"] == 20_000 and e["duration"] == 10.0 and e["sampling_rate"] == 2000.0
    # 1 V per m/s^2 and a DAQ gain of 1: the raw peaks themselves, in m/s^2
    assert np.allclose([v for v, _unit in e["peak"].values()], np.abs(raw).max(axis=0), rtol=0, atol=0)
    assert {unit for _v, unit in e["peak"].values()} == {"m/s^2"}
    assert e["clipped"] == ["ch1", "ch2"] and e["clipped_samples"] == {"ch1": 1, "ch2": 1}
    assert info["rig"] is None and info["format_version"] == FORMAT_VERSION


def _numeric_datasets(f: h5py.File) -> list[h5py.Dataset]:
    found = []
    f.visititems(lambda _n, o: found.append(o) if isinstance(o, h5py.Dataset) and o.dtype.kind != "O" else None)
    return found


def test_every_numeric_dataset_has_units_and_dims(tmp_path, thesis_rig):
    with create_project(tmp_path / "p.h5", rig=thesis_rig) as p:
        p.add_experiment("e", np.zeros((50, 11)), sampling_rate=2048.5, systeminfo=odd_systeminfo_11(),
                         excitation=HIT)
        p.write_derived("e", "d", {"x": DerivedArray(np.zeros(5), "s", ("t",))}, provenance={"plugin": "t"})
    with h5py.File(tmp_path / "p.h5", "r") as f:
        datasets = _numeric_datasets(f)
        assert len(datasets) >= 9  # raw, channel table, 7 RigInfo datasets, derived
        for ds in datasets:
            assert "units" in ds.attrs and "dims" in ds.attrs, ds.name
            assert len(ds.attrs["dims"]) == ds.ndim, ds.name
        groups = []
        f.visititems(lambda _n, o: groups.append(o) if isinstance(o, h5py.Group) else None)
        for g in groups:
            assert "odsuite_type" in g.attrs and "object_id" in g.attrs, g.name
    h5dump = shutil.which("h5dump")
    if h5dump is None:
        pytest.skip("h5dump not installed (apt-get install hdf5-tools) - the h5py walk above passed")
    out = subprocess.run([h5dump, "-A", str(tmp_path / "p.h5")], capture_output=True, text=True, check=True).stdout
    assert "odsuite_format" in out and '"odsuite.project"' in out and "units" in out and '"V"' in out


def test_text_is_stored_as_fixed_length_utf8(tmp_path, thesis_rig):
    """No variable-length strings anywhere: they live in HDF5's global heap, whose damaged bytes
    can hang the HDF5 reader (a fuzzing find); non-ASCII text round-trips."""
    from odsuite.store.h5text import is_variable_text

    si = odd_systeminfo_11()
    with create_project(tmp_path / "p.h5", rig=thesis_rig) as p:
        p.add_experiment("Prüfung ζ", np.zeros((50, 11)), sampling_rate=2048.5, systeminfo=si, excitation=HIT,
                         source="Prüfstand")
        p.write_derived("Prüfung ζ", "d", {"x": DerivedArray(np.zeros(5), "µm", ("t",))},
                        provenance={"plugin": "t"}, attrs={"note": "Δf = 2 Hz", "empty": ""})
        p.add_model_revision([{"effect": "stiffness"}], {"k": 1.0}, {"error": 0.5}, None)
    with h5py.File(tmp_path / "p.h5", "r") as f:
        objects = [f]
        f.visititems(lambda _n, o: objects.append(o))
        attrs = [(o.name, k, o.attrs.get_id(k).dtype) for o in objects for k in o.attrs]
        assert len(attrs) > 60
        assert [a for a in attrs if is_variable_text(a[2])] == []
        assert [o.name for o in objects if isinstance(o, h5py.Dataset) and is_variable_text(o.dtype)] == []
        assert h5py.check_string_dtype(f.attrs.get_id("odsuite_format").dtype).encoding == "utf-8"
    with open_project(tmp_path / "p.h5") as p:
        e = p.experiment("Prüfung ζ")
        assert e.source == "Prüfstand" and e.systeminfo == si
        info = p.derived_info("Prüfung ζ", "d")
        assert info["units"] == {"x": "µm"} and info["attrs"] == {"note": "Δf = 2 Hz", "empty": ""}


def odd_systeminfo_11() -> Systeminfo:
    si = odd_systeminfo()
    return Systeminfo([si.channels[i % 3] for i in range(11)], si.rig)


def test_failed_transaction_commits_nothing(tmp_path):
    path = tmp_path / "p.h5"
    with create_project(path, rig=None) as p:
        p.add_experiment("keep", np.ones((5, 2)), sampling_rate=1.0, systeminfo=systeminfo(2, rate=1.0), excitation=None)
        before = path.read_bytes()
        with pytest.raises(KeyError), p.transaction():
            p.add_experiment("lost", np.ones((5, 2)), sampling_rate=1.0, systeminfo=systeminfo(2, rate=1.0), excitation=None)
            p.write_derived("keep", "d", {"x": DerivedArray(np.zeros(2), "1", ("a",))}, provenance={"plugin": "t"})
            assert p.experiment_names() == ["keep", "lost"]  # the transaction sees its own writes
            raise KeyError("a plugin failed half-way")
        assert p.experiment_names() == ["keep"] and p.derived_kinds("keep") == []
    assert path.read_bytes() == before
    assert sorted(x.name for x in tmp_path.iterdir()) == ["p.h5"]


def test_a_project_keeps_its_rigs_ctr_and_never_reads_the_path_it_names(tmp_path, thesis_rig):
    # the stored rig named the .CTR by its absolute path, read at every `acquire`: a definition edited
    # to name any local file had that file read (and its first field printed in the error)
    import json

    from odsuite.store import h5text

    path = tmp_path / "p.h5"
    create_project(path, thesis_rig).close()
    with h5py.File(path, "r") as f:
        assert json.loads(f["rig"].attrs["definition"])["systeminfo"] == "thesis-table-e3.CTR"
        assert h5text.text(f["rig"].attrs["systeminfo_text"]) == thesis_rig.systeminfo_file.read_text(encoding="utf-8")
    with open_project(path, "r") as p:
        assert p.rig.systeminfo_text is not None
        assert Systeminfo.for_rig(p.rig, 20000.0) == Systeminfo.for_rig(thesis_rig, 20000.0)
    secret = tmp_path / "secret.txt"
    secret.write_text("hunter2\n" + "0\n" * 33)
    for named, kept in ((str(secret), None), ("/elsewhere/thesis-table-e3.CTR", thesis_rig.systeminfo_file)):
        with h5py.File(path, "r+") as f:  # as stored before the text was kept, or edited by hand
            d = json.loads(f["rig"].attrs["definition"])
            d["systeminfo"] = named
            f["rig"].attrs["definition"] = json.dumps(d)
            f["rig"].attrs["systeminfo_text"] = ""
        with open_project(path, "r") as p:
            # a registered rig's own table (shipped with the plugins) is found there; no other path is read
            assert p.rig.systeminfo_file == kept and p.rig.systeminfo_text is None
            channels = Systeminfo.for_rig(p.rig, 20000.0).channels
            assert len(channels) == p.rig.channel_count and all("hunter2" not in c.location for c in channels)


@pytest.mark.parametrize("streamed", [False, True])
def test_a_record_the_reader_would_refuse_is_not_stored(tmp_path, streamed):
    # a pre-trigger longer than the record was stored, then refused by every reader: info, compare
    # and report failed on the project for good
    raw = np.zeros((100, 2))
    with create_project(tmp_path / "p.h5", rig=None) as p:
        with pytest.raises(ConfigError, match=r"experiment 'e1'.*pretrigger.* 0 to 100 samples.*got 500"):
            p.add_experiment("e1", iter([raw[:60], raw[60:]]) if streamed else raw, sampling_rate=500.0,
                             systeminfo=systeminfo(2, rate=500.0), excitation=None, pretrigger=500)
        assert p.experiment_names() == []
