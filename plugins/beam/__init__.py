"""odsuite built-in plugin: a continuous beam (1-D finite elements) and the effects a slender
beam model may lack, written against the core contracts as a lab's own model family would be."""

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_models(registry):
    from .model import beam_model

    registry.add("beam", beam_model)


@hookimpl
def odsuite_register_effects(registry):
    from .effects import beam_effects

    for effect in beam_effects():
        registry.add(effect.name, effect)
