"""Red team, round six: geometry tables and stored geometries edited out of shape, a rig's
systeminfo, filter and [beam] table, a pipe where a geometry file belongs, an import that declares
values it never stored, output-only options beyond the record, a time column in milliseconds and
a figure renderer the render command could not call. Each is one line naming the file, field and
value (exit 1), or now works; nothing half-made is left behind."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from odsuite.cli import main

ROOT = Path(__file__).resolve().parents[2]
BEAM_RIG = ROOT / "projects" / "rigs" / "ladisk-beam.toml"
TWO_BODY_RIG = ROOT / "projects" / "rigs" / "two-body-machine.toml"
GOOD_GEOMETRY = ('nodes = [[1, 0, 0, 0], [2, 1, 0, 0], [3, 0, 1, 0]]\nlines = [[1, 2], [2, 3]]\n'
                 'sensors = [["c1", 1, "+x"], ["c2", 2, "+y"], ["c3", 3, "+z"]]\n')


def _one_line(capsys, argv: list[str], *words: str) -> str:
    assert main(argv) == 1
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and err.startswith("error: ") and "Traceback" not in err, err
    for w in words:
        assert w in err, (w, err)
    return err


def _operating_project(tmp_path: Path, geometry: str = GOOD_GEOMETRY) -> Path:
    """A project without a rig holding a 3-channel operating record and a geometry of its channels."""
    np.save(tmp_path / "rec.npy", np.random.default_rng(1).standard_normal((4000, 3)))
    (tmp_path / "rec.toml").write_text('sampling_rate = 1000.0\nchannels = ["c1", "c2", "c3"]\nunits = "m/s^2"\n')
    (tmp_path / "geo.toml").write_text(geometry)
    project = tmp_path / "o.h5"
    assert main(["new", str(project), "--rig", "none"]) == 0
    assert main(["import", str(project), str(tmp_path / "rec.npy"), "--name", "amb"]) == 0
    assert main(["import", str(project), str(tmp_path / "geo.toml"), "--name", "geo"]) == 0
    return project


@pytest.mark.parametrize("table, words", [
    ("sensors = [5]", ["g.toml", "sensors: 5 is not [channel, node, direction]"]),
    ("lines = [5]", ["g.toml", "line 5: a line joins 2 nodes"]),
    ("faces = [5]", ["g.toml", "face 5"]),
    ("[[rigid]]", ["g.toml", "rigid: {} is not a table with name and a list of nodes"]),
    ("bogus = 1", ["g.toml", "unknown field 'bogus'"]),
])
def test_a_geometry_table_out_of_shape_is_one_line(tmp_path, capsys, table, words):
    assert main(["new", str(tmp_path / "p.h5"), "--rig", "none"]) == 0
    (tmp_path / "g.toml").write_text(f"nodes = [[1, 0, 0, 0], [2, 1, 0, 0]]\n{table}\n")
    capsys.readouterr()
    _one_line(capsys, ["import", str(tmp_path / "p.h5"), str(tmp_path / "g.toml"), "--name", "g"], *words)


@pytest.mark.parametrize("nodes, words", [
    ("5", ["nodes: expected a list, got 5"]),
    ("[[1e20, 0, 0, 0], [2, 1, 0, 0]]", ["node id: 1e+20 is not a node number (a whole number below 2^31)"]),
    ("[[1, 0, 0, 1e200], [2, 1, 0, 0]]", ["node 1: coordinates [0.0, 0.0, 1e+200] m lie beyond 1000 m"]),
])
def test_geometry_nodes_out_of_range_are_one_line(tmp_path, capsys, nodes, words):
    assert main(["new", str(tmp_path / "p.h5"), "--rig", "none"]) == 0
    (tmp_path / "g.toml").write_text(f"nodes = {nodes}\n")
    capsys.readouterr()
    _one_line(capsys, ["import", str(tmp_path / "p.h5"), str(tmp_path / "g.toml"), "--name", "g"], "g.toml", *words)


def test_a_pipe_named_as_a_geometry_is_refused_not_read(tmp_path):
    # a FIFO blocked the reader for ever (and /dev/zero filled the memory): refused before reading
    assert main(["new", str(tmp_path / "p.h5"), "--rig", "none"]) == 0
    os.mkfifo(tmp_path / "g.toml")
    run = subprocess.run([sys.executable, "-m", "odsuite.cli", "import", str(tmp_path / "p.h5"), str(tmp_path / "g.toml"),
                          "--name", "g"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    assert run.stderr.strip().endswith("g.toml: not a regular file (a pipe or device), expected a geometry table file")


@pytest.mark.parametrize("edit, words", [
    (lambda g: g.attrs.__setitem__("faces", "[5]"), ["geometry 'geo': face: expected a list, got 5"]),
    (lambda g: g.attrs.__setitem__("fixed", '["a"]'), ["geometry 'geo': fixed: expected numbers, got ['a']"]),
    (lambda g: g.attrs.__setitem__("sensors", "5"), ["geometry 'geo': field 'sensors': expected a list, got 5"]),
    (lambda g: g.attrs.__setitem__("sensors", '[["c1", 5]]'),
     ["field 'sensors': expected [[channel, node, [dx, dy, dz]], ...], got ['c1', 5]"]),
    (lambda g: g.attrs.__setitem__("sensors", '[["c1", 1, [0, 0, 0]]]'), ["sensor 'c1': direction [0, 0, 0]"]),
    (lambda g: (g.__delitem__("lines"), g.create_dataset("lines", data=np.zeros((1, 3)))),
     ["lines: expected pairs of node ids, got shape (1, 3)"]),
    (lambda g: g.__delitem__("node_ids"), ["field 'node_ids' is missing"]),
    (lambda g: (g.__delitem__("xyz"), g.create_dataset("xyz", data=np.array([[b"a"] * 3] * 3))),
     ["node coordinates: expected numbers"]),
    # 10^9 rows declared, none stored: read as fill values it took 24 GB before the kernel ended it
    (lambda g: (g.__delitem__("xyz"), g.create_dataset("xyz", shape=(10**9, 3), dtype="f8", chunks=(4096, 3))),
     ["import 'geo' field 'xyz': shape (1000000000, 3) of 24000000000 bytes, of which 0 are stored"]),
])
def test_a_stored_geometry_edited_out_of_shape_is_one_line(tmp_path, capsys, edit, words):
    project = _operating_project(tmp_path)
    with h5py.File(project, "r+") as f:
        edit(f["imports/geo"])
    capsys.readouterr()
    _one_line(capsys, ["ods", str(project), "amb", "--reference", "c1", "--at", "5", "--movie",
                       str(tmp_path / "o.gif")], "o.h5", *words)
    assert not (tmp_path / "o.gif").exists()


def _rig_with(tmp_path: Path, source: Path, old: str, new: str) -> Path:
    text = source.read_text()
    assert old in text
    rig = tmp_path / "r.toml"
    rig.write_text(text.replace(old, new, 1))
    return rig


@pytest.mark.parametrize("source, old, new, words", [
    (TWO_BODY_RIG, "channel_count = 19", "channel_count = 19\nsysteminfo = 5", ["field 'systeminfo': expected a .CTR file name, got 5"]),
    (TWO_BODY_RIG, 'filter = { family = "butterworth", type = "highpass", order = 4, cutoff_hz = 4.0 }',
     'filter = { family = "elliptic", type = "highpass", order = 4, cutoff_hz = 20.0, ripple_db = 80.0, '
     'attenuation_db = 60.0 }', ["[processing].filter: ripple_db 80 must be below attenuation_db 60"]),
    (TWO_BODY_RIG, "iepe_corner_hz = 0.5", "iepe_corner_hz = 0.5\nbogus = 3", ["acquisition: unknown field 'bogus'"]),
    (TWO_BODY_RIG, "adc_range = [-5.0, 5.0]", "adc_range = [-1e300, 1e300]",
     ["acquisition field 'adc_range': expected volts within +-1000 V"]),
    (TWO_BODY_RIG, "adc_range = [-5.0, 5.0]", "adc_range = [-1e-300, 1e-300]",
     ["acquisition field 'adc_range': expected volts within +-1000 V, high at least 0.001 V above low, "
      "got [-1e-300, 1e-300]"]),
    (TWO_BODY_RIG, "adc_range = [-5.0, 5.0]", "adc_range = [2.0, 2.0005]",
     ["acquisition field 'adc_range': expected volts within +-1000 V, high at least 0.001 V above low, "
      "got [2.0, 2.0005]"]),
    (BEAM_RIG, "damping_ratio = 0.005", 'damping_ratio = [0.01, "a"]',
     ["[beam] field 'damping_ratio': expected ratios in [0, 1), got [0.01, 'a']"]),
    (BEAM_RIG, "first_mode_hz = 695.0", "bending_stiffness = 1e300",
     ["[beam] field 'bending_stiffness': expected at most 1e+15 N m^2"]),
    (BEAM_RIG, "elements = 40", 'elements = "forty"', ["[beam] field 'elements': expected an integer in 2..2000"]),
    # round 7: fields a later command refused, or that were silently merged or ignored
    (TWO_BODY_RIG, "adc_bits = 24", "adc_bits = 1", ["acquisition field 'adc_bits': expected 0 (not stated) or 2 to 32, got 1"]),
    (TWO_BODY_RIG, 'channels = [4, 5, 6]', 'channels = [4, 5, 6]\nuff_node = 3\n[[sensors]]\nname = "b2z"\nbody = "base"\n'
     'position = [0.0, 0.0, 0.05]\naxis = [0.0, 0.0, -1.0]\nchannel = 19\nuff_node = 3',
     ["sensors 'b2_z' and 'b2z' measure along one line at uff_node 3"]),
    (BEAM_RIG, 'name = "foam_right"', 'name = "foam_left"', ["[beam] supports[1] field 'name': a second support named 'foam_left'"]),
    (BEAM_RIG, "first_mode_hz = 695.0", "first_mode_hz = 695.0\nbending_stiffness = 100.0",
     ["[beam]: give 'first_mode_hz' or 'bending_stiffness', not both"]),
    (BEAM_RIG, "first_mode_hz = 695.0", "first_mode_hz = 1e300", ["[beam] field 'first_mode_hz': 1e+300 Hz needs a bending stiffness of inf N m^2"]),
    (BEAM_RIG, "first_mode_hz = 695.0", "first_mode_hz = 1e-300", ["[beam] field 'first_mode_hz': 1e-300 Hz needs a bending stiffness of 0 N m^2"]),
    (BEAM_RIG, "support_damping_ratio = 0.2", "support_damping_ratio = -1", ["[beam] field 'support_damping_ratio': expected a ratio in [0, 1), got -1"]),
    (BEAM_RIG, "hammer_offset_range = [-0.130, 0.130]", "hammer_offset_range = [nan, 0.1]",
     ["[beam] field 'hammer_offset_range': expected [lower, upper] in m, got [nan, 0.1]"]),
    (BEAM_RIG, "sensor_position_range = [0.0, 0.140]", "sensor_position_range = [0.2, 0.1]",
     ["[beam] field 'sensor_position_range': expected [lower, upper] in m, got [0.2, 0.1]"]),
])
def test_a_rig_refused_by_new_leaves_no_project(tmp_path, capsys, source, old, new, words):
    rig = _rig_with(tmp_path, source, old, new)
    _one_line(capsys, ["new", str(tmp_path / "p.h5"), "--rig", str(rig)], "r.toml", *words)
    assert not (tmp_path / "p.h5").exists()


def test_a_rig_whose_systeminfo_is_no_ctr_is_refused_by_new(tmp_path, capsys):
    # the .CTR named by the rig is read as the project is made: a text that is none is refused
    # there, not at every later recording
    (tmp_path / "not.CTR").write_text("root:x:0:0:root:/root:/bin/bash\n" * 25)
    rig = _rig_with(tmp_path, TWO_BODY_RIG, "channel_count = 19", 'channel_count = 19\nsysteminfo = "not.CTR"')
    _one_line(capsys, ["new", str(tmp_path / "p.h5"), "--rig", str(rig)], "not.CTR", "expected 34 rows")
    assert not (tmp_path / "p.h5").exists()


@pytest.mark.parametrize("option, words", [
    (["--decimate", "100000000"], ["--decimate 100000000: leaves 0 samples of the record's 4000"]),
    (["--block-rows", "5000"], ["--block-rows 5000: its lags (2 x 5000) need at least 20000 samples"]),
])
def test_output_only_options_beyond_the_record_are_one_line(tmp_path, capsys, option, words):
    # --decimate 10^8 took all the memory, --block-rows 5000 an SVD of 15000 rows for ever
    project = _operating_project(tmp_path)
    capsys.readouterr()
    _one_line(capsys, ["modes", str(project), "--experiment", "amb", "--output-only", *option], *words)


@pytest.mark.render
def test_a_geometry_of_nodes_alone_is_drawn(tmp_path, capsys):
    # no lines nor faces: the movie draws the nodes (it ended in a traceback in the line drawing)
    project = _operating_project(tmp_path, 'nodes = [[1, 0, 0, 0], [2, 1, 0, 0], [3, 0, 1, 0]]\n'
                                           'sensors = [["c1", 1, "+x"], ["c2", 2, "+y"], ["c3", 3, "+z"]]\n')
    capsys.readouterr()
    assert main(["ods", str(project), "amb", "--reference", "c1", "--at", "5", "--movie", str(tmp_path / "o.gif")]) == 0
    assert (tmp_path / "o.gif").stat().st_size > 1000


def test_render_draws_the_history_figure(tmp_path, capsys):
    # `render --figure history` handed the movie's options to the figure: a TypeError, and no JSON
    project = tmp_path / "p.h5"
    assert main(["new", str(project)]) == 0
    assert main(["acquire", str(project), "--daq", "sim", "--name", "s1", "--scenario", "T2"]) == 0
    capsys.readouterr()
    assert main(["render", str(project), "s1", "-o", str(tmp_path / "h.png"), "--figure", "history", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["renderer"] == "history" and doc["outputs"][0]["bytes"] > 10000


@pytest.mark.parametrize("point", ["\u0663,0,0", "1_0,0,0"])
def test_a_force_point_in_other_digits_is_refused(point):
    # Python's float() reads Arabic-Indic digits and digit groups: 3 mm and 10 mm were taken
    from odsuite.domain.errors import ConfigError
    from odsuite.domain.excitation import read_force_point

    with pytest.raises(ConfigError, match="--force-point: expected three numbers X,Y,Z"):
        read_force_point(point)



def test_stored_coordinates_of_1e300_are_one_line(tmp_path, capsys):
    # finite but absurd: the movie's scale bar divided by a magnification of zero (ZeroDivisionError)
    project = tmp_path / "p.h5"
    assert main(["new", str(project)]) == 0
    assert main(["acquire", str(project), "--daq", "sim", "--name", "s1", "--scenario", "T2"]) == 0
    assert main(["process", str(project)]) == 0
    with h5py.File(project, "r+") as f:
        f["experiments/s1/derived/gencoords/platform_at_g"][...] = 1e300
    capsys.readouterr()
    _one_line(capsys, ["render", str(project), "s1", "-o", str(tmp_path / "m.gif")],
              "coords['platform']: 1e+300 (m) at sample 0: not a vibration (beyond 1000)")
    assert not (tmp_path / "m.gif").exists()
