"""odsuite built-in plugin: daq_sim, the simulated thesis rig (the embedded default acquisition)."""

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_daq_backends(registry):
    from odsuite_plugins.daq_sim.simulator import SimulatedRig

    registry.add("sim", SimulatedRig())

