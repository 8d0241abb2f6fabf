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

RIG = Path(__file__).resolve().parents[1] / "data" / "rigs" / "undamped-block.toml"


def run(capsys, *args) -> str:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


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
