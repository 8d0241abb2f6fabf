"""The project catalogue: what it indexes equals what the projects hold, a refresh reads only the
files that changed, queries answer the campaign's questions, the page lists every error trail."""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import pytest

from hidden_effects import make_project

#: the hidden gain error of sensor zC in the "drifted" project (the truth the fit must find)
TRUE_GAIN = 1.25


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    from odsuite.diagnosis.add_effect import add_effect
    from odsuite.store.project import open_project

    store = tmp_path_factory.mktemp("catalog-made")
    plain = make_project(store / "plain.h5", n_samples=2048, scenarios=("T1", "T5"))
    drifted = make_project(store / "drifted.h5", [("sensor_gain", {"zC_gain": TRUE_GAIN})], seed=40,
                           n_samples=2048, scenarios=("T1", "T5"))
    with open_project(drifted, "a") as p:
        add_effect(p, "sensor_gain")
    return {"plain": plain, "drifted": drifted}


@pytest.fixture
def folder(made, tmp_path) -> Path:
    (tmp_path / "campaign" / "2026").mkdir(parents=True)
    shutil.copy(made["plain"], tmp_path / "campaign" / "plain.h5")
    shutil.copy(made["drifted"], tmp_path / "campaign" / "2026" / "drifted.h5")
    # an HDF5 signature with nothing behind it: listed with its error; a text file: ignored
    (tmp_path / "campaign" / "broken.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(200))
    (tmp_path / "campaign" / "notes.txt").write_text("rig moved on 3 May\n")
    return tmp_path / "campaign"


def test_catalog_holds_what_the_projects_hold(folder):
    from odsuite.ops.catalog import build_catalog, query
    from odsuite.store.project import open_project

    res = build_catalog(folder)
    assert sorted(res.indexed) == ["2026/drifted.h5", "broken.h5", "plain.h5"]
    assert res.path == folder / "odsuite-catalog.sqlite" and res.path.is_file()
    projects = {r["project"]: r for r in query(folder, "projects")}
    assert "damaged" in projects["broken.h5"]["read_error"] or "cannot" in projects["broken.h5"]["read_error"]
    assert projects["plain.h5"]["rig"] == "thesis-dynamometer"
    assert projects["plain.h5"]["n_experiments"] == 2
    exps = [r for r in query(folder, "experiments") if r["project"] == "plain.h5"]
    assert [r["experiment"] for r in exps] == ["T1", "T5"]
    assert all(r["n_samples"] == 2048 and math.isclose(r["duration_s"], 2048 / 20000.0) for r in exps)
    with open_project(folder / "2026" / "drifted.h5") as p:
        revs = p.model_revisions()
        serials = {c.serial for c in p.experiment("T1").systeminfo.channels if c.serial}
    trail = [r for r in query(folder, "errors") if r["project"] == "2026/drifted.h5"]
    assert [r["revision"] for r in trail] == [0, 1]
    assert trail[1]["added"] == "sensor_gain" and trail[1]["error"] == revs[1]["metrics"]["error"]
    # revision 0 never stored an error: its child's previous_error is it
    assert trail[0]["error"] == revs[1]["metrics"]["previous_error"] > trail[1]["error"]
    assert {r["serial"] for r in query(folder, "sensors")} >= serials
    gains = {(g["project"], g["sensor"]): g for g in query(folder, "gains")}
    zc = gains[("2026/drifted.h5", "zC")]
    assert abs(zc["gain"] - TRUE_GAIN) < 0.05, zc
    assert abs(gains[("2026/drifted.h5", "x1")]["gain"] - 1.0) < 0.05
    assert query(folder, "projects", rig="no-such-rig") == []
    rows = query(folder, "SELECT COUNT(*) AS n FROM bodies WHERE project = 'plain.h5'")
    with open_project(folder / "plain.h5") as p:
        assert rows == [{"n": len(p.rig.bodies)}]
    page = res.page.read_text()
    assert "2026/drifted.h5" in page and f"{trail[0]['error']:.4f} → {trail[1]['error']:.4f} (+sensor_gain)" in page


def test_refresh_reads_only_what_changed(folder):
    from odsuite.ops.catalog import build_catalog, query
    from odsuite.store.project import open_project

    build_catalog(folder)
    again = build_catalog(folder)
    assert again.indexed == [] and len(again.unchanged) == 3
    plain = folder / "plain.h5"
    st = plain.stat()
    os.utime(plain, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # touched, same content
    with open_project(folder / "2026" / "drifted.h5", "a") as p:
        p.set_current_revision(0)
    (folder / "broken.h5").unlink()
    res = build_catalog(folder)
    assert res.restamped == ["plain.h5"]
    assert res.indexed == ["2026/drifted.h5"]
    assert res.removed == ["broken.h5"]
    current = {r["project"]: r["current_revision"] for r in query(folder, "projects")}
    assert current == {"2026/drifted.h5": 0, "plain.h5": 0}


def test_compute_errors_and_unexplained(folder):
    from odsuite.ops.catalog import EXPLAINED_FACTOR, build_catalog, query
    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project

    build_catalog(folder)
    assert query(folder, "SELECT error FROM projects WHERE project = 'plain.h5'") == [{"error": None}]
    res = build_catalog(folder, compute_errors=True)
    assert res.indexed == ["plain.h5"]  # the drifted project stored its errors already
    with open_project(folder / "plain.h5") as p:
        cmp = compare(p)
    row = next(r for r in query(folder, "projects") if r["project"] == "plain.h5")
    assert math.isclose(row["error"], cmp.error, rel_tol=1e-12)
    assert math.isclose(row["noise_floor_error"], cmp.noise_floor_error, rel_tol=1e-12)
    # nothing hidden in the plain truth: its rigid model explains it; the drifted project's model
    # with the fitted gain does too, its revision 0 did not
    assert cmp.error <= EXPLAINED_FACTOR * cmp.noise_floor_error and row["verdict"] == "explained"
    assert {r["project"] for r in query(folder, "unexplained")} == set()
    trail = [r for r in query(folder, "errors") if r["project"] == "2026/drifted.h5"]
    assert [r["verdict"] for r in trail] == ["unexplained", "explained"]
    with open_project(folder / "2026" / "drifted.h5", "a") as p:
        p.set_current_revision(0)
    build_catalog(folder)
    assert [r["project"] for r in query(folder, "unexplained")] == ["2026/drifted.h5"]


def test_cli_catalog_json_and_errors(folder, capsys):
    from odsuite.cli import main

    assert main(["catalog", str(folder), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["indexed"]) == 3
    assert main(["catalog", "query", str(folder), "gains", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["sensor"] for r in rows} >= {"zC"}
    assert main(["catalog", "query", str(folder), "DELETE FROM projects"]) == 1
    err = capsys.readouterr().err
    assert "expected one of" in err and len(err.strip().splitlines()) == 1
    assert main(["catalog", "query", str(folder / "nowhere")]) == 1


def _user_db(path: Path) -> None:
    import sqlite3

    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE projects (name TEXT, budget REAL)")
        db.execute("INSERT INTO projects VALUES ('grant', 12345.0)")


def test_catalog_never_writes_through_links(folder, tmp_path):
    """A link at the catalogue's or its page's name is refused and its target left as it was; a
    hard link shared with a user's database is replaced by the new catalogue, the user's file kept."""
    from odsuite.domain.errors import ConfigError
    from odsuite.ops.catalog import CATALOG_NAME, PAGE_NAME, build_catalog, query

    user = tmp_path / "budget.sqlite"
    _user_db(user)
    before = user.read_bytes()
    (folder / CATALOG_NAME).symlink_to(user)
    with pytest.raises(ConfigError, match="is a link, which odsuite never writes through"):
        build_catalog(folder)
    (folder / CATALOG_NAME).unlink()
    (tmp_path / "page.html").write_text("<p>mine</p>")
    (folder / PAGE_NAME).symlink_to(tmp_path / "page.html")
    with pytest.raises(ConfigError, match="catalogue page is a link"):
        build_catalog(folder)
    assert (tmp_path / "page.html").read_text() == "<p>mine</p>"
    (folder / PAGE_NAME).unlink()
    os.link(user, folder / CATALOG_NAME)
    build_catalog(folder)
    assert user.read_bytes() == before
    assert {r["project"] for r in query(folder, "projects")} == {"plain.h5", "2026/drifted.h5", "broken.h5"}
    assert [p.name for p in folder.iterdir() if ".odsuite-out-" in p.name] == []


def test_catalog_skips_one_bad_project(folder):
    """Stored metrics that are not numbers make one project's row an error; the others are indexed."""
    import h5py

    from odsuite.ops.catalog import build_catalog, query

    with h5py.File(folder / "plain.h5", "a") as f:
        f["models/revisions/0"].attrs["metrics"] = "[1, 2]"
    build_catalog(folder)
    rows = {r["project"]: r for r in query(folder, "projects")}
    assert rows["plain.h5"]["read_error"].startswith(str(folder / "plain.h5")), rows["plain.h5"]
    assert rows["2026/drifted.h5"]["read_error"] is None and rows["2026/drifted.h5"]["n_experiments"] == 2


def test_catalog_query_bounded(folder, capsys):
    """An endless recursive query stops at --seconds, a 20,001-row one at --limit, in one line each;
    BLOBs come out of --json as hexadecimal text."""
    import time

    from odsuite.cli import main
    from odsuite.ops.catalog import build_catalog

    build_catalog(folder)
    capsys.readouterr()
    endless = "WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c) SELECT count(*) FROM c"
    started = time.monotonic()
    assert main(["catalog", "query", str(folder), endless, "--seconds", "1"]) == 1
    assert time.monotonic() - started < 20
    err = capsys.readouterr().err
    assert "stopped after 1 s of work" in err and err.count("\n") == 1
    many = "WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c LIMIT 20001) SELECT x FROM c"
    assert main(["catalog", "query", str(folder), many, "--json"]) == 1
    assert "more than 10000 rows" in capsys.readouterr().err
    assert main(["catalog", "query", str(folder), many, "--limit", "20001", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)[-1] == {"x": 20001}
    assert main(["catalog", "query", str(folder), "SELECT x'00ff10' AS b", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == [{"b": "00ff10"}]
    # the table shows BLOBs in hexadecimal too, and cuts a long value at 1,000 characters
    assert main(["catalog", "query", str(folder), "SELECT x'00ff10' AS b, zeroblob(5000) AS z, "
                 "printf('%.*c', 3000, 'x') AS t"]) == 0
    flat = "".join(ln.strip("│ ") for ln in capsys.readouterr().out.splitlines())
    assert "00ff10" in flat and "(5000 bytes)" in flat and "(3000 characters)" in flat


def test_catalog_refuses_a_project_reaching_outside(folder, tmp_path, capsys):
    """A project whose raw record is an external link: listed with its error, the others indexed,
    and the command fails in one line (a file built to read another is not a damaged file)."""
    import h5py

    from odsuite.cli import main
    from odsuite.ops.catalog import query

    with h5py.File(tmp_path / "other.h5", "w") as o:
        o["data"] = [1.0, 2.0]
    with h5py.File(folder / "plain.h5", "a") as f:
        name = next(f"experiments/{e}/raw" for e in f["experiments"])
        del f[name]
        f[name] = h5py.ExternalLink(str(tmp_path / "other.h5"), "data")
    capsys.readouterr()
    assert main(["catalog", str(folder)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: catalog: 1 project(s) refused") and "external link" in err
    rows = {r["project"]: r for r in query(folder, "projects")}
    assert "is an external link to" in rows["plain.h5"]["read_error"]
    assert rows["2026/drifted.h5"]["read_error"] is None


def test_usage_error_raised_by_a_command_is_its_message(capsys):
    """A command's own usage error (click's BadParameter) is click's message and exit code 2."""
    from odsuite.cli import main

    assert main(["catalog", "query"]) == 2
    err = capsys.readouterr().err
    assert "catalog query DIR" in err and "Traceback" not in err and "AttributeError" not in err
