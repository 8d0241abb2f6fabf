"""odsuite built-in plugin: a continuous beam (1-D finite elements) and the effects a slender
beam model may lack, written against the core contracts as a lab's own model family would be."""


from odsuite.api import hookimpl

#: the names of ``effects.beam_effects()``, so that registering imports none of them
EFFECTS = ("beam-shear-rotary", "beam-sensor-mass", "beam-supports", "beam-supports-alike",
           "beam-stiffness-scale", "beam-mass-scale", "beam-modal-damping", "beam-positions")


def _model():
    from .model import beam_model

    return beam_model


def _effects() -> dict:
    from .effects import beam_effects

    return {effect.name: effect for effect in beam_effects()}


@hookimpl
def odsuite_register_models(registry):
    registry.add_deferred("beam", _model)  # imported on first use: every command starts at once


@hookimpl
def odsuite_register_effects(registry):
    for name in EFFECTS:
        registry.add_deferred(name, lambda name=name: _effects()[name])
