"""The traps a new user falls into, each through the command line: positions with units and the
unit of bare numbers echoed, points off a moving body's surface, help texts that render, simulator
options with unit and default, notes once per project, an unsolvable layout named at `new`, and
`render --model` naming the sensor layout."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from odsuite.cli import main

RIG = Path(__file__).resolve().parents[2] / "examples" / "rigs" / "plate-and-motor.toml"
SHORT = ["--samples", "1024"]


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


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
    assert "--force-point: give a unit on every number or on none (bare numbers are mm), got '200mm,150,75'" in err


def test_metres_written_as_bare_numbers_land_on_the_floor_and_are_refused(capsys, project):
    # 0.2,0.15,0.01 read as mm is 0.01 mm above the floor's top: a body without mass
    code, _, err = run(capsys, "acquire", project, "--name", "a", "--force-point=0.2,0.15,0.01", "--force-dir=-z", *SHORT)
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    assert "(bare numbers are mm) (0.2, 0.15, 0.01) mm lies on 'floor', which has no mass" in err
    # as metres it is 40 mm under the plate and 10 mm above the floor: outside every body
    code, _, err = run(capsys, "acquire", project, "--name", "a", "--force-point=0.2,0.15,0.01m", "--force-dir=-z", *SHORT)
    assert code == 1 and "outside every body" in err and "'floor', is 10.0 mm away" in err, err


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
