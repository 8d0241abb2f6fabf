"""odsuite built-in plugin: filters (the thesis's Signal Processor steps, Ch. 4.3)."""

from odsuite.api import hookimpl


#: the steps ``steps.PROVIDERS`` defines, named here so that registering imports none of them
STEPS = ("convert", "invert", "micro", "scale", "offset", "moving-average", "iir", "integrate")


def _step(name: str):
    from odsuite_plugins.filters.steps import PROVIDERS

    return PROVIDERS[name]


@hookimpl
def odsuite_register_processing_steps(registry) -> None:
    for name in STEPS:  # each imported on first use: every command starts at once
        registry.add_deferred(name, lambda name=name: _step(name))
