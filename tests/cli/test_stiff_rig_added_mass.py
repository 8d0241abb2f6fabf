"""An added mass on a stiff structure, found from records its model never saw.

A 2 kg bracket on four stiff pads (tests/data/rigs/stiff-bracket.toml, written from
docs/rig-format.md; modes 306-832 Hz), recorded with 1.5 kg bolted on and spread like the
bracket's own (stiff-bracket-heavier.toml: every mass and moment 1.75 times), hit at 5, 30 and
150 N with no samples before the trigger. Before, the screening's first head (0.01 s, three
periods of the slowest mode) left the residual a cycle out of phase: its one step reached a mass
scale of 1.15, mass_properties was not fitted, and the verdict was "partly explained" by
damping+plate_flexibility_free at 40x the floor, its values outside their range."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli.clirun import run_ok as run

RIGS = Path(__file__).resolve().parents[1] / "data" / "rigs"


def test_a_heavier_bracket_is_explained_by_its_mass(tmp_path, capsys):
    p = tmp_path / "bracket.h5"
    run(capsys, "new", p, "--rig", RIGS / "stiff-bracket.toml")
    for force in (5, 30, 150):
        run(capsys, "acquire", p, "--name", f"hit{force}", "--samples", "8192", "--force-point", "30,20,100",
            "--force-dir=-0.2873,0,-0.9578", "--seed", force, "--force-peak", force,
            "--truth", RIGS / "stiff-bracket-heavier.toml")
    run(capsys, "process", p)
    d = json.loads(run(capsys, "diagnose", p, "--json"))
    top = d["candidates"][0]
    assert d["verdict"] == "explained" and top["effect"] == "mass_properties", d["message"]
    assert top["error_after"] < 1.2 * d["noise_floor_error"], (top["error_after"], d["noise_floor_error"])
    for name in ("mass_scale", "Ixx_scale", "Iyy_scale", "Izz_scale"):
        assert abs(top["parameters"][name] / 1.75 - 1) < 0.01, (name, top["parameters"])
