"""import-uff / export-uff through the command line: a round trip and one-line refusals."""

from __future__ import annotations

import numpy as np

from odsuite.cli import main
from odsuite.analysis.modal_project import physical
from odsuite.store.project import open_project
from odsuite_plugins.importers.uff import read_uff


def test_export_then_import_through_the_cli(tmp_path, capsys):
    p, q, uff = tmp_path / "p.h5", tmp_path / "q.h5", tmp_path / "e1.uff"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--daq", "sim", "--name", "e1", "--samples", "1024"]) == 0
    assert main(["export-uff", str(p), "-o", str(uff), "--nodes", "2411"]) == 0
    assert read_uff(uff).dataset_types[:2] == [164, 2411]  # SI units first, then the nodes
    assert main(["new", str(q), "--rig", "none"]) == 0
    assert main(["import-uff", str(q), str(uff), "--name", "back"]) == 0
    with open_project(p) as a, open_project(q) as b:
        np.testing.assert_array_equal(physical(b.experiment("back")), physical(a.experiment("e1")))
    assert "imported" in capsys.readouterr().out


def test_refusals_are_one_line(tmp_path, capsys):
    q = tmp_path / "q.h5"
    assert main(["new", str(q), "--rig", "none"]) == 0
    before = q.read_bytes()
    (tmp_path / "notes.uff").write_text("not a universal file\n")
    capsys.readouterr()
    assert main(["import-uff", str(q), str(tmp_path / "notes.uff"), "--name", "x"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == f"error: {tmp_path / 'notes.uff'}: no UFF datasets found (not a UFF file, or cut short)"
    assert main(["export-uff", str(q), "-o", str(tmp_path / "o.uff")]) == 1
    assert capsys.readouterr().err.strip() == f"error: {q}: name the experiment to export (experiments: none)"
    assert q.read_bytes() == before
