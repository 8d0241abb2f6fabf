"""Systeminfo: the per-experiment description of every channel and of the rig (thesis Table E.2).

All values are SI: sensitivities in volts per SI unit (V/(m/s^2), V/N, V/m, V/V), lengths in metres,
frequencies in Hz. The legacy ``.CTR`` codec converts the thesis's mV and mm at the file edge.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum


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


@dataclass
class Systeminfo:
    channels: list[ChannelInfo]
    rig: RigInfo = field(default_factory=RigInfo)

    @property
    def sampling_rate(self) -> float:
        return self.channels[0].sampling_rate if self.channels else 0.0
