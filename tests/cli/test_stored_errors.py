"""A revision's error is stored by the writing commands with a stamp of the records it was
computed on, read back by `info` and `history` while those records are unchanged, and computed
again (the same number `compare` gives) once they change."""

from __future__ import annotations

import hashlib
import json

from odsuite.analysis.history import data_stamp
from odsuite.cli import main
from odsuite.store.project import open_project


def _json(capsys, *args) -> dict:
    assert main([str(a) for a in args]) == 0
    return json.loads(capsys.readouterr().out)


def test_process_stores_the_error_compare_gives_until_the_records_change(tmp_path, capsys):
    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"]):
        assert main([str(a) for a in argv]) == 0
    capsys.readouterr()
    processed = _json(capsys, "process", p, "--json")
    assert processed["experiments"]["T1"]["datasets"] and processed["revision"] == 0
    with open_project(p) as proj:
        metrics = proj.model_revisions()[0]["metrics"]
        assert metrics["data_stamp"] == data_stamp(proj)
        # hashlib's SHA-256, whichever module the stamp is read with: stamps stored before stay valid
        ref = hashlib.sha256()
        for name in proj.experiment_names():
            record, derived = proj.object_ids(name)
            ref.update(f"{name}\0{record}\0".encode())
            for kind, object_id in derived.items():
                ref.update(f"{kind}\0{object_id}\0".encode())
        assert data_stamp(proj) == ref.hexdigest()[:16]
    compared = _json(capsys, "compare", p, "--json")
    assert metrics["error"] == compared["error"] == processed["error"] > 0
    assert metrics["noise_floor_error"] == compared["noise_floor_error"] > 0
    info = _json(capsys, "info", p, "--json")
    assert info["model_revisions"][0]["error"] == metrics["error"]

    # a second record: the stored error no longer holds; both readers compute the new one
    assert main([str(a) for a in ["acquire", p, "--daq", "sim", "--name", "T2", "--scenario", "T2", "--seed", "2",
                                  "--samples", "2048"]]) == 0
    capsys.readouterr()
    compared = _json(capsys, "compare", p, "--json")
    hist = _json(capsys, "history", p, "--json")
    info = _json(capsys, "info", p, "--json")
    assert compared["error"] != metrics["error"]
    assert hist["revisions"][0]["error"] == info["model_revisions"][0]["error"] == compared["error"]
    with open_project(p) as proj:  # reading never writes
        assert proj.model_revisions()[0]["metrics"] == metrics


def test_info_reads_the_stored_error_without_importing_the_comparison(tmp_path, capsys):
    """`info` on a processed project prints revision 0's stored error and imports none of scipy,
    the model or the comparison (its start-up is `bench/bench_startup.py`'s)."""
    import subprocess
    import sys

    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"], ["process", p]):
        assert main([str(a) for a in argv]) == 0
    capsys.readouterr()
    with open_project(p) as proj:
        stored = proj.model_revisions()[0]["metrics"]["error"]
    heavy = ("scipy", "odsuite.domain.model", "odsuite.analysis.comparison", "matplotlib")
    code = ("import contextlib, io, json, sys; from odsuite.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out: code = main(['info', sys.argv[1], '--json'])\n"
            "assert code == 0\n"
            f"print(json.dumps([json.loads(out.getvalue())['model_revisions'][0]['error'], "
            f"sorted(m for m in {heavy!r} if m in sys.modules)]))")
    out = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout) == [stored, []]


def test_add_effect_keeps_the_parents_error_so_info_compares_nothing(tmp_path, capsys):
    """After the first add-effect every revision's error is stored for the records: revision 0's
    is the error add-effect started from (before, `info` compared it again on every call)."""
    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"], ["process", p]):
        assert main([str(a) for a in argv]) == 0
    with open_project(p, "a") as proj:  # as a project processed by an odsuite that stored nothing
        proj.set_revision_metrics(0, {"error": None, "noise_floor_error": None, "data_stamp": None})
    capsys.readouterr()
    added = _json(capsys, "add-effect", p, "stiffness", "--json")
    with open_project(p) as proj:
        stamp = data_stamp(proj)
        metrics = {r["revision"]: r["metrics"] for r in proj.model_revisions()}
    assert metrics[0]["error"] == added["previous_error"] > 0 and metrics[0]["data_stamp"] == stamp
    assert metrics[1]["error"] == added["error"] and metrics[1]["data_stamp"] == stamp
    info = _json(capsys, "info", p, "--json")
    assert [r["error"] for r in info["model_revisions"]] == [metrics[0]["error"], metrics[1]["error"]]
