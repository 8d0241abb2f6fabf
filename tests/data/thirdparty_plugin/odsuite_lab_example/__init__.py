"""A lab's own odsuite plugin, written only against odsuite's public contracts.

It registers an effect (a point mass clamped to a body) and a renderer (the generalized
coordinates of an experiment as a CSV table), exactly as a lab's installable package would.
"""

from odsuite import hookimpl


@hookimpl
def odsuite_register_effects(registry):
    from .effects import AddedPointMass  # on first use, so `odsuite --help` stays fast

    registry.add(AddedPointMass.name, AddedPointMass())


@hookimpl
def odsuite_register_renderers(registry):
    from .renderers import CoordinatesCsv

    registry.add(CoordinatesCsv.name, CoordinatesCsv())
