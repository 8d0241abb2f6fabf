"""The simulator's truth: the rig's registered default model, optionally altered by registered effects."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import Rig


def truth_model(rig: Rig, effects: Sequence[tuple[str, Mapping[str, Any]]] = ()):
    """The rig's default model with ``effects`` [(name, parameters), ...] applied in order."""
    from odsuite.contracts.plugins import registries

    if not rig.default_model:
        raise ConfigError(f"rig {rig.name!r} names no default_model; the simulator needs one as its truth")
    regs = registries()
    model = regs.models.get(rig.default_model)(rig)
    for name, params in effects:
        model = regs.effects.get(name).apply(model, dict(params))
    return model


class ModelTruth:
    """A truth for :class:`~odsuite_plugins.daq_sim.simulator.SimulatedRig`: accelerations of
    every accelerometer of ``rig`` (along its axis, at its position; columns in ``order``, default
    the rig's) simulated exactly with a first-order hold, from a force record (``__call__``) or
    from the ground's rigid motion (``ground``)."""

    def __init__(self, rig: Rig, model, order: Sequence[int] | None = None) -> None:
        from odsuite.api import Output

        self.rig, self.model = rig, model
        sensors = rig.accelerometers
        self.outputs = [Output.sensor(sensors[k]) for k in (order if order is not None else range(len(sensors)))]

    def __call__(self, force: np.ndarray, fs: float, point: np.ndarray, direction: np.ndarray,
                 body: str | None = None) -> np.ndarray:
        from odsuite.api import Input
        from odsuite.api import simulate

        hit = Input.force(point, direction, body=self.rig.force_body(point, body))
        return simulate(self.model, [hit], force, fs, self.outputs, hold="foh")

    def ground(self, accelerations: np.ndarray, fs: float) -> np.ndarray:
        """Absolute accelerations to the ground's (samples x 6: m/s^2 along the rig's x, y, z, then
        rad/s^2 about them through the rig origin)."""
        from odsuite.api import Input
        from odsuite.api import simulate

        axes = np.eye(3)
        inputs = [Input.ground_acceleration(a) for a in axes] + [Input.ground_angular_acceleration(a) for a in axes]
        return simulate(self.model, inputs, accelerations, fs, self.outputs, hold="foh")


def model_truth(rig: Rig, effects: Sequence[tuple[str, Mapping[str, Any]]] = ()) -> ModelTruth:
    """The truth of the rig's default model with ``effects`` applied."""
    return ModelTruth(rig, truth_model(rig, effects))


def rig_file_truth(rig: Rig, path: str) -> tuple[ModelTruth, dict[int, tuple[float, float]]]:
    """A truth from another rig file (a user's hidden change) with the project rig's channels:
    accelerations in ``rig.accelerometers`` order, and {channel: (sensitivity, sign)} of the
    sensors whose true sensitivity or sign differ from the project rig's."""
    from odsuite.contracts.plugins import registries
    from odsuite.api import load_rig

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
    return ModelTruth(true, truth_model(true), order), changed
