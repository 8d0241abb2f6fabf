"""The lab's spreadsheet export: a CSV of SI values, one column per channel of the project's rig.

Header ``t_s,force_N,<sensor>_m/s^2,...``: time in s (uniform steps), the hammer force in N and one
acceleration column per rig sensor along the sensor's positive axis, any order. The values are
stored as the experiment's record with a conversion of 1 (1 V per N, 1 V per m/s^2, no inversion)
and the rig's processing settings otherwise, so `odsuite process` treats them as acquired volts.
"""

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from odsuite.api import open_project
from odsuite.contracts.daq import channel_name, rig_systeminfo
from odsuite.api import ConfigError, DimensionError
from odsuite.contracts.importers import Imported, ImportOption
from odsuite.api import parse_force_direction, parse_force_point
from odsuite.api import Excitation
from odsuite.api import Systeminfo

#: relative spread of the time steps accepted as one sampling rate (the text's rounding is ~1e-9)
STEP_TOLERANCE = 1e-3


def read_si_csv(path):
    """(sampling rate in Hz, {column name: values}, {column name: unit}) of a lab CSV file."""
    path = Path(path)
    try:
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot be read as CSV text: {exc}") from None
    if len(rows) < 3:
        raise DimensionError(f"{path}: expected a header and at least two rows, got {len(rows)} line(s)")
    header = [h.strip() for h in rows[0]]
    if header[0] != "t_s":
        raise ConfigError(f"{path}: row 1 column 1: expected 't_s' (time in s), got {header[0]!r}")
    units = {}
    for k, h in enumerate(header[1:], 2):
        name, _, unit = h.rpartition("_")
        if unit not in ("N", "m/s^2") or not name:
            raise ConfigError(f"{path}: row 1 column {k}: expected '<name>_N' or '<name>_m/s^2', got {h!r}")
        units[name] = unit
    values = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:], 2):
        if len(row) != len(header):
            raise DimensionError(f"{path}: row {i}: {len(row)} values for {len(header)} columns")
        for k, cell in enumerate(row):
            try:
                values[i - 2, k] = float(cell)
            except ValueError:
                raise ConfigError(f"{path}: row {i} column {k + 1} ({header[k]}): not a number: {cell!r}") from None
            if not np.isfinite(values[i - 2, k]):
                raise ConfigError(f"{path}: row {i} column {k + 1} ({header[k]}): {cell!r} is not finite")
    steps = np.diff(values[:, 0])
    span = values[-1, 0] - values[0, 0]
    if span <= 0 or np.max(np.abs(steps - span / len(steps))) > STEP_TOLERANCE * span / len(steps):
        raise ConfigError(f"{path}: column t_s: the time steps are not uniform "
                          f"({steps.min():.6g} s .. {steps.max():.6g} s)")
    fs = float(f"{len(steps) / span:.9g}")  # the text holds about nine digits
    return fs, {name: values[:, k] for k, name in enumerate(units, 1)}, units


class SiCsvImporter:
    name = "lab_si_csv"
    description = "the lab's CSV of SI values: t_s, force_N and one <sensor>_m/s^2 column per rig sensor"
    suffixes = (".csv",)
    options = (ImportOption("force_point", "X,Y,Z in mm from the platform's centre of mass, platform axes",
                            required=True),
               ImportOption("force_dir", "+x,-x,+y,-y,+z,-z or a vector dx,dy,dz", required=True))

    def import_file(self, project, file, name, *, force_point, force_dir):
        point, direction = parse_force_point(force_point), parse_force_direction(force_dir)
        fs, columns, units = read_si_csv(file)
        with open_project(project, "a") as p:
            rig = p.rig
            if rig is None or rig.force_channel is None:
                raise ConfigError(f"{project}: importer {self.name!r} needs a project on a rig with a force channel")
            expected = {"force": "N", **{s.name: "m/s^2" for s in rig.sensors}}
            missing = sorted(set(expected) - set(columns))
            unknown = sorted(set(columns) - set(expected))
            wrong = sorted(c for c in set(columns) & set(expected) if units[c] != expected[c])
            if missing or unknown or wrong:
                raise ConfigError(f"{file}: columns do not match rig {rig.name!r}: missing {missing or 'none'}, "
                                  f"unknown {unknown or 'none'}, wrong unit {wrong or 'none'}")
            n = len(columns["force"])
            raw = np.zeros((n, rig.channel_count))  # channels the rig does not use stay at 0
            raw[:, rig.force_channel] = columns["force"]
            for s in rig.sensors:
                raw[:, s.channel] = columns[s.name]
            # an SI file has no ADC range: limits beyond the values, so the clipping scan finds none
            limit = 2.0 * max(float(np.max(np.abs(raw))), 1.0)
            si = rig_systeminfo(rig, fs)
            si = Systeminfo([replace(c, sensitivity=1.0, daq_gain=1.0, invert=False, limit_high=limit,
                                     limit_low=-limit) for c in si.channels], si.rig)
            p.add_experiment(name, raw, sampling_rate=fs, systeminfo=si,
                             excitation=Excitation(rig.force_channel, point, direction), source=Path(file).name,
                             channel_names=[channel_name(rig, ch) for ch in range(rig.channel_count)])
        return Imported(name, f"{n} samples x {len(columns)} SI columns at {fs:g} Hz from {Path(file).name}")
