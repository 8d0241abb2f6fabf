"""`odsuite info` lists a rig's bodies, springs and the coordinate solver each body gets, and each
record's peaks in their channels' units."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.clirun import run_ok as run

RIG_FILE = Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml"


def test_info_lists_bodies_springs_and_solvers(capsys, tmp_path):
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", RIG_FILE)
    layout = json.loads(run(capsys, "info", p, "--json"))["rig_layout"]
    bodies = {b["name"]: b for b in layout["bodies"]}
    assert bodies["base"]["mass_kg"] == 40.0 and bodies["machine"]["mass_kg"] == 20.0
    assert not bodies["floor"]["moving"] and bodies["floor"]["solver"] is None
    # three triaxial accelerometers per body: nine directions, least squares
    assert [len(bodies[b]["sensors"]) for b in ("base", "machine")] == [9, 9]
    assert bodies["base"]["solver"] == bodies["machine"]["solver"] == "least-squares"
    springs = {s["name"]: s for s in layout["springs"]}
    assert len(springs) == 8 and springs["mount1"]["other"] == "base" and springs["isolator1"]["other"] == "ground"
    assert springs["isolator1"]["stiffness_n_per_m"] == [200000.0, 200000.0, 400000.0]
    text = run(capsys, "info", p)
    assert "least-squares" in text and "isolator4" in text and "machine - base" in text


def test_a_body_its_sensors_cannot_solve_is_said(capsys, tmp_path):
    # the machine keeps one triaxial accelerometer: three directions at one point, not six motions
    text = RIG_FILE.read_text()
    for k in (2, 3):
        start = text.index(f'name = "m{k}"')
        text = text[:start] + text[start:].replace("body = \"machine\"", "body = \"base\"", 1)
    rig = tmp_path / "rig.toml"
    rig.write_text(text)
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", rig)
    bodies = {b["name"]: b for b in json.loads(run(capsys, "info", p, "--json"))["rig_layout"]["bodies"]}
    assert bodies["machine"]["solver"] is None and "machine" in bodies["machine"]["solver_problem"]
    assert bodies["base"]["solver"] == "least-squares" and len(bodies["base"]["sensors"]) == 15


def test_info_lists_the_springs_rotational_stiffness(capsys, tmp_path):
    """The three-body stand's two isolators resist the roll about the line joining them only by
    their rotational stiffness (30 kN m/rad each): `info` shows it, and only for springs that have
    one (it showed none, as if the rig rolled freely)."""
    rig = Path(__file__).resolve().parents[1] / "data" / "rigs" / "three-body-stand.toml"
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", rig)
    springs = {s["name"]: s for s in json.loads(run(capsys, "info", p, "--json"))["rig_layout"]["springs"]}
    assert springs["iso_left"]["rot_stiffness_n_m_per_rad"] == [3e4, 3e4, 3e4]
    assert springs["iso_right"]["rot_damping_n_m_s_per_rad"] == [10.0, 10.0, 10.0]
    assert springs["ped_1"]["rot_stiffness_n_m_per_rad"] == [0.0, 0.0, 0.0]
    text = run(capsys, "info", p)
    table = text[text.index("springs on the relative rotation"):]
    rows = [line.split()[0] for line in table.splitlines()[3:] if line.strip()]
    assert rows[:2] == ["iso_left", "iso_right"] and "ped_1" not in rows
    assert "iso_left   30, 30, 30" in table
    p2 = tmp_path / "q.h5"
    run(capsys, "new", p2, "--rig", RIG_FILE)
    assert "relative rotation" not in run(capsys, "info", p2)


def test_info_gives_each_peak_in_its_channel_unit_for_an_imported_record(capsys, tmp_path):
    """A CSV's columns are stored in the file's units (N, m/s^2, g): no peak of theirs is called
    volts, each is in SI with its unit; the table's peak is the force's in N, and without a force
    the largest acceleration in m/s^2 (2 g, not the 3 stored in the m/s^2 column)."""
    (tmp_path / "r.csv").write_text("hammer [N],a [m/s^2],b [g]\n0,0,0\n12.5,-3,0.5\n1,0.25,-2\n0,0,0\n")
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", "none")
    run(capsys, "import", p, tmp_path / "r.csv", "--name", "x", "--rate", "1000")
    (tmp_path / "o.csv").write_text("a [m/s^2],b [g]\n0,0\n-3,0.5\n0.25,-2\n0,0\n")
    run(capsys, "import", p, tmp_path / "o.csv", "--name", "o", "--rate", "1000")
    e = json.loads(run(capsys, "info", p, "--json"))["experiments"]["x"]
    assert not [key for key in e if "volt" in key]
    assert e["peak"]["hammer"] == [12.5, "N"] and e["peak"]["a"] == [3.0, "m/s^2"]
    assert e["peak"]["b"][1] == "m/s^2" and e["peak"]["b"][0] == pytest.approx(2 * 9.80665, rel=1e-12)
    rows = {line.split()[0]: line for line in run(capsys, "info", p).splitlines() if line[:2] in ("x ", "o ")}
    assert "12.5 N (hammer)" in rows["x"] and "19.61 m/s^2 (b)" in rows["o"]
