"""`odsuite model` shows the fitted parameters with their units and meaning, not only the modes."""

from __future__ import annotations

import json

from odsuite.cli import main


def run(capsys, *args) -> str:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


def test_model_lists_each_effects_parameters(capsys, tmp_path):
    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    run(capsys, "acquire", p, "--name", "T1", "--samples", "2048", "--scenario", "T1", "--seed", "2")
    run(capsys, "process", p)
    run(capsys, "add-effect", p, "damping")
    report = json.loads(run(capsys, "model", p, "--json"))
    values = report["parameters"]["damping"]
    assert report["parameter_info"]["damping"]["scale_x"]["description"].startswith("damping along x")
    text = run(capsys, "model", p)
    assert "parameters" in text and "damping along x" in text
    assert f"{values['scale_x']:.6g}" in text
