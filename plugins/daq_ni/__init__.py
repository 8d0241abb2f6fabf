"""odsuite built-in plugin: daq_ni, acquisition with National Instruments cards through NI-DAQmx.

``nidaqmx`` is imported only when a record is taken, so this plugin loads on machines without it.
"""

from odsuite.api import hookimpl


def _backend():
    from odsuite_plugins.daq_ni.backend import NiDaq

    return NiDaq()


@hookimpl
def odsuite_register_daq_backends(registry):
    from odsuite_plugins.daq_ni.options import OPTIONS

    registry.add_deferred("ni", _backend, options=OPTIONS)  # imported on first use: every command starts at once
