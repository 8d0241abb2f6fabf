"""odsuite built-in plugin: models, physical effects and the rigs they describe."""

import importlib
from pathlib import Path

from odsuite.api import hookimpl

#: Public names and the module defining them, imported on first use (`odsuite --help` starts fast).
#: The model and effect contracts (Model, Structure, Effect, Parameter, ...) come from odsuite.api and
#: odsuite.contracts.
_LAZY = {
    "builtin_effects": "effects",
    **dict.fromkeys(["thesis_car_2dof", "thesis_dynamometer"], "thesis"),
}

RIG_DIR = Path(__file__).with_name("rigs")

#: the models this plugin registers and where each is defined, and the names of
#: ``effects.builtin_effects()`` and ``sensor_types.builtin_sensor_types()``: registering imports none of them
SENSOR_TYPES = ("accelerometer", "triaxial_accelerometer", "force", "proximity", "voltage")
MODELS = {"rigid-bodies": "rigid_bodies:rigid_bodies", "thesis-dynamometer": "thesis:thesis_dynamometer",
          "thesis-car-2dof": "thesis:thesis_car_2dof"}
EFFECTS = ("stiffness", "spring_stiffness", "damping", "nonlinear_stiffness", "mass_properties", "plate_flexibility",
           "plate_flexibility_free", "sensor_gain", "sensor_polarity", "sensor_orientation", "sensor_position",
           "sensor_dynamics", "impact_location", "force_gain", "base_motion", "missing_mode", "coupled_mode",
           "mounted_mode", "channel_delay", "scan_skew", "channel_swap", "measured-modal-damping")

__all__ = ["builtin_effects", "thesis_car_2dof", "thesis_dynamometer"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _sensor_types() -> dict:
    from .sensor_types import builtin_sensor_types

    return {sensor_type.name: sensor_type for sensor_type in builtin_sensor_types()}


@hookimpl
def odsuite_register_sensor_types(registry):
    for name in SENSOR_TYPES:  # each made on first use: every command starts at once
        registry.add_deferred(name, lambda name=name: _sensor_types()[name])


def _rig(path: Path, sensor_types):
    from odsuite.api import ConfigError, load_rig

    rig = load_rig(path, sensor_types)
    if rig.name != path.stem:
        raise ConfigError(f"{path}: rig {rig.name!r} is registered under its file's name {path.stem!r}; "
                          "name the file after the rig")
    return rig


@hookimpl
def odsuite_register_rigs(registry):
    # each file named after its rig, read on first use: every command starts at once
    for path in sorted(RIG_DIR.glob("*.toml")):
        registry.add_deferred(path.stem, lambda path=path, types=registry.sensor_types: _rig(path, types))


def _model(name: str):
    module, attribute = MODELS[name].split(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), attribute)


def _effects() -> dict:
    from .effects import builtin_effects

    return {effect.name: effect for effect in builtin_effects()}


@hookimpl
def odsuite_register_models(registry):
    for name in MODELS:  # each imported on first use: every command starts at once
        registry.add_deferred(name, lambda name=name: _model(name))


@hookimpl
def odsuite_register_effects(registry):
    for name in EFFECTS:
        registry.add_deferred(name, lambda name=name: _effects()[name])
