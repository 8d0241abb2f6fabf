"""Every pyuff sample file through `odsuite import`: stored as what it is (a record, FRFs, nodes,
modes) with the values its README lists, or refused in one line saying why; a file cut short is
refused naming what is missing; an export read and rewritten by pyuff imports back identically."""

from __future__ import annotations

import numpy as np
import pytest
import pyuff

from odsuite.cli import main
from odsuite.store.project import open_project
from odsuite.domain.systeminfo import SensorType


@pytest.fixture
def samples(real_data):
    return real_data / "pyuff_uff_samples"


@pytest.fixture
def empty(tmp_path):
    p = tmp_path / "u.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    return p


def _import(project, path, name, capsys):
    capsys.readouterr()
    code = main(["import", str(project), str(path), "--name", name])
    out = capsys.readouterr()
    return code, out.out, out.err


# file -> experiment: (samples, channels, first value of channel 0 from the README/pyuff's tests)
RECORDS = {
    "Sample_UFF58_ascii": (79292, 1, -1.47553e-2),
    "Sample_UFF58b_bin": (79292, 1, -1.47553e-2),
    "binary8byte": (250, 1, 0.0),
    "mpstd_set001_58b_4ch_accel": (222400, 4, None),
    "time-history-not-all-columns-filled": (13, 1, None),
}


@pytest.mark.parametrize("stem", sorted(RECORDS))
def test_time_files_are_operating_records(samples, empty, capsys, stem):
    n, channels, first = RECORDS[stem]
    code, out, err = _import(empty, samples / f"{stem}.uff", "r", capsys)
    assert code == 0 and "as experiment 'r'" in out
    assert "stored as an operating record" in err  # none of them holds a force
    with open_project(empty) as p:
        exp = p.experiment("r")
        assert exp.excitation is None and exp.n_samples == n and exp.n_channels == channels
        assert SensorType.LOADCELL not in [c.sensor_type for c in exp.systeminfo.channels]
        if first is not None:
            assert exp.raw()[0, 0] == pytest.approx(first, rel=1e-5, abs=1e-12)
        if stem.startswith("Sample_UFF58"):  # a microphone's record: its unit label says Pa
            assert exp.systeminfo.channels[0].unit == "Pa"


def test_geometry_files_are_nodes(samples, empty, capsys):
    for stem, count in (("artemis_geometry_15_82_2412", 74), ("oros_mesh_18_15_2412", 96),
                        ("testlab_geometry_151_164_18_15_82", 36)):
        code, out, _ = _import(empty, samples / f"{stem}.uff", stem, capsys)
        assert code == 0 and f"{count} nodes as import {stem!r} (nodes)" in out
    with open_project(empty) as p:
        assert p.info()["imports"] == {s: "nodes" for s in ("artemis_geometry_15_82_2412", "oros_mesh_18_15_2412",
                                                            "testlab_geometry_151_164_18_15_82")}
        art, attrs = p.read_import("artemis_geometry_15_82_2412")
        tl, tl_attrs = p.read_import("testlab_geometry_151_164_18_15_82")
    # pyuff's test_15 values (README): node numbers and coordinates (m)
    assert art["node_nums"][:4].tolist() == [16, 17, 18, 19]
    np.testing.assert_allclose(art["xyz"][:11, 0], [0, 1.53, 0, -1.53, 0, 1.53, 0, 1.53, 4.296, 5.616, 4.296])
    np.testing.assert_allclose(art["xyz"][:9, 2], [0, 0, 0, 0, 1.83, 1.83, 1.83, 1.83, 0.4])
    assert [name for name, _ in attrs["trace_lines"]] == ["Global Trace Lines"] * 2
    # TestLab: every node has its own system (dataset 18, test_18): node 1's x axis runs from
    # ref_o (-2.4, -0.95, 0) to x_point (-3.4, -0.95, -8.74e-8), i.e. along global -x; 164 length 1
    np.testing.assert_allclose(tl["xyz"][0], [-2.4, -0.95, 0.0])
    np.testing.assert_allclose(tl["directions"][0][:, 0], [-1.0, 0.0, -8.74228e-08], atol=1e-6)
    assert [name for name, _ in tl_attrs["trace_lines"]] == ["Massif", "Stator", "Dalle"]


def test_frf_only_file_is_an_frf_import(samples, empty, capsys):
    code, out, _ = _import(empty, samples / "non_ascii_header.uff", "h", capsys)
    assert code == 0 and "1 FRFs as import 'h' (frf)" in out
    with open_project(empty) as p:
        arrays, attrs = p.read_import("h")
    H = arrays["H_real"] + 1j * arrays["H_imag"]
    assert H.shape == (1, 6)
    assert H[0, 0] == pytest.approx(0.407994, rel=1e-5) and H[0, -1] == pytest.approx(3.75037 + 2.93363j, rel=1e-5)
    assert arrays["frequency"][1] == pytest.approx(0.195313, rel=1e-5)


def test_mode_files_are_mode_imports(samples, empty, capsys):
    code, out, _ = _import(empty, samples / "uff55_translation.uff", "m3", capsys)
    assert code == 0 and "3 modes as import 'm3' (modes)" in out
    code, out, _ = _import(empty, samples / "uff55_translation_rotation.uff", "m1", capsys)
    assert code == 0 and "1 modes as import 'm1' (modes)" in out
    with open_project(empty) as p:
        three, _ = p.read_import("m3")
        one, _ = p.read_import("m1")
    np.testing.assert_allclose(three["frequency_hz"], [10.0, 12.0, 13.0])
    assert three["mode_nodes"].tolist() == [1, 2, 3, 4] and three["shape_real"].shape == (3, 4, 3)
    assert one["frequency_hz"].tolist() == [pytest.approx(97.013)] and one["shape_real"].shape == (1, 43, 6)
    raw = pyuff.UFF(str(samples / "uff55_translation_rotation.uff")).read_sets()
    raw = raw[0] if isinstance(raw, list) else raw
    np.testing.assert_array_equal(one["shape_real"][0][:, 3], raw["r4"])  # the first rotation, as pyuff reads it


def test_psd_is_not_a_record(samples, empty, capsys):
    before = empty.read_bytes()
    code, _, err = _import(empty, samples / "sample_dataset58_psd.uff", "psd", capsys)
    assert code == 1
    assert err.strip() == (f"error: {samples / 'sample_dataset58_psd.uff'}: nothing to import: 58 'Power Spectral "
                           "Density (PSD)' is a power spectral density (function type 9), not a record")
    assert empty.read_bytes() == before


@pytest.mark.parametrize("stem, cut, words", [
    ("Sample_UFF58_ascii", 300_000, "dataset 1 (type 58) from line 2 has no closing '-1' line (cut off?)"),
    ("Sample_UFF58b_bin", 200_000, "dataset 1 (58b) from line 2: 199428 of its 317168 data bytes (cut off?)"),
    ("uff55_translation_rotation", 3_000, "the file ends inside a line of blanks (cut off?)"),
    ("testlab_geometry_151_164_18_15_82", 6_000, "dataset 3 (type 18) from line 18 has no closing '-1' line (cut off?)"),
])
def test_a_file_cut_short_names_what_is_missing(samples, empty, tmp_path, capsys, stem, cut, words):
    cut_file = tmp_path / f"{stem}-cut.uff"
    cut_file.write_bytes((samples / f"{stem}.uff").read_bytes()[:cut])
    before = empty.read_bytes()
    code, _, err = _import(empty, cut_file, "x", capsys)
    assert code == 1 and "\n" not in err.strip() and words in err, err
    assert empty.read_bytes() == before


@pytest.fixture
def thesis_with_frf(tmp_path):
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--name", "e1", "--samples", "2048"]) == 0
    assert main(["frf", str(p), "--experiment", "e1"]) == 0
    return p


def test_export_types_units_and_one_node_per_location(thesis_with_frf, tmp_path):
    out = tmp_path / "e1.uff"
    assert main(["export-uff", str(thesis_with_frf), "e1", "-o", str(out)]) == 0
    sets = pyuff.UFF(str(out)).read_sets()  # pyuff alone
    units = [s for s in sets if s["type"] == 164]
    assert len(units) == 1 and units[0]["units_code"] == 1 and units[0]["length"] == 1.0
    f58 = {s["id1"].strip(): s for s in sets if s["type"] == 58}
    assert f58["force"]["func_type"] == 1 and f58["force"]["ordinate_spec_data_type"] == 13
    assert f58["xC"]["func_type"] == 1 and f58["xC"]["ordinate_spec_data_type"] == 12
    assert f58["H xC"]["func_type"] == 4
    assert (f58["H xC"]["ordinate_spec_data_type"], f58["H xC"]["orddenom_spec_data_type"]) == (12, 13)
    # the triaxial corner C: xC, yC, zC on one node, three directions
    nodes = {(f58[n]["rsp_node"], abs(f58[n]["rsp_dir"])) for n in ("xC", "yC", "zC")}
    assert len({n for n, _ in nodes}) == 1 and {d for _, d in nodes} == {1, 2, 3}
    geo = next(s for s in sets if s["type"] == 15)
    xyz = np.column_stack([geo["x"], geo["y"], geo["z"]])
    assert len(np.unique(np.round(xyz, 9), axis=0)) == len(xyz)  # no two nodes at one place


def test_export_through_pyuff_imports_back_identically(thesis_with_frf, tmp_path):
    """Our export, read by pyuff and written again by pyuff, imports to the same record, FRFs and
    hammer point."""
    from odsuite.analysis.modal_project import physical

    ours = tmp_path / "e1.uff"
    assert main(["export-uff", str(thesis_with_frf), "e1", "-o", str(ours)]) == 0
    theirs = tmp_path / "e1-pyuff.uff"
    pyuff.UFF(str(theirs)).write_sets(pyuff.UFF(str(ours)).read_sets(), mode="add")
    q = tmp_path / "q.h5"
    assert main(["new", str(q), "--rig", "none"]) == 0
    assert main(["import", str(q), str(theirs), "--name", "back"]) == 0
    with open_project(thesis_with_frf) as a, open_project(q) as b:
        e, back = a.experiment("e1"), b.experiment("back")
        assert back.channel_names == e.channel_names
        np.testing.assert_array_equal(physical(back), physical(e))
        assert back.excitation.force_channel == e.excitation.force_channel
        np.testing.assert_allclose(back.excitation.point, e.excitation.point, atol=1e-6)  # 15 writes E13.5
        np.testing.assert_allclose(back.excitation.direction, e.excitation.direction, atol=1e-12)
        fa, fb = a.read_derived("e1", "frf"), b.read_derived("back", "frf")
        np.testing.assert_array_equal(fb["H_real"], fa["H_real"])
        np.testing.assert_array_equal(fb["H_imag"], fa["H_imag"])
        np.testing.assert_allclose(fb["frequency"], fa["frequency"], rtol=1e-5)


def test_export_imports_back_onto_the_thesis_rig(thesis_with_frf, tmp_path):
    """rig-format.md: an export imports back onto the same rig. The thesis rig's spare channel (no
    sensor: UFF node 0, direction 0) was refused as matching no sensor, and its accelerometers, which
    its .CTR inverts, came back negated (a value in m/s^2 carries its sign already)."""
    from odsuite.analysis.prediction import prepare

    out = tmp_path / "e1.uff"
    assert main(["export-uff", str(thesis_with_frf), "e1", "-o", str(out)]) == 0
    q = tmp_path / "q.h5"
    assert main(["new", str(q)]) == 0
    assert main(["import", str(q), str(out), "--name", "e1"]) == 0
    with open_project(thesis_with_frf) as a, open_project(q) as b:
        (pa,), (pb,) = prepare(a, ["e1"]), prepare(b, ["e1"])
        assert [s.name for s in pb.sensors] == [s.name for s in pa.sensors]
        np.testing.assert_allclose(pb.measured, pa.measured, rtol=1e-6, atol=1e-6 * np.abs(pa.measured).max())
        np.testing.assert_allclose(pb.force, pa.force, rtol=1e-6, atol=1e-6 * np.abs(pa.force).max())
