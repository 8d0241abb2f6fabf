"""``odsuite demo``: the whole story on the simulated thesis rig, no hardware.

A project is created on the thesis rig; five impact tests like the thesis's are recorded on the
simulated rig whose truth hides two effects the project's model does not know (a stiffer vertical
suspension and a flexible twist mode of the platform); the records are processed to generalized
coordinates; the model-measurement loop (compare, diagnose, add the best effect) runs until the
diagnosis finds nothing to explain or no significant candidate, or the round limit is reached; a report, a movie with the model
overlaid and the history figure are written; finally the hidden truth is written beside them and
set against what the loop found.
"""

from __future__ import annotations

import json
import math
import os
import textwrap
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn
from rich.table import Table

from odsuite.api import error_text, say_on_interrupt

#: The truth's hidden effects: a 30 % stiffer vertical suspension and a platform twist mode at
#: 640 Hz, 2 % damping (well inside the accelerometer and filter bands, beyond every rigid mode)
HIDDEN_EFFECTS: tuple[tuple[str, dict[str, float]], ...] = (
    ("stiffness", {"scale_z": 1.3}),
    ("plate_flexibility", {"frequency_hz": 640.0, "damping_ratio": 0.02, "twist": 0.4}),
)
#: Thesis tests: +z at the centre, near the +y edge, near the -x edge; -x on a side; +z near a corner
SCENARIOS = ("T1", "T2", "T3", "T5", "T6")
#: T3 (20 N in the thesis) is struck at 15 N: the stiffer truth would overload accelerometer x3's range
FORCE_PEAK_N = {"T3": 15.0}
SAMPLES = 4096
SAMPLING_RATE = 20_000.0
ADC_BITS = 16
#: at most this many rounds; the last one normally only confirms that no significant candidate is left
ROUNDS = 3
PROJECT_NAME = "demo.h5"
#: The movie: this experiment, from 5 ms before the hit to 60 ms after, one frame per 0.25 ms
MOVIE_EXPERIMENT = "T6"
MOVIE_WINDOW_S = (-0.005, 0.06)
MOVIE_FRAME_STEP = 5


@dataclass
class DemoResult:
    """What the demo did: the errors of revisions 0, 1, ..., the effects found with their values,
    the hidden truth and the files written."""

    out: Path
    project: Path
    errors: list[float]
    noise_floor: float
    added: list[str]
    found: dict[str, dict[str, float]]
    hidden: dict[str, dict[str, float]]
    files: dict[str, Path] = field(default_factory=dict)


def _progress() -> Progress:
    err = Console(stderr=True)
    return Progress(TextColumn("{task.description}"), BarColumn(), console=err, transient=True,
                    disable=not err.is_terminal)


def _step(console: Console, n: int, title: str, started: float) -> None:
    console.rule(f"[bold]{n}. {title}[/bold] (at {time.monotonic() - started:.0f} s)", align="left")


def effective_scales(effect_name: str, values: Mapping[str, float], model) -> dict[str, float]:
    """Key values of an effect for the summary. A spring scale's per-axis and per-spring factors
    multiply (only their products are identifiable), so it is summarised as the total spring
    coefficient along each axis relative to the nominal one; other effects by their own values."""
    from odsuite.contracts.plugins import registries

    effect = registries().effects.get(effect_name)
    quantity = getattr(effect, "field", None)
    if quantity not in ("stiffness", "damping"):
        return dict(values)
    changed = effect.apply(model, dict(values))
    before = sum(np.asarray(getattr(s, quantity), dtype=float) for s in model.springs)
    after = sum(np.asarray(getattr(s, quantity), dtype=float) for s in changed.springs)
    return {f"total_{a}": float(r) for a, r in zip("xyz", after / before)}


def _record(project, console: Console) -> None:
    from odsuite.api import acquire
    from odsuite.contracts.daq import AcquisitionSettings
    from odsuite.contracts.plugins import registries

    sim = registries().daq_backends.get("sim")
    settings = AcquisitionSettings(sampling_rate=SAMPLING_RATE, n_samples=SAMPLES)
    for i, name in enumerate(SCENARIOS):
        peak = FORCE_PEAK_N.get(name, max(h.peak for h in sim.scenarios[name].hits))
        exp, rec = acquire(project, sim, name, settings, scenario=name, force_peak=FORCE_PEAK_N.get(name),
                           seed=10 + i, adc_bits=ADC_BITS, effects=[(e, dict(v)) for e, v in HIDDEN_EFFECTS])
        clipped = "".join(f", [red]{n} samples of {rec.channel_names[ch]} clipped[/red]"
                          for ch, n in rec.clipped.items())
        _say(console, f"  {name}: {sim.scenarios[name].description}; {peak:g} N hammer, "
                      f"{exp.n_samples} samples x {exp.n_channels} channels{clipped}")


def _say(console: Console, text: str) -> None:
    """One narrative line wrapped at the console's width (80 columns when piped), its continuation
    indented under it; a path or a number is never broken."""
    indent = " " * (len(text) - len(text.lstrip(" ")))
    console.print(textwrap.fill(text, console.width, subsequent_indent=indent + "  ", break_long_words=False,
                                break_on_hyphens=False), highlight=False, soft_wrap=True)


def _print_comparison(console: Console, doc: Mapping[str, Any]) -> None:
    worst = ", ".join(f"{w['name']} {error_text(w['error'])}" for w in doc["worst"] if w["kind"] == "channel")
    _say(console, f"  compare: error [bold]{doc['error']:.4f}[/bold] (noise floor {doc['noise_floor_error']:.4f}); "
                  f"worst channels: {worst}")
    for peak in doc["residual_peaks"]:
        if peak["lacking"]:
            _say(console, f"  residual peak at {peak['frequency_hz']:.0f} Hz in {', '.join(peak['channels'])}: "
                          "the model has no mode there")


def _print_candidates(console: Console, doc: Mapping[str, Any], rows: int = 6) -> None:
    # the title on a line of its own: as the table's title it wrapped at the table's narrow width
    console.print(f"diagnose (revision {doc['revision']}): candidate effects, best first (errors after the fit)",
                  highlight=False)
    table = Table()
    # no column of fitted factors: a split the data do not determine (a scale per axis times one per
    # spring); what is determined is printed, in physical units, with each effect added
    table.add_column("effect", no_wrap=True)
    for col in ("signif.", "fitted", "validated"):
        table.add_column(col)
    for c in doc["candidates"][:rows]:
        validated = c["validated_error"]
        # "-": left undecided, as nothing the diagnosis reads turns on it (significance_decided)
        shown = ("[green]yes[/green]" if c["significant"] else "no") if c.get("significance_decided", True) else "-"
        table.add_row(c["effect"], shown, f"{c['error_after']:.4f}",
                      "-" if validated is None or math.isnan(validated) else f"{validated:.4f}")
    console.print(table)
    rest = doc["candidates"][rows:]
    if rest:
        significant = sum(c["significant"] for c in rest)
        _say(console, f"  ({len(rest)} more candidates, {significant or 'none'} significant)")


def _write_outputs(out: Path, project_path: Path, diagnosis: Mapping[str, Any] | None,
                   console: Console) -> dict[str, Path]:
    """The history figure, a movie of one test with the model's motion and the HTML report."""
    from odsuite.contracts.plugins import registries
    from odsuite.api import open_project
    from odsuite.contracts.renderers import RenderRequest

    files: dict[str, Path] = {"history": out / "history.png"}
    movie_exp = MOVIE_EXPERIMENT
    registries().renderers.get("history").render(RenderRequest(project_path, None, files["history"]))
    with open_project(project_path) as p:
        exp = p.experiment(movie_exp)
    hit = exp.pretrigger / exp.sampling_rate
    movie = registries().renderers.get("movie").render(RenderRequest(
        project_path, movie_exp, out / f"{movie_exp}.mp4", {
            "model": True, "start": max(0.0, hit + MOVIE_WINDOW_S[0]), "end": hit + MOVIE_WINDOW_S[1],
            "frame_step": MOVIE_FRAME_STEP}, progress=False))
    files["movie"] = Path(movie.path)
    _say(console, f"  movie: {movie.path} ({movie.summary}; measured and model motion overlaid)")
    for note in movie.notes:
        _say(console, f"  note: {note}")
    _say(console, f"  history figure: {files['history']}")
    res = registries().renderers.get("report").render(RenderRequest(
        project_path, None, out / "report.html",
        {"diagnosis": diagnosis, "run_diagnosis": False, "movie_experiment": movie_exp}))
    files["report"] = Path(res.path)
    _say(console, f"  report: {res.path} ({res.summary})")
    for note in res.notes:
        _say(console, f"  note: {note}")
    return files


def _summary_table(result: DemoResult, model) -> Table:
    table = Table(title="hidden in the simulated rig vs found by the loop", title_justify="left")
    for col in ("effect", "quantity", "hidden", "found"):
        table.add_column(col)
    for name in list(result.hidden) + [n for n in result.found if n not in result.hidden]:
        hidden = effective_scales(name, result.hidden[name], model) if name in result.hidden else {}
        found = effective_scales(name, result.found[name], model) if name in result.found else {}
        keys = list(hidden) or list(found)
        if name in result.hidden and name not in result.found:
            table.add_row(name, "", "present", "[red]not found[/red]")
            continue
        for i, k in enumerate(keys):
            table.add_row(name if i == 0 else "", k, f"{hidden[k]:.4g}" if k in hidden else "absent",
                          f"{found[k]:.4g}" if k in found else "-")
    return table


def run_demo(out: str | Path = "demo-output", *, rounds: int = ROUNDS, console: Console | None = None) -> DemoResult:
    """Run the demo into directory ``out`` (its ``demo.h5``, report, movie and figures are replaced).

    ``rounds``: at most this many diagnose/add-effect rounds; the loop stops earlier when the
    diagnosis finds nothing to explain (the error is within the noise floor) or no candidate is
    significant.
    """
    started = time.monotonic()
    console = console or Console()
    out = Path(out)
    _demo_folder(out)
    say_on_interrupt(f"interrupted: {out} holds what the demo wrote so far; run it again to replace it")
    path = out / PROJECT_NAME
    _recorded_project(path, console, started)

    _step(console, 4, "the loop: compare, diagnose, add the best effect", started)
    errors, added, diagnosis_doc, noise, found, base = _loop(path, rounds, console)
    _say(console, "  error per revision: " + " -> ".join(error_text(e) for e in errors) + f" (noise floor {noise:.4f})")

    _step(console, 5, "report, movie and history figure", started)
    files = _write_outputs(out, path, diagnosis_doc, console)

    _step(console, 6, "what was hidden and what was found", started)
    hidden = {e: dict(v) for e, v in HIDDEN_EFFECTS}
    files["hidden_truth"] = _write_truth(out, hidden)
    result = DemoResult(out=out, project=path, errors=errors, noise_floor=noise, added=added, found=found,
                        hidden=hidden, files=files)
    console.print(_summary_table(result, base))
    missed = [n for n in hidden if n not in found]
    extra = [n for n in found if n not in hidden]
    verdict = ("both hidden effects found" if not missed and not extra else
               f"missed: {', '.join(missed) or 'none'}; not hidden but added: {', '.join(extra) or 'none'}")
    _say(console, f"  {verdict}; hidden truth written to {files['hidden_truth']}; "
                  f"{time.monotonic() - started:.0f} s in all")
    return result


#: the file that marks a folder as the demo's own: its outputs are replaced when the demo runs there again
MARKER = ".odsuite-demo"
#: what the demo writes (the movie's name: MOVIE_EXPERIMENT's, .mp4 or the renderer's fallback)
OUTPUTS = (PROJECT_NAME, "hidden-truth.json", "history.png", "report.html")


def _demo_folder(out: Path) -> None:
    """Make ``out`` the demo's folder, its earlier project and truth file removed; refuse (one line,
    nothing touched) a path that is not a folder, a folder of someone else's files (without the
    demo's marker, and not all of an earlier demo's outputs alone), and an output in the way that
    is not a writable file."""
    from odsuite.api import ConfigError

    if out.is_symlink() and not out.exists():
        raise ConfigError(f"{out}: a link to nothing: demo --out takes a folder for its project, report, movie and figures")
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: not a folder: demo --out takes a folder for its project, report, movie and figures")
    if out.is_dir() and not (out / MARKER).is_file():
        names = {p.name for p in out.iterdir()}
        earlier = set(OUTPUTS) <= names and all(n in OUTPUTS or n.startswith(f"{MOVIE_EXPERIMENT}.") for n in names)
        if names and not earlier:
            raise ConfigError(f"{out}: a folder the demo did not write ({len(names)} entries, no {MARKER}): its files "
                              "would be replaced; choose a new or empty folder")
    for name in OUTPUTS:
        target = out / name
        if target.is_symlink() or (target.exists() and not target.is_file()):
            raise ConfigError(f"{target}: not a file the demo wrote (a link, folder or device): remove it or choose "
                              "another folder")
        if target.exists() and not os.access(target, os.W_OK):
            raise ConfigError(f"{target}: read-only: left as it is; choose another folder")
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text("written by `odsuite demo`: its project, report, movie and figures here are replaced "
                              "when it runs here again\n")
    for name in (PROJECT_NAME, "hidden-truth.json"):
        (out / name).unlink(missing_ok=True)


def _recorded_project(path: Path, console: Console, started: float) -> None:
    """Steps 1-3: a project on the thesis rig, the simulated hammer tests, processed."""
    from odsuite.api import create_project, process_experiment, revision_model

    _step(console, 1, "a project on the thesis rig", started)
    p = create_project(path, "thesis-dynamometer")
    try:
        modes = revision_model(p).shared.modes().frequency_hz
        _say(console, f"  {path}: rig {p.rig.name}, model {p.rig.default_model!r} (rigid platform on four "
                      f"springs), modes {', '.join(f'{f:.0f}' for f in modes)} Hz")

        _step(console, 2, "impact tests on the simulated rig", started)
        _say(console, f"  {len(SCENARIOS)} hammer tests at {SAMPLING_RATE:g} Hz, {ADC_BITS}-bit ADC; the simulated "
                      "rig differs from the model in two ways the loop has to find")
        _record(p, console)

        _step(console, 3, "process to generalized coordinates", started)
        for name in p.experiment_names():
            s = process_experiment(p, name)
            _say(console, f"  {name}: {', '.join(s['datasets'])} (channels {s['channels'][0]}..{s['channels'][-1]})")
        info = p.info()
        near = {}
        for name, e in info["experiments"].items():
            for ch in e["clipped"]:
                near.setdefault(ch, []).append(name)
        near_txt = "; ".join(f"{ch} in {', '.join(names)}" for ch, names in near.items()) or "none"
        _say(console, f"  info: {len(info['experiments'])} experiments, "
                      f"{sum(e['n_samples'] for e in info['experiments'].values())} samples per channel in all, "
                      f"derived {', '.join(sorted({d for e in info['experiments'].values() for d in e['derived']}))}; "
                      f"channels reaching their Systeminfo input limits: {near_txt}"
                      + (" (the thesis's input ranges at its hammer levels: a model cannot follow a clipped "
                         "signal, so each is left out of its experiment's comparison)" if near else ""))
    finally:
        p.close()


def _loop(path: Path, rounds: int, console: Console):
    """Step 4: compare, diagnose and add the best significant effect, round after round, until
    nothing is left to explain or no candidate is significant. Returns the errors per revision,
    the effects added, the last diagnosis, the noise floor, the effects found with their values
    and the model without them."""
    from odsuite.api import (add_effect, compare, current_revision, diagnose, moved_quantities, open_project,
                             physical_text, prepare, revision_model)

    errors: list[float] = []
    added: list[str] = []
    diagnosis_doc = None
    noise = math.nan
    with open_project(path, "a") as p, _progress() as bar:
        task = bar.add_task("", total=None)

        def report(what: str, i: int = 0, n: int = 0) -> None:
            bar.update(task, description=what, completed=i, total=n or None)

        exps = prepare(p)
        for r in range(1, rounds + 1):
            console.print(f"[bold]  round {r}[/bold]")
            cmp = compare(p, prepared=exps).as_dict()
            if not errors:
                errors.append(cmp["error"])
            noise = cmp["noise_floor_error"]
            _print_comparison(console, cmp)
            diagnosis_doc = diagnose(p, prepared=exps, progress=report).as_dict()
            _print_candidates(console, diagnosis_doc)
            _say(console, f"  verdict: {diagnosis_doc['verdict']}")
            best = next((c for c in diagnosis_doc["candidates"] if c["significant"]), None)
            if diagnosis_doc["verdict"] == "nothing to explain":
                _say(console, "  the error is within the noise floor: the loop stops")
                break
            if best is None:
                _say(console, "  no candidate is significant: the loop stops")
                break
            res = add_effect(p, best["effect"], progress=report)
            added.append(best["effect"])
            for step in res.get("steps", [res]):  # a pair "A+B" adds A, then B: a revision each
                errors.append(step["error"])
                _say(console, f"  add-effect {step['effect']}: revision {step['revision']}, error "
                              f"{step['previous_error']:.4f} -> [bold]{step['error']:.4f}[/bold]")
                rows = next((e.get("physical") for e in reversed(step["effects"]) if e["effect"] == step["effect"]),
                            None)
                if rows:  # what moved most, as `odsuite add-effect` prints it
                    console.print(textwrap.fill(physical_text(moved_quantities(rows, limit=3)), console.width,
                                                initial_indent="    ", subsequent_indent="    ",
                                                break_on_hyphens=False), highlight=False, soft_wrap=True)
        found = {e["effect"]: dict(e["values"]) for e in current_revision(p).get("effects", [])}
        base = revision_model(p, {"effects": []}).shared
    return errors, added, diagnosis_doc, noise, found, base


def _write_truth(out: Path, hidden: dict) -> Path:
    """Step 6's file: what the simulated rig hid from the model, and how it was recorded."""
    truth_file = out / "hidden-truth.json"
    truth_file.write_text(json.dumps({
        "effects": [{"effect": e, "values": v} for e, v in hidden.items()],
        "scenarios": list(SCENARIOS), "n_samples": SAMPLES, "sampling_rate_hz": SAMPLING_RATE,
        "adc_bits": ADC_BITS}, indent=2) + "\n")
    return truth_file
