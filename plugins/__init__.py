"""odsuite's built-in plugins, installed as the import package ``odsuite_plugins``.

Each sub-package is declared in the ``odsuite`` entry-point group, exactly as a lab's own plugin
package would be.
"""
