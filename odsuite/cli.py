"""The ``odsuite`` command line: every command is a thin call into the Python API.

Only ``OdsuiteError`` is caught: it is printed as one line and the exit code is 1. Any other
exception is a bug and keeps its traceback. Ctrl-C ends a command with exit code 130 and one line
saying what was stored and what was not.

Names and paths are data: every string printed goes through ``shown`` (no rich markup, control
characters and undecodable bytes escaped), so a name like ``[/x]`` or ``x\\xff`` prints as itself.
"""

from __future__ import annotations

import contextlib
import math
import signal
import sys
from pathlib import Path

#: Ctrl-Cs received: one while the command line loads (imports take about a second) is held here
#: until ``main`` can report it (only when run as the ``odsuite`` program, never for an importing
#: library); one swallowed on the way (see ``_unraisable``) is reported when the command ends.
_INTERRUPTS: list[int] = []
_AS_PROGRAM = Path(sys.argv[0]).name == "odsuite"
if _AS_PROGRAM:
    signal.signal(signal.SIGINT, lambda signum, frame: _INTERRUPTS.append(signum))

import typer
from rich.console import Console
from rich.table import Table
from rich.text import Text

from odsuite.core import diskspace
from odsuite.core.errors import ConfigError, OdsuiteError

app = typer.Typer(
    name="odsuite",
    help="Experimental vibration analysis: impact tests, rigid-plate motion, model comparison.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion for bash, zsh, fish, PowerShell
    pretty_exceptions_enable=False,
)


def shown(value: object) -> str:
    """User data as one printable line: control characters (newlines, ANSI escapes) and bytes that
    were not UTF-8 (surrogate escapes of argv and file names) written as Python escapes."""
    text = str(value)
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else
                   f"\\x{ord(c) - 0xDC00:02x}" if 0xDC80 <= ord(c) <= 0xDCFF else repr(c)[1:-1]
                   for c in text)


class _DataConsole(Console):
    """A console that never reads markup and prints every string through ``shown`` (tables,
    progress descriptions and messages alike); styles come from ``Text`` objects only."""

    def __init__(self, **kwargs) -> None:
        super().__init__(markup=False, **kwargs)

    def render_str(self, text: str, **kwargs) -> Text:
        return super().render_str(shown(text), **{**kwargs, "markup": False})


console = _DataConsole()
err_console = _DataConsole(stderr=True)


class _Interrupted(BaseException):
    """Ctrl-C, raised instead of KeyboardInterrupt so click does not turn it into 'Aborted!'; every
    ``finally`` and copy-on-write cleanup still runs."""


def _commits() -> list[Path]:
    """``storage.COMMITS`` without importing storage: a Ctrl-C that cut an import short (numpy's)
    makes importing it again fail, and before storage is imported nothing was committed."""
    return getattr(sys.modules.get("odsuite.core.storage"), "COMMITS", [])


class _Ledger:
    """What the running command stored, for the one line a Ctrl-C prints. A command names the
    units it will store (``plan``), opens each (``start``) and closes it (``done``); a unit whose
    commit reached the disk (``storage.COMMITS``) before the interrupt counts as stored."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.target: Path | None = None
        self.planned: list[str] = []
        self.stored: list[str] = []
        self.current: str | None = None
        self.commits_at_start = 0

    def plan(self, target: Path, units: list[str]) -> None:
        self.target, self.planned, self.commits_at_start = target, list(units), len(_commits())

    def start(self, unit: str) -> None:
        self.current, self.commits_at_start = unit, len(_commits())

    def done(self) -> None:
        if self.current is not None:
            self.stored.append(self.current)
        self.current = None

    def line(self) -> str:
        if self.current is not None and len(_commits()) > self.commits_at_start:
            self.done()
        if self.target is None:
            return "interrupted: nothing stored"
        missing = [u for u in self.planned if u not in self.stored]
        if not self.stored:
            return f"interrupted: nothing stored, {self.target} unchanged"
        return (f"interrupted: stored {', '.join(self.stored)} in {self.target}; not stored: "
                f"{', '.join(missing) or 'nothing'}")

    def after_error(self, message: str) -> str:
        """The error line of a command that failed after committing some units (multi-experiment
        ``process``): it names what stays stored."""
        if self.current is not None and len(_commits()) > self.commits_at_start:
            self.done()
        if not self.stored:
            return message
        missing = [u for u in self.planned if u not in self.stored]
        return (f"{message.removesuffix('; project unchanged')}; stored before the error: "
                f"{', '.join(self.stored)} in {self.target}; not stored: {', '.join(missing) or 'nothing'}")


_ledger = _Ledger()


def _print_version(value: bool) -> None:
    if value:
        from odsuite.core.version import __version__

        console.print(f"odsuite {__version__}", highlight=False)
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                 help="Print odsuite's version and exit."),
) -> None:
    """Experimental vibration analysis: impact tests, rigid-plate motion, model comparison."""
    from odsuite.core.plugins import registries

    # every provider is checked against its contract before any command runs
    registries()


@app.command("plugins")
def plugins_cmd(as_json: bool = typer.Option(False, "--json", help="Print one JSON document.")) -> None:
    """List registered plugins, their versions and what each registers."""
    from dataclasses import fields

    from odsuite.core.plugins import Registries, default_manager, registries

    pm = default_manager()
    regs = registries()
    if as_json:
        doc = {}
        for name, _plugin in sorted(pm.list_name_plugin()):
            source = pm.source(name)
            registers = {f.name: getattr(regs, f.name).by_plugin(name) for f in fields(Registries)}
            backends = {b: [{"flag": o.cli_flag, "type": o.type.__name__} for o in regs.daq_backends.get(b).options]
                        for b in regs.daq_backends.by_plugin(name)}
            doc[name] = {"distribution": source.distribution, "version": source.version,
                         "registers": {k: list(v) for k, v in registers.items() if v}, "daq_backend_options": backends}
        _print_json({"plugins": doc})
        return
    table = Table(title="odsuite plugins")
    table.add_column("plugin")
    table.add_column("distribution")
    table.add_column("version")
    table.add_column("registers")
    for name, _plugin in sorted(pm.list_name_plugin()):
        provided = []
        for f in fields(Registries):
            names = getattr(regs, f.name).by_plugin(name)
            if names:
                provided.append(f"{f.name.replace('_', ' ')}: {', '.join(names)}")
        for backend in regs.daq_backends.by_plugin(name):
            flags = " ".join(f"{o.cli_flag}" + ("" if o.type is bool else f" {o.type.__name__.upper()}")
                             for o in regs.daq_backends.get(backend).options)
            provided.append(f"  acquire --daq {backend} options: {flags or 'none'}")
        source = pm.source(name)
        # one line per kind: a Text keeps the line breaks that plain strings would show escaped
        table.add_row(name, source.distribution, source.version, Text("\n".join(shown(p) for p in provided) or "-"))
    console.print(table)


@app.command("new")
def new_cmd(
    project: Path = typer.Argument(..., help="Project file to create (.h5)."),
    rig: str = typer.Option("thesis-dynamometer", "--rig",
                            help="Registered rig name, a rig .toml file, or 'none' (no rig geometry)."),
) -> None:
    """Create a new project file on a rig."""
    from odsuite.core.project import create_project

    created = create_project(project, rig)
    name = created.rig.name if created.rig else "none"
    created.close()
    console.print(f"created {project} (rig: {name})", highlight=False, soft_wrap=True)


@app.command("info")
def info_cmd(project: Path = typer.Argument(..., help="Project file."),
             as_json: bool = typer.Option(False, "--json", help="Print one JSON document.")) -> None:
    """Experiments, rig (bodies, springs, coordinate solvers) and model revisions of a project
    (errors as `odsuite history` gives them)."""
    from odsuite.core.history import history
    from odsuite.core.plugins import registries
    from odsuite.core.project import open_project
    from odsuite.core.rig_summary import rig_layout

    with open_project(project) as p:
        info = p.info()
        revisions = p.model_revisions()
        # the same numbers as `history`: a revision never compared gets its error computed now
        errors = {r["revision"]: r["error"] for r in history(p)["revisions"]} if revisions else {}
        layout = rig_layout(p.rig, registries().coordinate_solvers) if p.rig is not None else None
    if as_json:
        _print_json({**info, "rig_layout": layout,
                     "model_revisions": [{**r, "error": errors.get(r["revision"])} for r in revisions]})
        return
    console.print(f"{info['path']}  format {info['format_version']}  rig: {info['rig'] or 'none'}",
                  highlight=False, soft_wrap=True)
    if layout is not None:
        _print_rig_layout(layout)
    table = Table(title="experiments")
    for col in ("name", "channels", "fs (Hz)", "samples", "length (s)", "peak |V|", "clipped",
                "derived"):
        table.add_column(col)
    for name, e in info["experiments"].items():
        peak_channel = max(e["peak_volts"], key=e["peak_volts"].get)
        clipped = ", ".join(f"{c} ({n})" for c, n in e["clipped_samples"].items())
        table.add_row(name, str(len(e["channels"])), f"{e['sampling_rate']:g}",
                      str(e["n_samples"]), f"{e['duration']:.4g}",
                      f"{e['peak_volts'][peak_channel]:.4g} ({peak_channel})",
                      Text(shown(clipped), style="red") if clipped else "-", ", ".join(e["derived"]) or "-")
    console.print(table)
    if info["imports"]:
        console.print("imports (not records): " + ", ".join(f"{shown(n)} ({k})" for n, k in info["imports"].items()),
                      highlight=False, soft_wrap=True)
    if revisions:
        rt = Table(title=f"model revisions (current: {info['current_revision']})")
        for col in ("revision", "model", "effects", "error"):
            rt.add_column(col)
        for r in revisions:
            effects = ", ".join(str(e.get("effect", e.get("name", e))) if isinstance(e, dict) else str(e)
                                for e in r["effects"])
            error = errors.get(r["revision"])
            rt.add_row(str(r["revision"]), r["model"] or "-", effects or "-",
                       "-" if error is None else f"{error:.4f}")
        console.print(rt)


def _print_rig_layout(layout: dict) -> None:
    import numpy as np

    bodies = Table(title=f"rig {shown(layout['name'])}: bodies")
    for col in ("body", "mass (kg)", "sensors", "coordinate solver"):
        bodies.add_column(col)
    for b in layout["bodies"]:
        solver = b["solver"] or (Text("cannot solve: see `process`", style="yellow") if b["solver_problem"] else "-")
        bodies.add_row(shown(b["name"]), f"{b['mass_kg']:.4g}" if b["moving"] else "fixed",
                       str(len(b["sensors"])) if b["sensors"] else "-", solver)
    console.print(bodies)
    if layout["springs"]:
        springs = Table(title="springs")
        for col in ("spring", "between", "at (mm)", "k x, y, z (kN/m)", "c x, y, z (N s/m)"):
            springs.add_column(col)
        for s in layout["springs"]:
            k = np.asarray(s["stiffness_n_per_m"], float)
            c = np.asarray(s["damping_n_s_per_m"], float)
            k, c = (np.diag(k) if k.ndim == 2 else k), (np.diag(c) if c.ndim == 2 else c)  # a matrix: its diagonal
            springs.add_row(shown(s["name"]), f"{shown(s['body'])} - {shown(s['other'])}",
                            ", ".join(f"{1e3 * v:.4g}" for v in s["position_m"]),
                            ", ".join(f"{v / 1e3:.4g}" for v in k), ", ".join(f"{v:.4g}" for v in c))
        console.print(springs)


def _import(project: Path, file: Path, name: str, fmt: str | None, **options) -> None:
    from odsuite.core.importers import check_options, choose_importer
    from odsuite.core.plugins import registries

    importer = choose_importer(registries().importers, file, fmt)
    _ledger.plan(project, [f"experiment {name}"])
    _ledger.start(f"experiment {name}")
    res = importer.import_file(project, file, name, **check_options(importer, options))
    for note in res.notes:
        err_console.print(f"warning: {note}", style="yellow", highlight=False, soft_wrap=True)
    console.print(f"imported {file} ({importer.name}: {res.summary})", highlight=False, soft_wrap=True)


@app.command("import")
def import_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    file: Path = typer.Argument(..., help="Measurement file; its suffix chooses the importer unless --format."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    fmt: str = typer.Option(None, "--format", help="A registered importer (built in: legacy, lvm, uff; "
                            "`odsuite plugins` lists all)."),
    systeminfo: Path = typer.Option(None, "--systeminfo", help="legacy: the .CTR Systeminfo file."),
    force_point: str = typer.Option(None, "--force-point",
                                    help="legacy, lvm, uff: X,Y,Z in mm in the rig frame (the thesis rig: from the "
                                    "platform's centre of mass)."),
    force_dir: str = typer.Option(None, "--force-dir", help="legacy, lvm, uff: +x,-x,+y,-y,+z,-z or a vector dx,dy,dz."),
    force_channel: str = typer.Option(None, "--force-channel", help="lvm, uff: name of the force channel."),
    force_body: str = typer.Option(None, "--force-body", help="lvm, uff on a rig: the body hit, when the force point "
                                   "lies on two."),
) -> None:
    """Import a measurement file as a new experiment, by the importer for its format."""
    _import(project, file, name, fmt, systeminfo=systeminfo, force_point=force_point, force_dir=force_dir,
            force_channel=force_channel, force_body=force_body)


@app.command("import-legacy")
def import_legacy_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    datfile: Path = typer.Argument(..., help="Legacy .DAT/.VIZ data file (volts, samples x channels)."),
    systeminfo: Path = typer.Option(..., "--systeminfo", help="Legacy .CTR Systeminfo file."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_point: str = typer.Option(..., "--force-point",
                                    help="X,Y,Z in mm in the rig frame (the thesis rig: from the platform's centre of mass)."),
    force_dir: str = typer.Option(..., "--force-dir", help="+x,-x,+y,-y,+z,-z or a vector dx,dy,dz."),
) -> None:
    """Import a thesis-era .DAT/.VIZ record with its .CTR Systeminfo (`odsuite import --format legacy`)."""
    _import(project, datfile, name, "legacy", systeminfo=systeminfo, force_point=force_point, force_dir=force_dir)


@app.command("export-legacy")
def export_legacy_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Argument(..., help="Experiment name."),
    cod: Path = typer.Option(..., "--cod", help=".COD file to write."),
    at: str = typer.Option("center", "--at", help="center (centre of mass G) or corner (corner C)."),
) -> None:
    """Write an experiment's generalized coordinates as a thesis .COD file (6 columns per body)."""
    from odsuite.core.importing import export_legacy

    _check_output(cod, project, "--cod")
    export_legacy(project, experiment, cod, at)
    console.print(f"wrote {cod}", highlight=False, soft_wrap=True)


@app.command("process")
def process_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: list[str] = typer.Option(None, "--experiment", help="Experiment name (repeatable; default: all)."),
    corrected: bool = typer.Option(False, "--corrected", help="Also store model-corrected coordinates "
                                   "(gencoords_corrected): no high-pass, drift removed against the current model revision."),
    cutoff: float = typer.Option(None, "--cutoff", help="--corrected: Hz below which the model replaces the "
                                 "measurement (default: half the model's lowest natural frequency)."),
) -> None:
    """Run each experiment's Table E.2 processing chain and the generalized-coordinate solver."""
    from rich.progress import Progress

    from odsuite.core.pipeline import process_experiment
    from odsuite.core.project import open_project

    # below 0.01 Hz no hammer record (seconds long) has a frequency line: checked before anything is stored
    if cutoff is not None and not (math.isfinite(cutoff) and cutoff >= 0.01):
        raise ConfigError(f"--cutoff: must be a finite frequency >= 0.01 Hz, got {cutoff}")
    with open_project(project, "a") as p, Progress(console=err_console, transient=True,
                                                   disable=not err_console.is_terminal) as bar, \
            (p.transaction() if corrected else contextlib.nullcontext()):
        # with --corrected one transaction: all or nothing; without, each experiment commits on its own
        names = experiment or p.experiment_names()
        _ledger.plan(project, names + ([f"{n} (corrected)" for n in names] if corrected else []))
        if corrected:
            _ledger.start(", ".join(names + [f"{n} (corrected)" for n in names]))
        for name in names:
            task = bar.add_task(f"processing {name}", total=None)
            if not corrected:
                _ledger.start(name)
            summary = process_experiment(p, name, progress=lambda a, b, t=task: bar.update(t, completed=a, total=b))
            if not corrected:
                _ledger.done()
            bodies = "; ".join(f"{b}: {r['solver']}" + (
                f", rigidity {', '.join(f'{k} {v:.1%}' for k, v in r['rigidity'].items())}" if "rigidity" in r else "")
                + (f" FLAGGED {','.join(r['flagged'])}" if r.get("flagged") else "")
                for b, r in summary["bodies"].items())
            console.print(f"{name}: {', '.join(summary['datasets'])} for channels "
                          f"{', '.join(map(str, summary['channels']))}" + (f"; {bodies}" if bodies else ""),
                          highlight=False, soft_wrap=True)
            for note in summary["notes"]:
                err_console.print(f"note: {note}", highlight=False, soft_wrap=True)
        if corrected:
            from odsuite.core.correction import process_corrected

            for name, res in process_corrected(p, experiment or None, cutoff_hz=cutoff).items():
                console.print(f"{name}: gencoords_corrected (model revision {res['revision']}, cutoff "
                              f"{res['cutoff_hz']:.1f} Hz)", highlight=False, soft_wrap=True)


@app.command("acquire", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def acquire_cmd(
    ctx: typer.Context,
    project: Path = typer.Argument(..., help="Project file."),
    daq: str = typer.Option("sim", "--daq", help="A registered acquisition backend (built in: sim, the simulated "
                            "rig; ni, NI-DAQmx). Its own options follow; `odsuite plugins` lists them."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_point: str = typer.Option(None, "--force-point", help="X,Y,Z in mm in the rig frame (the thesis rig: from the platform's centre of mass)."),
    force_dir: str = typer.Option(None, "--force-dir", help="+x,-x,+y,-y,+z,-z or a vector dx,dy,dz."),
    force_body: str = typer.Option(None, "--force-body", help="The body hit, when the force point lies on two."),
    rate: float = typer.Option(None, "--rate", help="Sampling rate, Hz (default: the rig's [acquisition], "
                               "else 20000)."),
    samples: int = typer.Option(4096, "--samples", help="Samples per channel."),
    pretrigger: int = typer.Option(None, "--pretrigger", help="Samples kept before the trigger (default: the "
                                   "rig's [acquisition], else 512)."),
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

    from odsuite.core.acquisition import acquire
    from odsuite.core.daq import AcquisitionSettings, parse_backend_options
    from odsuite.core.importing import parse_force_direction, parse_force_point
    from odsuite.core.plugins import registries
    from odsuite.core.project import open_project

    backend = registries().daq_backends.get(daq)
    options = parse_backend_options(daq, backend, ctx.args)
    if rate is None or pretrigger is None:  # the rig's own settings, when its file states them
        with open_project(project) as p:
            acq = p.rig.acquisition if p.rig is not None else None
        rate = rate if rate is not None else (acq.sampling_rate if acq and acq.sampling_rate else 20_000.0)
        pretrigger = pretrigger if pretrigger is not None else (
            acq.pre_trigger if acq and acq.pre_trigger is not None else 512)
    settings = AcquisitionSettings(
        sampling_rate=rate, n_samples=samples, pretrigger=pretrigger, trigger_level=trigger_level,
        trigger_slope=trigger_slope, trigger_timeout=trigger_timeout,
        mode="continuous" if continuous else "finite")
    if force_point is not None or force_dir is not None:
        if force_point is None or force_dir is None:
            raise typer.BadParameter("give both --force-point and --force-dir")
        options.update(point=parse_force_point(force_point), direction=parse_force_direction(force_dir))
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
    for ch, count in rec.clipped.items():
        err_console.print(f"warning: channel {ch} ({rec.channel_names[ch]}): {count} samples clipped at the ADC limits",
                          style="yellow", highlight=False, soft_wrap=True)
    for note in rec.notes:
        err_console.print(f"warning: {note}", style="yellow", highlight=False, soft_wrap=True)
    console.print(f"acquired {name!r}: {exp.n_samples} samples x {exp.n_channels} channels at {exp.sampling_rate:g} Hz, "
                  f"{exp.pretrigger} before the trigger ({rec.source})", highlight=False, soft_wrap=True)


@app.command("model")
def model_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """The project's current model: revision, effects, parameters and modes (ascending)."""
    import json

    from odsuite.core.modelrev import model_report
    from odsuite.core.project import open_project

    with open_project(project) as p:
        report = model_report(p)
    if as_json:
        print(json.dumps(report))
        return
    console.print(f"model {report['model']!r}, revision {report['revision']}, effects: "
                  f"{', '.join(report['effects']) or 'none'}", highlight=False, soft_wrap=True)
    if report["parameters"]:
        params = Table(title="parameters")
        for col in ("effect", "parameter", "value", "unit", "meaning"):
            params.add_column(col)
        for effect, values in report["parameters"].items():
            info = report["parameter_info"].get(effect.split("#")[0], {})  # "missing_mode#2": its second instance
            for name, value in values.items():
                if name == "per_experiment":
                    continue
                about = info.get(name, {})
                params.add_row(shown(effect), shown(name), f"{value:.6g}", shown(about.get("unit", "")) or "-",
                               shown(about.get("description", "")))
        console.print(params)
    table = Table(title="modes")
    for col in ("mode", "frequency (Hz)", "damping ratio"):
        table.add_column(col)
    for i, m in enumerate(report["modes"], 1):
        table.add_row(str(i), f"{m['frequency_hz']:.2f}", f"{m['damping_ratio']:.4f}")
    console.print(table)


@app.command("import-lvm")
def import_lvm_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    lvmfile: Path = typer.Argument(..., help="LabVIEW .lvm text file."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_channel: str = typer.Option(None, "--force-channel", help="Name of the force column (on a rig: the one for its force channel)."),
    force_point: str = typer.Option(None, "--force-point", help="On a rig: X,Y,Z in mm in the rig frame."),
    force_dir: str = typer.Option(None, "--force-dir", help="On a rig: +x,-x,+y,-y,+z,-z or a vector dx,dy,dz."),
    force_body: str = typer.Option(None, "--force-body", help="On a rig: the body hit, when the force point lies on two."),
) -> None:
    """Import a LabVIEW .lvm hammer record as a new experiment (`odsuite import --format lvm`); on a
    rig its columns go to the rig's sensors by name, else in order."""
    _import(project, lvmfile, name, "lvm", force_channel=force_channel, force_point=force_point, force_dir=force_dir,
            force_body=force_body)


@app.command("import-uff")
def import_uff_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    ufffile: Path = typer.Argument(..., help="UFF file (.uff/.unv) with time records (dataset 58)."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_channel: str = typer.Option(None, "--force-channel", help="Name of the force record."),
    force_point: str = typer.Option(None, "--force-point", help="On a rig: X,Y,Z in mm in the rig frame (default: "
                                    "the force record's node in the file)."),
    force_dir: str = typer.Option(None, "--force-dir", help="On a rig: +x,-x,+y,-y,+z,-z or a vector dx,dy,dz "
                                  "(default: the force record's direction in the file)."),
    force_body: str = typer.Option(None, "--force-body", help="On a rig: the body hit, when the force point lies on two."),
) -> None:
    """Import a UFF file's time records as a new experiment, its FRFs as derived 'frf'
    (`odsuite import --format uff`); on a rig its records go to the rig's sensors by UFF node and
    direction, else by name, else in order."""
    _import(project, ufffile, name, "uff", force_channel=force_channel, force_point=force_point, force_dir=force_dir,
            force_body=force_body)


@app.command("export-uff")
def export_uff_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Argument(None, help="Experiment name (default: the only one)."),
    output: Path = typer.Option(..., "-o", "--output", help="UFF file to write."),
    ascii_: bool = typer.Option(False, "--ascii", help="ASCII dataset 58 instead of binary 58b."),
    nodes: int = typer.Option(15, "--nodes", help="Node dataset: 15 or 2411."),
) -> None:
    """Write an experiment as UFF: time records, FRFs, the rig's nodes and trace lines."""
    from odsuite.core.uff_project import export_uff

    _check_output(output, project, "-o")
    export_uff(project, output, experiment, binary=not ascii_, node_dataset=nodes)
    console.print(f"wrote {output}", highlight=False, soft_wrap=True)


@app.command("frf")
def frf_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Option(..., "--experiment", help="Experiment name."),
    estimator: str = typer.Option("H1", "--estimator", help="H1, H2 or Hv."),
    figure: Path = typer.Option(None, "--figure", help="Write magnitude, phase and coherence (.png, .svg, .pdf)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """FRFs over the accepted hammer hits of an experiment (stored as derived 'frf')."""
    from odsuite.core.errors import ConfigError
    from odsuite.core.frf import usable_band
    from odsuite.core.modal_project import experiment_frf

    if figure is not None:
        _check_output(figure, project, "--figure")
    frf, hits = experiment_frf(project, experiment, estimator=estimator)
    for h in hits if not as_json else ():
        state = "accepted" if h.accepted else "rejected: " + ", ".join(h.reasons)
        console.print(f"hit at sample {h.peak_index} ({h.peak_force:.4g} N): {state}", highlight=False)
    try:
        band = usable_band(frf.frequency, frf.force_autospectrum, frf.coherence, frf.n_averages)
        usable = f"usable band {band[0]:.1f}-{band[1]:.1f} Hz"
    except ConfigError as exc:  # the FRFs are stored all the same: say why no band, do not fail
        band, usable = None, str(exc).split(";")[0]
    if figure is not None:
        from odsuite.core.modal_figures import frf_figure

        frf_figure(frf, figure, band_hz=band, title=f"FRFs of {experiment}")
    if as_json:
        _print_json({"experiment": experiment, "estimator": estimator, "channels": list(frf.output_names),
                     "n_averages": frf.n_averages, "lines": int(frf.frequency.size),
                     "resolution_hz": float(frf.frequency[1] - frf.frequency[0]) if frf.frequency.size > 1 else None,
                     "usable_band_hz": None if band is None else [float(band[0]), float(band[1])],
                     "usable_band_note": None if band is not None else usable,
                     "hits": [{"sample": int(h.peak_index), "peak_force_n": float(h.peak_force),
                               "accepted": bool(h.accepted), "reasons": list(h.reasons)} for h in hits],
                     "figure": None if figure is None else str(figure)})
        return
    averaged = "1 hit" if frf.n_averages == 1 else f"{frf.n_averages} hits averaged"
    console.print(f"{estimator} FRFs of {len(frf.output_names)} channels, {averaged}, "
                  f"{frf.frequency.size} lines, {usable}", highlight=False)
    if figure is not None:
        console.print(f"wrote {figure}", highlight=False, soft_wrap=True)


@app.command("modes")
def modes_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiments: list[str] = typer.Option(..., "--experiment", help="Experiment name; give it several times for "
                                          "an FRF matrix across experiments (roving hammer, several references)."),
    f_min: float = typer.Option(None, "--fmin", help="Lowest frequency of the fit band (Hz)."),
    f_max: float = typer.Option(None, "--fmax", help="Highest frequency of the fit band (Hz)."),
    max_order: int = typer.Option(50, "--max-order", help="Highest model order (LSCF; SSI-cov state size with --output-only)."),
    at: str = typer.Option(None, "--at", help="Pick poles nearest these frequencies: f1,f2,... (Hz)."),
    figure: Path = typer.Option(None, "--figure", help="Write the stabilisation diagram (.png, .svg, .pdf)."),
    mac_figure: Path = typer.Option(None, "--mac-figure", help="Write the modes' MAC matrix (AutoMAC; .png, .svg, .pdf)."),
    output_only: bool = typer.Option(False, "--output-only", help="From the responses alone (SSI-cov): operating data, no force."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Natural frequencies, damping ratios and mode shapes identified from measured FRFs (default
    band: where the hammer's force spectrum and the coherence are usable), of one experiment or of
    the FRF matrix of several, or with --output-only from the responses alone."""
    import json

    from odsuite.core.errors import ConfigError
    from odsuite.core.modal_project import experiment_modes, experiment_output_only_modes, experiments_modes

    try:
        freqs = [float(v) for v in at.split(",")] if at else None
    except ValueError:
        raise ConfigError(f"--at {at!r}: expected comma-separated frequencies in Hz") from None
    for option, value in (("--fmin", f_min), ("--fmax", f_max)):
        if value is not None and not (math.isfinite(value) and value >= 0):  # before the FRF is stored
            raise ConfigError(f"{option}: must be a finite frequency >= 0 Hz, got {value}")
    band = None if f_min is None and f_max is None else (f_min, f_max)
    for path, option in ((figure, "--figure"), (mac_figure, "--mac-figure")):
        if path is not None:
            _check_output(path, project, option)
    references = None
    name = ", ".join(experiments)
    if output_only:
        if freqs is not None:
            raise ConfigError("--at picks poles of the FRF fit; it does not combine with --output-only")
        if len(experiments) > 1:
            raise ConfigError("--output-only identifies modes of one record: give one --experiment")
        res, freq, spectrum = experiment_output_only_modes(project, experiments[0], f_band=band, max_order=max_order)
        background = "rms amplitude spectrum of the outputs (unit/√Hz)"
    elif len(experiments) > 1:
        res, freq, spectrum, references = experiments_modes(project, experiments, f_band=band, max_order=max_order,
                                                            frequencies=freqs)
        background = "rms |H| of the FRF matrix (FRF units)"
    else:
        res, frf = experiment_modes(project, experiments[0], f_band=band, max_order=max_order, frequencies=freqs)
        freq, spectrum, background = frf.frequency, frf.H, "rms |H| of the outputs (FRF units)"
    if figure is not None:
        from odsuite.core.modal_figures import stabilisation_figure

        stabilisation_figure(res, freq, spectrum, figure, title=f"stabilisation diagram of {name}",
                             background=background)
    if mac_figure is not None:
        from odsuite.core.modal import mac
        from odsuite.core.modal_figures import mac_figure as draw_mac

        labels = [f"{f:.1f} Hz" for f in res.frequency_hz]
        draw_mac(mac(res.shapes, res.shapes), mac_figure, labels_a=labels, labels_b=labels,
                 title=f"AutoMAC of the modes of {name}")
    for note in res.rejected:
        err_console.print(f"note: stable pole not taken as a mode: {note}", highlight=False, soft_wrap=True)
    if as_json:
        doc = res.to_dict()
        if references is not None:
            doc["references"] = references
        print(json.dumps(doc))
        return
    lo, hi = res.band_hz
    table = Table(title=f"modes of {shown(name)} ({lo:.1f}-{hi:.1f} Hz)")
    scatter = res.frequency_std_hz is not None  # output-only: standard errors from the record's segments
    for col in ("mode", "f (Hz)", "damping ratio", "stable orders") + (("± f (Hz)", "± damping") if scatter else ()):
        table.add_column(col)
    for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio), start=1):
        extra = (f"{res.frequency_std_hz[k - 1]:.2f}", f"{res.damping_std[k - 1]:.4f}") if scatter else ()
        table.add_row(str(k), f"{f:.2f}", f"{z:.5f}", str(res.stable_orders[k - 1]), *extra)
    console.print(table)
    for u in res.unresolved:
        err_console.print(f"note: the pole at {u.frequency_hz:.2f} Hz (damping ratio {u.damping_ratio:.3f}) is not "
                          f"reported as a mode: {u.reason}", highlight=False, soft_wrap=True)
    for path in (figure, mac_figure):
        if path is not None:
            console.print(f"wrote {path}", highlight=False, soft_wrap=True)


@app.command("render")
def render_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Argument(..., help="Experiment name."),
    output: Path = typer.Option(..., "-o", "--output", help="Movie (.mp4, .gif) or figure (.png, .svg, .pdf)."),
    model: bool = typer.Option(False, "--model", help="Overlay the current model revision's motion (computed like `odsuite compare`)."),
    magnify: str = typer.Option(None, "--magnify", help="H_t,H_r (default: largest corner motion = 15 % of the plate)."),
    view: str = typer.Option(None, "--view", help="Movie: AZ,EL degrees. Projection: EYE[,THETA,PHI,PSI] (eye x|y|z)."),
    figure: str = typer.Option(None, "--figure", help="A registered figure renderer (built in: overlay, projection, residuals; `odsuite plugins` lists all). Default: the movie renderer for the output's suffix."),
    workers: int = typer.Option(None, "--workers", help="Render processes for a movie (default: one per two cores)."),
    frame_step: int = typer.Option(None, "--frame-step", help="Samples per movie frame (default 1)."),
    slowdown: float = typer.Option(None, "--slowdown", help="Slow-motion factor: movie time / real time."),
    ods: float = typer.Option(None, "--ods", help="Animate the operating deflection shape at this frequency (Hz)."),
    reference: str = typer.Option(None, "--reference", help="With --ods: the reference sensor of an operating record's ODS (cross-spectra)."),
    start: float = typer.Option(None, "--start", help="Movie window start, s from the record's start (default: just before the hit)."),
    end: float = typer.Option(None, "--end", help="Movie window end, s (default: when the motion has decayed to a tenth)."),
    fps: float = typer.Option(None, "--fps", help="Movie frames per second (default 25)."),
    duration: float = typer.Option(None, "--duration", help="Movie length, s (default 10; or set --frame-step / --slowdown)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Wireframe movie of an experiment's plates, or a figure, by a registered renderer."""
    from odsuite.core.plugins import registries
    from odsuite.core.renderers import RenderRequest, choose_renderer, parse_magnify

    if workers is not None and workers < 1:
        raise ConfigError(f"--workers: at least 1 render process, got {workers}")
    if ods is not None and not (math.isfinite(ods) and ods >= 0.01):  # as --cutoff: no line below 0.01 Hz
        raise ConfigError(f"--ods: must be a finite frequency >= 0.01 Hz, got {ods}")
    _check_output(output, project, "-o")
    renderer = choose_renderer(registries().renderers, output, figure, "figure" if figure else "movie")
    options = {"model": model, "magnify": parse_magnify(magnify), "view": view, "workers": workers,
               "frame_step": frame_step, "slowdown": slowdown, "ods_hz": ods, "reference": reference, "start": start,
               "end": end, "fps": fps, "duration": duration}
    res = renderer.render(RenderRequest(project, experiment, output, options,
                                        progress=err_console.is_terminal and not as_json))
    if as_json:
        _print_json(_rendered_doc(renderer, res))
        return
    for note in res.notes:
        err_console.print(f"note: {note}", highlight=False)
    console.print(f"wrote {res.path} ({res.summary})", highlight=False, soft_wrap=True)


@app.command("ods")
def ods_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Argument(..., help="Experiment name (an operating record, or any record)."),
    reference: str = typer.Option(..., "--reference", help="Reference sensor: phases are relative to it."),
    at: float = typer.Option(..., "--at", help="Frequency of the shape, Hz (the nearest spectral line is used)."),
    movie: Path = typer.Option(None, "--movie", help="Also animate the shape on the rig (.mp4, .gif)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Operating deflection shape: every response's cross-spectrum to the reference sensor, scaled by
    the reference's autospectrum (rms amplitude and phase per sensor), and on a rig the bodies'
    generalized coordinates."""
    import numpy as np

    from odsuite.core.ods import operating_shape
    from odsuite.core.plugins import registries
    from odsuite.core.project import open_project
    from odsuite.core.renderers import RenderRequest, choose_renderer
    from odsuite.core.rigidbody import COORDINATE_UNITS, COORDINATES

    if not math.isfinite(at) or at <= 0:
        raise ConfigError(f"--at: must be a finite frequency > 0 Hz, got {at}")
    renderer = None
    if movie is not None:
        _check_output(movie, project, "--movie")
        renderer = choose_renderer(registries().renderers, movie, None, "movie")
    with open_project(project) as p:
        if experiment not in p.experiment_names():
            raise ConfigError(f"{project}: no experiment {experiment!r} "
                              f"(experiments: {', '.join(p.experiment_names()) or 'none'})")
        res = operating_shape(p, experiment, reference, at)
    rendered = None
    if renderer is not None:
        rendered = renderer.render(RenderRequest(project, experiment, movie, {"ods_hz": at, "reference": reference},
                                                 progress=err_console.is_terminal and not as_json))
    if as_json:
        doc = res.to_dict()
        doc["notes"] = list(res.notes)
        if rendered is not None:
            doc["movie"] = _rendered_doc(renderer, rendered)
        _print_json(doc)
        return
    for note in res.notes:
        err_console.print(f"note: {note}", highlight=False, soft_wrap=True)
    console.print(f"{shown(experiment)}: operating deflection shape at {res.frequency_hz:.3f} Hz (line nearest "
                  f"{res.requested_hz:g} Hz; {res.resolution_hz:.3g} Hz lines, {res.n_segments} segments), "
                  f"phases relative to {shown(reference)}", highlight=False, soft_wrap=True)
    table = Table(box=None)
    for col in ("sensor", "amplitude (rms)", "phase (°)", "coherence"):
        table.add_column(col)
    for name, v in res.shape.items():
        table.add_row(shown(name), f"{abs(v):.4g} {res.units[name]}", f"{np.degrees(np.angle(v)):+.1f}",
                      f"{res.coherence[name]:.3f}")
    console.print(table)
    for body, d in res.coordinates.items():
        parts = [f"{c} {abs(v):.3g} {u} ∠{np.degrees(np.angle(v)):+.0f}°"
                 for c, v, u in zip(COORDINATES, d, COORDINATE_UNITS)]
        console.print(f"{shown(body)} at G (rms displacement): " + ", ".join(parts), highlight=False, soft_wrap=True)
    if rendered is not None:
        console.print(f"wrote {rendered.path} ({rendered.summary})", highlight=False, soft_wrap=True)


def _rendered_doc(renderer, res) -> dict:
    """What a renderer wrote, for --json: the files (a movie may fall back to another format)."""
    return {"renderer": renderer.name, "outputs": [{"path": str(res.path), "bytes": res.path.stat().st_size}],
            "summary": res.summary, "notes": list(res.notes)}


@app.command("verify")
def verify_cmd(project: Path = typer.Argument(..., help="Project file."),
               as_json: bool = typer.Option(False, "--json", help="Print one JSON document.")) -> None:
    """Read every checksummed dataset; a corrupted one is named (exit code 1)."""
    from odsuite.core.project import open_project

    with open_project(project) as p:
        checked = p.verify()
    if as_json:
        _print_json({"project": str(project), "intact": True, "datasets": sum(checked.values()),
                     "experiments": dict(checked)})
        return
    console.print(f"{project}: {sum(checked.values())} checksummed datasets in {len(checked)} experiments "
                  "read back intact", highlight=False, soft_wrap=True)



#: Output files of the running command, checked before writing, and whether each existed then:
#: a full disk names the last one and removes the new ones (a writer that ran into it half-way).
_OUTPUTS: dict[Path, bool] = {}


def _check_output(output: Path, project: Path, option: str) -> None:
    from odsuite.core.storage import check_output

    output = check_output(output, project, option)
    _OUTPUTS[output] = output.exists() or output.is_symlink()


def _print_json(doc) -> None:
    """Exactly one JSON document on stdout (NaN/inf become null, which JSON lacks)."""
    import json
    import math

    def clean(x):
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {str(k): clean(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        return x

    print(json.dumps(clean(doc)))


def _loop_progress():
    from rich.progress import BarColumn, Progress, TextColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), console=err_console, transient=True,
                    disable=not err_console.is_terminal)


@app.command("compare")
def compare_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Compare the current model revision with every experiment (like with like)."""
    from odsuite.core.comparison import compare
    from odsuite.core.project import open_project

    with open_project(project) as p:
        result = compare(p).as_dict()
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
    for n in result["channels"]:
        table.add_row(shown(n), *(f"{result['experiments'][e]['channels'].get(n, float('nan')):.3f}"
                                  for e in experiments), f"{result['channels'][n]:.3f}")
    table.add_row("all", *(f"{result['experiments'][e]['error']:.3f}" for e in experiments), f"{result['error']:.3f}",
                  style="bold")
    console.print(table)
    worst = Table(title="where the model fails most")
    for col in ("kind", "name", "error"):
        worst.add_column(col)
    for w in result["worst"]:
        worst.add_row(w["kind"], w["name"], f"{w['error']:.3f}")
    console.print(worst)
    for peak in result["residual_peaks"]:
        where = "no model mode there" if peak["lacking"] else f"near the model's mode at {peak['model_mode_hz']:.0f} Hz"
        console.print(f"residual peak at {peak['frequency_hz']:.0f} Hz ({peak.get('to_floor', float('nan')):.1f}x the "
                      f"noise floor there) in {', '.join(peak['channels'])}: {where}", highlight=False)
    if result.get("modal"):
        console.print(_modal_table(result["modal"]))
    for note in (result.get("modal_notes") or []) + (result.get("notes") or []):
        console.print(note, highlight=False, soft_wrap=True)


def _modal_table(rows) -> Table:
    """compare's measured-against-model modes: frequencies (Hz), damping ratios (%), MAC."""
    table = Table(title="measured against model modes (-: no model mode within 10 %)")
    table.add_column("record", no_wrap=True)
    for col in ("meas. Hz", "model Hz", "Δf", "meas. ζ %", "model ζ %", "Δζ", "MAC"):
        table.add_column(col, no_wrap=True)
    for r in rows:
        paired = r["model_hz"] is not None
        table.add_row(r["experiment"], f"{r['measured_hz']:.2f}", f"{r['model_hz']:.2f}" if paired else "-",
                      f"{100 * (r['model_hz'] / r['measured_hz'] - 1):+.2f}%" if paired else "-",
                      f"{100 * r['measured_zeta']:.3f}", f"{100 * r['model_zeta']:.3f}" if paired else "-",
                      f"{100 * (r['model_zeta'] / r['measured_zeta'] - 1):+.0f}%" if paired and r["measured_zeta"] else "-",
                      "-" if r["mac"] is None else f"{r['mac']:.3f}")
    return table


@app.command("diagnose")
def diagnose_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
    effect: list[str] = typer.Option(None, "--effect", help="Try only these effects (repeatable)."),
    workers: int = typer.Option(None, "--workers", min=1, help="Processes that screen and fit candidates (default: "
                                "one per core, at most 2 for a few dozen candidates; the result does not depend on it)."),
) -> None:
    """Rank every registered physical effect by the error it removes (validated), best first."""
    from odsuite.core.diagnosis import diagnose
    from odsuite.core.project import open_project

    with open_project(project) as p, _loop_progress() as bar:
        task = bar.add_task("diagnosing", total=None)
        result = diagnose(p, effects=effect or None, workers=workers,
                          progress=lambda what, i, n: bar.update(task, description=what, completed=i, total=n))
    doc = result.as_dict()
    if as_json:
        _print_json(doc)
        return
    console.print(f"revision {doc['revision']}: error {doc['baseline_error']:.4f} "
                  f"(noise floor {doc['noise_floor']:.4f}, {doc['residual_to_floor']:.2f}x)", highlight=False)
    console.print(f"verdict: {doc['verdict']}", highlight=False)
    console.print(shown(doc["message"]), highlight=False, soft_wrap=True)
    sig = doc["signature"]
    where = [("channels", ", ".join(f"{c['channel']} ({c['residual_to_floor']:.1f}x)" for c in sig["channels"][:6])),
             ("experiments", ", ".join(f"{x['experiment']} ({x['residual_to_floor']:.1f}x)" for x in sig["experiments"][:6])),
             ("bands", ", ".join(f"{b['band']} ({b['residual_to_floor']:.1f}x)" for b in sig["bands"][:6])),
             ("peaks", ", ".join(f"{p:.0f} Hz" for p in sig["peaks_hz"]))]
    for label, text in where:
        if text:
            console.print(f"left above the floor, {label}: {shown(text)}", highlight=False, soft_wrap=True)
    if sig["amplitude_dependent"]:
        console.print("amplitude dependent: the fitted parameters follow the force level", highlight=False)
    table = Table(title="candidate effects, best first")
    for col in ("effect", "significant", "consistent", "plausible", "error after", "validated", "confounded with",
                "evidence"):
        table.add_column(col)

    def yes(v: bool) -> str:
        return "yes" if v else "no"

    for c in doc["candidates"]:
        table.add_row(c["effect"], yes(c["significant"]), yes(c["consistent"]) if c["fitted"] else "-",
                      yes(c["plausible"]) if c["fitted"] else "-", f"{c['error_after']:.4f}",
                      "-" if c["validated_error"] != c["validated_error"] else f"{c['validated_error']:.4f}",
                      ", ".join(c["confounded_with"]) or "-", c["evidence"])
    console.print(table)
    if doc["not_applicable"]:
        console.print(f"not applicable to this model: {', '.join(doc['not_applicable'])}", highlight=False,
                      soft_wrap=True)


@app.command("add-effect")
def add_effect_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    effect: str = typer.Argument(..., help="Registered effect name (see `odsuite diagnose`)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Fit an effect together with the current ones and store a new model revision."""
    from odsuite.core.add_effect import add_effect
    from odsuite.core.project import open_project

    with open_project(project, "a") as p, _loop_progress() as bar:
        task = bar.add_task(f"adding {effect}", total=None)
        result = add_effect(p, effect, progress=lambda what, i, n: bar.update(task, description=what,
                                                                                completed=i, total=n))
    if as_json:
        _print_json(result)
        return
    console.print(f"revision {result['revision']}: + {effect}; error {result['previous_error']:.4f} -> "
                  f"{result['error']:.4f} (noise floor {result['noise_floor_error']:.4f})", highlight=False)
    for line in result["warnings"]:
        err_console.print(f"warning: {shown(line)}", highlight=False, soft_wrap=True)


@app.command("history")
def history_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
    figure: Path = typer.Option(None, "--figure", help="Also draw the error per revision (PNG or SVG)."),
) -> None:
    """Model revisions with their effects and errors."""
    from odsuite.core.history import history
    from odsuite.core.project import open_project

    if figure is not None:
        _check_output(figure, project, "--figure")
        if figure.suffix.lower() not in (".png", ".svg", ".pdf"):
            raise ConfigError(f"--figure {figure}: suffix {figure.suffix!r} is not .png, .svg or .pdf")
    with open_project(project) as p:
        doc = history(p)
    if figure is not None:
        from odsuite.core.history import history_figure

        history_figure(doc, figure)
    if as_json:
        _print_json(doc)
        return
    table = Table(title=f"model revisions (current: {doc['current']})")
    for col in ("revision", "parent", "effects", "error"):
        table.add_column(col)
    for r in doc["revisions"]:
        table.add_row(str(r["revision"]), "-" if r["parent"] is None else str(r["parent"]),
                      ", ".join(r["effects"]) or "-", "-" if r["error"] is None else f"{r['error']:.4f}")
    console.print(table)


@app.command("revert")
def revert_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    revision: int = typer.Argument(..., help="Revision to make current again."),
) -> None:
    """Make an earlier model revision current (nothing is deleted)."""
    from odsuite.core.project import open_project

    with open_project(project, "a") as p:
        p.set_current_revision(revision)
    console.print(f"current model revision: {revision}")


@app.command("report")
def report_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    output: Path = typer.Option(..., "-o", "--output", help="The HTML page to write (self-contained)."),
    diagnosis: Path = typer.Option(None, "--diagnosis", help="Show this `odsuite diagnose --json` output "
                                   "instead of diagnosing now."),
    no_diagnose: bool = typer.Option(False, "--no-diagnose", help="Leave the candidate effects out (diagnosis takes ~20 s)."),
    no_movie: bool = typer.Option(False, "--no-movie", help="Leave the movie out."),
    movie_experiment: str = typer.Option(None, "--movie-experiment", help="Experiment of the movie "
                                         "(default: the one the model fits worst)."),
    frf_channel: list[str] = typer.Option(None, "--frf-channel", help="Channel whose FRF the page draws for "
                                          "each hammer record; repeatable (default: the driving point, the "
                                          "accelerometer nearest the force point)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """One self-contained HTML page: experiments, model against measurement, failures, candidate
    effects, error across revisions, a movie and a 3-D view (the registered page renderer 'report')."""
    from odsuite.core.plugins import registries
    from odsuite.core.renderers import RenderRequest, choose_renderer

    _check_output(output, project, "-o")
    renderer = choose_renderer(registries().renderers, output, "report")
    with _loop_progress() as bar:
        task = bar.add_task("report", total=None)
        options = {"diagnosis": diagnosis, "run_diagnosis": not no_diagnose, "movie": not no_movie,
                   "movie_experiment": movie_experiment, "frf_channels": frf_channel or None,
                   "on_stage": lambda what: bar.update(task, description=what)}
        res = renderer.render(RenderRequest(project, None, output, options))
    if as_json:
        _print_json(_rendered_doc(renderer, res))
        return
    for note in res.notes:
        err_console.print(f"note: {note}", highlight=False)
    console.print(f"wrote {res.path} ({res.summary})", highlight=False, soft_wrap=True)


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
    from odsuite.core.batch import describe, run_batch

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
    if as_json:
        _print_json(result.as_dict())
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
    if not result.ok:
        raise typer.Exit(1)


@app.command("catalog")
def catalog_cmd(
    args: list[str] = typer.Argument(..., help="DIR to index or refresh, or: query DIR [NAME|SELECT ...] "
                                     "(NAME: projects, unexplained, errors, experiments, sensors, gains)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
    rig: str = typer.Option(None, "--rig", help="query: only projects on this rig."),
    errors: bool = typer.Option(False, "--errors", help="Compute errors that no revision stored (slower, once per change)."),
) -> None:
    """Index every project under a folder into an SQLite catalogue beside them, or query it."""
    from odsuite.core.catalog import build_catalog, query

    if args[0] == "query":
        if len(args) < 2:
            raise typer.BadParameter("catalog query DIR [NAME|SELECT ...]")
        rows = query(args[1], " ".join(args[2:]) or "projects", rig=rig)
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
            table.add_row(*("-" if v is None else f"{v:.4g}" if isinstance(v, float) else str(v) for v in r.values()))
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
        return
    console.print(f"{res.path}: {len(res.indexed)} projects read, {len(res.restamped) + len(res.unchanged)} "
                  f"unchanged, {len(res.removed)} removed, {len(res.skipped)} files that are no projects "
                  f"({res.seconds:.2f} s); page {res.page}", highlight=False, soft_wrap=True)


def _register_plugin_commands() -> None:
    from odsuite.core.plugins import default_manager

    default_manager().hook.odsuite_register_commands(app=app)


def _quiet_flags(command) -> None:
    """On/off flags take no value, so their help shows no type: an empty metavar drops typer's
    ``<bool>`` (the help option included, which click makes once per command and caches)."""
    import click

    command.get_help_option(click.Context(command))
    for param in [*command.params, command._help_option]:
        if getattr(param, "is_flag", False):
            param.metavar = ""
    for sub in getattr(command, "commands", {}).values():
        _quiet_flags(sub)


def _on_interrupt(signum, frame) -> None:
    # one interrupt ends the command; further ones wait for its cleanup (temporary copies, workers)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _INTERRUPTS.append(signum)
    raise _Interrupted()


def _unraisable(hook_args) -> None:
    # an interrupt raised where Python cannot raise (a finaliser) is still reported by main
    if not isinstance(hook_args.exc_value, _Interrupted):
        sys.__unraisablehook__(hook_args)


def main(argv: list[str] | None = None) -> int:
    _ledger.reset()
    _OUTPUTS.clear()
    if not _AS_PROGRAM:  # called again in the same process (tests, scripts): a fresh start
        _INTERRUPTS.clear()
    try:
        previous = signal.signal(signal.SIGINT, _on_interrupt)
    except ValueError:  # not the main thread: interrupts stay Python's
        previous = None
    hook, sys.unraisablehook = sys.unraisablehook, _unraisable
    try:
        return _run(argv)
    finally:
        sys.unraisablehook = hook
        if previous is not None:
            # the program's work is done: a late Ctrl-C must not kill the exiting interpreter
            signal.signal(signal.SIGINT, signal.SIG_IGN if _AS_PROGRAM else previous)


def _run(argv: list[str] | None) -> int:
    try:
        if _INTERRUPTS:  # Ctrl-C while the program loaded
            raise _Interrupted()
        _register_plugin_commands()
        command = typer.main.get_command(app)
        _quiet_flags(command)
        code = command.main(args=argv, standalone_mode=False, prog_name="odsuite")
    except (_Interrupted, KeyboardInterrupt):
        err_console.print(_ledger.line(), highlight=False, soft_wrap=True)
        return 130
    except Exception:
        if not _INTERRUPTS:
            return _failed(sys.exc_info()[1])
        # the interrupt came first and the error is its doing: a library that turned it into
        # its own error (VTK's importer reports an interrupted import as an ImportError)
        err_console.print(_ledger.line(), highlight=False, soft_wrap=True)
        return 130
    if _INTERRUPTS:  # the interrupt was swallowed on the way (see _unraisable): report it
        err_console.print(_ledger.line(), highlight=False, soft_wrap=True)
        return 130
    # standalone_mode=False returns a command's typer.Exit code instead of raising it
    return code if isinstance(code, int) else 0


def _failed(exc: Exception) -> int:
    """The exit code of a command that raised ``exc`` (printing its one line), or ``exc`` again
    when it is a bug."""
    try:
        raise exc
    except OdsuiteError as exc:
        err_console.print(f"error: {_ledger.after_error(str(exc))}", style="bold red", highlight=False,
                          soft_wrap=True)
        return 1
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        err_console.print("aborted")
        return 1
    except typer.TyperException as exc:
        # usage errors (unknown option, missing argument) carry their own exit code
        exc.show()
        return exc.exit_code
    except Exception as exc:
        if not diskspace.is_disk_full(exc):  # anything else is a bug and keeps its traceback
            raise
        # an output file (movie, report, figure, text) ran into a full disk
        where = Path(getattr(exc, "filename", None) or ([*_OUTPUTS] or [Path.cwd() / "-"])[-1])
        line = diskspace.full_message(where, where, diskspace.written_so_far(where), outcome="nothing written")
        for output, existed in _OUTPUTS.items():
            if not existed:
                output.unlink(missing_ok=True)
        err_console.print(f"error: {line}", style="bold red", highlight=False, soft_wrap=True)
        return 1


if __name__ == "__main__":
    sys.exit(main())
