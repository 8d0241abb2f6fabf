"""odsuite built-in plugin: filters."""
