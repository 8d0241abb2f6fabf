"""The importers this plugin registers, behind the importer contract (odsuite.contracts.importers)."""

from __future__ import annotations

import warnings
from pathlib import Path

from odsuite.api import ConfigError
from odsuite.contracts.importers import Imported, ImportOption

FORCE_CHANNEL = ImportOption("force_channel", "name of the force channel (default: the one record in newtons "
                                              "or named 'force')")


#: where the hammer hit a rig, for the importers that lay a file onto a rig's sensors
ON_RIG = (ImportOption("force_point", "on a rig: X,Y,Z in the rig frame, where the hammer hit, with units "
                                      "(200mm or 0.2m each); bare numbers are mm"),
          ImportOption("force_dir", "on a rig: +x,-x,+y,-y,+z,-z or a vector dx,dy,dz"),
          ImportOption("force_body", "on a rig: the body hit, when the force point lies on two"))


def _hammer(force_point, force_dir, force_body) -> dict:
    """The ON_RIG options as the core importers take them (metres, a unit vector)."""
    from odsuite.api import parse_force_direction, parse_force_point

    return {"force_point": None if force_point is None else parse_force_point(force_point),
            "force_dir": None if force_dir is None else parse_force_direction(force_dir),
            "force_body": force_body}


class LegacyImporter:
    name = "legacy"
    description = "thesis-era .DAT/.VIZ record (volts, samples x channels) with its .CTR Systeminfo"
    suffixes = (".dat", ".viz")
    options = (ImportOption("systeminfo", "the .CTR Systeminfo file", required=True),
               ImportOption("force_point", "X,Y,Z from the platform's centre of mass, platform axes, with units "
                                            "(200mm or 0.2m each); bare numbers are mm",
                            required=True),
               ImportOption("force_dir", "+x,-x,+y,-y,+z,-z or a vector dx,dy,dz", required=True))

    def import_file(self, project, file, name, *, systeminfo, force_point, force_dir) -> Imported:
        from odsuite_plugins.importers.importing import import_legacy

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            import_legacy(project, file, systeminfo, name, force_point, force_dir)
        return Imported(name, f"{Path(file).name} with Systeminfo {Path(systeminfo).name} as experiment {name!r}",
                        tuple(str(w.message) for w in caught))

    def export_file(self, project, out, experiment, *, at: str = "center", kind: str = "gencoords") -> None:
        """The experiment's generalized coordinates as a thesis .COD file (6 columns per body) at
        the centre of mass ("center") or the corner C ("corner")."""
        from odsuite_plugins.importers.importing import export_legacy

        export_legacy(project, experiment, out, at, kind)


class LvmImporter:
    name = "lvm"
    description = ("LabVIEW Measurement (.lvm) text file, decimal point or comma; on a rig its columns go to the "
                   "rig's sensors by name, else in order")
    suffixes = (".lvm",)
    options = (FORCE_CHANNEL, *ON_RIG,
               ImportOption("units", "replaces the file's unit labels (a column mislabelled): m/s^2, g, N or V, one "
                                     "for all or one per column, comma-separated"))

    def import_file(self, project, file, name, *, force_channel=None, force_point=None, force_dir=None,
                    force_body=None, units=None) -> Imported:
        from odsuite_plugins.importers.columns import import_lvm

        notes = import_lvm(project, file, name, force_channel, units=units,
                           **_hammer(force_point, force_dir, force_body))
        return Imported(name, f"LabVIEW file {Path(file).name} as experiment {name!r}", tuple(notes))


class UffImporter:
    name = "uff"
    description = ("universal file format: time records (58) as the record and its FRFs (on a rig: onto its sensors "
                   "by UFF node and direction, else name, else order); a file without them as an import of its "
                   "FRFs, modes (55) or nodes (15/2411 with 18, 82, 164)")
    suffixes = (".uff", ".unv")
    options = (FORCE_CHANNEL, *ON_RIG)

    def import_file(self, project, file, name, *, force_channel=None, force_point=None, force_dir=None,
                    force_body=None) -> Imported:
        from odsuite_plugins.importers.uff_project import import_uff

        summary, notes = import_uff(project, file, name, force_channel,
                                    **_hammer(force_point, force_dir, force_body))
        return Imported(name, f"UFF file {Path(file).name}: {summary}", notes)

    def export_file(self, project, out, experiment=None, *, binary: bool = True, node_dataset: int = 15) -> None:
        """Time records (58/58b), FRFs, the rig's nodes (15 or 2411) and trace lines."""
        from odsuite_plugins.importers.uff_project import export_uff

        export_uff(project, out, experiment, binary=binary, node_dataset=node_dataset)


#: what a file of numbers may not say itself (a sidecar FILE.toml says it too; docs/importing.md)
TABLE_OPTIONS = (ImportOption("rate", "sampling rate in Hz (else the file's or its sidecar's)"),
                 ImportOption("channels", "channel names, comma-separated (else the file's or its sidecar's)"),
                 ImportOption("units", "m/s^2, g, N or V: one for all or one per channel, comma-separated"))


class TableImporter:
    """CSV, NumPy .npy, MATLAB .mat or NI TDMS records (odsuite_plugins.importers.tables)."""

    def __init__(self, name: str, suffix: str, description: str, extra: tuple = ()) -> None:
        self.name, self.suffixes, self.description = name, (suffix,), description
        self.options = (*TABLE_OPTIONS, *extra, FORCE_CHANNEL, *ON_RIG)

    def import_file(self, project, file, name, *, rate=None, channels=None, units=None, variable=None, group=None,
                    force_channel=None, force_point=None, force_dir=None, force_body=None) -> Imported:
        from odsuite_plugins.importers.columns import import_columns
        from odsuite_plugins.importers.tables import _listed, read_columns

        c = read_columns(file, {"sampling_rate": rate, "channels": channels, "units": units, "variable": variable,
                                "group": group}, self.suffixes[0])
        notes = import_columns(project, file, name, c.names, c.units, c.data, c.fs, force_channel,
                               **_hammer(force_point, force_dir, force_body))
        return Imported(name, f"{self.name} file {Path(file).name}: {c.data.shape[1]} channels "
                              f"({_listed([f'{n} [{u}]' for n, u in zip(c.names, c.units)])}) x {c.data.shape[0]} "
                              f"samples at {c.fs:g} Hz as experiment {name!r}", tuple(notes))


class GeometryImporter:
    name = "geometry"
    description = ("a structure's geometry: nodes, lines, faces and sensors on nodes from a TOML or CSV table, or "
                   "nodes and trace lines from UFF 15/82 (with --sensors); stored as import NAME (docs/geometry.md)")
    suffixes = (".toml",)
    options = (ImportOption("sensors", "UFF geometry: a TOML or CSV table of sensors, fixed nodes and rigid groups"),)

    def import_file(self, project, file, name, *, sensors=None) -> Imported:
        from odsuite.api import DerivedArray, GEOMETRY_KIND, geometry_record, open_project
        from odsuite_plugins.importers.geometry_files import read_geometry

        geom = read_geometry(file, name, sensors)
        arrays, attrs = geometry_record(geom)
        with open_project(project, "a") as p:
            p.write_import(name, GEOMETRY_KIND, {k: DerivedArray(*v) for k, v in arrays.items()},
                           source=Path(file).name, attrs=attrs)
        return Imported(name, f"geometry of {geom.node_ids.size} nodes, {len(geom.lines)} lines, {len(geom.faces)} "
                              f"faces, {len(geom.sensors)} sensors as import {name!r}")

    def export_file(self, project, out, experiment=None, *, modes=(), geometry=None) -> None:
        """The project's geometry as UFF 15 (nodes) and 82 (its lines), with ``modes`` ((frequency Hz,
        damping ratio, node motions (nodes, 3) complex), ...) as UFF 55."""
        from odsuite.api import open_project, project_geometry
        from odsuite_plugins.importers.geometry_files import write_geometry_uff

        with open_project(project) as p:
            geom = project_geometry(p, geometry)
            if geom is None:
                raise ConfigError(f"{p.path}: no geometry to write (import one with --format geometry)")
        write_geometry_uff(out, geom, modes)


def builtin_importers() -> list:
    return [LegacyImporter(), LvmImporter(), UffImporter(),
            TableImporter("csv", ".csv", "CSV record: a header of channel names (each may end in its unit, "
                          "'acc1 [m/s^2]'; a first column 'time' gives the rate), one row per sample"),
            TableImporter("npy", ".npy", "NumPy .npy array, samples x channels, with a sidecar FILE.toml or options "
                          "for rate, channel names and units"),
            TableImporter("mat", ".mat", "MATLAB .mat (v4-v7.3): a samples x channels array, with fs, channels and "
                          "units variables, a sidecar or options",
                          (ImportOption("variable", "the .mat array to read (default: the only one); several vectors "
                                                    "of one length, comma-separated, one channel each"),)),
            TableImporter("tdms", ".tdms", "NI TDMS file (npTDMS): one group's channels with their unit_string and "
                          "wf_increment", (ImportOption("group", "the TDMS group to read (default: the only one)"),)),
            GeometryImporter()]
