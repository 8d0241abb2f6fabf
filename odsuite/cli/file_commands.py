"""Commands that bring files in and write them out: import (every format), export-legacy, export-uff."""

from __future__ import annotations

from pathlib import Path

import typer

from odsuite.cli.app import _check_output, _ledger, app, console, echo_force_point, err_console


def _import(project: Path, file: Path, name: str, fmt: str | None, **options) -> None:
    from odsuite.contracts.importers import check_options, choose_importer
    from odsuite.contracts.plugins import registries

    importer = choose_importer(registries().importers, file, fmt)
    _ledger.plan(project, [f"experiment {name}"])
    _ledger.start(f"experiment {name}")
    res = importer.import_file(project, file, name, **check_options(importer, options))
    for note in res.notes:
        err_console.print(f"warning: {note}", style="yellow", highlight=False, soft_wrap=True)
    echo_force_point(project, name, options.get("force_point"))
    console.print(f"imported {file} ({importer.name}: {res.summary})", highlight=False, soft_wrap=True)


@app.command("import")
def import_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    file: Path = typer.Argument(..., help="Measurement file; its suffix chooses the importer unless --format."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    fmt: str = typer.Option(None, "--format", help="A registered importer (built in: legacy, lvm, uff, csv, npy, mat, tdms, geometry; "
                            "`odsuite plugins` lists all)."),
    systeminfo: Path = typer.Option(None, "--systeminfo", help="legacy: the .CTR Systeminfo file."),
    force_point: str = typer.Option(None, "--force-point",
                                    help="legacy, lvm, uff: X,Y,Z in the rig frame with units (200mm or 0.2m each); bare numbers are mm (the thesis rig: "
                                    "from the platform's centre of mass)."),
    force_dir: str = typer.Option(None, "--force-dir", help="legacy, lvm, uff: +x,-x,+y,-y,+z,-z or a vector dx,dy,dz."),
    force_channel: str = typer.Option(None, "--force-channel", help="lvm, uff: name of the force channel."),
    force_body: str = typer.Option(None, "--force-body", help="lvm, uff on a rig: the body hit, when the force point "
                                   "lies on two."),
    rate: float = typer.Option(None, "--rate", help="csv, npy, mat, tdms: sampling rate, Hz."),
    channels: str = typer.Option(None, "--channels", help="csv, npy, mat, tdms: channel names, comma-separated."),
    units: str = typer.Option(None, "--units", help="csv, npy, mat, tdms: m/s^2, g, N or V (one, or one per channel)."),
    variable: str = typer.Option(None, "--variable", help="mat: the array to read."),
    group: str = typer.Option(None, "--group", help="tdms: the group to read."),
    sensors: Path = typer.Option(None, "--sensors", help="geometry from UFF: a table of sensors on its nodes."),
) -> None:
    """Import a measurement file as a new experiment (or a geometry: --format geometry), by the
    importer for its format."""
    _import(project, file, name, fmt, systeminfo=systeminfo, force_point=force_point, force_dir=force_dir,
            force_channel=force_channel, force_body=force_body, rate=rate, channels=channels, units=units,
            variable=variable, group=group, sensors=sensors)


@app.command("import-legacy")
def import_legacy_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    datfile: Path = typer.Argument(..., help="Legacy .DAT/.VIZ data file (volts, samples x channels)."),
    systeminfo: Path = typer.Option(..., "--systeminfo", help="Legacy .CTR Systeminfo file."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_point: str = typer.Option(..., "--force-point",
                                    help="X,Y,Z in the rig frame with units (200mm or 0.2m each); bare numbers are mm (the thesis rig: from the "
                                    "platform's centre of mass)."),
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
    corrected: bool = typer.Option(False, "--corrected", help="The corrected coordinates (`process --corrected`)."),
) -> None:
    """Write an experiment's generalized coordinates as a thesis .COD file (6 columns per body)."""
    from odsuite.contracts.importers import exporter
    from odsuite.contracts.plugins import registries

    _check_output(cod, project, "--cod")
    exporter(registries().importers, "legacy").export_file(
        project, cod, experiment, at=at, **({"kind": "gencoords_corrected"} if corrected else {}))
    console.print(f"wrote {cod}", highlight=False, soft_wrap=True)


@app.command("import-lvm")
def import_lvm_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    lvmfile: Path = typer.Argument(..., help="LabVIEW .lvm text file."),
    name: str = typer.Option(..., "--name", help="Experiment name."),
    force_channel: str = typer.Option(None, "--force-channel", help="Name of the force column (on a rig: the one for its force channel)."),
    force_point: str = typer.Option(None, "--force-point", help="On a rig: X,Y,Z in the rig frame with units (200mm or 0.2m each); bare numbers are mm."),
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
    force_point: str = typer.Option(None, "--force-point", help="On a rig: X,Y,Z in the rig frame with units (200mm or 0.2m each); bare numbers are mm (default: "
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
    from odsuite.contracts.importers import exporter
    from odsuite.contracts.plugins import registries

    _check_output(output, project, "-o")
    exporter(registries().importers, "uff").export_file(project, output, experiment, binary=not ascii_,
                                                          node_dataset=nodes)
    console.print(f"wrote {output}", highlight=False, soft_wrap=True)
