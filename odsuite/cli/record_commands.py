"""Commands that record and process experiments: acquire, process."""

from __future__ import annotations

import contextlib
import math
import sys
from pathlib import Path

import typer

from odsuite.domain.errors import ConfigError, OdsuiteError
from odsuite.cli.app import _ledger, _print_json, app, console, echo_force_point, err_console


@app.command("process")
def process_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: list[str] = typer.Option(None, "--experiment", help="Experiment name (repeatable; default: all)."),
    corrected: bool = typer.Option(False, "--corrected", help="Also store corrected coordinates "
                                   "(gencoords_corrected): the current revision's measurement effects undone on the "
                                   "records, no high-pass, drift removed against the revision's structure."),
    cutoff: float = typer.Option(None, "--cutoff", help="--corrected: Hz below which the model replaces the "
                                 "measurement (default: half the model's lowest natural frequency)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document: per experiment the datasets, "
                                 "channels and solvers; corrections applied; the current revision's error."),
) -> None:
    """Run each experiment's Table E.2 processing chain and the generalized-coordinate solver."""
    from rich.progress import Progress

    from odsuite.analysis.history import store_current_error
    from odsuite.analysis.stored_modes import store_record_modes
    from odsuite.processing.pipeline import process_experiment
    from odsuite.store.project import open_project

    # below 0.01 Hz no hammer record (seconds long) has a frequency line: checked before anything is stored
    if cutoff is not None and not (math.isfinite(cutoff) and cutoff >= 0.01):
        raise ConfigError(f"--cutoff: must be a finite frequency >= 0.01 Hz, got {cutoff}")
    if cutoff is not None and not corrected:  # else ignored without a word
        raise ConfigError(f"--cutoff {cutoff:g} Hz: sets where the corrected coordinates hand over to the model, "
                          "so it applies with --corrected only; add --corrected or leave --cutoff out")
    with open_project(project, "a") as p, Progress(console=err_console, transient=True,
                                                   disable=not err_console.is_terminal) as bar, \
            (p.transaction() if corrected else contextlib.nullcontext()):
        # with --corrected one transaction: all or nothing; without, each experiment commits on its own
        names = experiment or p.experiment_names()
        if not names:  # else the command ends without a word
            err_console.print(f"note: {project}: no experiments to process (acquire or import some first)",
                              highlight=False, soft_wrap=True)
        notes: dict[str, list[str]] = {}  # a note (the rig's layout) holds for many experiments: said once
        doc: dict = {"project": str(project), "experiments": {}, "corrected": {}, "revision": p.current_revision,
                     "error": None, "error_notes": []}
        say = (lambda *a, **k: None) if as_json else console.print
        _ledger.plan(project, names + ([f"{n} (corrected)" for n in names] if corrected else []))
        if corrected:
            _ledger.start(", ".join(names + [f"{n} (corrected)" for n in names]))
        for name in names:
            task = bar.add_task(f"processing {name}", total=None)
            if not corrected:
                _ledger.start(name)
            with p.transaction():  # the record and its modes in one commit: a failure leaves neither
                summary = process_experiment(p, name, progress=lambda a, b, t=task: bar.update(t, completed=a,
                                                                                                total=b))
                bar.update(task, description=f"identifying the modes of {name}")
                # `compare` reads them instead of identifying them again
                summary["notes"] += store_record_modes(p, name)
            if not corrected:
                _ledger.done()
            doc["experiments"][name] = summary
            bodies = "; ".join(f"{b}: {r['solver']}" + (
                f", rigidity {', '.join(f'{k} {v:.1%}' for k, v in r['rigidity'].items())}" if "rigidity" in r else "")
                + (f" FLAGGED {','.join(r['flagged'])}" if r.get("flagged") else "")
                for b, r in summary["bodies"].items())
            say(f"{name}: {', '.join(summary['datasets'])} for channels "
                          f"{', '.join(map(str, summary['channels']))}" + (f"; {bodies}" if bodies else ""),
                          highlight=False, soft_wrap=True)
            for note in summary["notes"]:
                notes.setdefault(note, []).append(name)
        for note, named in notes.items():
            which = "every experiment" if len(named) == len(names) > 1 else ", ".join(named)
            err_console.print(f"note ({which}): {note}", highlight=False, soft_wrap=True)
        if corrected:
            from odsuite.analysis.correction import process_corrected

            for name, res in process_corrected(p, experiment or None, cutoff_hz=cutoff).items():
                doc["corrected"][name] = res
                undone = "; ".join(f"{c['effect']} " + ", ".join(f"{k} {v:.4g}" for k, v in c["values"].items())
                                   for c in res["corrections"]) or "none"
                say(f"{name}: gencoords_corrected (model revision {res['revision']}, cutoff "
                              f"{res['cutoff_hz']:.1f} Hz; measurement corrections: {undone})",
                              highlight=False, soft_wrap=True)
        # stored now, so that `info` and `history` read it instead of comparing again
        task = bar.add_task("comparing the current model revision with the records", total=None)
        try:
            doc["error"] = store_current_error(p, doc["error_notes"])
        except OdsuiteError as exc:  # the records are processed all the same
            err_console.print(f"note: the current model revision's error was not stored: {exc}",
                              highlight=False, soft_wrap=True)
        bar.remove_task(task)
        for note in doc["error_notes"]:  # records the error leaves out
            err_console.print(f"note: {note}", highlight=False, soft_wrap=True)
    if as_json:
        _print_json(doc)


@app.command("acquire", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def acquire_cmd(
    ctx: typer.Context,
    project: Path = typer.Argument(..., help="Project file."),
    daq: str = typer.Option("sim", "--daq", help="A registered acquisition backend (built in: sim, the simulated "
                            "rig; ni, NI-DAQmx). Its own options follow; `odsuite plugins` lists them."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_point: str = typer.Option(None, "--force-point", help="X,Y,Z in the rig frame with units (200mm,150mm,75mm or 0.2,0.15,0.075m); bare numbers are mm "
                                   "(the thesis rig: from the platform's centre of mass). A point inside a body moves onto "
                                   "the nearest face the blow strikes."),
    force_dir: str = typer.Option(None, "--force-dir", help="+x,-x,+y,-y,+z,-z or a vector dx,dy,dz."),
    force_body: str = typer.Option(None, "--force-body", help="The body hit, when the force point lies on two."),
    rate: float = typer.Option(None, "--rate", help="Sampling rate, Hz (default: the rig file's "
                               "acquisition sampling_rate, else 20000 Hz)."),
    samples: int = typer.Option(4096, "--samples", help="Samples per channel."),
    pretrigger: int = typer.Option(None, "--pretrigger", help="Samples kept before the trigger (default: "
                                   "the rig file's acquisition pre_trigger, else 512, at most half of --samples)."),
    trigger_level: float = typer.Option(1.0, "--trigger-level", help="Force trigger level, N."),
    trigger_slope: str = typer.Option("rising", "--trigger-slope", help="rising or falling."),
    trigger_timeout: float = typer.Option(10.0, "--trigger-timeout", help="Seconds to wait for the trigger."),
    continuous: bool = typer.Option(False, "--continuous", help="Stream continuously and capture when Enter is pressed."),
) -> None:
    """Record an impact test with an acquisition backend (the simulated rig, NI-DAQmx, a lab's own) into
    the project. The backend's own options (e.g. sim: --scenario T2 --seed 3; ni: --device Dev2) go
    after the common ones."""
    import threading

    from rich.progress import BarColumn, Progress, TextColumn

    from odsuite.processing.acquisition import acquire
    from odsuite.contracts.daq import AcquisitionSettings, parse_backend_options
    from odsuite.domain.excitation import check_force_point, parse_force_direction, read_force_point, surface_point
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    backend = registries().daq_backends.get(daq)
    options = parse_backend_options(daq, backend, ctx.args)
    with open_project(project) as p:
        rig = p.rig
    acq = rig.acquisition if rig is not None else None
    rig_pre = pretrigger is None and acq is not None and acq.pre_trigger is not None
    if rate is None or pretrigger is None:  # the rig's own settings, when its file states them
        rate = rate if rate is not None else (acq.sampling_rate if acq and acq.sampling_rate else 20_000.0)
        # 512, but never more than half the record: --samples 256 was refused for a pretrigger not given
        pretrigger = pretrigger if pretrigger is not None else (acq.pre_trigger if rig_pre else
                                                                max(0, min(512, samples // 2)))
    if rig_pre and 2 <= samples <= pretrigger:  # the settings' own check would not say where the number came from
        raise ConfigError(f"--samples {samples} is not more than the {pretrigger} samples before the trigger that "
                          f"rig {rig.name!r} sets ([acquisition] pre_trigger = {pretrigger}): pass --samples above "
                          f"{pretrigger} (e.g. --samples {2 * pretrigger}) or --pretrigger below {samples}")
    settings = AcquisitionSettings(
        sampling_rate=rate, n_samples=samples, pretrigger=pretrigger, trigger_level=trigger_level,
        trigger_slope=trigger_slope, trigger_timeout=trigger_timeout,
        mode="continuous" if continuous else "finite")
    if not continuous and trigger_slope == "rising" and trigger_level <= 0:
        # kept, not refused: a level below any signal is how a test fires at once on a simulated card
        err_console.print(f"note: --trigger-level {trigger_level:g} N with the rising slope is at or below the force at "
                          "rest (0 N): it fires on noise or as the force comes back up after the blow, not at the "
                          "blow's onset (a level above 0 N catches a blow that reads positive; --trigger-slope "
                          "falling with a level below 0 N one that reads negative)", highlight=False, soft_wrap=True)
    moved = None
    if force_point is not None or force_dir is not None:
        if force_point is None or force_dir is None:
            raise typer.BadParameter("give both --force-point and --force-dir")
        point, bare = read_force_point(force_point)
        where = "--force-point" + (" (bare numbers are mm)" if bare else "")
        direction = parse_force_direction(force_dir)
        if rig is not None:
            point, moved = surface_point(rig, point, direction)  # said once the record is taken
            check_force_point(rig, point, where)
        options.update(point=point, direction=direction)
    if force_body is not None:
        options["force_body"] = force_body
    if continuous:
        pressed = threading.Event()
        threading.Thread(target=lambda: (sys.stdin.readline(), pressed.set()), daemon=True).start()
        options["capture"] = pressed.is_set
        err_console.print("streaming: press Enter to capture", highlight=False)
    with open_project(project, "a") as p, Progress(
            TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
            console=err_console, transient=True, disable=not err_console.is_terminal) as bar:
        task = bar.add_task("arming", total=samples)
        _ledger.plan(project, [f"experiment {name}"])
        _ledger.start(f"experiment {name}")

        def progress(stage: str, done: int, total: int) -> None:
            bar.update(task, description=stage, completed=done, total=total)

        exp, rec = acquire(p, backend, name, settings, progress=progress, **options)
        # as recorded, through the front end (a short blow reads below the hammer's set peak)
        force_peak = None
        if exp.excitation is not None:
            fch = exp.excitation.force_channel
            info = exp.systeminfo.channels[fch]
            force_peak = float(abs(exp.raw(channels=fch)).max() / abs(info.sensitivity * info.daq_gain))
    for ch, count in rec.clipped.items():
        err_console.print(f"warning: channel {ch} ({rec.channel_names[ch]}): {count} samples clipped at the ADC limits",
                          style="yellow", highlight=False, soft_wrap=True)
    for note in rec.notes + ([moved] if moved else []):
        err_console.print(f"warning: {note}", style="yellow", highlight=False, soft_wrap=True)
    echo_force_point(project, name, force_point)
    console.print(f"acquired {name!r}: {exp.n_samples} samples x {exp.n_channels} channels at {exp.sampling_rate:g} Hz, "
                  f"{exp.pretrigger} before the trigger ({rec.source})"
                  + (f"; force peak {force_peak:.3g} N" if force_peak is not None else ""),
                  highlight=False, soft_wrap=True)
