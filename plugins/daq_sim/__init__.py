"""odsuite built-in plugin: daq_sim, the simulated thesis rig (the embedded default acquisition)."""

from odsuite.api import hookimpl


def _backend():
    from odsuite_plugins.daq_sim.simulator import SimulatedRig

    return SimulatedRig()


@hookimpl
def odsuite_register_daq_backends(registry):
    from odsuite_plugins.daq_sim.options import OPTIONS

    registry.add_deferred("sim", _backend, options=OPTIONS)  # imported on first use: every command starts at once

