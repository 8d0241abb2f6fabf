"""`odsuite model` shows the fitted parameters with their units and meaning, not only the modes."""

from __future__ import annotations

import json
import re

import pytest

from odsuite.cli import main
from tests.cli.clirun import run_ok as run


def damped_project(capsys, tmp_path):
    """A processed one-hit project with the damping effect added (revision 1)."""
    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    run(capsys, "acquire", p, "--name", "T1", "--samples", "2048", "--scenario", "T1", "--seed", "2")
    run(capsys, "process", p)
    run(capsys, "add-effect", p, "damping")
    return p


def test_model_lists_each_effects_parameters(capsys, tmp_path):
    p = damped_project(capsys, tmp_path)
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
    p = damped_project(capsys, tmp_path)
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
    # each spring's effective damping as stored with the revision, in N s/m, with the rig's value
    physical = report["physical"]["damping"]
    assert physical and all(r["unit"] == "N s/m" and r["nominal"] > 0 for r in physical)
    for r in physical:
        assert [r["label"], f"{r['value']:.5g}"] in [c[1:3] for c in cells if c[0] == "damping"], r["label"]
    doc = json.loads(run(capsys, "history", p, "--json"))
    text = run(capsys, "history", p)
    for r in doc["revisions"]:
        assert any(line.split()[:1] == [str(r["revision"])] and f"{r['error']:.4f}" in line
                   for line in text.splitlines()), r


def test_physical_quantities_read_in_engineering_units():
    from odsuite.cli.project_commands import _engineering

    assert _engineering(262000.0, 324.1, 262000.0, "N/m") == ["262", "0.32", "262", "kN/m"]
    assert _engineering(1.64e7, 2.5e4, 1.26e7, "N/m") == ["16.4", "0.025", "12.6", "MN/m"]
    assert _engineering(350.0, None, 400.0, "N s/m") == ["350", "-", "400", "N s/m"]
    assert _engineering(37.7, 0.12, None, "kg") == ["37.7", "0.12", "-", "kg"]
    assert _engineering(0.98, 0.01, 1.0, "1") == ["0.98", "0.01", "1", "-"]


def test_add_effect_prints_each_members_fitted_values(capsys, tmp_path):
    # a pair's add-effect printed no parameter, and an effect without physical quantities (a gain) none
    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    run(capsys, "acquire", p, "--name", "T1", "--samples", "2048", "--scenario", "T1", "--seed", "2")
    run(capsys, "process", p)
    out = run(capsys, "add-effect", p, "force_gain")
    gain = json.loads(run(capsys, "model", p, "--json"))["parameters"]["force_gain"]["gain"]
    assert f"force_gain: gain = {gain:.6g}" in out
    out = run(capsys, "add-effect", p, "damping+sensor_gain")
    assert re.search(r"^damping: .*damping", out, re.M) and re.search(r"^sensor_gain: ", out, re.M), out


@pytest.mark.parametrize("pair, message", [
    ("force_gain+forse_gain", "unknown effect 'forse_gain'"),
    ("force_gain+", "unknown effect ''"),
    # known, but not for this model: found after the first member was fitted and stored
    ("force_gain+beam-mass-scale", "effect 'beam-mass-scale' does not apply to this model"),
])
def test_a_pair_that_fails_leaves_the_project_as_it_was(capsys, tmp_path, pair, message):
    # the pair's first member was stored and made current before the second failed (exit 1)
    from odsuite.cli import main

    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    run(capsys, "acquire", p, "--name", "T1", "--samples", "2048", "--scenario", "T1", "--seed", "2")
    run(capsys, "process", p)
    before = p.read_bytes()
    assert main(["add-effect", str(p), pair]) == 1
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert p.read_bytes() == before


def test_an_undamped_models_damping_ratios_print_as_zero(capsys, tmp_path):
    """Springs with damping [0, 0, 0]: the modes listed damping ratio -0.0000 (and -0.0 in --json)."""
    from tests.core.test_comparison import SLAB_RIG

    (tmp_path / "slab.toml").write_text(re.sub(r"damping = \[.*\]", "damping = [0.0, 0.0, 0.0]", SLAB_RIG))
    run(capsys, "new", tmp_path / "p.h5", "--rig", tmp_path / "slab.toml")
    text = run(capsys, "model", tmp_path / "p.h5")
    rows = [ln.split() for ln in text.splitlines() if re.match(r"^[123] ", ln)]
    assert [r[2] for r in rows] == ["0.0000"] * 3, text
    modes = json.loads(run(capsys, "model", tmp_path / "p.h5", "--json"))["modes"]
    assert [str(m["damping_ratio"]) for m in modes] == ["0.0"] * 3


def test_adding_an_effect_the_model_holds_refits_it_and_says_so(capsys, tmp_path):
    """A second `add-effect damping` stored another revision with the same effects and no word; it
    still refits (as every addition refits all effects), and one note says so."""
    p = damped_project(capsys, tmp_path)
    code = main(["add-effect", str(p), "damping"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert out.count("damping is in revision 1 already: it was refitted with the others, and the new") == 1, out
    doc = json.loads(run(capsys, "model", p, "--json"))
    assert doc["revision"] == 2 and [e for e in doc["parameters"]] == ["damping"]


def test_a_pair_naming_one_effect_twice_is_refused(capsys, tmp_path):
    """`add-effect P damping+damping` stored two revisions of the one effect."""
    p = damped_project(capsys, tmp_path)
    before = p.read_bytes()
    assert main(["add-effect", str(p), "damping+damping"]) == 1
    _, err = capsys.readouterr()
    assert err == f"error: {p}: effect 'damping+damping' names 'damping' twice; a model holds it once (give 'damping')\n"
    assert p.read_bytes() == before


def test_a_rising_trigger_at_a_negative_level_is_noted(capsys, tmp_path):
    """--trigger-level -1 with the rising slope ran without a word; it is kept (a level below every
    signal fires at once, which tests use) with one note."""
    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    assert main(["acquire", str(p), "--name", "T1", "--samples", "2048", "--trigger-level", "-1"]) == 0
    _, err = capsys.readouterr()
    assert err.count("note: --trigger-level -1 N with the rising slope is at or below the force at rest (0 N)") == 1
    assert main(["acquire", str(p), "--name", "T2", "--samples", "2048", "--trigger-level", "-1",
                 "--trigger-slope", "falling"]) == 0
    assert "note" not in capsys.readouterr().err


def test_add_effect_that_stays_at_its_nominal_values_prints_them(capsys, tmp_path, monkeypatch):
    # the LADISK beam's sensor mass fitted 0 g, its nominal: add-effect printed
    # "beam-sensor-mass:  (1 more: `odsuite model copy.h5`)", an empty list and a count
    from odsuite.diagnosis import add_effect

    p = tmp_path / "p.h5"
    run(capsys, "new", p)
    row = {"label": "mass of each accelerometer", "value": 0.0, "unit": "g", "uncertainty": 0.18, "nominal": 0.0}
    result = {"revision": 7, "previous_error": 0.3141, "error": 0.3141, "noise_floor_error": 0.0098,
              "effects": [{"effect": "beam-sensor-mass", "values": {"mass": 0.0}, "physical": [row]}],
              "warnings": [], "notes": []}
    monkeypatch.setattr(add_effect, "add_effect", lambda project, name, progress=None: result)
    out = run(capsys, "add-effect", p, "beam-sensor-mass")
    line = next(ln for ln in out.splitlines() if ln.startswith("beam-sensor-mass:"))
    assert "mass of each accelerometer = 0 ± 0.18 g" in line and "more" not in line, out
