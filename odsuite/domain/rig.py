"""Rig definitions: the bodies, plates and sensors of a test rig, read from TOML data files.

A lab describes its own rig by copying a rig file (see ``projects/rigs/`` and the thesis rig in
``plugins/models/rigs/``) and editing it. All
lengths are metres in the rig frame, which the file states (for the thesis rig: origin at the
platform's centre of mass G at rest, platform axes, z pointing down into the platform).
"""

from __future__ import annotations

import difflib
import functools
import math
import os
import stat
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.domain.rig_processing import FILTER_DB_TEXT, check_ripple, filter_db_ok, parse_processing

#: Generalized coordinates of a body, in order (m, m, m, rad, rad, rad).
COORDINATES = ("x", "y", "z", "theta", "phi", "psi")
#: how far (m) outside a body's plate box a force point may lie and still be on that body: points are
#: given to the millimetre on plates whose sizes are rounded too (the thesis's Table 5.3 puts test 5
#: 1.6 mm beyond the platform's 98.46 mm length)
FORCE_POINT_SLACK = 2e-3
#: Roles of the nine-accelerometer set, in Table E.2 row 33 / Eq. 4.13 order.
NINE_ROLES = ("xC", "yC", "zC", "x1", "z1", "y2", "z2", "x3", "y3")


#: frequencies a rig file may give (Hz): sampling rates, an IEPE supply's corner, a sensor's resonance
FREQUENCY_RANGE_HZ = (1e-4, 1e8)
#: the lowest sampling rate, as acquire's and a stored record's
LOWEST_RATE_HZ = 0.1


@dataclass(frozen=True)
class Plate:
    """A box drawn for a body: size (L, W, H along body x, y, z) and its corner of least x, y, z."""

    size: np.ndarray
    corner: np.ndarray


@dataclass(frozen=True)
class NineSensorSet:
    """Nine single-axis accelerometers on three corners (thesis Fig. 4.9, Eq. 4.13).

    ``corner`` is corner C; corner 1 = C + (0, ry, 0), corner 2 = C + (rx, 0, 0),
    corner 3 = C + (0, 0, rz). ``sensors`` maps each role of NINE_ROLES to a sensor name.
    """

    corner: np.ndarray
    rx: float
    ry: float
    rz: float
    sensors: dict[str, str]


@dataclass(frozen=True)
class Body:
    """A body of the rig: a moving rigid body (mass, inertia) or a fixed one (the ground, a reference)."""

    name: str
    com: np.ndarray  # centre of mass at rest, rig frame
    mass: float | None = None  # None: not modelled as a moving rigid body (e.g. a fixed reference)
    inertia: np.ndarray | None = None  # 3x3 about the centre of mass, body axes
    plate: Plate | None = None
    nine_sensor_set: NineSensorSet | None = None
    solver: str | None = None  # a registered coordinate solver; None: the most suitable one
    dofs: tuple[str, ...] = COORDINATES  # the coordinates that may move (a planar model: ("z", "phi"))


@dataclass(frozen=True)
class Sensor:
    """A single-axis sensor: volts = sign * sensitivity * (quantity at ``position`` along ``axis``).
    A hammer's force sensor has no body, position or axis (None): the force point and direction
    are given per experiment."""

    name: str
    channel: int
    body: str | None
    position: np.ndarray | None
    axis: np.ndarray | None
    sign: float = 1.0
    kind: str = "accelerometer"  # the registered sensor type that declared it
    serial: str = ""
    sensitivity: float | None = None  # V per SI unit (e.g. V/(m/s^2)); None: from the Systeminfo
    quantity: str = "acceleration"  # what it measures: acceleration, force, displacement, voltage, ...
    group: str = ""  # the multi-axis sensor it is one axis of (e.g. a triaxial accelerometer)
    uff_node: int | None = None  # the UFF node number its records carry; None: the number export-uff gives it


@dataclass(frozen=True, eq=False)
class Spring:
    """A spring-damper between ``body`` and ``other`` (another body, or None for the ground) acting
    at ``position`` (m, rig frame) on the relative displacement of that point: ``stiffness`` N/m and
    ``damping`` N s/m along the rig axes (3,) or as 3x3 matrices; ``rot_stiffness`` N m/rad and
    ``rot_damping`` N m s/rad on the relative rotation (3,). ``group``: springs scaled together by
    effects (e.g. "isolators"); by default the spring's own name."""

    name: str
    body: str
    other: str | None
    position: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    rot_stiffness: np.ndarray
    rot_damping: np.ndarray
    group: str


#: anti-aliasing filter families a rig file may name (scipy.signal's analog prototypes)
AA_FAMILIES = ("butterworth", "elliptic", "chebyshev1", "bessel")


@dataclass(frozen=True)
class AntiAliasing:
    """The DAQ's analog low-pass ahead of the ADC. ``force_channel``: the hammer's channel passes
    through it too (the usual case: the model, driven by the filtered force, then carries the filter
    already; False: only the accelerometer channels are filtered, so the prediction adds it)."""

    family: str
    order: int
    cutoff_hz: float
    ripple_db: float = 0.1  # elliptic and Chebyshev pass-band ripple
    attenuation_db: float = 60.0  # elliptic stop-band attenuation
    force_channel: bool = True

    def zpk(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Analog zeros, poles (rad/s) and gain."""
        import scipy.signal

        wc = 2 * np.pi * self.cutoff_hz
        if self.family == "butterworth":
            return scipy.signal.butter(self.order, wc, analog=True, output="zpk")
        if self.family == "elliptic":
            return scipy.signal.ellip(self.order, self.ripple_db, self.attenuation_db, wc, analog=True, output="zpk")
        if self.family == "chebyshev1":
            return scipy.signal.cheby1(self.order, self.ripple_db, wc, analog=True, output="zpk")
        return scipy.signal.bessel(self.order, wc, analog=True, output="zpk", norm="mag")


@dataclass(frozen=True)
class Acquisition:
    """A rig file's ``[acquisition]`` table: how its DAQ records (SI: Hz, V)."""

    sampling_rate: float | None = None
    pre_trigger: int | None = None
    adc_bits: int | None = None  # None (or 0 in the file): not stated
    adc_range: tuple[float, float] | None = None  # V, input range of the ADC
    anti_aliasing: AntiAliasing | None = None
    iepe_corner_hz: float | None = None  # AC coupling of the accelerometers' IEPE supply (first order)
    sensor_resonance_hz: float | None = None  # the accelerometers' mounted resonance
    sensor_resonance_damping: float = 0.03

    @property
    def lsb_v(self) -> float | None:
        """Volts per ADC code, when bits and range are stated."""
        if not self.adc_bits or self.adc_range is None:
            return None
        return (self.adc_range[1] - self.adc_range[0]) / 2**self.adc_bits


@dataclass(frozen=True)
class Rig:
    """A rig: its bodies, the springs between them and the sensors on them, in the rig frame (SI)."""

    name: str
    description: str
    frame: str
    bodies: tuple[Body, ...]
    sensors: tuple[Sensor, ...]
    force_channel: int | None
    channel_count: int
    default_model: str | None
    systeminfo_file: Path | None = None  # a legacy .CTR with the rig's default Systeminfo
    #: that file's text where a project keeps it (read instead of the file: a project never reads outside itself)
    systeminfo_text: str | None = None
    springs: tuple[Spring, ...] = ()
    source: Path | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    #: the file's ``[processing]`` tables as written: "" the rig's, else a sensor's name
    processing_tables: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: ChannelInfo settings of ``[processing]`` for records without a .CTR, and per sensor on top
    processing: dict[str, Any] = field(default_factory=dict)
    sensor_processing: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: the rig frame's upward direction (against gravity), for drawing: [0, 0, 1] unless the file says
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def horizontal_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Two unit vectors spanning the horizontal plane (perpendicular to ``up``): the rig's x and
        y made horizontal, so that a view's azimuth is measured from x towards y."""
        e1 = np.eye(3)[0] - self.up * self.up[0]
        if np.linalg.norm(e1) < 1e-6:  # x is vertical: measure from y
            e1 = np.eye(3)[1] - self.up * self.up[1]
        e1 = e1 / np.linalg.norm(e1)
        e2 = np.eye(3)[1] - self.up * self.up[1] - e1 * e1[1]
        if np.linalg.norm(e2) < 1e-6:
            e2 = np.cross(self.up, e1)
        return e1, e2 / np.linalg.norm(e2)
    acquisition: Acquisition | None = None

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise ConfigError(f"rig {self.name!r}: no body named {name!r}")

    def sensor(self, name: str) -> Sensor:
        found = self._sensor_by_name.get(name)
        if found is None:
            raise ConfigError(f"rig {self.name!r}: no sensor named {name!r}")
        return found

    @functools.cached_property
    def _sensor_by_name(self) -> dict[str, Sensor]:
        """The first sensor of each name, found once (a walk per lookup was quadratic: 4,000 sensors)."""
        out: dict[str, Sensor] = {}
        for s in self.sensors:
            out.setdefault(s.name, s)
        return out

    def sensor_on_channel(self, channel: int) -> Sensor | None:
        return self._sensor_by_channel.get(channel)

    @functools.cached_property
    def _sensor_by_channel(self) -> dict[int, Sensor]:
        """The first sensor on each channel, found once (a walk per lookup was quadratic: 4,000 channels)."""
        out: dict[int, Sensor] = {}
        for s in self.sensors:
            out.setdefault(s.channel, s)
        return out

    @property
    def moving_bodies(self) -> tuple[Body, ...]:
        return tuple(b for b in self.bodies if b.mass is not None)

    @property
    def accelerometers(self) -> tuple[Sensor, ...]:
        """The sensors that measure acceleration (the ones a model predicts), in file order."""
        return tuple(s for s in self.sensors if s.quantity == "acceleration")

    def left_out_note(self, used: Sequence[int], what: str) -> str | None:
        """A line naming the sensors on a body that measure something other than acceleration (a
        proximity probe's displacement) and are not among the channels ``used``: ``what`` (processing,
        the comparison) takes accelerometers only. None when there are none."""
        out = [s for s in self.sensors if s.body is not None and s.quantity != "acceleration" and s.channel not in used]
        if not out:
            return None
        named = ", ".join(f"channel {s.channel} ({s.name}, {s.kind}: {s.quantity})" for s in out)
        return (f"rig {self.name!r}: {named} {'is' if len(out) == 1 else 'are'} left out of {what}, which takes "
                "accelerometers only; "
                "`odsuite modes` reads such channels")

    def force_body(self, point, body: str | None = None) -> str | None:
        """The moving body a hammer hits at ``point`` (m): ``body`` when given (a moving body's
        name), else the one whose plate holds the point (within FORCE_POINT_SLACK), else the one
        whose centre of mass is nearest; None without moving bodies. A point on two bodies' plates
        (a machine's foot on its base) is refused unless ``body`` says which."""
        point = np.asarray(point, dtype=float)
        moving = self.moving_bodies
        if body is not None:
            if body not in {b.name for b in moving}:
                raise ConfigError(f"--force-body: rig {self.name!r} has no moving body {body!r} "
                                  f"(moving: {', '.join(b.name for b in moving) or 'none'})")
            return body
        holding = [b.name for b in moving if b.plate is not None
                   and np.all(point >= b.plate.corner - FORCE_POINT_SLACK)
                   and np.all(point <= b.plate.corner + b.plate.size + FORCE_POINT_SLACK)]
        if len(holding) > 1:
            mm = ", ".join(f"{1e3 * v:g}" for v in point)
            raise ConfigError(f"force point ({mm}) mm lies on bodies {' and '.join(map(repr, holding))} of rig "
                              f"{self.name!r}: say which one was hit with --force-body")
        if holding:
            return holding[0]
        if not moving:
            return None
        return min(moving, key=lambda b: float(np.linalg.norm(point - b.com))).name


def body_sensors(rig: Rig, body: Body) -> tuple[Sensor, ...]:
    """The rig's sensors mounted on ``body``."""
    return tuple(s for s in rig.sensors if s.body == body.name)


#: A sensor axis written with two decimals ([0.71, 0.71, 0]) is 0.4 % long; a length further from 1
#: is a mistake (a gain or a sign written into the axis), not rounding
AXIS_LENGTH_SLACK = 1e-2

#: UFF node numbers are I10 fields of datasets 15/2411 and 58
UFF_NODE_MAX = 2**31 - 1

#: Channels a rig (or a file) may have: no DAQ chassis has more
MAX_CHANNELS = 4096
#: physical ranges of a rig file's numbers (SI): beyond them a value is a typo or an attack, and
#: the model's matrices lose their meaning (1e308 N/m overflows, 1e-300 kg underflows)
MASS_RANGE = (1e-6, 1e7)  # kg: a 1 mg sensor to a 10,000 t foundation
INERTIA_MAX = 1e8  # kg m^2
INERTIA_MIN = 1e-15  # kg m^2: a principal moment of a 1 mg, 0.03 mm body; below it, round-off
#: V per SI unit: a 0.1 mV/g accelerometer is 1e-5 V/(m/s^2), a laser displacement sensor 1e4 V/m
SENSITIVITY_RANGE = (1e-9, 1e9)
STIFFNESS_MAX = 1e12  # N/m, N m/rad (and N s/m, N m s/rad for damping)
#: a nonzero coefficient below this is a typo: a 1 mg body on it swings once in about two hours, and
#: subnormal values (1e-300) break the simulation's matrix balancing
STIFFNESS_MIN = 1e-12
SIZE_MAX = 1e3  # m: positions, sizes and corners within a kilometre of the origin
#: a rig file is text of at most this many bytes, tables and arrays nested at most this deep
RIG_FILE_BYTES = 16 * 2**20
RIG_NESTING = 32
#: the keys each table of a rig file may hold (a top-level table of another name is a plugin's
#: section, e.g. [beam]; anything else is a typo)
TOP_KEYS = ("name", "description", "frame", "bodies", "springs", "sensors", "force_channel", "channel_count",
            "default_model", "systeminfo", "processing", "up", "acquisition")
BODY_KEYS = ("name", "mass", "inertia", "plate", "nine_sensor_set", "solver", "dofs", "com")
SPRING_KEYS = ("name", "body", "other", "position", "stiffness", "damping", "rot_stiffness", "rot_damping", "group")
SENSOR_KEYS = ("name", "kind", "body", "channel", "position", "axis", "sign", "sensitivity", "serial", "group",
               "uff_node", "processing")


def known_keys(where: str, table: dict[str, Any], known: tuple[str, ...], *, tables_allowed: bool = False) -> None:
    """Refuse a key ``table`` does not know, naming the nearest known one (a misspelt key would
    otherwise be ignored and its default used)."""
    for key in table:
        if key in known:  # the usual case first: matching every key costs a rig's load 10 ms
            continue
        # a plugin's own table passes, unless its name is a known key misspelt ([acquisiton])
        if tables_allowed and isinstance(table[key], dict) and not difflib.get_close_matches(
                str(key), known, n=1, cutoff=0.8):
            continue
        near = difflib.get_close_matches(str(key), known, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else f" (known: {', '.join(known)})"
        raise ConfigError(f"{where}: unknown field {key!r}{hint}")


def printable_name(where: str, value: Any) -> str:
    """A name shown in tables, reports and file names: printable text (no newline, escape
    sequence or bidirectional control), at most 200 characters."""
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{where}: expected a non-empty name, got {value!r}")
    if not value.isprintable() or len(value) > 200:
        raise ConfigError(f"{where}: expected printable text of at most 200 characters (no control, escape or "
                          f"bidirectional characters), got {value[:200]!r}")
    return value


def _within(where: str, arr: np.ndarray, most: float, what: str, unit: str) -> np.ndarray:
    if np.any(np.abs(arr) > most):
        raise ConfigError(f"{where}: {what} beyond {most:g} {unit}, got {arr.tolist()}")
    return arr


def _depth(value: Any, limit: int, level: int = 0) -> int:
    """How deep ``value`` nests tables and arrays (stops counting past ``limit``)."""
    if level > limit or not isinstance(value, (dict, list)):
        return level
    items = value.values() if isinstance(value, dict) else value
    return max((_depth(v, limit, level + 1) for v in items), default=level + 1)


def _floats(value: Any) -> np.ndarray | None:
    """A TOML list as floats; None when it is no list or holds an integer beyond a float (10**400)."""
    try:
        return np.asarray(value, dtype=float) if isinstance(value, list) else None
    except (OverflowError, TypeError, ValueError):
        return None


def _vector(where: str, value: Any, n: int = 3) -> np.ndarray:
    arr = _floats(value)
    if arr is None or arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f"{where}: expected {n} finite numbers, got {value!r}")
    return arr


def _number(where: str, value: Any, *, positive: bool = False) -> float:
    try:  # math, not numpy: an integer beyond int64 (10**41) is no numpy number
        finite = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    except OverflowError:  # an integer beyond a float (10**400)
        finite = False
    if not finite:
        raise ConfigError(f"{where}: expected a finite number, got {value!r}")
    if positive and value <= 0:
        raise ConfigError(f"{where}: must be > 0, got {value!r}")
    return float(value)


def _hz(where: str, value: Any, lowest: float = FREQUENCY_RANGE_HZ[0]) -> float:
    """A frequency of a rig's front end: a corner of 1e300 Hz (or 1e-300) is accepted as a number
    and breaks the discretisation (an anti-aliasing cut-off of 1e300 Hz overflowed)."""
    v = _number(where, value, positive=True)
    if not lowest <= v <= FREQUENCY_RANGE_HZ[1]:
        raise ConfigError(f"{where}: expected {lowest:g} to {FREQUENCY_RANGE_HZ[1]:g} Hz, got {v!r}")
    return v


def _integer(where: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(f"{where}: expected an integer from {low} to {high}, got {value!r}")
    return value


def _channel_count(where: str, data: dict[str, Any], channels: list[int]) -> int:
    """The rig's channel count: given, or one past the highest sensor or force channel; every
    sensor channel and the force channel lie below it."""
    force = data.get("force_channel")
    if force is not None:
        _integer(f"{where}: field 'force_channel'", force, 0, MAX_CHANNELS - 1)
    used = channels + ([force] if force is not None else [])
    if "channel_count" not in data:
        if force is not None and channels and force > max(channels) + 1:
            raise ConfigError(f"{where}: field 'force_channel': channel {force} lies beyond the sensors' channels "
                              f"(highest {max(channels)}); give channel_count to leave the channels between unused")
        return max(used, default=-1) + 1
    count = _integer(f"{where}: field 'channel_count'", data["channel_count"], 1, MAX_CHANNELS)
    if used and max(used) >= count:
        raise ConfigError(f"{where}: field 'channel_count': {count} channels, but channel {max(used)} is used")
    return count


def rig_from_dict(data: dict[str, Any], sensor_types, source: Path | None = None) -> Rig:
    """Build and validate a rig from parsed TOML; errors name the file, field and value. Each
    ``[[sensors]]`` entry is read by the sensor type its ``kind`` names (``sensor_types``: the
    registry of sensor types; default kind "accelerometer")."""
    if not isinstance(data, Mapping):
        arguments.refuse("rig_from_dict", "data", data, "a rig's tables as a dict (a parsed rig file)")
    _check_sensor_types("rig_from_dict", sensor_types)
    where0 = str(source) if source else "rig"
    name = _rig_name(data, where0)
    bodies: list[Body] = []
    for i, b in enumerate(data.get("bodies", [])):
        bodies.append(_body(b, i, where0, bodies))
    body_names = {b.name for b in bodies}
    if len(body_names) != len(bodies):
        raise ConfigError(f"{where0}: two bodies share a name ({sorted(b.name for b in bodies)})")
    springs = _springs(data.get("springs", []), where0, {b.name for b in bodies if b.mass is not None}, body_names)
    sensors, sensor_processing, processing_tables = _sensors(data, where0, sensor_types, body_names)
    sensor_names = {s.name for s in sensors}
    channels = [s.channel for s in sensors]
    for b in bodies:
        if b.nine_sensor_set:
            unknown = [v for v in b.nine_sensor_set.sensors.values() if v not in sensor_names]
            if unknown:
                raise ConfigError(f"{where0}: body {b.name!r} nine_sensor_set names unknown sensor(s) {unknown}")
    systeminfo_file = None
    if data.get("systeminfo"):
        if not isinstance(data["systeminfo"], str):
            raise ConfigError(f"{where0} field 'systeminfo': expected a .CTR file name, got {data['systeminfo']!r}")
        base = source.parent if source else Path.cwd()
        systeminfo_file = base / data["systeminfo"]
    known = set(TOP_KEYS) - {"acquisition"}
    default_model = data.get("default_model")
    if default_model is not None:
        printable_name(f"{where0}: field 'default_model'", default_model)
    acquisition = _acquisition(data.get("acquisition"), where0)
    channel_count = _channel_count(where0, data, channels)
    return Rig(
        name=name, description=data.get("description", ""), frame=data.get("frame", ""),
        bodies=tuple(bodies), sensors=tuple(sensors), force_channel=_force_channel(data, sensors, where0),
        channel_count=channel_count,
        default_model=data.get("default_model"), systeminfo_file=systeminfo_file, source=source,
        springs=springs,
        extra={k: v for k, v in data.items() if k not in known}, acquisition=acquisition,
        processing=parse_processing(data.get("processing", {}), f"{where0}: [processing]"),
        up=_up(data.get("up", [0.0, 0.0, 1.0]), where0),
        sensor_processing=sensor_processing, processing_tables=processing_tables,
    )


def _rig_name(data: dict[str, Any], where0: str) -> str:
    """The rig's name, after the file's shape is checked: known keys only, nesting bounded, lists
    where lists belong."""
    try:
        name = data["name"]
    except KeyError:
        raise ConfigError(f"{where0}: missing field 'name'") from None
    if not isinstance(name, str) or not name.strip():
        raise ConfigError(f"{where0}: field 'name': expected a non-empty text, got {name!r}")
    printable_name(f"{where0}: field 'name'", name)
    known_keys(where0, data, TOP_KEYS, tables_allowed=True)
    if _depth(data, RIG_NESTING) > RIG_NESTING:
        raise ConfigError(f"{where0}: tables and arrays nested deeper than {RIG_NESTING} levels")
    for key in ("bodies", "sensors"):
        if not isinstance(data.get(key, []), list):
            raise ConfigError(f"{where0}: field {key!r}: expected a list of [[{key}]] tables, got {data[key]!r}")
    return name


def _body(b: Any, i: int, where0: str, earlier: list[Body]) -> Body:
    """One ``[[bodies]]`` table (``earlier``: the bodies read before it, whose names it must not repeat)."""
    w = f"{where0}: bodies[{i}]"
    if not isinstance(b, dict):
        raise ConfigError(f"{w}: expected a table, got {b!r}")
    if not isinstance(b.get("name"), str) or not b["name"]:
        raise ConfigError(f"{w}: field 'name': expected a non-empty name, got {b.get('name')!r}")
    if any(unicodedata.normalize("NFC", b["name"]) == unicodedata.normalize("NFC", other.name) for other in earlier):
        raise ConfigError(f"{w}: field 'name': a second body named {b['name']!r}")
    printable_name(f"{w}: field 'name'", b["name"])
    w = f"{where0}: body {b['name']!r}"
    known_keys(w, b, BODY_KEYS)
    mass = b.get("mass")
    inertia = None
    if mass is not None:
        mass = _number(f"{w} field 'mass'", mass, positive=True)
        if not MASS_RANGE[0] <= mass <= MASS_RANGE[1]:
            raise ConfigError(f"{w} field 'mass': expected {MASS_RANGE[0]:g} to {MASS_RANGE[1]:g} kg, got {mass!r}")
        inertia = _inertia(w, b.get("inertia", np.zeros((3, 3)).tolist()))
    plate = _plate(w, b["plate"]) if "plate" in b else None
    nine = _nine_sensor_set(w, b["nine_sensor_set"]) if "nine_sensor_set" in b else None
    solver = b.get("solver")
    if solver is not None and (not isinstance(solver, str) or not solver):
        raise ConfigError(f"{w} field 'solver': expected a coordinate solver's name, got {solver!r}")
    if mass is None and (solver is not None or nine is not None):
        field_name = "solver" if solver is not None else "nine_sensor_set"
        raise ConfigError(f"{w} field {field_name!r}: the body has no mass, so it does not move in the model "
                          "and its sensors cannot give it coordinates (give it a 'mass' or drop the field)")
    dofs = b.get("dofs", list(COORDINATES))
    if (not isinstance(dofs, list) or not dofs or any(d not in COORDINATES for d in dofs)
            or len(set(dofs)) != len(dofs)):
        raise ConfigError(f"{w} field 'dofs': expected distinct names from {list(COORDINATES)}, got {dofs!r}")
    return Body(
        name=b["name"], com=_within(f"{w} field 'com'", _vector(f"{w} field 'com'", b.get("com", [0.0, 0.0, 0.0])),
                                    SIZE_MAX, "positions", "m"),
        mass=mass, inertia=inertia, plate=plate, nine_sensor_set=nine, solver=solver,
        dofs=tuple(d for d in COORDINATES if d in dofs),
    )


def _inertia(w: str, value: Any) -> np.ndarray:
    """A body's inertia tensor (kg m^2): symmetric, positive definite, bounded, and one a rigid body
    can have."""
    try:
        inertia = np.asarray(value, dtype=float)
    except (TypeError, ValueError):  # text, or rows of different lengths
        raise ConfigError(f"{w} field 'inertia': expected a symmetric 3x3 matrix of numbers, "
                          f"got {value!r}") from None
    if not np.all(np.isfinite(inertia)):
        raise ConfigError(f"{w} field 'inertia': expected finite numbers, got {value!r}")
    if inertia.shape != (3, 3) or not np.allclose(inertia, inertia.T):
        raise ConfigError(f"{w} field 'inertia': expected a symmetric 3x3 matrix, got {value!r}")
    _within(f"{w} field 'inertia'", inertia, INERTIA_MAX, "entries", "kg m^2")
    if np.linalg.eigvalsh(inertia).min() <= 0:
        raise ConfigError(f"{w} field 'inertia': not positive definite (eigenvalues {np.linalg.eigvalsh(inertia)})")
    moments = np.linalg.eigvalsh(inertia)
    if moments[0] < INERTIA_MIN:
        raise ConfigError(f"{w} field 'inertia': principal moment {moments[0]:g} kg m^2, below {INERTIA_MIN:g} "
                          "(no body that carries a sensor is that small)")
    # no rigid body has one principal moment above the sum of the other two
    if moments[2] > (moments[0] + moments[1]) * (1 + 1e-9):
        raise ConfigError(f"{w} field 'inertia': principal moments {moments.tolist()} kg m^2 break the "
                          "triangle inequality (the largest exceeds the sum of the others)")
    return inertia


def _plate(w: str, p: Any) -> Plate:
    size = _within(f"{w} field 'plate.size'", _vector(f"{w} field 'plate.size'", p.get("size")), SIZE_MAX,
                   "sizes", "m")
    if np.any(size <= 0):
        raise ConfigError(f"{w} field 'plate.size': must be > 0, got {p.get('size')!r}")
    return Plate(size=size, corner=_vector(f"{w} field 'plate.corner'", p.get("corner")))


def _nine_sensor_set(w: str, n: Any) -> NineSensorSet:
    missing = [r for r in NINE_ROLES if r not in n.get("sensors", {})]
    if missing:
        raise ConfigError(f"{w} field 'nine_sensor_set.sensors': missing role(s) {', '.join(missing)}")
    return NineSensorSet(
        corner=_vector(f"{w} field 'nine_sensor_set.corner'", n.get("corner")),
        rx=_number(f"{w} field 'nine_sensor_set.rx'", n.get("rx"), positive=True),
        ry=_number(f"{w} field 'nine_sensor_set.ry'", n.get("ry"), positive=True),
        rz=_number(f"{w} field 'nine_sensor_set.rz'", n.get("rz"), positive=True),
        sensors=dict(n["sensors"]),
    )


def _sensors(data: dict[str, Any], where0: str, sensor_types, body_names: set[str]):
    """The ``[[sensors]]`` tables, each read by its kind's sensor type, with the processing tables
    given per sensor and for the whole rig."""
    sensors = []
    sensor_processing: dict[str, dict[str, Any]] = {}
    processing_tables: dict[str, dict[str, Any]] = {"": data["processing"]} if "processing" in data else {}
    for i, s in enumerate(data.get("sensors", [])):
        w = f"{where0}: sensors[{i}]" + (f" {s.get('name')!r}" if isinstance(s, dict) and "name" in s else "")
        if not isinstance(s, dict):
            raise ConfigError(f"{w}: expected a table, got {s!r}")
        kind = s.get("kind", "accelerometer")
        if kind not in sensor_types:
            raise ConfigError(f"{w} field 'kind': unknown sensor type {kind!r} "
                              f"(known: {', '.join(sensor_types.names())})")
        for sensor in sensor_types.get(kind).sensors(s, w):
            printable_name(f"{w} field 'name'", sensor.name)
            if sensor.position is not None:
                _within(f"{w} field 'position'", np.asarray(sensor.position), SIZE_MAX, "positions", "m")
            if sensor.body is not None and sensor.body not in body_names:
                raise ConfigError(f"{w} field 'body': no body named {sensor.body!r}")
            sensors.append(sensor)
            if "processing" in s:
                sensor_processing[sensor.name] = parse_processing(s["processing"], f"{w} field 'processing'")
                processing_tables[sensor.name] = s["processing"]
    first: dict[int, str] = {}
    for s in sensors:
        if s.channel in first:
            raise ConfigError(f"{where0}: two sensors share a channel: {first[s.channel]!r} and {s.name!r} "
                              f"(field 'channel', both {s.channel})")
        first[s.channel] = s.name
    # names that differ only in how Unicode composes them ('é' and 'e' + U+0301) print alike
    if len({unicodedata.normalize("NFC", s.name) for s in sensors}) != len(sensors):
        raise ConfigError(f"{where0}: two sensors share a name ({sorted(s.name for s in sensors)})")
    # a UFF record names its node and line: two sensors along one line at one given node could not be
    # told apart (export-uff refused the rig, new had accepted it)
    noded = [s for s in sensors if s.uff_node is not None and s.axis is not None]
    for i, a in enumerate(noded):
        for b in noded[i + 1:]:
            if a.uff_node == b.uff_node and abs(abs(float(np.dot(a.axis, b.axis))) - 1.0) < 1e-6:
                raise ConfigError(f"{where0}: sensors {a.name!r} and {b.name!r} measure along one line at "
                                  f"uff_node {a.uff_node}: a UFF record could not tell them apart (give one "
                                  "of them another uff_node)")
    return sensors, sensor_processing, processing_tables


def _up(value: Any, where0: str) -> np.ndarray:
    up = _vector(f"{where0}: field 'up'", value)
    if abs(np.linalg.norm(up) - 1.0) > AXIS_LENGTH_SLACK:
        raise ConfigError(f"{where0}: field 'up': expected a unit vector, got {up.tolist()}")
    return up / np.linalg.norm(up)


#: the [acquisition] table's fields (docs/rig-format.md)
ACQUISITION_KEYS = ("sampling_rate", "pre_trigger", "adc_bits", "adc_range", "anti_aliasing", "iepe_corner_hz",
                    "sensor_resonance_hz", "sensor_resonance_damping")
#: the widest ADC input range (V): a DAQ card's is at most a few hundred volts
ADC_RANGE_MAX_V = 1e3
#: the narrowest (V, high - low): a strain-gauge module's +-10 mV, NI multifunction cards' +-50 mV
#: (a range of 1e-300 V clipped every simulated sample: the trigger never came)
ADC_SPAN_MIN_V = 1e-3
#: what an ADC input range (a rig's adc_range, a .CTR's DAQ limits) must be
ADC_RANGE_TEXT = f"volts within +-{ADC_RANGE_MAX_V:g} V, high at least {ADC_SPAN_MIN_V:g} V above low"


def adc_range_ok(low: float, high: float) -> bool:
    """Whether [``low``, ``high``] V is a converter's input range (``ADC_RANGE_TEXT``)."""
    return max(abs(low), abs(high)) <= ADC_RANGE_MAX_V and high - low >= ADC_SPAN_MIN_V


def _acquisition(table: Any, where0: str) -> Acquisition | None:
    """The ``[acquisition]`` table, validated (errors name the field and the value)."""
    if table is None:
        return None
    w = f"{where0}: acquisition"
    if not isinstance(table, dict):
        raise ConfigError(f"{w}: expected a table, got {table!r}")
    known_keys(w, table, ACQUISITION_KEYS)

    def opt_hz(key: str, lowest: float = FREQUENCY_RANGE_HZ[0]) -> float | None:
        return None if table.get(key) is None else _hz(f"{w} field {key!r}", table[key], lowest)

    bits = table.get("adc_bits")
    if bits is not None:
        bits = _integer(f"{w} field 'adc_bits'", bits, 0, 32) or None
        if bits == 1:  # a one-bit converter measures no vibration (the simulated one starts at 2)
            raise ConfigError(f"{w} field 'adc_bits': expected 0 (not stated) or 2 to 32, got 1")
    adc_range = table.get("adc_range")
    if adc_range is not None:
        lo_hi = _vector(f"{w} field 'adc_range'", adc_range, 2)
        if not lo_hi[1] > lo_hi[0]:
            raise ConfigError(f"{w} field 'adc_range': expected [low, high] volts with high > low, got {adc_range!r}")
        if not adc_range_ok(lo_hi[0], lo_hi[1]):
            raise ConfigError(f"{w} field 'adc_range': expected {ADC_RANGE_TEXT}, got {adc_range!r}")
        adc_range = (float(lo_hi[0]), float(lo_hi[1]))
    pre = table.get("pre_trigger")
    if pre is not None:
        pre = _integer(f"{w} field 'pre_trigger'", pre, 0, 2**34)
    aa = table.get("anti_aliasing")
    if aa is not None:
        wa = f"{w} field 'anti_aliasing'"
        if not isinstance(aa, dict):
            raise ConfigError(f"{wa}: expected a table {{family, order, cutoff_hz}}, got {aa!r}")
        family = aa.get("family", "butterworth")
        if family not in AA_FAMILIES:
            raise ConfigError(f"{wa}.family: expected one of {', '.join(AA_FAMILIES)}, got {family!r}")
        force = aa.get("force_channel", True)
        if not isinstance(force, bool):
            raise ConfigError(f"{wa}.force_channel: expected true or false, got {force!r}")
        aa = AntiAliasing(
            family=family, order=_integer(f"{wa}.order", aa.get("order"), 1, 16),
            cutoff_hz=_hz(f"{wa}.cutoff_hz", aa.get("cutoff_hz")),
            ripple_db=_number(f"{wa}.ripple_db", aa.get("ripple_db", 0.1), positive=True),
            attenuation_db=_number(f"{wa}.attenuation_db", aa.get("attenuation_db", 60.0), positive=True),
            force_channel=force)
        for key in ("ripple_db", "attenuation_db"):
            if not filter_db_ok(getattr(aa, key)):
                raise ConfigError(f"{wa}.{key}: expected {FILTER_DB_TEXT}, got {getattr(aa, key)!r}")
        if family == "elliptic":
            check_ripple(wa, aa.ripple_db, aa.attenuation_db)
    damping = _number(f"{w} field 'sensor_resonance_damping'", table.get("sensor_resonance_damping", 0.03),
                      positive=True)
    if damping >= 1:
        raise ConfigError(f"{w} field 'sensor_resonance_damping': expected a ratio below 1, got {damping!r}")
    return Acquisition(sampling_rate=opt_hz("sampling_rate", LOWEST_RATE_HZ), pre_trigger=pre, adc_bits=bits,
                       adc_range=adc_range, anti_aliasing=aa, iepe_corner_hz=opt_hz("iepe_corner_hz"),
                       sensor_resonance_hz=opt_hz("sensor_resonance_hz"), sensor_resonance_damping=damping)


def _sensitivity(where: str, value: Any) -> float:
    v = _number(where, value, positive=True)
    if not SENSITIVITY_RANGE[0] <= v <= SENSITIVITY_RANGE[1]:
        raise ConfigError(f"{where}: expected {SENSITIVITY_RANGE[0]:g} to {SENSITIVITY_RANGE[1]:g} V per SI unit, "
                          f"got {value!r}")
    return v


def _force_channel(data: dict[str, Any], sensors: list[Sensor], where0: str) -> int | None:
    """The hammer's channel: the file's ``force_channel``, or its one force sensor's channel."""
    declared = data.get("force_channel")
    if declared is not None and (isinstance(declared, bool) or not isinstance(declared, int) or declared < 0):
        raise ConfigError(f"{where0}: field 'force_channel': expected a channel index >= 0, got {declared!r}")
    forces = [s for s in sensors if s.quantity == "force" and s.body is None]
    if len(forces) > 1:
        raise ConfigError(f"{where0}: {len(forces)} force sensors without a body ({', '.join(s.name for s in forces)}); "
                          "one hammer per rig")
    if forces and declared is not None and declared != forces[0].channel:
        raise ConfigError(f"{where0}: field 'force_channel' = {declared} but force sensor {forces[0].name!r} is on "
                          f"channel {forces[0].channel}")
    response = next((s for s in sensors if s.channel == declared and s not in forces), None)
    if declared is not None and response is not None:
        raise ConfigError(f"{where0}: field 'force_channel' = {declared} is the channel of sensor {response.name!r} "
                          "(the hammer needs a channel of its own)")
    return forces[0].channel if forces else declared


def _coefficients(where: str, value: Any, default: Any = None) -> np.ndarray:
    """Three coefficients along the rig axes or a symmetric 3x3 matrix, finite, positive
    semi-definite (a negative stiffness or damping is not a spring)."""
    if value is None:
        value = default
    arr = _floats(value)
    try:
        ok = arr is not None and arr.shape in ((3,), (3, 3)) and bool(np.all(np.isfinite(arr)))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"{where}: expected 3 numbers [x, y, z] or a 3x3 matrix, got {value!r}")
    if arr.ndim == 2 and not np.allclose(arr, arr.T, rtol=1e-12, atol=0):
        raise ConfigError(f"{where}: the 3x3 matrix is not symmetric: {value!r}")
    low = np.min(arr) if arr.ndim == 1 else np.linalg.eigvalsh(arr).min()
    if low < 0:
        raise ConfigError(f"{where}: must not be negative, got {value!r}")
    main = arr if arr.ndim == 1 else np.diag(arr)
    if np.any((main != 0) & (np.abs(main) < STIFFNESS_MIN)):
        raise ConfigError(f"{where}: expected 0 or at least {STIFFNESS_MIN:g} (SI), got {value!r}")
    return arr


def _springs(entries: Any, where0: str, moving: set[str], bodies: set[str]) -> tuple[Spring, ...]:
    if not isinstance(entries, list):
        raise ConfigError(f"{where0}: field 'springs': expected a list of [[springs]] tables, got {entries!r}")
    out = []
    for i, s in enumerate(entries):
        w = f"{where0}: springs[{i}]" + (f" {s.get('name')!r}" if isinstance(s, dict) and "name" in s else "")
        if not isinstance(s, dict):
            raise ConfigError(f"{w}: expected a table, got {s!r}")
        name = s.get("name")
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{w} field 'name': expected a non-empty name, got {name!r}")
        printable_name(f"{w} field 'name'", name)
        known_keys(w, s, SPRING_KEYS)
        body = s.get("body")
        for field_name, value in (("body", body), ("other", s.get("other", "ground"))):
            if value == "ground" and field_name == "other":
                continue
            if value not in bodies:
                raise ConfigError(f"{w} field {field_name!r}: no body named {value!r} (bodies: {', '.join(sorted(bodies))})")
            if value not in moving:
                raise ConfigError(f"{w} field {field_name!r}: body {value!r} has no mass, so it does not move; "
                                  "attach the spring to 'ground' instead")
        other = s.get("other", "ground")
        if other == body:
            raise ConfigError(f"{w} field 'other': the spring joins body {body!r} to itself")
        stiffness, damping, rot_k, rot_c = (
            _within(f"{w} field {f!r}", _coefficients(f"{w} field {f!r}", s.get(f), default), STIFFNESS_MAX,
                    "coefficients", "(SI)")
            for f, default in (("stiffness", None), ("damping", [0.0] * 3), ("rot_stiffness", [0.0] * 3),
                               ("rot_damping", [0.0] * 3)))
        if not np.any(stiffness) and not np.any(rot_k):
            raise ConfigError(f"{w} field 'stiffness': zero in every direction, got {s.get('stiffness')!r}")
        group = s.get("group", name)
        if not isinstance(group, str) or not group:
            raise ConfigError(f"{w} field 'group': expected a name, got {group!r}")
        out.append(Spring(name, body, None if other == "ground" else other,
                          _within(f"{w} field 'position'", _vector(f"{w} field 'position'", s.get("position")),
                                  SIZE_MAX, "positions", "m"), stiffness, damping, rot_k, rot_c,
                          group))
    names = [s.name for s in out]
    if len(set(names)) != len(names):
        raise ConfigError(f"{where0}: two springs share a name ({sorted(names)})")
    return tuple(out)


def _check_sensor_types(where: str, sensor_types: Any) -> None:
    """The registry a rig's sensors are read by (None raised inside, at the first sensor)."""
    if not all(callable(getattr(sensor_types, k, None)) for k in ("get", "names", "__contains__")):
        arguments.refuse(where, "sensor_types", sensor_types, "the registry of sensor types "
                         "(registries().sensor_types)")


def load_rig(path: str | Path, sensor_types) -> Rig:
    import tomllib  # here, not at the top: a stored rig is JSON, so reading a project needs no TOML

    if not isinstance(path, str | os.PathLike):
        arguments.refuse("load_rig", "path", path, "a rig file's path")
    _check_sensor_types("load_rig", sensor_types)
    path = Path(path)
    try:
        # non-blocking: opening a pipe must not wait for a writer (it is refused just after)
        with open(path, "rb", opener=lambda p, flags: os.open(p, flags | os.O_NONBLOCK)) as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                raise ConfigError(f"{path}: not a regular file (a pipe, device or folder), expected a TOML rig file")
            if st.st_size > RIG_FILE_BYTES:
                raise ConfigError(f"{path}: {st.st_size} bytes, more than a rig file's {RIG_FILE_BYTES} bytes")
            text = f.read(RIG_FILE_BYTES + 1).decode("utf-8")
        data = tomllib.loads(text)
    except RecursionError:  # tomllib recurses per nesting level
        raise ConfigError(f"{path}: tables and arrays nested deeper than {RIG_NESTING} levels") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: not a regular file (a pipe, device or folder), expected a TOML rig file") from None
    except FileNotFoundError:
        raise ConfigError(f"{path}: rig file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start}), "
                          "so not a TOML rig file") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the rig file ({exc.strerror})") from None
    return rig_from_dict(data, sensor_types, source=path)


def single_axis_sensor(entry: dict[str, Any], where: str, *, kind: str, quantity: str, name: str | None = None,
                       channel: Any = None, axis: Any = None, sensitivity: Any = None, sign: Any = None,
                       group: str = "") -> Sensor:
    """One single-axis sensor from a rig file entry's fields (or the given values, for one axis of
    a multi-axis sensor), validated: errors name ``where``, the field and the value."""
    if name is None:  # a whole entry of one sensor: its fields are these
        known_keys(where, entry, SENSOR_KEYS)
    name = entry.get("name") if name is None else name
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{where} field 'name': expected a non-empty name, got {name!r}")
    if not isinstance(entry.get("body"), str):
        raise ConfigError(f"{where} field 'body': expected a body's name, got {entry.get('body')!r}")
    axis = _vector(f"{where} field 'axis'", entry.get("axis") if axis is None else axis)
    if np.linalg.norm(axis) == 0:
        raise ConfigError(f"{where} field 'axis': zero vector")
    if abs(np.linalg.norm(axis) - 1.0) > AXIS_LENGTH_SLACK:
        raise ConfigError(f"{where} field 'axis': expected a unit vector, got {axis.tolist()} of length "
                          f"{np.linalg.norm(axis):.4g} (a gain belongs in 'sensitivity')")
    sign = entry.get("sign", 1) if sign is None else sign
    if sign not in (1, -1) or isinstance(sign, bool):
        raise ConfigError(f"{where} field 'sign': must be 1 or -1, got {sign!r}")
    channel = entry.get("channel") if channel is None else channel
    if not isinstance(channel, int) or isinstance(channel, bool) or channel < 0:
        raise ConfigError(f"{where} field 'channel': expected a channel index >= 0, got {channel!r}")
    if channel >= MAX_CHANNELS:  # else the rig loads and the project stored with it does not
        raise ConfigError(f"{where} field 'channel': expected a channel index below {MAX_CHANNELS}, got {channel!r}")
    sensitivity = entry.get("sensitivity") if sensitivity is None else sensitivity
    uff_node = entry.get("uff_node")
    if uff_node is not None:
        uff_node = _integer(f"{where} field 'uff_node'", uff_node, 1, UFF_NODE_MAX)
    return Sensor(
        name=name, channel=channel, body=entry["body"],
        position=_vector(f"{where} field 'position'", entry.get("position")),
        axis=axis / np.linalg.norm(axis), sign=float(sign), kind=kind, serial=str(entry.get("serial", "")),
        sensitivity=None if sensitivity is None else _sensitivity(f"{where} field 'sensitivity'", sensitivity),
        quantity=quantity, group=str(entry.get("group", group)), uff_node=uff_node,
    )
