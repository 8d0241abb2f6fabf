"""The renderers this plugin registers, behind the renderer contract (odsuite.contracts.renderers)."""

from __future__ import annotations

from pathlib import Path

from odsuite.contracts.renderers import Rendered, RenderRequest

MOVIE_OPTIONS = frozenset({"model", "magnify", "view", "workers", "frame_step", "slowdown", "ods_hz", "reference",
                           "start", "end", "fps", "duration"})
FIGURE_OPTIONS = frozenset({"model", "magnify", "view"})
REPORT_OPTIONS = frozenset({"diagnosis", "run_diagnosis", "movie", "movie_experiment", "frf_channels", "on_stage"})


class MovieRenderer:
    name = "movie"
    description = "off-screen wireframe movie of every plate (MP4, or GIF), the model's motion overlaid on request"
    kind = "movie"
    suffixes = (".mp4", ".gif")

    def render(self, request: RenderRequest) -> Rendered:
        from .experiment import render_experiment
        from .motion import magnification_words, speed_words

        options = request.checked_options(MOVIE_OPTIONS, self.name)
        res = render_experiment(request.project, request.experiment, request.output, progress=request.progress,
                                registries=request.registries, **options)
        if getattr(res, "frame_step", None) == 0:  # a shape on the project's geometry
            return Rendered(res.path, f"{_frames(res)}, the shape on the project's geometry", tuple(res.notes))
        return Rendered(res.path, f"{_frames(res)}, {speed_words(res.slowdown)}, {magnification_words(res.magnify)}",
                        tuple(res.notes))


def _frames(res) -> str:
    """A movie's frames and the rate it plays at (a GIF's: 33.33 for 30 asked)."""
    from .movie import seconds_text

    return (f"{res.n_frames} frame{'' if res.n_frames == 1 else 's'} at {res.fps:.4g} fps "
            f"({seconds_text(res.n_frames / res.fps)})")


class FigureRenderer:
    """One of the experiment figures of :func:`.experiment.render_experiment`."""

    kind = "figure"
    suffixes = (".png", ".svg", ".pdf")

    def __init__(self, name: str, description: str) -> None:
        self.name = name
        self.description = description

    def render(self, request: RenderRequest) -> Rendered:
        from .experiment import render_experiment

        options = request.checked_options(FIGURE_OPTIONS, self.name)
        path = render_experiment(request.project, request.experiment, request.output, figure=self.name,
                                 progress=request.progress, registries=request.registries, **options)
        return Rendered(path, f"{self.name} figure of {request.experiment}")


class DrawnFigure:
    """A figure of numbers the core computed and hands over as the option ``data`` names (the FRFs
    of ``odsuite frf``, the modes of ``odsuite modes``, ...); the other options are the drawing
    function's keywords. ``compute(request)``, where given, finds the numbers in the project when
    none are handed over."""

    kind = "figure"
    suffixes = (".png", ".svg", ".pdf")

    def __init__(self, name: str, description: str, data: str, draw: str, options: frozenset[str], *,
                 compute=None, made_by: str = "") -> None:
        self.name, self.description = name, description
        self.data, self.draw, self.options, self.compute = data, draw, options | {data}, compute
        self.made_by = made_by

    def render(self, request: RenderRequest) -> Rendered:
        from importlib import import_module

        from odsuite.api import ConfigError

        request.unknown_options(self.options, self.name)
        # an option this figure does not take passes unknown_options only unset (None or False): not handed over
        kwargs = {k: v for k, v in request.options.items() if v is not None and k != self.data and k in self.options}
        data = request.options.get(self.data)
        if data is None and self.compute is None:
            raise ConfigError(f"renderer {self.name!r} draws the numbers it is given (option {self.data!r}), "
                              f"not a stored experiment: use {self.made_by}")
        if data is None:
            data = self.compute(request)
        module, _, function = self.draw.partition(":")
        getattr(import_module(module, __package__), function)(data, request.output, **kwargs)
        return Rendered(Path(request.output), f"{self.name} figure")


def _history_of(request: RenderRequest):
    from odsuite.api import history, open_project

    with open_project(request.project, registries=request.registries) as p:
        return history(p)


class ReportRenderer:
    name = "report"
    description = ("one self-contained HTML page: experiments, model against measurement, failures, candidate "
                   "effects, error across revisions and a movie")
    kind = "page"
    suffixes = (".html", ".htm")

    def render(self, request: RenderRequest) -> Rendered:
        from .report import build_report

        request.unknown_options(REPORT_OPTIONS, self.name)
        opts = dict(request.options)
        res = build_report(request.project, request.output, registries=request.registries,
                           diagnosis=opts.get("diagnosis"),
                           run_diagnosis=opts.get("run_diagnosis", True), movie=opts.get("movie", True),
                           movie_experiment=opts.get("movie_experiment"), frf_channels=opts.get("frf_channels"),
                           progress=opts.get("on_stage"))
        # NaN: no rig, so no model; a rig-less page of hammer records is not output-only
        error = (f"error {res.error:.4f}" if res.error == res.error else
                 "no rig: no model" if "hammer" in res.sections else "output-only: no model")
        return Rendered(res.path, f"{res.size_bytes / 2**20:.1f} MiB; {error}", tuple(res.notes))


class ModeShapeRenderer:
    name = "mode-shape"
    description = ("a mode shape identified from an experiment's responses (output-only) moving on the project's "
                   "geometry (MP4, or GIF); to .uff: the geometry (15/82) with every mode (55) for other tools")
    kind = "movie"
    suffixes = (".mp4", ".gif", ".uff", ".html")
    OPTIONS = frozenset({"mode", "fmin", "fmax", "max_order", "view", "workers", "fps", "reference"})

    def render(self, request: RenderRequest) -> Rendered:
        from .shapes import render_mode_shape

        options = request.checked_options(self.OPTIONS, self.name)
        res, n, notes = render_mode_shape(request.project, request.experiment, request.output,
                                          progress=request.progress, registries=request.registries,
                                          **{k: v for k, v in options.items() if v is not False})
        if isinstance(res, Path) and res.suffix.lower() in (".html", ".htm"):
            return Rendered(res, f"interactive 3-D view of {n} mode shapes", tuple(notes))
        if isinstance(res, Path):
            return Rendered(res, f"geometry (UFF 15/82) and {n} mode shapes (UFF 55)", tuple(notes))
        return Rendered(res.path, f"{_frames(res)}, mode {request.options.get('mode')} of {n}",
                        tuple(res.notes) + tuple(notes))


def builtin_renderers() -> list:
    return [MovieRenderer(), ModeShapeRenderer(),
            FigureRenderer("projection", "the thesis's 2-D projection (Eq. 4.25): rest and characteristic forced response"),
            FigureRenderer("overlay", "generalized coordinates, measured against the model, over time"),
            FigureRenderer("residuals", "spectra of the measured coordinates and of their residual against the model"),
            DrawnFigure("frf", "FRFs: magnitude, phase and coherence per output", "frf",
                        ".modal_figures:frf_figure",
                        frozenset({"band_hz", "outputs", "title", "model_hz", "f_range", "size", "dpi",
                                   "model_H"}),
                        made_by="`odsuite frf --figure`"),
            DrawnFigure("stabilisation", "stabilisation diagram: poles per model order and the chosen modes", "modes",
                        ".modal_figures:stabilisation_figure", frozenset({"freq", "H", "title", "background", "size", "dpi", "log_frequency"}),
                        made_by="`odsuite modes --figure`"),
            DrawnFigure("mac", "MAC matrix: two sets of mode shapes, each value in its cell", "mac",
                        ".modal_figures:mac_figure",
                        frozenset({"labels_a", "labels_b", "title", "xlabel", "ylabel", "dpi"}),
                        made_by="`odsuite modes --mac-figure`"),
            DrawnFigure("history", "model error per revision, with the noise floor", "history",
                        ".history_figure:history_figure", frozenset(), compute=_history_of),
            ReportRenderer()]
