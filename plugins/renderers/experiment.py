"""Render a stored experiment: its generalized coordinates (derived kind "gencoords") as a movie
or a figure, optionally with the model's motion, computed by the comparison (the current model
revision driven by the measured force, predicted at the sensors, through the same chain and solver
as the measurement)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, plain_number
from odsuite.contracts.renderers import check_view_angles, parse_view
from odsuite.api import COORDINATE_UNITS, COORDINATES

from .figures import comparison_figure, projection_figure, residual_spectra_figure
from .motion import check_coords, contact_index, event_window
from .movie import MovieResult, render_movie
from .scene import Hammer

MEASURED_KIND = "gencoords"
FIGURES = ("overlay", "projection", "residuals")
SUFFIX = "_at_g"
#: Default movie length (s) of the window around the hit: long enough to follow the motion,
#: short enough to watch (about 250 frames at 25 fps).
DEFAULT_DURATION = 10.0


def _coords(project, experiment: str, kind: str, hint: str) -> dict[str, np.ndarray]:
    if kind not in project.derived_kinds(experiment):
        raise ConfigError(f"{project.path}: experiment {experiment!r} has no {kind!r} data; {hint}")
    arrays = project.read_derived(experiment, kind)
    coords = {k[: -len(SUFFIX)]: np.asarray(v) for k, v in arrays.items() if k.endswith(SUFFIX)}
    if not coords:
        raise ConfigError(f"{project.path}: experiment {experiment!r}: {kind!r} holds no '<body>{SUFFIX}' dataset")
    return coords


def _why_no_coordinates(project, experiment: str) -> str:
    """An unprocessed experiment, or a processed one whose bodies' sensors cannot give their motion."""
    from odsuite.contracts.solvers import body_solvers

    if "processed" not in project.derived_kinds(experiment):
        return "run `odsuite process` first"
    notes = body_solvers(project.rig, [s.name for s in project.rig.sensors], project.registries.coordinate_solvers)[1]
    return f"no body's motion can be solved from its sensors ({'; '.join(notes)})" if notes else \
        "run `odsuite process` first"


def render_experiment(
    project_path: str | Path,
    experiment: str,
    output: str | Path,
    *,
    model: bool = False,
    magnify: tuple[float, float] | None = None,
    view: str | None = None,
    figure: str | None = None,
    registries=None,
    workers: int | None = None,
    frame_step: int | None = None,
    slowdown: float | None = None,
    progress: bool = True,
    ods_hz: float | None = None,
    reference: str | None = None,
    start: float | None = None,
    end: float | None = None,
    fps: float | None = None,
    duration: float | None = None,
) -> MovieResult | Path:
    """A movie (``figure`` None) or a figure of one experiment of a project.

    ``view``: for movies "AZ,EL" in degrees; for the projection figure "EYE[,THETA,PHI,PSI]" (eye
    axis x, y or z and the Eq. 4.25 viewpoint angles in degrees). ``model`` adds the model's
    motion (overlay and residual figures always need it); the measured motion then comes from the
    comparison too, so both sides went through the same chain and solver. ``ods_hz``: animate the
    operating deflection shape at that frequency instead of the record: from the measured FRFs, or
    for an operating record (no force) or with a ``reference`` sensor from the cross-spectra to it.
    Movies: ``start``/``end`` (s from the record's start) choose the window, by default from just
    before the hit until the motion has decayed to a tenth; ``duration`` (s, default 10) or
    ``frame_step``/``slowdown`` the playback speed at ``fps`` (default 25).
    """
    from odsuite.api import open_project

    if figure is not None and figure not in FIGURES:
        raise ConfigError(f"--figure: expected one of {', '.join(FIGURES)}, got {figure!r}")
    with open_project(project_path, registries=registries) as project:
        if project.rig is None and ods_hz is not None and figure is None and not model:
            from odsuite.api import project_geometry

            if project_geometry(project) is not None:  # a structure that is not a set of plates
                from .shapes import geometry_ods_movie

                return geometry_ods_movie(project, experiment, output, ods_hz=ods_hz, reference=reference,
                                          view=view, workers=workers, fps=fps, progress=progress)
        _check_experiment(project, experiment)
        exp = project.experiment(experiment)
        fs = exp.sampling_rate
        model_coords = corrected_coords = None
        ods_source = None
        if reference is not None and ods_hz is None:
            raise ConfigError("--reference names the ODS's reference sensor: give --ods HZ too")
        if ods_hz is not None:
            if figure is not None or model:
                raise ConfigError("--ods draws a movie of the measured shape: drop --figure and --model")
            coords, fs, ods_hz, ods_source = _ods(project, experiment, exp, ods_hz, reference)
        elif model or figure in ("overlay", "residuals"):
            coords, model_coords, corrected_coords = _with_model(project, experiment, movie=figure is None)
        else:
            coords = _coords(project, experiment, MEASURED_KIND, _why_no_coordinates(project, experiment))
        force = None
        if figure == "projection" and exp.excitation is not None:
            force = exp.raw(channels=exp.excitation.force_channel)
        hammer = _hammer(project, experiment, exp, coords) if figure is None and ods_hz is None else None
        rig = project.rig
    if figure is None:
        return _movie(rig, coords, fs, output, experiment, model_coords=model_coords,
                      corrected_coords=corrected_coords, magnify=magnify,
                      view=view, workers=workers, frame_step=frame_step, slowdown=slowdown, progress=progress,
                      hammer=hammer, ods_hz=ods_hz, ods_source=ods_source, start=start, end=end, fps=fps,
                      duration=duration)
    if any(v is not None for v in (start, end, fps, duration)):
        raise ConfigError("--start, --end, --fps and --duration are movie options: drop them for a figure")
    return _figure(figure, rig, experiment, coords, model_coords, fs, output, force=force, view=view, magnify=magnify)


def _check_experiment(project, experiment: str) -> None:
    """A project with a rig to draw and the experiment named."""
    if project.rig is None:
        from odsuite.api import project_geometry

        geometry = project_geometry(project)
        if geometry is not None:  # what can be drawn on it, not a claim that it is missing
            raise ConfigError(f"{project.path}: the project has no rig (created with --rig none), whose plates a "
                              f"record's motion is drawn on; on its geometry {geometry.name!r} `--renderer "
                              "mode-shape --mode K` draws a mode and `--ods HZ --reference SENSOR` an operating "
                              "deflection shape (docs/geometry.md)")
        raise ConfigError(f"{project.path}: the project has no rig geometry to draw (created with --rig none) "
                          "and no geometry of nodes and lines (docs/geometry.md)")
    if experiment not in project.experiment_names():
        raise ConfigError(f"{project.path}: no experiment {experiment!r} "
                          f"(experiments: {', '.join(project.experiment_names()) or 'none'})")


def _ods(project, experiment: str, exp, ods_hz: float, reference: str | None):
    """The operating deflection shape's motion at ``ods_hz``: (coords, fs, frequency, source words);
    from the measured FRFs, or for an operating record or with a ``reference`` from the cross-spectra."""
    from odsuite.api import ods_coordinates, ods_motion

    if reference is None and exp.excitation is not None:
        shapes, source = ods_coordinates(project, experiment, ods_hz), "from the measured FRFs"
    else:
        from odsuite.api import operating_shape

        if reference is None:
            raise ConfigError(f"{project.path}: experiment {experiment!r} is an operating record (no force): "
                              "give the ODS's --reference sensor")
        ods = operating_shape(project, experiment, reference, ods_hz)
        if not ods.coordinates:
            raise ConfigError(f"{project.path}: experiment {experiment!r}: {'; '.join(ods.notes)}")
        shapes, ods_hz = ods.coordinates, ods.frequency_hz
        source = f"cross-spectra to {reference}"
    coords, fs = ods_motion(shapes, ods_hz)
    return coords, fs, ods_hz, source


def _with_model(project, experiment: str, *, movie: bool):
    """Measured and model coordinates from the comparison (both through the same chain and solver)
    and, for a movie, the corrected motion where it is stored for every body (else None)."""
    from odsuite.api import experiment_coordinates

    pairs = experiment_coordinates(project, experiment)
    coords = {b: m for b, (m, _) in pairs.items()}
    model_coords = {b: p for b, (_, p) in pairs.items()}
    corrected = None
    if movie:
        from odsuite.api import stored_correction

        stored = stored_correction(project, experiment)
        corrected = stored[0] if stored and set(stored[0]) == set(coords) else None
    return coords, model_coords, corrected


def _hammer(project, experiment: str, exp, coords) -> Hammer | None:
    """The hammer drawn on the body it hit (None for an operating record)."""
    if exp.excitation is None:
        return None
    from odsuite.api import experiment_force

    body = project.rig.force_body(exp.excitation.point, exp.excitation.body)
    return Hammer(body if body in coords else next(iter(coords)), np.asarray(exp.excitation.point, float),
                  np.asarray(exp.excitation.direction, float), experiment_force(project, experiment))


def _figure(figure: str, rig, experiment: str, coords, model_coords, fs: float, output, *, force, view, magnify
            ) -> Path:
    """The projection, overlay or residual-spectra figure of one experiment."""
    if figure == "projection":
        parts = (view or "x").split(",")
        if len(parts) not in (1, 4):
            raise ConfigError(f"--view: for the projection expected 'EYE' or 'EYE,THETA,PHI,PSI', got {view!r}")
        try:
            angles = tuple(plain_number(v) for v in parts[1:]) or (0.0, 0.0, 0.0)
        except ValueError:
            raise ConfigError(f"--view: viewpoint angles must be numbers, got {view!r}") from None
        check_view_angles(angles, view)
        return projection_figure(rig, coords, fs, output, force=force, eye=parts[0], view_angles=angles,
                                 magnify=magnify, title=f"{experiment}").path
    # every moving body: translations in the first column, rotations in the second (body by body)
    bodies = list(coords)
    order = [(b, k) for half in (range(3), range(3, 6)) for b in bodies for k in half]
    measured = np.column_stack([coords[b][:, k] for b, k in order])
    predicted = np.column_stack([model_coords[b][:, k] for b, k in order])
    names = [COORDINATES[k] if len(bodies) == 1 else f"{b} {COORDINATES[k]}" for b, k in order]
    units = [COORDINATE_UNITS[k] for _, k in order]
    title = (f"{experiment}: {bodies[0]} at its centre of mass" if len(bodies) == 1
             else f"{experiment}: {', '.join(bodies)} at their centres of mass")
    if figure == "overlay":
        t = np.arange(measured.shape[0]) / fs
        return comparison_figure(t, measured, predicted, output, names=names, units=units, title=title).path
    return residual_spectra_figure(fs, measured, predicted, output, names=names, units=units, title=title).path


def _movie(rig, coords, fs, output, experiment, *, model_coords, magnify, corrected_coords=None, view, workers, frame_step, slowdown,
           progress, hammer, ods_hz, ods_source, start, end, fps, duration) -> MovieResult:
    """The movie with its story: the window around the hit, a title saying what is shown."""
    coords = check_coords(rig, coords)  # before the window is measured on them
    n = next(iter(coords.values())).shape[0]
    time_zero = None
    if ods_hz is not None:
        title = f"{experiment}: operating deflection shape at {ods_hz:.2f} Hz ({ods_source})"
    else:
        title = f"{experiment}: measured motion" + (
            " (blue), corrected (green) and the model's (orange band)" if corrected_coords else
            " (blue) and the model's (orange band)" if model_coords else "")
        if hammer is not None:
            time_zero = contact_index(hammer.force) / fs
        if start is None and end is None:
            contact = None if time_zero is None else int(round(time_zero * fs))
            start, end = event_window(rig, coords, fs, contact=contact)
    for name, value in (("--start", start), ("--end", end)):
        if value is not None and not 0 <= value <= (n - 1) / fs:
            raise ConfigError(f"{name}: {value:g} s is outside the record (0 to {(n - 1) / fs:g} s)")
    if start is not None and end is not None and end <= start:
        raise ConfigError(f"--end {end:g} s must come after --start {start:g} s")
    if ods_hz is None and duration is None and frame_step is None and slowdown is None:
        duration = DEFAULT_DURATION
    return render_movie(rig, coords, fs, output, model_coords=model_coords, corrected_coords=corrected_coords,
                        magnify=magnify,
                        view=parse_view(view) or (60.0, 25.0), workers=workers,
                        frame_step=frame_step, slowdown=slowdown, duration=duration, progress=progress,
                        start=start or 0.0, stop=end, fps=fps or 25.0, hammer=hammer, title=title,
                        time_zero=time_zero, ods_hz=ods_hz)
