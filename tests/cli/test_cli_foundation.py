"""`odsuite new`, `info`, `import-legacy`, `export-legacy` through the CLI entry point."""

from __future__ import annotations

import hashlib
import subprocess
import sys

import numpy as np
import pytest

from odsuite import cli
from odsuite_plugins.importers.legacy import read_cod, write_dat
from odsuite.store.project import DerivedArray, open_project
from tests.cli.clirun import run
from tests.conftest import REPO
from tests.core.test_legacy_import import legacy_volts
from tests.core.test_systeminfo import TABLE_E3

RIG_TOML = REPO / "plugins" / "models" / "rigs" / "thesis-dynamometer.toml"


@pytest.fixture(autouse=True)
def wide_console(monkeypatch):
    # one table row per line, whatever terminal the tests run in
    monkeypatch.setattr(cli.console, "width", 200)


@pytest.fixture
def legacy_dat(tmp_path):
    data = legacy_volts()
    data[700:710, 7] = 0.5  # y2 at its +0.5 V DAQ limit (Table E.3 row 19)
    write_dat(tmp_path / "T5.DAT", data)
    return tmp_path / "T5.DAT"


def _import(capsys, project, dat, name="T5", point="--force-point=50.025,-75.761,-6.320", direction="--force-dir=-x"):
    return run(capsys, "import-legacy", project, dat, "--systeminfo", TABLE_E3, "--name", name, point, direction)


def test_new_import_info(tmp_path, capsys, legacy_dat):
    project = tmp_path / "p.h5"
    code, out, _ = run(capsys, "new", project)
    assert code == 0 and "rig: thesis-dynamometer" in out
    code, out, err = _import(capsys, project, legacy_dat)
    assert code == 0, err
    assert "imported" in out and "'T5'" in out
    assert "warning:" in err and "sensor type 6" in err and "clipped" in err and "y2 (10 samples)" in err
    # the negative vector may also follow the option as a separate word
    code, _, err = run(capsys, "import-legacy", project, legacy_dat, "--systeminfo", TABLE_E3, "--name", "T6",
                       "--force-point", "-37.325,-68.141,-11.4", "--force-dir", "+z")
    assert code == 0, err
    with open_project(project) as p:
        np.testing.assert_allclose(p.experiment("T6").excitation.point, [-0.037325, -0.068141, -0.0114])
        np.testing.assert_array_equal(p.experiment("T5").excitation.direction, [-1.0, 0.0, 0.0])
    code, out, err = run(capsys, "info", project)
    assert code == 0, err
    assert "thesis-dynamometer" in out
    lines = [line for line in out.splitlines() if "T5" in line]
    assert lines and "11" in lines[0] and "20000" in lines[0] and "2048" in lines[0] and "y2 (10)" in lines[0]
    # the peak in the channel's unit: the hammer pulse (0.8 V raw) in N through the force sensitivity
    assert "35.64 N (force)" in lines[0]
    assert "revision" in out


def test_new_with_rig_file_and_none(tmp_path, capsys):
    code, out, err = run(capsys, "new", tmp_path / "a.h5", "--rig", RIG_TOML)
    assert code == 0, err
    assert "rig: thesis-dynamometer" in out
    code, out, _ = run(capsys, "new", tmp_path / "b.h5", "--rig", "none")
    assert code == 0 and "rig: none" in out
    code, out, _ = run(capsys, "info", tmp_path / "b.h5")
    assert code == 0 and "rig: none" in out


def test_errors_are_one_line_and_leave_the_project_unchanged(tmp_path, capsys, legacy_dat):
    project = tmp_path / "p.h5"
    run(capsys, "new", project)
    before = hashlib.sha256(project.read_bytes()).hexdigest()
    (tmp_path / "bad.DAT").write_text("0\t" * 10 + "0\n" + "0\t" * 10 + "nan\n")
    for args in (
        ("new", project),
        ("new", tmp_path / "x.h5", "--rig", "no-such-rig"),
        ("info", tmp_path / "missing.h5"),
        ("import-legacy", project, tmp_path / "bad.DAT", "--systeminfo", TABLE_E3, "--name", "B",
         "--force-point=0,0,0", "--force-dir=+z"),
        ("import-legacy", project, legacy_dat, "--systeminfo", TABLE_E3, "--name", "B",
         "--force-point=0,0", "--force-dir=+z"),
        ("import-legacy", project, legacy_dat, "--systeminfo", TABLE_E3, "--name", "B",
         "--force-point=0,0,0", "--force-dir=0,0,0"),
        ("export-legacy", project, "B", "--cod", tmp_path / "b.COD"),
    ):
        code, out, err = run(capsys, *args)
        assert code == 1, args
        assert err.startswith("error: ") and err.count("\n") == 1, err
    assert "bad.DAT: line 2, column 10: not a finite number: 'nan'" in _import(
        capsys, project, tmp_path / "bad.DAT")[2]
    assert hashlib.sha256(project.read_bytes()).hexdigest() == before
    assert not (tmp_path / "x.h5").exists()


def test_export_legacy(tmp_path, capsys, legacy_dat):
    project = tmp_path / "p.h5"
    run(capsys, "new", project)
    _import(capsys, project, legacy_dat)
    code, _, err = run(capsys, "export-legacy", project, "T5", "--cod", tmp_path / "T5.COD")
    assert code == 1 and "no generalized coordinates: run `odsuite process PROJECT` first" in err
    at_g = np.random.default_rng(5).normal(scale=1e-6, size=(2048, 6))
    with open_project(project, "a") as p:
        p.write_derived("T5", "gencoords", {"platform_at_g": DerivedArray(at_g, "m|rad", ("sample", "coordinate"))},
                        provenance={"plugin": "test", "version": "0", "parameters": {}, "inputs": []})
    code, out, err = run(capsys, "export-legacy", project, "T5", "--cod", tmp_path / "T5.COD", "--at", "center")
    assert code == 0, err
    (platform,) = read_cod(tmp_path / "T5.COD")
    np.testing.assert_array_equal(platform, at_g)


def test_console_script_runs(tmp_path):
    result = subprocess.run([sys.executable, "-m", "odsuite.cli", "new", str(tmp_path / "s.h5"), "--rig", "none"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "s.h5").is_file()
