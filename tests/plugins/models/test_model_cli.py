"""`odsuite model PROJECT --json`: the current revision's model and its modes."""

from __future__ import annotations

import json

import numpy as np
from odsuite_plugins.models import thesis_dynamometer

from odsuite.cli import main
from odsuite.store.project import create_project, open_project


def run_json(capsys, *args) -> dict:
    assert main(["model", *map(str, args), "--json"]) == 0
    out = capsys.readouterr().out
    return json.loads(out)


def test_model_json_of_a_new_project_is_the_rig_default(tmp_path, capsys, thesis_rig):
    path = tmp_path / "p.h5"
    create_project(path).close()
    doc = run_json(capsys, path)
    assert doc["revision"] == 0 and doc["effects"] == [] and doc["parameters"] == {}
    f = [m["frequency_hz"] for m in doc["modes"]]
    ref = thesis_dynamometer(thesis_rig).modes()
    assert len(f) == 6 and f == sorted(f)
    assert np.allclose(f, ref.frequency_hz, rtol=1e-12)
    assert np.allclose([m["damping_ratio"] for m in doc["modes"]], ref.damping_ratio, rtol=1e-12)


def test_model_json_follows_the_current_revision(tmp_path, capsys):
    path = tmp_path / "p.h5"
    create_project(path).close()
    base = run_json(capsys, path)
    with open_project(path, "a") as p:
        p.add_model_revision([{"effect": "stiffness", "values": {"scale_x": 1.21, "scale_y": 1.21, "scale_z": 1.21}},
                              {"effect": "damping", "values": {"scale_x": 1.1, "scale_y": 1.1, "scale_z": 1.1}}],
                             {}, {}, None)
    doc = run_json(capsys, path)
    assert doc["revision"] == 1 and doc["effects"] == ["stiffness", "damping"]
    assert doc["parameters"]["damping"] == {"scale_x": 1.1, "scale_y": 1.1, "scale_z": 1.1}
    assert np.allclose([m["frequency_hz"] for m in doc["modes"]],
                       [1.1 * m["frequency_hz"] for m in base["modes"]], rtol=1e-12)


def test_model_errors_are_one_line(tmp_path, capsys):
    path = tmp_path / "p.h5"
    create_project(path).close()
    with open_project(path, "a") as p:
        p.add_model_revision([{"effect": "stiffness", "values": {"scale_q": 2.0}}], {}, {}, None)
    assert main(["model", str(path), "--json"]) == 1
    captured = capsys.readouterr()
    assert "scale_q" in captured.err and len(captured.err.strip().splitlines()) == 1
    # --json: the same line as the one JSON document on stdout
    assert json.loads(captured.out) == {"error": captured.err.strip().removeprefix("error: ")}


def test_model_without_rig_is_refused(tmp_path, capsys):
    path = tmp_path / "p.h5"
    create_project(path, None).close()
    assert main(["model", str(path)]) == 1
    assert "no model" in capsys.readouterr().err
