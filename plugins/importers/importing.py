"""Importing the thesis's legacy files into a project, and exporting generalized coordinates back.

The ``.DAT``/``.VIZ`` files of the thesis hold the volts the DAQ recorded: the DAC program saves
"acquired data" as a spreadsheet (App. D.1) and the signal processor reads that file together with
a Systeminfo to convert V_r to physical units (Eq. 4.3, §4.3.1, App. D.2). They are therefore stored
unchanged as the experiment's raw volts; sensitivities, gain, inversion and offset stay in the
stored Systeminfo, applied by processing exactly as for acquired data.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, DimensionError, OdsuiteWarning
from odsuite_plugins.importers.legacy import read_dat, write_cod
from odsuite.api import Excitation, open_project
from odsuite.api import parse_force_direction, parse_force_point
from odsuite.api import SensorType, read_ctr

#: ``--at`` of export-legacy: the stored dataset suffix and the point it describes.
COD_POINTS = {"center": "_at_g", "corner": "_at_c"}


def import_legacy(project_path: str | Path, dat: str | Path, ctr: str | Path, name: str,
                  force_point_mm: str | Sequence[float], force_dir: str | Sequence[float]) -> str:
    """Add the legacy record ``dat`` described by the Systeminfo ``ctr`` as experiment ``name``.

    ``force_point_mm`` is the hammer's point in mm from the platform's centre of mass (platform
    axes), ``force_dir`` its direction. The Systeminfo is validated against the data before anything
    is written; the experiment is added atomically. Channels with samples at the DAQ limits give
    an OdsuiteWarning (``odsuite info`` lists them too). Returns ``name``.
    """
    point = parse_force_point(force_point_mm)
    direction = parse_force_direction(force_dir)
    ctr, dat = Path(ctr), Path(dat)
    with open_project(project_path, "a") as project:
        if name in project.experiment_names():
            raise ConfigError(f"{project.path}: experiment {name!r} already exists; choose another name")
        si = read_ctr(ctr)
        si.validate(source=ctr)
        record = read_dat(dat, n_channels=si.n_channels, sampling_rate=si.sampling_rate)
        n_samples = record.data.shape[0]
        si.validate(n_samples=n_samples, source=ctr)
        rig = project.rig
        if rig is not None:
            for sensor in rig.sensors:
                if sensor.channel >= si.n_channels:
                    raise DimensionError(f"{dat}: rig {rig.name!r} sensor {sensor.name!r} is on channel "
                                         f"{sensor.channel}, but the record has {si.n_channels} channels")
            force_channel = rig.force_channel
        else:
            force_channel = None
        if force_channel is None:
            force_channel = next((k for k, c in enumerate(si.channels)
                                  if c.sensor_type is SensorType.LOADCELL), None)
        if force_channel is None:
            raise ConfigError(f"{ctr}: row 0 (sensor type): no load cell channel (code 1) for the hammer "
                              "force, and the project's rig names no force channel")
        project.add_experiment(
            name, record.data, sampling_rate=si.sampling_rate, systeminfo=si,
            excitation=Excitation(force_channel=force_channel, point=point, direction=direction),
            source=f"legacy import: {dat.name} with Systeminfo {ctr.name}",
        )
        clipped = project.info()["experiments"][name]["clipped_samples"]
    if clipped:
        listing = ", ".join(f"{ch} ({n} samples)" for ch, n in clipped.items())
        warnings.warn(OdsuiteWarning(f"{dat}: samples at the DAQ limits (clipped) on {listing}"),
                      stacklevel=2)
    return name


def export_legacy(project_path: str | Path, experiment: str, cod: str | Path,
                  at: str = "center", kind: str = "gencoords") -> Path:
    """Write the generalized coordinates stored by processing as a thesis ``.COD`` file: 6 columns
    ``x y z theta phi psi`` (m, rad) per body, platform first; ``at`` is ``"center"`` (the centre
    of mass G) or ``"corner"`` (corner C); ``kind`` "gencoords_corrected" writes the corrected ones
    (``odsuite process --corrected``)."""
    if at not in COD_POINTS:
        raise ConfigError(f"--at: expected one of {', '.join(COD_POINTS)}, got {at!r}")
    suffix = COD_POINTS[at]
    with open_project(project_path) as project:
        project.experiment(experiment)
        if kind not in project.derived_kinds(experiment):
            what = "corrected generalized coordinates" if kind != "gencoords" else "generalized coordinates"
            raise ConfigError(f"{project.path}: experiment {experiment!r}: no {what}: run `odsuite process PROJECT"
                              + (" --corrected`" if kind != "gencoords" else "`") + " first")
        arrays = project.read_derived(experiment, kind)
        rig = project.rig
    order = [b.name for b in rig.moving_bodies] if rig is not None else []
    names = sorted((k[:-len(suffix)] for k in arrays if k.endswith(suffix)),
                   key=lambda b: (b not in order, order.index(b) if b in order else 0, b))
    if not names:
        raise ConfigError(f"{project_path}: experiment {experiment!r}: the generalized coordinates hold no "
                          f"'<body>{suffix}' datasets (found: {', '.join(sorted(arrays))})")
    write_cod(cod, [arrays[n + suffix] for n in names])
    return Path(cod)
