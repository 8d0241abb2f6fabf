"""odsuite built-in plugin: daq_ni."""
