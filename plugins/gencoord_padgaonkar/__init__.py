"""odsuite built-in plugin: gencoord_padgaonkar."""
