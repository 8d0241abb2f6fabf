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
        from .motion import magnification_words

        request.unknown_options(MOVIE_OPTIONS, self.name)
        res = render_experiment(request.project, request.experiment, request.output, progress=request.progress,
                                registries=request.registries, **{k: v for k, v in request.options.items() if v is not None})
        if getattr(res, "frame_step", None) == 0:  # a shape on the project's geometry
            return Rendered(res.path, f"{res.n_frames} frames at {res.fps:g} fps ({res.n_frames / res.fps:.1f} s), "
                                      "the shape on the project's geometry", tuple(res.notes))
        return Rendered(res.path, f"{res.n_frames} frames at {res.fps:g} fps ({res.n_frames / res.fps:.1f} s), "
                                  f"{res.slowdown:,.0f} times slower than real time, {magnification_words(res.magnify)}",
                        tuple(res.notes))


class FigureRenderer:
    """One of the experiment figures of :func:`.experiment.render_experiment`."""

    kind = "figure"
    suffixes = (".png", ".svg", ".pdf")

    def __init__(self, name: str, description: str) -> None:
        self.name = name
        self.description = description

    def render(self, request: RenderRequest) -> Rendered:
        from .experiment import render_experiment

        request.unknown_options(FIGURE_OPTIONS, self.name)
        path = render_experiment(request.project, request.experiment, request.output, figure=self.name,
                                 progress=request.progress, registries=request.registries,
                                 **{k: v for k, v in request.options.items() if v is not None})
        return Rendered(path, f"{self.name} figure of {request.experiment}")


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
        return Rendered(res.path, f"{res.size_bytes / 2**20:.1f} MiB; error {res.error:.4f}", tuple(res.notes))


class ModeShapeRenderer:
    name = "mode-shape"
    description = ("a mode shape identified from an experiment's responses (output-only) moving on the project's "
                   "geometry (MP4, or GIF); to .uff: the geometry (15/82) with every mode (55) for other tools")
    kind = "movie"
    suffixes = (".mp4", ".gif", ".uff")
    OPTIONS = frozenset({"mode", "fmin", "fmax", "max_order", "view", "workers", "fps"})

    def render(self, request: RenderRequest) -> Rendered:
        from .shapes import render_mode_shape

        request.unknown_options(self.OPTIONS, self.name)
        res, n, notes = render_mode_shape(request.project, request.experiment, request.output,
                                          progress=request.progress, registries=request.registries,
                                          **{k: v for k, v in request.options.items()
                                             if v is not None and v is not False})
        if isinstance(res, Path):
            return Rendered(res, f"geometry (UFF 15/82) and {n} mode shapes (UFF 55)", tuple(notes))
        return Rendered(res.path, f"{res.n_frames} frames at {res.fps:g} fps ({res.n_frames / res.fps:.1f} s), "
                                  f"mode {request.options.get('mode')} of {n}", tuple(res.notes) + tuple(notes))


def builtin_renderers() -> list:
    return [MovieRenderer(), ModeShapeRenderer(),
            FigureRenderer("projection", "the thesis's 2-D projection (Eq. 4.25): rest and characteristic forced response"),
            FigureRenderer("overlay", "generalized coordinates, measured against the model, over time"),
            FigureRenderer("residuals", "spectra of the measured coordinates and of their residual against the model"),
            ReportRenderer()]
