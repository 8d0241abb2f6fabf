"""The model-measurement loop: compare, diagnose, add-effect, history, revert."""

from __future__ import annotations

from pathlib import Path

import typer

from odsuite.domain.arguments import check_workers
from odsuite.domain.display import error_text

from odsuite.cli.app import (_figure_renderer, _loop_progress, _modal_table, _print_json, app, console,
                             console_width, err_console, paragraph, shown)


@app.command("compare")
def compare_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Compare the current model revision with every experiment (like with like)."""
    from rich.table import Table

    from odsuite.analysis.comparison import compare
    from odsuite.analysis.noise_floor import FLOOR_TOLERANCE
    from odsuite.store.project import open_project

    with open_project(project) as p, _loop_progress() as bar:
        task = bar.add_task("comparing", total=None)
        result = compare(p, figures=False,  # the table only: no FRFs where the modes are stored
                         progress=lambda stage: bar.update(task, description=f"comparing: {stage}")).as_dict()
    if as_json:
        _print_json(result)
        return
    console.print(f"revision {result['revision']}: error {result['error']:.4f} "
                  f"(noise floor {result['noise_floor']:.4f}, {result['residual_to_floor']:.2f}x)", highlight=False)
    # a row per channel: a rig has more channels than a terminal has room for columns
    table = Table(title="error (NRMSE, acceleration stage)")
    experiments = list(result["experiments"])
    table.add_column("channel")
    for exp in experiments:
        table.add_column(shown(exp), justify="right")
    table.add_column("all", justify="right")

    def cell(error):  # None: the channel never moved, which a note says
        return "never moves" if error is None else error_text(error)

    for n in result["channels"]:  # "-": the channel is not compared in that experiment
        table.add_row(shown(n), *(cell(result['experiments'][e]['channels'][n])
                                  if n in result["experiments"][e]["channels"] else "-"
                                  for e in experiments), cell(result['channels'][n]))
    table.add_row("all", *(error_text(result['experiments'][e]['error']) for e in experiments), error_text(result['error']),
                  style="bold")
    console.print(table)
    worst = Table(title="where the model fails most",
                  caption=f"channels ranked by their error over their noise floor; within {FLOOR_TOLERANCE:g}x of it "
                          "a channel holds noise alone and tells nothing of the model")
    for col in ("kind", "name", "error", "to floor"):
        worst.add_column(col)
    for w in result["worst"]:
        ratio = w.get("to_floor")
        worst.add_row(w["kind"], w["name"], error_text(w["error"]), "" if ratio is None else
                      f"{ratio:.2f}x" + (" (noise)" if ratio <= FLOOR_TOLERANCE else ""))
    console.print(worst)
    for peak in result["residual_peaks"]:
        where = "no model mode there" if peak["lacking"] else f"near the model's mode at {peak['model_mode_hz']:.0f} Hz"
        console.print(f"residual peak at {peak['frequency_hz']:.0f} Hz ({peak.get('to_floor', float('nan')):.1f}x the "
                      f"noise floor there) in {', '.join(peak['channels'])}: {where}", highlight=False)
    if result.get("modal"):
        console.print(_modal_table(result["modal"]))
    for note in (result.get("modal_notes") or []) + (result.get("notes") or []):
        paragraph(note)


@app.command("diagnose")
def diagnose_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
    effect: list[str] = typer.Option(None, "--effect", help="Try only these effects (repeatable)."),
    workers: int = typer.Option(None, "--workers", min=1, help="Processes that screen and fit candidates (default: "
                                "one per core, at most 2 for a few dozen candidates; the result does not depend on it)."),
) -> None:
    """Rank every registered physical effect by the error it removes (validated), best first. A
    diagnosis of every effect is kept with the model revision: `odsuite report` shows it."""
    from odsuite.analysis.stored_diagnosis import diagnosis_stamp
    from odsuite.diagnosis.diagnose import diagnose
    from odsuite.store.project import open_project

    check_workers(workers)
    with open_project(project) as p, _loop_progress() as bar:
        stamp = None if effect else diagnosis_stamp(p)  # before: records changed meanwhile store nothing
        task = bar.add_task("diagnosing", total=None)
        result = diagnose(p, effects=effect or None, workers=workers,
                          progress=lambda what, i, n: bar.update(task, description=what, completed=i, total=n))
    doc = result.as_dict()
    if stamp is not None:
        _keep_diagnosis(project, doc, stamp)
    if as_json:
        _print_json(doc)
        return
    _print_diagnosis(doc)


def _print_diagnosis(doc) -> None:
    """diagnose's document as text at the console's width."""
    console.print(f"revision {doc['revision']}: error {doc['baseline_error']:.4f} "
                  f"(noise floor {doc['noise_floor']:.4f}, {doc['residual_to_floor']:.2f}x)", highlight=False)
    console.print(f"verdict: {doc['verdict']}", highlight=False)
    console.print(shown(doc["message"]), highlight=False)
    sig = doc["signature"]
    where = [("channels", ", ".join(f"{c['channel']} ({c['residual_to_floor']:.1f}x)" for c in sig["channels"][:6])),
             ("experiments", ", ".join(f"{x['experiment']} ({x['residual_to_floor']:.1f}x)" for x in sig["experiments"][:6])),
             ("bands", ", ".join(f"{b['band']} ({b['residual_to_floor']:.1f}x)" for b in sig["bands"][:6])),
             ("peaks", ", ".join(f"{p:.0f} Hz" for p in sig["peaks_hz"]))]
    for label, text in where:
        if text:
            paragraph(f"left above the floor, {label}: {text}")
    if sig["amplitude_dependent"]:
        console.print("amplitude dependent: the fitted parameters follow the force level", highlight=False)
    console.print(_candidates_table(doc["candidates"], console_width()))
    # the evidence as paragraphs, wrapped at the console's width: the significant candidates' (and
    # the best one's when none is); every candidate's is in --json
    told = [c for c in doc["candidates"] if c["significant"]] or doc["candidates"][:1]
    for c in told:
        confounded = f" (cannot be told apart from {', '.join(c['confounded_with'])})" if c["confounded_with"] else ""
        console.print(f"{c['effect']}{confounded}: {shown(c['evidence'])}", highlight=False)
    if len(told) < len(doc["candidates"]):
        console.print(f"({len(doc['candidates']) - len(told)} more candidates' evidence: --json)", highlight=False)
    if doc["not_applicable"] and "Not tried, as they apply to other model families" not in doc["message"]:
        paragraph(f"not applicable to this model: {', '.join(doc['not_applicable'])}")
    for note in doc.get("notes", ()):  # a document written before diagnose kept notes has none
        paragraph(note)



#: diagnose's table: the checks and the errors after the fit, each column as wide as its header
_CHECKS = ("signif.", "consist.", "plausible")
_ERRORS = ("fitted", "validated")


def _candidates_table(candidates, width: int):
    """diagnose's candidates, best first, laid out in ``width`` columns; 120 or more add whom each
    is confounded with (else they are named with the evidence below the table). An effect's name
    is what `add-effect` takes, so it is never cut or broken: where the names and the three checks
    do not fit side by side the checks fold into one column, and a pair's name longer than the
    room left breaks after its '+' only."""
    from rich.table import Table

    def yes(v: bool) -> str:
        return "yes" if v else "no"

    def room(sizes) -> int:  # the effect column's room beside columns this wide (rich: 3 per column, 1 border)
        return width - sum(sizes) - 3 * (len(sizes) + 1) - 1

    longest = max((len(c["effect"]) for c in candidates), default=len("effect"))
    wide = width >= 120
    folded = not wide and longest > room([len(h) for h in _CHECKS + _ERRORS])
    # folded, the checks read "yes no  -" under their three names
    columns = {" ".join(_CHECKS): 3 * len(_CHECKS) + 2} if folded else {h: len(h) for h in _CHECKS}
    columns.update({h: len(h) for h in _ERRORS})
    fits = longest <= room(list(columns.values()))
    table = Table(title="candidate effects, best first (errors after the fit)")
    table.add_column("effect", no_wrap=fits, overflow="fold")
    for col, size in columns.items():
        table.add_column(col, no_wrap=size == len(col), width=size, overflow="ellipsis")
    if wide:
        table.add_column("confounded with", overflow="fold")
    for c in candidates:
        name = c["effect"] if fits else c["effect"].replace("+", "+\n")
        # "-": not checked (screened only, or a pair whose fit stopped early; its significance: not
        # decided, as nothing the diagnosis reads turns on it)
        tests = [yes(c["significant"]) if c.get("significance_decided", True) else "-",
                 "-" if c["consistent"] is None or not c["fitted"] else yes(c["consistent"]),
                 yes(c["plausible"]) if c["fitted"] else "-"]
        table.add_row(name, *([" ".join(f"{t:<3}" for t in tests).rstrip()] if folded else tests),
                      f"{c['error_after']:.4f}",
                      "-" if c["validated_error"] != c["validated_error"] else f"{c['validated_error']:.4f}",
                      *([", ".join(c["confounded_with"]) or "-"] if wide else []))
    return table


def _keep_diagnosis(project: Path, doc: dict, stamp: dict) -> None:
    """Store the diagnosis with its revision for `report`; where the project cannot be written
    now (another command writes it, a read-only file) a note says so and nothing else changes."""
    from odsuite.analysis.stored_diagnosis import store_diagnosis
    from odsuite.store.project import open_project

    try:
        with open_project(project, "a") as p:
            stored = store_diagnosis(p, doc, stamp)
    except OSError as exc:
        paragraph(f"note: diagnosis not kept for `odsuite report`: {exc}", err_console)
        return
    if not stored:
        paragraph("note: diagnosis not kept for `odsuite report`: the project's records or revision changed while "
                  "diagnosing", err_console)


@app.command("add-effect")
def add_effect_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    effect: str = typer.Argument(..., help="Registered effect name, or a pair A+B diagnose fitted jointly (see `odsuite diagnose`)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Fit an effect together with the current ones and store a new model revision."""
    from odsuite.diagnosis.add_effect import add_effect
    from odsuite.diagnosis.physical import moved, text as physical_text
    from odsuite.store.project import open_project

    with open_project(project, "a") as p, _loop_progress() as bar:
        task = bar.add_task(f"adding {effect}", total=None)
        result = add_effect(p, effect, progress=lambda what, i, n: bar.update(task, description=what,
                                                                                completed=i, total=n))
    if as_json:
        _print_json(result)
        return
    console.print(f"revision {result['revision']}: + {effect}; error {result['previous_error']:.4f} -> "
                  f"{result['error']:.4f} (noise floor {result['noise_floor_error']:.4f})", highlight=False)
    for member in effect.split("+"):  # a pair adds both
        entry = next((e for e in reversed(result["effects"]) if e["effect"] == member), None)
        if entry is None:
            continue
        rows = entry.get("physical")
        if rows:  # the quantities that moved most, as stored; all of them in `odsuite model`
            # none moved (a fit that stayed at the nominal values): the first as stored, not an empty line
            most = moved(rows, limit=6) or list(rows[:6])
            rest = len(rows) - len(most)
            more = f" ({rest} more: `odsuite model {project}`)" if rest else ""
            console.print(f"{member}: {shown(physical_text(most))}{more}", highlight=False)
        elif entry.get("values"):  # an effect without physical quantities (a gain): its fitted values
            values = ", ".join(f"{k} = {v:.6g}" for k, v in entry["values"].items() if isinstance(v, (int, float)))
            console.print(f"{member}: {shown(values)}", highlight=False)
    for line in result["warnings"]:
        paragraph(f"warning: {line}", err_console)
    for note in result.get("notes", ()):
        paragraph(note)


@app.command("history")
def history_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
    figure: Path = typer.Option(None, "--figure", help="Also draw the error per revision (PNG or SVG)."),
) -> None:
    """Model revisions with their effects and errors."""
    from odsuite.analysis.history import history
    from odsuite.cli.text_table import text_table
    from odsuite.store.project import open_project

    from odsuite.contracts.renderers import RenderRequest

    renderer = _figure_renderer("history", figure, project, "--figure") if figure is not None else None
    with open_project(project) as p:
        doc = history(p)
    if renderer is not None:
        renderer.render(RenderRequest(project, None, figure, {"history": doc}))
    if as_json:
        _print_json(doc)
        return
    print(text_table(f"model revisions (current: {doc['current']})", ["revision", "parent", "effects", "error (NRMSE)"],
                     [[str(r["revision"]), "-" if r["parent"] is None else str(r["parent"]),
                       ", ".join(r["effects"]) or "-", "-" if r["error"] is None else f"{r['error']:.4f}"]
                      for r in doc["revisions"]]))
    if renderer is not None:  # as `render` and `frf --figure` say what they wrote
        from odsuite.cli.printable import shown

        print(f"wrote {shown(figure)}")


@app.command("revert")
def revert_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    revision: int = typer.Argument(..., help="Revision to make current again."),
) -> None:
    """Make an earlier model revision current (nothing is deleted)."""
    from odsuite.store.project import open_project

    with open_project(project, "a") as p:
        p.set_current_revision(revision)
    console.print(f"current model revision: {revision}")
