"""The simulator's truth: the rig's registered default model, optionally altered by registered effects."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from odsuite.core.errors import ConfigError
from odsuite.core.rig import Rig


def truth_model(rig: Rig, effects: Sequence[tuple[str, Mapping[str, Any]]] = ()):
    """The rig's default model with ``effects`` [(name, parameters), ...] applied in order."""
    from odsuite.core.plugins import registries

    if not rig.default_model:
        raise ConfigError(f"rig {rig.name!r} names no default_model; the simulator needs one as its truth")
    regs = registries()
    model = regs.models.get(rig.default_model)(rig)
    for name, params in effects:
        model = regs.effects.get(name).apply(model, dict(params))
    return model


def model_truth(rig: Rig, effects: Sequence[tuple[str, Mapping[str, Any]]] = ()):
    """A truth function for :class:`~odsuite_plugins.daq_sim.simulator.SimulatedRig`: accelerations
    of every rig accelerometer (along its axis, at its position) to a force record on the body the
    force point is on, simulated exactly with a first-order hold."""
    from odsuite.core.model import Input, Output
    from odsuite.core.simulation import simulate

    model = truth_model(rig, effects)
    outputs = [Output.sensor(s) for s in rig.accelerometers]

    def truth(force: np.ndarray, fs: float, point: np.ndarray, direction: np.ndarray,
              body: str | None = None) -> np.ndarray:
        hit = Input.force(point, direction, body=rig.force_body(point, body))
        return simulate(model, [hit], force, fs, outputs, hold="foh")

    return truth


def rig_file_truth(rig: Rig, path: str):
    """A truth from another rig file (a user's hidden change) with the project rig's channels:
    accelerations in ``rig.accelerometers`` order, and {channel: (sensitivity, sign)} of the
    sensors whose true sensitivity or sign differ from the project rig's."""
    from odsuite.core.plugins import registries
    from odsuite.core.rig import load_rig

    true = load_rig(path, registries().sensor_types)
    by_channel = {s.channel: s for s in true.accelerometers}
    order = []
    changed: dict[int, tuple[float, float]] = {}
    for sensor in rig.accelerometers:
        other = by_channel.get(sensor.channel)
        if other is None:
            raise ConfigError(f"--truth {path}: no accelerometer on channel {sensor.channel} "
                              f"(the project rig's {sensor.name!r})")
        order.append(true.accelerometers.index(other))
        if other.sensitivity is not None and (other.sensitivity, other.sign) != (sensor.sensitivity, sensor.sign):
            changed[sensor.channel] = (other.sensitivity, other.sign)
    if true.force_channel != rig.force_channel:
        raise ConfigError(f"--truth {path}: force channel {true.force_channel}, the project rig's is {rig.force_channel}")
    simulate_true = model_truth(true)

    def truth(force: np.ndarray, fs: float, point: np.ndarray, direction: np.ndarray,
              body: str | None = None) -> np.ndarray:
        return simulate_true(force, fs, point, direction, body)[:, order]

    return truth, changed
