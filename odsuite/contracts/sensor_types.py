"""The sensor-type contract: what a rig file's ``[[sensors]]`` entry of a given ``kind`` declares.

A provider registered through ``odsuite_register_sensor_types`` has:

- ``name`` (str): the ``kind`` a rig file writes; ``description`` (str);
- ``quantity`` (str): what it measures ("acceleration", "force", "displacement", "voltage", or a
  lab's own), and ``unit`` (str): that quantity's SI unit;
- ``sensors(entry, where) -> list[Sensor]``: the single-axis sensors, one per channel, that the
  entry (the parsed TOML table) declares, in SI (positions in m, rig frame; unit axes;
  sensitivities in V per SI unit). Bad fields raise :class:`~odsuite.domain.errors.ConfigError`
  naming ``where`` (the file and entry), the field and the value.
  :func:`odsuite.domain.rig.single_axis_sensor` validates the usual fields.

Sensor types are registered before rigs, so a plugin's rig files may use any registered kind: the
registry a rig-registration hook receives has them as ``registry.sensor_types``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol


class SensorKind(Protocol):
    """What every registered sensor type has (checked when a plugin registers one)."""

    name: str
    description: str
    quantity: str
    unit: str

    def sensors(self, entry: Mapping[str, Any], where: str) -> list: ...


PROTOCOL = SensorKind
