"""Red team, round five (see redteam5.py): its two extra judgements judge what they are meant to,
usage errors under ``--json`` print the error document, a handful of real tries run in seconds, and
the whole run (623 tries, 12-20 minutes on two shared cores) is behind the slow marker."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from odsuite.cli import main
from tests.reliability import redteam5 as r5


@pytest.mark.parametrize("stdout, code, expected", [
    (b'{"experiments": []}\n', 0, []),
    (b'{"error": "p.h5: no such project file"}\n', 1, []),
    (b"", 2, ["bad json"]),
    (b'{"a": 1}\n{"b": 2}\n', 0, ["bad json"]),
    (b"[1, 2]\n", 0, ["bad json"]),
    (b'{"experiments": []}\n', 1, ["bad json"]),  # failed, but no error line
    (b"NaN\n", 0, ["bad json"]),
])
def test_json_judged(stdout, code, expected):
    assert [p[0] for p in r5._json_check(Path("."), {"stdout": stdout, "code": code})] == expected


@pytest.mark.parametrize("argv, message", [
    (["diagnose", "p.h5", "--workers", "0", "--json"], "Invalid value for '--workers': 0 is not in the range x>=1."),
    (["info", "p.h5", "--json", "--bogus"], "No such option: --bogus"),
    (["ods", "p.h5", "s1", "--at", "100", "--json"], "Missing option '--reference'."),
])
def test_usage_error_under_json(argv, message, capsys):
    """A usage error is one line on stderr (exit 2) and, under --json, the error document on stdout."""
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert json.loads(out) == {"error": message}
    assert err.count("\n") == 1 and err.startswith(f"error: {message} (odsuite {argv[0]} --help)"), err


def test_a_value_given_to_json_is_a_usage_error_a_script_reads_as_json(capsys):
    # "--json=1" was not taken for --json: the usage error came without the JSON document
    assert main(["info", "p.h5", "--json=1"]) == 2
    out, err = capsys.readouterr()
    assert json.loads(out) == {"error": "Option '--json' does not take a value."}
    assert err.count("\n") == 1 and "Traceback" not in err, err


def test_usage_error_one_line_without_json(capsys):
    assert main(["info", "p.h5", "--bogus"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == "error: No such option: --bogus (odsuite info --help)\n"


def _quick(tmp_path: Path) -> list:
    labels = {"import csv: --rate 1e9", "import npy: header: 10^11 x 2 float64, 64 bytes", "import mat: fs a string",
              "import tdms: wf_increment a string", "import: uff --format mat", "diagnose --json --workers 0"}
    cases = [c for c in r5.all_cases("csv,npy,mat,tdms,other,commands") if c.label in labels]
    assert len(cases) == len(labels)
    return r5.rt.run(cases, tmp_path, timeout=60.0, jobs=1, master=r5.prepare(tmp_path))


def test_a_handful_of_tries(tmp_path):
    """Six tries that failed before their fixes (a project stored at a rate it then refuses to open,
    a .npy header asking for 1.6 TB, a .mat rate that is text, a TDMS increment that is text, a
    UFF read as .mat, a usage error without JSON): each now refused in one line."""
    results = _quick(tmp_path)
    assert [(r.label, r.outcome) for r in results if r.outcome != "ok"] == []
    assert all(r.code in (1, 2) and len(r.stderr) == 1 for r in results), [(r.label, r.stderr) for r in results]


@pytest.mark.slow
def test_redteam5_all(tmp_path):
    results = r5.rt.run(r5.all_cases(), tmp_path, timeout=90.0, jobs=2, master=r5.prepare(tmp_path))
    bad = [(r.group, r.label, r.outcome, r.problems[:1]) for r in results if r.outcome in r5.FAILURES]
    assert len(results) >= 600 and bad == []
