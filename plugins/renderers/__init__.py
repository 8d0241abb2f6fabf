"""odsuite built-in plugin: renderers.

* ``movie``: off-screen pyvista wireframe movies of every plate of a rig (MP4, GIF fallback),
* ``projection``: the thesis Table 5.2 picture (initial position and Characteristic Forced Response),
* ``overlay``: measured vs model per generalized coordinate or per channel,
* ``residuals``: spectra of the measured signals and of their residual against the model,
* ``report``: the project's self-contained HTML report.
"""

from odsuite.api import hookimpl

#: the renderers ``providers.builtin_renderers`` makes, named here so that registering imports
#: neither them nor the renderer contract
RENDERERS = ("movie", "mode-shape", "projection", "overlay", "residuals", "frf", "stabilisation", "mac",
             "history", "report")


def _renderer(name: str):
    from .providers import builtin_renderers

    return next(r for r in builtin_renderers() if r.name == name)


@hookimpl
def odsuite_register_renderers(registry):
    for name in RENDERERS:  # each made on first use: every command starts at once
        registry.add_deferred(name, lambda name=name: _renderer(name))
