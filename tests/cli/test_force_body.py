"""A force point on two bodies (a machine standing on its base): refused until the experimenter says
which body was hit; the named body is stored and drives the model."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.clirun import run

RIG_FILE = Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml"


@pytest.fixture
def stacked(tmp_path) -> Path:
    """The two-body rig with the machine's box standing on the base's top face (z = 50 mm)."""
    text = RIG_FILE.read_text().replace("corner = [-0.15, -0.1, 0.1]", "corner = [-0.15, -0.1, 0.05]", 1)
    assert "corner = [-0.15, -0.1, 0.05]" in text
    path = tmp_path / "stacked.toml"
    path.write_text(text)
    return path


def test_a_point_on_two_bodies_needs_the_body_and_the_named_body_drives_the_model(capsys, tmp_path, stacked):
    p = tmp_path / "p.h5"
    assert run(capsys, "new", p, "--rig", stacked)[0] == 0
    hit = ["--force-point=0,0,50", "--force-dir=-z", "--rate", "5120", "--samples", "2048", "--pretrigger", "256"]
    code, _, err = run(capsys, "acquire", p, "--name", "a", *hit, "--seed", "1")
    assert code == 1 and "'base' and 'machine'" in err and "--force-body" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, "acquire", p, "--name", "a", *hit, "--force-body", "floor", "--seed", "1")
    assert code == 1 and "no moving body 'floor'" in err, err
    for body in ("machine", "base"):
        code, _, err = run(capsys, "acquire", p, "--name", body, *hit, "--force-body", body, "--seed", "1")
        assert code == 0, err
    info = json.loads(run(capsys, "info", p, "--json")[1])
    assert {n: e["excitation"]["body"] for n, e in info["experiments"].items()} == {"machine": "machine",
                                                                                   "base": "base"}
    assert run(capsys, "process", p)[0] == 0
    code, out, err = run(capsys, "compare", p, "--json")
    assert code == 0, err
    result = json.loads(out)
    # the model is the truth: hit on the body each record names (the point alone is refused), the
    # prediction is within the noise on the vertical channels that carry the blow
    for name, e in result["experiments"].items():
        assert e["error"] <= 1.5 * e["noise_floor_error"], (name, e)
        vertical = [v for ch, v in e["channels"].items() if ch.endswith("_z")]
        assert max(vertical) < 0.6, (name, e["channels"])
