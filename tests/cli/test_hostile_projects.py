"""Project files edited by hand, read back: one line naming the file and field, never a traceback."""

from __future__ import annotations

import json

import h5py
import pytest

from odsuite.cli import main


@pytest.mark.parametrize("command", [["model"], ["compare"], ["history"]])
@pytest.mark.parametrize("big", ["1" + "0" * 400, "NaN"])
def test_a_stored_parameter_past_a_floats_range_is_refused_in_one_line(tmp_path, capsys, command, big):
    # JSON's integers have no bound: 10**400 passed the stored-value check as a number, and turning
    # it into a float stopped `model`, `compare`, `report` and `diagnose` (OverflowError). A NaN
    # passed it too, and the model's bounds check said "nan 1 is outside [0.25, 4.0]" without the file
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    with h5py.File(p, "r+") as f:
        rev = f["models/revisions/0"]
        rev.attrs["effects"] = '[{"effect": "stiffness", "values": {"scale_z": %s}}]' % big
        rev.attrs["parameters"] = '{"stiffness.scale_z": %s}' % big
    capsys.readouterr()
    assert main([*command, str(p), "--json"]) != 0
    captured = capsys.readouterr()
    assert len(captured.err.strip().splitlines()) == 1 and "Traceback" not in captured.err
    assert "model revision 0" in json.loads(captured.out)["error"]


@pytest.mark.parametrize("edit", ["filter order", "force point"])
def test_a_stored_record_beyond_the_writers_limits_is_refused_in_one_line(tmp_path, capsys, edit):
    # a channel's filter order of 10^12 (its design asked for terabytes) and a force point 1e300 m
    # away (overflow warnings through every analysis) were read back as stored
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--daq", "sim", "--name", "T2", "--scenario", "T2", "--samples", "2048"]) == 0
    with h5py.File(p, "r+") as f:
        g = f["experiments/T2"]
        if edit == "filter order":
            table = g["systeminfo/channels"][()]
            table["filter_order"][2] = 10**12
            g["systeminfo/channels"][...] = table
        else:
            g.attrs["force_point"] = [1e300, 0.0, 0.0]
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) != 0
    captured = capsys.readouterr()
    assert len(captured.err.strip().splitlines()) == 1 and "Traceback" not in captured.err, captured.err
    assert ("filter_order" if edit == "filter order" else "force_point") in json.loads(captured.out)["error"]


@pytest.mark.parametrize("where, field, value", [("", "force_point_units", "mm"), ("", "sampling_rate_units", "kHz"),
                                                  ("raw", "units", "mV")])
def test_a_stored_unit_other_than_odsuites_is_refused_in_one_line(tmp_path, capsys, where, field, value):
    # the unit attributes were never read: a force point stored in mm was taken as metres, a rate
    # in kHz as Hz, raw millivolts as volts
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--daq", "sim", "--name", "T2", "--scenario", "T2", "--samples", "2048"]) == 0
    with h5py.File(p, "r+") as f:
        f["experiments/T2" + (f"/{where}" if where else "")].attrs[field] = value
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) != 0
    captured = capsys.readouterr()
    assert len(captured.err.strip().splitlines()) == 1 and "Traceback" not in captured.err, captured.err
    error = json.loads(captured.out)["error"]
    assert f"experiment 'T2' field '{'raw.' if where else ''}{field}'" in error and repr(value) in error, error


@pytest.mark.parametrize("field, value", [("iepe_corner_hz", "1e300"), ("sensor_resonance_hz", "1e-300")])
def test_a_rig_frequency_out_of_any_lab_range_is_refused_by_new(tmp_path, capsys, field, value):
    # accepted as a positive number, a corner of 1e300 Hz stopped `acquire` in the sensor's
    # discretisation (LinAlgError)
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml").read_text()
    assert "\niepe_corner_hz = " in text  # in the [acquisition] table
    rig = tmp_path / "rig.toml"
    given = f"{field} = {value}" if field == "iepe_corner_hz" else f"iepe_corner_hz = 0.5\n{field} = {value}"
    rig.write_text("\n".join(given if line.startswith("iepe_corner_hz = ") else line for line in text.splitlines()) + "\n")
    capsys.readouterr()
    assert main(["new", str(tmp_path / "p.h5"), "--rig", str(rig)]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"field {field!r}: expected 0.0001 to 1e+08 Hz" in err, err
    assert not (tmp_path / "p.h5").exists()


def test_a_negative_stored_error_is_refused_in_one_line(tmp_path, capsys):
    # it ran into the history figure's log axis (a matplotlib warning beside the figure)
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    with h5py.File(p, "r+") as f:
        f["models/revisions/0"].attrs["metrics"] = '{"error": -0.5}'
    capsys.readouterr()
    assert main(["history", str(p), "--figure", str(tmp_path / "h.png")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "metrics.error" in err and ">= 0" in err, err
    assert not (tmp_path / "h.png").exists()


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_an_npy_of_long_doubles_past_a_floats_range_gets_one_line(tmp_path, capsys):
    import numpy as np

    np.save(tmp_path / "x.npy", np.full((100, 2), np.longdouble("1e400")))
    (tmp_path / "x.toml").write_text('units = "m/s^2"\n')
    assert main(["new", str(tmp_path / "p.h5"), "--rig", "none"]) == 0
    capsys.readouterr()
    assert main(["import", str(tmp_path / "p.h5"), str(tmp_path / "x.npy"), "--rate", "1000", "--name", "x"]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "x.npy" in err, err


def test_an_ods_at_a_frequency_a_short_record_cannot_resolve_gets_one_line(tmp_path, capsys):
    # four samples: the line nearest 500 Hz is 0 Hz, and the displacement there divided by zero
    # (two RuntimeWarnings before the error line)
    p = tmp_path / "o.h5"
    (tmp_path / "o.csv").write_text("time,xC [m/s^2],zC [m/s^2]\n0,0.0001,-3.9\n0.0005,0.001,0.001\n"
                                    "0.001,0.0003,-0.0009\n0.0015,-0.0003,0.002\n")
    assert main(["new", str(p)]) == 0
    assert main(["import", str(p), str(tmp_path / "o.csv"), "--name", "x"]) == 0
    capsys.readouterr()
    assert main(["ods", str(p), "x", "--reference", "xC", "--at", "500"]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "the line nearest 500 Hz is 0 Hz" in err, err


def test_a_project_written_from_a_rig_at_its_sensitivity_limit_reads_back(tmp_path, capsys):
    # the read-back check must take what the writers store: a rig file allows up to 1e9 V per SI
    # unit, and a check at the .CTR reader's 1e3 made this project unreadable after its import
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml").read_text()
    assert "\nsensitivity = 0.0102 " in text
    rig = tmp_path / "rig.toml"
    rig.write_text(text.replace("\nsensitivity = 0.0102 ", "\nsensitivity = 2000.0 "))
    (tmp_path / "r.csv").write_text("hammer [N],m1_x [m/s^2]\n" + "".join(
        f"{10.0 if 100 <= k < 103 else 0.0},{0.01 * (k % 7)}\n" for k in range(1024)))
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", str(rig)]) == 0
    assert main(["import", str(p), str(tmp_path / "r.csv"), "--name", "x", "--rate", "10240",
                 "--force-point=100,50,250", "--force-dir=-z"]) == 0
    capsys.readouterr()
    assert main(["info", str(p), "--json"]) == 0, capsys.readouterr().err


def test_memory_running_out_past_the_checks_is_one_line(tmp_path, capsys, monkeypatch):
    # a 2 GiB sparse CSV passed the free-memory check (8 bytes per byte of text) and, with another
    # program taking memory meanwhile, its parse ran out: a MemoryError traceback
    import odsuite.analysis.comparison as comparison

    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--daq", "sim", "--name", "T2", "--scenario", "T2", "--samples", "2048"]) == 0

    def no_memory(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(comparison, "compare", no_memory)
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) == 1
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and err.startswith("error: out of memory") and "Traceback" not in err, err
    assert json.loads(out)["error"].startswith("out of memory")
