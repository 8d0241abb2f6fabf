"""`odsuite demo`: the loop finds both effects hidden in the simulated rig and the error falls in
every round; the summary's spring totals match a hand sum over the springs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from odsuite.contracts.plugins import registries
from odsuite_plugins.demo.story import HIDDEN_EFFECTS, PROJECT_NAME, effective_scales


def test_spring_totals_are_the_hand_summed_stiffness_ratios(thesis_rig):
    model = registries().models.get("thesis-dynamometer")(thesis_rig)
    k = np.array([s.stiffness for s in model.springs], dtype=float)  # springs x axes
    first = model.springs[0].name
    got = effective_scales("stiffness", {"scale_z": 1.2, f"scale_{first}": 1.5}, model)
    weights = np.ones(len(k))
    weights[0] = 1.5
    expected = np.array([1.0, 1.0, 1.2]) * (weights @ k) / k.sum(axis=0)
    assert [got["total_x"], got["total_y"], got["total_z"]] == pytest.approx(expected, rel=1e-12)
    # an effect that is not a spring scale is summarised by its own values
    assert effective_scales("force_gain", {"gain": 1.1}, model) == {"gain": 1.1}


@pytest.mark.slow
def test_demo_finds_both_hidden_effects_and_the_error_falls_each_round(tmp_path, capsys, monkeypatch):
    from odsuite.cli import main
    from odsuite.analysis.history import history
    from odsuite.analysis.modelrev import current_revision
    from odsuite.store.project import open_project

    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    with open_project(out / PROJECT_NAME) as p:
        hist = history(p)
        rev = current_revision(p)
        base = registries().models.get(p.rig.default_model)(p.rig)

    errors = [r["error"] for r in hist["revisions"]]
    assert len(errors) == 3
    assert errors[1] < 0.7 * errors[0] and errors[2] < 0.7 * errors[1], errors
    assert errors[2] < 0.05
    found = {e["effect"]: e["values"] for e in rev["effects"]}
    assert set(found) == {name for name, _ in HIDDEN_EFFECTS}

    # the values found against the hidden truth (the simulator's own parameters)
    totals = effective_scales("stiffness", found["stiffness"], base)
    assert totals["total_z"] == pytest.approx(1.3, abs=0.02)
    assert totals["total_x"] == pytest.approx(1.0, abs=0.03)
    assert totals["total_y"] == pytest.approx(1.0, abs=0.03)
    flex = found["plate_flexibility"]
    assert flex["frequency_hz"] == pytest.approx(640.0, abs=2.0)
    assert flex["damping_ratio"] == pytest.approx(0.02, abs=0.002)
    assert flex["twist"] == pytest.approx(0.4, rel=0.05)

    truth = json.loads((out / "hidden-truth.json").read_text())
    assert {e["effect"]: e["values"] for e in truth["effects"]} == dict(HIDDEN_EFFECTS)
    assert (out / "history.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    movies = list(out.glob("T*.mp4")) + list(out.glob("T*.gif"))
    assert len(movies) == 1 and movies[0].stat().st_size > 10_000
    report = out / "report.html"
    assert report.exists() and "<html" in report.read_text()[:500].lower()
    assert "both hidden effects found" in text
    # a channel at its input limits is said to be left out of its experiment's comparison
    assert "input limits: none" in text or "left out of its experiment's comparison" in text
    # the narrative wraps at the console's width (80 when piped); only a lone path may run over
    assert not [ln for ln in text.splitlines() if len(ln) > 80 and len(ln.split()) > 2]
    # each revision's error printed as the history figure labels it (four decimals: 0.0134, not 0.013)
    assert " -> ".join(f"{e:.4f}" for e in errors) in text

    # the project's summaries at 80 columns (a terminal that wide, or piped): `model`'s table was 94
    from odsuite import cli

    monkeypatch.setattr(cli.console, "width", 80)
    project = str(out / PROJECT_NAME)
    for command in (["model"], ["history"], ["info"], ["compare"], ["diagnose", "--workers", "1"]):
        assert main([command[0], project, *command[1:]]) == 0
        lines = capsys.readouterr().out.splitlines()
        assert max(len(line) for line in lines) <= 80, (command, [ln for ln in lines if len(ln) > 80])


def test_the_candidates_table_prints_no_split_of_factors_and_fits_80_columns():
    """The demo's table of candidates: the fitted factors of a scale per axis times one per spring
    are a split the data do not determine; they are not printed (the determined stiffness in N/m is,
    with each effect added), and the table fits an 80-column terminal without folding."""
    import io

    from rich.console import Console

    from odsuite_plugins.demo.story import _print_candidates

    stiffness = {"effect": "stiffness", "significant": True, "error_after": 0.1505, "validated_error": 0.1506,
                 "parameters": {"scale_x": 0.946, "scale_y": 0.941, "scale_z": 1.21, "scale_spring1": 1.07}}
    pair = {**stiffness, "effect": "stiffness+plate_flexibility", "error_after": 0.0134, "validated_error": 0.0155,
            "parameters": {"stiffness.scale_x": 0.957, "plate_flexibility.frequency_hz": 640.0}}
    out = io.StringIO()
    _print_candidates(Console(file=out, width=80), {"revision": 0, "candidates": [pair, stiffness]})
    text = out.getvalue()
    assert "scale_" not in text and "0.946" not in text
    rows = [line for line in text.splitlines() if "stiffness" in line]
    assert len(rows) == 2 and all(len(line) <= 80 for line in text.splitlines())
    # the title is a line of its own, not folded at the narrow table's width
    assert "candidate effects, best first (errors after the fit)" in text


def test_a_narrative_line_wraps_at_the_console_width_without_breaking_a_path():
    import io

    from rich.console import Console

    from odsuite_plugins.demo.story import _say

    path = "/a/rather/long/directory/name/that/holds/the/demo/output/of/this/run/report.html"
    out = io.StringIO()
    _say(Console(file=out, width=80), f"  report: {path} (6 sections, 14 figures; the residual by band and "
                                      "channel, the candidates and the verdict)")
    lines = out.getvalue().splitlines()
    assert len(lines) >= 3 and all(len(ln) <= 80 or ln.split() == [path] for ln in lines)
    assert path in lines[1] and all(ln.startswith("    ") for ln in lines[1:])  # under the first line
    assert " ".join(" ".join(lines).split()).startswith(f"report: {path} (6 sections")


def _demo_refuses(args, capsys) -> str:
    from odsuite.cli import main

    assert main(["demo", *args]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


def test_the_demo_leaves_a_folder_it_did_not_write_as_it_is(tmp_path, capsys):
    # a user's own project named demo.h5 (read-only too) was replaced by the demo's
    lab = tmp_path / "lab"
    lab.mkdir()
    mine = lab / PROJECT_NAME
    mine.write_bytes(b"my project")
    mine.chmod(0o444)
    assert "did not write" in _demo_refuses(["--out", str(lab)], capsys)
    assert mine.read_bytes() == b"my project" and sorted(p.name for p in lab.iterdir()) == [PROJECT_NAME]
    # a file, a link to nothing, a folder where the demo writes its project: one line each
    (tmp_path / "notes.txt").write_text("notes\n")
    assert "not a folder" in _demo_refuses(["--out", str(tmp_path / "notes.txt")], capsys)
    (tmp_path / "gone").symlink_to(tmp_path / "nowhere")
    assert "link to nothing" in _demo_refuses(["--out", str(tmp_path / "gone")], capsys)
    ours = tmp_path / "ours"
    ours.mkdir()
    (ours / ".odsuite-demo").write_text("")
    (ours / PROJECT_NAME).mkdir()
    assert "not a file the demo wrote" in _demo_refuses(["--out", str(ours)], capsys)
    assert (ours / PROJECT_NAME).is_dir()


def test_the_demo_takes_back_its_own_folder(tmp_path):
    from odsuite_plugins.demo.story import MARKER, OUTPUTS, _demo_folder

    earlier = tmp_path / "demo-output"  # an earlier version's outputs, without the marker
    earlier.mkdir()
    for name in (*OUTPUTS, "T6.mp4"):
        (earlier / name).write_text("old")
    _demo_folder(earlier)
    assert (earlier / MARKER).is_file() and not (earlier / PROJECT_NAME).exists()
    assert (earlier / "report.html").read_text() == "old"  # replaced when the demo writes it
    fresh = tmp_path / "new" / "folder"
    _demo_folder(fresh)
    assert sorted(p.name for p in fresh.iterdir()) == [MARKER]


def test_ctrl_c_during_the_demo_names_the_folder_it_wrote(tmp_path, capsys, monkeypatch):
    # the command line's own line said "interrupted: nothing stored" while the folder held the
    # marker and what the demo had written so far: a plugin's command says what it leaves
    from odsuite.cli import main
    from odsuite_plugins.demo import story

    import signal

    def interrupted(path, console, started):
        path.write_bytes(b"half a project")
        signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(story, "_recorded_project", interrupted)
    out = tmp_path / "out"
    assert main(["demo", "--out", str(out)]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"interrupted: {out} holds what the demo wrote so far; run it again to replace it"], err
    # the next command's Ctrl-C is its own again
    assert main(["info", str(tmp_path / "none.h5")]) != 0
    from odsuite.contracts.interrupts import said_on_interrupt

    assert said_on_interrupt() is None
