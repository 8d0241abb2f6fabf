"""A load cell with its own filter (rig-format.md's example: the hammer low-passed, the
accelerometers high-passed): the model is driven with the force without that filter, as the
accelerometers' chains, which the predictions pass, do not have it. A 2 kg bracket on stiff pads
(tests/data/rigs/stiff-bracket.toml, written from the rig format alone), the hammer low-passed at
8 kHz, recorded from itself: its error read 19.5x the floor, the residual peaking at the model's
own modes (the low-pass's lag at 300-800 Hz); without that filter on the force, 1.16x."""

from __future__ import annotations

import json
from pathlib import Path

from odsuite.cli import main
from tests.cli.clirun import run_ok as run

RIG = Path(__file__).resolve().parents[1] / "data" / "rigs" / "stiff-bracket.toml"


def test_a_low_passed_load_cell_leaves_the_prediction_unfiltered(tmp_path, capsys):
    assert 'type = "lowpass"' in RIG.read_text()  # the hammer's own filter
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", RIG)
    run(capsys, "acquire", p, "--name", "hit30", "--samples", "8192", "--force-point=30,20,100",
        "--force-dir=-0.3,0,-1", "--force-peak", "30", "--seed", "30")
    cmp = json.loads(run(capsys, "compare", p, "--json"))
    assert cmp["error"] < 1.5 * cmp["noise_floor_error"], (cmp["error"], cmp["noise_floor_error"])


def test_a_proximity_probe_left_out_is_named_once(tmp_path, capsys):
    # the bracket's eddy-current probe under its foot (channel 7, displacement) was neither processed
    # nor compared, and nothing said so
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", RIG)
    for name in ("a", "b"):
        run(capsys, "acquire", p, "--name", name, "--samples", "2048", "--force-point=30,20,100", "--force-dir=-z",
            "--seed", "3")
    assert main(["process", str(p)]) == 0
    out, err = capsys.readouterr()
    said = [ln for ln in err.splitlines() if "channel 7 (gap, proximity: displacement) is left out of processing" in ln]
    assert len(said) == 1 and "every experiment" in said[0], err
    assert main(["compare", str(p), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert sum("channel 7 (gap, proximity: displacement) is left out of the comparison" in n for n in notes) == 1, notes


def test_diagnose_names_the_proximity_probe_it_leaves_out(tmp_path, capsys):
    # compare said so and diagnose, which compares the same channels, did not
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", RIG)
    run(capsys, "acquire", p, "--name", "a", "--samples", "2048", "--force-point=30,20,100", "--force-dir=-z")
    assert main(["diagnose", str(p), "--effect", "damping", "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert sum("channel 7 (gap, proximity: displacement) is left out of the comparison" in n for n in notes) == 1, notes
