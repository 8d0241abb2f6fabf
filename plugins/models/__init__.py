"""odsuite built-in plugin: models, physical effects and the rigs they describe."""

from pathlib import Path

from odsuite import hookimpl
from odsuite.core.rig import load_rig

from .multibody import (COORDS, Chain, FlexibleMode, Input, Model, Modes, Output, RigidBody,
                        SensorDynamics, SpringDamper, StateSpace, Structure, point_map)
from .effects import Effect, Parameter, builtin_effects
from .simulation import simulate, simulate_state_space
from .thesis import thesis_car_2dof, thesis_dynamometer

RIG_DIR = Path(__file__).with_name("rigs")

__all__ = ["COORDS", "Chain", "Effect", "Parameter", "builtin_effects", "FlexibleMode", "Input", "Model", "Modes", "Output", "RigidBody",
           "SensorDynamics", "SpringDamper", "StateSpace", "Structure", "point_map", "simulate",
           "simulate_state_space", "thesis_car_2dof", "thesis_dynamometer"]


@hookimpl
def odsuite_register_rigs(registry):
    for path in sorted(RIG_DIR.glob("*.toml")):
        rig = load_rig(path)
        registry.add(rig.name, rig)


@hookimpl
def odsuite_register_models(registry):
    registry.add("thesis-dynamometer", thesis_dynamometer)
    registry.add("thesis-car-2dof", thesis_car_2dof)


@hookimpl
def odsuite_register_effects(registry):
    for effect in builtin_effects():
        registry.add(effect.name, effect)
