"""Systeminfo: the per-experiment description of every channel and of the rig (thesis Table E.2).

All values are SI: sensitivities in volts per SI unit (V/(m/s^2), V/N, V/m, V/V), lengths in metres,
frequencies in Hz. The legacy ``.CTR`` codec converts the thesis's mV and mm at the file edge.
"""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass, field, replace
from enum import IntEnum
from pathlib import Path

from odsuite.core.errors import ConfigError, OdsuiteWarning
from odsuite.core.rig import NINE_ROLES, Rig


class SensorType(IntEnum):
    """Table E.2 row 0 (code 6, an auxiliary channel in Table E.3, is erratum 9)."""

    NONE = 0
    LOADCELL = 1
    PROXIMITY = 2
    VOLTAGE = 3
    ACCELEROMETER = 4
    AUXILIARY = 6


class Integration(IntEnum):
    """Table E.2 row 4."""

    NONE = 0
    DOUBLE = 1
    SINGLE = 2


class FilterType(IntEnum):
    """Table E.2 row 5."""

    LOWPASS = 0
    HIGHPASS = 1
    BANDPASS = 2
    BANDSTOP = 3


class FilterFamily(IntEnum):
    """Table E.2 row 18."""

    ELLIPTIC = 0
    BUTTERWORTH = 1


#: Physical quantity and SI unit measured by each sensor type; its sensitivity is in V per this unit.
SENSOR_UNITS: dict[SensorType, tuple[str, str]] = {
    SensorType.NONE: ("voltage", "V"),
    SensorType.LOADCELL: ("force", "N"),
    SensorType.PROXIMITY: ("displacement", "m"),
    SensorType.VOLTAGE: ("voltage", "V"),
    SensorType.ACCELEROMETER: ("acceleration", "m/s^2"),
    SensorType.AUXILIARY: ("voltage", "V"),
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

#: Rig sensor kinds (rig TOML ``kind``) and the sensor type a Systeminfo gives them.
_KIND_TO_SENSOR_TYPE = {
    "accelerometer": SensorType.ACCELEROMETER, "loadcell": SensorType.LOADCELL,
    "force": SensorType.LOADCELL, "proximity": SensorType.PROXIMITY,
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
                if not _finite(value) or value <= 0:
                    raise ConfigError(f"{at(row)}: an elliptic filter needs a value > 0 dB, got {value!r}")
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
    channels: list[ChannelInfo]
    rig: RigInfo = field(default_factory=RigInfo)

    @property
    def sampling_rate(self) -> float:
        return self.channels[0].sampling_rate if self.channels else 0.0

    @property
    def n_channels(self) -> int:
        return len(self.channels)

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
            if not isinstance(c, numbers.Integral) or not 0 <= c < len(self.channels):
                raise ConfigError(f"{where(source, 33, i)}: channel {c!r} is not one of the "
                                  f"{len(self.channels)} channels")
        for row, value in ((30, self.rig.rx), (31, self.rig.ry), (32, self.rig.rz)):
            if value is not None and (not _finite(value) or value <= 0):
                raise ConfigError(f"{where(source, row, 0)}: must be > 0, got {value!r} m")

    @classmethod
    def for_rig(cls, rig: Rig, sampling_rate: float, n_channels: int | None = None) -> Systeminfo:
        """A Systeminfo for ``rig``: its default ``.CTR`` when it has one (channels beyond it are
        described from the rig's sensors), else one built from the rig's sensors with the thesis's
        processing settings. Every channel gets ``sampling_rate``."""
        n = rig.channel_count if n_channels is None else n_channels
        fs = float(sampling_rate)
        channels = [_channel_for_rig(rig, k, fs) for k in range(n)]
        rig_info = _rig_info_from_geometry(rig)
        if rig.systeminfo_file is not None:
            from odsuite.core.legacy import read_ctr

            with warnings.catch_warnings():
                # the rig's own file is curated: its codes were reviewed when it was shipped
                warnings.simplefilter("ignore", OdsuiteWarning)
                default = read_ctr(rig.systeminfo_file)
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
    """Channel ``k`` described from the rig with the thesis's settings; accelerometers are
    integrated twice with filters 1 and 2 on (§5.2), sensors with sign -1 inverted."""
    sensor = rig.sensor_on_channel(k)
    if sensor is None:
        if k == rig.force_channel:
            return ChannelInfo(sensor_type=SensorType.LOADCELL, location="force", sampling_rate=fs,
                               sensitivity=_THESIS_LOADCELL_V_PER_N, **_THESIS_CHANNEL)
        return ChannelInfo(sensor_type=SensorType.VOLTAGE, location=f"ai{k}", sampling_rate=fs,
                           **_THESIS_CHANNEL)
    sensor_type = _KIND_TO_SENSOR_TYPE.get(sensor.kind, SensorType.NONE)
    if sensor.sensitivity is None and sensor_type is not SensorType.VOLTAGE:
        raise ConfigError(f"rig {rig.name!r}: sensor {sensor.name!r} (channel {k}) has no sensitivity")
    ch = ChannelInfo(sensor_type=sensor_type, location=sensor.name, serial=sensor.serial,
                     sensitivity=sensor.sensitivity or 1.0, sampling_rate=fs,
                     invert=sensor.sign < 0, **_THESIS_CHANNEL)
    if sensor_type is SensorType.ACCELEROMETER:
        ch = replace(ch, integration=Integration.DOUBLE, filters_on=3)
    return ch


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
