"""Nulls on rigs written from docs/rig-format.md alone: the simulated record is the model's own,
so the verdict must be "nothing to explain" with no significant candidate.

- An undamped block (the format's default damping), recorded at 512 Hz with 32 samples before the
  trigger. Before, the noise was measured on the record's last eighth, where the response still
  rang at full strength (the floor 0.997 for an error of 0.0758), and a channel that never moves,
  its noise a quarter of a code, was given no noise at all (its cells 4.3x their floor):
  'unexplained'.
- A slab on four mounts moving in z, theta and phi only, three z accelerometers on a 12-bit card,
  a 10 N hit: two channels' 128 samples before the hit sit on one code, and their noise was read
  as the least the estimate allows (0.01 code for about 0.1-0.2), the floor of a null a quarter
  of its error: 'unexplained' (a1 at 400-800 Hz 3.99x its floor)."""

from __future__ import annotations

import json
from pathlib import Path

from odsuite.cli import main
from tests.cli.clirun import run_ok as run

RIG = Path(__file__).resolve().parents[1] / "data" / "rigs" / "undamped-block.toml"


def test_an_undamped_null_has_nothing_to_explain(tmp_path, capsys):
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", RIG)
    run(capsys, "acquire", p, "--name", "k1", "--samples", "4096", "--force-point", "0,0,50", "--force-dir=-z")
    run(capsys, "process", p)
    cmp = json.loads(run(capsys, "compare", p, "--json"))
    # the floor is no longer far above the error a perfect model has (13x before)
    assert cmp["noise_floor_error"] <= cmp["error"], (cmp["error"], cmp["noise_floor_error"])
    assert any("the noise is measured on them alone" in n and "still ring" in n for n in cmp["notes"]), cmp["notes"]
    d = json.loads(run(capsys, "diagnose", p, "--json"))
    assert d["verdict"] == "nothing to explain", d["message"]
    assert not [c["effect"] for c in d["candidates"] if c.get("significant")]


def test_a_twelve_bit_slab_null_has_nothing_to_explain(tmp_path, capsys):
    from tests.core.test_comparison import SLAB_RIG

    (tmp_path / "slab.toml").write_text(SLAB_RIG)
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", tmp_path / "slab.toml")
    run(capsys, "acquire", p, "--name", "k1", "--samples", "4096", "--force-point=-250,150,50", "--force-dir=-z")
    run(capsys, "process", p)
    d = json.loads(run(capsys, "diagnose", p, "--json"))
    assert d["verdict"] == "nothing to explain", d["message"]
    assert not [c["effect"] for c in d["candidates"] if c.get("significant")]
    assert d["baseline_error"] / d["noise_floor_error"] < 1.3  # 1.52 before


def test_an_undamped_model_gains_the_damping_its_records_show(tmp_path, capsys):
    # the damping effect scaled the springs' damping, which the rig format leaves at zero: it
    # changed nothing (5.2174 -> 5.2174), and a sensor tilt near its bound was the top candidate
    rigs = RIG.parent
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", rigs / "heavy-press.toml")
    for name, point, direction, seed, force in (("p1", "200,200,850", "-z", 11, 12), ("p2", "1300,800,850", "-z", 12, 15),
                                                ("p3", "1500,300,600", "-x", 13, 5)):
        run(capsys, "acquire", p, "--samples", "4096", "--contact-ms", "2", "--truth", rigs / "heavy-press-damped.toml",
            "--name", name, f"--force-point={point}", f"--force-dir={direction}", "--seed", seed, "--force-peak", force)
    run(capsys, "process", p)
    d = json.loads(run(capsys, "diagnose", p, "--json"))
    assert d["verdict"] == "explained" and d["candidates"][0]["effect"] == "damping", d["message"]
    run(capsys, "add-effect", p, "damping")
    rows = {r["label"]: r["value"] for r in json.loads(run(capsys, "model", p, "--json"))["physical"]["damping"]}
    # the truth: 800, 800 and 1600 N s/m, 2 % of each isolator's critical damping
    for axis, truth in (("x", 800.0), ("y", 800.0), ("z", 1600.0)):
        assert abs(rows[f"damping of iso (each, e.g. iso1) along {axis}"] / truth - 1) < 0.05, rows


def test_new_says_a_rig_without_damping_rings_without_end(tmp_path, capsys):
    rigs = RIG.parent
    assert main(["new", str(tmp_path / "u.h5"), "--rig", str(rigs / "heavy-press.toml")]) == 0
    assert "note: rig 'heavy-press' (" in capsys.readouterr().err
    assert main(["new", str(tmp_path / "d.h5"), "--rig", str(rigs / "heavy-press-damped.toml")]) == 0
    assert "no spring has damping" not in capsys.readouterr().err


def test_a_null_recorded_from_its_trigger_inside_the_hit_has_nothing_to_explain(tmp_path, capsys):
    # the 2 kg bracket (24-bit cards at 25.6 kHz, pre_trigger = 0, an elliptic front end): its
    # records start at the trigger, 10 % of the way up the hit, so the force before the first sample
    # and the response to it are not in the model's input. A perfect model's residual rang at the
    # bracket's 306 Hz mode, 0.2 % of the response (noise-free), and charge_x (50 mV/g, the quietest
    # channel) read 3.4-3.9x its floor there: 'unexplained'. The floor now counts that force
    rig = Path(__file__).resolve().parents[1] / "data" / "rigs" / "stiff-bracket.toml"
    p = tmp_path / "b.h5"
    run(capsys, "new", p, "--rig", rig)
    for force in (5, 30, 150):
        run(capsys, "acquire", p, "--name", f"hit{force}", "--force-point=30,20,100", "--force-dir=-0.3,0,-1",
            "--force-peak", force, "--samples", "8192", "--seed", force)
    run(capsys, "process", p)
    cmp = json.loads(run(capsys, "compare", p, "--json"))
    assert sum("the record starts inside its hit" in n for n in cmp["notes"]) == 3, cmp["notes"]
    d = json.loads(run(capsys, "diagnose", p, "--json"))
    assert d["verdict"] == "nothing to explain", d["message"]
    assert not [c["effect"] for c in d["candidates"] if c.get("significant")]
