"""A file's named columns as an experiment: the unit labels files use, the force column, and
LabVIEW ``.lvm`` records laid onto a rig's channels or stored as they are.

Experiments imported from engineering-unit files store those values as the raw column with a
sensitivity that converts them to SI (1 V per unit, g -> m/s^2 through 1/9.81 V per m/s^2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import ChannelInfo, SensorType, Systeminfo
from odsuite.api import Excitation, open_project
from odsuite_plugins.importers.lvm import read_lvm
from odsuite_plugins.importers.rig_import import names_the_rig, onto_rig
from odsuite_plugins.importers.tables import UNITS, _list, _listed, check_names, check_values, unit_key


def check_units(names: list[str], units: list[str], where: str) -> None:
    """Refuse a unit label none of UNITS (an empty one is a column without a unit): 'mg', 'kN' or
    'mm/s^2' stored as they are would be read at the wrong scale."""
    for n, u in zip(names, units):
        if u.strip() and unit_key(u) not in UNITS:
            raise ConfigError(f"{where}: channel {n!r}: unit {u!r} is not one of m/s^2, g, N, V")


def force_index(names: list[str], units: list[str], force_channel: str | None, where: str,
                table: dict = UNITS) -> int | None:
    """The force channel's column: ``force_channel`` (a column's name), else the one column in
    newtons or named like a force; None when no column is one (an operating record: responses
    only). A column whose unit (read in ``table``) says it measures something else is never taken
    as the force."""
    if force_channel is not None:
        if force_channel not in names:
            raise ConfigError(f"{where}: no channel {force_channel!r}; channels are {_listed(names)}")
        k = names.index(force_channel)
        stype = table.get(unit_key(units[k]), (SensorType.NONE, 1.0))[0]
        if stype not in (SensorType.LOADCELL, SensorType.NONE, SensorType.VOLTAGE):
            raise ConfigError(f"{where}: --force-channel {force_channel!r} is in {units[k]!r}, a response, "
                              "not a force")
        return k
    cand = [i for i, (n, u) in enumerate(zip(names, units)) if unit_key(u) in ("n", "newtons") or "force" in n.lower()]
    if len(cand) > 1:
        raise ConfigError(f"{where}: cannot tell the force channel among {_listed([names[k] for k in cand])}; "
                          "give --force-channel")
    return cand[0] if cand else None


def operating_note(where: str, names: list[str], units: list[str]) -> str:
    """The warning for a record stored as an operating record, naming its columns with their units:
    a hammer column labelled in a response unit (lvm_read's impact test: F in g) shows there."""
    columns = _listed([f"{n} [{u}]" for n, u in zip(names, units)])
    return (f"{where}: no force channel among its columns ({columns}; none in N or named like a force): stored as "
            "an operating record, responses only (`odsuite ods`, `odsuite modes --output-only`; --force-channel "
            "names a force column)")


def import_lvm(project: str | Path, lvm_path: str | Path, name: str, force_channel: str | None = None, *,
               force_point: np.ndarray | None = None, force_dir: np.ndarray | None = None,
               force_body: str | None = None, units: str | list[str] | None = None) -> tuple[str, ...]:
    """Add a LabVIEW ``.lvm`` record to a project as experiment ``name``; returns notes for the user.

    On a project with a rig the columns are laid onto the rig's channels (by sensor name, else in
    order; :mod:`odsuite_plugins.importers.rig_import`) and the hammer's ``force_point`` (m, rig frame) and
    ``force_dir`` are required (``force_body`` when the point lies on two bodies); without a rig, or when the columns are not the rig's channels and
    no force point is given (a single-point test kept beside the rig's records, said in a note),
    the columns are stored as they are. ``units`` replaces the file's unit labels (one for all, or one
    per column), for a file whose labels are wrong (a load cell's column labelled g)."""
    d = read_lvm(lvm_path)
    d.check_complete()
    labels, notes = list(d.units), ()
    if units is not None:
        labels = _list(units, len(d.channel_names), str(lvm_path), "units")
        changed = [f"{c} {a or '(none)'} -> {b}" for c, a, b in zip(d.channel_names, d.units, labels) if a != b]
        notes = (f"{lvm_path}: --units replaces the file's labels: {_listed(changed)}",) if changed else ()
    return notes + import_columns(project, lvm_path, name, d.channel_names, labels, d.data, d.sampling_rate,
                                  force_channel, force_point=force_point, force_dir=force_dir, force_body=force_body)


def import_columns(project: str | Path, file: str | Path, name: str, names: list[str], units: list[str],
                   data: np.ndarray, fs: float, force_channel: str | None = None, *,
                   force_point: np.ndarray | None = None, force_dir: np.ndarray | None = None,
                   force_body: str | None = None) -> tuple[str, ...]:
    """Add a file's named columns (``data``: samples x columns in ``units``, at ``fs`` Hz) to a
    project as experiment ``name``, as :func:`import_lvm` says; returns notes for the user."""
    check_units(list(names), list(units), str(file))
    check_names(str(file), list(names))
    check_values(str(file), list(names), list(units), np.asarray(data, float))
    with open_project(project, "a") as p:
        on_rig = p.rig is not None and (force_point is not None or force_dir is not None
                                        or names_the_rig(p.rig, names))
        if on_rig:
            rec = onto_rig(p.rig, names, units, data, fs, str(file), force_point,
                           force_dir, force_channel, force_body)
            p.add_experiment(name, rec.raw, sampling_rate=fs, systeminfo=rec.systeminfo,
                             excitation=rec.excitation, source=str(Path(file).name),
                             channel_names=rec.channel_names)
            return rec.notes
        if force_point is not None or force_dir is not None or force_body is not None:
            raise ConfigError(f"{file}: --force-point/--force-dir/--force-body need a project with a rig geometry")
        notes: tuple[str, ...] = ()
        if p.rig is not None:  # e.g. a single-point beam test kept beside the rig's records
            notes = (f"{file}: its columns ({_listed(list(names))}) are not the channels of rig {p.rig.name!r}: "
                     "stored as they are, without the rig's geometry",)
        fidx = force_index(list(names), list(units), force_channel, str(file))
        if fidx is None:
            notes += (operating_note(str(file), list(names), list(units)),)
        # a file in engineering units holds no converter range: limits well above the peaks, so that
        # volt limits are never applied to g or N (clipping is then told by flat tops alone)
        limits = np.maximum(10.0, np.ceil(2 * np.abs(data).max(axis=0)))
        channels = []
        for k, (n, u) in enumerate(zip(names, units)):
            stype, sens = UNITS.get(unit_key(u), (SensorType.NONE, 1.0))
            if k == fidx:
                stype, sens = SensorType.LOADCELL, 1.0  # force values are newtons (volts taken as N)
            channels.append(ChannelInfo(sensor_type=stype, location=n, sensitivity=sens, sampling_rate=fs,
                                        limit_high=float(limits[k]), limit_low=-float(limits[k])))
        p.add_experiment(
            name, data, sampling_rate=fs, systeminfo=Systeminfo(channels),
            # such files hold no geometry: point at the origin, direction +z by convention
            excitation=None if fidx is None else Excitation(fidx, np.zeros(3), np.array([0.0, 0.0, 1.0])),
            source=str(Path(file).name), channel_names=list(names),
        )
    return notes
