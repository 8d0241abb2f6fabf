"""Shapes that move on a structure's geometry: an operating deflection shape or an identified mode
shape, from the sensors' complex values, spread over the geometry's nodes (its documented rule)
and animated over cycles of the shape in the plate movies' style; mode shapes also written as UFF
15/82/55 for other tools."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, Geometry, unit_text
from odsuite.contracts.renderers import parse_view

from .movie import MovieResult, frame_labels, movie_target, write_movie, _even
from .scene import Style
from .shape_scene import ShapeScene

#: the largest node motion is drawn as this fraction of the structure's size
DRAWN_FRACTION = 0.10
FRAMES_PER_CYCLE = 40
CYCLES = 3


def shape_motion(geometry: Geometry, values: Mapping[str, complex], frames_per_cycle: int = FRAMES_PER_CYCLE,
                 cycles: int = CYCLES, fraction: float = DRAWN_FRACTION) -> tuple[np.ndarray, float, np.ndarray]:
    """Node motions (frames, nodes, 3) drawn over ``cycles`` cycles, the drawing's scale factor and
    the complex node shape (nodes, 3). Channels the geometry does not place are left out."""
    on = {c: complex(v) for c, v in values.items() if c in set(geometry.channels)}
    if not on:
        raise ConfigError(f"{geometry.where}: none of the channels {', '.join(values)} has a sensor on the geometry "
                          f"(sensors: {', '.join(geometry.channels) or 'none'})")
    U = geometry.node_motion(on)  # nodes x 3, complex
    phase = 2 * np.pi * np.arange(frames_per_cycle * cycles) / frames_per_cycle
    motion = np.real(U[None] * np.exp(1j * phase)[:, None, None])
    peak = float(np.linalg.norm(motion, axis=2).max())  # the largest excursion of a node over the cycle
    if not np.isfinite(peak) or peak == 0:
        raise ConfigError(f"{geometry.where}: the shape is zero at every node: nothing moves")
    factor = fraction * geometry.size() / peak
    return factor * motion, factor, U


def render_shape_movie(geometry: Geometry, values: Mapping[str, complex], frequency_hz: float, output: str | Path,
                       *, title: str, what: str, unit: str = "", view: tuple[float, float] | None = None,
                       workers: int | None = None, fps: float | None = None, progress: bool = True,
                       style: Style = Style()) -> MovieResult:
    """A movie (MP4, else GIF) of the shape ``values`` (channel -> complex) at ``frequency_hz``."""
    path, fmt, fps, notes = movie_target(Path(output), 25.0 if fps is None else float(fps))
    motion, factor, _ = shape_motion(geometry, values)
    frames = np.arange(motion.shape[0])
    labels = frame_labels(frames, frequency_hz * FRAMES_PER_CYCLE, ods_hz=frequency_hz)
    scale = f"largest motion drawn as {100 * DRAWN_FRACTION:.0f} % of the structure's {geometry.size():.3g} m"
    if unit:  # an ODS has its data's unit; an output-only mode shape has no scale
        scale += f" ({factor:.3g} m drawn per {unit} rms)"
    size = _even((1280, 720))
    job = {"scene_type": ShapeScene, "scene_args": (geometry, motion), "fps": fps, "labels": labels,
           "n_frames": len(frames),
           "scene": dict(view=tuple(view) if view else (-60.0, 20.0), title=f"{title}\n{scale}", size=size,
                         style=style, what=what)}
    workers = 1 if workers is None else workers
    path = write_movie(job, frames, path, fmt, size, workers, progress)
    # frame_step 0: frames are phases of the shape, not samples of a record
    return MovieResult(path=path, format=fmt, n_frames=len(frames), fps=fps, magnify=(factor, factor),
                       frame_step=0, slowdown=frequency_hz * FRAMES_PER_CYCLE / fps, notes=notes)


def geometry_ods_movie(project, experiment: str, output, *, ods_hz: float, reference: str | None, view=None,
                       workers=None, fps=None, progress=True) -> MovieResult:
    """The operating deflection shape of ``experiment`` at ``ods_hz`` on the project's geometry."""
    from odsuite.api import operating_shape, project_geometry

    geom = project_geometry(project)
    if reference is None:
        raise ConfigError(f"{project.path}: experiment {experiment!r}: give the ODS's --reference sensor")
    ods = operating_shape(project, experiment, reference, ods_hz)
    unit = unit_text(next(iter(ods.units.values()), ""))
    res = render_shape_movie(geom, ods.shape, ods.frequency_hz, output,
                             title=f"{experiment}: operating deflection shape at {ods.frequency_hz:.3f} Hz "
                                   f"(phases to {reference})", what="operating deflection shape", unit=unit,
                             view=parse_view(view), workers=workers, fps=fps, progress=progress)
    missing = [c for c in ods.shape if c not in set(geom.channels)]
    if missing:
        res.notes.append(f"channel(s) {', '.join(missing)} have no sensor on geometry {geom.name!r}: not drawn")
    return res


def identified_modes(project_path, experiment: str, fmin: float | None, fmax: float | None, max_order: int | None):
    """The experiment's modes from its responses alone (``odsuite modes --output-only``)."""
    from odsuite.api import experiment_output_only_modes

    band = None if fmin is None and fmax is None else (fmin, fmax)
    kw = {} if max_order is None else {"max_order": max_order}
    res = experiment_output_only_modes(project_path, experiment, f_band=band, **kw)[0]
    if not len(res.frequency_hz):
        raise ConfigError(f"{project_path}: experiment {experiment!r}: no mode identified in the band")
    return res


def render_mode_shape(project_path, experiment: str, output, *, mode: int | None = None, fmin=None, fmax=None,
                      max_order=None, view=None, workers=None, fps=None, progress=True, registries=None,
                      reference=None):
    """A movie of mode ``mode`` (1-based) of ``experiment`` on the project's geometry, or with a
    .uff ``output`` the geometry (15/82) with every mode's node motion (55). ``experiment`` "a,b,c"
    (names of several experiments): the setups of a roving survey, their modes merged through the
    ``reference`` channels ("ch,ch"; default: those every setup has) and drawn over all channels."""
    from odsuite.api import open_project, project_geometry

    with open_project(project_path, registries=registries) as p:
        geom = project_geometry(p)
        if geom is None:
            raise ConfigError(f"{p.path}: no geometry to draw the mode on; `odsuite import {p.path.name} FILE.toml "
                              "--name geometry` adds one (docs/geometry.md)")
        setups = [experiment] if experiment in p.experiment_names() else [e.strip() for e in experiment.split(",")]
        for e in setups:
            if e not in p.experiment_names():
                raise ConfigError(f"{p.path}: no experiment {e!r} "
                                  f"(experiments: {', '.join(p.experiment_names()) or 'none'})")
    if len(setups) > 1:
        from odsuite.api import project_setups_modes

        band = None if fmin is None and fmax is None else (fmin, fmax)
        refs = None if reference is None else [c.strip() for c in reference.split(",") if c.strip()]
        res = project_setups_modes(project_path, setups, references=refs, f_band=band,
                                   **({} if max_order is None else {"max_order": max_order}))
        names, label = list(res.channels), f"setups {', '.join(setups)} merged"
    else:
        res = identified_modes(project_path, experiment, fmin, fmax, max_order)
        names, label = list(res.output_names), experiment
    out = Path(output)
    if out.suffix.lower() in (".uff", ".unv"):
        from odsuite.contracts.importers import exporter
        from odsuite.contracts.plugins import registries as installed

        modes = [(float(f), float(z), geom.node_motion(dict(zip(names, res.shapes[:, k]))))
                 for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio))]
        exporter((registries or installed()).importers, "geometry").export_file(project_path, out, setups[0],
                                                                              modes=modes)
        return out, len(modes), []
    if out.suffix.lower() in (".html", ".htm"):
        return _mode_page(geom, res, names, label, out), len(res.frequency_hz), []
    n = len(res.frequency_hz)
    if mode is None or not 1 <= mode <= n:
        listed = ", ".join(f"{k + 1}: {f:.3f} Hz" for k, f in enumerate(res.frequency_hz))
        raise ConfigError(f"--mode: {mode}: the experiment's modes are {listed}")
    k = mode - 1
    f, z = float(res.frequency_hz[k]), float(res.damping_ratio[k])
    movie = render_shape_movie(geom, dict(zip(names, res.shapes[:, k])), f, out,
                               title=f"{label}: mode {mode} of {n}, {f:.3f} Hz, damping {100 * z:.2f} %",
                               what=f"mode shape {mode}", view=parse_view(view), workers=workers, fps=fps,
                               progress=progress)
    return movie, n, [f"{name} not on geometry {geom.name!r}: not drawn" for name in names
                      if name not in set(geom.channels)]


def _mode_page(geom: Geometry, res, names: list[str], label: str, out: Path) -> Path:
    """A self-contained page with the interactive 3-D view of every mode on the geometry."""
    import html

    from odsuite.api import mpc, write_output

    from .mode_view import geometry_modes, mode_label, mode_view_data, mode_view_html

    kind = "merged OMA" if hasattr(res, "channels") else "OMA"
    labels = [mode_label(kind, label, k + 1, f, z, mpc(res.shapes[:, k]))
              for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio))]
    nodes, lines, modes, fixed, sensors = geometry_modes(geom, names, res.shapes, labels)
    body = mode_view_html(mode_view_data(nodes, lines, modes, fixed=fixed, sensors=sensors))
    text = (f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{html.escape(label)}: mode shapes</title>'
            f'</head><body><h1>{html.escape(label)}: mode shapes on {html.escape(geom.name)}</h1>{body}</body></html>')
    data = text.encode("utf-8")
    write_output(out, len(data), lambda tmp: tmp.write_bytes(data))
    return out
