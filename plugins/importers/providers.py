"""The importers this plugin registers, behind the importer contract (odsuite.contracts.importers)."""

from __future__ import annotations

import warnings
from pathlib import Path

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

    def export_file(self, project, out, experiment, *, at: str = "center") -> None:
        """The experiment's generalized coordinates as a thesis .COD file (6 columns per body) at
        the centre of mass ("center") or the corner C ("corner")."""
        from odsuite_plugins.importers.importing import export_legacy

        export_legacy(project, experiment, out, at)


class LvmImporter:
    name = "lvm"
    description = ("LabVIEW Measurement (.lvm) text file, decimal point or comma; on a rig its columns go to the "
                   "rig's sensors by name, else in order")
    suffixes = (".lvm",)
    options = (FORCE_CHANNEL, *ON_RIG)

    def import_file(self, project, file, name, *, force_channel=None, force_point=None, force_dir=None,
                    force_body=None) -> Imported:
        from odsuite_plugins.importers.columns import import_lvm

        notes = import_lvm(project, file, name, force_channel, **_hammer(force_point, force_dir, force_body))
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


def builtin_importers() -> list:
    return [LegacyImporter(), LvmImporter(), UffImporter()]
