"""Commands about the project and its plugins: plugins, new, info, model, verify."""

from __future__ import annotations

from pathlib import Path

import typer

from odsuite.domain.display import fixed
from odsuite.cli.app import _print_json, app, console, shown, wrapped


@app.command("plugins")
def plugins_cmd(as_json: bool = typer.Option(False, "--json", help="Print one JSON document.")) -> None:
    """List registered plugins, their versions and what each registers."""
    from rich.table import Table
    from rich.text import Text

    from dataclasses import fields

    from odsuite.contracts.plugins import Registries, default_manager, registries

    pm = default_manager()
    regs = registries()
    if as_json:
        doc = {}
        for name, _plugin in sorted(pm.list_name_plugin()):
            source = pm.source(name)
            registers = {f.name: getattr(regs, f.name).by_plugin(name) for f in fields(Registries)}
            backends = {b: [{"flag": o.cli_flag, "type": o.type.__name__} for o in regs.daq_backends.attribute(b, "options")]
                        for b in regs.daq_backends.by_plugin(name)}
            doc[name] = {"distribution": source.distribution, "version": source.version,
                         "registers": {k: list(v) for k, v in registers.items() if v}, "daq_backend_options": backends}
        _print_json({"plugins": doc, "failed": dict(pm.failures)})
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
            options = regs.daq_backends.attribute(backend, "options")
            provided.append(f"  acquire --daq {backend} options:" + ("" if options else " none"))
            for o in options:  # each with its help: the unit and default live there
                default = "" if o.default is None or o.type is bool or "default" in o.help else f" (default {o.default:g})" \
                    if isinstance(o.default, float) else f" (default {o.default})"
                provided.append(f"    {o.cli_flag}" + ("" if o.type is bool else f" {o.type.__name__.upper()}")
                                + f": {o.help}{default}")
        source = pm.source(name)
        # one line per kind: a Text keeps the line breaks that plain strings would show escaped
        table.add_row(name, source.distribution, source.version, Text("\n".join(shown(p) for p in provided) or "-"))
    for name, line in sorted(pm.failures.items()):
        source = pm.source(name)
        table.add_row(name, source.distribution, source.version, Text(shown(line), style="red"))
    console.print(table)


@app.command("new")
def new_cmd(
    project: Path = typer.Argument(..., help="Project file to create (.h5)."),
    rig: str = typer.Option("thesis-dynamometer", "--rig",
                            help="Registered rig name, a rig .toml file, or 'none' (no rig geometry)."),
) -> None:
    """Create a new project file on a rig."""
    from odsuite.cli.app import err_console
    from odsuite.contracts.plugins import registries
    from odsuite.processing.rig_summary import far_from_bodies, rig_layout, undamped
    from odsuite.store.project import create_project

    created = create_project(project, rig)
    name = created.rig.name if created.rig else "none"
    layout = rig_layout(created.rig, registries().coordinate_solvers) if created.rig else {"bodies": []}
    created.close()
    console.print(f"created {project} (rig: {name})", highlight=False, soft_wrap=True)
    for body in layout["bodies"]:  # said now, not first at `process` after the records are taken
        if body["solver_problem"]:
            err_console.print(f"warning: {body['solver_problem']}; `process` will store no generalized "
                              f"coordinates for body {body['name']!r}",
                              style="yellow", highlight=False, soft_wrap=True)
    for far in far_from_bodies(created.rig) if created.rig else []:
        err_console.print(f"warning: {far}", style="yellow", highlight=False, soft_wrap=True)
    if created.rig is not None and (line := undamped(created.rig)) is not None:
        err_console.print(f"note: {line}", highlight=False, soft_wrap=True)


@app.command("info")
def info_cmd(project: Path = typer.Argument(..., help="Project file."),
             as_json: bool = typer.Option(False, "--json", help="Print one JSON document.")) -> None:
    """Experiments, rig (bodies, springs, coordinate solvers) and model revisions of a project
    (errors as `odsuite history` gives them)."""
    from odsuite.analysis.history import history
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project
    from odsuite.processing.rig_summary import rig_layout

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
    from odsuite.cli.text_table import text_table

    # plain text, not rich: info is what a user runs most, and rich's import and layout would
    # cost a quarter of its start-up
    print("\n".join(wrapped(f"{info['path']}  format {info['format_version']}  rig: {info['rig'] or 'none'}")))
    if layout is not None:
        _print_rig_layout(layout)
    rows = []
    for name, e in info["experiments"].items():
        # one kind per column: a hammer record's force (N), else its largest acceleration, both in
        # SI (a column imported in g stores 2 for 19.6 m/s^2)
        forces = {c: v for c, (v, unit) in e["peak"].items() if unit == "N"}
        accelerations = {c: v for c, (v, unit) in e["peak"].items() if unit == "m/s^2"}
        peaks = forces or accelerations or {c: v for c, (v, _unit) in e["peak"].items()}
        peak_channel = max(peaks, key=peaks.get)
        clipped = ", ".join(f"{c} ({n})" for c, n in e["clipped_samples"].items())
        rows.append([name, str(len(e["channels"])), f"{e['sampling_rate']:g}", str(e["n_samples"]),
                     f"{e['duration']:.4g}", "{:.4g} {} ({})".format(*e["peak"][peak_channel], peak_channel),
                     clipped or "-", ", ".join(e["derived"]) or "-"])
    print(text_table("experiments", ["name", "channels", "fs (Hz)", "samples", "length (s)", "peak",
                                     "clipped samples", "derived"], rows))
    if info["imports"]:
        print(shown("imports (not records): " + ", ".join(f"{n} ({k})" for n, k in info["imports"].items())))
    if revisions:
        rows = []
        for r in revisions:
            effects = ", ".join(str(e.get("effect", e.get("name", e))) if isinstance(e, dict) else str(e)
                                for e in r["effects"])
            error = errors.get(r["revision"])
            rows.append([str(r["revision"]), r["model"] or "-", effects or "-",
                         "-" if error is None else f"{error:.4f}"])
        print(text_table(f"model revisions (current: {info['current_revision']})",
                         ["revision", "model", "effects", "error (NRMSE)"], rows))


def _print_rig_layout(layout: dict) -> None:
    import numpy as np

    from odsuite.cli.text_table import text_table

    rows = [[b["name"], f"{b['mass_kg']:.4g}" if b["moving"] else "fixed",
             str(len(b["sensors"])) if b["sensors"] else "-",
             b["solver"] or ("cannot solve: see `process`" if b["solver_problem"] else "-")] for b in layout["bodies"]]
    print(text_table(f"rig {layout['name']}: bodies", ["body", "mass (kg)", "sensors", "coordinate solver"], rows))
    if layout["springs"]:
        rows = []
        for s in layout["springs"]:
            k = np.asarray(s["stiffness_n_per_m"], float)
            c = np.asarray(s["damping_n_s_per_m"], float)
            k, c = (np.diag(k) if k.ndim == 2 else k), (np.diag(c) if c.ndim == 2 else c)  # a matrix: its diagonal
            rows.append([s["name"], f"{s['body']} - {s['other']}", ", ".join(f"{1e3 * v:.4g}" for v in s["position_m"]),
                         ", ".join(f"{v / 1e3:.4g}" for v in k), ", ".join(f"{v:.4g}" for v in c)])
        print(text_table("springs", ["spring", "between", "at (mm)", "k x, y, z (kN/m)", "c x, y, z (N s/m)"], rows))
        # on the relative rotation (a pad's shear resists a roll two springs on one line cannot)
        rows = [[s["name"], ", ".join(f"{v / 1e3:.4g}" for v in s["rot_stiffness_n_m_per_rad"]),
                 ", ".join(f"{v:.4g}" for v in s["rot_damping_n_m_s_per_rad"])]
                for s in layout["springs"] if any(s["rot_stiffness_n_m_per_rad"]) or any(s["rot_damping_n_m_s_per_rad"])]
        if rows:
            print(text_table("springs on the relative rotation", ["spring", "k θ, φ, ψ (kN m/rad)",
                                                                  "c θ, φ, ψ (N m s/rad)"], rows))


@app.command("model")
def model_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """The project's current model: revision, effects, parameters and modes (ascending)."""
    from odsuite.analysis.modelrev import model_report
    from odsuite.cli.text_table import text_table
    from odsuite.store.project import open_project

    with open_project(project) as p:
        report = model_report(p)
    if as_json:
        _print_json(report)  # NaN and inf as null, as every --json
        return
    print(shown(f"model {report['model']!r}, revision {report['revision']}, effects: "
                f"{', '.join(report['effects']) or 'none'}"))
    if report["parameters"]:
        rows = []
        for effect, values in report["parameters"].items():
            info = report["parameter_info"].get(effect.split("#")[0], {})  # "missing_mode#2": its second instance
            for name, value in values.items():
                if name == "per_experiment":
                    continue
                about = info.get(name, {})
                rows.append([effect, name, f"{value:.6g}", about.get("unit", "") or "-", about.get("description", "")])
        print(text_table("parameters", ["effect", "parameter", "value", "unit", "meaning"], rows, prose=("meaning",)))
    # a value the data do not determine alone is one of many that fit alike: said so, beside the
    # combinations of such values that they determine (rows of their own)
    quantities = [[effect, r["label"] + (" (alone: not determined)" if r.get("determined", True) is False else ""),
                   *_engineering(r["value"], r.get("uncertainty"), r.get("nominal"), r["unit"])]
                  for effect, rs in report["physical"].items() for r in rs]
    if quantities:
        print(text_table("physical quantities (fitted, its standard deviation, the rig's value)",
                         ["effect", "quantity", "fitted", "±", "rig", "unit"], quantities, prose=("quantity",)))
    print(text_table("modes", ["mode", "frequency (Hz)", "damping ratio"],
                     [[str(i), f"{m['frequency_hz']:.2f}", fixed(m["damping_ratio"], 4)]
                      for i, m in enumerate(report["modes"], 1)]))


def _engineering(value: float, sd: float | None, nominal: float | None, unit: str) -> list[str]:
    """Value, standard deviation and the rig's value as text in one unit (physical.engineering_unit)."""
    from odsuite.diagnosis.physical import engineering_unit
    from odsuite.domain.display import unit_text

    scale, shown_unit = engineering_unit(value, unit)
    return [f"{value / scale:.5g}", "-" if sd is None else f"{sd / scale:.2g}",
            "-" if nominal is None else f"{nominal / scale:.5g}", unit_text(shown_unit) if shown_unit not in ("", "1") else "-"]


@app.command("verify")
def verify_cmd(project: Path = typer.Argument(..., help="Project file."),
               as_json: bool = typer.Option(False, "--json", help="Print one JSON document.")) -> None:
    """Read every checksummed dataset; a corrupted one is named (exit code 1)."""
    from odsuite.store.project import open_project

    with open_project(project) as p:
        checked = p.verify()
    if as_json:
        _print_json({"project": str(project), "intact": True, "datasets": sum(checked.values()),
                     "experiments": dict(checked)})
        return
    console.print(f"{project}: {sum(checked.values())} checksummed datasets in {len(checked)} experiments "
                  "read back intact", highlight=False, soft_wrap=True)
