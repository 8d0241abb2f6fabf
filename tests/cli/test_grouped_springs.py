"""A worn mount among like mounts (the rig file groups them: `group = "rubber"`), through the
command line on the shipped example rig: the stiffness effect scales a group together as declared,
so only `spring_stiffness` (each spring on its own, fitted from stiffness's fit) can say which
mount changed. Reference: the truth rig file, edited by hand (rubber2 40 % softer)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.clirun import run_ok as run

RIG = Path(__file__).resolve().parents[2] / "examples" / "rigs" / "plate-and-motor.toml"
HITS = [("0,0,75", "-z"), ("250,150,75", "-z"), ("-250,-100,75", "-z"), ("0,200,60", "-y")]
EFFECTS = ["stiffness", "spring_stiffness", "mass_properties"]


def test_a_softer_mount_of_a_group_is_found_and_fixed(capsys, tmp_path):
    text = RIG.read_text()
    head, rest = text.split('name = "rubber2"', 1)
    nominal = "stiffness = [60000.0, 60000.0, 250000.0]"
    assert nominal in rest.split("[[springs]]", 1)[0] and 'group = "rubber"' in rest.split("[[springs]]", 1)[0]
    truth = tmp_path / "worn.toml"
    truth.write_text(head + 'name = "rubber2"' + rest.replace(nominal, "stiffness = [36000.0, 36000.0, 150000.0]", 1))
    p = tmp_path / "p.h5"
    run(capsys, "new", p, "--rig", RIG)
    for k, (point, direction) in enumerate(HITS):
        run(capsys, "acquire", p, "--name", f"h{k}", f"--force-point={point}", f"--force-dir={direction}",
            "--seed", k + 1, "--truth", truth)
    run(capsys, "process", p)
    effects = [a for e in EFFECTS for a in ("--effect", e)]
    d = json.loads(run(capsys, "diagnose", p, *effects, "--json"))
    top = d["candidates"][0]
    assert top["effect"] == "spring_stiffness" and top["significant"] and d["verdict"] == "explained", (
        [(c["effect"], c["significant"], c["error_after"]) for c in d["candidates"]], d["verdict"])
    assert not d["signature"]["amplitude_dependent"]
    found = {(q["label"]): q["value"] for q in top["physical"]}
    # the worn mount at its true stiffness, its like neighbours at theirs
    assert found["stiffness of rubber2 along z"] == pytest.approx(150000.0, rel=0.03)
    assert found["stiffness of rubber2 along x"] == pytest.approx(36000.0, rel=0.03)
    assert found["stiffness of rubber1 along z"] == pytest.approx(250000.0, rel=0.03)
    run(capsys, "add-effect", p, "spring_stiffness")
    after = json.loads(run(capsys, "diagnose", p, *effects, "--json"))
    assert after["verdict"] == "nothing to explain"
    assert not any(c["significant"] for c in after["candidates"])
