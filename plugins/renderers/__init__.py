"""odsuite built-in plugin: renderers.

* ``movie``: off-screen pyvista wireframe movies of every plate of a rig (MP4, GIF fallback),
* ``projection``: the thesis Table 5.2 picture (initial position and Characteristic Forced Response),
* ``overlay``: measured vs model per generalized coordinate or per channel,
* ``residuals``: spectra of the measured signals and of their residual against the model,
* ``report``: the project's self-contained HTML report.
"""

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_renderers(registry):
    from .providers import builtin_renderers  # on first use: `odsuite --help` starts fast

    for renderer in builtin_renderers():
        registry.add(renderer.name, renderer)
