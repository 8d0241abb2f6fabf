"""LabVIEW .lvm reader on real files (LADISK beam impact, lvm_read's test data) and malformed input."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError
from odsuite_plugins.importers.lvm import read_lvm


def test_ladisk_beam_impact_quick_facts(real_data):
    # README "Quick facts": force peak 195.6 N at sample 36, acceleration peak 35.46 g
    d = read_lvm(real_data / "ladisk_beam_impact" / "acceleration.lvm")
    assert d.channel_names == ["Acceleration (Trigger)", "Force (Trigger)"]
    assert d.units == ["g", "Newtons"]
    assert d.sampling_rate == 50000.0
    assert d.data.shape == (50030, 2)
    force = d.channel("Force (Trigger)")
    assert int(np.argmax(force)) == 36
    assert force.max() == pytest.approx(195.6, abs=0.05)
    assert np.abs(d.channel("Acceleration (Trigger)")).max() == pytest.approx(35.46, abs=0.005)
    cam = read_lvm(real_data / "ladisk_beam_impact" / "camera.lvm")
    assert int(np.argmax(cam.data[:, 1])) == 35
    assert cam.data[:, 1].max() == pytest.approx(422.4, abs=0.05)
    assert np.abs(cam.data[:, 0]).max() == pytest.approx(54.79, abs=0.005)


def test_lvm_read_peer_expectations(real_data):
    base = real_data / "lvm_read_impacts"
    short = read_lvm(base / "short.lvm")
    assert short.data[0, 0] == 0.914018  # decimal comma
    assert short.delta_x[0] == pytest.approx(3.90625e-5) and short.sampling_rate == 25600.0
    assert short.units == ["Newtons", "m/s^2"] and short.time is None

    multi = read_lvm(base / "multi_time_column.lvm")
    row0 = [multi.time[0, 0], multi.data[0, 0], multi.time[0, 1], multi.data[0, 1]]
    assert row0 == [0.0, -0.035229, 0.0, 0.532608]
    assert multi.time[1, 1] == pytest.approx(1.953125e-5)
    assert multi.n_samples == 3 and multi.declared_samples == [51200, 51200]  # truncated file

    nodec = read_lvm(base / "no_decimal_separator.lvm")
    assert nodec.data[0, 0] == -0.008807
    assert nodec.channel_names == ["ax", "ay", "az"]
    assert nodec.data[3, 2] == -0.009433
    assert nodec.sampling_rate == 4000.0


def test_long_record_two_triggered_records(real_data):
    d = read_lvm(real_data / "lvm_read_impacts" / "long_single_header_multi_ch.lvm")
    assert d.channel_names == ["F", "m_1", "m_2"]
    assert d.declared_samples[0] == 8192 and d.n_samples == 16384
    # Delta_X printed as 0.000977 is 1/1024 s
    assert d.sampling_rate == 1024.0
    recs = d.records()
    assert len(recs) == 2
    for rec in recs:
        hit = int(np.argmax(np.abs(rec[:, 0])))
        assert 83 <= hit <= 86
        assert rec[hit, 0] == pytest.approx(-18, abs=3)


def _write(path, text):
    path.write_text(text.replace("|", "\t"), encoding="latin-1")
    return path


HEADER = (
    "LabVIEW Measurement|\nWriter_Version|2\nSeparator|Tab\nDecimal_Separator|,\nX_Columns|One\n"
    "***End_of_Header***|\n|\n"
)


def _segment(values, dt="1,0E-3"):
    seg = (
        f"Channels|2||\nSamples|{len(values)}|{len(values)}|\nY_Unit_Label|N|m/s^2|\n"
        f"X0|0,0|0,0|\nDelta_X|{dt}|{dt}|\n***End_of_Header***|||\nX_Value|F|a|Comment\n"
    )
    return seg + "".join(f"{t},0|{a}|{b}\n" for t, (a, b) in enumerate(values))


def test_segments_and_shared_time_column(tmp_path):
    f = _write(
        tmp_path / "two.lvm",
        HEADER + _segment([("1,5", "2"), ("3", "-4,25")]) + "\n" + _segment([("5", "6")]),
    )
    d = read_lvm(f)
    assert d.segment_starts == [0, 2]
    np.testing.assert_array_equal(d.data, [[1.5, 2], [3, -4.25], [5, 6]])
    np.testing.assert_array_equal(d.time[:, 0], [0, 1, 0])
    assert d.channel_names == ["F", "a"] and d.sampling_rate == 1000.0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("Some other file\n", "not an .lvm file"),
        ("LabVIEW Measurement|\nSeparator|Tab\n", "no ***End_of_Header***"),
        (HEADER.replace("Tab", "Pipe"), "Separator has unknown value 'Pipe'"),
        (HEADER + _segment([("1", "x2")]), "line 15, column 3: 'x2' is not a number"),
        (HEADER + _segment([("1", "2")], dt="0"), "Delta_X of channel 0 is '0'"),
        # a header field that is no number is named by its own line (it was "line 0")
        (HEADER + _segment([("1", "2")], dt="1,0E-3x"), "bad.lvm: line 12, Delta_X of channel 0: '1,0E-3x' is not a number"),
        (HEADER + _segment([("1", "2")]).replace("X0|0,0|0,0|", "X0|0,0|t0|"), "line 11, X0 of channel 1: 't0' is not a number"),
        (HEADER + _segment([("1", "2"), ("3", "4")]) + "\n" + _segment([("5", "6")], dt="?"),
         "line 22, Delta_X of channel 0: '?' is not a number"),
        (HEADER, "no channel header"),
    ],
)
def test_malformed_files_give_one_line_errors(tmp_path, text, message):
    f = _write(tmp_path / "bad.lvm", text)
    with pytest.raises(ConfigError) as info:
        read_lvm(f)
    assert message in str(info.value)
    assert str(f) in str(info.value) and "\n" not in str(info.value)


def test_unknown_channel_name(real_data):
    d = read_lvm(real_data / "lvm_read_impacts" / "short.lvm")
    with pytest.raises(ConfigError, match="no channel 'Force'.*Excitation"):
        d.channel("Force")


def test_cli_import_lvm_frf_modes(real_data, tmp_path, capsys):
    import json

    from odsuite.cli import main

    proj = tmp_path / "beam.h5"
    lvm = real_data / "ladisk_beam_impact" / "acceleration.lvm"
    assert main(["new", str(proj), "--rig", "none"]) == 0
    assert main(["import-lvm", str(proj), str(lvm), "--name", "beam"]) == 0
    capsys.readouterr()
    assert main(["modes", str(proj), "--experiment", "beam", "--fmin", "1", "--fmax", "4000", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    f = [m["frequency_hz"] for m in doc["modes"]]
    np.testing.assert_allclose(f, [695.0, 1897.6, 2777.3, 3671.2], rtol=0.005)
    multi = real_data / "lvm_read_impacts" / "long_single_header_multi_ch.lvm"
    # no column in N or named like a force: an operating record (responses only), said on stderr
    assert main(["import-lvm", str(proj), str(multi), "--name", "lab"]) == 0
    assert "stored as an operating record" in capsys.readouterr().err
    assert main(["frf", str(proj), "--experiment", "lab"]) == 1
    assert "experiment 'lab' has no force channel" in capsys.readouterr().err


def test_units_replace_a_mislabelled_lvm_column(real_data, tmp_path, capsys):
    # the hammer column F of lvm_read's impact test is labelled g (its README: a labelling error,
    # the values are newtons): refused as a force, and .lvm took no --units to say otherwise
    import json

    from odsuite.cli import main
    from odsuite.store.project import open_project

    lvm = real_data / "lvm_read_impacts" / "long_single_header_multi_ch.lvm"
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    assert main(["import", str(p), str(lvm), "--name", "bad", "--force-channel", "F"]) == 1
    assert "is in 'g', a response, not a force" in capsys.readouterr().err
    assert main(["import", str(p), str(lvm), "--name", "imp", "--force-channel", "F", "--units", "N,m/s^2,m/s^2"]) == 0
    assert "--units replaces the file's labels: F g -> N" in capsys.readouterr().err
    with open_project(p) as project:
        e = project.experiment("imp")
        assert e.excitation is not None and e.channel_names[e.excitation.force_channel] == "F"
    assert main(["modes", str(p), "--experiment", "imp", "--json"]) == 0
    f = np.array([m["frequency_hz"] for m in json.loads(capsys.readouterr().out)["modes"]])
    # the README's own H1 peaks: 19.8 and 21.1 Hz (a close pair), 160.7 Hz, 340 Hz
    for peak in (19.8, 21.1, 160.7, 340.0):
        assert np.min(np.abs(f / peak - 1)) < 0.01, (peak, f)


def test_an_operating_record_names_its_columns_and_units(real_data, tmp_path, capsys):
    # lvm_read's impact test labels its hammer column F in g: stored as an operating record, the
    # warning said only "no column in N or named like a force", and the label that caused it was
    # nowhere on the screen
    from odsuite.cli import main

    lvm = real_data / "lvm_read_impacts" / "long_single_header_multi_ch.lvm"
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    capsys.readouterr()
    assert main(["import", str(p), str(lvm), "--name", "ambient"]) == 0
    assert (f"warning: {lvm}: no force channel among its columns (F [g], m_1 [m/s^2], m_2 [m/s^2]; none in N or "
            "named like a force): stored as an operating record") in capsys.readouterr().err
