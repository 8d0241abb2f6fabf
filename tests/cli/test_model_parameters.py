"""`odsuite model` shows the fitted parameters with their units and meaning, not only the modes."""

from __future__ import annotations

import json
import re

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


def test_model_and_history_read_at_80_columns(capsys, tmp_path, monkeypatch):
    """Plain text tables: within 80 columns where the words allow, each value on one line with its
    unit, the same numbers as --json."""
    import sys

    monkeypatch.setattr(sys.modules["odsuite.cli.app"].console, "width", 80)
    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    run(capsys, "acquire", p, "--name", "T1", "--samples", "2048", "--scenario", "T1", "--seed", "2")
    run(capsys, "process", p)
    run(capsys, "add-effect", p, "damping")
    report = json.loads(run(capsys, "model", p, "--json"))
    text = run(capsys, "model", p)
    rows = text.splitlines()
    cells = [re.split(r"\s{2,}", line) for line in rows]
    for name, value in report["parameters"]["damping"].items():
        unit = report["parameter_info"]["damping"][name].get("unit") or "-"
        assert ["damping", name, f"{value:.6g}", unit] in [c[:4] for c in cells], name
    for i, m in enumerate(report["modes"], 1):
        assert f"{i:<4}  {m['frequency_hz']:.2f}" in text
    longest_word = max(len(w) for w in text.split())
    assert max(len(line) for line in rows) <= max(80, longest_word)
    doc = json.loads(run(capsys, "history", p, "--json"))
    text = run(capsys, "history", p)
    for r in doc["revisions"]:
        assert any(line.split()[:1] == [str(r["revision"])] and f"{r['error']:.4f}" in line
                   for line in text.splitlines()), r
