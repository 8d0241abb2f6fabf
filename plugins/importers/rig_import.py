"""Records from other tools mapped onto a rig: each column to the rig's channel whose sensor it is.

Columns are matched by name (a column named like a rig sensor, or like its force sensor) or, when no
column name matches, by position (column k is channel k). Volts are converted with the rig's
sensitivities (the file's volts are at the sensor: DAQ gain 1); columns in physical units (m/s^2, g,
N) are kept as they are, with a sensitivity that converts them to SI. The rig's thesis-style chain
(offset, filters, integration) processes them like any record of the rig.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from odsuite.api import ConfigError, DimensionError
from odsuite.api import Excitation
from odsuite.api import Rig
from odsuite.api import SENSOR_UNITS, SensorType, Systeminfo
from odsuite_plugins.importers.tables import UNITS, unit_key

#: UNITS of a column in physical units -> (quantity, stored units per SI unit); the others are volts
PHYSICAL_UNITS = {u: (SENSOR_UNITS[kind][0], per_si) for u, (kind, per_si) in UNITS.items()
                  if kind is not SensorType.VOLTAGE}
VOLTS = tuple(u for u in UNITS if u not in PHYSICAL_UNITS)


@dataclass(frozen=True)
class RigRecord:
    """A record laid out on the rig's channels, ready to store as an experiment."""

    raw: np.ndarray  # samples x rig channels
    systeminfo: Systeminfo
    excitation: Excitation | None  # None: an operating record (no force column)
    channel_names: list[str]
    notes: tuple[str, ...] = ()


def name_key(name: str) -> str:
    """A name as tools spell it differently: case, spaces, '_', '-' and '.' do not count ("m1_x" is
    LabVIEW's "M1 X" or "m1x")."""
    return "".join(c for c in name.lower() if c.isalnum())


def names_the_rig(rig: Rig, names: Sequence[str]) -> bool:
    """Whether a record's columns are the rig's channels: one named like a rig sensor, or as many
    columns as the rig has channels."""
    by_name = {name_key(s.name) for s in rig.sensors}
    return any(name_key(n) in by_name for n in names) or len(names) == rig.channel_count


def columns_to_channels(rig: Rig, names: Sequence[str], where: str, force_column: str | None,
                        what: str = "column") -> tuple[dict[int, int], bool]:
    """Column index -> rig channel, by sensor name, else (no name matching) in order; and whether
    the match was by name. Two columns naming one sensor are refused."""
    by_name = {name_key(s.name): s.channel for s in rig.sensors}
    matched = {k: by_name[name_key(n)] for k, n in enumerate(names) if name_key(n) in by_name}
    first: dict[int, int] = {}
    for k, ch in matched.items():
        if ch in first:
            raise ConfigError(f"{where}: {what}s {names[first[ch]]!r} and {names[k]!r} both match sensor "
                              f"{rig.sensor_on_channel(ch).name!r} (channel {ch}) of rig {rig.name!r}")
        first[ch] = k
    if force_column is not None:  # the user names the hammer's column
        if force_column not in names:
            raise ConfigError(f"{where}: no channel {force_column!r}; channels are {', '.join(names)}")
        matched = {k: c for k, c in matched.items() if c != rig.force_channel}
        matched[list(names).index(force_column)] = rig.force_channel
        if len(matched) == 1 and len(names) == rig.channel_count:
            return {k: k for k in range(len(names))} | matched, False
    if not matched:
        if len(names) != rig.channel_count:
            raise DimensionError(f"{where}: no {what} is named like a sensor of rig {rig.name!r} "
                                 f"({', '.join(s.name for s in rig.sensors)}), and its {len(names)} {what}s "
                                 f"cannot be its {rig.channel_count} channels in order; rename the {what}s")
        return {k: k for k in range(len(names))}, False
    unmatched = [n for k, n in enumerate(names) if k not in matched]
    if unmatched:
        raise ConfigError(f"{where}: {what}(s) {', '.join(map(repr, unmatched))} match no sensor of rig "
                          f"{rig.name!r} (sensors: {', '.join(s.name for s in rig.sensors)})")
    return matched, True


def _sensitivities_for(rig: Rig, in_volts: dict[int, int], names: Sequence[str], where: str, what: str) -> Rig:
    """The rig, refusing a column in volts (``in_volts``: channel -> column) for a sensor without a
    sensitivity; a sensor whose column is in physical units, or that has none, needs no sensitivity
    (its stored sensitivity comes from the unit)."""
    for s in rig.sensors:
        if s.sensitivity is None and s.channel in in_volts and s.quantity != "voltage":
            raise ConfigError(f"{where}: {what} {names[in_volts[s.channel]]!r} is in volts, but rig {rig.name!r} "
                              f"sensor {s.name!r} (channel {s.channel}) has no 'sensitivity' to convert it; give "
                              "the sensitivity or a file in physical units")
    return replace(rig, sensors=tuple(s if s.sensitivity is not None or s.channel in in_volts
                                      else replace(s, sensitivity=1.0) for s in rig.sensors))


#: how the name of a column that is the hammer's force begins (name_key spelling: "Hammer 2", "force1")
FORCE_NAMES = ("force", "hammer", "impact", "loadcell")


def _force_column(rig: Rig, names: Sequence[str], units: Sequence[str]) -> str | None:
    """The column that is the force where its name does not match the rig's force sensor: the one
    column in N, else the one named like a force (docs/importing.md); None where none or several."""
    by_name = {name_key(s.name) for s in rig.sensors}
    free = [k for k, n in enumerate(names) if name_key(n) not in by_name]
    in_newtons = [k for k in free if k < len(units) and PHYSICAL_UNITS.get(unit_key(units[k]), ("",))[0] == "force"]
    named = [k for k in free if name_key(names[k]).startswith(FORCE_NAMES)]
    for found in (in_newtons, named):
        if len(found) == 1:
            return names[found[0]]
    return None


def onto_rig(rig: Rig, names: Sequence[str], units: Sequence[str], data: np.ndarray, fs: float, where: str,
             point: np.ndarray | None, direction: np.ndarray | None, force_column: str | None = None,
             force_body: str | None = None, mapping: dict[int, int] | None = None,
             what: str = "column") -> RigRecord:
    """Lay ``data`` (samples x columns, named ``names`` in ``units``) onto ``rig``'s channels; the
    hammer hit ``point`` (m, rig frame) along ``direction`` (on ``force_body`` when the point lies
    on two bodies); ``force_column`` names the column that is the rig's force channel when its name
    does not say so; ``mapping`` (column -> channel) when the caller matched the columns already
    (e.g. by UFF node). A record with no force column and
    no ``point``/``direction`` is an operating record (responses only, no excitation)."""
    if mapping is None:
        if force_column is None and rig.force_channel is not None:
            force_column = _force_column(rig, names, units)
        mapping = columns_to_channels(rig, names, where, force_column, what)[0]
    operating = (point is None and direction is None and force_column is None
                 and (rig.force_channel is None or rig.force_channel not in mapping.values()))
    if not operating:
        if rig.force_channel is None:
            raise ConfigError(f"{where}: rig {rig.name!r} has no force channel (a 'force' sensor or force_channel)")
        if point is None or direction is None:
            raise ConfigError(f"{where}: a record on rig {rig.name!r} needs the hammer's --force-point and --force-dir")
        rig.force_body(point, force_body)  # a known body, or a point that tells one
        if rig.force_channel not in mapping.values():
            raise ConfigError(f"{where}: no {what} is the force channel {rig.force_channel} of rig {rig.name!r}")
    if rig.systeminfo_file is None:  # else the rig's .CTR gives the sensitivities
        rig = _sensitivities_for(rig, {ch: k for k, ch in mapping.items()
                                       if (unit_key(units[k]) if k < len(units) else "") in VOLTS + ("",)},
                                 names, where, what)
    si = Systeminfo.for_rig(rig, fs)
    channels = list(si.channels)
    raw = np.zeros((data.shape[0], rig.channel_count))
    for k, ch in mapping.items():
        unit = unit_key(units[k]) if k < len(units) else ""
        info = replace(channels[ch], daq_gain=1.0)  # the file's values are at the sensor
        if unit in PHYSICAL_UNITS:
            quantity, per_si = PHYSICAL_UNITS[unit]
            sensor = rig.sensor_on_channel(ch)
            expected = sensor.quantity if sensor is not None else "force" if ch == rig.force_channel else None
            if expected != quantity:
                raise ConfigError(f"{where}: {what} {names[k]!r} is in {units[k]!r} ({quantity}), but rig "
                                  f"{rig.name!r} channel {ch} measures {expected or 'nothing'}")
            # the value is the sensor's own output: stored as it is, converted to SI by the sensitivity;
            # limits far above the peaks, so that volt limits never clip g or N
            peak = float(np.ceil(2 * np.abs(data[:, k]).max())) if data.shape[0] else 1.0
            # a value in physical units carries its sign already: a channel the rig's .CTR inverts
            # (the thesis rig's accelerometers) read back negated through export-uff and import
            info = replace(info, sensitivity=per_si, invert=False, limit_high=max(10.0, peak), limit_low=-max(10.0, peak))
        elif unit not in VOLTS and unit:
            raise ConfigError(f"{where}: {what} {names[k]!r}: unit {units[k]!r} is neither volts nor one of "
                              f"{', '.join(sorted(PHYSICAL_UNITS))}")
        channels[ch] = info
        raw[:, ch] = data[:, k]
    # channels the file does not hold are stored empty and left out of processing and comparison
    missing = [ch for ch in range(rig.channel_count) if ch not in mapping.values()]
    for ch in missing:
        channels[ch] = replace(channels[ch], sensor_type=SensorType.NONE)
    excitation = None if operating else Excitation(rig.force_channel, np.asarray(point, float),
                                                   np.asarray(direction, float), force_body)
    names_out = [next((names[k] for k, c in mapping.items() if c == ch), f"ai{ch}") for ch in range(rig.channel_count)]
    lost = [s.name for s in rig.accelerometers if s.channel in missing]
    notes = (f"{where}: rig sensor(s) {', '.join(lost)} have no {what}: not recorded",) if lost else ()
    if operating:
        notes += (f"{where}: no force {what}: stored as an operating record, responses only (`odsuite ods`, "
                  "`odsuite modes --output-only`)",)
    return RigRecord(raw, Systeminfo(channels=channels, rig=si.rig), excitation, names_out, notes)
