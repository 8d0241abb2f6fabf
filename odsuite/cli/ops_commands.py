"""Work over many projects: batch, catalog."""

from __future__ import annotations

from pathlib import Path

import typer

from odsuite.domain.errors import ConfigError
from odsuite.cli.app import _ledger, _loop_progress, _print_json, app, console, err_console, shown


@app.command("batch")
def batch_cmd(
    command: str = typer.Argument(..., help="info, process, compare, diagnose, history, add-effect, report or render."),
    projects: list[Path] = typer.Argument(..., help="Project files (one task each)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Address of a running dask scheduler, e.g. "
                                  "tcp://10.0.0.5:8786 (default: a local cluster on this machine)."),
    workers: int = typer.Option(None, "--workers", help="Local cluster: worker processes (default: one per core)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document with every project's result."),
    effect: list[str] = typer.Option(None, "--effect", help="add-effect: the effect to add; diagnose: try only "
                                     "these (repeatable)."),
    experiment: str = typer.Option(None, "--experiment", help="render: experiment (default: each project's first)."),
    out: Path = typer.Option(None, "--out", help="report, render: folder for the files (default: beside each project)."),
    no_diagnose: bool = typer.Option(False, "--no-diagnose", help="report: leave the candidate effects out."),
    no_movie: bool = typer.Option(False, "--no-movie", help="report: leave the movie out."),
) -> None:
    """Run one command over many projects on dask.distributed, one project per task."""
    from rich.table import Table
    from rich.text import Text

    from odsuite.ops.batch import describe, run_batch, settled_line

    if workers is not None and workers < 1:
        raise ConfigError(f"--workers: at least 1 worker process, got {workers}")
    options = {"effects": effect or None, "effect": effect[0] if effect else None, "experiment": experiment,
               "out": None if out is None else str(out.resolve()), "no_diagnose": no_diagnose, "no_movie": no_movie}
    with _loop_progress() as bar:
        task = bar.add_task(f"{command}: starting workers", total=len(projects))

        def progress(record, done, total):
            bar.update(task, description=f"{command}: {Path(record['project']).name} {record['status']}",
                       completed=done, total=total)

        result = run_batch(command, projects, scheduler=scheduler, workers=workers, options=options,
                           progress=progress)
        _ledger.settle(settled_line(result))  # a Ctrl-C from here on tells what the batch did
    line = None
    if not result.ok:
        bad = [r for r in result.projects if r["status"] != "ok"]
        first = shown(bad[0]["error"] or bad[0]["status"])
        if not first.startswith(shown(bad[0]["project"])):  # most errors name their project already
            first = f"{shown(bad[0]['project'])}: {first}"
        line = f"batch {command}: {len(bad)} of {len(result.projects)} projects did not succeed (first: {first})"
    if as_json:  # a batch that failed is a failed command: its document carries the error line too
        _print_json(result.as_dict() | ({"error": line} if line else {}))
    else:
        table = Table(title=f"{command} on {len(result.projects)} projects ({result.workers} workers, "
                            f"{result.seconds:.1f} s)")
        for col in ("project", "status", "time (s)", "result"):
            table.add_column(col)
        for r in result.projects:
            style = "" if r["status"] == "ok" else "red"
            table.add_row(r["project"], Text(shown(r["status"]), style=style),
                          "-" if r["seconds"] is None else f"{r['seconds']:.1f}", describe(command, r))
        console.print(table)
    if line:
        err_console.print(f"error: {line}", highlight=False, soft_wrap=True)
        raise typer.Exit(1)


@app.command("catalog")
def catalog_cmd(
    args: list[str] = typer.Argument(..., help="DIR to index or refresh, or: query DIR [NAME|SELECT ...] "
                                     "(NAME: projects, unexplained, errors, experiments, sensors, gains)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
    rig: str = typer.Option(None, "--rig", help="query: only projects on this rig."),
    errors: bool = typer.Option(False, "--errors", help="Compute errors that no revision stored (slower, once per change)."),
    limit: int = typer.Option(10_000, "--limit", help="query: at most this many rows (more is refused)."),
    seconds: float = typer.Option(30.0, "--seconds", help="query: stop after this many seconds of work."),
) -> None:
    """Index every project under a folder into an SQLite catalogue beside them, or query it."""
    from rich.table import Table

    from odsuite.ops.catalog import build_catalog, query

    folder = args[1] if args[0] == "query" and len(args) > 1 else args[0]
    if not folder.strip():  # pathlib reads "" as ".": a name left empty by a script would index this folder
        raise ConfigError(f"catalog: the folder name is empty ({folder!r})")
    if args[0] == "query":
        if len(args) < 2:
            raise typer.BadParameter("catalog query DIR [NAME|SELECT ...]")
        # no query names the projects; an empty one given is refused by query()
        rows = query(args[1], " ".join(args[2:]) if len(args) > 2 else "projects", rig=rig, limit=limit,
                     seconds=seconds)
        if as_json:
            _print_json(rows)
            return
        if not rows:
            console.print(f"no rows: no project in {args[1]} answers {' '.join(args[2:]) or 'projects'!r}",
                          highlight=False, soft_wrap=True)
            return
        table = Table(title=f"{len(rows)} rows")
        for col in rows[0]:
            table.add_column(col)
        for r in rows:
            table.add_row(*(_cell(v) for v in r.values()))
        console.print(table)
        return
    if len(args) != 1:
        raise typer.BadParameter("catalog DIR (one folder), or catalog query DIR ...")
    with _loop_progress() as bar:
        task = bar.add_task("catalog", total=None)
        res = build_catalog(args[0], compute_errors=errors,
                            progress=lambda name, i, n: bar.update(task, description=f"catalog: {name}",
                                                                   completed=i, total=n))
    if as_json:
        _print_json(res.as_dict())
    else:
        console.print(f"{res.path}: {len(res.indexed)} projects read, {len(res.restamped) + len(res.unchanged)} "
                      f"unchanged, {len(res.removed)} removed, {len(res.skipped)} files that are no projects "
                      f"({res.seconds:.2f} s); page {res.page}", highlight=False, soft_wrap=True)
    if res.refused:  # a file reaching outside itself is worth a failing exit code, not only a row
        first = next(iter(res.refused.values()))
        err_console.print(f"error: catalog: {len(res.refused)} project(s) refused, listed with their error: "
                          f"{shown(first)}", highlight=False, soft_wrap=True)
        raise typer.Exit(1)


#: characters a catalogue table cell shows (laying out one 50 MB value took 18 s of CPU)
CELL_CHARS = 1000


def _cell(v) -> str:
    """One value of a query row as table text: BLOBs in hexadecimal as in --json, long values cut."""
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, (bytes, bytearray, memoryview)):
        head = bytes(v[: CELL_CHARS // 2])
        return head.hex() + (f"… ({len(v)} bytes)" if len(v) > len(head) else "")
    text = str(v)
    return shown(text[:CELL_CHARS]) + (f"… ({len(text)} characters)" if len(text) > CELL_CHARS else "")
