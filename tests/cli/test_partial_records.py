"""Records that hold some of a rig's channels, at rates a rig file does not expect: the two-body
machine's rig with a CSV of one triaxial's three channels. `diagnose` stopped on a sensor
parameter of a sensor no record holds (a KeyError in the sweep of sensor starts) and, at 10 MHz, on
a mass fit that ended where no physical body has its inertia (its physical quantities); `compare`
on a band without two FRF lines (a reduction of an empty array) and printed a warning for a band
without energy."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from odsuite.cli import main

RIG = Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml"


def two_body_csv_project(tmp_path: Path, samples, rate: float) -> Path:
    """A project on the two-body machine holding one CSV record ``x`` at ``rate``: per sample
    (force N, acceleration m/s^2) the hammer and m1's x, y and z at 1, 0.5 and 0.2 of it."""
    rig = tmp_path / "rig.toml"
    shutil.copy(RIG, rig)
    lines = ["hammer [N],m1_x [m/s^2],m1_y [m/s^2],m1_z [m/s^2]"]
    lines += [f"{f},{a},{0.5 * a},{0.2 * a}" for f, a in samples]
    (tmp_path / "r.csv").write_text("\n".join(lines) + "\n")
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", str(rig)]) == 0
    assert main(["import", str(p), str(tmp_path / "r.csv"), "--name", "x", "--rate", f"{rate:g}",
                 "--force-point=100,50,250", "--force-dir=-z"]) == 0
    return p


def _project(tmp_path: Path, rate: float) -> Path:
    samples = [(10.0 if 100 <= k < 103 else 0.0,
                math.exp(-(k - 100) / 300) * math.sin((k - 100) / 5) if k >= 100 else 0.0) for k in range(2048)]
    return two_body_csv_project(tmp_path, samples, rate)


@pytest.mark.parametrize("rate", [10240.0, 1e7])
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_record_of_some_channels_is_compared_and_diagnosed(tmp_path, capsys, rate):
    p = _project(tmp_path, rate)
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["error"] > 0.5  # a made-up decay the model does not hold
    if rate > 1e6:
        assert any("no record has two FRF lines" in n for n in doc["modes"]["notes"]), doc["modes"]["notes"]
    assert main(["diagnose", str(p), "--json"]) == 0
    diagnosis = json.loads(capsys.readouterr().out)
    assert diagnosis["verdict"] and diagnosis["candidates"]


def test_frfs_of_a_record_too_short_for_a_band_are_stored_and_say_why(tmp_path, capsys):
    # the FRFs were stored, then `frf` ended with an error (exit 1) on the band it could not give
    p = tmp_path / "f.h5"
    (tmp_path / "r.csv").write_text("time,hammer [N],a [m/s^2]\n0,0.0001,-3.9\n0.0005,0.001,0.001\n"
                                    "0.001,0.0003,-0.0009\n0.0015,-0.0003,0.002\n")
    assert main(["new", str(p), "--rig", "none"]) == 0
    assert main(["import", str(p), str(tmp_path / "r.csv"), "--name", "x"]) == 0
    capsys.readouterr()
    assert main(["frf", str(p), "--experiment", "x", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["usable_band_hz"] is None and "2 lines above 0 Hz" in doc["usable_band_note"]
    assert main(["info", str(p), "--json"]) == 0
    assert "frf" in json.loads(capsys.readouterr().out)["experiments"]["x"]["derived"]


@pytest.mark.parametrize("columns", [["hammer [N]", "a [m/s^2]"], ["hammer [N]"]])
def test_output_only_modes_of_a_record_without_motion_say_so(tmp_path, capsys, columns):
    # responses all zero, or a force channel alone: SSI-cov's eigenvalues of NaN (a LinAlgError)
    p = tmp_path / "z.h5"
    rows = [",".join(columns)] + [",".join([f"{10.0 if 256 <= k < 259 else 0.0}", "0.0"][:len(columns)])
                                  for k in range(2048)]
    (tmp_path / "z.csv").write_text("\n".join(rows) + "\n")
    assert main(["new", str(p), "--rig", "none"]) == 0
    assert main(["import", str(p), str(tmp_path / "z.csv"), "--name", "x", "--rate", "2000"]) == 0
    capsys.readouterr()
    assert main(["modes", str(p), "--experiment", "x", "--output-only", "--json"]) != 0
    captured = capsys.readouterr()
    assert "no motion to identify modes from" in json.loads(captured.out)["error"]
    assert len(captured.err.strip().splitlines()) == 1


UNRECORDED = "b1_x, b1_y, b1_z, b2_x, b2_y, b2_z, b3_x, b3_y, b3_z, m2_x, m2_y, m2_z, m3_x, m3_y, m3_z"


def test_frfs_and_modes_hold_the_recorded_channels_and_name_the_rigs_others(tmp_path, capsys):
    # the rig's 15 channels the file has no column for, stored as zeros, were 15 of the 18 FRFs
    # listed and mode-shape entries
    p = _project(tmp_path, 10240.0)
    capsys.readouterr()
    note = (f"experiment 'x': channels {UNRECORDED} were not recorded (the file imported has no column for them; "
            "stored as zeros): no FRF is estimated for them")
    assert main(["frf", str(p), "--experiment", "x", "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["channels"] == ["m1_x", "m1_y", "m1_z"]
    assert captured.err.count(note) == 1, captured.err
    assert main(["modes", str(p), "--experiment", "x", "--json"]) == 0
    captured = capsys.readouterr()
    shapes = [m["shape"] for m in json.loads(captured.out)["modes"]]
    assert shapes and all(list(s) == ["m1_x", "m1_y", "m1_z"] for s in shapes)
    # the made-up decay's amplitudes, 1 : 0.5 : 0.2
    assert [abs(complex(*v)) for v in shapes[0].values()] == pytest.approx([1.0, 0.5, 0.2], rel=1e-6)
    assert captured.err.count(note) == 1, captured.err


def _import_silent(p: Path, tmp_path: Path, name: str):
    """``_project``'s blow with zeros for every response."""
    lines = ["hammer [N],m1_x [m/s^2],m1_y [m/s^2],m1_z [m/s^2]"]
    lines += [f"{10.0 if 100 <= k < 103 else 0.0},0.0,0.0,0.0" for k in range(2048)]
    (tmp_path / f"{name}.csv").write_text("\n".join(lines) + "\n")
    assert main(["import", str(p), str(tmp_path / f"{name}.csv"), "--name", name, "--rate", "10240",
                 "--force-point=100,50,250", "--force-dir=-z"]) == 0


def _silent_line(p: Path, name: str) -> str:
    return (f"{p}: experiment {name!r}: its responses hold no signal: m1_x, m1_y, m1_z (channels 10, 11, 12) read one "
            "value in every sample, so the model has nothing to be compared with")


def test_a_record_of_zero_responses_is_said_so_in_one_line(tmp_path, capsys):
    # compare printed 'error nan (noise floor nan, infx)' and process 'the error was not stored'
    rig = tmp_path / "rig.toml"
    shutil.copy(RIG, rig)
    p = tmp_path / "z.h5"
    assert main(["new", str(p), "--rig", str(rig)]) == 0
    _import_silent(p, tmp_path, "z")
    capsys.readouterr()
    assert main(["compare", str(p)]) == 1
    captured = capsys.readouterr()
    assert captured.err.strip() == f"error: {_silent_line(p, 'z')}" and captured.out == ""
    assert main(["compare", str(p), "--json"]) == 1
    assert json.loads(capsys.readouterr().out) == {"error": _silent_line(p, "z")}
    assert main(["process", str(p), "--json"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert doc["error"] is None and doc["error_notes"] == [_silent_line(p, "z")]
    assert f"note: {_silent_line(p, 'z')}" in captured.err.splitlines() and "not stored" not in captured.err
    assert main(["history", str(p)]) == 0
    assert "nan" not in capsys.readouterr().out
    assert main(["diagnose", str(p)]) == 1  # it ended on a fitted parameter of NaN
    assert capsys.readouterr().err.strip() == f"error: {_silent_line(p, 'z')}"


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_record_of_zero_responses_is_left_out_of_the_others_comparison(tmp_path, capsys):
    p = _project(tmp_path, 10240.0)
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) == 0
    alone = json.loads(capsys.readouterr().out)
    _import_silent(p, tmp_path, "z")
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert list(doc["experiments"]) == ["x"] and doc["error"] == pytest.approx(alone["error"], rel=1e-12)
    assert _silent_line(p, "z") in doc["notes"]
    assert main(["compare", str(p)]) == 0
    out = capsys.readouterr().out
    assert not re.search(r"\b(nan|inf)(x|\b)", out) and "hold no signal" in out


def _still_line(p: Path) -> str:
    return (f"{p}: experiment 'x': channel 12 (m1_z) never moves (one value in every sample): it has no error of its "
            "own (nothing measured to divide by), and the model's motion there counts in the record's error")


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_response_that_never_moves_beside_live_ones_is_named_once_and_has_no_error_of_its_own(tmp_path, capsys):
    # compare printed nan as the channel's error, and its JSON (the API's as_dict) held NaN
    import h5py

    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project

    p = _project(tmp_path, 10240.0)
    with h5py.File(p, "r+") as f:  # m1_z's accelerometer reads 0 throughout, m1_x and m1_y ring
        f["experiments/x/raw"][:, 12] = 0.0
    assert main(["process", str(p)]) == 0
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["experiments"]["x"]["channels"]["m1_z"] is None and doc["channels"]["m1_z"] is None
    assert doc["channels"]["m1_x"] == pytest.approx(doc["experiments"]["x"]["channels"]["m1_x"], rel=1e-12)
    assert doc["channels"]["m1_x"] > 0.5  # a made-up decay the model does not hold
    assert doc["notes"].count(_still_line(p)) == 1
    assert [row[2] for row in doc["bands"]["energy_share"]] == [0.0] * len(doc["bands"]["labels"])
    assert "m1_z" not in [w["name"] for w in doc["worst"]]
    with open_project(p) as project:
        json.dumps(compare(project).as_dict(), allow_nan=False)  # no NaN for a script to trip on
        # the pooled band errors count the still channel's residual, as the overall error does (they
        # left it out): each band's residual over its measured energy, from the records' spectra
        from odsuite.analysis.comparison import BAND_EDGES_HZ
        from odsuite.analysis.prediction import prepare

        cmp = compare(project)
        (e,), (pred,) = prepare(project, None, []), cmp.predictions
    f = np.fft.rfftfreq(e.n_samples, 1.0 / e.fs)
    measured, residual = np.abs(np.fft.rfft(e.measured, axis=0)) ** 2, np.abs(np.fft.rfft(e.measured - pred, axis=0)) ** 2
    still = [s.name for s in e.sensors].index("m1_z")
    assert not e.measured[:, still].any() and residual[:, still].sum() > 1e-3 * residual.sum()  # the model moves there
    edges = [x for x in BAND_EDGES_HZ if x < e.fs / 2] + [e.fs / 2]
    for w in [w for w in cmp.worst if w["kind"] == "band"]:
        lo, hi = (float(x) for x in w["name"].removesuffix(" Hz").split("-"))
        sel = (f >= lo) & ((f < hi) if hi < edges[-1] else True)
        assert w["error"] == pytest.approx(np.sqrt(residual[sel].sum() / measured[sel].sum()), rel=1e-9)
        assert w["residual_share"] == pytest.approx(residual[sel].sum() / residual.sum(), rel=1e-9)
    assert main(["compare", str(p)]) == 0
    out = capsys.readouterr().out
    assert not re.search(r"\bnan\b", out) and " ".join(out.split()).count(_still_line(p)) == 1
