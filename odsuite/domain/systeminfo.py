"""Systeminfo: the per-experiment description of every channel and of the rig (thesis Table E.2).

All values are SI: sensitivities in volts per SI unit (V/(m/s^2), V/N, V/m, V/V), lengths in metres,
frequencies in Hz. The ``.CTR`` codec below (the LabVIEW program's Systeminfo file) converts the
thesis's mV and mm at the file edge.
"""

from __future__ import annotations

import math
import numbers
import re
import warnings
from dataclasses import dataclass, field, replace
from decimal import Decimal
from enum import IntEnum
from pathlib import Path

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError, OdsuiteWarning
from odsuite.domain.filter_kinds import MAX_FILTER_ORDER, FilterFamily, FilterType
from odsuite.domain.rig import ADC_RANGE_MAX_V, ADC_RANGE_TEXT, MAX_CHANNELS, NINE_ROLES, Rig, adc_range_ok
from odsuite.domain.rig_processing import FILTER_DB_TEXT, check_ripple, filter_db_ok
from odsuite.domain.textfiles import read_text


class SensorType(IntEnum):
    """Table E.2 row 0 (code 6, an auxiliary channel in Table E.3, is erratum 9); 7 and 8 are
    odsuite's, for records imported in m/s and Pa (no thesis sensor measures them)."""

    NONE = 0
    LOADCELL = 1
    PROXIMITY = 2
    VOLTAGE = 3
    ACCELEROMETER = 4
    AUXILIARY = 6
    VELOCITY = 7
    PRESSURE = 8


class Integration(IntEnum):
    """Table E.2 row 4."""

    NONE = 0
    DOUBLE = 1
    SINGLE = 2


#: V per SI unit: a shock accelerometer has ~1e-6 V/(m/s^2), a seismic one ~1 V/(m/s^2); beyond
#: these bounds a volt of noise would read as 1e9 units (or a whole signal as nothing)
MIN_SENSITIVITY = 1e-9
MAX_SENSITIVITY = 1e3
#: per metre more: an eddy-current probe gives ~8e3 V/m (200 mV/mil), a capacitive one up to 1e7
MAX_DISPLACEMENT_SENSITIVITY = 1e7
#: Physical quantity and SI unit measured by each sensor type; its sensitivity is in V per this unit.
SENSOR_UNITS: dict[SensorType, tuple[str, str]] = {
    SensorType.NONE: ("voltage", "V"),
    SensorType.LOADCELL: ("force", "N"),
    SensorType.PROXIMITY: ("displacement", "m"),
    SensorType.VOLTAGE: ("voltage", "V"),
    SensorType.ACCELEROMETER: ("acceleration", "m/s^2"),
    SensorType.AUXILIARY: ("voltage", "V"),
    SensorType.VELOCITY: ("velocity", "m/s"),
    SensorType.PRESSURE: ("pressure", "Pa"),
}


@dataclass
class ChannelInfo:
    """One column of a Systeminfo (rows 0-20 of Table E.2, plus what the thesis lacked)."""

    sensor_type: SensorType = SensorType.NONE  # row 0
    location: str = ""  # row 1
    serial: str = ""  # row 2
    sensitivity: float = 1.0  # row 3, V per SI unit of the sensor type (mV/unit in .CTR)
    integration: Integration = Integration.NONE  # row 4
    filter_type: FilterType = FilterType.LOWPASS  # row 5
    filter_order: int = 0  # row 6
    sampling_rate: float = 0.0  # row 7, Hz
    cutoff_high: float | None = None  # row 8, Hz (upper edge: low-pass, band edges)
    cutoff_low: float | None = None  # row 9, Hz (lower edge: high-pass, band edges)
    ripple_db: float = 0.1  # row 10
    attenuation_db: float = 60.0  # row 11
    filters_on: int = 0  # row 12, bitmask: bit k = filter k+1 (legacy 16 = all three)
    micro_units: bool = False  # row 13
    invert: bool = False  # row 14
    offset_start: int = 0  # row 15, sample index
    offset_length: int = 0  # row 16, samples (0 = no offset removal)
    daq_gain: float = 1.0  # row 17
    filter_family: FilterFamily = FilterFamily.ELLIPTIC  # row 18
    limit_high: float = 10.0  # row 19, V
    limit_low: float = -10.0  # row 20, V
    # not in the thesis: its behaviour is the default
    zero_phase: bool = False  # filtfilt-style zero-phase filtering instead of causal
    integration_rule: str = "thesis"  # "thesis" (Eq. 4.5, leads by half a sample) or "trapezoid"

    @property
    def quantity(self) -> str:
        return SENSOR_UNITS[self.sensor_type][0]

    @property
    def unit(self) -> str:
        return SENSOR_UNITS[self.sensor_type][1]


@dataclass
class RigInfo:
    """Rig-level rows 21-33 of Table E.2 (stored in the first columns of a .CTR). SI units."""

    use_in_gcc: bool = False  # row 21 column 0
    use_in_ag: bool = False  # row 21 column 1
    plate_sizes: list[tuple[float, float, float]] = field(default_factory=list)  # rows 22-24, m
    plate_origins: list[tuple[float, float, float]] = field(default_factory=list)  # rows 25-27, m
    plot_from_corner: bool = False  # row 28: False = reference frame at plate origin O, True = corner C_R
    coordinate_columns: list[int] = field(default_factory=list)  # row 29: platform, base column index
    rx: float | None = None  # row 30, m
    ry: float | None = None  # row 31, m
    rz: float | None = None  # row 32, m
    # row 33: data column of xC, yC, zC, x1, z1, y2, z2, x3, y3 (Eq. 4.13 order)
    nine_channels: list[int] = field(default_factory=list)


#: row 29's .COD columns: 6 per body, at most a body per channel (1e30 overflowed the store's integers)
MAX_COORDINATE_COLUMN = 6 * MAX_CHANNELS - 1


def column_in_range(name: str, value: object, n_channels: int) -> bool:
    """Whether ``value`` may be an entry of RigInfo's column list ``name``: a whole number from 0,
    for ``nine_channels`` (raw channels) below ``n_channels``, else at most MAX_COORDINATE_COLUMN."""
    high = n_channels if name == "nine_channels" else MAX_COORDINATE_COLUMN + 1
    return isinstance(value, numbers.Integral) and not isinstance(value, bool) and 0 <= value < high


#: Table E.2 row labels, used to name the field in error messages.
ROW_LABELS: dict[int, str] = {
    0: "sensor type", 1: "sensor location", 2: "serial number", 3: "sensitivity",
    4: "integration", 5: "filter type", 6: "filter order", 7: "sampling frequency",
    8: "high cut-off frequency", 9: "low cut-off frequency", 10: "pass-band ripple",
    11: "stop-band attenuation", 12: "filter on/off", 13: "micro-units", 14: "invert signal",
    15: "offset start index", 16: "offset length", 17: "DAQ gain", 18: "filter family",
    19: "DAQ high limit", 20: "DAQ low limit", 21: "use Systeminfo in GCC/AG",
    22: "plate lengths", 23: "plate widths", 24: "plate heights", 25: "plate lengths from origin",
    26: "plate widths from origin", 27: "plate heights from origin", 28: "plot option",
    29: "generalized coordinate columns", 30: "rx", 31: "ry", 32: "rz",
    33: "nine-accelerometer channel assignment",
    34: "zero-phase filtering (odsuite)", 35: "integration rule (odsuite)",
}

#: ChannelInfo attribute of each per-channel row 0-20 (index = row number).
CHANNEL_FIELDS: tuple[str, ...] = (
    "sensor_type", "location", "serial", "sensitivity", "integration", "filter_type",
    "filter_order", "sampling_rate", "cutoff_high", "cutoff_low", "ripple_db", "attenuation_db",
    "filters_on", "micro_units", "invert", "offset_start", "offset_length", "daq_gain",
    "filter_family", "limit_high", "limit_low",
)

INTEGRATION_RULES = ("thesis", "trapezoid")

#: What a rig sensor measures and the Table E.2 sensor type a Systeminfo gives it; other quantities
#: (a lab's strain gauge) are recorded as auxiliary channels, not processed as one of these.
_QUANTITY_TO_SENSOR_TYPE = {
    "acceleration": SensorType.ACCELEROMETER, "force": SensorType.LOADCELL,
    "displacement": SensorType.PROXIMITY, "voltage": SensorType.VOLTAGE,
}


def where(source: str | Path, row: int, channel: int | None = None) -> str:
    """The location prefix of a message: file, row number and name, and channel (column)."""
    text = f"{source}: row {row} ({ROW_LABELS[row]})"
    return text if channel is None else f"{text}, channel {channel}"


def _integer(value: object, place: str) -> int:
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real) and float(value).is_integer():
        return int(value)
    raise ConfigError(f"{place}: expected an integer, got {value!r}")


def enum_code(enum_cls: type[IntEnum], value: object, place: str) -> IntEnum:
    """Convert a legacy numeric code to ``enum_cls``; unknown codes raise a ConfigError."""
    code = _integer(value, place)
    try:
        return enum_cls(code)
    except ValueError:
        known = ", ".join(f"{m.value} = {m.name.lower()}" for m in enum_cls)
        raise ConfigError(f"{place}: unknown code {value!r} (known: {known})") from None


def sensor_type_code(value: object, place: str) -> SensorType:
    """Row 0 code; 6 (Table E.3's auxiliary column, erratum 9) is accepted with a warning."""
    sensor_type = enum_code(SensorType, value, place)
    if sensor_type is SensorType.AUXILIARY:
        warnings.warn(OdsuiteWarning(
            f"{place}: sensor type 6 is not defined in Table E.2; read as an auxiliary voltage channel"),
            stacklevel=3)
    return sensor_type


def filters_on_code(value: object, place: str) -> int:
    """Row 12 as a bitmask (bit k = filter k+1); the legacy code 16 means all three (erratum 8)."""
    code = _integer(value, place)
    if code == 16:
        return 7
    if not 0 <= code <= 7:
        raise ConfigError(f"{place}: expected a bitmask 0..7 (or the legacy 16 = all on), got {value!r}")
    return code


def _finite(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


#: Cut-off rows each filter type reads: low-pass the high cut-off, high-pass the low one.
_CUTOFF_ROWS = {
    FilterType.LOWPASS: (8,), FilterType.HIGHPASS: (9,),
    FilterType.BANDPASS: (9, 8), FilterType.BANDSTOP: (9, 8),
}


def _validate_channel(ch: ChannelInfo, k: int, source: str | Path, n_samples: int | None,
                      fs0: float) -> None:
    def at(row: int) -> str:
        return where(source, row, k)

    sensor_type = enum_code(SensorType, ch.sensor_type, at(0))
    enum_code(Integration, ch.integration, at(4))
    filter_type = enum_code(FilterType, ch.filter_type, at(5))
    family = enum_code(FilterFamily, ch.filter_family, at(18))
    filters_on = _integer(ch.filters_on, at(12))
    if not 0 <= filters_on <= 7:
        raise ConfigError(f"{at(12)}: expected a bitmask 0..7, got {ch.filters_on!r}")
    fs = ch.sampling_rate
    if not _finite(fs) or fs <= 0:
        raise ConfigError(f"{at(7)}: sampling rate must be > 0 Hz, got {fs!r}")
    if fs != fs0:
        raise ConfigError(f"{at(7)}: sampling rate {fs!r} Hz differs from channel 0's {fs0!r} Hz")
    if sensor_type is not SensorType.NONE and (not _finite(ch.sensitivity) or ch.sensitivity <= 0):
        kind = sensor_type.name.lower()
        raise ConfigError(f"{at(3)}: sensitivity must be > 0 on {'an' if kind[0] in 'aeiou' else 'a'} {kind} channel, "
                          f"got {ch.sensitivity!r} V/{ch.unit}")
    top = MAX_DISPLACEMENT_SENSITIVITY if sensor_type is SensorType.PROXIMITY else MAX_SENSITIVITY
    if sensor_type is not SensorType.NONE and not MIN_SENSITIVITY <= abs(ch.sensitivity) <= top:
        raise ConfigError(f"{at(3)}: sensitivity {ch.sensitivity!r} V/{ch.unit} is outside what any sensor has "
                          f"({MIN_SENSITIVITY:g} to {top:g} V/{ch.unit})")
    if not _finite(ch.daq_gain) or ch.daq_gain <= 0:
        raise ConfigError(f"{at(17)}: DAQ gain must be > 0, got {ch.daq_gain!r}")
    for row in (19, 20):
        value = getattr(ch, CHANNEL_FIELDS[row])
        if not _finite(value):
            raise ConfigError(f"{at(row)}: expected a finite voltage, got {value!r}")
    if ch.limit_low >= ch.limit_high:
        raise ConfigError(f"{at(20)}: DAQ low limit {ch.limit_low!r} V must be below the high limit "
                          f"{ch.limit_high!r} V")
    if filters_on:
        order = _integer(ch.filter_order, at(6))
        if order < 1:
            raise ConfigError(f"{at(6)}: filter order must be >= 1 when a filter is on (row 12 = "
                              f"{filters_on}), got {ch.filter_order!r}")
        if order > MAX_FILTER_ORDER:
            raise ConfigError(f"{at(6)}: filter order {order} is above {MAX_FILTER_ORDER}, where IIR designs "
                              "lose their poles to rounding")
        nyquist = fs / 2
        rows = _CUTOFF_ROWS[filter_type]
        for row in rows:
            cutoff = getattr(ch, CHANNEL_FIELDS[row])
            if cutoff is None:
                raise ConfigError(f"{at(row)}: a {filter_type.name.lower()} filter needs this cut-off, "
                                  "got no value")
            if not _finite(cutoff) or not 0 < cutoff < nyquist:
                raise ConfigError(f"{at(row)}: cut-off must be > 0 and below the Nyquist frequency "
                                  f"{nyquist:g} Hz, got {cutoff!r} Hz")
        if len(rows) == 2 and ch.cutoff_low >= ch.cutoff_high:
            raise ConfigError(f"{at(9)}: low cut-off {ch.cutoff_low!r} Hz must be below the high "
                              f"cut-off {ch.cutoff_high!r} Hz")
        if family is FilterFamily.ELLIPTIC:
            for row in (10, 11):
                value = getattr(ch, CHANNEL_FIELDS[row])
                if not _finite(value) or not filter_db_ok(value):
                    raise ConfigError(f"{at(row)}: an elliptic filter needs {FILTER_DB_TEXT}, got {value!r}")
            check_ripple(at(10), ch.ripple_db, ch.attenuation_db)
    start = _integer(ch.offset_start, at(15))
    length = _integer(ch.offset_length, at(16))
    if start < 0:
        raise ConfigError(f"{at(15)}: offset start must be >= 0, got {ch.offset_start!r}")
    if length < 0:
        raise ConfigError(f"{at(16)}: offset length must be >= 0, got {ch.offset_length!r}")
    if n_samples is not None and length > 0 and start + length > n_samples:
        raise ConfigError(f"{at(16)}: offset window samples {start}..{start + length - 1} lies outside "
                          f"the record of {n_samples} samples")
    if ch.integration_rule not in INTEGRATION_RULES:
        raise ConfigError(f"{source}: channel {k} field 'integration_rule': expected one of "
                          f"{', '.join(INTEGRATION_RULES)}, got {ch.integration_rule!r}")


@dataclass
class Systeminfo:
    """What the acquisition recorded about each channel and the rig."""

    channels: list[ChannelInfo]
    rig: RigInfo = field(default_factory=RigInfo)

    @property
    def sampling_rate(self) -> float:
        return self.channels[0].sampling_rate if self.channels else 0.0

    @property
    def n_channels(self) -> int:
        return len(self.channels)

    def with_rate(self, sampling_rate: float) -> Systeminfo:
        """This Systeminfo with every channel whose row 7 is unset (0 Hz) at ``sampling_rate``."""
        return replace(self, channels=[ch if ch.sampling_rate else replace(ch, sampling_rate=float(sampling_rate))
                                       for ch in self.channels])

    def validate(self, *, n_samples: int | None = None, source: str | Path = "systeminfo") -> None:
        """Raise a one-line ConfigError naming ``source``, row, channel and value of the first
        invalid setting. ``n_samples`` (record length) enables the offset-window check."""
        if not self.channels:
            raise ConfigError(f"{source}: no channels")
        fs0 = self.channels[0].sampling_rate
        for k, ch in enumerate(self.channels):
            _validate_channel(ch, k, source, n_samples, fs0)
        nine = self.rig.nine_channels
        if nine and len(nine) != 9:
            raise ConfigError(f"{where(source, 33)}: expected 9 channels, got {len(nine)} ({nine})")
        for i, c in enumerate(nine):
            if not column_in_range("nine_channels", c, len(self.channels)):
                raise ConfigError(f"{where(source, 33, i)}: channel {c!r} is not one of the "
                                  f"{len(self.channels)} channels")
        for i, c in enumerate(self.rig.coordinate_columns):  # the stored table refuses these too
            if not column_in_range("coordinate_columns", c, len(self.channels)):
                raise ConfigError(f"{where(source, 29, i)}: expected a column number from 0 to "
                                  f"{MAX_COORDINATE_COLUMN}, got {c!r}")
        for row, value in ((30, self.rig.rx), (31, self.rig.ry), (32, self.rig.rz)):
            if value is not None and (not _finite(value) or value <= 0):
                raise ConfigError(f"{where(source, row, 0)}: must be > 0, got {value!r} m")

    @classmethod
    def for_rig(cls, rig: Rig, sampling_rate: float, n_channels: int | None = None) -> Systeminfo:
        """A Systeminfo for ``rig``: its default ``.CTR`` when it has one (channels beyond it are
        described from the rig's sensors), else one built from the rig's sensors and its
        ``[processing]`` settings. Every channel gets ``sampling_rate``."""
        n = rig.channel_count if n_channels is None else n_channels
        fs = float(sampling_rate)
        channels = [_channel_for_rig(rig, k, fs) for k in range(n)]
        rig_info = _rig_info_from_geometry(rig)
        if rig.systeminfo_text is not None or rig.systeminfo_file is not None:
            with warnings.catch_warnings():
                # the rig's own file is curated: its codes were reviewed when it was shipped
                warnings.simplefilter("ignore", OdsuiteWarning)
                default = (read_ctr(rig.systeminfo_file) if rig.systeminfo_text is None else
                           parse_ctr(rig.systeminfo_text, source=rig.systeminfo_file or "systeminfo"))
            for k, ch in enumerate(default.channels[:n]):
                channels[k] = replace(ch, sampling_rate=fs)
            rig_info = default.rig
        return cls(channels=channels, rig=rig_info)


#: what the thesis's experimenter set on every channel (Table E.3): DAQ gain 10, +-5 V, offset
#: from the first 100 samples, 8th-order elliptic 20 Hz high-pass (0.1 dB, 60 dB)
_THESIS_CHANNEL = dict(filter_type=FilterType.HIGHPASS, filter_order=8, cutoff_low=20.0, ripple_db=0.1,
                       attenuation_db=60.0, filter_family=FilterFamily.ELLIPTIC, offset_length=100,
                       daq_gain=10.0, limit_high=5.0, limit_low=-5.0)
#: the thesis's load cell (PCB 208B03, Table A.1), for a rig that names no force sensitivity
_THESIS_LOADCELL_V_PER_N = 2.248e-3


def _channel_for_rig(rig: Rig, k: int, fs: float) -> ChannelInfo:
    """Channel ``k`` described from the rig: the thesis's settings under the rig's ``[processing]``
    and the sensor's own ``processing`` table. Accelerometers are integrated twice, filtered on the
    signal and after the first integration unless the rig says otherwise (§5.2); a rig-wide
    ``filter_at`` concerns accelerometers only. Sensors with sign -1 are inverted."""
    settings = {**_THESIS_CHANNEL, **{key: v for key, v in rig.processing.items() if key != "filters_on"}}
    if rig.acquisition is not None and rig.acquisition.adc_range is not None:  # else +-10 V read clipped at 5 V
        settings.update(limit_low=rig.acquisition.adc_range[0], limit_high=rig.acquisition.adc_range[1])
    sensor = rig.sensor_on_channel(k)
    if sensor is None:
        if k == rig.force_channel:
            return ChannelInfo(sensor_type=SensorType.LOADCELL, location="force", sampling_rate=fs,
                               sensitivity=_THESIS_LOADCELL_V_PER_N, **settings)
        return ChannelInfo(sensor_type=SensorType.VOLTAGE, location=f"ai{k}", sampling_rate=fs, **settings)
    sensor_type = _QUANTITY_TO_SENSOR_TYPE.get(sensor.quantity, SensorType.AUXILIARY)
    if sensor.sensitivity is None and sensor_type is not SensorType.VOLTAGE:
        raise ConfigError(f"rig {rig.name!r}: sensor {sensor.name!r} (channel {k}) has no sensitivity")
    if sensor_type is SensorType.ACCELEROMETER:
        settings.update(integration=Integration.DOUBLE, filters_on=rig.processing.get("filters_on", 3))
    settings.update(rig.sensor_processing.get(sensor.name, {}))
    return ChannelInfo(sensor_type=sensor_type, location=sensor.name, serial=sensor.serial,
                       sensitivity=sensor.sensitivity or 1.0, sampling_rate=fs,
                       invert=sensor.sign < 0, **settings)


def _rig_info_from_geometry(rig: Rig) -> RigInfo:
    info = RigInfo(use_in_gcc=True, use_in_ag=True)
    for body in rig.bodies:
        if body.plate is not None:
            info.plate_sizes.append(tuple(float(v) for v in body.plate.size))
            info.plate_origins.append(tuple(float(v) for v in body.plate.corner))
        nine = body.nine_sensor_set
        if nine is not None and info.rx is None:
            info.rx, info.ry, info.rz = nine.rx, nine.ry, nine.rz
            info.nine_channels = [rig.sensor(nine.sensors[r]).channel for r in NINE_ROLES]
    return info


# ---------------------------------------------------------------------------------------------
# the .CTR file (Table E.2)

N_ROWS = 34
#: Rows odsuite adds after Table E.2's 34, per channel, written only when a channel departs from
#: the thesis's behaviour (so thesis files stay 34 rows): 34 zero-phase filtering (0 no, 1 yes),
#: 35 integration rule (0 the thesis's Eq. 4.5, 1 trapezoid).
EXTRA_ROWS = ("zero_phase", "integration_rule")
NO_VALUE = ("", "-")

_SEPARATOR_LINE = re.compile(r"^[\s|:+-]*-{3,}[\s|:+-]*$")


def _separator(text: str) -> str | None:
    """The file's cell separator: ``|`` (a table copied from the thesis), a tab (the LabVIEW
    spreadsheet format) or None (whitespace). Decided once per file: a tab-delimited cell may
    hold spaces (a sensor location such as "corner C x")."""
    return "|" if "|" in text else "\t" if "\t" in text else None


def _split(line: str, sep: str | None) -> list[str]:
    """Cells of one line; with a separator, empty cells are kept."""
    if sep == "|":
        body = line.strip()
        body = body[1:] if body.startswith("|") else body
        body = body[:-1] if body.endswith("|") else body
        return [c.strip() for c in body.split("|")]
    if sep == "\t":
        return [c.strip() for c in line.split("\t")]
    return line.split()


def _ctr_rows(text: str, source: str | Path) -> list[list[str]]:
    """The 34 rows of cells, from either the bare 34 x n array or the table as printed in the thesis
    (a header line starting with "Row" and each row led by its number)."""
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    while lines and not lines[0].strip():
        lines.pop(0)
    if not lines:
        raise ConfigError(f"{source}: empty file")
    sep = _separator(text)
    labelled = next((i for i, line in enumerate(lines)
                     if (_split(line, sep) or [""])[0].lower() == "row"), None)
    if labelled is None:
        if len(lines) not in (N_ROWS, N_ROWS + len(EXTRA_ROWS)):
            raise ConfigError(f"{source}: expected {N_ROWS} rows (Table E.2), found {len(lines)}")
        return [_split(line, sep) for line in lines]
    rows: dict[int, list[str]] = {}
    for number, line in enumerate(lines[labelled + 1:], start=labelled + 2):
        if not line.strip() or _SEPARATOR_LINE.match(line):
            continue
        cells = _split(line, sep)
        if not cells[0].isdigit() or int(cells[0]) != len(rows):
            raise ConfigError(f"{source}: line {number}: expected row number {len(rows)}, "
                              f"got {cells[0]!r}")
        rows[len(rows)] = cells[1:]
    if len(rows) != N_ROWS:
        raise ConfigError(f"{source}: expected {N_ROWS} rows (Table E.2), found {len(rows)}")
    return [rows[r] for r in range(N_ROWS)]


def _number(cell: str, place: str) -> float | None:
    if cell in NO_VALUE:
        return None
    try:
        value = float(cell)
    except ValueError:
        raise ConfigError(f"{place}: not a number: {cell!r}") from None
    if not math.isfinite(value):
        raise ConfigError(f"{place}: not a finite number: {cell!r}")
    return value


def _from_milli(cell: str, place: str) -> float | None:
    """A mV or mm cell in V or m: the decimal point moved exactly, then rounded once to a float."""
    if _number(cell, place) is None:
        return None
    return float(Decimal(cell).scaleb(-3))


def _flag(cell: str, place: str) -> bool | None:
    value = _number(cell, place)
    if value not in (None, 0.0, 1.0):
        raise ConfigError(f"{place}: expected 0 (no) or 1 (yes), got {cell!r}")
    return None if value is None else bool(value)


def _channel(cells: list[str], k: int, source: str | Path) -> ChannelInfo:
    """Column ``k`` of rows 0-20; a cell without a value keeps the Table E.2 default."""
    values: dict[str, object] = {}
    for row, name in enumerate(CHANNEL_FIELDS):
        cell = cells[row]
        place = where(source, row, k)
        if row in (1, 2):
            values[name] = "" if cell in NO_VALUE else cell
            continue
        if row in (13, 14):
            value = _flag(cell, place)
        elif row == 3:
            value = _from_milli(cell, place)
        else:
            value = _number(cell, place)
        if value is None:
            continue
        if row == 0:
            value = sensor_type_code(value, place)
        elif row == 4:
            value = enum_code(Integration, value, place)
        elif row == 5:
            value = enum_code(FilterType, value, place)
        elif row == 18:
            value = enum_code(FilterFamily, value, place)
        elif row == 12:
            value = filters_on_code(value, place)
        elif row in (6, 15, 16):
            if not value.is_integer():
                raise ConfigError(f"{place}: expected an integer, got {cell!r}")
            value = int(value)
        values[name] = value
    return ChannelInfo(**values)


def _rig(rows: list[list[str]], source: str | Path) -> RigInfo:
    """Rows 21-33: only their first columns are used (Table E.2); later cells are ignored."""

    def cell(row: int, col: int) -> str:
        return rows[row][col] if col < len(rows[row]) else ""

    def num(row: int, col: int) -> float | None:
        return _number(cell(row, col), where(source, row, col))

    def mm(row: int, col: int) -> float | None:
        return _from_milli(cell(row, col), where(source, row, col))

    def required(row: int, col: int, value: float | None) -> float:
        if value is None:
            raise ConfigError(f"{where(source, row, col)}: missing value")
        return value

    def integer(row: int, col: int) -> int | None:
        value = num(row, col)
        if value is not None and not value.is_integer():
            raise ConfigError(f"{where(source, row, col)}: expected an integer, got {cell(row, col)!r}")
        return None if value is None else int(value)

    info = RigInfo()
    info.use_in_gcc = bool(_flag(cell(21, 0), where(source, 21, 0)))
    info.use_in_ag = bool(_flag(cell(21, 1), where(source, 21, 1)))
    n_plates = 0
    while n_plates < 3 and num(22, n_plates) is not None:
        n_plates += 1
    info.plate_sizes = [tuple(required(r, j, mm(r, j)) for r in (22, 23, 24)) for j in range(n_plates)]
    if any(num(r, j) is not None for r in (25, 26, 27) for j in range(3)):
        info.plate_origins = [tuple(required(r, j, mm(r, j)) for r in (25, 26, 27))
                              for j in range(n_plates)]
    info.plot_from_corner = bool(_flag(cell(28, 0), where(source, 28, 0)))
    columns = [integer(29, j) for j in range(2)]
    info.coordinate_columns = [c for c in columns if c is not None]
    info.rx, info.ry, info.rz = mm(30, 0), mm(31, 0), mm(32, 0)
    nine = [integer(33, j) for j in range(9)]
    if any(c is not None for c in nine):
        info.nine_channels = [int(required(33, j, c)) for j, c in enumerate(nine)]
    return info


def parse_ctr(text: str, source: str | Path = "systeminfo") -> Systeminfo:
    """Parse the text of a ``.CTR`` file (34 rows x n channels, Table E.2) into SI units."""
    if not isinstance(text, str):  # a path or None raised inside (read_ctr reads a file)
        arguments.refuse("parse_ctr", "text", text, "the text of a .CTR file (read_ctr reads one from its path)")
    rows = _ctr_rows(text, source)
    head = rows[0]
    n = len(head)
    while n and head[n - 1] in NO_VALUE:
        n -= 1
    if n == 0:
        raise ConfigError(f"{where(source, 0)}: no channels")
    for r in range(21):
        extra = [c for c in rows[r][n:] if c not in NO_VALUE]
        if extra:
            raise ConfigError(f"{where(source, r, n)}: row 0 has {n} channels but this row has a value "
                              f"{extra[0]!r} beyond them")
        rows[r] = rows[r] + [""] * (n - len(rows[r]))
    channels = [_channel([rows[r][k] for r in range(21)], k, source) for k in range(n)]
    for k, ch in enumerate(channels):
        # limits in the wrong order: Systeminfo.validate names them (row 20)
        if ch.limit_low < ch.limit_high and not adc_range_ok(ch.limit_low, ch.limit_high):
            row = 20 if abs(ch.limit_low) > ADC_RANGE_MAX_V >= abs(ch.limit_high) else 19  # else high, or the span
            raise ConfigError(f"{where(source, row, k)}: DAQ limits {ch.limit_low!r} V to {ch.limit_high!r} V: "
                              f"expected {ADC_RANGE_TEXT}")
    if len(rows) > N_ROWS:
        channels = [_extra(ch, [rows[r][k] if k < len(rows[r]) else "" for r in range(N_ROWS, len(rows))],
                           k, source) for k, ch in enumerate(channels)]
    return Systeminfo(channels=channels, rig=_rig(rows, source))


def _extra(ch: ChannelInfo, cells: list[str], k: int, source: str | Path) -> ChannelInfo:
    """Rows 34-35 (see EXTRA_ROWS) of column ``k``; an empty cell keeps the thesis's behaviour."""
    zero_phase = _flag(cells[0], where(source, N_ROWS, k)) if cells[0] not in NO_VALUE else False
    rule = ch.integration_rule
    if cells[1] not in NO_VALUE:
        place = where(source, N_ROWS + 1, k)
        code = _number(cells[1], place)
        if code not in (0, 1):
            raise ConfigError(f"{place}: integration rule must be 0 (thesis Eq. 4.5) or 1 (trapezoid), "
                              f"got {cells[1]!r}")
        rule = INTEGRATION_RULES[int(code)]
    return replace(ch, zero_phase=bool(zero_phase), integration_rule=rule)


def read_ctr(path: str | Path) -> Systeminfo:
    """Read a ``.CTR`` Systeminfo file (tab-, whitespace- or ``|``-separated)."""
    return parse_ctr(read_text(path, "Systeminfo (.CTR)"), source=path)


def _fmt(value: float | int | bool | None) -> str:
    """Shortest text that reads back to exactly ``value``."""
    if value is None:
        return "-"
    if isinstance(value, (bool, int)):
        return str(int(value))
    value = float(value)
    if value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def _fmt_milli(value: float | None) -> str:
    """``value`` (SI) in milli-units: its shortest repr shifted three decimal places, which
    :func:`_from_milli` reads back to exactly ``value``."""
    if value is None:
        return "-"
    shifted = Decimal(repr(float(value))).scaleb(3).normalize()
    return format(shifted, "f") if 1e-6 <= abs(shifted) < 1e15 or shifted == 0 else str(shifted)


def _text_cell(value: str, row: int, k: int) -> str:
    if not value:
        return "-"
    if any(c in value for c in "\t\r\n|") or value.strip() != value or value == "-":
        raise ConfigError(f"{where('systeminfo', row, k)}: {value!r} cannot be written to a .CTR cell")
    return value


def format_ctr(si: Systeminfo) -> str:
    """The ``.CTR`` text of ``si``: 34 tab-separated rows, one column per channel."""
    n = len(si.channels)
    rows: list[list[str]] = []
    for row, name in enumerate(CHANNEL_FIELDS):
        cells = []
        for k, ch in enumerate(si.channels):
            value = getattr(ch, name)
            if row in (1, 2):
                cells.append(_text_cell(value, row, k))
            elif row == 3:
                cells.append(_fmt_milli(value))
            else:
                cells.append(_fmt(value))
        rows.append(cells)
    rig = si.rig
    plates = rig.plate_sizes
    origins = rig.plate_origins
    rig_rows: list[list[str]] = [
        [_fmt(rig.use_in_gcc), _fmt(rig.use_in_ag)],
        *[[_fmt_milli(p[i]) for p in plates] for i in range(3)],
        *[[_fmt_milli(o[i]) for o in origins] for i in range(3)],
        [_fmt(rig.plot_from_corner)],
        [_fmt(c) for c in rig.coordinate_columns],
        [_fmt_milli(rig.rx)], [_fmt_milli(rig.ry)], [_fmt_milli(rig.rz)],
        [_fmt(c) for c in rig.nine_channels],
    ]
    for cells in rig_rows:
        rows.append(cells + ["-"] * (n - len(cells)))
    if any(ch.zero_phase or ch.integration_rule != "thesis" for ch in si.channels):
        rows.append([_fmt(ch.zero_phase) for ch in si.channels])
        rows.append([_fmt(INTEGRATION_RULES.index(ch.integration_rule)) for ch in si.channels])
    return "".join("\t".join(cells) + "\n" for cells in rows)


def write_ctr(si: Systeminfo, path: str | Path) -> None:
    """Write ``si`` as a ``.CTR`` file (mV/unit sensitivities, mm lengths)."""
    Path(path).write_text(format_ctr(si), encoding="utf-8")
