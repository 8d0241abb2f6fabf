"""Red team, round three: hostile projects, catalogues, batches, rig files, plugins and signals,
every try a real ``odsuite`` subprocess in a folder of its own, judged from the outside.

Each try copies a master folder (a processed project ``p.h5``, a rig file, a user's home with a
private key, another user's HDF5 file and notes), plants what it needs, runs one command line with
a time limit (in its own process group, ``HOME`` and ``TMPDIR`` inside the folder, memory bounded),
optionally sends SIGINT or SIGTERM to the group at a set moment, and is classified by the worst of:

- ``hang``: still running at the time limit (the group is killed);
- ``traceback``: ``Traceback`` or ``internal error`` in the output, or several lines naming a Python
  exception;
- ``harmed file``: a user's file or link outside the command's outputs changed or disappeared;
- ``read outside``: the bytes of a file outside the project (the planted key, another user's HDF5
  file) reached an output. Found by running the try twice with different contents of those files
  and comparing stdout and the output files (times and durations blanked), and by a marker string;
- ``changed project``: a command that failed left a project with other bytes;
- ``leftover``: a lock file or temporary copy or folder outlived the command;
- ``wrong success``: exit 0 where the try must be refused (a project reading outside itself,
  a write through a catalogue query, a misspelt key, ...);
- ``silent failure``: non-zero exit (or death by a signal) with nothing on stderr;
- ``noisy``: the one line is not one (warnings, several lines) without a Python exception;
- ``ok``: none of these.

``python -m tests.reliability.redteam3 --out DIR [--only GROUP] [--timeout S] [--jobs N]`` runs
the tries, prints a table by group and outcome and writes ``DIR/redteam3.json`` with every try.
"""

from __future__ import annotations

import argparse
import hashlib
import http.server
import json
import os
import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from fnmatch import fnmatch
from pathlib import Path

import h5py
import numpy as np

ODSUITE = str(Path(sys.executable).with_name("odsuite"))
REPO = Path(__file__).resolve().parents[2]
TIMEOUT = 45.0  # s per try; the slowest clean command of these tries (a report) takes ~20 s
MEMORY_LIMIT = 6 * 2**30  # bytes of address space per try, so a runaway reader cannot take the machine
OUTCOMES = ("hang", "traceback", "harmed file", "read outside", "changed project", "leftover",
            "wrong success", "silent failure", "noisy", "ok")
FAILURES = ("hang", "traceback", "harmed file", "read outside")
MARKER = b"ODSUITE-CANARY-5e1f"  # in every file outside the project that a try plants
SIDE_NAMES = (".odsuite-lock", ".odsuite-tmp-", ".odsuite-out-", "odsuite-movie-", "odsuite-report-")

RIG_BASE = """name = "bench"
force_channel = 0
default_model = "rigid-bodies"
[[bodies]]
name = "plate"
mass = {mass}
inertia = {inertia}
plate = {{ size = [0.2, 0.2, 0.02], corner = [-0.1, -0.1, 0.0] }}
[[sensors]]
name = "{sensor}"
channel = 1
body = "plate"
position = {position}
axis = [0.0, 0.0, 1.0]
sensitivity = 0.01
"""
SPRING = """[[springs]]
name = "s{k}"
body = "plate"
position = [{x}, {y}, 0.0]
stiffness = {stiffness}
damping = [1.0, 1.0, 1.0]
"""
RIG_DEFAULTS = {"mass": "2.0", "inertia": "[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]", "sensor": "a1",
                "position": "[0.0, 0.0, 0.0]", "stiffness": "[1000.0, 1000.0, 1000.0]"}


def rig_text(**changes: str) -> str:
    """The bench rig (one plate on four springs, one accelerometer) with fields replaced."""
    v = {**RIG_DEFAULTS, **changes}
    text = RIG_BASE.format(**v)
    for k, (x, y) in enumerate([(0.08, 0.08), (-0.08, 0.08), (0.08, -0.08), (-0.08, -0.08)]):
        text += SPRING.format(k=k, x=x, y=y, stiffness=v["stiffness"])
    return text


LVM_HEAD = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
            "Multi_Headings\tYes\nX_Columns\tNo\nTime_Pref\tAbsolute\n***End_of_Header***\t\n\t\n"
            "Channels\t2\t\t\nSamples\t{n}\t{n}\t\nY_Unit_Label\tNewtons\tm/s^2\t\nX_Dimension\tTime\tTime\t\n"
            "X0\t0.0E+0\t0.0E+0\t\nDelta_X\t1.0E-4\t1.0E-4\t\n***End_of_Header***\t\t\t\n"
            "X_Value\tForce\tResponse\tComment\n")


def lvm_text(rows: list[str]) -> str:
    return LVM_HEAD.format(n=len(rows)) + "".join("\t" + r + "\n" for r in rows)


GOOD_ROWS = [f"{v:.4f}\t{np.sin(k / 3):.4f}" for k, v in enumerate([0.0, 0.5, 2.0, 0.5] + [0.0] * 60)]


# ----------------------------------------------------------------------------- tries


@dataclass
class Case:
    """One try: ``argv(d)`` in folder ``d`` after ``setup(d, variant)``; ``outputs`` are globs (relative
    to ``d``) the command may write; ``projects`` the project files it must leave alone when it fails."""

    group: str
    label: str
    argv: Callable[[Path], list[str]]
    setup: Callable[[Path, int], object] | None = None
    expect: str = "any"  # "refuse": exit 0 is a wrong success
    outputs: tuple[str, ...] = ()
    projects: tuple[str, ...] = ("p.h5",)
    canary: bool = False  # run twice with different outside contents to find reads outside
    send: tuple[int, float] | None = None  # (signal, seconds after start) to the process group
    env: dict[str, str] = field(default_factory=dict)
    timeout: float | None = None  # at most this long (else the run's --timeout)
    check: Callable[[Path, dict], list[tuple[str, str]]] | None = None  # more (outcome, why) pairs
    program: list[str] | None = None  # instead of odsuite (the harness's own tests)


@dataclass
class Result:
    group: str
    label: str
    command: list[str]
    outcome: str
    code: int | None
    seconds: float
    problems: list[tuple[str, str]]
    stderr: list[str]
    stdout: list[str]
    where: str = ""  # the innermost frame of odsuite's own code in a traceback (module:line function)

    def as_dict(self) -> dict:
        return {"group": self.group, "label": self.label, "command": self.command, "outcome": self.outcome,
                "exit_code": self.code, "seconds": round(self.seconds, 2),
                "problems": [list(p) for p in self.problems], "stderr_head": self.stderr, "stdout_head": self.stdout,
                "where": self.where}


# ----------------------------------------------------------------------------- the master folder


def _run_setup(argv: list[str], cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([ODSUITE, *argv], cwd=cwd, capture_output=True, text=True, timeout=300,
                          env={**os.environ, **(env or {})})


def fake_key(variant: int, size: int = 200_000) -> bytes:
    """A private key's text (base64 lines), different for each variant, with the marker."""
    import base64

    rng = np.random.default_rng(1000 + variant)
    body = base64.b64encode(rng.bytes(size)).decode()
    lines = [body[i:i + 70] for i in range(0, len(body), 70)]
    return ("-----BEGIN OPENSSH PRIVATE KEY-----\n" + MARKER.decode() + "\n" + "\n".join(lines)
            + "\n-----END OPENSSH PRIVATE KEY-----\n").encode()[:size]


def prepare_master(work: Path) -> Path:
    """p.h5 (thesis rig, simulated test s1, processed), rig.toml, good.lvm, x/run.h5 and y/run.h5,
    a.h5 b.h5 c.h5 (for batches), the user's home (private key, notes, another user's HDF5 file)."""
    m = work / "master"
    if (m / ".complete").exists():
        return m
    shutil.rmtree(m, ignore_errors=True)
    m.mkdir(parents=True)
    for argv in (["new", "p.h5"], ["acquire", "p.h5", "--name", "s1", "--samples", "2048"], ["process", "p.h5"]):
        r = _run_setup(argv, m)
        if r.returncode:
            raise RuntimeError(f"odsuite {argv}: {r.stderr}")
    (m / "rig.toml").write_text(rig_text())
    (m / "good.lvm").write_text(lvm_text(GOOD_ROWS))
    for sub in ("x", "y"):
        (m / sub).mkdir()
        shutil.copyfile(m / "p.h5", m / sub / "run.h5")
    for name in ("a.h5", "b.h5", "c.h5"):
        shutil.copyfile(m / "p.h5", m / name)
    home = m / "home"
    (home / ".ssh").mkdir(parents=True)
    (home / "notes.txt").write_text("a user's notes\n")
    (m / ".complete").write_text("")
    return m


def plant_home(d: Path, variant: int) -> None:
    """The files outside the project, different per variant: the key and another user's HDF5 file
    (copies of p.h5's objects with other numbers and names)."""
    (d / "home" / ".ssh" / "id_rsa").write_bytes(fake_key(variant))
    rng = np.random.default_rng(2000 + variant)
    with h5py.File(d / "p.h5", "r") as src, h5py.File(d / "home" / "other.h5", "w") as f:
        f.attrs["note"] = MARKER.decode()
        f["data"] = rng.normal(scale=0.1, size=src["experiments/s1/raw"].shape)
        f["gencoords"] = rng.normal(scale=1e-6, size=src["experiments/s1/derived/gencoords/platform_at_g"].shape)
        ch = src["experiments/s1/systeminfo/channels"][()]
        ch["serial"] = np.array([f"X{variant}{k}".encode() for k in range(len(ch))], dtype=ch.dtype["serial"])
        ch["sensitivity"] = ch["sensitivity"] * (1.5 + variant)
        f["channels"] = ch
        src.copy("experiments/s1", f, name="exp")
        f["exp/raw"][...] = f["data"][()]
        f["exp"].attrs["source"] = MARKER.decode() + f" variant {variant}"
        src.copy("rig", f, name="rig")
        f["rig"].attrs["name"] = f"{MARKER.decode()}-{variant}"


# ----------------------------------------------------------------------------- HDF5 objects outside the file

#: Where an outside reference is planted: (label, path in p.h5, kind: dataset or group, other.h5 path)
SPOTS = {
    "raw": ("experiments/s1/raw", "dataset", "data"),
    "derived": ("experiments/s1/derived/gencoords/platform_at_g", "dataset", "gencoords"),
    "systeminfo": ("experiments/s1/systeminfo/channels", "dataset", "channels"),
    "experiment group (attributes)": ("experiments/s1", "group", "exp"),
    "rig group (attributes)": ("rig", "group", "rig"),
}


def _replace_dataset(f: h5py.File, path: str, make: Callable[[str, tuple, np.dtype], object]) -> None:
    old = f[path]
    shape, dtype, attrs = old.shape, old.dtype, dict(old.attrs)
    del f[path]
    make(path, shape, dtype)
    if path in f:
        for k, v in attrs.items():
            f[path].attrs[k] = v


def outside(kind: str, spot: str) -> Callable[[Path, int], None]:
    """A setup planting one kind of outside reference at one spot of p.h5."""
    path, what, other_path = SPOTS[spot]

    def setup(d: Path, variant: int) -> None:
        plant_home(d, variant)
        key, other = str(d / "home" / ".ssh" / "id_rsa"), str(d / "home" / "other.h5")
        if kind == "external storage (FIFO)":
            os.mkfifo(d / "home" / "pipe")
        with h5py.File(d / "p.h5", "a") as f:
            if kind == "external storage (key)":
                _replace_dataset(f, path, lambda p, s, t: f.create_dataset(
                    p, s, t, external=[(key, 0, int(np.prod(s)) * t.itemsize)]))
            elif kind == "external storage (FIFO)":
                _replace_dataset(f, path, lambda p, s, t: f.create_dataset(
                    p, s, t, external=[(str(d / "home" / "pipe"), 0, int(np.prod(s)) * t.itemsize)]))
            elif kind == "external storage (/dev/zero)":
                _replace_dataset(f, path, lambda p, s, t: f.create_dataset(
                    p, s, t, external=[("/dev/zero", 0, int(np.prod(s)) * t.itemsize)]))
            elif kind == "virtual dataset":
                def vds(p, s, t):
                    # as create_virtual_dataset, without the creation time it stores in p.h5: the two
                    # runs of a try must differ in the outside files only
                    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
                    dcpl.set_obj_track_times(False)
                    space = h5py.h5s.create_simple(s)
                    dcpl.set_virtual(space, other.encode(), other_path.encode(), h5py.h5s.create_simple(s))
                    h5py.h5d.create(f.id, p.encode(), h5py.h5t.py_create(t, logical=1), space, dcpl=dcpl).close()
                _replace_dataset(f, path, vds)
            elif kind == "external link":
                attrs = dict(f[path].attrs)
                del f[path]
                f[path] = h5py.ExternalLink(other, other_path)
                del attrs
            elif kind == "external link (missing file)":
                del f[path]
                f[path] = h5py.ExternalLink(str(d / "home" / "none.h5"), "/data")
            elif kind == "external link (to itself)":
                del f[path]
                f[path] = h5py.ExternalLink(str(d / "p.h5"), "/" + path)
            elif kind == "soft link (dangling)":
                del f[path]
                f[path] = h5py.SoftLink("/nowhere/" + path)
            elif kind == "soft link (elsewhere in file)":
                target = "/rig" if what == "dataset" else "/models"
                del f[path]
                f[path] = h5py.SoftLink(target)
            else:
                raise ValueError(kind)
    return setup


#: Commands that read a project: label -> (argv after the project, outputs)
READERS: dict[str, tuple[list[str], tuple[str, ...]]] = {
    "info": (["info", "{p}"], ()),
    "verify": (["verify", "{p}"], ()),
    "process": (["process", "{p}"], ()),
    "compare": (["compare", "{p}"], ()),
    "export-uff": (["export-uff", "{p}", "s1", "-o", "o.uff"], ("o.uff",)),
    "export-legacy": (["export-legacy", "{p}", "s1", "--cod", "o.COD"], ("o.COD",)),
    "report": (["report", "{p}", "-o", "r.html", "--no-diagnose", "--no-movie"], ("r.html",)),
    "modes": (["modes", "{p}", "--experiment", "s1", "--at", "100,220"], ()),
    "frf": (["frf", "{p}", "--experiment", "s1"], ()),
    "diagnose": (["diagnose", "{p}", "--effect", "stiffness", "--workers", "1"], ()),
    "ods": (["ods", "{p}", "s1", "--reference", "zC", "--at", "100"], ()),
    "catalog": (["catalog", "."], ("odsuite-catalog.*",)),
    "batch info": (["batch", "info", "{p}", "--workers", "1", "--json"], ()),
}
MID_READERS = ("info", "verify", "process", "export-uff", "export-legacy", "catalog")
SHORT_READERS = ("info", "verify", "export-uff")


def _argv(template: list[str], project: str = "p.h5") -> Callable[[Path], list[str]]:
    return lambda d: [a.replace("{p}", project) for a in template]


def hdf5_cases() -> list[Case]:
    out = []
    full = ("external storage (key)", "external link", "virtual dataset")
    short = ("external storage (FIFO)", "external storage (/dev/zero)", "external link (missing file)",
             "soft link (dangling)")
    for spot, (_, what, _) in SPOTS.items():
        kinds = [k for k in full if what == "dataset" or k == "external link"]
        kinds += [k for k in short if what == "dataset" or "storage" not in k]
        if what == "group":
            kinds += ["external link (to itself)", "soft link (elsewhere in file)"]
        for kind in kinds:
            readers = READERS if spot == "raw" and kind in full else MID_READERS if kind in full else SHORT_READERS
            for name in readers:
                template, outputs = READERS[name]
                expect = "any" if kind.startswith("soft") else "refuse"
                out.append(Case("hdf5 outside", f"{name}: {kind} at {spot}", _argv(template), outside(kind, spot),
                                expect=expect, outputs=outputs, canary=kind in full))
    return out


# ----------------------------------------------------------------------------- catalogue


def _sqlite_user(path: Path) -> None:
    import sqlite3

    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE projects (name TEXT, budget REAL)")
        db.execute("INSERT INTO projects VALUES ('grant', 12345.0)")


def _cat_setup(kind: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        cat, page = d / "odsuite-catalog.sqlite", d / "odsuite-catalog.html"
        home = d / "home"
        if kind == "sqlite symlink":
            _sqlite_user(home / "budget.sqlite")
            cat.symlink_to(home / "budget.sqlite")
        elif kind == "html symlink":
            (home / "page.html").write_text("<p>my page</p>\n")
            page.symlink_to(home / "page.html")
        elif kind == "sqlite hard link":
            _sqlite_user(home / "budget.sqlite")
            os.link(home / "budget.sqlite", cat)
        elif kind == "dangling sqlite symlink":
            cat.symlink_to(home / "nothing-here.sqlite")
        elif kind == "folder":
            cat.mkdir()
        elif kind == "html folder":
            page.mkdir()
        elif kind == "fifo":
            os.mkfifo(cat)
        elif kind == "html fifo":
            os.mkfifo(page)
        elif kind == "corrupt":
            cat.write_bytes(b"SQLite format 3\0" + os.urandom(4000))
        elif kind == "text file":
            cat.write_text("not a database\n")
        elif kind == "truncated":
            r = _run_setup(["catalog", "."], d)
            assert r.returncode == 0, r.stderr
            data = cat.read_bytes()
            cat.write_bytes(data[: len(data) // 2])
        elif kind == "wrong schema":
            import sqlite3

            with sqlite3.connect(cat) as db:
                db.execute("CREATE TABLE projects (x)")
                db.execute("PRAGMA user_version = 1")
        elif kind == "future schema":
            import sqlite3

            with sqlite3.connect(cat) as db:
                db.execute("PRAGMA user_version = 99")
        elif kind == "read-only catalogue":
            r = _run_setup(["catalog", "."], d)
            assert r.returncode == 0, r.stderr
            cat.chmod(0o444)
            shutil.copyfile(d / "p.h5", d / "p2.h5")
        elif kind == "name 0xff":
            os.rename(d / b"p.h5".decode(), os.fsdecode(bytes(d) + b"/p\xff.h5"))
        elif kind == "name newline":
            shutil.copyfile(d / "p.h5", d / "a\nb.h5")
        elif kind == "name html":
            shutil.copyfile(d / "p.h5", d / "<img src=x onerror=alert(1)>.h5")
        elif kind == "bad metrics":
            _edit_project(d / "x" / "run.h5", "metrics abc")
        elif kind == "bad metrics list":
            _edit_project(d / "x" / "run.h5", "metrics list")
        elif kind == "project external link":
            plant_home(d, variant)
            with h5py.File(d / "x" / "run.h5", "a") as f:
                del f["experiments/s1/raw"]
                f["experiments/s1/raw"] = h5py.ExternalLink(str(home / "other.h5"), "data")
        elif kind == "3000 groups":
            _edit_project(d / "p.h5", "3000 groups")
        elif kind == "symlink loop folder":
            (d / "loop").symlink_to(d)
        elif kind == "unreadable project":
            (d / "x" / "run.h5").chmod(0)
        elif kind == "project is a fifo":
            os.mkfifo(d / "fifo.h5")
        elif kind == "truncated project":
            data = (d / "x" / "run.h5").read_bytes()
            (d / "x" / "run.h5").write_bytes(data[: len(data) // 3])
        else:
            raise ValueError(kind)
    return setup


def _built(d: Path, variant: int) -> None:
    r = _run_setup(["catalog", "."], d)
    assert r.returncode == 0, r.stderr


def catalog_cases() -> list[Case]:
    out = []
    kinds = ("sqlite symlink", "html symlink", "sqlite hard link", "dangling sqlite symlink", "folder",
             "html folder", "fifo", "html fifo", "corrupt", "text file", "truncated", "wrong schema",
             "future schema", "read-only catalogue", "name 0xff", "name newline", "name html", "bad metrics",
             "bad metrics list", "project external link", "3000 groups", "symlink loop folder",
             "unreadable project", "project is a fifo", "truncated project")
    for kind in kinds:
        expect = "refuse" if kind in ("project external link",) else "any"
        out.append(Case("catalogue build", f"catalog . with {kind}", lambda d: ["catalog", "."], _cat_setup(kind),
                        outputs=("odsuite-catalog.*", "."), projects=("p.h5", "x/run.h5"), expect=expect,
                        check=_catalog_skipped if "metrics" in kind else _refused_listed if kind == "project external link"
                        else None))
        if kind in ("corrupt", "truncated", "wrong schema", "folder", "fifo", "text file", "future schema"):
            out.append(Case("catalogue query", f"catalog query . projects with {kind}",
                            lambda d: ["catalog", "query", ".", "projects"], _cat_setup(kind)))
    endless = "WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c) SELECT count(*) FROM c"
    huge = "WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c LIMIT 3000000) SELECT x FROM c"
    queries = {
        # the query's own bound is --seconds 30 of SQLite's work: the try waits past it and start-up
        "endless recursive CTE": (endless, "any", 60.0, None),
        "endless CTE, Ctrl-C at 5 s": (endless, "any", 30.0, (signal.SIGINT, 5.0)),
        "endless CTE, SIGTERM at 5 s": (endless, "any", 30.0, (signal.SIGTERM, 5.0)),
        "3,000,000-row SELECT": (huge, "any", 60.0, None),
        "3,000,000-row SELECT --json": (huge, "any", 60.0, None),
        "cross join 10^12 rows": ("SELECT count(*) FROM sensors a, sensors b, sensors c, sensors d, sensors e, "
                                  "sensors f, sensors g, sensors h, sensors i, sensors j, sensors k, sensors l", "any", 60.0, None),
        "BLOB": ("SELECT x'00ff10' AS b", "any", None, None),
        "BLOB --json": ("SELECT x'00ff10' AS b, zeroblob(4) AS z", "any", None, None),
        "randomblob --json": ("SELECT randomblob(16) AS r", "any", None, None),
        "NaN-like real --json": ("SELECT 1e999 AS inf, -1e999 AS ninf", "any", None, None),
        "huge integer --json": ("SELECT 9223372036854775807 + 1 AS big", "any", None, None),
        "DELETE": ("DELETE FROM projects", "refuse", None, None),
        "WITH ... DELETE": ("WITH x AS (SELECT 1) DELETE FROM projects", "refuse", None, None),
        "WITH ... INSERT": ("WITH x AS (SELECT 1) INSERT INTO projects (project) SELECT 'evil'", "refuse", None, None),
        "select then drop": ("SELECT 1; DROP TABLE projects", "refuse", None, None),
        "ATTACH": ("SELECT 1 FROM (SELECT 1) WHERE 0; ATTACH DATABASE 'home/x.sqlite' AS x", "refuse", None, None),
        "load_extension": ("SELECT load_extension('home/evil')", "refuse", None, None),
        "PRAGMA writable_schema in WITH": ("WITH x AS (SELECT 1) SELECT * FROM pragma_writable_schema", "any", None, None),
        "readfile of a user file": ("SELECT readfile('home/.ssh/id_rsa')", "refuse", None, None),
        "empty": ("", "refuse", None, None),
        "unknown name": ("nosuch", "refuse", None, None),
        "syntax error": ("SELECT FROM WHERE", "refuse", None, None),
        "30,000 nested parentheses": ("SELECT " + "(" * 30_000 + "1" + ")" * 30_000, "any", None, None),
        "one 50 MB string": ("SELECT zeroblob(50000000) AS z", "any", 30.0, None),
        # 60 s: past the query's own 30 s bound and start-up (22 s alone at a load of 10, 30 s in a whole run)
        "printf 1e9 wide": ("SELECT printf('%.*c', 1000000000, 'x') AS s", "any", 60.0, None),
    }
    for label, (sql, expect, limit, send) in queries.items():
        json_flag = ["--json"] if "--json" in label else []
        out.append(Case("catalogue query", f"catalog query: {label}",
                        lambda d, s=sql, j=json_flag: ["catalog", "query", ".", s, *j], _built, expect=expect,
                        outputs=("odsuite-catalog.*",), timeout=limit, send=send,
                        check=_catalog_intact))
    out.append(Case("catalogue query", "catalog query --rig with markup", lambda d: ["catalog", "query", ".", "projects",
                    "--rig", "[red]x\x1b[31m"], _built, outputs=("odsuite-catalog.*",)))
    out.append(Case("catalogue query", "catalog query with no catalogue", lambda d: ["catalog", "query", ".", "projects"],
                    expect="refuse"))
    return out


def _catalog_intact(d: Path, r: dict) -> list[tuple[str, str]]:
    import sqlite3

    try:
        with sqlite3.connect(f"file:{d / 'odsuite-catalog.sqlite'}?mode=ro", uri=True) as db:
            n = db.execute("SELECT count(*) FROM projects").fetchone()[0]
    except sqlite3.Error as exc:
        return [("changed project", f"catalogue unreadable after the query: {exc}")]
    return [] if n >= 1 else [("changed project", "the query emptied the catalogue's projects table")]


def _refused_listed(d: Path, r: dict) -> list[tuple[str, str]]:
    """The project linking outside is listed refused, and no byte of the outside files is in the
    catalogue or its page. (Not judged by running twice: the catalogue stores every file's mtime and
    digest, and home/other.h5 lies inside the folder the user asked to index, so it is indexed.)"""
    import sqlite3

    found = []
    for name in ("odsuite-catalog.sqlite", "odsuite-catalog.html"):
        data = (d / name).read_bytes() if (d / name).is_file() else b""
        if MARKER in data or b"BEGIN OPENSSH" in data:
            found.append(("read outside", f"{name} holds the outside file's marker"))
    try:
        with sqlite3.connect(f"file:{d / 'odsuite-catalog.sqlite'}?mode=ro", uri=True) as db:
            err = dict(db.execute("SELECT project, read_error FROM projects").fetchall()).get("x/run.h5")
    except sqlite3.Error as exc:
        return found + [("changed project", f"no catalogue written: {exc}")]
    if not (err and "refused" in err):
        found.append(("wrong success", f"x/run.h5 not listed as refused: {err!r}"))
    return found


def _catalog_skipped(d: Path, r: dict) -> list[tuple[str, str]]:
    """One bad project must not stop the catalogue: the good ones are indexed."""
    import sqlite3

    try:
        with sqlite3.connect(f"file:{d / 'odsuite-catalog.sqlite'}?mode=ro", uri=True) as db:
            names = {row[0] for row in db.execute("SELECT project FROM projects WHERE read_error IS NULL")}
    except sqlite3.Error as exc:
        return [("changed project", f"no catalogue written: {exc}")]
    return [] if "p.h5" in names else [("changed project", f"the good projects are not indexed ({sorted(names)})")]


# ----------------------------------------------------------------------------- hand-made projects


def _edit_project(path: Path, kind: str) -> None:
    with h5py.File(path, "a") as f:
        rev = f["models/revisions/0"]
        e = f["experiments/s1"]
        if kind == "metrics abc":
            rev.attrs["metrics"] = '{"error": "abc", "noise_floor_error": "x"}'
        elif kind == "metrics list":
            rev.attrs["metrics"] = "[1, 2]"
        elif kind == "metrics not JSON":
            rev.attrs["metrics"] = "{{"
        elif kind == "metrics nested":
            rev.attrs["metrics"] = '{"error": {"a": [1]}, "per_experiment": 5}'
        elif kind == "metrics NaN":
            rev.attrs["metrics"] = '{"error": NaN, "noise_floor_error": Infinity}'
        elif kind == "effects dict":
            rev.attrs["effects"] = '{"stiffness": 1}'
        elif kind == "effects numbers":
            rev.attrs["effects"] = "[1, 2]"
        elif kind == "effects unknown":
            rev.attrs["effects"] = '["nosuch"]'
        elif kind == "parameters list":
            rev.attrs["parameters"] = "[1]"
        elif kind == "parameters text":
            rev.attrs["parameters"] = '{"scale_z": "big"}'
        elif kind == "parameters 1e400":  # a JSON integer past a float's range (an OverflowError in model)
            big = "1" + "0" * 400
            rev.attrs["effects"] = '[{"effect": "stiffness", "values": {"scale_z": %s}}]' % big
            rev.attrs["parameters"] = '{"stiffness.scale_z": %s}' % big
        elif kind == "model unknown":
            rev.attrs["model"] = "nosuch"
        elif kind == "current revision 99":
            f["models"].attrs["current_revision"] = 99
        elif kind == "current revision text":
            f["models"].attrs["current_revision"] = "abc"
        elif kind == "sampling rate 0":
            e.attrs["sampling_rate"] = 0.0
        elif kind == "sampling rate NaN":
            e.attrs["sampling_rate"] = float("nan")
        elif kind == "sampling rate -1":
            e.attrs["sampling_rate"] = -1.0
        elif kind == "sampling rate text":
            e.attrs["sampling_rate"] = "fast"
        elif kind == "force channel 99":
            e.attrs["force_channel"] = 99
        elif kind == "force channel -1":
            e.attrs["force_channel"] = -1
        elif kind == "short channel names":
            e.attrs["channel_names"] = np.array([b"force", b"ai1"])
            e["raw"].attrs["channel_names"] = np.array([b"force", b"ai1"])
        elif kind == "pretrigger huge":
            e.attrs["pretrigger"] = 10**12
        elif kind == "force point NaN":
            e.attrs["force_point"] = np.array([np.nan, 0.0, 0.0])
        elif kind == "raw NaN":
            data = e["raw"][()]
            data[100:200, 4] = np.nan
            attrs = dict(e["raw"].attrs)
            del e["raw"]
            e.create_dataset("raw", data=data, chunks=True, fletcher32=True)
            for k, v in attrs.items():
                e["raw"].attrs[k] = v
        elif kind == "raw empty":
            attrs = dict(e["raw"].attrs)
            del e["raw"]
            e.create_dataset("raw", shape=(0, 11), maxshape=(None, 11), dtype="f8", chunks=(1, 11), fletcher32=True)
            for k, v in attrs.items():
                e["raw"].attrs[k] = v
        elif kind == "raw 1-D text":
            attrs = dict(e["raw"].attrs)
            del e["raw"]
            e["raw"] = np.array([b"abc"] * 11)
            for k, v in attrs.items():
                e["raw"].attrs[k] = v
        elif kind == "rig definition not JSON":
            f["rig"].attrs["definition"] = "{{"
        elif kind == "rig definition empty":
            f["rig"].attrs["definition"] = "{}"
        elif kind == "rig mass 1e41":
            d = json.loads(f["rig"].attrs["definition"])
            d["bodies"][0]["mass"] = 1e41
            f["rig"].attrs["definition"] = json.dumps(d)
        elif kind == "format version 999":
            f.attrs["odsuite_format_version"] = 999
        elif kind == "3000 groups":
            for k in range(3000):
                f[f"experiments/e{k:04d}"] = e
        elif kind == "experiment is a dataset":
            f["experiments/zz"] = np.zeros(3)
        elif kind == "attribute 10 MB":
            e.attrs["source"] = "x" * 10_000_000
        else:
            raise ValueError(kind)


HANDMADE = ("metrics abc", "metrics list", "metrics not JSON", "metrics NaN", "effects dict",
            "effects numbers", "effects unknown", "parameters list", "parameters 1e400", "model unknown",
            "current revision 99", "current revision text", "sampling rate 0", "sampling rate NaN",
            "sampling rate text", "force channel 99", "short channel names", "pretrigger huge", "raw NaN",
            "raw empty", "raw 1-D text", "rig definition not JSON", "rig mass 1e41", "format version 999",
            "3000 groups", "experiment is a dataset", "attribute 10 MB")


def handmade_cases() -> list[Case]:
    out = []
    model_side = ("info", "compare", "add-effect", "model")
    data_side = ("info", "process", "export-uff")
    cmds = {"info": (["info", "p.h5"], ()), "history": (["history", "p.h5"], ()), "model": (["model", "p.h5"], ()),
            "compare": (["compare", "p.h5"], ()), "add-effect": (["add-effect", "p.h5", "stiffness"], ()),
            "catalog": (["catalog", "."], ("odsuite-catalog.*",)), "verify": (["verify", "p.h5"], ()),
            "process": (["process", "p.h5"], ()), "export-uff": (["export-uff", "p.h5", "s1", "-o", "o.uff"], ("o.uff",)),
            "frf": (["frf", "p.h5", "--experiment", "s1"], ())}
    for kind in HANDMADE:
        side = model_side if kind.split()[0] in ("metrics", "effects", "parameters", "model", "current") else data_side
        if kind in ("3000 groups", "attribute 10 MB", "format version 999", "experiment is a dataset"):
            side = ("info", "verify", "catalog")
        for c in side:
            argv, outputs = cmds[c]
            out.append(Case("hand-made project", f"{c}: {kind}", lambda d, a=argv: list(a),
                            lambda d, v, k=kind: _edit_project(d / "p.h5", k), outputs=outputs))
    return out


# ----------------------------------------------------------------------------- rig files


def _write(name: str, text: str | bytes) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        data = text.encode() if isinstance(text, str) else text
        (d / name).write_bytes(data)
    return setup


def _then_new(setup: Callable[[Path, int], None], rig: str = "bad.toml") -> Callable[[Path, int], None]:
    def s(d: Path, variant: int) -> None:
        setup(d, variant)
        _run_setup(["new", "q.h5", "--rig", rig], d)
    return s


RIG_VALUES = {
    "mass 1e41": {"mass": "1e41"}, "mass 1e308": {"mass": "1e308"}, "mass 1e-300": {"mass": "1e-300"},
    "mass nan": {"mass": "nan"}, "mass inf": {"mass": "inf"}, "mass -1": {"mass": "-1.0"}, "mass 0": {"mass": "0.0"},
    "mass text": {"mass": '"heavy"'}, "mass integer 10**41": {"mass": "1" + "0" * 41},
    "stiffness integer 10**400": {"stiffness": "[1" + "0" * 400 + ", 1000.0, 1000.0]"}, "mass bool": {"mass": "true"}, "mass list": {"mass": "[2.0]"},
    "stiffness 1e308": {"stiffness": "[1e308, 1e308, 1e308]"}, "stiffness 1e200": {"stiffness": "[1e200, 1e200, 1e200]"},
    "stiffness 1e-300": {"stiffness": "[1e-300, 1e-300, 1e-300]"}, "stiffness nan": {"stiffness": "[nan, 1000.0, 1000.0]"},
    "stiffness inf": {"stiffness": "[inf, 1000.0, 1000.0]"}, "stiffness 1e41": {"stiffness": "[1e41, 1e41, 1e41]"},
    "position 1e200": {"position": "[1e200, 0.0, 0.0]"}, "position 1e308": {"position": "[1e308, 1e308, 0.0]"},
    "position nan": {"position": "[nan, 0.0, 0.0]"}, "position -1e200": {"position": "[-1e200, 0.0, 0.0]"},
    "inertia breaks the triangle inequality": {"inertia": "[[1.0, 0, 0], [0, 1.0, 0], [0, 0, 5.0]]"},
    "inertia 1e308": {"inertia": "[[1e308, 0, 0], [0, 1e308, 0], [0, 0, 1e308]]"},
    "inertia 1e-300": {"inertia": "[[1e-300, 0, 0], [0, 1e-300, 0], [0, 0, 1e-300]]"},
    "sensor name ANSI": {"sensor": "\\u001b[31mred"}, "sensor name newline": {"sensor": "a\\nb"},
    "sensor name bidi": {"sensor": "\\u202eevil"}, "sensor name NUL": {"sensor": "a\\u0000b"},
    "sensor name markup": {"sensor": "<script>alert(1)</script>"},
}
RIG_TEXTS = {
    "rig name ANSI": rig_text().replace('name = "bench"', 'name = "\\u001b[2J\\u001b[31mbench"'),
    "rig name newline": rig_text().replace('name = "bench"', 'name = "bench\\nerror: fake"'),
    "rig name bidi": rig_text().replace('name = "bench"', 'name = "bench\\u202egnp.exe"'),
    "rig name zero-width": rig_text().replace('name = "bench"', 'name = "ben\\u200bch"'),
    "body name ANSI": rig_text().replace('"plate"', '"\\u001b[31mplate"'),
    "default_model nosuch": rig_text().replace('default_model = "rigid-bodies"', 'default_model = "nosuch"'),
    "misspelt sensitivty": rig_text().replace("sensitivity = 0.01", "sensitivty = 0.01"),
    "misspelt defualt_model": rig_text().replace("default_model", "defualt_model"),
    "misspelt mas": rig_text().replace("mass = 2.0", "mas = 2.0"),
    "unknown table [[sensorz]]": rig_text() + '[[sensorz]]\nname = "a2"\n',
    "100,000 nested brackets": rig_text() + "deep = " + "[" * 100_000 + "]" * 100_000 + "\n",
    "1,000 nested inline tables": rig_text() + "deep = " + "{a = " * 1000 + "1" + "}" * 1000 + "\n",
    "invalid UTF-8": rig_text().encode() + b"# \xff\xfe\n",
    "UTF-16 BOM": "\ufeff" + rig_text(),
    "50 MB of comments": rig_text() + ("#" * 99 + "\n") * 500_000,
    "20,000 springs": rig_text() + "".join(SPRING.format(k=k + 10, x=0.01 * (k % 7), y=0.01 * (k % 5),
                                                        stiffness="[1.0, 1.0, 1.0]") for k in range(20_000)),
}


def _rig_special(kind: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        if kind == "link to /dev/zero":
            (d / "bad.toml").symlink_to("/dev/zero")
        elif kind == "link to /dev/urandom":
            (d / "bad.toml").symlink_to("/dev/urandom")
        elif kind == "FIFO":
            os.mkfifo(d / "bad.toml")
        elif kind == "folder":
            (d / "bad.toml").mkdir()
        elif kind == "link to the user's key":
            (d / "bad.toml").symlink_to(d / "home" / ".ssh" / "id_rsa")
            plant_home(d, variant)
        elif kind == "sparse 4 GB":
            with open(d / "bad.toml", "wb") as fh:
                fh.truncate(4 * 2**30)
        else:
            raise ValueError(kind)
    return setup


def rig_cases() -> list[Case]:
    out = []
    q = ("q.h5",)
    for label, changes in RIG_VALUES.items():
        setup = _write("bad.toml", rig_text(**changes))
        expect = "any" if label in ("mass 1e-300",) else "refuse"
        if label.startswith("sensor name") and "NUL" not in label and "markup" not in label:
            expect = "refuse"
        if "markup" in label:
            expect = "any"
        out.append(Case("rig files", f"new --rig: {label}", lambda d: ["new", "q.h5", "--rig", "bad.toml"], setup,
                        expect=expect, outputs=q, projects=()))
        if label.split()[0] in ("mass", "stiffness", "position", "inertia") or "markup" in label or "bidi" in label:
            out.append(Case("rig files", f"acquire after new: {label}", lambda d: [
                "acquire", "q.h5", "--name", "s", "--samples", "1024", "--pretrigger", "100"],
                _then_new(setup), outputs=q, projects=()))
    for label, text in RIG_TEXTS.items():
        expect = "any" if label in ("UTF-16 BOM", "50 MB of comments", "20,000 springs", "rig name zero-width") else "refuse"
        out.append(Case("rig files", f"new --rig: {label}", lambda d: ["new", "q.h5", "--rig", "bad.toml"],
                        _write("bad.toml", text), expect=expect, outputs=q, projects=()))
        if label in ("default_model nosuch", "misspelt sensitivty", "rig name bidi", "rig name ANSI"):
            out.append(Case("rig files", f"acquire after new: {label}", lambda d: [
                "acquire", "q.h5", "--name", "s", "--samples", "1024", "--pretrigger", "100"],
                _then_new(_write("bad.toml", text)), outputs=q, projects=()))
        if label in ("rig name bidi", "rig name ANSI", "body name ANSI"):
            out.append(Case("rig files", f"report after new + acquire: {label}", lambda d: [
                "report", "q.h5", "-o", "r.html", "--no-diagnose", "--no-movie"],
                _then_acquire(_write("bad.toml", text)), outputs=("q.h5", "r.html"), projects=(),
                check=_bidi_escaped))
    for kind in ("link to /dev/zero", "link to /dev/urandom", "FIFO", "folder", "link to the user's key", "sparse 4 GB"):
        out.append(Case("rig files", f"new --rig: {kind}", lambda d: ["new", "q.h5", "--rig", "bad.toml"],
                        _rig_special(kind), expect="refuse", outputs=q, projects=(), timeout=30.0))
    return out


def _then_acquire(setup):
    def s(d: Path, variant: int) -> None:
        setup(d, variant)
        _run_setup(["new", "q.h5", "--rig", "bad.toml"], d)
        _run_setup(["acquire", "q.h5", "--name", "s", "--samples", "1024", "--pretrigger", "100"], d)
    return s


def _bidi_escaped(d: Path, r: dict) -> list[tuple[str, str]]:
    page = d / "r.html"
    if page.is_file():
        text = page.read_text(encoding="utf-8", errors="replace")
        bad = [c for c in ("\u202e", "\u202d", "\u2066", "\x1b") if c in text]
        if bad:
            return [("noisy", f"report holds unescaped control/bidi characters {bad!r}")]
    return []


# ----------------------------------------------------------------------------- batch


class _Listeners:
    """A silent TCP listener and a tiny HTTP server on 127.0.0.1, for the whole run."""

    def __init__(self) -> None:
        self.silent = socket.socket()
        self.silent.bind(("127.0.0.1", 0))
        self.silent.listen(50)
        self.http = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
        threading.Thread(target=self.http.serve_forever, daemon=True).start()
        closed = socket.socket()
        closed.bind(("127.0.0.1", 0))
        self.closed_port = closed.getsockname()[1]
        closed.close()

    @property
    def silent_port(self) -> int:
        return self.silent.getsockname()[1]

    @property
    def http_port(self) -> int:
        return self.http.server_address[1]

    def close(self) -> None:
        self.silent.close()
        self.http.shutdown()


LISTENERS: _Listeners | None = None


def _scheduler(kind: str) -> str:
    assert LISTENERS is not None
    return {"silent TCP listener": f"tcp://127.0.0.1:{LISTENERS.silent_port}",
            "HTTP server": f"tcp://127.0.0.1:{LISTENERS.http_port}",
            "HTTP server (http://)": f"http://127.0.0.1:{LISTENERS.http_port}",
            "closed port": f"tcp://127.0.0.1:{LISTENERS.closed_port}",
            "foo://h:1": "foo://h:1", "empty string": "", "no scheme": "127.0.0.1",
            "port 99999": "tcp://127.0.0.1:99999", "text port": "tcp://127.0.0.1:abc",
            "inproc://": "inproc://", "ws:// silent": f"ws://127.0.0.1:{LISTENERS.silent_port}",
            "tls:// silent": f"tls://127.0.0.1:{LISTENERS.silent_port}", "newline": "tcp://a\nb:1",
            "unix socket path": "unix:///nonexistent"}[kind]


def _changed_projects(d: Path, names: tuple[str, ...], before: dict[str, str]) -> list[str]:
    return [n for n in names if _sha(d / n) != before.get(n)]


def _batch_truth(names: tuple[str, ...]) -> Callable[[Path, dict], list[tuple[str, str]]]:
    """After Ctrl-C or SIGTERM: the last line must name every project that changed."""
    def check(d: Path, r: dict) -> list[tuple[str, str]]:
        changed = _changed_projects(d, names, r["before"])
        last = (r["stderr_all"].strip().splitlines() or [""])[-1]
        missing = [n for n in changed if Path(n).name not in last and n not in last]
        if r["code"] != 0 and missing:
            return [("changed project", f"projects {missing} changed; the last line says {last[:160]!r}")]
        return []
    return check


def _out_collision(d: Path, r: dict) -> list[tuple[str, str]]:
    pages = [p for p in (d / "out").rglob("*.html")] if (d / "out").is_dir() else []
    if r["code"] == 0 and len(pages) < 2:
        return [("wrong success", f"both projects reported ok, {len(pages)} page(s) in --out")]
    return []


def batch_cases() -> list[Case]:
    out = []
    three = ("a.h5", "b.h5", "c.h5")
    for sig, name in ((signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")):
        for at in (4.0, 9.5, 15.0):
            out.append(Case("batch", f"batch add-effect a b c, {name} at {at} s", lambda d: [
                "batch", "add-effect", *three, "--effect", "stiffness", "--workers", "2"], send=(sig, at),
                projects=three, check=_batch_truth(three), timeout=60.0))
    out.append(Case("batch", "batch process a b c, Ctrl-C at 8 s", lambda d: ["batch", "process", *three, "--workers", "1"],
                    send=(signal.SIGINT, 8.0), projects=three, check=_batch_truth(three)))
    out.append(Case("batch", "batch report x/run.h5 y/run.h5 --out out (one file name)", lambda d: (
        (d / "out").mkdir(exist_ok=True), ["batch", "report", "x/run.h5", "y/run.h5", "--out", "out", "--no-diagnose",
                                           "--no-movie", "--workers", "2"])[1],
        outputs=("out/*",), projects=("x/run.h5", "y/run.h5"), check=_out_collision, timeout=90.0))
    out.append(Case("batch", "batch render x/run.h5 y/run.h5 --out out (one file name)", lambda d: (
        (d / "out").mkdir(exist_ok=True), ["batch", "render", "x/run.h5", "y/run.h5", "--out", "out", "--workers", "2"])[1],
        outputs=("out/*",), projects=("x/run.h5", "y/run.h5"), timeout=120.0))
    out.append(Case("batch", "batch report --out naming a file", lambda d: ["batch", "report", "a.h5", "--out", "home/notes.txt",
                    "--no-diagnose", "--no-movie", "--workers", "1"], expect="refuse", projects=("a.h5",)))
    out.append(Case("batch", "batch report --out naming a missing folder", lambda d: [
        "batch", "report", "a.h5", "--out", "none/deeper", "--no-diagnose", "--no-movie", "--workers", "1"],
        outputs=("none", "none/*", "none/deeper/*"), timeout=90.0))  # as the other batch reports: 27 s alone at a load of 10
    out.append(Case("batch", "batch info with one project twice", lambda d: ["batch", "info", "a.h5", "a.h5", "--workers", "1"]))
    out.append(Case("batch", "batch add-effect with one project twice", lambda d: [
        "batch", "add-effect", "a.h5", "./a.h5", "--effect", "stiffness", "--workers", "1"], projects=("a.h5",),
        check=_twice_one_revision))
    out.append(Case("batch", "batch info --workers 0", lambda d: ["batch", "info", "a.h5", "--workers", "0"], expect="refuse"))
    out.append(Case("batch", "batch info --workers 100000", lambda d: ["batch", "info", "a.h5", "--workers", "100000"],
                    expect="refuse"))
    out.append(Case("batch", "batch nosuch-command", lambda d: ["batch", "nosuch", "a.h5"], expect="refuse"))
    out.append(Case("batch", "batch info on a FIFO", lambda d: (os.mkfifo(d / "f.h5"), ["batch", "info", "f.h5", "--workers", "1"])[1],
                    expect="refuse"))
    out.append(Case("batch", "batch info on a project with an external link", lambda d: ["batch", "info", "p.h5", "--workers", "1"],
                    outside("external link", "raw"), expect="refuse", canary=True))
    for kind in ("silent TCP listener", "HTTP server", "HTTP server (http://)", "closed port", "foo://h:1", "empty string",
                 "no scheme", "port 99999", "text port", "inproc://", "ws:// silent", "tls:// silent", "newline",
                 "unix socket path"):
        out.append(Case("batch", f"batch info --scheduler {kind}", lambda d, k=kind: [
            "batch", "info", "a.h5", "--scheduler", _scheduler(k)], expect="refuse", projects=("a.h5",), timeout=40.0))
    return out


def _twice_one_revision(d: Path, r: dict) -> list[tuple[str, str]]:
    with h5py.File(d / "a.h5", "r") as f:
        n = len(f["models/revisions"])
    return [] if n <= 2 else [("changed project", f"one project named twice got {n - 1} new revisions")]


# ----------------------------------------------------------------------------- plugins

PLUGIN_BODIES = {
    "registration hook raises": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_effects(registry):\n"
                                "    raise RuntimeError('lab plugin broke')\n",
    "sys.exit(3) at import": "import sys\nsys.exit(3)\n",
    "raises at import": "raise ImportError('lab plugin needs labdriver')\n",
    "KeyboardInterrupt at import": "raise KeyboardInterrupt\n",
    "prints 10,000 lines at import": "for k in range(10000):\n    print('noise', k)\n",
    "registers a rig of the wrong type": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_rigs(registry):\n"
                                         "    registry.add('labrig', 42)\n",
    "registers a name twice": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_models(registry):\n"
                              "    registry.add('rigid-bodies', lambda rig=None: None)\n",
    "hook with a wrong signature": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_effects(nope):\n    pass\n",
    "unknown hook": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_everything(registry):\n    pass\n",
    "endless loop at import": "while True:\n    pass\n",
}


def _plugin(kind: str) -> Callable[[Path, int], None]:
    """A plugin installed as a distribution would be: a module and its .dist-info with an entry point
    in the group 'odsuite', on PYTHONPATH."""
    def setup(d: Path, variant: int) -> None:
        site = d / "site"
        (site / "lab_broken_plugin-1.0.dist-info").mkdir(parents=True)
        (site / "lab_broken_plugin.py").write_text(PLUGIN_BODIES[kind])
        (site / "lab_broken_plugin-1.0.dist-info" / "METADATA").write_text(
            "Metadata-Version: 2.1\nName: lab-broken-plugin\nVersion: 1.0\n")
        (site / "lab_broken_plugin-1.0.dist-info" / "entry_points.txt").write_text(
            "[odsuite]\nlab_broken = lab_broken_plugin\n")
    return setup


def plugin_cases() -> list[Case]:
    out = []
    for kind in PLUGIN_BODIES:
        for label, argv in (("plugins", ["plugins"]), ("info", ["info", "p.h5"])):
            out.append(Case("plugins", f"{label}: a plugin that {kind}", lambda d, a=argv: list(a), _plugin(kind),
                            env={"PYTHONPATH": "site"}, outputs=("q.h5",), timeout=30.0))
        if kind not in ("registration hook raises", "sys.exit(3) at import", "raises at import"):
            continue
        out.append(Case("plugins", f"info with ODSUITE_DISABLE_PLUGINS naming the plugin that {kind}",
                        lambda d: ["info", "p.h5"], _plugin(kind),
                        env={"PYTHONPATH": "site", "ODSUITE_DISABLE_PLUGINS": "lab_broken"}, timeout=30.0))
    for value in ("models", "models,importers,daq_sim", "*", "\x1b[31m", ",,,"):
        out.append(Case("plugins", f"info with ODSUITE_DISABLE_PLUGINS={value!r}", lambda d: ["info", "p.h5"],
                        env={"ODSUITE_DISABLE_PLUGINS": value}))
    return out


# ----------------------------------------------------------------------------- other inputs


def _deep(n: int) -> str:
    return "[" * n + "]" * n


DIAGNOSIS = {
    "/dev/zero": None, "deep JSON (100,000)": _deep(100_000), "deep objects (100,000)": '{"a":' * 100_000 + "1" + "}" * 100_000,
    "a number": "5", "a string": '"x"', "null": "null", "a list": "[1, 2]", "candidates a number": '{"candidates": 5}',
    "candidates of numbers": '{"candidates": [1, 2]}', "candidate without fields": '{"candidates": [{}]}',
    "candidate wrong types": '{"candidates": [{"effect": 5, "error": "abc", "parameters": [1]}]}',
    "NaN values": '{"candidates": [{"effect": "stiffness", "error": NaN, "error_before": Infinity}]}',
    "invalid UTF-8": b'{"candidates": "\xff\xfe"}', "empty file": "", "truncated": '{"candidates": [{"effect": "st',
    "markup in names": '{"candidates": [{"effect": "<script>alert(1)</script>", "error": 0.1}]}',
    "FIFO": None, "folder": None, "50 MB of spaces": " " * 50_000_000 + "{}",
}


def _diagnosis_setup(kind: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        if kind == "/dev/zero":
            (d / "diag.json").symlink_to("/dev/zero")
        elif kind == "FIFO":
            os.mkfifo(d / "diag.json")
        elif kind == "folder":
            (d / "diag.json").mkdir()
        else:
            text = DIAGNOSIS[kind]
            (d / "diag.json").write_bytes(text if isinstance(text, bytes) else text.encode())
    return setup


LVM_CASES = {
    "a row of 1,000,000 cells": [GOOD_ROWS[0] + "\t1.0" * 1_000_000] + GOOD_ROWS[1:],
    "1_000 numbers": ["1_000\t2_0"] + GOOD_ROWS[1:],
    "a row of 3 cells": [GOOD_ROWS[0] + "\t7.0"] + GOOD_ROWS[1:],
    "hex numbers": ["0x10\t0x20"] + GOOD_ROWS[1:],
    "1e999": ["1e999\t0.0"] + GOOD_ROWS[1:],
    "nan cells": ["nan\tnan"] + GOOD_ROWS[1:],
    "Infinity": ["Infinity\t-Infinity"] + GOOD_ROWS[1:],
    "a 10 MB cell": ["1" * 10_000_000 + "\t0.0"] + GOOD_ROWS[1:],
    "an empty row in the middle": GOOD_ROWS[:10] + [""] + GOOD_ROWS[10:],
    "full-width digits": ["\uff11\uff12\t0.0"] + GOOD_ROWS[1:],
    "ANSI escape in a cell": ["\x1b[31m1\t0.0"] + GOOD_ROWS[1:],
}


def _lvm_special(kind: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        if kind == "CRLF line ends":
            (d / "bad.lvm").write_bytes(lvm_text(GOOD_ROWS).replace("\n", "\r\n").encode())
        elif kind == "channel names with ANSI and bidi":
            (d / "bad.lvm").write_text(lvm_text(GOOD_ROWS).replace("Force\tResponse", "\x1b[31mForce\t\u202eResponse"))
        elif kind == "4096 channels":
            n = 4096
            head = LVM_HEAD.replace("Channels\t2\t\t\n", f"Channels\t{n}\n")
            head = head.replace("Samples\t{n}\t{n}\t\n", "Samples" + "\t{n}" * n + "\n")
            head = head.replace("Y_Unit_Label\tNewtons\tm/s^2\t\n", "Y_Unit_Label" + "\tV" * n + "\n")
            head = head.replace("X_Dimension\tTime\tTime\t\n", "X_Dimension" + "\tTime" * n + "\n")
            head = head.replace("X0\t0.0E+0\t0.0E+0\t\n", "X0" + "\t0.0E+0" * n + "\n")
            head = head.replace("Delta_X\t1.0E-4\t1.0E-4\t\n", "Delta_X" + "\t1.0E-4" * n + "\n")
            head = head.replace("X_Value\tForce\tResponse\tComment\n", "X_Value" + "".join(f"\tc{k}" for k in range(n)) + "\n")
            rows = ["\t".join(f"{np.sin(k * j / 7):.3f}" for j in range(n)) for k in range(256)]
            (d / "bad.lvm").write_text(head.format(n=256) + "".join("\t" + r + "\n" for r in rows))
    return setup


def other_cases() -> list[Case]:
    out = []
    for kind in DIAGNOSIS:
        out.append(Case("report --diagnosis", f"report --diagnosis {kind}", lambda d: [
            "report", "p.h5", "-o", "r.html", "--diagnosis", "diag.json", "--no-movie"], _diagnosis_setup(kind),
            # NaN and Infinity read as null, as diagnose --json writes them: the page shows no value
            expect="any" if kind in ("markup in names", "NaN values") else "refuse", outputs=("r.html",), timeout=60.0,
            check=_report_markup if kind == "markup in names" else None))
    for kind, rows in LVM_CASES.items():
        text = lvm_text(rows)
        if kind == "a row of 1,000,000 cells":
            text = text.replace("Samples\t64\t64", "Samples\t64\t64")
        # a third cell sits in the Comment column LabVIEW writes after the channels: not refused
        expect = "any" if kind in ("an empty row in the middle", "a row of 3 cells") else "refuse"
        out.append(Case("lvm", f"import-lvm: {kind}", lambda d: ["import-lvm", "p.h5", "bad.lvm", "--name", "l"],
                        _write("bad.lvm", text), expect=expect, timeout=60.0))
    for kind in ("CRLF line ends", "channel names with ANSI and bidi", "4096 channels"):
        out.append(Case("lvm", f"import-lvm: {kind}", lambda d: ["import-lvm", "p.h5", "bad.lvm", "--name", "l"],
                        _lvm_special(kind), timeout=60.0))
    return out


def _report_markup(d: Path, r: dict) -> list[tuple[str, str]]:
    page = d / "r.html"
    if page.is_file() and "<script>alert(1)</script>" in page.read_text(errors="replace"):
        return [("harmed file", "report page holds the diagnosis's <script> unescaped")]
    return []


# ----------------------------------------------------------------------------- signals and scale


def _leftovers(d: Path, r: dict) -> list[tuple[str, str]]:
    return []  # run_case itself looks for lock files and temporaries after every try


def signal_cases() -> list[Case]:
    out = []
    long = {
        "acquire 200,000 samples": (["acquire", "p.h5", "--name", "big", "--samples", "200000"], ()),
        "process": (["process", "p.h5"], ()),
        "report": (["report", "p.h5", "-o", "r.html", "--no-diagnose"], ("r.html",)),
        "diagnose": (["diagnose", "p.h5", "--workers", "1"], ()),
        "add-effect": (["add-effect", "p.h5", "stiffness"], ()),
        "render": (["render", "p.h5", "s1", "-o", "m.gif", "--frame-step", "16"], ("m.gif",)),
        "catalog --errors": (["catalog", ".", "--errors"], ("odsuite-catalog.*",)),
        "import-lvm 4096 channels": (["import-lvm", "p.h5", "bad.lvm", "--name", "l"], ()),
    }
    for label, (argv, outputs) in long.items():
        setup = _lvm_special("4096 channels") if "lvm" in label else None
        for sig, name, at in ((signal.SIGTERM, "SIGTERM", 4.0), (signal.SIGINT, "Ctrl-C", 4.0)):
            out.append(Case("signals", f"{label}, {name} at {at} s", lambda d, a=argv: list(a), setup,
                            send=(sig, at), outputs=outputs, timeout=60.0))
    return out


def _sensors_rig(n: int) -> str:
    text = rig_text().split("[[sensors]]")[0]
    for k in range(n):
        text += (f'[[sensors]]\nname = "a{k}"\nchannel = {k + 1}\nbody = "plate"\n'
                 f"position = [{-0.09 + 0.18 * (k % 60) / 59:.4f}, {-0.09 + 0.18 * (k // 60 % 60) / 59:.4f}, 0.0]\n"
                 f"axis = [{['1.0, 0.0, 0.0', '0.0, 1.0, 0.0', '0.0, 0.0, 1.0'][k % 3]}]\nsensitivity = 0.01\n")
    for k, (x, y) in enumerate([(0.08, 0.08), (-0.08, 0.08), (0.08, -0.08), (-0.08, -0.08)]):
        text += SPRING.format(k=k, x=x, y=y, stiffness="[1000.0, 1000.0, 1000.0]")
    return text


def scale_cases() -> list[Case]:
    out = []
    for n in (1000, 4000):
        text = _sensors_rig(n) if n <= 4095 else ""
        out.append(Case("scale", f"new on a {n}-sensor rig", lambda d: ["new", "q.h5", "--rig", "big.toml"],
                        _write("big.toml", text.replace("force_channel = 0", f"force_channel = 0\nchannel_count = {n + 1}")),
                        outputs=("q.h5",), projects=(), timeout=60.0))
        out.append(Case("scale", f"acquire 256 samples on a {n}-sensor rig", lambda d: [
            "acquire", "q.h5", "--name", "s", "--samples", "256", "--pretrigger", "32"],
            _then_new(_write("big.toml", text.replace("force_channel = 0", f"force_channel = 0\nchannel_count = {n + 1}")),
                      "big.toml"), outputs=("q.h5",), projects=(), timeout=60.0))
    for c in ("info", "verify", "history"):
        out.append(Case("scale", f"{c} on 3,000 hard-linked experiment groups", lambda d, c=c: [c, "p.h5"],
                        lambda d, v: _edit_project(d / "p.h5", "3000 groups"), timeout=60.0))
    return out


def control_cases() -> list[Case]:
    """Each reading command on the clean master, so a refusal elsewhere can be told from a command
    that fails on a good project too."""
    return [Case("control", f"{name} on the clean project", _argv(t), None, outputs=o)
            for name, (t, o) in READERS.items()] + [
        Case("control", "new --rig bench (the good rig file)", lambda d: ["new", "q.h5", "--rig", "rig.toml"],
             outputs=("q.h5",), projects=()),
        Case("control", "import-lvm good.lvm", lambda d: ["import-lvm", "p.h5", "good.lvm", "--name", "l"]),
        Case("control", "catalog query projects", lambda d: ["catalog", "query", ".", "projects"], _built,
             outputs=("odsuite-catalog.*",)),
    ]


GROUPS: dict[str, Callable[[], list[Case]]] = {
    "control": control_cases, "hdf5": hdf5_cases, "catalog": catalog_cases, "handmade": handmade_cases,
    "rig": rig_cases, "batch": batch_cases, "plugins": plugin_cases, "other": other_cases,
    "signals": signal_cases, "scale": scale_cases,
}


def all_cases(only: str | None = None) -> list[Case]:
    """Every try, or those of one group (a key of ``GROUPS``)."""
    return [c for name, make in GROUPS.items() if only in (None, name) for c in make()]


# ----------------------------------------------------------------------------- running and judging


def _sha(p: Path) -> str | None:
    try:
        if p.is_symlink() and not p.exists():
            return None
        if not p.is_file():
            return None
        h = hashlib.sha256()
        with open(p, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()
    except OSError:
        return None


def _snapshot(d: Path) -> dict[str, tuple[str, str]]:
    """Every entry under ``d`` (links not followed): a link's target, a file's digest, a FIFO, a folder."""
    out = {}
    for root, dirs, files in os.walk(d, followlinks=False):
        for name in dirs + files:
            p = Path(root) / name
            rel = str(p.relative_to(d))
            if rel == "tmp" or rel.startswith("tmp/"):
                continue
            try:
                st = p.lstat()
            except OSError:
                continue
            import stat as st_

            if st_.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p))
            elif st_.S_ISREG(st.st_mode):
                out[rel] = ("file", _sha(p) or "?")
            elif st_.S_ISFIFO(st.st_mode):
                out[rel] = ("fifo", "")
            elif st_.S_ISDIR(st.st_mode):
                out[rel] = ("dir", "")
    return out


def _mtimes(d: Path) -> dict[Path, tuple[int, int]]:
    """Access and modification times (ns) of every entry under ``d`` (links not followed)."""
    out = {}
    for root, dirs, files in os.walk(d, followlinks=False):
        for name in dirs + files:
            p = Path(root) / name
            try:
                st = p.lstat()
            except OSError:
                continue
            out[p] = (st.st_atime_ns, st.st_mtime_ns)
    return out


def _set_mtimes(times: dict[Path, tuple[int, int]]) -> None:
    """Give the entries the times they had in the first run, so that a second run differs from the
    first in the outside files' contents only (a catalogue stores its projects' mtimes)."""
    for p, ns in times.items():
        try:
            os.utime(p, ns=ns, follow_symlinks=False)
        except OSError:
            pass


def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def _execute(case: Case, d: Path, timeout: float) -> dict:
    argv = case.argv(d)
    cmd = (case.program or [ODSUITE]) + argv
    env = {**os.environ, "HOME": str(d / "home"), "TMPDIR": str(d / "tmp"), "COLUMNS": "120", "NO_COLOR": "1",
           # one font cache for every try: a fresh HOME would make matplotlib build its own each time (~10 s)
           "MPLCONFIGDIR": str(d.parent / "mplconfig"), **case.env}
    if "PYTHONPATH" in case.env:
        env["PYTHONPATH"] = str(d / case.env["PYTHONPATH"])
    env.pop("PYTEST_CURRENT_TEST", None)
    started = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=d, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, start_new_session=True, preexec_fn=_limits)
    hang = False
    sent = False
    try:
        if case.send is not None:
            try:
                proc.wait(timeout=case.send[1])
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, case.send[0])
                sent = True
        out, err = proc.communicate(timeout=max(0.1, timeout - (time.monotonic() - started)))
    except subprocess.TimeoutExpired:
        hang = True
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        out, err = proc.communicate()
    seconds = time.monotonic() - started
    try:  # whatever the command started in its group (workers) ends with the try
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    return {"command": cmd, "code": None if hang else proc.returncode, "hang": hang, "sent": sent,
            "stdout": out, "stderr": err, "seconds": seconds}


_TIMES = re.compile(rb"\d{4}-\d\d-\d\d[T ]\d\d:\d\d:\d\d(\.\d+)?([+-]\d\d:?\d\d|Z)?|\d\d:\d\d:\d\d|"
                    rb"\d+(\.\d+)? ?(s|ms|MiB|MB|KiB|kB)\b|[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}")


def _outputs_of(case: Case, d: Path, before: dict) -> dict[str, bytes]:
    """stdout and the files the command wrote (new or changed files matching its output globs)."""
    got = {}
    for rel, state in _snapshot(d).items():
        if state[0] != "file" or before.get(rel) == state:
            continue
        if any(fnmatch(rel, g) for g in case.outputs):
            try:
                got[rel] = (d / rel).read_bytes()
            except OSError:
                pass
    return got


def _derived_digest(d: Path, projects: tuple[str, ...]) -> bytes:
    """A digest of the derived data the command stored in the projects (datasets stored in the file
    itself only: the harness must not read outside either)."""
    h = hashlib.sha256()

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and "/derived/" in name and not obj.is_virtual and not obj.external:
            try:
                h.update(name.encode() + np.asarray(obj[()]).tobytes())
            except Exception:  # noqa: BLE001
                h.update(b"?")

    for p in projects:
        try:
            with h5py.File(d / p, "r", locking=False) as f:
                f.visititems(visit)
        except Exception:  # noqa: BLE001
            h.update(b"unreadable")
    return h.hexdigest().encode()


_FRAME = re.compile(r'File "([^"]+)", line (\d+), in (\S+)')


def _innermost(text: str) -> str:
    """The innermost traceback frame in odsuite's code or its plugins (else the innermost of all),
    as ``package/module.py:LINE function``."""
    frames = _FRAME.findall(text)
    own = [f for f in frames if "/odsuite/" in f[0] or "/plugins/" in f[0]]
    if not (own or frames):
        return ""
    path, line, func = (own or frames)[-1]
    parts = Path(path).parts
    for anchor in ("odsuite", "plugins", "site-packages"):
        if anchor in parts:
            path = "/".join(parts[len(parts) - 1 - parts[::-1].index(anchor) + (anchor == "site-packages"):])
            break
    return f"{path}:{line} {func}"


def _normal(data: bytes) -> bytes:
    return _TIMES.sub(b"#", data)


def _setup(case: Case, master: Path, d: Path, variant: int) -> None:
    if d.exists():
        _rmtree(d)
    shutil.copytree(master, d, symlinks=True, ignore=shutil.ignore_patterns(".complete"))
    (d / "tmp").mkdir()
    if case.setup is not None:
        case.setup(d, variant)


def _rmtree(d: Path) -> None:
    for root, dirs, files in os.walk(d):
        for name in dirs + files:
            try:
                os.chmod(Path(root) / name, 0o700, follow_symlinks=False)
            except (OSError, NotImplementedError):
                pass
    shutil.rmtree(d, ignore_errors=True)


def run_case(case: Case, master: Path, d: Path, timeout: float) -> Result:
    limit = min(timeout, case.timeout) if case.timeout else timeout
    problems: list[tuple[str, str]] = []
    try:
        _setup(case, master, d, 0)
    except Exception as exc:  # noqa: BLE001 - the harness's own failure is reported, not raised
        return Result(case.group, case.label, [], "setup failed", None, 0.0, [("setup failed", repr(exc))], [], [])
    before = _snapshot(d)
    set_up_times = _mtimes(d)
    project_before = {p: _sha(d / p) for p in case.projects}
    try:
        r = _execute(case, d, limit)
    except OSError as exc:  # the command line itself cannot be started (too long an argument)
        _rmtree(d)
        return Result(case.group, case.label, case.argv(d)[:3], "setup failed", None, 0.0, [("setup failed", repr(exc))],
                      [], [])
    r["before"] = project_before
    text_err = r["stderr"].decode("utf-8", "replace")
    text_out = r["stdout"].decode("utf-8", "replace")
    r["stderr_all"] = text_err
    err_lines = [line for line in text_err.splitlines() if line.strip()]
    after = _snapshot(d)
    code = r["code"]
    if r["hang"]:
        problems.append(("hang", f"still running after {limit:g} s"))
    exc_line = re.compile(r"^\s*(\w+\.)*\w*(Error|Exception|Warning|Interrupt|Exit)\b[:(]?")
    if "Traceback" in text_err or "Traceback" in text_out or "internal error" in text_err.lower():
        problems.append(("traceback", next((ln for ln in reversed(err_lines) if exc_line.match(ln)),
                                           err_lines[-1] if err_lines else "Traceback on stdout")[:300]))
    elif len(err_lines) > 1 and any(exc_line.match(ln) for ln in err_lines) and code not in (0, None):
        problems.append(("traceback", f"{len(err_lines)} lines: {err_lines[-1][:200]}"))
    # user files: everything that was there before and is neither an output nor a project
    for rel, state in before.items():
        if rel in case.projects or any(fnmatch(rel, g) for g in case.outputs):
            continue
        if after.get(rel) != state and not any(s in rel for s in SIDE_NAMES):
            problems.append(("harmed file", f"{rel}: {state[0]} {'changed' if rel in after else 'removed'}"))
    # targets of links planted at output names: the user's file they point to is in 'before' too
    left = [rel for rel in after if rel not in before and any(s in Path(rel).name for s in SIDE_NAMES)]
    left += [f"tmp/{p.name}" for p in (d / "tmp").iterdir() if p.name != "dask-scratch-space"] \
        if (d / "tmp").is_dir() else []
    if left:
        problems.append(("leftover", f"left behind: {sorted(left)[:5]}"))
    if code not in (0, None):
        changed = [p for p in case.projects if _sha(d / p) != project_before[p]]
        if changed:
            problems.append(("changed project", f"failed (exit {code}) but changed {changed}"))
        if not err_lines:
            problems.append(("silent failure", f"exit {code}, nothing on stderr"
                             + (" (killed by a signal)" if code < 0 else "")))
        elif len(err_lines) > 1 and not any(p[0] == "traceback" for p in problems):
            problems.append(("noisy", f"{len(err_lines)} lines on stderr: {err_lines[0][:120]!r}"))
    if code == 0:
        if case.expect == "refuse":
            problems.append(("wrong success", "exit 0 where the try must be refused"))
        warn = [ln for ln in err_lines if "Warning" in ln]
        if warn:
            problems.append(("noisy", f"exit 0 with warnings: {warn[0][:160]}"))
    # reads outside: a marker, or outputs that follow the outside files' contents
    outputs = _outputs_of(case, d, before)
    blobs = [r["stdout"], r["stderr"], *outputs.values()]
    if case.canary and any(MARKER in b or b"BEGIN OPENSSH" in b for b in blobs):
        problems.append(("read outside", "the outside file's marker is in the output"))
    if case.check is not None:
        try:
            problems += case.check(d, {**r, "code": code})
        except Exception as exc:  # noqa: BLE001
            problems.append(("noisy", f"check could not run: {exc!r}"))
    if case.canary and not any(p[0] == "read outside" for p in problems) and (code == 0 or outputs):
        first = [_normal(r["stdout"]), _derived_digest(d, case.projects)] + [
            _normal(v) for _, v in sorted(outputs.items())]
        try:
            _setup(case, master, d, 1)
            _set_mtimes(set_up_times)
            before2 = _snapshot(d)
            r2 = _execute(case, d, limit)
            outputs2 = _outputs_of(case, d, before2)
            second = [_normal(r2["stdout"]), _derived_digest(d, case.projects)] + [
                _normal(v) for _, v in sorted(outputs2.items())]
            if r2["code"] == code and first != second:
                which = ["stdout", "derived data stored in the project"] + sorted(outputs)
                differ = [w for w, a, b in zip(which, first, second) if a != b]
                problems.append(("read outside", f"output follows the outside file's contents: {differ}"))
        except Exception as exc:  # noqa: BLE001
            problems.append(("noisy", f"second run could not run: {exc!r}"))
    outcome = next((o for o in OUTCOMES if any(p[0] == o for p in problems)), "ok")
    where = _innermost(text_err + text_out) if outcome == "traceback" else ""
    res = Result(case.group, case.label, r["command"][1:] if not case.program else r["command"], outcome, code,
                 r["seconds"], problems, err_lines[:6] + ([f"... {len(err_lines)} lines"] if len(err_lines) > 6 else []),
                 [ln for ln in text_out.splitlines() if ln.strip()][:3], where)
    _rmtree(d)
    return res


def run(cases: list[Case], work: Path, timeout: float = TIMEOUT, jobs: int = 2,
        progress: Callable[[int, int, Result], None] | None = None, master: Path | None = None) -> list[Result]:
    """Run ``cases`` (``jobs`` at a time) in folders under ``work``, each a copy of ``master``
    (default: ``prepare_master(work)``)."""
    global LISTENERS
    work.mkdir(parents=True, exist_ok=True)
    master = prepare_master(work) if master is None else master
    LISTENERS = _Listeners()
    results: list[Result | None] = [None] * len(cases)
    done = [0]
    lock = threading.Lock()

    def one(k: int) -> None:
        res = run_case(cases[k], master, work / f"t{k:04d}", timeout)
        results[k] = res
        with lock:
            done[0] += 1
            if progress is not None:
                progress(done[0], len(cases), res)

    try:
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            list(pool.map(one, range(len(cases))))
    finally:
        LISTENERS.close()
    return [r for r in results if r is not None]


def table(results: list[Result]) -> str:
    cols = [o for o in OUTCOMES if any(r.outcome == o for r in results)]
    cols += sorted({r.outcome for r in results} - set(cols))
    groups = sorted({r.group for r in results}, key=lambda g: [r.group for r in results].index(g))
    counts = defaultdict(Counter)
    for r in results:
        counts[r.group][r.outcome] += 1
    w = max(len(g) for g in groups + ["group", "all"]) + 2
    lines = ["group".ljust(w) + "tries".rjust(7) + "".join(c.rjust(max(len(c), 5) + 2) for c in cols)]
    for g in groups + ["all"]:
        row = Counter(r.outcome for r in results) if g == "all" else counts[g]
        lines.append(g.ljust(w) + str(sum(row.values())).rjust(7)
                     + "".join(str(row.get(c, 0)).rjust(max(len(c), 5) + 2) for c in cols))
    return "\n".join(lines)


def selected(groups: dict, only: str | None) -> list[Case]:
    """The tries of the comma-separated groups ``only`` (every group's when None)."""
    names = None if only is None else {g.strip() for g in only.split(",")}
    return [c for name, make in groups.items() if names is None or name in names for c in make()]


def command_line(name: str, doc: str, groups: dict, argv: list[str] | None, *, failures=FAILURES,
                 timeout: float = TIMEOUT, prepare=None) -> int:
    """A red-team round's command line: run its groups' tries, print the table, write NAME.json;
    exit 1 when a try ended in one of ``failures``. ``prepare(out)``: a master project the tries copy."""
    ap = argparse.ArgumentParser(prog=f"python -m tests.reliability.{name}", description=doc.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help=f"folder for the tries and {name}.json")
    ap.add_argument("--only", help=f"run these groups of tries only (comma-separated: {', '.join(groups)})")
    ap.add_argument("--timeout", type=float, default=timeout, help="seconds per try before it is a hang")
    ap.add_argument("--jobs", type=int, default=2, help="tries run at once")
    ap.add_argument("--match", help="only tries whose label contains this text")
    args = ap.parse_args(argv)
    unknown = [g for g in (args.only or "").split(",") if g.strip() and g.strip() not in groups]
    if unknown:
        ap.error(f"--only: unknown group(s) {', '.join(unknown)} (known: {', '.join(groups)})")
    cases = [c for c in selected(groups, args.only) if args.match is None or args.match in c.label]
    print(f"{len(cases)} tries", flush=True)

    def progress(i, n, r):
        print(f"[{i}/{n}] {r.outcome:16s} {r.seconds:6.1f} s  {r.group}: {r.label[:90]}", flush=True)

    started = time.monotonic()
    extra = {} if prepare is None else {"master": prepare(args.out)}
    results = run(cases, args.out, args.timeout, args.jobs, progress, **extra)
    print(table(results))
    print(f"{len(results)} tries in {time.monotonic() - started:.0f} s")
    (args.out / f"{name}.json").write_text(json.dumps(
        {"timeout_s": args.timeout, "tries": [r.as_dict() for r in results],
         "counts": {g: dict(Counter(r.outcome for r in results if r.group == g)) for g in {r.group for r in results}}},
        indent=1, ensure_ascii=True))
    return 0 if not any(r.outcome in failures for r in results) else 1


def main(argv: list[str] | None = None) -> int:
    return command_line("redteam3", __doc__, GROUPS, argv)


if __name__ == "__main__":
    sys.exit(main())
