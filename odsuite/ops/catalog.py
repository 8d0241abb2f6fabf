"""A catalogue of every project under a folder, in an embedded SQLite file beside the projects.

``build_catalog(folder)`` indexes each project file (rig, bodies, experiments with their dates and
records, sensors with serial numbers, model revisions with effects, errors and verdicts, fitted
sensor gains) into ``<folder>/odsuite-catalog.sqlite`` and writes the catalogue page
``<folder>/odsuite-catalog.html``. A refresh reads only what changed: a file whose size and
modification time match the catalogue is skipped, one whose content hash (SHA-256) matches is only
re-stamped, the others are read again, and rows of vanished files are dropped.

``query(folder, name_or_sql)`` returns plain rows (a list of dicts; ``pandas.DataFrame(rows)``
takes them as they are); ``connect(folder)`` a read-only connection for ``pandas.read_sql``.
"""

from __future__ import annotations

import hashlib
import html
import math
import os
import secrets
import shutil
import sqlite3
import stat
import time
from collections.abc import Mapping, Sequence
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from odsuite.domain.errors import ConfigError, OdsuiteError
from odsuite.store.h5contained import ReachesOutsideError
from odsuite.analysis.noise_floor import FLOOR_TOLERANCE

CATALOG_NAME = "odsuite-catalog.sqlite"
PAGE_NAME = "odsuite-catalog.html"
#: the first bytes of every HDF5 file: other files are not looked at
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: a model explains the measurements when its error is within this factor of the noise floor: the
#: calibrated floor's tolerance (odsuite.analysis.noise_floor: a perfect model lies within 0.89-1.06 of
#: it on independent nominal data; the simulated thesis rig's truth at 1.05), while a missing effect
#: lifts the error far beyond (5x for one sensor's gain 25 % off, 100x for a 60 % stiffer
#: suspension). A screening verdict: ``odsuite diagnose`` gives the validated one
EXPLAINED_FACTOR = FLOOR_TOLERANCE
#: a query's default bounds: rows returned and seconds of SQLite's work (``query(limit=, seconds=)``)
QUERY_ROWS = 10_000
QUERY_SECONDS = 30.0
#: the longest text or BLOB a query may make (SQLite's own limit is 1e9 bytes)
QUERY_VALUE_BYTES = 100_000_000
#: bump when the tables change: an older catalogue is rebuilt from scratch
SCHEMA_VERSION = 1

SCHEMA = """
CREATE TABLE IF NOT EXISTS projects (
    project TEXT PRIMARY KEY, size_bytes INTEGER, mtime_ns INTEGER, sha256 TEXT, format_version TEXT,
    rig TEXT, created TEXT, updated TEXT, n_experiments INTEGER, n_revisions INTEGER,
    current_revision INTEGER, error REAL, noise_floor_error REAL, verdict TEXT, read_error TEXT,
    indexed_at TEXT);
CREATE TABLE IF NOT EXISTS bodies (project TEXT, body TEXT, mass_kg REAL, sensors INTEGER);
CREATE TABLE IF NOT EXISTS experiments (
    project TEXT, experiment TEXT, created TEXT, source TEXT, sampling_rate_hz REAL, n_samples INTEGER,
    duration_s REAL, n_channels INTEGER, derived TEXT);
CREATE TABLE IF NOT EXISTS sensors (
    project TEXT, experiment TEXT, channel INTEGER, location TEXT, serial TEXT, sensor_type TEXT,
    sensitivity REAL);
CREATE TABLE IF NOT EXISTS revisions (
    project TEXT, revision INTEGER, parent INTEGER, model TEXT, effects TEXT, added TEXT, error REAL,
    noise_floor_error REAL, verdict TEXT, created TEXT, current INTEGER);
CREATE TABLE IF NOT EXISTS sensor_gains (
    project TEXT, revision INTEGER, created TEXT, sensor TEXT, gain REAL, uncertainty REAL);
CREATE INDEX IF NOT EXISTS bodies_project ON bodies(project);
CREATE INDEX IF NOT EXISTS experiments_project ON experiments(project);
CREATE INDEX IF NOT EXISTS sensors_project ON sensors(project);
CREATE INDEX IF NOT EXISTS sensors_serial ON sensors(serial);
CREATE INDEX IF NOT EXISTS revisions_project ON revisions(project);
CREATE INDEX IF NOT EXISTS gains_sensor ON sensor_gains(sensor);
"""
TABLES = ("projects", "bodies", "experiments", "sensors", "revisions", "sensor_gains")

#: named queries: the questions a lab asks of its campaign
QUERIES: dict[str, str] = {
    "projects": "SELECT project, rig, n_experiments, n_revisions, current_revision, error, noise_floor_error, "
                "verdict, read_error FROM projects WHERE (:rig IS NULL OR rig = :rig) ORDER BY project",
    "unexplained": "SELECT project, rig, current_revision, error, noise_floor_error FROM projects "
                   "WHERE verdict = 'unexplained' AND (:rig IS NULL OR rig = :rig) ORDER BY error DESC",
    "errors": "SELECT r.project, r.revision, r.parent, r.effects, r.added, r.error, r.noise_floor_error, "
              "r.verdict, r.created FROM revisions r JOIN projects p USING (project) "
              "WHERE (:rig IS NULL OR p.rig = :rig) ORDER BY r.project, r.revision",
    "experiments": "SELECT e.project, e.experiment, e.created, e.sampling_rate_hz, e.n_samples, e.duration_s, "
                   "e.n_channels, e.derived FROM experiments e JOIN projects p USING (project) "
                   "WHERE (:rig IS NULL OR p.rig = :rig) ORDER BY e.created, e.project, e.experiment",
    "sensors": "SELECT s.serial, s.location, s.sensor_type, s.sensitivity, COUNT(*) AS records, "
               "COUNT(DISTINCT s.project) AS projects FROM sensors s JOIN projects p USING (project) "
               "WHERE s.serial != '' AND (:rig IS NULL OR p.rig = :rig) "
               "GROUP BY s.serial, s.location, s.sensor_type, s.sensitivity ORDER BY s.serial",
    "gains": "SELECT g.sensor, g.project, g.revision, g.created, g.gain, g.uncertainty FROM sensor_gains g "
             "JOIN projects p USING (project) WHERE (:rig IS NULL OR p.rig = :rig) "
             "ORDER BY g.sensor, g.created",
}


@dataclass
class CatalogResult:
    """What a build did: projects read, re-stamped (same content), unchanged, dropped, files that
    are no projects (with the reason), and where the catalogue and its page are."""

    path: Path
    page: Path
    indexed: list[str] = field(default_factory=list)
    restamped: list[str] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    #: projects refused because they reach files outside themselves (listed, with their error)
    refused: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"catalog": str(self.path), "page": str(self.page), "indexed": self.indexed,
                "restamped": self.restamped, "unchanged": self.unchanged, "removed": self.removed,
                "skipped": self.skipped, "refused": self.refused, "seconds": self.seconds}


def _folder(folder: str | Path) -> Path:
    folder = Path(folder)
    if not folder.is_dir():
        raise ConfigError(f"{folder}: not a folder")
    return folder


def _candidates(folder: Path) -> list[Path]:
    """HDF5 files under ``folder`` (lock and interrupted-write files left aside)."""
    out = []
    for path in sorted(folder.rglob("*")):
        if not path.is_file() or ".odsuite-" in path.name or path.name == CATALOG_NAME:
            continue
        try:
            with open(path, "rb") as fh:
                if fh.read(8) == HDF5_SIGNATURE:
                    out.append(path)
        except OSError:
            continue
    return out


def _key(path: Path, folder: Path) -> str:
    """The project's name in the catalogue: its path under the folder, bytes that are not UTF-8
    as backslash escapes (SQLite text must be UTF-8)."""
    return os.fsencode(path.relative_to(folder).as_posix()).decode("utf-8", "backslashreplace")


def _own_file(path: Path, what: str) -> bool:
    """Whether the catalogue's own ``path`` exists as a regular file; a link (never followed: the
    user did not name it) or a folder, pipe or device in its place is refused in one line."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return False
    if stat.S_ISLNK(st.st_mode):
        raise ConfigError(f"{path}: the {what} is a link, which odsuite never writes through; remove it")
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{path}: the {what} is not a regular file (a folder, pipe or device); move it elsewhere")
    return True


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def verdict(error: float | None, noise: float | None) -> str | None:
    if error is None or not noise:
        return None
    return "explained" if error <= EXPLAINED_FACTOR * noise else "unexplained"


def _revision_rows(key: str, revisions: Sequence[Mapping[str, Any]], current: int | None
                   ) -> tuple[list[tuple], list[tuple]]:
    """Revision rows and fitted sensor gains. A revision's error is its stored one, else the
    ``previous_error`` its first child stored when it was made (revision 0 before any compare)."""
    from_child = {}
    for r in revisions:
        prev = r["metrics"].get("previous_error")
        if r["parent"] is not None and prev is not None:
            from_child.setdefault(r["parent"], prev)
    noise_any = next((r["metrics"]["noise_floor_error"] for r in revisions
                      if r["metrics"].get("noise_floor_error") is not None), None)
    rows, gains = [], []
    for r in revisions:
        m = r["metrics"]
        error = m.get("error", from_child.get(r["revision"]))
        noise = m.get("noise_floor_error", noise_any)  # the same records: the same noise floor
        effects = ", ".join(e["effect"] for e in r["effects"])
        rows.append((key, r["revision"], r["parent"], r["model"], effects, m.get("added"), error, noise,
                     verdict(error, noise), r["created"], int(r["revision"] == current)))
        for e in r["effects"]:
            unc = e.get("uncertainties", {})
            if e["effect"] == "sensor_gain":
                for name, g in e.get("values", {}).items():
                    if name.endswith("_gain"):
                        gains.append((key, r["revision"], r["created"], name[: -len("_gain")], g, unc.get(name)))
            elif e["effect"] == "force_gain" and "gain" in e.get("values", {}):
                gains.append((key, r["revision"], r["created"], "force", e["values"]["gain"], unc.get("gain")))
    return rows, gains


def _with_errors(project, revisions: list[dict]) -> list[dict]:
    """Revisions whose error was never stored (a project only compared, never changed) get it
    computed the way ``odsuite history`` does (not stored in the project: reading never writes)."""
    from odsuite.analysis.comparison import compare
    from odsuite.analysis.prediction import prepare

    exps = None
    out = []
    for r in revisions:
        if r["metrics"].get("error") is None:
            exps = exps or prepare(project)
            cmp = compare(project, revision=r, prepared=exps, resonances=False)
            r = {**r, "metrics": {**r["metrics"], "error": cmp.error, "noise_floor_error": cmp.noise_floor_error}}
        out.append(r)
    return out


def _index_project(db: sqlite3.Connection, key: str, path: Path, compute_errors: bool = False) -> dict[str, Any]:
    """Read one project and replace its rows (the caller commits); returns its projects row.
    The file's dates come from ``Project.file_times``: ``Project.info()`` would also scan every
    record for its peaks, which a catalogue of large projects cannot afford."""
    from odsuite.store.project import open_project

    for table in TABLES[1:]:
        db.execute(f"DELETE FROM {table} WHERE project = ?", (key,))
    with open_project(path) as p:
        created, updated = p.file_times
        rig = p.rig
        if rig is not None:
            db.executemany("INSERT INTO bodies VALUES (?, ?, ?, ?)",
                           [(key, b.name, b.mass, sum(s.body == b.name for s in rig.sensors)) for b in rig.bodies])
        names = p.experiment_names()
        for name in names:
            e = p.experiment(name)
            db.execute("INSERT INTO experiments VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                       (key, name, e.created, e.source, e.sampling_rate, e.n_samples,
                        e.n_samples / e.sampling_rate, e.n_channels, ", ".join(p.derived_kinds(name))))
            db.executemany("INSERT INTO sensors VALUES (?, ?, ?, ?, ?, ?, ?)",
                           [(key, name, k, c.location, c.serial, c.sensor_type.name.lower(), c.sensitivity)
                            for k, c in enumerate(e.systeminfo.channels)])
        revisions = p.model_revisions()
        current = p.current_revision
        if compute_errors and rig is not None and names:
            revisions = _with_errors(p, revisions)
        rows, gains = _revision_rows(key, revisions, current)
        db.executemany(f"INSERT INTO revisions VALUES ({', '.join('?' * 11)})", rows)
        db.executemany("INSERT INTO sensor_gains VALUES (?, ?, ?, ?, ?, ?)", gains)
        cur = next((r for r in rows if r[-1]), None)
        fmt = p.format_version
    return {"format_version": fmt, "rig": rig.name if rig else None, "created": created, "updated": updated,
            "n_experiments": len(names), "n_revisions": len(revisions), "current_revision": current,
            "error": cur[6] if cur else None, "noise_floor_error": cur[7] if cur else None,
            "verdict": cur[8] if cur else None, "read_error": None}


def _open_db(path: Path) -> sqlite3.Connection:
    """The working copy's database; one that is not a catalogue of this schema (damaged, another
    program's, another version) is rebuilt from scratch."""
    try:
        db = sqlite3.connect(path, timeout=30)
        version = db.execute("PRAGMA user_version").fetchone()[0]
        if version == SCHEMA_VERSION:
            db.execute("PRAGMA quick_check").fetchall()
            cols = [r[1] for r in db.execute("PRAGMA table_info(projects)")]
            if cols and len(cols) != 16:
                version = None
    except sqlite3.DatabaseError:
        db.close()
        path.unlink()
        db, version = sqlite3.connect(path, timeout=30), None
    if version != SCHEMA_VERSION:
        for table in TABLES:
            db.execute(f"DROP TABLE IF EXISTS {table}")
        db.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    db.executescript(SCHEMA)
    return db


def build_catalog(folder: str | Path, *, compute_errors: bool = False, progress=None) -> CatalogResult:
    """Index or refresh every project under ``folder``; write the catalogue page. A project that
    cannot be read keeps a row with its one-line error (``read_error``). ``compute_errors``:
    revisions without a stored error get one computed (seconds per project, once per content)."""
    folder = _folder(folder)
    started = time.monotonic()
    res = CatalogResult(path=folder / CATALOG_NAME, page=folder / PAGE_NAME)
    _own_file(res.page, "catalogue page")
    # the catalogue is refreshed in a private copy that replaces it in one rename (never written
    # through a link, nor into a file another name shares)
    tmp = folder / f".{CATALOG_NAME}.odsuite-out-{secrets.token_hex(4)}"
    try:
        if _own_file(res.path, "catalogue"):
            shutil.copyfile(res.path, tmp)
        _fill(folder, tmp, res, compute_errors, progress)
        if res.path.exists():
            os.chmod(tmp, stat.S_IMODE(os.stat(res.path).st_mode) | stat.S_IWUSR)
        os.replace(tmp, res.path)
    except sqlite3.Error as exc:
        raise ConfigError(f"{res.path}: catalogue not written: {exc}") from None
    except OSError as exc:
        raise ConfigError(f"{res.path}: catalogue not written: {exc.strerror or exc}") from None
    finally:
        for leftover in (tmp, tmp.with_name(tmp.name + "-journal")):
            leftover.unlink(missing_ok=True)
    write_page(folder)
    res.seconds = time.monotonic() - started
    return res


def _fill(folder: Path, tmp: Path, res: CatalogResult, compute_errors: bool, progress) -> None:
    """Refresh the catalogue database ``tmp`` from the projects under ``folder``."""
    from odsuite.domain.errors import NotAProjectError

    files = _candidates(folder)
    with closing(_open_db(tmp)) as db:
        known = {row[0]: row[1:] for row in db.execute(
            "SELECT project, size_bytes, mtime_ns, sha256, error IS NULL AND n_experiments > 0 FROM projects")}
        seen = set()
        for i, path in enumerate(files):
            key = _key(path, folder)
            if progress is not None:
                progress(key, i, len(files))
            st = path.stat()
            old = known.get(key)
            lacks_errors = compute_errors and old is not None and old[3]
            if old is not None and old[0] == st.st_size and old[1] == st.st_mtime_ns and not lacks_errors:
                res.unchanged.append(key)
                seen.add(key)
                continue
            digest = _sha256(path)
            now = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
            with db:  # one transaction per project
                if old is not None and old[2] == digest and not lacks_errors:
                    db.execute("UPDATE projects SET size_bytes = ?, mtime_ns = ? WHERE project = ?",
                               (st.st_size, st.st_mtime_ns, key))
                    res.restamped.append(key)
                    seen.add(key)
                    continue
                try:
                    row = _index_project(db, key, path, compute_errors)
                except NotAProjectError as exc:
                    res.skipped[key] = str(exc)
                    continue
                except Exception as exc:  # a damaged project is listed with its error
                    for table in TABLES[1:]:
                        db.execute(f"DELETE FROM {table} WHERE project = ?", (key,))
                    row = dict.fromkeys(("format_version", "rig", "created", "updated", "n_experiments",
                                         "n_revisions", "current_revision", "error", "noise_floor_error",
                                         "verdict"))
                    line = (str(exc).splitlines() or [""])[0]
                    # an error of odsuite's says what is wrong; another is named by its kind
                    row["read_error"] = line if isinstance(exc, OdsuiteError) else \
                        f"{path}: project cannot be read ({type(exc).__name__}: {line})"
                    if isinstance(exc, ReachesOutsideError):
                        res.refused[key] = line
                db.execute("INSERT OR REPLACE INTO projects VALUES "
                           "(:project, :size, :mtime, :sha, :format_version, :rig, :created, :updated, "
                           ":n_experiments, :n_revisions, :current_revision, :error, :noise_floor_error, "
                           ":verdict, :read_error, :now)",
                           {**row, "project": key, "size": st.st_size, "mtime": st.st_mtime_ns, "sha": digest,
                            "now": now})
            res.indexed.append(key)
            seen.add(key)
        with db:
            for key in sorted(set(known) - seen):
                for table in TABLES:
                    db.execute(f"DELETE FROM {table} WHERE project = ?", (key,))
                res.removed.append(key)


def connect(folder: str | Path) -> sqlite3.Connection:
    """A read-only connection to the folder's catalogue (``pandas.read_sql(sql, connect(dir))``)."""
    path = _folder(folder) / CATALOG_NAME
    if not path.exists():
        raise ConfigError(f"{path}: no catalogue yet; build it with `odsuite catalog {folder}`")
    if not path.is_file():
        raise ConfigError(f"{path}: the catalogue is not a regular file (a folder, pipe or device)")
    db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    db.setlimit(sqlite3.SQLITE_LIMIT_LENGTH, QUERY_VALUE_BYTES)
    return db


class _Bounds:
    """SQLite's progress handler: stops a query past its time, or at Ctrl-C (SQLite's C loop
    does not return to Python otherwise, so the interrupt would wait for the query's end)."""

    def __init__(self, seconds: float) -> None:
        self.deadline = time.monotonic() + seconds
        self.late = False
        self.interrupted: BaseException | None = None

    def __call__(self) -> int:
        try:
            self.late = time.monotonic() > self.deadline
            return int(self.late)
        except BaseException as exc:  # Ctrl-C or SIGTERM (the command line's own interrupt)
            self.interrupted = exc
            return 1


def query(folder: str | Path, name_or_sql: str = "projects", *, rig: str | None = None,
          limit: int = QUERY_ROWS, seconds: float = QUERY_SECONDS) -> list[dict[str, Any]]:
    """Rows of a named query (see QUERIES) or of a read-only SQL SELECT, as dicts: at most
    ``limit`` rows (more is refused in one line) within ``seconds`` of SQLite's work."""
    sql = QUERIES.get(name_or_sql, name_or_sql)
    if name_or_sql not in QUERIES and not name_or_sql.lstrip().lower().startswith(("select", "with")):
        raise ConfigError(f"catalog query {name_or_sql!r}: expected one of {', '.join(QUERIES)} or a SELECT")
    if not limit >= 1:
        raise ConfigError(f"--limit: at least 1 row, got {limit}")
    if not (math.isfinite(seconds) and seconds > 0):  # NaN never compares late: the query would run unbounded
        raise ConfigError(f"--seconds: a finite time > 0 s, got {seconds}")
    bounds = _Bounds(seconds)
    with closing(connect(folder)) as db:
        db.set_progress_handler(bounds, 10_000)
        try:
            cur = db.execute(sql, {"rig": rig} if ":rig" in sql else {})
            cols = [d[0] for d in cur.description or ()]
            rows = cur.fetchmany(limit + 1)
        except (sqlite3.Error, MemoryError, OverflowError) as exc:
            if bounds.interrupted is not None:
                raise bounds.interrupted from None
            if bounds.late:
                raise ConfigError(f"catalog query {name_or_sql!r}: stopped after {seconds:g} s of work "
                                  "(give --seconds for longer)") from None
            raise ConfigError(f"catalog query {name_or_sql!r}: {exc}") from None
    if bounds.interrupted is not None:
        raise bounds.interrupted
    if len(rows) > limit:
        raise ConfigError(f"catalog query {name_or_sql!r}: more than {limit} rows; give --limit for more "
                          "or narrow the query (LIMIT, WHERE)")
    return [dict(zip(cols, row)) for row in rows]


def _num(v: float | None) -> str:
    return "–" if v is None else f"{v:.4f}"


def write_page(folder: str | Path) -> Path:
    """The catalogue page: every project with its rig, records, verdict and error trail."""
    folder = _folder(folder)
    projects = query(folder, "projects")
    trails: dict[str, list[dict]] = {}
    for r in query(folder, "errors"):
        trails.setdefault(r["project"], []).append(r)
    rows = []
    for p in projects:
        trail = " → ".join(f"{_num(r['error'])}" + (f" (+{html.escape(r['added'])})" if r["added"] else "")
                           for r in trails.get(p["project"], []))
        verdict_cell = html.escape(p["read_error"] or p["verdict"] or "–")
        cls = "bad" if p["read_error"] or p["verdict"] == "unexplained" else ""
        rows.append(f"<tr class='{cls}'><td>{html.escape(p['project'])}</td><td>{html.escape(p['rig'] or '–')}</td>"
                    f"<td>{p['n_experiments'] if p['n_experiments'] is not None else '–'}</td>"
                    f"<td>{p['n_revisions'] if p['n_revisions'] is not None else '–'}</td>"
                    f"<td>{_num(p['error'])}</td><td>{_num(p['noise_floor_error'])}</td>"
                    f"<td>{verdict_cell}</td><td>{trail or '–'}</td></tr>")
    unexplained = sum(p["verdict"] == "unexplained" for p in projects)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>odsuite catalogue: {html.escape(folder.name)}</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:4px 8px;text-align:left}}tr.bad td{{background:#fde8e8}}</style></head>
<body><h1>odsuite catalogue: {html.escape(folder.name)}</h1>
<p>{len(projects)} projects, {unexplained} with a model that does not yet explain the measurements
(error above {EXPLAINED_FACTOR:g} &times; the noise floor). Errors are pooled NRMSE (dimensionless).</p>
<table><thead><tr><th>project</th><th>rig</th><th>experiments</th><th>revisions</th><th>error</th>
<th>noise floor</th><th>verdict</th><th>error trail (every revision, + the effect it added)</th></tr></thead>
<tbody>{''.join(rows)}</tbody></table></body></html>
"""
    out = folder / PAGE_NAME
    out.write_text(page, encoding="utf-8")
    return out
