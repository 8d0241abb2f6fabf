"""Red team, round three (see redteam3.py): the harness judges what it is meant to judge, and a
representative handful of real tries runs in seconds; the whole run (about 500 tries, 20-25 minutes
on two cores) is behind the slow marker and must end with no traceback, hang, harmed file or read
outside the project."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tests.reliability import redteam3 as rt
from tests.reliability.redteam3 import Case

PY = [sys.executable, "-c"]


def _home(d: Path, variant: int) -> None:
    (d / "home" / ".ssh" / "id_rsa").write_bytes(rt.fake_key(variant, 4000))


def _master(tmp_path: Path) -> Path:
    m = tmp_path / "master"
    (m / "home" / ".ssh").mkdir(parents=True)
    (m / "home" / "notes.txt").write_text("a user's notes\n")
    (m / "rig.toml").write_text(rt.rig_text())
    (m / "bad.toml").write_text(rt.rig_text(mass="1e-300"))
    return m


#: (what the program does, the outcome the harness must give)
SELF_TESTS = [
    (Case("self", "one error line", lambda d: [], program=PY + ["import sys; print('error: no', file=sys.stderr); sys.exit(1)"]),
     "ok"),
    (Case("self", "writes into a user's file", lambda d: [], program=PY + ["open('home/notes.txt', 'a').write('x')"]),
     "harmed file"),
    (Case("self", "a traceback", lambda d: [], program=PY + ["1 / 0"]), "traceback"),
    (Case("self", "sleeps past the limit", lambda d: [], program=PY + ["import time; time.sleep(30)"], timeout=1.0),
     "hang"),
    (Case("self", "exit 1 and nothing said", lambda d: [], program=PY + ["raise SystemExit(1)"]), "silent failure"),
    (Case("self", "dies of SIGTERM", lambda d: [], program=PY + ["import time; time.sleep(30)"],
          send=(rt.signal.SIGTERM, 0.5), timeout=10.0), "silent failure"),
    (Case("self", "exit 0 where refused", lambda d: [], program=PY + ["pass"], expect="refuse"), "wrong success"),
    (Case("self", "prints the key's first line", lambda d: [], _home, canary=True,
          program=PY + ["print(open('home/.ssh/id_rsa').read(60))"]), "read outside"),
    (Case("self", "prints a digest of the key", lambda d: [], _home, canary=True,
          program=PY + ["import hashlib; print(hashlib.sha1(open('home/.ssh/id_rsa','rb').read()[100:]).hexdigest())"]),
     "read outside"),
    (Case("self", "prints the mtime of a project its setup rewrote", lambda d: [],
          lambda d, v: (_home(d, v), (d / "p.h5").write_text("p")), canary=True,
          program=PY + ["import os, time; time.sleep(0.01); print(os.stat('p.h5').st_mtime_ns)"]), "ok"),
    (Case("self", "changes the project and fails", lambda d: [], lambda d, v: (d / "p.h5").write_text("p"),
          program=PY + ["import sys; open('p.h5', 'a').write('x'); print('error: no', file=sys.stderr); sys.exit(1)"]),
     "changed project"),
    (Case("self", "leaves a temporary folder", lambda d: [], program=PY + ["import os; os.mkdir('tmp/odsuite-movie-1')"]),
     "leftover"),
    (Case("self", "a warning on exit 0", lambda d: [], program=PY + ["import warnings; warnings.warn('x', RuntimeWarning)"]),
     "noisy"),
]


def test_harness_classifies(tmp_path):
    results = rt.run([c for c, _ in SELF_TESTS], tmp_path / "work", timeout=20.0, jobs=4, master=_master(tmp_path))
    assert [(r.label, r.outcome) for r in results] == [(c.label, want) for c, want in SELF_TESTS]


def test_representative_tries(tmp_path):
    """A clean rig file is ok; a hostile one (mass 1e-300 kg) and the plugin that calls sys.exit(3)
    at import end in one of the outcomes, recorded with their command and stderr."""
    cases = [
        Case("control", "new --rig bench", lambda d: ["new", "q.h5", "--rig", "rig.toml"], outputs=("q.h5",), projects=()),
        Case("rig files", "new --rig: mass 1e-300", lambda d: ["new", "q.h5", "--rig", "bad.toml"], outputs=("q.h5",),
             projects=()),
        Case("plugins", "--version: a plugin that sys.exit(3) at import", lambda d: ["--version"],
             rt._plugin("sys.exit(3) at import"), env={"PYTHONPATH": "site"}),
    ]
    results = rt.run(cases, tmp_path / "work", timeout=60.0, jobs=3, master=_master(tmp_path))
    assert results[0].outcome == "ok", results[0].as_dict()
    assert all(r.outcome in rt.OUTCOMES for r in results)
    assert [r.command[0] for r in results] == ["new", "new", "--version"]
    assert all(r.stderr is not None and r.seconds > 0 for r in results)
    table = rt.table(results).splitlines()
    assert table[0].split()[:2] == ["group", "tries"] and table[-1].split()[:2] == ["all", "3"]


def test_round_four_representative_tries(tmp_path):
    """Round four (redteam4.py): a project naming its experiment twice, /dev/zero as the diagnosis
    and a plugin looping at import (bound 1 s) are each refused or left out in one line."""
    from tests.reliability import redteam4 as rt4

    labels = ("info: experiment group", "report --diagnosis: the device /dev/zero",
              "info: a plugin that loops at import (bound 1 s)")
    cases = [c for c in rt4.all_cases("hardlinks,diagnosis,plugins") if c.label in labels]
    assert [c.label for c in cases] == list(labels)
    master = _master(tmp_path)
    for argv in (["new", "p.h5"], ["acquire", "p.h5", "--name", "s1", "--samples", "2048"]):
        assert rt._run_setup(argv, master).returncode == 0
    results = rt.run(cases, tmp_path / "work", timeout=60.0, jobs=2, master=master)
    assert [(r.outcome, r.code) for r in results] == [("ok", 1), ("ok", 1), ("ok", 0)], [r.problems for r in results]
    assert "names the same object" in results[0].stderr[0] and "not a regular file" in results[1].stderr[0]
    assert "PluginTimeout: still running after 1 s" in results[2].stderr[0]


@pytest.mark.slow
def test_redteam3_full(tmp_path):
    results = rt.run(rt.all_cases(), tmp_path, jobs=2)
    assert len(results) >= 450
    bad = [r.as_dict() for r in results if r.outcome in rt.FAILURES]
    assert not bad, rt.table(results) + "\n" + "\n".join(f"{b['outcome']}: {b['label']}" for b in bad[:50])


def test_catalogue_lists_a_project_with_outside_storage_refused(tmp_path):
    """`catalog .` beside a project whose raw data are external storage on the user's key lists it
    refused and ends ok: neither the key's bytes nor the time its setup wrote it reach the catalogue."""
    (case,) = [c for c in rt.all_cases("hdf5") if c.label == "catalog: external storage (key) at raw"]
    master = _master(tmp_path)
    for argv in (["new", "p.h5"], ["acquire", "p.h5", "--name", "s1", "--samples", "2048"], ["process", "p.h5"]):
        assert rt._run_setup(argv, master).returncode == 0
    (result,) = rt.run([case], tmp_path / "work", timeout=60.0, jobs=1, master=master)
    assert (result.outcome, result.code) == ("ok", 1), result.problems
    assert "p.h5: refused: dataset 'experiments/s1/raw' has external storage" in result.stderr[0]
