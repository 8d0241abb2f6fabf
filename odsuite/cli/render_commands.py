"""Pictures and pages: render, report."""

from __future__ import annotations

from pathlib import Path

import typer

from odsuite.domain.errors import ConfigError
from odsuite.cli.app import (_check_output, _loop_progress, _print_json, _rendered_doc, app, console,
                             err_console)


@app.command("render")
def render_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Argument(..., help="Experiment name."),
    output: Path = typer.Option(..., "-o", "--output", help="Movie (.mp4, .gif) or figure (.png, .svg, .pdf)."),
    model: bool = typer.Option(False, "--model", help="Overlay the current model revision's motion (computed like `odsuite compare`)."),
    magnify: str = typer.Option(None, "--magnify", help="H_t,H_r (default: largest corner motion = 15 % of the plate, or the vibration's under a slower drift, which stays within a plate; at most 10 plates; 0 holds that motion still)."),
    view: str = typer.Option(None, "--view", help="Movie: AZ,EL degrees (EL -90 to 90). Projection: EYE[,THETA,PHI,PSI] (eye x|y|z). Angles -360 to 360."),
    figure: str = typer.Option(None, "--figure", help="A registered figure renderer (built in: overlay, projection, residuals; `odsuite plugins` lists all). Default: the movie renderer for the output's suffix."),
    workers: int = typer.Option(None, "--workers", help="Render processes for a movie (default: one per two cores)."),
    frame_step: int = typer.Option(None, "--frame-step", help="Samples per movie frame (default 1)."),
    slowdown: float = typer.Option(None, "--slowdown", help="Slow-motion factor: movie time / real time."),
    ods: float = typer.Option(None, "--ods", help="Animate the operating deflection shape at this frequency (Hz)."),
    reference: str = typer.Option(None, "--reference", help="With --ods: the reference sensor of an operating record's ODS (cross-spectra)."),
    start: float = typer.Option(None, "--start", help="Movie window start, s from the record's start (default: just before the hit)."),
    end: float = typer.Option(None, "--end", help="Movie window end, s (default: when the motion has decayed to a tenth)."),
    fps: float = typer.Option(None, "--fps", help="Movie frames per second (default 25; a GIF at most 50, at the nearest 100/k)."),
    duration: float = typer.Option(None, "--duration", help="Movie length, s (default 10; or set --frame-step / --slowdown)."),
    renderer_name: str = typer.Option(None, "--renderer", help="A registered renderer by name (e.g. mode-shape), as --figure."),
    mode: int = typer.Option(None, "--mode", help="mode-shape: the mode to animate (1 = lowest)."),
    f_min: float = typer.Option(None, "--fmin", help="mode-shape: lowest frequency of the identification band (Hz)."),
    f_max: float = typer.Option(None, "--fmax", help="mode-shape: highest frequency of the identification band (Hz)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Wireframe movie of an experiment's plates, or a figure, by a registered renderer."""
    from odsuite.contracts.plugins import registries
    from odsuite.contracts.renderers import RenderRequest, check_render_options, choose_renderer

    options = {"model": model, "magnify": magnify, "view": view, "workers": workers,
               "frame_step": frame_step, "slowdown": slowdown, "ods_hz": ods, "reference": reference, "start": start,
               "end": end, "fps": fps, "duration": duration, "mode": mode, "fmin": f_min, "fmax": f_max}
    # the renderer checks them too (for Python callers); here before the output and renderer are chosen
    options = check_render_options(options)
    _check_output(output, project, "-o")
    if renderer_name is not None and figure is not None:
        raise ConfigError("--renderer and --figure both name the renderer: give one")
    renderer = choose_renderer(registries().renderers, output, figure or renderer_name,
                               "figure" if figure else "movie")
    res = renderer.render(RenderRequest(project, experiment, output, options,
                                        progress=err_console.is_terminal and not as_json))
    _say_rendered(renderer, res, as_json)


@app.command("report")
def report_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    output: Path = typer.Option(..., "-o", "--output", help="The HTML page to write (self-contained)."),
    diagnosis: Path = typer.Option(None, "--diagnosis", help="Show this `odsuite diagnose --json` output "
                                   "(default: the diagnosis `odsuite diagnose` kept for the current revision "
                                   "and records, else one made now)."),
    no_diagnose: bool = typer.Option(False, "--no-diagnose", help="Leave the candidate effects out (a diagnosis "
                                     "made now takes ~20 s; `odsuite diagnose` keeps one for the report)."),
    no_movie: bool = typer.Option(False, "--no-movie", help="Leave the movie out."),
    movie_experiment: str = typer.Option(None, "--movie-experiment", help="Experiment of the movie "
                                         "(default: the one the model fits worst)."),
    frf_channel: list[str] = typer.Option(None, "--frf-channel", help="Channel whose FRF the page draws for "
                                          "each hammer record; repeatable (default: the driving point, the "
                                          "accelerometer nearest the force point)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """One self-contained HTML page: experiments, model against measurement, failures, candidate
    effects, error across revisions, a movie and a 3-D view (the registered page renderer 'report')."""
    from odsuite.contracts.plugins import registries
    from odsuite.contracts.renderers import RenderRequest, choose_renderer

    _check_output(output, project, "-o")
    renderer = choose_renderer(registries().renderers, output, "report")
    with _loop_progress() as bar:
        task = bar.add_task("report", total=None)
        options = {"diagnosis": diagnosis, "run_diagnosis": not no_diagnose, "movie": not no_movie,
                   "movie_experiment": movie_experiment, "frf_channels": frf_channel or None,
                   "on_stage": lambda what: bar.update(task, description=what)}
        res = renderer.render(RenderRequest(project, None, output, options))
    _say_rendered(renderer, res, as_json)


def _say_rendered(renderer, res, as_json: bool) -> None:
    """What a renderer wrote: one JSON document, or its notes and one line."""
    if as_json:
        _print_json(_rendered_doc(renderer, res))
        return
    for note in res.notes:
        err_console.print(f"note: {note}", highlight=False, soft_wrap=True)
    console.print(f"wrote {res.path} ({res.summary})", highlight=False, soft_wrap=True)
