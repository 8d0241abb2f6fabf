"""odsuite built-in plugin: daq_sim."""
