"""odsuite built-in plugin: renderers."""
