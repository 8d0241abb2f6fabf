"""odsuite built-in plugin: filters (the thesis's Signal Processor steps, Ch. 4.3)."""

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_processing_steps(registry) -> None:
    from odsuite_plugins.filters.steps import PROVIDERS  # on first use: `odsuite --help` starts fast

    for name, provider in PROVIDERS.items():
        registry.add(name, provider)
