"""odsuite built-in plugin: renderers.

* ``movie``: off-screen pyvista wireframe movies of every plate of a rig (MP4, GIF fallback),
* ``projection``: the thesis Table 5.2 picture (initial position and Characteristic Forced Response),
* ``overlay``: measured vs model per generalized coordinate or per channel,
* ``residuals``: spectra of the measured signals and of their residual against the model.
"""

from odsuite import hookimpl


@hookimpl
def odsuite_register_renderers(registry):
    from .figures import comparison_figure, projection_figure, residual_spectra_figure  # on first use
    from .movie import render_movie

    registry.add("movie", render_movie)
    registry.add("projection", projection_figure)
    registry.add("overlay", comparison_figure)
    registry.add("residuals", residual_spectra_figure)
