"""A lab's own odsuite plugin, written only against odsuite's public contracts.

It registers an effect (a point mass clamped to a body), a renderer (the generalized coordinates
of an experiment as a CSV table), a coordinate solver (weighted least squares, used where a rig
file names it), an importer (the lab's CSV of SI values) and a sensor type (accelerometers given
in mV/g, as on their datasheets), exactly as a lab's installable package would.
"""

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_effects(registry):
    from .effects import AddedPointMass  # on first use, so `odsuite --help` stays fast

    registry.add(AddedPointMass.name, AddedPointMass())


@hookimpl
def odsuite_register_renderers(registry):
    from .renderers import CoordinatesCsv

    registry.add(CoordinatesCsv.name, CoordinatesCsv())


@hookimpl
def odsuite_register_coordinate_solvers(registry):
    from .solvers import WeightedLeastSquares

    registry.add(WeightedLeastSquares.name, WeightedLeastSquares())


@hookimpl
def odsuite_register_importers(registry):
    from .importers import SiCsvImporter

    registry.add(SiCsvImporter.name, SiCsvImporter())


@hookimpl
def odsuite_register_sensor_types(registry):
    from .sensor_types import DatasheetAccelerometer

    registry.add(DatasheetAccelerometer.name, DatasheetAccelerometer())
