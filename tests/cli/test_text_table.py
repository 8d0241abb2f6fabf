"""Plain aligned-text tables (``info``): within the console's width where the cells allow, a cell
wrapped after its commas only (a name, or a number with its unit, never split), columns aligned."""

from __future__ import annotations

import json

from odsuite import cli
from odsuite.cli import main
from odsuite.cli.text_table import text_table


def _dashes(lines: list[str]) -> int:
    return next(i for i, line in enumerate(lines) if line and set(line) == {"-", " "})


def _cells(text: str, starts: list[int], row: int) -> list[str]:
    """The cells of data row ``row`` read back from the text: its lines cut at the columns' starts,
    a wrapped cell's lines joined as they were split."""
    lines = text.splitlines()
    lines = lines[_dashes(lines) + 1:]
    rows: list[list[str]] = []
    for line in lines:
        parts = [line[a:b].rstrip() for a, b in zip(starts, [*starts[1:], None])]
        if parts[0]:
            rows.append(parts)
        else:  # a continuation line: each part goes on with its column
            rows[-1] = [f"{old} {new}" if new else old for old, new in zip(rows[-1], parts)]
    return rows[row]


def test_a_wide_table_wraps_after_commas_within_the_width():
    rows = [["spring1", "platform - ground", "-29.99, 49.79, 10.7", "262, 262, 1260", "140, 125, 275"],
            ["a-very-long-unbreakable-name", "x - y", "1, 2, 3", "4, 5, 6", "7, 8, 9"]]
    columns = ["spring", "between", "at (mm)", "k x, y, z (kN/m)", "c x, y, z (N s/m)"]
    natural = text_table("springs", columns, rows, width=1000)
    assert max(len(line) for line in natural.splitlines()) == 28 + 17 + 19 + 16 + 17 + 8  # one line each
    text = text_table("springs", columns, rows, width=80)
    lines = text.splitlines()
    dashes = lines[_dashes(lines)]
    assert lines[0] == "springs" and _dashes(lines) > 2  # a header wrapped at its spaces
    assert max(len(line) for line in lines) <= 80
    starts = [0] + [i + 3 for i, (a, b) in enumerate(zip(dashes, dashes[1:])) if a == "-" and b == " "]
    assert len(starts) == 5
    for i, row in enumerate(rows):  # nothing lost, nothing split but after a comma
        assert _cells(text, starts, i) == row
    assert "platform - ground" in text and "a-very-long-unbreakable-name" in text


def test_cells_that_cannot_break_keep_the_table_as_narrow_as_they_allow():
    text = text_table("t", ["name", "peak"], [["n" * 50, "4.991 m/s^2 (z1)"]], width=40)
    assert text.splitlines()[3] == "n" * 50 + "  4.991 m/s^2 (z1)"


def test_info_reads_at_80_columns(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli.console, "width", 80)
    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"], ["process", p]):
        assert main([str(a) for a in argv]) == 0
    capsys.readouterr()
    assert main(["info", str(p), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{p}  format ")  # the path on a line of its own, whole
    assert max(len(line) for line in out.splitlines()[1:]) <= 80
    e = doc["experiments"]["T1"]
    # a hammer record's peak is its force's (one kind per column)
    channel = next(c for c in e["peak"] if e["peak"][c][1] == "N")
    value, unit = e["peak"][channel]
    row = next(line for line in out.splitlines() if line.startswith("T1 "))
    # the peak with its unit and channel on the row's first line, the clipped count beside it
    assert f"{value:.4g} {unit} ({channel})" in row and str(e["n_samples"]) in row
    assert f"{doc['model_revisions'][0]['error']:.4f}" in out
    for s in doc["rig_layout"]["springs"]:
        assert f"{s['name']}  {s['body']} - {s['other']}" in out


def test_a_column_of_prose_wraps_at_its_spaces():
    """`model`'s parameters: the meaning is prose and wraps at its spaces (the table ran 94 wide at
    80 columns); the names and numbers beside it stay whole."""
    rows = [["spring_stiffness", "scale_soft2", "0.659167", "1", "stiffness of soft2, every axis, a meaning that "
             "runs on past the edge of an eighty-column terminal"],
            ["mass_properties", "dm", "-0.0123", "kg", "mass added to the body"]]
    columns = ["effect", "parameter", "value", "unit", "meaning"]
    text = text_table("parameters", columns, rows, width=80, prose=("meaning",))
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 80 and len(lines) > 5
    dashes = lines[_dashes(lines)]
    starts = [0] + [i + 3 for i, (a, b) in enumerate(zip(dashes, dashes[1:])) if a == "-" and b == " "]
    for i, row in enumerate(rows):
        assert _cells(text, starts, i) == row
    # without prose the meaning breaks after its commas only, and the table stays wider
    assert max(len(line) for line in text_table("parameters", columns, rows, width=80).splitlines()) > 80
