"""The traps a new user falls into, each through the command line: positions with units and the
unit of bare numbers echoed, points off a moving body's surface, help texts that render, simulator
options with unit and default, notes once per project, an unsolvable layout named at `new`, and
`render --model` naming the sensor layout."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import numpy as np
import pytest

from tests.cli.clirun import run

RIG = Path(__file__).resolve().parents[2] / "examples" / "rigs" / "plate-and-motor.toml"
SHORT = ["--samples", "1024"]


@pytest.fixture
def project(tmp_path, capsys) -> Path:
    p = tmp_path / "p.h5"
    assert run(capsys, "new", p, "--rig", RIG)[0] == 0
    return p


def stored_point(capsys, p, name) -> np.ndarray:
    code, out, _ = run(capsys, "info", p, "--json")
    return np.asarray(json.loads(out)["experiments"][name]["excitation"]["point"], dtype=float)


@pytest.mark.parametrize("written", ["200mm,150mm,75mm", "0.2m,0.15m,0.075m", "0.2,0.15,0.075m",
                                     "20cm,15cm,7.5cm", "200,150,75"])
def test_a_force_point_takes_units_and_bare_numbers_are_mm_echoed_back(capsys, project, written):
    code, out, err = run(capsys, "acquire", project, "--name", "a", f"--force-point={written}", "--force-dir=-z", *SHORT)
    assert code == 0, err
    # the top face of the plate (0.6 x 0.4 x 0.025 m, underside 50 mm above the floor) at x 200, y 150 mm
    np.testing.assert_allclose(stored_point(capsys, project, "a"), [0.2, 0.15, 0.075], rtol=1e-12)
    line = next(ln for ln in out.splitlines() if ln.startswith("force point"))
    assert line.startswith("force point (200, 150, 75) mm in the rig frame") and "'plate'" in line, line
    assert ("read from bare numbers as mm" in line) == (written == "200,150,75"), line


def test_a_unit_on_some_numbers_only_is_refused_in_one_line(capsys, project):
    code, _, err = run(capsys, "acquire", project, "--name", "a", "--force-point=200mm,150,75", "--force-dir=-z", *SHORT)
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert ("--force-point: give a unit on every number other than 0 or on none (bare numbers are mm), "
            "got '200mm,150,75'") in err


@pytest.mark.parametrize("written", ["200mm,0,75mm", "0.2m,-0,0.075m", "200mm,0.0mm,75mm"])
def test_a_bare_zero_among_numbers_with_units_is_zero_in_their_unit(capsys, project, written):
    code, out, err = run(capsys, "acquire", project, "--name", "a", f"--force-point={written}", "--force-dir=-z", *SHORT)
    assert code == 0, err
    np.testing.assert_allclose(stored_point(capsys, project, "a"), [0.2, 0.0, 0.075], rtol=1e-12, atol=0)
    line = next(ln for ln in out.splitlines() if ln.startswith("force point"))
    assert "read from bare numbers" not in line, line
    # a bare number other than 0 keeps its refusal: 75 could be mm or m
    code, _, err = run(capsys, "acquire", project, "--name", "b", "--force-point=200mm,0,75", "--force-dir=-z", *SHORT)
    assert code == 1 and "give a unit on every number other than 0 or on none" in err, err


def test_metres_written_as_bare_numbers_land_on_the_floor_and_are_refused(capsys, project):
    # 0.2,0.15,0.01 read as mm is 0.01 mm above the floor's top: a body without mass
    code, _, err = run(capsys, "acquire", project, "--name", "a", "--force-point=0.2,0.15,0.01", "--force-dir=-z", *SHORT)
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    assert "(bare numbers are mm) (0.2, 0.15, 0.01) mm lies on 'floor', which has no mass" in err
    # as metres it is 40 mm under the plate and 10 mm above the floor: outside every body
    code, _, err = run(capsys, "acquire", project, "--name", "a", "--force-point=0.2,0.15,0.01m", "--force-dir=-z", *SHORT)
    # the body a hammer can hit is named: the plate 40 mm above, not the floor 10 mm below
    assert code == 1 and "outside every body" in err and "the nearest moving body, 'plate', is 40.0 mm away" in err, err


@pytest.mark.parametrize("written, direction, expected, face", [
    ("200mm,150mm,60mm", "-z", [0.2, 0.15, 0.075], "z = 75 mm"),   # struck from above: the top face
    ("200mm,150mm,60mm", "+z", [0.2, 0.15, 0.05], "z = 50 mm"),    # from below: the underside
    ("290mm,150mm,60mm", "-x", [0.3, 0.15, 0.06], "x = 300 mm"),   # from +x: the end face, 10 mm away
])
def test_a_point_inside_a_plate_moves_onto_the_face_the_blow_strikes_with_a_line(capsys, project, written, direction,
                                                                                 expected, face):
    code, _, err = run(capsys, "acquire", project, "--name", "a", f"--force-point={written}",
                       f"--force-dir={direction}", *SHORT)
    assert code == 0, err
    warnings = [ln for ln in err.splitlines() if "inside body 'plate'" in ln]
    assert len(warnings) == 1 and face in warnings[0], err
    np.testing.assert_allclose(stored_point(capsys, project, "a"), expected, rtol=1e-12)


def test_every_help_text_renders_its_brackets(capsys, monkeypatch):
    """Rich markup reads "[acquisition]" as a style and drops it: every bracketed word a command's or
    option's help holds must reach the printed help."""
    import typer

    from odsuite.cli.app import _register_plugin_commands, app

    monkeypatch.setenv("COLUMNS", "400")
    monkeypatch.setenv("TERMINAL_WIDTH", "400")
    _register_plugin_commands()
    group = typer.main.get_command(app)
    checked = 0
    for name, command in group.commands.items():
        texts = [command.help or ""] + [getattr(p, "help", None) or "" for p in command.params]
        brackets = {b for text in texts for b in re.findall(r"\[[^\]\s]+\]", text)}
        if not brackets:
            continue
        code, out, err = run(capsys, name, "--help")
        assert code == 0, err
        flat = " ".join(out.split())
        assert not [b for b in brackets if b not in flat], (name, brackets)
        checked += 1
    code, out, _ = run(capsys, "acquire", "--help")
    assert "the rig's ," not in out and "acquisition sampling_rate, else 20000 Hz" in " ".join(out.split())
    assert checked >= 1  # render's --ods X,Y,Z[,THETA,PHI,PSI]


def test_an_unknown_option_is_a_usage_line_not_a_traceback(capsys, project):
    code, out, err = run(capsys, "render", project, "--experiment", "H1")
    assert code == 2 and "No such option: --experiment" in err and "Traceback" not in err + out, err


def without_sensors(tmp_path, *names) -> Path:
    """The example rig without the triaxial accelerometers ``names`` (taken from the end of the file):
    two triaxials on a body leave its rotation about the line through them undetermined."""
    text = RIG.read_text()
    for name in names:
        start = text.index(f'[[sensors]]\nname = "{name}"')
        end = text.find("[[sensors]]", start + 1)
        text = text[:start] + (text[end:] if end > 0 else "")
    channels = 19 - 3 * len(names)
    text = text.replace("channel_count = 19", f"channel_count = {channels}")
    for k, name in enumerate(n for n in ("P1", "P2", "P3", "M1", "M2", "M3") if n not in names):  # channels 1..
        text = re.sub(rf'(name = "{name}"\n(?:.*\n)*?channels = )\[[0-9, ]+\]', rf"\g<1>[{3 * k + 1}, {3 * k + 2}, {3 * k + 3}]",
                      text, count=1)
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_new_warns_at_once_about_a_body_its_sensors_cannot_solve(capsys, tmp_path):
    code, out, err = run(capsys, "new", tmp_path / "p.h5", "--rig", without_sensors(tmp_path, "M3"))
    assert code == 0 and out.startswith("created")
    warnings = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert len(warnings) == 1 and "body 'motor': its motion cannot be solved" in warnings[0], err
    assert "M1_x" in warnings[0] and "M2_z" in warnings[0] and "no generalized coordinates for body 'motor'" in warnings[0]
    code, _, err = run(capsys, "new", tmp_path / "q.h5", "--rig", RIG)
    assert code == 0 and "warning" not in err, err


def test_process_says_a_note_once_per_project(capsys, tmp_path):
    p = tmp_path / "p.h5"
    assert run(capsys, "new", p, "--rig", without_sensors(tmp_path, "M3"))[0] == 0
    for k in range(3):
        code, _, err = run(capsys, "acquire", p, "--name", f"H{k}", "--force-point=200mm,150mm,75mm", "--force-dir=-z",
                           "--seed", k, *SHORT)
        assert code == 0, err
    code, out, err = run(capsys, "process", p)
    assert code == 0 and len(out.strip().splitlines()) == 3, out
    notes = [ln for ln in err.splitlines() if ln.startswith("note")]
    assert len(notes) == 1 and notes[0].startswith("note (every experiment): ") and "body 'motor'" in notes[0], err


def test_render_model_names_the_sensor_layout_not_the_chains(capsys, tmp_path):
    p = tmp_path / "p.h5"
    assert run(capsys, "new", p, "--rig", without_sensors(tmp_path, "P3", "M3"))[0] == 0
    assert run(capsys, "acquire", p, "--name", "H1", "--force-point=200mm,150mm,75mm", "--force-dir=-z", *SHORT)[0] == 0
    assert run(capsys, "process", p)[0] == 0
    for extra in (["--model"], []):
        code, _, err = run(capsys, "render", p, "H1", *extra, "-o", tmp_path / "m.gif")
        assert code == 1 and len(err.strip().splitlines()) == 1, err
        assert "no body's motion can be solved from its sensors" in err and "process` first" not in err, err
        assert "body 'plate'" in err and "body 'motor'" in err and "chains" not in err, err
    assert not (tmp_path / "m.gif").exists()


def test_every_simulator_option_is_listed_with_its_unit_and_default(capsys):
    """`odsuite plugins` and the user guide list each of the simulator's options; the hammer's stated
    defaults are the ones a blow without options gets (hammer.Hit's)."""
    from odsuite_plugins.daq_sim.hammer import Hit
    from odsuite_plugins.daq_sim.simulator import SimulatedRig

    listed = {o.cli_flag: o for o in SimulatedRig.options}
    for flag, o in listed.items():
        assert o.default is not None or "default" in o.help, flag
    assert f"else {Hit().peak:g} N" in listed["--force-peak"].help
    assert f"else {1e3 * Hit().width:g} ms" in listed["--contact-ms"].help
    guide = (Path(__file__).resolve().parents[2] / "docs" / "user-guide.md").read_text()
    rows = {line.split("`")[1].split()[0]: line for line in guide.splitlines() if line.startswith("| `--")}
    assert set(rows) == set(listed)
    assert f"else {Hit().peak:g} N" in rows["--force-peak"] and f"else {1e3 * Hit().width:g} ms" in rows["--contact-ms"]
    code, out, _ = run(capsys, "plugins")
    flat = " ".join(out.replace("│", " ").split())
    for flag, o in listed.items():  # each with its type and help (the table wraps long ones)
        assert f"{flag} {o.type.__name__.upper()}: {o.help[:30]}" in flat, flag
    assert "--seed INT: random seed; one seed, one record (default 0)" in flat


@pytest.mark.slow
def test_the_report_speaks_of_the_rig_at_hand(capsys, project, tmp_path):
    """Words from the rig: its frame as its file states it, its bodies; no platform, no DAQ gain (a
    field of the thesis's .CTR files, not of the rig format)."""
    import html
    import tomllib

    frame = tomllib.loads(RIG.read_text())["frame"]
    assert run(capsys, "acquire", project, "--name", "H1", "--force-point=200mm,150mm,75mm", "--force-dir=-z",
               "--samples", "2048")[0] == 0
    assert run(capsys, "process", project)[0] == 0
    out = tmp_path / "r.html"
    code, _, err = run(capsys, "report", project, "-o", out, "--no-diagnose", "--no-movie")
    assert code == 0, err
    text = html.unescape(re.sub(r"<[^>]+>", " ", out.read_text()))
    assert f"Force points in mm in the rig frame ({frame})." in text
    assert "platform" not in text.lower() and "DAQ gain" not in text and "z down" not in text
    assert "plate (47.1 kg), motor (18 kg), floor" in text


def test_import_echoes_the_force_point_it_read(capsys, project, tmp_path):
    """A record exported from one project and imported onto the same rig: the point written in
    metres is stored and said back in mm; bare numbers are said to be read as mm."""
    assert run(capsys, "acquire", project, "--name", "a", "--force-point=200mm,150mm,75mm", "--force-dir=-z",
               *SHORT)[0] == 0
    uff = tmp_path / "a.uff"
    code, _, err = run(capsys, "export-uff", project, "a", "-o", uff)
    assert code == 0, err
    for k, written in enumerate(["0.25,0.1,0.075m", "250,100,75"]):
        code, out, err = run(capsys, "import-uff", project, uff, "--name", f"u{k}", f"--force-point={written}",
                             "--force-dir=-z")
        assert code == 0, err
        line = next(ln for ln in out.splitlines() if ln.startswith("force point"))
        assert line == "force point (250, 100, 75) mm in the rig frame" + (", read from bare numbers as mm" if k else "") \
            + ", on 'plate'", line
        np.testing.assert_allclose(stored_point(capsys, project, f"u{k}"), [0.25, 0.1, 0.075], rtol=1e-12)


def test_process_of_a_project_without_experiments_says_so(capsys, project):
    code, out, err = run(capsys, "process", project)
    assert code == 0 and out == "" and err.strip() == (f"note: {project}: no experiments to process "
                                                         "(acquire or import some first)"), (out, err)
    code, out, err = run(capsys, "process", project, "--json")
    assert code == 0 and json.loads(out)["experiments"] == {}, out


def test_history_figure_says_what_it_wrote(capsys, project, tmp_path):
    fig = tmp_path / "h.png"
    code, out, err = run(capsys, "history", project, "--figure", fig)
    assert code == 0 and out.strip().splitlines()[-1] == f"wrote {fig}", (out, err)
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, _ = run(capsys, "history", project, "--figure", fig, "--json")
    assert code == 0 and json.loads(out)["current"] == 0


@pytest.mark.parametrize("field, old, new, words", [
    ("com", "com = [0.0, 0.0, 0.0385]", "com = [0.0, 0.0, 38.5]",
     "body 'block' field 'com' at (0, 0, 38500) mm is 38.4 m from the plate of body 'block'"),
    ("position", "position = [-0.05, -0.03, 0.077]", "position = [-50.0, -30.0, 77.0]",
     "sensor 'top_z' field 'position' at (-50000, -30000, 77000) mm is 96.5 m from the plate of body 'block'"),
    ("spring", "position = [0.05, 0.0, 0.0]", "position = [50.0, 0.0, 0.0]",
     "spring 'foot_c' field 'position' at (50000, 0, 0) mm is 49.9 m from the plate of body 'block'"),
    # one [[sensors]] entry, one line (its three axes gave three)
    ("triaxial", "position = [0.05, 0.03, 0.077]", "position = [50.0, 30.0, 77.0]",
     "sensor 'tri' (tri_x, tri_y, tri_z) field 'position' at (50000, 30000, 77000) mm is 96.5 m from the plate of "
     "body 'block'"),
])
def test_new_warns_of_a_position_given_in_mm(capsys, tmp_path, field, old, new, words):
    """A 2 kg block on three feet, one triaxial and two single-axis accelerometers: a length in mm
    loads as metres, a thousand times off; `new` says so, naming the field and the value."""
    rig = BLOCK_ON_FEET.replace(old, new)
    assert rig != BLOCK_ON_FEET
    (tmp_path / "r.toml").write_text(rig)
    code, _, err = run(capsys, "new", tmp_path / "p.h5", "--rig", tmp_path / "r.toml")
    warned = [ln for ln in err.splitlines() if "from the plate" in ln]
    assert code == 0 and warned == [f"warning: rig 'block-on-feet' ({tmp_path / 'r.toml'}): {words}: positions are in m"], err
    (tmp_path / "p.h5").unlink()
    tmp_path.joinpath("ok.toml").write_text(BLOCK_ON_FEET)
    code, _, err = run(capsys, "new", tmp_path / "p.h5", "--rig", tmp_path / "ok.toml")
    assert code == 0 and "from the plate" not in err, err


BLOCK_ON_FEET = """
name = "block-on-feet"
frame = "origin under the block's centre, z up"
default_model = "rigid-bodies"
[[bodies]]
name = "block"
mass = 2.0
com = [0.0, 0.0, 0.0385]
inertia = [[0.002055, 0, 0], [0, 0.003388, 0], [0, 0, 0.003467]]
[bodies.plate]
size = [0.12, 0.08, 0.077]
corner = [-0.06, -0.04, 0.0]
[[springs]]
name = "foot_a"
body = "block"
position = [-0.05, -0.03, 0.0]
stiffness = [4e4, 4e4, 1e5]
group = "feet"
[[springs]]
name = "foot_b"
body = "block"
position = [-0.05, 0.03, 0.0]
stiffness = [4e4, 4e4, 1e5]
group = "feet"
[[springs]]
name = "foot_c"
body = "block"
position = [0.05, 0.0, 0.0]
stiffness = [4e4, 4e4, 1e5]
group = "feet"
[[sensors]]
name = "hammer"
kind = "force"
channel = 3
sensitivity = 0.0115
[[sensors]]
name = "tri"
kind = "triaxial_accelerometer"
body = "block"
position = [0.05, 0.03, 0.077]
channels = [0, 1, 2]
sensitivity = 0.0102
[[sensors]]
name = "top_z"
body = "block"
position = [-0.05, -0.03, 0.077]
axis = [0, 0, 1]
channel = 4
sensitivity = 0.00102
[[sensors]]
name = "side_xy"
body = "block"
position = [0.06, -0.03, 0.04]
axis = [0.6, 0.8, 0.0]
channel = 5
sign = -1
sensitivity = 0.00102
"""


def test_compare_modal_table_keeps_every_number_at_80_columns():
    """A narrow terminal wraps the headers; it cut the numbers before (a MAC of 0.766 read '0.7…')."""
    from rich.console import Console

    from odsuite.cli.app import _modal_table

    rows = [{"experiment": "motor_side", "measured_hz": 96.56, "model_hz": 98.61, "measured_zeta": 0.06347,
             "model_zeta": 0.05904, "mac": 0.766},
            {"experiment": "pump_top", "measured_hz": 1117.5, "model_hz": None, "measured_zeta": 0.0607,
             "model_zeta": None, "mac": None}]
    console = Console(width=80, record=True, file=io.StringIO())
    console.print(_modal_table(rows))
    text = console.export_text()
    assert "…" not in text and max(len(ln) for ln in text.splitlines()) <= 80, text
    for number in ("96.56", "98.61", "+2.12%", "6.347", "5.904", "-7%", "0.766", "1117.50"):
        assert number in text, (number, text)


def test_compare_modal_table_prints_an_undamped_models_zeta_as_zero():
    """A model of undamped springs printed 'model ζ % -0.000'."""
    from rich.console import Console

    from odsuite.cli.app import _modal_table

    rows = [{"experiment": "e1", "measured_hz": 23.2, "model_hz": 23.19, "measured_zeta": 0.0213,
             "model_zeta": -0.0, "mac": 0.99},
            {"experiment": "e1", "measured_hz": 30.1, "model_hz": 30.09, "measured_zeta": 0.0301,
             "model_zeta": -3e-9, "mac": 0.98}]
    console = Console(width=120, record=True, file=io.StringIO())
    console.print(_modal_table(rows))
    text = console.export_text()
    assert "-0.000" not in text and text.count(" 0.000 ") == 2, text


@pytest.mark.parametrize("names", [
    ["mass_properties+sensor_dynamics", "spring_stiffness", "plate_flexibility_free"],
    ["mass_properties+stiffness", "spring_stiffness", "sensor_gain"],
    ["plate_flexibility_free+measured-modal-damping", "spring_stiffness"],
])
def test_diagnose_table_keeps_every_effect_name_whole_at_80_columns(names):
    """An effect's name is what `add-effect` takes: at 80 columns the table folds its three checks
    into one column rather than break a name ('mass_properties+stiffn / ess' before), and only a
    pair longer than the room left breaks, after its '+'; each name reads whole on one line."""
    from rich.console import Console

    from odsuite.cli.loop_commands import _candidates_table

    rows = [{"effect": n, "significant": k == 0, "consistent": True, "plausible": k == 0, "fitted": k < 2,
             "error_after": 0.0264 + k / 1000, "validated_error": float("nan") if k else 0.0265,
             "confounded_with": []} for k, n in enumerate(names)]
    console = Console(width=80, record=True, file=io.StringIO())
    console.print(_candidates_table(rows, 80))
    text = console.export_text()
    assert max(len(ln) for ln in text.splitlines()) <= 80, text
    cells = [ln.split("│")[1].strip() for ln in text.splitlines() if ln.startswith("│")]
    for n in names:
        parts = [n] if len(n) <= 40 else [p + "+" for p in n.split("+")[:-1]] + [n.split("+")[-1]]
        for part in parts:
            assert part in cells, (part, text)
    checks = [ln.split("│")[2].strip() for ln in text.splitlines() if ln.startswith("│") and ln.split("│")[2].strip()]
    assert checks[:2] == ["yes yes yes", "no  yes no"], text
    assert "0.0264" in text and "0.0265" in text


def test_diagnose_text_keeps_to_80_columns_piped(monkeypatch):
    """diagnose at 80 columns, piped: the list of effects that do not apply wraps between names like
    the paragraphs (it ran on as one line of 230 characters)."""
    from rich.console import Console

    import importlib

    from odsuite.cli import loop_commands

    console = Console(width=80, record=True, file=io.StringIO())
    monkeypatch.setattr(loop_commands, "console", console)
    # paragraph() prints on the app module's console (the package's `app` is the typer app)
    monkeypatch.setattr(importlib.import_module("odsuite.cli.app"), "console", console)
    names = ["base_motion", "beam-mass-scale", "beam-modal-damping", "beam-positions", "beam-sensor-mass",
             "beam-shear-rotary", "beam-stiffness-scale", "beam-supports", "beam-supports-alike",
             "measured-modal-damping", "spring_stiffness"]
    c = {"effect": "stiffness", "significant": True, "consistent": True, "plausible": True, "fitted": True,
         "error_after": 0.2381, "validated_error": 0.2381, "confounded_with": [],
         "evidence": "fitted stiffness of mount4 along z = 799.8 ± 0.5 kN/m (model: 1000)"}
    doc = {"revision": 0, "baseline_error": 0.4916, "noise_floor": 0.2379, "residual_to_floor": 2.07,
           "verdict": "explained", "message": "The model's error is 0.492.", "candidates": [c],
           "signature": {"channels": [], "experiments": [], "bands": [], "peaks_hz": [], "amplitude_dependent": False},
           "not_applicable": names}
    loop_commands._print_diagnosis(doc)
    text = console.export_text()
    assert max(len(ln) for ln in text.splitlines()) <= 80, text
    assert all(n in text.replace("\n", " ") for n in names)


def test_a_note_of_several_lines_prints_each_line_wrapped(capsys, monkeypatch):
    """A note quoting a message of several lines printed its line break as the two characters of
    its escape ("\\n") in one long line: each line is printed and wrapped on its own."""
    from odsuite import cli
    from odsuite.cli.app import paragraph

    monkeypatch.setattr(cli.console, "width", 80)
    first = "E1: measured modes not identified: " + "the first line of the message " * 3
    paragraph(first + "\n  the second line\x1b[31m")
    lines = capsys.readouterr().out.splitlines()
    assert "\\n" not in "".join(lines) and all(len(ln) <= 80 for ln in lines), lines
    assert " ".join(ln.strip() for ln in lines[:-1]) == first.strip() and len(lines) > 2
    assert lines[-1] == "  the second line\\x1b[31m"  # its own indent; a control character still escaped


def test_prose_lines_wrap_at_their_words_with_their_indent_at_80_columns(capsys, monkeypatch):
    """compare's notes and diagnose's list of effects that do not apply ran 137-220 characters on
    one line: wrapped at spaces within 80 columns, continuation lines indented past the line's own
    indent, every word kept whole (a path longer than a line on a line of its own)."""
    from odsuite import cli
    from odsuite.cli.app import paragraph

    monkeypatch.setattr(cli.console, "width", 80)
    notes = ["E1: measured modes not identified: no stable poles found in 2.273-702.4 Hz up to model order 50 "
             "(87.36 Hz: synthesis misfit 49 % near it)",
             "not applicable to this model: base_motion, beam-mass-scale, beam-modal-damping, beam-positions, "
             "beam-sensor-mass, beam-shear-rotary, beam-stiffness-scale, beam-supports, beam-supports-alike, "
             "measured-modal-damping",
             "    an indented note about /a/" + "very-long/" * 10 + "path.h5 that cannot break"]
    for note in notes:
        capsys.readouterr()
        paragraph(note)
        lines = capsys.readouterr().out.splitlines()
        indent = note[:len(note) - len(note.lstrip())]
        assert len(lines) > 1 and lines[0].startswith(indent) and not lines[0].startswith(indent + " ")
        assert all(ln.startswith(indent + "  ") and not ln.startswith(indent + "   ") for ln in lines[1:]), lines
        assert " ".join(ln.strip() for ln in lines) == note.strip()
        assert all(len(ln) <= 80 for ln in lines if "/" not in ln), lines


def test_a_quoted_name_never_takes_a_possessive(capsys, tmp_path):
    # "rig 'stiff-bracket''s elliptic anti-aliasing filter" read as a doubled quote: the names
    # quoted by !r go after "of" instead (that warning is gone: the simulated rig now draws the
    # declared family)
    rig = Path(__file__).resolve().parents[1] / "data" / "rigs" / "stiff-bracket.toml"
    assert run(capsys, "new", tmp_path / "b.h5", "--rig", rig)[0] == 0
    code, _, err = run(capsys, "acquire", tmp_path / "b.h5", "--name", "a", "--samples", "256", "--seed", "1")
    assert code == 0, err
    assert "'s " not in err and "Butterworth" not in err, err
    root = Path(__file__).resolve().parents[2]
    found = [f"{path.relative_to(root)}:{n}" for folder in ("odsuite", "plugins") for path in (root / folder).rglob("*.py")
             for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if re.search(r"!r\}'s\b", line)]
    assert not found, found


def test_a_short_record_takes_a_pretrigger_it_can_hold(capsys, tmp_path):
    # --samples 256 on a rig whose file sets no pre_trigger was refused for the default 512 samples
    # before the trigger, a number the user never gave
    rig = Path(__file__).resolve().parents[1] / "data" / "rigs" / "undamped-block.toml"
    (tmp_path / "rig.toml").write_text(rig.read_text(encoding="utf-8").replace("pre_trigger = 32\n", ""))
    assert run(capsys, "new", tmp_path / "b.h5", "--rig", tmp_path / "rig.toml")[0] == 0
    code, out, err = run(capsys, "acquire", tmp_path / "b.h5", "--name", "a", "--samples", "256")
    assert code == 0, err
    assert "256 samples x 10 channels at 512 Hz, 128 before the trigger" in out


def test_model_and_modes_json_print_nan_as_null(capsys, tmp_path, monkeypatch):
    # `model --json` and `modes --json` printed their documents with json.dumps directly: a NaN or
    # inf would have made text no JSON parser reads (every other --json prints them as null)
    import odsuite.analysis.modelrev as modelrev

    rig = Path(__file__).resolve().parents[1] / "data" / "rigs" / "stiff-bracket.toml"
    assert run(capsys, "new", tmp_path / "b.h5", "--rig", rig)[0] == 0
    real = modelrev.model_report
    monkeypatch.setattr(modelrev, "model_report", lambda p: {**real(p), "odd": [float("nan"), float("inf")]})
    code, out, err = run(capsys, "model", tmp_path / "b.h5", "--json")
    assert code == 0, err
    assert json.loads(out)["odd"] == [None, None]
    assert "NaN" not in out and "Infinity" not in out
