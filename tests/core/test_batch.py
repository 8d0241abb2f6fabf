"""Batch runs on dask.distributed: results equal the direct API calls, a locked project is reported
and left unchanged, a killed worker's project is rerun elsewhere (or reported when the cluster
allows no retry) and every project stays intact."""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import signal
import sys
import time
from pathlib import Path

import pytest

from hidden_effects import make_project

distributed = pytest.importorskip("distributed")

#: short records keep each task at a few seconds
SAMPLES = 2048
SCENARIOS = ("T1", "T5")


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> list[Path]:
    store = tmp_path_factory.mktemp("batch-made")
    return [make_project(store / f"rig{i}.h5", [("stiffness", {"scale_z": 1.0 + 0.3 * i})], seed=20 + i,
                         n_samples=SAMPLES, scenarios=SCENARIOS) for i in range(3)]


@pytest.fixture
def projects(made, tmp_path) -> list[Path]:
    out = []
    for p in made:
        shutil.copy(p, tmp_path / p.name)
        out.append(tmp_path / p.name)
    return out


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _direct_history(path: Path) -> dict:
    from odsuite.analysis.history import history
    from odsuite.store.project import open_project

    with open_project(path) as p:
        return history(p)


def test_batch_on_local_cluster_equals_direct_calls(projects, tmp_path):
    from odsuite.ops.batch import run_batch

    missing = tmp_path / "missing.h5"
    seen = []
    res = run_batch("history", [*projects, missing], workers=2,
                    progress=lambda record, done, total: seen.append((done, total)))
    assert [r["project"] for r in res.projects] == [str(p.resolve()) for p in [*projects, missing]]
    assert res.counts == {"ok": 3, "error": 1, "locked": 0, "not-run": 0}
    assert seen[-1] == (4, 4)
    bad = res.projects[-1]
    assert "missing.h5" in bad["error"] and "\n" not in bad["error"]
    # the stiffer truths' errors grow with the hidden scale; each equals the in-process call
    errors = []
    for p, r in zip(projects, res.projects):
        direct = _direct_history(p)
        assert r["result"]["current"] == direct["current"] == 0
        assert math.isclose(r["result"]["revisions"][0]["error"], direct["revisions"][0]["error"], rel_tol=1e-9)
        errors.append(direct["revisions"][0]["error"])
    assert errors[0] < errors[1] < errors[2]
    # pids: the work ran in worker processes, not here
    assert all(r["pid"] != os.getpid() for r in res.projects[:3])
    json.dumps(res.as_dict(), allow_nan=False)


def test_locked_project_is_reported_and_left_unchanged(projects):
    from odsuite.ops.batch import run_batch
    from odsuite.store.project import open_project

    locked, free = projects[0], projects[1]
    before = _digest(locked)
    with open_project(locked, "a"):
        res = run_batch("process", [locked, free], workers=2)
    assert [r["status"] for r in res.projects] == ["locked", "ok"]
    assert f"pid {os.getpid()}" in res.projects[0]["error"]
    assert _digest(locked) == before
    assert set(res.projects[1]["result"]["experiments"]) == set(SCENARIOS)
    with open_project(free) as p:
        assert all("processed" in p.derived_kinds(n) for n in SCENARIOS)


def test_cli_batch_json_is_one_document(projects, capsys):
    from odsuite.cli import main

    code = main(["batch", "info", *map(str, projects[:2]), "--workers", "1", "--json"])
    out = capsys.readouterr().out
    doc = json.loads(out)
    assert code == 0
    assert doc["command"] == "info" and doc["counts"]["ok"] == 2
    assert [e for e in doc["projects"][0]["result"]["experiments"]] == list(SCENARIOS)
    assert doc["projects"][0]["result"]["experiments"]["T1"]["n_samples"] == SAMPLES


def _kill_first_busy_worker(client, futures, killed: dict) -> None:
    """Kill (SIGKILL) the worker process running the first task, once it has run for a while."""
    pids = client.run(os.getpid)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        busy = [w for w, keys in client.processing().items() if keys]
        if busy:
            time.sleep(1.0)  # inside the command, not before it
            keys = client.processing().get(busy[0], ())
            running = [p for p, f in futures.items() if f.key in keys and not f.done()]
            if running:
                killed["pid"] = pids[busy[0]]
                killed["projects"] = running  # assigned to it; one of them runs, the next may wait there
                os.kill(pids[busy[0]], signal.SIGKILL)
                return
        time.sleep(0.05)


def _cluster(**config):
    import dask
    from distributed import LocalCluster

    with dask.config.set(config):
        return LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                            scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                            silence_logs=50)


def test_killed_worker_task_reruns_and_projects_stay_intact(projects):
    from odsuite.ops.batch import run_batch
    from odsuite.store.project import open_project

    killed: dict = {}
    cluster = _cluster()
    try:
        res = run_batch("diagnose", projects, scheduler=cluster.scheduler_address,
                        options={"effects": ["stiffness"]},
                        on_submitted=lambda c, f: _kill_first_busy_worker(c, f, killed))
    finally:
        cluster.close()
    assert killed, "no worker was killed"
    assert res.counts["ok"] == len(projects), res.projects
    # the task that was running when its worker died finished in another process
    assert any(r["pid"] != killed["pid"] for r in res.projects if r["project"] in killed["projects"])
    for r in res.projects:
        top = r["result"]["candidates"][0]
        assert top["effect"] == "stiffness"
    # the same numbers as an undisturbed in-process diagnosis
    from odsuite.diagnosis.diagnose import diagnose

    with open_project(projects[0]) as p:
        direct = diagnose(p, effects=["stiffness"], workers=1).as_dict()
    assert math.isclose(res.projects[0]["result"]["candidates"][0]["error_after"],
                        direct["candidates"][0]["error_after"], rel_tol=1e-9)
    for path in projects:
        with open_project(path) as p:
            assert sum(p.verify().values()) > 0


def test_killed_worker_without_retries_is_reported(projects):
    from odsuite.ops.batch import run_batch

    killed: dict = {}
    cluster = _cluster(**{"distributed.scheduler.allowed-failures": 0})
    try:
        res = run_batch("add-effect", projects, scheduler=cluster.scheduler_address, options={"effect": "stiffness"},
                        on_submitted=lambda c, f: _kill_first_busy_worker(c, f, killed))
    finally:
        cluster.close()
    assert killed
    lost = [r for r in res.projects if r["status"] == "not-run"]
    assert lost and {r["project"] for r in lost} <= set(killed["projects"])
    assert all(r["status"] in ("ok", "not-run") for r in res.projects)
    assert "KilledWorker" in lost[0]["error"]
    assert res.counts["ok"] == len(projects) - len(lost)
    from odsuite.store.project import open_project

    for path in projects:  # the killed write left its project as it was or whole
        with open_project(path) as p:
            p.verify()


def test_unreachable_scheduler_is_one_line(projects):
    from odsuite.ops.batch import run_batch
    from odsuite.domain.errors import ConfigError

    # port 9 (discard) on the loopback: nothing listens there
    with pytest.raises(ConfigError, match=r"cannot reach the scheduler at tcp://127\.0\.0\.1:9") as info:
        run_batch("info", projects[:1], scheduler="tcp://127.0.0.1:9")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("address", ["", "foo://h:1", "127.0.0.1", "tcp://127.0.0.1:99999", "tcp://127.0.0.1:abc",
                                     "inproc://", "unix:///nonexistent", "tcp://a\nb:1", "http://127.0.0.1:80"])
def test_scheduler_address_checked(address):
    from odsuite.domain.errors import ConfigError
    from odsuite.ops.batch import check_scheduler

    with pytest.raises(ConfigError, match=r"^--scheduler: expected an address tcp://HOST:PORT"):
        check_scheduler(address)
    assert check_scheduler("127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    with pytest.raises(ConfigError, match="tls:// needs dask's TLS settings"):
        check_scheduler("tls://h.example:1")


def test_silent_scheduler_is_one_line_within_the_timeout(projects, monkeypatch):
    """A listener that accepts and never answers: one line within the connection time (+5 s)."""
    import socket

    from odsuite.domain.errors import ConfigError
    from odsuite.ops import batch

    monkeypatch.setattr(batch, "CONNECT_SECONDS", 2.0)
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(1)
        started = time.monotonic()
        with pytest.raises(ConfigError, match="did not answer within 2 s|cannot reach the scheduler"):
            batch.run_batch("info", projects[:1], scheduler=f"tcp://127.0.0.1:{silent.getsockname()[1]}")
        assert time.monotonic() - started < 2.0 + 5 + 3


def test_outputs_of_one_name_and_out_file_refused_before_work(projects, tmp_path):
    from odsuite.domain.errors import ConfigError
    from odsuite.ops.batch import run_batch

    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    twins = [shutil.copy(projects[0], tmp_path / d / "run.h5") for d in ("x", "y")]
    with pytest.raises(ConfigError, match=r"would write files of one name \(run-report\.html"):
        run_batch("report", twins, options={"out": str(tmp_path / "out")})
    (tmp_path / "notes.txt").write_text("mine\n")
    with pytest.raises(ConfigError, match=r"^--out .*notes\.txt: not a folder"):
        run_batch("report", projects[:1], options={"out": str(tmp_path / "notes.txt")})
    assert (tmp_path / "notes.txt").read_text() == "mine\n" and not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match=r"--workers must be from 1 to"):
        run_batch("info", projects[:1], workers=100_000)


def test_interrupted_batch_names_the_projects_that_changed(projects):
    """The line after Ctrl-C is made from the projects on disk once the workers are gone: a
    project replaced by a commit is named as changed, the others as unchanged."""
    from odsuite.ops.batch import _fingerprint, _interrupted_line

    before = {p: _fingerprint(p) for p in projects}
    tmp = projects[1].with_name("copy.h5")
    shutil.copy(projects[1], tmp)
    os.replace(tmp, projects[1])  # what a commit does
    line = _interrupted_line("add-effect", projects, before, {})
    assert line == (f"interrupted: add-effect stored in {projects[1]}; unchanged: {projects[0]}, {projects[2]}")
    assert _interrupted_line("add-effect", projects[:1], before, {}) == \
        "interrupted: nothing stored, no project changed"
    assert _interrupted_line("info", projects, before, {str(projects[0]): {"status": "ok"}}) == \
        f"interrupted: nothing stored; finished: {projects[0]} of 3 projects"


def test_an_interrupt_after_the_batch_ended_says_what_it_stored(projects, monkeypatch, capfd):
    """Ctrl-C while the table prints, after add-effect had written every project: the line names
    them (it said "interrupted: nothing stored" of three projects just written)."""
    import odsuite.ops.batch as batch
    from odsuite import cli

    def ran(command, paths, **kwargs):
        return batch.BatchResult(command, "local", 1, [{"project": str(p), "status": "ok" if i < 2 else "failed",
                                                        "result": None, "error": None, "seconds": 0.1,
                                                        "host": None, "pid": None} for i, p in enumerate(paths)])

    def cut(*args, **kwargs):  # what the command line's Ctrl-C handler raises
        raise sys.modules["odsuite.cli.app"]._Interrupted()

    monkeypatch.setattr(batch, "run_batch", ran)
    monkeypatch.setattr(batch, "describe", cut)
    code = cli.main(["batch", "add-effect", *map(str, projects), "--effect", "stiffness"])
    last = capfd.readouterr().err.strip().splitlines()[-1]
    assert code == 130
    assert last == f"interrupted: add-effect stored in {projects[0]}, {projects[1]}; unchanged: {projects[2]}"
    cli.main(["batch", "info", *map(str, projects)])  # a reading command: it stored nothing
    assert capfd.readouterr().err.strip().splitlines()[-1] == \
        f"interrupted: nothing stored; finished: {projects[0]}, {projects[1]} of 3 projects"


def test_a_link_at_a_name_batch_derives_is_refused(tmp_path):
    # batch report writes <out>/<project>-report.html, a name the user did not give: a link there
    # (to the user's notes) is refused in one line, never written through
    from odsuite.domain.errors import ConfigError
    from odsuite.ops.batch import _output

    (tmp_path / "out").mkdir()
    notes = tmp_path / "notes.txt"
    notes.write_text("NOTES")
    (tmp_path / "out" / "p-report.html").symlink_to(notes)
    with pytest.raises(ConfigError, match=r"p-report\.html: a link, which batch never writes through "
                                          r"\(the name comes from p\.h5\); remove it"):
        _output(tmp_path / "p.h5", {"out": str(tmp_path / "out")}, "-report.html")
    assert notes.read_text() == "NOTES"
    assert _output(tmp_path / "q.h5", {"out": str(tmp_path / "out")}, "-report.html") == tmp_path / "out" / "q-report.html"
