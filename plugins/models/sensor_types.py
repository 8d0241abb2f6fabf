"""The sensor kinds a rig file can declare: single-axis sensors and the triaxial accelerometer."""

from __future__ import annotations

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import SENSOR_KEYS, Sensor, known_keys, single_axis_sensor


class SingleAxis:
    """One channel along one axis at one point of a body."""

    def __init__(self, name: str, quantity: str, unit: str, description: str) -> None:
        self.name, self.quantity, self.unit, self.description = name, quantity, unit, description

    def sensors(self, entry, where):
        return [single_axis_sensor(entry, where, kind=self.name, quantity=self.quantity)]


class Triaxial:
    """Three channels along three axes at one point: ``channels`` (3), ``axes`` (3 unit vectors,
    default the rig axes), ``sensitivity`` (3 values in V per m/s^2, or one for all), optional
    ``names`` (3; default NAME_x, NAME_y, NAME_z) and ``sign`` (one, or three)."""

    name = "triaxial_accelerometer"
    quantity = "acceleration"
    unit = "m/s^2"
    description = "three accelerometer axes at one point (three channels)"

    def sensors(self, entry, where):
        known_keys(where, entry, tuple(k for k in SENSOR_KEYS if k not in ("channel", "axis"))
                   + ("channels", "axes", "names"))
        name = entry.get("name")
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{where} field 'name': expected a non-empty name, got {name!r}")
        channels = entry.get("channels")
        if not (isinstance(channels, list) and len(channels) == 3):
            raise ConfigError(f"{where} field 'channels': expected 3 channel indices, got {channels!r}")
        axes = entry.get("axes", np.eye(3).tolist())
        if not (isinstance(axes, list) and len(axes) == 3):
            raise ConfigError(f"{where} field 'axes': expected 3 unit vectors, got {axes!r}")
        names = entry.get("names", [f"{name}_{a}" for a in "xyz"])
        if not (isinstance(names, list) and len(names) == 3):
            raise ConfigError(f"{where} field 'names': expected 3 names, got {names!r}")
        sens = entry.get("sensitivity")
        sens = sens if isinstance(sens, list) else [sens] * 3
        sign = entry.get("sign", 1)
        signs = sign if isinstance(sign, list) else [sign] * 3
        if len(sens) != 3 or len(signs) != 3:
            raise ConfigError(f"{where} fields 'sensitivity' and 'sign': one value or 3, got {sens!r} and {sign!r}")
        out = [single_axis_sensor(entry, f"{where} axis {k + 1}", kind="accelerometer", quantity=self.quantity,
                                  name=names[k], channel=channels[k], axis=axes[k], sensitivity=sens[k],
                                  sign=signs[k], group=name)
               for k in range(3)]
        gram = np.array([s.axis for s in out])
        if abs(np.linalg.det(gram)) < 0.5:  # three unit axes span less than half a unit volume
            raise ConfigError(f"{where} field 'axes': the three axes {axes!r} are not independent")
        return out


class HammerForce:
    """The impact hammer's load cell: ``channel`` and ``sensitivity`` (V/N), ``name`` (default
    "force"); no body or position, since every experiment records where the hammer hit. Given a
    ``body``, it is a force sensor fixed at a point of that body, along its ``axis``."""

    name = "force"
    quantity = "force"
    unit = "N"
    description = "the hammer's load cell (no position: the force point is given per experiment)"

    def sensors(self, entry, where):
        if "body" in entry:
            return [single_axis_sensor(entry, where, kind=self.name, quantity=self.quantity)]
        for field_name in ("position", "axis"):
            if field_name in entry:
                raise ConfigError(f"{where} field {field_name!r}: a hammer's force sensor has no {field_name} "
                                  "(the force point is given per experiment); give a 'body' for a fixed force sensor")
        known_keys(where, entry, SENSOR_KEYS)
        channel, sens, sign = entry.get("channel"), entry.get("sensitivity"), entry.get("sign", 1)
        if not isinstance(channel, int) or isinstance(channel, bool) or channel < 0:
            raise ConfigError(f"{where} field 'channel': expected a channel index >= 0, got {channel!r}")
        if sens is not None and (isinstance(sens, bool) or not isinstance(sens, (int, float)) or not sens > 0):
            raise ConfigError(f"{where} field 'sensitivity': expected V/N > 0, got {sens!r}")
        if sign not in (1, -1) or isinstance(sign, bool):
            raise ConfigError(f"{where} field 'sign': must be 1 or -1, got {sign!r}")
        name = entry.get("name", "force")
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{where} field 'name': expected a non-empty name, got {name!r}")
        return [Sensor(name=name, channel=channel, body=None, position=None, axis=None, sign=float(sign),
                       kind=self.name, serial=str(entry.get("serial", "")),
                       sensitivity=None if sens is None else float(sens), quantity=self.quantity)]


def builtin_sensor_types() -> list:
    return [SingleAxis("accelerometer", "acceleration", "m/s^2", "one accelerometer axis (one channel)"),
            Triaxial(),
            HammerForce(),
            SingleAxis("proximity", "displacement", "m", "a displacement (proximity) probe along one axis"),
            SingleAxis("voltage", "voltage", "V", "an auxiliary voltage channel")]
