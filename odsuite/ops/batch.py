"""Run one command over many projects on dask.distributed: one project per task.

An embedded ``LocalCluster`` (worker processes on this machine, bound to 127.0.0.1) is started
and closed for each batch unless the address of a running scheduler is given; both take the same
path through a ``Client``. Each task calls the same Python API function as the CLI command and
returns a plain, JSON-ready record: ``ok`` with the command's result, ``error`` or ``locked`` with
one line, never an exception, so a project's own error is not retried as if a worker had died.
When a worker dies, the scheduler reruns its tasks on the others (up to the cluster's
``distributed.scheduler.allowed-failures``); a task that still does not finish is reported as
``not-run`` with the reason. Writing commands are safe to rerun: a project changes only through
whole transactions and its writer lock (an flock) dies with the process that held it.
"""

from __future__ import annotations

import logging
import math
import os
import socket
import time
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError, OdsuiteError, ProjectLockedError

#: statuses of a project's record, in the order the summary lists them
STATUSES = ("ok", "error", "locked", "not-run")
#: seconds to reach a scheduler and hear its answer
CONNECT_SECONDS = 10.0
#: commands writing one output file per project (its name from the project's name) into --out
OUTPUT_SUFFIX = {"report": "-report.html", "render": "-"}




def _plain(x: Any) -> Any:
    """JSON-ready: numpy scalars and arrays to Python, paths to text, NaN/inf to None."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, Path):
        return str(x)
    return x


# ---------------------------------------------------------------------------------------------
# the commands: each takes a project path and the batch's options and returns the CLI's result


def _info(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.store.project import open_project

    with open_project(path) as p:
        info = p.info()
        info["model_revisions"] = [{k: r[k] for k in ("revision", "model", "effects", "metrics", "parent",
                                                       "created")} for r in p.model_revisions()]
    return info


def _process(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.processing.pipeline import process_experiment
    from odsuite.store.project import open_project

    # one thread per task: the batch spreads projects over the cores instead
    with open_project(path, "a") as p:
        names = options.get("experiments") or p.experiment_names()
        return {"experiments": {n: process_experiment(p, n, workers=1) for n in names}}


def _compare(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.analysis.comparison import compare
    from odsuite.store.project import open_project

    with open_project(path) as p:
        return compare(p).as_dict()


def _diagnose(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.diagnosis.diagnose import diagnose
    from odsuite.store.project import open_project

    with open_project(path) as p:
        return diagnose(p, effects=options.get("effects") or None, workers=1).as_dict()


def _history(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.analysis.history import history
    from odsuite.store.project import open_project

    with open_project(path) as p:
        return history(p)


def _add_effect(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.diagnosis.add_effect import add_effect
    from odsuite.store.project import open_project

    with open_project(path, "a") as p:
        return add_effect(p, options["effect"])


def _output(path: Path, options: Mapping[str, Any], suffix: str) -> Path:
    """``<out>/<project stem><suffix>``; ``out`` defaults to the project's folder."""
    from odsuite.store.storage import check_output

    out = Path(options.get("out") or path.parent)
    out.mkdir(parents=True, exist_ok=True)
    output = out / f"{path.stem}{suffix}"
    # a name the user did not give: never written through a link (a report over the file it points to)
    if output.is_symlink():
        raise ConfigError(f"{output}: a link, which batch never writes through (the name comes from {path.name}); "
                          "remove it")
    check_output(output, path, "--out")
    return output


def _render_with(renderer, path: Path, experiment: str | None, output: Path, options: Mapping[str, Any]
                 ) -> dict[str, Any]:
    from odsuite.contracts.renderers import RenderRequest

    res = renderer.render(RenderRequest(path, experiment, output, options, progress=False))
    return {"path": res.path, "summary": res.summary, "notes": list(res.notes)}


def _report(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.contracts.plugins import registries

    return _render_with(registries().renderers.get("report"), path, None, _output(path, options, "-report.html"),
                        {"run_diagnosis": not options.get("no_diagnose"), "movie": not options.get("no_movie")})


def _render(path: Path, options: Mapping[str, Any]) -> dict[str, Any]:
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project
    from odsuite.contracts.renderers import choose_renderer

    experiment = options.get("experiment")
    if experiment is None:
        with open_project(path) as p:
            names = p.experiment_names()
        if not names:
            raise ConfigError(f"{path}: no experiment to render")
        experiment = names[0]
    figure = options.get("figure")
    output = _output(path, options, f"-{experiment}" + (".mp4" if figure is None else f"-{figure}.png"))
    renderer = choose_renderer(registries().renderers, output, figure, "figure" if figure else "movie")
    opts = {"model": bool(options.get("model")) or None, **({} if figure else {"workers": 1})}
    return {**_render_with(renderer, path, experiment, output, opts), "experiment": experiment}


#: command -> (function, whether it writes the project)
COMMANDS: dict[str, tuple[Callable[[Path, Mapping[str, Any]], dict[str, Any]], bool]] = {
    "info": (_info, False),
    "process": (_process, True),
    "compare": (_compare, False),
    "diagnose": (_diagnose, False),
    "history": (_history, False),
    "add-effect": (_add_effect, True),
    "report": (_report, False),
    "render": (_render, False),
}


def run_project(command: str, path: str, options: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """One task: run ``command`` on one project; a record with status, result or one-line error,
    the seconds it took and where it ran. Only OdsuiteError is a project's own error; anything
    else is a bug and is reported with its type (one line too: the batch goes on)."""
    fn, _writes = COMMANDS[command]
    started = time.monotonic()
    record: dict[str, Any] = {"project": str(path), "status": "ok", "result": None, "error": None}
    try:
        record["result"] = _plain(fn(Path(path), options or {}))
    except ProjectLockedError as exc:
        record.update(status="locked", error=str(exc))
    except OdsuiteError as exc:
        record.update(status="error", error=str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    except Exception as exc:  # noqa: BLE001 - a bug in one project's run must not stop the batch
        first = str(exc).splitlines()[0] if str(exc) else ""
        record.update(status="error", error=f"internal error {type(exc).__name__}: {first}")
    record["seconds"] = time.monotonic() - started
    record["host"] = socket.gethostname()
    record["pid"] = os.getpid()
    return record


# ---------------------------------------------------------------------------------------------
# the batch


@dataclass
class BatchResult:
    """Every project's record in the order given, and where the batch ran."""

    command: str
    scheduler: str
    workers: int
    projects: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def counts(self) -> dict[str, int]:
        return {s: sum(r["status"] == s for r in self.projects) for s in STATUSES}

    @property
    def ok(self) -> bool:
        return all(r["status"] == "ok" for r in self.projects)

    def as_dict(self) -> dict[str, Any]:
        return {"command": self.command, "scheduler": self.scheduler, "workers": self.workers,
                "seconds": self.seconds, "counts": self.counts, "projects": self.projects}


def _check_projects(command: str, projects: Sequence[str | Path], options: Mapping[str, Any]) -> list[Path]:
    if command not in COMMANDS:
        raise ConfigError(f"batch: unknown command {command!r} (commands: {', '.join(COMMANDS)})")
    if command == "add-effect" and not options.get("effect"):
        raise ConfigError("batch add-effect: name the effect with --effect")
    if not projects:
        raise ConfigError("batch: no projects given")
    paths: list[Path] = []
    for p in projects:
        # absolute: workers on other machines see the same shared folder under the same path
        path = Path(p).expanduser().resolve()
        if path not in paths:  # the same project twice would only collide on its lock
            paths.append(path)
    out = options.get("out")
    if out is not None and command in OUTPUT_SUFFIX:
        if Path(out).exists() and not Path(out).is_dir():
            raise ConfigError(f"--out {out}: not a folder; give a folder for the {command} files")
        # outputs are named after the project's file name: two of one name would overwrite each other
        by_stem: dict[str, Path] = {}
        for path in paths:
            other = by_stem.setdefault(path.stem, path)
            if other != path:
                raise ConfigError(f"--out {out}: {other} and {path} would write files of one name "
                                  f"({path.stem}{OUTPUT_SUFFIX[command]}...); give the projects distinct "
                                  "file names or leave out --out (each beside its project)")
    return paths


def check_scheduler(address: str) -> str:
    """A dask scheduler address 'tcp://HOST:PORT' or 'tls://HOST:PORT' (or HOST:PORT), else one line."""
    from urllib.parse import urlsplit

    text = address.strip()
    if not text or not text.isprintable():
        raise ConfigError(f"--scheduler: expected an address tcp://HOST:PORT, got {address!r}")
    parts = urlsplit(text if "://" in text else "tcp://" + text)
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme not in ("tcp", "tls") or not parts.hostname or port is None or not 0 < port < 65536 \
            or parts.path not in ("", "/"):
        raise ConfigError(f"--scheduler: expected an address tcp://HOST:PORT or tls://HOST:PORT "
                          f"(PORT 1 to 65535), got {address!r}")
    if parts.scheme == "tls":
        import dask.config

        if not dask.config.get("distributed.comm.tls.ca-file", None):
            raise ConfigError(f"--scheduler {address}: tls:// needs dask's TLS settings "
                              "(distributed.comm.tls.ca-file, .client.cert and .client.key)")
    return f"{parts.scheme}://{parts.netloc}"


def _fingerprint(path: Path) -> tuple[int, int, int] | None:
    """What changes when a project is written (a commit replaces the file: a new inode)."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


def _clear_stale_locks(paths: Sequence[Path]) -> None:
    """Remove the lock files that workers of this machine, ended by the interrupt, left behind: a
    lock file whose lock can be taken is stale (a live writer elsewhere keeps its own)."""
    from odsuite.store.storage import acquire_lock, release_lock
    from odsuite.store.writer_lock import lock_path

    quiet = logging.getLogger("odsuite.store.storage")
    level, quiet.level = quiet.level, logging.ERROR  # its note on removed working copies: ours to make
    try:
        for path in paths:
            if os.path.lexists(lock_path(path)):
                try:
                    release_lock(acquire_lock(path))
                except OdsuiteError:
                    pass
    finally:
        quiet.setLevel(level)


def _interrupted_line(command: str, paths: Sequence[Path], before: dict[Path, Any],
                      records: Mapping[str, Mapping[str, Any]]) -> str:
    """The one line of an interrupted batch: for a writing command the projects that changed
    (seen on disk once the workers are gone), else those that finished."""
    if COMMANDS[command][1]:
        return _stored_line(command, [p for p in paths if _fingerprint(p) != before[p]], paths)
    done = [p for p in paths if records.get(str(p), {}).get("status") == "ok"]
    return _finished_line(done, paths)


def settled_line(result: BatchResult) -> str:
    """The one line of an interrupt that comes after the batch's work ended (while its table is
    printed): what the records say it stored or finished. Before, the command's own line said
    "nothing stored" of three projects add-effect had just written."""
    paths = [r["project"] for r in result.projects]
    done = [r["project"] for r in result.projects if r["status"] == "ok"]
    return _stored_line(result.command, done, paths) if COMMANDS[result.command][1] else _finished_line(done, paths)


def _stored_line(command: str, changed: Sequence, paths: Sequence) -> str:
    if not changed:
        return "interrupted: nothing stored, no project changed"
    rest = [p for p in paths if p not in changed]
    return (f"interrupted: {command} stored in {', '.join(map(str, changed))}; "
            f"unchanged: {', '.join(map(str, rest)) or 'none'}")


def _finished_line(done: Sequence, paths: Sequence) -> str:
    return (f"interrupted: nothing stored; finished: {', '.join(map(str, done)) or 'none'} "
            f"of {len(paths)} projects")


def _not_run(path: str, why: str) -> dict[str, Any]:
    return {"project": path, "status": "not-run", "result": None, "error": f"did not run: {why}",
            "seconds": None, "host": None, "pid": None}


def run_batch(command: str, projects: Sequence[str | Path], *, scheduler: str | None = None,
              workers: int | None = None, options: Mapping[str, Any] | None = None,
              progress: Callable[[dict[str, Any], int, int], None] | None = None,
              on_submitted: Callable[[Any, dict[str, Any]], None] | None = None) -> BatchResult:
    """Run ``command`` on every project, one task per project, on a new local cluster of
    ``workers`` single-threaded processes (default: one per core) or on the running scheduler at
    ``scheduler`` ("tcp://host:8786"). ``progress(record, done, total)`` is called as each
    project finishes; ``on_submitted(client, futures_by_path)`` right after submission (for
    monitoring). The cluster started here is always closed before returning."""
    from distributed import Client, LocalCluster, as_completed

    # one path is text (or a Path): its characters were run as projects, one task each
    if isinstance(projects, str | bytes | os.PathLike) or not isinstance(projects, Iterable):
        raise ConfigError(f"run_batch: 'projects' is a list of project paths, got {projects!r}")
    options = dict(options or {})
    paths = _check_projects(command, projects, options)
    most, per_core = arguments.most_workers(), arguments.WORKERS_PER_CORE
    if workers is not None and not (isinstance(workers, int) and not isinstance(workers, bool)):
        raise ConfigError(f"run_batch: 'workers' must be an integer from 1 to {most} ({per_core} per core), "
                          f"got {workers!r}")
    if workers is not None and not 1 <= workers <= most:
        raise ConfigError(f"batch: --workers must be from 1 to {most} ({per_core} per core), got {workers}")
    if scheduler is not None:
        scheduler = check_scheduler(scheduler)
    started = time.monotonic()
    cluster = None
    n = workers or os.cpu_count() or 1
    before = {p: _fingerprint(p) for p in paths}
    records: dict[str, dict[str, Any]] = {}
    try:
        if scheduler is None:
            # processes, not threads: most of the work holds the GIL. Loopback only, no dashboard
            # (its HTTP server still starts: on a free port of 127.0.0.1)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                                   silence_logs=logging.ERROR)
            address = cluster.scheduler_address
        else:
            address = scheduler
        client = _connect(Client, address)
        with client:
            n_workers = len(client.scheduler_info(n_workers=-1)["workers"]) if scheduler else n
            if not n_workers:
                raise ConfigError(f"batch: the scheduler at {address} has no workers; start some with "
                                  f"`dask worker {address}`")
            # keys of their own: another batch on a shared scheduler must not share these tasks
            batch_id = uuid.uuid4().hex[:8]
            futures = {str(p): client.submit(run_project, command, str(p), options, pure=False,
                                             key=f"odsuite-{command}-{batch_id}-{i}-{p.name}")
                       for i, p in enumerate(paths)}
            if on_submitted is not None:
                on_submitted(client, futures)
            try:
                for done, fut in enumerate(as_completed(list(futures.values()), loop=client.loop), start=1):
                    path = next(k for k, f in futures.items() if f is fut)
                    try:
                        records[path] = fut.result()
                    except Exception as exc:  # noqa: BLE001 - KilledWorker, a lost scheduler: it did not run
                        first = str(exc).splitlines()[0] if str(exc) else ""
                        records[path] = _not_run(path, f"{type(exc).__name__}: {first}")
                    if progress is not None:
                        progress(records[path], done, len(futures))
            except BaseException:  # Ctrl-C or SIGTERM: what finished is kept, the rest cancelled
                client.cancel([f for p, f in futures.items() if p not in records])
                raise
    except BaseException as exc:
        if isinstance(exc, (Exception, SystemExit, GeneratorExit)):
            raise
        logging.getLogger("distributed").setLevel(logging.CRITICAL)  # its shutdown noise is not ours
        if cluster is not None:  # the workers are gone before the projects are looked at
            cluster.close()
            cluster = None
            if COMMANDS[command][1]:
                _clear_stale_locks(paths)
        # the interrupt goes on (the command line's own exception), carrying its truthful line
        exc.line = _interrupted_line(command, paths, before, records)  # type: ignore[attr-defined]
        raise
    finally:
        if cluster is not None:
            cluster.close()
    return BatchResult(command=command, scheduler=scheduler or "local", workers=n_workers,
                       projects=[records[str(p)] for p in paths], seconds=time.monotonic() - started)


def _connect(client_class, address: str):
    """A Client of the scheduler at ``address``, or one line within CONNECT_SECONDS: a closed
    port, a listener that never answers or a server that speaks another protocol."""
    import threading

    got: list = []

    def connect() -> None:
        try:
            got.append(client_class(address, timeout=f"{CONNECT_SECONDS:g}s", set_as_default=False))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller below
            got.append(exc)

    # a daemon thread: a connection that never returns must not keep the program from exiting
    thread = threading.Thread(target=connect, name="odsuite-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_SECONDS + 5)
    if not got:
        raise ConfigError(f"batch: the scheduler at {address} did not answer within {CONNECT_SECONDS:g} s")
    if not isinstance(got[0], BaseException):
        return got[0]
    exc = got[0]
    if isinstance(exc, (OSError, TimeoutError, ValueError, TypeError)):
        first = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise ConfigError(f"batch: cannot reach the scheduler at {address}: {first}") from None
    raise exc


def describe(command: str, record: Mapping[str, Any]) -> str:
    """One line for a project's record, with units."""
    if record["status"] != "ok":
        return record["error"] or record["status"]
    r = record["result"]
    if command == "info":
        return (f"rig {r['rig'] or 'none'}, {len(r['experiments'])} experiments, "
                f"{r['revisions']} model revisions")
    if command == "process":
        return f"processed {len(r['experiments'])} experiments: {', '.join(r['experiments'])}"
    if command == "compare":
        return f"revision {r['revision']}: error {r['error']:.4f} (noise floor {r['noise_floor_error']:.4f})"
    if command == "diagnose":
        top = r["candidates"][0] if r["candidates"] else None
        best = "no candidate" if top is None else (
            f"best {top['effect']} ({'significant' if top['significant'] else 'not significant'}, "
            f"error after {top['error_after']:.4f})")
        return f"revision {r['revision']}: error {r['baseline_error']:.4f}; {best}"
    if command == "history":
        trail = " -> ".join("-" if v["error"] is None else f"{v['error']:.4f}" for v in r["revisions"])
        return f"{len(r['revisions'])} revisions, error {trail}"
    if command == "add-effect":
        return f"revision {r['revision']}: + {r['effect']}; error {r['previous_error']:.4f} -> {r['error']:.4f}"
    if command == "report":
        return f"wrote {r['path']} ({r['summary']})"
    return f"wrote {r['path']}"
