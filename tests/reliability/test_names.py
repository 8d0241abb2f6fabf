"""Names are data: rich markup, escape sequences and undecodable bytes in names and paths never
crash a command and are printed as themselves, escaped where not printable."""

from __future__ import annotations

import pytest

from odsuite import cli
from odsuite.cli import main, shown
from tests.reliability.test_bad_input import LVM_TEXT

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")


def test_shown_escapes_only_what_is_not_printable():
    assert shown("[red]a[/x]") == "[red]a[/x]"
    assert shown("a\nb\x1b[31m") == "a\\nb\\x1b[31m"
    assert shown("x\udcff") == "x\\xff"  # the byte 0xff as argv or a file name delivers it
    assert shown("Ω ²") == "Ω ²"


def test_markup_names_are_stored_and_printed_verbatim(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli.console, "_width", 250)  # whole names in the table's cells
    project = str(tmp_path / "[bold]p.h5")
    assert main(["new", project]) == 0
    assert main(["acquire", project, "--name", "[red]hit", "--samples", "1024", "--pretrigger", "100"]) == 0
    lvm = tmp_path / "beam.lvm"
    lvm.write_text(LVM_TEXT.replace("X_Value\tForce\tResponse", "X_Value\tForce\t[/x]"))
    assert main(["import-lvm", project, str(lvm), "--name", "[/b]"]) == 1  # '/' is refused as a name
    assert main(["import-lvm", project, str(lvm), "--name", "[b]lvm"]) == 0
    capsys.readouterr()
    assert main(["info", project]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert "[bold]p.h5" in out and "[red]hit" in out and "[b]lvm" in out
    assert main(["process", project, "--experiment", "[red]hit"]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("[red]hit: ")


def test_undecodable_and_escape_paths_print_escaped(tmp_path, capsys):
    project = tmp_path / "p\udcff\x1b[2J.h5"
    assert main(["new", str(project)]) == 0
    out, _ = capsys.readouterr()
    assert "p\\xff\\x1b[2J.h5" in out and "\x1b" not in out
    assert main(["info", str(tmp_path / "no\nsuch.h5")]) == 1
    _, err = capsys.readouterr()
    assert err.count("\n") == 1 and "no\\nsuch.h5: no such project file" in err
