"""odsuite built-in plugin: models, physical effects and the rigs they describe."""

import importlib
from pathlib import Path

from odsuite.api import hookimpl
from odsuite.api import load_rig

#: Public names and the module defining them, imported on first use (`odsuite --help` starts fast).
#: The model and effect contracts (Model, Structure, Effect, Parameter, ...) come from odsuite.api and
#: odsuite.contracts.
_LAZY = {
    "builtin_effects": "effects",
    **dict.fromkeys(["thesis_car_2dof", "thesis_dynamometer"], "thesis"),
}

RIG_DIR = Path(__file__).with_name("rigs")

__all__ = ["builtin_effects", "thesis_car_2dof", "thesis_dynamometer"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@hookimpl
def odsuite_register_sensor_types(registry):
    from .sensor_types import builtin_sensor_types

    for sensor_type in builtin_sensor_types():
        registry.add(sensor_type.name, sensor_type)


@hookimpl
def odsuite_register_rigs(registry):
    for path in sorted(RIG_DIR.glob("*.toml")):
        rig = load_rig(path, registry.sensor_types)
        registry.add(rig.name, rig)


@hookimpl
def odsuite_register_models(registry):
    from .rigid_bodies import rigid_bodies
    from .thesis import thesis_car_2dof, thesis_dynamometer

    registry.add("rigid-bodies", rigid_bodies)
    registry.add("thesis-dynamometer", thesis_dynamometer)
    registry.add("thesis-car-2dof", thesis_car_2dof)


@hookimpl
def odsuite_register_effects(registry):
    from .effects import builtin_effects

    for effect in builtin_effects():
        registry.add(effect.name, effect)
