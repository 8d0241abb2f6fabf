"""Hook specifications: the only way plugins, built-in or a lab's own, extend odsuite.

A plugin is a module (or object) with functions marked ``@odsuite.hookimpl`` and declared in the
``odsuite`` entry-point group of its distribution. Each registration hook receives a
:class:`~odsuite.contracts.registry.Registry` and calls ``registry.add(name, provider)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    import typer

    from odsuite.contracts.registry import Registry

hookspec = pluggy.HookspecMarker("odsuite")
hookimpl = pluggy.HookimplMarker("odsuite")


@hookspec
def odsuite_register_daq_backends(registry: Registry) -> None:
    """Add acquisition backends (e.g. ``sim``, ``ni``): objects with an ``acquire`` method."""


@hookspec
def odsuite_register_processing_steps(registry: Registry) -> None:
    """Add signal processing steps (conversion, offset, filters, integration, ...) by name."""


@hookspec
def odsuite_register_coordinate_solvers(registry: Registry) -> None:
    """Add solvers that turn processed sensor signals into generalized coordinates of bodies."""


@hookspec
def odsuite_register_models(registry: Registry) -> None:
    """Add model factories (e.g. ``thesis-dynamometer``): callables taking a rig, returning a model."""


@hookspec
def odsuite_register_effects(registry: Registry) -> None:
    """Add physical effects the diagnosis can fit (stiffness, damping, plate flexibility, ...)."""


@hookspec
def odsuite_register_renderers(registry: Registry) -> None:
    """Add renderers that draw movies or figures from generalized coordinates."""


@hookspec
def odsuite_register_sensor_types(registry: Registry) -> None:
    """Add sensor types: how a Systeminfo sensor code maps to a physical quantity and unit."""


@hookspec
def odsuite_register_rigs(registry: Registry) -> None:
    """Add rig definitions (bodies, plates, sensors, force channel, default model)."""


@hookspec
def odsuite_register_importers(registry: Registry) -> None:
    """Add importers of measurement files (legacy .DAT/.CTR, LabVIEW .lvm, UFF, ...)."""


@hookspec
def odsuite_register_commands(app: typer.Typer) -> None:
    """Add sub-commands to the ``odsuite`` command line."""
