"""One self-contained HTML page telling a project's story: the rig and experiments, measured against
model per generalized coordinate and per channel, where the model fails, the candidate effects,
the error across revisions, a movie of one experiment with the model's motion overlaid and an
interactive 3-D view of that motion.

Figures are embedded as base64 256-colour PNG, the movie as a base64 MP4 in ``<video>`` (a GIF where
no H.264 encoder is at hand), and the 3-D view as a canvas with an inline script: the page needs no
network.
Every number shown comes from ``compare``, ``diagnose`` and ``history`` unchanged.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odsuite.api import fixed, per_unit, rms_label, unit_text, write_output
from odsuite.api import ConfigError, check_diagnosis, check_text_file

#: Movie: frame size (pixels), frames per second, about this many frames, this long after the hit.
#: The rate is one a GIF plays exactly (8/100 s a frame), should the movie be one.
MOVIE_SIZE = (640, 360)
MOVIE_FPS = 12.5
MOVIE_FRAMES = 90
MOVIE_AFTER_S = 0.06
MOVIE_BEFORE_S = 0.002
FIGURE_DPI = 90
#: Modal figures are drawn at the width of a printed A4/Letter text column (inches), so their type
#: sizes are the printed ones.
PRINT_WIDTH_IN = 6.5
#: The page should stay below this size (a mail attachment); beyond it a note says what made it large.
SIZE_BUDGET = 4 * 1024 * 1024
#: a diagnosis document (``diagnose --json``) is a few kB; more is no diagnosis (bytes)
DIAGNOSIS_BYTES = 16 * 2**20

SECTIONS = ("summary", "modal", "metadata", "experiments", "overlays", "failures", "candidates", "history", "movie", "view3d")


@dataclass
class ReportResult:
    """The written page, its size, the error it reports and what was left out (and why)."""

    path: Path
    size_bytes: int
    error: float
    sections: list[str]
    movie_experiment: str | None = None
    notes: list[str] = field(default_factory=list)


def _fmt(v: Any, spec: str = ".4f") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    # fixed decimals: a zero never signed (an undamped model's ζ)
    return fixed(v, int(spec[1:-1])) if spec.startswith(".") and spec.endswith("f") else format(v, spec)


def _esc(v: Any) -> str:
    return html.escape(str(v))


def _data_uri(path: Path, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(path.read_bytes()).decode('ascii')}"


#: a figure is embedded with 256 colours only where each colour it draws over at least
#: PALETTE_AREA pixels (a line's, a map cell's own colour, not an antialiased edge's) moves by at
#: most PALETTE_TOLERANCE (of 255): median cut alone merges the rarer colours of a figure of many
#: coloured lines (40 lines of a hue wheel: the lines' own colours moved by up to 42/255, three
#: pairs drawn in one colour); a few k-means rounds mend most, and what they do not stays RGB
PALETTE_TOLERANCE = 8
PALETTE_AREA = 20


def _palette_png(path: Path) -> Path:
    """``path`` rewritten as a 256-colour PNG, a third of the bytes of matplotlib's RGBA one, where
    that keeps its colours (see ``PALETTE_TOLERANCE``), else as an RGB PNG; median cut keeps white
    white (no dithering: no speckle around the lines)."""
    from PIL import Image

    with Image.open(path) as im:
        rgb = im.convert("RGB")
    original = np.asarray(rgb).astype(np.int16)
    for rounds in (0, 2):  # k-means rounds only where median cut alone moved a colour
        pal = rgb.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE, kmeans=rounds)
        moved = original[np.abs(original - np.asarray(pal.convert("RGB"), np.int16)).max(axis=2) > PALETTE_TOLERANCE]
        # without dithering every pixel of a colour maps to the same entry, so the pixels moved
        # too far are whole colours: only their areas need counting, not every pixel's
        code = (moved[:, 0].astype(np.int32) << 16) | (moved[:, 1].astype(np.int32) << 8) | moved[:, 2]
        if np.unique(code, return_counts=True)[1].max(initial=0) < PALETTE_AREA:
            pal.save(path)
            return path
    rgb.save(path)
    return path


def _img(path: Path, alt: str) -> str:
    return (f'<figure><img src="{_data_uri(_palette_png(path), "image/png")}" alt="{_esc(alt)}">'
            f'<figcaption>{_esc(alt)}</figcaption></figure>')


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]], *, id: str | None = None, caption: str = "",
           empty: str = "") -> str:
    """An HTML table; cells are escaped unless given as ``("raw", html)``. Without rows, no table:
    the sentence ``empty`` (else the caption and "none") says why."""
    if not rows:
        ident = f' id="{_esc(id)}-none"' if id else ""
        return f"<p class='empty'{ident}>{_esc(empty or (caption or 'table') + ': none.')}</p>"
    def cell(c: Any, tag: str) -> str:
        if isinstance(c, tuple) and c and c[0] == "raw":
            return f"<{tag}>{c[1]}</{tag}>"
        return f"<{tag}>{_esc(c)}</{tag}>"

    head = "".join(cell(h, "th") for h in header)
    body = "".join("<tr>" + "".join(cell(c, "td") for c in r) + "</tr>" for r in rows)
    cap = f"<caption>{_esc(caption)}</caption>" if caption else ""
    ident = f' id="{_esc(id)}"' if id else ""
    return f"<table{ident}>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _heatmap(values: np.ndarray, rows: Sequence[str], cols: Sequence[str], path: Path, *, xlabel: str,
             ylabel: str, title: str) -> Path:
    """A labelled heat map of NRMSE values with the number in every cell."""
    from matplotlib.figure import Figure

    v = np.asarray(values, dtype=float)
    fig = Figure(figsize=(1.6 + 0.95 * len(cols), 1.4 + 0.45 * len(rows)), layout="constrained")
    ax = fig.add_subplot()
    im = ax.imshow(np.ma.masked_invalid(v), cmap="magma_r", aspect="auto", vmin=0.0,
                   vmax=max(1e-12, float(np.nanmax(v))) if np.isfinite(v).any() else 1.0)
    ax.set_xticks(range(len(cols)), cols, rotation=30, ha="right", fontsize=9)
    ax.set_yticks(range(len(rows)), rows, fontsize=9)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    top = np.nanmax(v) if np.isfinite(v).any() else 1.0
    for i in range(v.shape[0]):
        for j in range(v.shape[1]):
            if np.isfinite(v[i, j]):
                ax.text(j, i, f"{v[i, j]:.3f}", ha="center", va="center", fontsize=9,
                        color="white" if v[i, j] > 0.5 * top else "black")
    fig.colorbar(im, ax=ax, label="NRMSE [–]")
    fig.savefig(path, dpi=FIGURE_DPI)
    return path


def _mark_peaks(fig, peaks: Sequence[Mapping[str, Any]], modes_hz: Sequence[float]) -> None:
    """Mark the residual peaks (red: no model mode near, the model lacks them) and the model's modes
    (grey) on every panel of a residual spectra figure, before it is saved."""
    panels = [ax for ax in fig.axes if ax.get_visible()]
    for ax in panels:
        for f in modes_hz:
            ax.axvline(f, color="0.6", lw=0.7, ls=":")
        for p in peaks:
            ax.axvline(p["frequency_hz"], color="red" if p["lacking"] else "tab:green", lw=0.8, ls="--")
    if panels:
        from matplotlib.lines import Line2D

        from .figures import legend_below

        handles = panels[0].get_legend_handles_labels()[0] + [
            Line2D([], [], color="red", ls="--", label="residual peak, no model mode"),
            Line2D([], [], color="tab:green", ls="--", label="residual peak near a model mode"),
            Line2D([], [], color="0.6", ls=":", label="model mode")]
        legend_below(fig, handles)


def load_diagnosis(source: str | Path | Mapping[str, Any]) -> dict[str, Any]:
    """A diagnosis document (``odsuite diagnose --json``) from a file or a mapping, checked."""
    where = str(source) if not isinstance(source, Mapping) else "diagnosis"
    if isinstance(source, Mapping):
        doc = dict(source)
    else:
        try:
            check_text_file(Path(source), "diagnosis (JSON)")  # a pipe or device is refused, never read
            with open(source, "rb") as f:
                text = f.read(DIAGNOSIS_BYTES + 1)
            if len(text) > DIAGNOSIS_BYTES:
                raise ConfigError(f"{where}: more than {DIAGNOSIS_BYTES} bytes, not a diagnosis from "
                                  "`odsuite diagnose --json`")
            # NaN and Infinity (json.dumps of a diagnosis made through the API) read as null, as
            # `diagnose --json` writes them: a number that is not finite is no value to show
            doc = json.loads(text.decode("utf-8"), parse_constant=lambda name: None)
        except RecursionError:  # the JSON parser recurses per level of nesting
            raise ConfigError(f"{where}: JSON nested too deeply to be a diagnosis from `odsuite diagnose --json`") from None
        except OSError as exc:
            raise ConfigError(f"{where}: cannot read the diagnosis ({exc.strerror or exc})") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{where}: not a JSON document from `odsuite diagnose --json` ({exc})") from None
        except ConfigError:
            raise
        except ValueError as exc:  # an integer of more than 4,300 digits (Python's conversion limit)
            raise ConfigError(f"{where}: not a diagnosis from `odsuite diagnose --json` "
                              f"({str(exc).splitlines()[0][:120]})") from None
    return check_diagnosis(doc, f"{where}:")


def _direction(unit: Sequence[float]) -> str:
    """A force direction as signed components: a -x blow is (-1.00, +0.00, +0.00), not -0.00."""
    return "(" + ", ".join(f"{round(float(v), 2) + 0.0:+.2f}" for v in unit) + ")"


def _experiments_section(project, exps, comparison) -> str:
    from odsuite.api import assess_hits

    info = project.info()["experiments"]
    rows = []
    for e in exps:
        d = info[e.name]
        hits = assess_hits(e.force, e.measured, e.fs, decay_limit=None)
        rejected = sorted({r for h in hits for r in h.reasons})
        clipped = ", ".join(f"{c} ({n} samples)" for c, n in d["clipped_samples"].items()) or "none"
        p = 1e3 * e.point
        rows.append([e.name, f"({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f})",
                     _direction(e.direction), d["n_samples"],
                     f"{d['sampling_rate']:g}", f"{np.max(np.abs(e.force)):.1f}",
                     f"{len(hits)}" + (f" (rejected: {', '.join(rejected)})" if rejected else ""), clipped,
                     _fmt(comparison.experiments[e.name]["error"])])
    rig = project.rig
    bodies = ", ".join(f"{b.name}" + (f" ({b.mass:g} kg)" if b.mass is not None else "") for b in rig.bodies)
    sensors = ", ".join(s.name for s in exps[0].sensors)
    # the rig file's own words for its frame: no other rig's origin or axes
    frame = f"the rig frame ({_esc(rig.frame)})" if rig.frame else "the rig frame"
    return (f"<p>Rig <b>{_esc(rig.name)}</b>: bodies {_esc(bodies)}; accelerometers {_esc(sensors)}. "
            f"Force points in mm in {frame}.</p>"
            + _table(["experiment", "force point [mm]", "force direction", "samples", "rate [Hz]",
                      "peak force [N]", "hits", "clipped channels", "error (NRMSE)"], rows, id="experiments"))


def _metadata_section(project, exps) -> str:
    """What a test record needs: when, with what hammer and sensors (serials, calibration), by
    which software."""
    from odsuite.api import __version__

    info = project.info()
    exp_rows = []
    for e in exps:
        d = info["experiments"][e.name]
        exp_rows.append([e.name, d.get("created") or "–", d.get("source") or "–", f"{d['sampling_rate']:g} Hz",
                         f"{d['n_samples']} ({1e3 * d['duration']:.1f} ms, {d['pretrigger']} before the trigger)"])
    first = project.experiment(exps[0].name)
    si = first.systeminfo
    names = first.channel_names
    chan_rows = []
    for k, ch in enumerate(si.channels):
        sensor = project.rig.sensor_on_channel(k)
        unit = ("u" if ch.micro_units else "") + ch.unit
        chan_rows.append([k, names[k] if k < len(names) else "–", ch.quantity, ch.serial or "–",
                          f"{ch.sensitivity:.6g} {per_unit('V', unit)}", f"{ch.daq_gain:g}",
                          "–" if sensor is None or sensor.position is None
                          else "(" + ", ".join(f"{1e3 * v:.1f}" for v in sensor.position) + ")"])
    # a DAQ gain is a .CTR Systeminfo's field (the rig's own or a legacy import's); the rig format has none
    gains = project.rig.systeminfo_file is not None or str(info["experiments"][exps[0].name].get("source") or
                                                           "").startswith("legacy import")
    if not gains:
        chan_rows = [row[:5] + row[6:] for row in chan_rows]
    hammer = si.channels[first.excitation.force_channel] if first.excitation is not None else None
    hammer_text = ("–" if hammer is None else
                   f"channel {first.excitation.force_channel} ({names[first.excitation.force_channel]}), "
                   f"serial {hammer.serial or 'not recorded'}, {hammer.sensitivity:.6g} V/N"
                   + (f", DAQ gain {hammer.daq_gain:g}" if gains else ""))
    return (_table(["quantity", "value"],
                   [["software", f"odsuite {__version__} (report written now; project created by "
                                 f"{info.get('creator') or 'unknown'})"],
                    ["project file", f"{project.path.name}, format {info['format_version']}"],
                    ["rig", project.rig.name], ["hammer (force sensor)", hammer_text]], id="metadata")
            + _table(["experiment", "recorded", "source", "sampling rate", "samples"], exp_rows, id="recordings")
            + _table(["channel", "name", "quantity", "serial", "calibration"] + (["DAQ gain"] if gains else [])
                     + ["position [mm]"], chan_rows,
                     id="channels", caption=f"channels of {exps[0].name} (Systeminfo): calibration in volts per "
                                            "unit of the measured quantity"))


def build_report(
    project_path: str | Path,
    output: str | Path,
    *,
    diagnosis: str | Path | Mapping[str, Any] | None = None,
    run_diagnosis: bool = True,
    movie: bool = True,
    movie_experiment: str | None = None,
    frf_channels: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
    registries=None,
) -> ReportResult:
    """Write the project's report to ``output`` (one self-contained HTML file).

    ``diagnosis``: a stored ``odsuite diagnose --json`` document (file or mapping) to show; without
    it the page shows the diagnosis ``odsuite diagnose`` kept with the current revision for the
    records as they are, else the diagnosis runs now unless ``run_diagnosis`` is False. ``movie``:
    embed a movie of ``movie_experiment`` (default: the experiment the model fits worst) with the
    model overlaid. ``frf_channels``: the channels whose FRFs are drawn for each hammer record
    (default: the driving point: the accelerometer nearest the force point, along the force).
    ``registries``: the providers to open the project with (None: the installed plugins').
    """
    from threadpoolctl import threadpool_limits

    from odsuite.api import open_project

    output = Path(output)
    if output.suffix.lower() not in (".html", ".htm"):
        raise ConfigError(f"{output}: the report is an HTML page; give a name ending in .html")
    say = progress or (lambda what: None)
    diag_doc = load_diagnosis(diagnosis) if diagnosis is not None else None
    notes: list[str] = []
    # one BLAS thread: the report's linear algebra is small, a second thread only spins on a busy core
    with open_project(project_path, registries=registries) as project, \
            tempfile.TemporaryDirectory(prefix="odsuite-report-") as tmpdir, threadpool_limits(1):
        tmp = Path(tmpdir)
        if project.rig is None:  # output-only records of a structure: no model to compare with
            from .oma_report import oma_report

            return oma_report(project, output, tmp, say, notes)
        if movie_experiment is not None and movie_experiment not in project.experiment_names():
            raise ConfigError(f"{project.path}: --movie-experiment: no experiment {movie_experiment!r} "
                              f"(experiments: {', '.join(project.experiment_names()) or 'none'})")
        c = _compared(project, say)
        sections, chosen = _sections(project, c, tmp, notes, say, diag_doc=diag_doc, run_diagnosis=run_diagnosis,
                                     movie=movie, movie_experiment=movie_experiment, frf_channels=frf_channels)
    size = _write_page(output, _page(f"odsuite report: {Path(project_path).name}", sections, notes))
    if size > SIZE_BUDGET:
        notes.append(f"the page is {size / 2**20:.1f} MiB (budget {SIZE_BUDGET / 2**20:.0f} MiB); "
                     "--no-movie makes it smaller")
    return ReportResult(path=output, size_bytes=size, error=float(c.doc["error"]), sections=[s[0] for s in sections],
                        movie_experiment=chosen, notes=notes)


@dataclass
class _Compared:
    """The current revision against the records: what every section draws from."""

    exps: list
    rev: Mapping[str, Any]
    rmodel: Any
    cmp: Any
    doc: dict[str, Any]
    modes_hz: list[float]
    preds: dict[str, np.ndarray]
    fault: Any
    windows: dict[str, tuple]


def _compared(project, say: Callable[[str], None]) -> _Compared:
    """Compare the current revision with the records, predict each, and find the fault's band."""
    from odsuite.api import compare, current_revision, predict, prepare, revision_model

    say("comparing")
    exps = prepare(project)
    rev = current_revision(project)
    rmodel = revision_model(project, rev)
    cmp = compare(project, revision=rev, prepared=exps, progress=lambda stage: say(f"comparing: {stage}"))
    doc = cmp.as_dict()
    preds = {e.name: predict(rmodel.for_experiment(e.name), e) for e in exps}
    fault, windows = _fault(exps, preds, cmp.floor)
    return _Compared(exps, rev, rmodel, cmp, doc, [m["frequency_hz"] for m in doc["modes"]["model"]], preds, fault,
                     windows)


def _sections(project, c: _Compared, tmp: Path, notes: list[str], say: Callable[[str], None], *, diag_doc,
              run_diagnosis: bool, movie: bool, movie_experiment: str | None,
              frf_channels: Sequence[str] | None) -> tuple[list[tuple[str, str, str]], str | None]:
    """Every section of the page (key, heading, HTML), and the movie's experiment (None without)."""
    from odsuite.api import COORDINATE_NAMES

    experiments_html = _experiments_section(project, c.exps, c.cmp)
    overlay_figures, coord_series = _overlay_figures(project.rig, c.exps, c.rmodel, c.preds, c.fault, c.windows, tmp)
    import matplotlib.backends.backend_agg  # noqa: F401  imported once, before the fork: both processes draw

    def beside() -> str:  # about as much drawing as the rest does here (a profile's CPU seconds)
        _draw_comparisons(overlay_figures)
        return _failures_section(c.doc, c.exps, c.preds, c.modes_hz, tmp, COORDINATE_NAMES)

    drawn_beside = _Background(beside)
    try:
        say("drawing the FRFs and MAC matrices")
        modal_html = _modal_section(c.doc, _modal_figures(project, c.exps, c.cmp.modal_records or [], frf_channels,
                                                          c.modes_hz, tmp, model_for=c.rmodel.for_experiment))
        diag, source = _diagnosis(project, c.exps, c.rev["revision"], diag_doc, run_diagnosis, notes, say)
        candidates = _candidates_section(diag, c.doc["revision"], notes, source)
        say("history")
        hist_html = _history_section(project, tmp)
        metadata_html = _metadata_section(project, c.exps)
        chosen, movie_html, view_html = _movie_and_view(project, c, coord_series, tmp, notes, say, movie,
                                                        movie_experiment)
        summary = _summary_section(project, c.exps, c.rev, c.doc, _model_modes_words(c.rmodel, c.exps, c.modes_hz))
        say("drawing the overlays and where the model fails")
        failures = drawn_beside.wait()
    finally:
        drawn_beside.close()
    overlays = _fault_words(c.fault) + _overlays_html(c.exps, c.cmp, overlay_figures)
    return [
        ("summary", "Summary", summary),
        ("modal", "Measured against model modes", modal_html),
        ("metadata", "Test record", metadata_html),
        ("experiments", "Rig and experiments", experiments_html),
        ("overlays", "Measured against model", overlays),
        ("failures", "Where the model fails", failures),
        ("candidates", "Candidate effects", candidates),
        ("history", "Error across model revisions", hist_html),
        ("movie", "Movie" + (f" of {chosen} with the model" if chosen else ""), movie_html),
        ("view3d", "Interactive 3-D view" + (f" of {chosen}" if chosen else ""), view_html),
    ], chosen


def _movie_and_view(project, c: _Compared, coord_series: Mapping[str, Mapping], tmp: Path, notes: list[str],
                    say: Callable[[str], None], movie: bool, movie_experiment: str | None) -> tuple[str | None, str, str]:
    """The movie's experiment (None without a movie), the movie and the 3-D views (the chosen
    experiment's motion and the measured mode shapes)."""
    chosen = None
    if movie:
        chosen = movie_experiment or (c.fault.experiment if c.fault else
                                      max(c.cmp.experiments, key=lambda n: c.cmp.experiments[n]["error"]))
        say(f"rendering the movie of {chosen}")
        exp = next(e for e in c.exps if e.name == chosen)
        series, corrected = _corrected_series(project, project.rig, exp, c.rev, coord_series[chosen])
        why = "" if series else _why_no_motion(project)
        movie_html = _movie_section(project.rig, exp, series, tmp, corrected, c.windows.get(chosen), c.fault, why=why)
        view_html = _view_section(project.rig, exp, series, corrected, c.windows.get(chosen), why=why)
    else:
        movie_html = "<p>Movie left out (--no-movie).</p>"
        view_html = "<p>3-D view left out with the movie (--no-movie).</p>"
        notes.append("movie skipped (--no-movie)")
    return chosen, movie_html, view_html + _mode_view_section(project, c.cmp.modal_records or [], notes)


def _why_no_motion(project) -> str:
    """Why no body's motion is drawn: the bodies' sensors cannot give it, else the chains give no
    displacements."""
    from odsuite.contracts.solvers import body_solvers

    problems = body_solvers(project.rig, [s.name for s in project.rig.sensors],
                            project.registries.coordinate_solvers)[1]
    return (f"no body's motion can be solved from its sensors ({'; '.join(problems)})" if problems
            else "the chains give no displacements")


def _overlay_figures(rig, exps, rmodel, preds: Mapping[str, np.ndarray], fault, windows: Mapping[str, tuple],
                     tmp: Path) -> tuple[list[tuple[str, Path, dict, str]], dict]:
    """Measured against model in time, per experiment: each body's generalized coordinates and every
    accelerometer where the fault's band rings (and, in the fault's experiment, around the hit as a
    second view), as figures to draw (experiment, path, ``comparison_figure``'s arguments, caption);
    also each experiment's coordinate series for the later sections."""
    from odsuite.api import coordinate_series

    figures, coord_series = [], {}
    for e in exps:
        model = rmodel.for_experiment(e.name)
        t = np.arange(e.n_samples) / e.fs
        # where the fault's band rings (the hit alone is a second view below)
        window = windows.get(e.name) or _window(e)
        series = coord_series[e.name] = coordinate_series(rig, e, model)
        for body, (gm, gp, _) in series.items():
            figures.append((e.name, tmp / f"{e.name}-{body}.png",
                            dict(t=t, measured=gm, model=gp, title=f"{e.name}: {body} at its centre of mass",
                                 window=window),
                            f"{e.name}: generalized coordinates of the {body} at its centre of mass, model (solid) "
                            "and measured (dashed)"))
        names = [s.name for s in e.sensors]
        figures.append((e.name, tmp / f"{e.name}-channels.png",
                        dict(t=t, measured=e.measured, model=preds[e.name], names=names, units=e.units,
                             title=f"{e.name}: accelerometers (acceleration stage)", window=window),
                        f"{e.name}: every accelerometer after filter 1, model (solid) and measured (dashed)"
                        + _window_words(window, e, fault)))
        if fault is not None and e.name == fault.experiment:  # one second view: the page has a budget
            figures.append(_hit_view(e, preds[e.name], names, tmp))
    return figures, coord_series


def _draw_comparisons(figures: Sequence[tuple[str, Path, dict, str]]) -> None:
    from .figures import comparison_figure

    for _, path, args, _ in figures:
        comparison_figure(path=path, dpi=FIGURE_DPI, **args)


def _overlays_html(exps, cmp, figures: Sequence[tuple[str, Path, dict, str]]) -> str:
    """The drawn overlay figures under a heading per experiment with its error."""
    parts = []
    for e in exps:
        parts.append(f"<h3 id='overlay-{_esc(e.name)}'>{_esc(e.name)} "
                     f"(error {_fmt(cmp.experiments[e.name]['error'])})</h3>")
        parts += [_img(path, caption) for name, path, _, caption in figures if name == e.name]
    return "".join(parts)


#: jobs for a forked process, by token: the child inherits them with the fork, so no figure's data
#: is pickled on the way there (only the job's result comes back)
_JOBS: dict[int, Callable[[], Any]] = {}


def _run_job(token: int) -> Any:
    return _JOBS[token]()


class _Background:
    """Runs one job (a function without arguments) in a forked process while this one goes on (the
    report's figures are independent: two cores draw them in about half the time); in this
    process, at once, where a process cannot fork or start children (a batch's worker)."""

    def __init__(self, job: Callable[[], Any]) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        self._pool = self._future = self._result = None
        self._token = id(job)
        if ((os.cpu_count() or 1) > 1 and "fork" in multiprocessing.get_all_start_methods()
                and not multiprocessing.current_process().daemon):
            _JOBS[self._token] = job
            self._pool = ProcessPoolExecutor(1, multiprocessing.get_context("fork"))
            self._future = self._pool.submit(_run_job, self._token)
        else:
            self._result = job()

    def wait(self) -> Any:
        """The job's result, when it is done; its error, if any, raised here."""
        if self._pool is not None:
            try:
                self._result = self._future.result()
            finally:
                self.close()
        return self._result

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        _JOBS.pop(self._token, None)


def _diagnosis(project, exps, revision: int, diag_doc: Mapping[str, Any] | None, run_diagnosis: bool,
               notes: list[str], say: Callable[[str], None]) -> tuple[Mapping[str, Any] | None, str]:
    """The diagnosis to show and a sentence saying where it is from: the one given, else the one
    ``odsuite diagnose`` kept with ``revision`` (the current one) for the records as they are, else
    one run now (unless ``run_diagnosis`` is False; it takes as long as ``odsuite diagnose``)."""
    from odsuite.api import stored_diagnosis

    if diag_doc is not None:
        return diag_doc, "The candidates below are from the diagnosis given to the report (--diagnosis)."
    if not run_diagnosis:
        notes.append("diagnosis skipped (--no-diagnose)")
        return None, ""
    kept = stored_diagnosis(project, revision)
    if kept is not None:
        return kept, (f"The candidates below are from <code>odsuite diagnose</code>, kept with revision "
                      f"{_esc(revision)} for the records as they are now.")
    from odsuite.api import diagnose

    say("diagnosing")
    doc = diagnose(project, prepared=exps,
                   progress=lambda what, i, n: say(f"diagnosing: {what} ({i}/{n})" if n else f"diagnosing: {what}")).as_dict()
    notes.append(f"no diagnosis kept with revision {revision} for these records: diagnosed now; "
                 f"`odsuite diagnose {project.path.name}` keeps one that the next report shows at once")
    return doc, ("The candidates below are from <code>odsuite diagnose</code>, run now for this page: none was "
                 f"kept with revision {_esc(revision)} for the records as they are now.")


def _history_section(project, tmp: Path) -> str:
    """The pooled error per model revision: a figure and a table."""
    from odsuite.api import history

    hist = history(project)
    _draw(project, "history", None, tmp / "history.png", history=hist)
    return (_img(tmp / "history.png", "pooled error per model revision")
            + _table(["revision", "parent", "effects", "error (NRMSE)"],
                     [[r["revision"], "–" if r["parent"] is None else r["parent"],
                       ", ".join(r["effects"]) or "rigid model", _fmt(r["error"])] for r in hist["revisions"]],
                     id="history", caption=f"current revision: {hist['current']}"))


def _summary_section(project, exps, rev: Mapping[str, Any], doc: Mapping[str, Any], model_modes: str) -> str:
    """The story in one paragraph (revision, error against the noise floor, the worst channel and
    band, residual peaks the model lacks) and the summary table."""
    effects = ", ".join(e["effect"] for e in rev.get("effects", [])) or "none (the rig's rigid model)"
    worst_band = next((w for w in doc["worst"] if w["kind"] == "band"), None)
    worst_ch = next((w for w in doc["worst"] if w["kind"] == "channel"), None)
    story = (f"Model revision <span id='revision'>{_esc(doc['revision'])}</span> (effects: {_esc(effects)}) "
             f"against {len(exps)} experiment(s): pooled error <b id='error'>{_fmt(doc['error'])}</b>, "
             f"noise floor <span id='noise-floor'>{_fmt(doc['noise_floor_error'])}</span> "
             "(what a perfect model would leave).")
    if worst_ch and worst_band:
        story += (f" The worst channel is {_esc(worst_ch['name'])} ({_fmt(worst_ch['error'])}); the band "
                  f"{_esc(worst_band['name'])} holds {100 * worst_band['residual_share']:.0f} % of the residual.")
    lacking = [p for p in doc["residual_peaks"] if p["lacking"]]
    if lacking:
        story += (" Residual peaks without a model mode: "
                  + ", ".join(f"{p['frequency_hz']:.0f} Hz" for p in lacking) + ".")
    return f"<p>{story}</p>" + _table(
        ["quantity", "value"],
        [["project", project.path.name], ["rig", project.rig.name], ["current revision", doc["revision"]],
         ["effects in the model", effects], ["error (pooled NRMSE, acceleration stage)", _fmt(doc["error"])],
         ["noise floor", _fmt(doc["noise_floor_error"])],
         ["model modes [Hz]", model_modes]], id="summary-table")


def _write_page(output: Path, page: str) -> int:
    """Write the page all or nothing; its size in bytes."""
    output.parent.mkdir(parents=True, exist_ok=True)
    text = page.encode("utf-8")
    write_output(output, len(text), lambda tmp: tmp.write_bytes(text))
    return output.stat().st_size


CSS = """
body{font-family:system-ui,sans-serif;max-width:1180px;margin:1em auto;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{border-bottom:2px solid #ccd;padding-bottom:.2em;margin-top:2em}h3{font-size:1.05em}
table{border-collapse:collapse;margin:.6em 0;font-size:.85em}caption{text-align:left;font-style:italic}
th,td{border:1px solid #ccd;padding:.2em .5em;text-align:left;vertical-align:top}th{background:#eef}
figure{margin:.8em 0}figure img{max-width:100%;border:1px solid #eee}figcaption{font-size:.8em;color:#555}
nav a{margin-right:1em}.modal-figs{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}
.modal-figs figure{flex:1 1 420px}.notes{color:#a50}.lacking{color:#b00;font-weight:bold}
video{max-width:100%;border:1px solid #eee}.viewer canvas{max-width:100%;border:1px solid #ccd;cursor:grab}
.v-controls{display:flex;gap:.6em;align-items:center}.v-scrub{flex:1}.v-help{font-size:.8em;color:#555}
"""


def _modal_section(doc: Mapping[str, Any], figures: str = "") -> str:
    """compare's measured-against-model modes, record by record (model columns empty where the
    model has no mode near the measured one), then each record's FRF and MAC figures."""
    rows = doc.get("modal") or []
    notes = "".join(f"<p class='notes'>{_esc(n)}</p>" for n in doc.get("modal_notes") or [])
    if not rows:
        return notes + "<p>No measured modes (see the notes).</p>" + figures

    def rel(a: Any, b: Any) -> str:
        return "–" if a is None or not b else f"{100 * (a / b - 1):+.2f} %"

    body = [[r["experiment"], _fmt(r["measured_hz"], ".2f"), _fmt(r["model_hz"], ".2f"),
             rel(r["model_hz"], r["measured_hz"]), _fmt(100 * r["measured_zeta"], ".3f"),
             "–" if r["model_zeta"] is None else _fmt(100 * r["model_zeta"], ".3f"),
             rel(r["model_zeta"], r["measured_zeta"]), _fmt(r["mac"], ".3f")] for r in rows]
    return _table(["record", "measured f [Hz]", "model f [Hz]", "Δf", "measured ζ [%]", "model ζ [%]", "Δζ", "MAC"],
                  body, id="modal-table", caption="modes identified from each record's hammer FRFs (as "
                  "odsuite modes does) paired with the model's; MAC where two or more sensors give shapes") + notes + figures


#: sensors this close to the nearest one (m) sit at the same point (the axes of a triaxial one)
SAME_POINT_M = 1e-3


#: a sensor measures along the force when its axis is within 60 degrees of the blow's line
ALONG_FORCE_COS = 0.5


def driving_point(exp) -> int:
    """The driving point (column of ``exp.sensors``): of the accelerometers nearest the force
    point among those that measure along the force (any, when none does), the one whose axis lies
    closest to the force direction. A z sensor beside an x blow sees little of it: its FRF is noise."""
    along = np.array([0.0 if s.axis is None else abs(float(np.dot(s.axis, exp.direction))) for s in exp.sensors])
    dist = np.array([np.inf if s.position is None else float(np.linalg.norm(np.asarray(s.position) - exp.point))
                     for s in exp.sensors])
    if np.isfinite(dist[along >= ALONG_FORCE_COS]).any():
        dist = np.where(along >= ALONG_FORCE_COS, dist, np.inf)
    near = np.flatnonzero(dist <= dist.min() + SAME_POINT_M)
    return int(max(near, key=lambda k: along[k]))


def _model_frf(project, exp, model, frf, outputs: Sequence[str]) -> dict[str, np.ndarray]:
    """The model's FRF (acceleration per force, its sensor dynamics included) from the record's force
    point to each of ``outputs`` at the measured FRF's lines: what the measured one should be."""
    from odsuite.api import Input, Output

    channel_of = {n: k for k, n in enumerate(project.experiment(exp.name).channel_names)}
    force = Input.force(exp.point, exp.direction, body=project.rig.force_body(exp.point, exp.force_body))
    out = {}
    for name in outputs:
        sensor = project.rig.sensor_on_channel(channel_of[name])
        if sensor is not None and sensor.quantity == "acceleration":
            out[name] = model.transfer([force], [Output.sensor(sensor)], frf.frequency)[:, 0, 0]
    return out


def _missed_suspension_html(rec, model) -> str:
    """A sentence naming the model's suspension modes in the record's band that no measured mode
    lies within 10 % of (a suspension mode is often seen in the FRF but not picked as a stable pole)."""
    from .mode_kinds import suspension_modes

    flags = suspension_modes(model)
    if flags is None or rec.band_hz is None:
        return ""
    f = model.modes().frequency_hz
    missed = [v for v, s in zip(f, flags) if s and rec.band_hz[0] <= v <= rec.band_hz[1]
              and not np.any(np.abs(np.asarray(rec.measured_hz) - v) <= 0.1 * v)]
    if not missed:
        return ""
    return (f"<p>The model's suspension modes (the bodies together on their mounts) at "
            f"{', '.join(f'{v:.1f}' for v in missed)} Hz lie in this record's band but were not identified "
            "as stable poles; compare the FRF with the model's near them.</p>")


def _stabilisation_html(project, rec, tag: str, tmp: Path) -> str:
    """The record's stabilisation diagram: the poles the modal table's modes were chosen from."""
    if rec.modes is None or getattr(rec.modes, "diagram", None) is None or rec.modes.band_hz is None:
        return ""
    _draw(project, "stabilisation", rec.experiment, tmp / f"stab-{tag}.png", modes=rec.modes,
          freq=rec.frf.frequency, H=rec.frf.H, title=f"{rec.experiment}: stabilisation diagram",
          background=rms_label("|H| of the outputs", rec.frf.units),
          size=(PRINT_WIDTH_IN, 4.0), dpi=FIGURE_DPI, log_frequency=rec.modes.band_hz[1] > 10 * rec.modes.band_hz[0])
    return _img(tmp / f"stab-{tag}.png", f"{rec.experiment}: poles of every model order in the fit band (red: "
                "frequency and damping stable), the chosen modes dashed, the rms FRF behind them")


def _modal_figures(project, exps, records, frf_channels: Sequence[str] | None, modes_hz: Sequence[float],
                   tmp: Path, model_for=None) -> str:
    """Per hammer record: its FRFs (magnitude log-log, phase, coherence) for ``frf_channels`` or the
    driving point, with the model's (``model_for(experiment)``) and its modes dotted; its
    stabilisation diagram; and the MAC matrix of its measured modes against the model's, beside
    the modal table."""
    from .modal_figures import frf_drawn

    by_name = {e.name: e for e in exps}
    parts = []
    for rec in records:
        names = rec.frf.output_names
        if frf_channels:
            missing = [c for c in frf_channels if c not in names]
            if missing:
                raise ConfigError(f"{project.path}: --frf-channel {missing[0]!r}: experiment {rec.experiment!r} "
                                  f"has no such response channel (channels: {', '.join(names)})")
            chosen = list(frf_channels)
            what = "channels " + ", ".join(chosen)
        else:
            e = by_name[rec.experiment]
            channel_names = project.experiment(rec.experiment).channel_names
            chosen = [channel_names[e.columns[driving_point(e)]]]
            what = f"driving point {chosen[0]} (the accelerometer nearest the force point, along the force)"
        tag = f"{len(parts)}"
        # the model's modes near the band; where no mode was measured, every mode of the model
        model_hz = rec.model_hz if rec.measured_hz.size else modes_hz
        model_H = (_model_frf(project, by_name[rec.experiment], model_for(rec.experiment), rec.frf, chosen)
                   if model_for is not None else None)
        _draw(project, "frf", rec.experiment, tmp / f"frf-{tag}.png", frf=rec.frf, f_range=rec.band_hz, outputs=chosen,
              model_hz=model_hz, title=f"record {rec.experiment}: {', '.join(chosen)}", size=(PRINT_WIDTH_IN, 5.2),
              dpi=FIGURE_DPI, model_H=model_H)
        band = ("over the whole record's band (no usable band found)" if rec.band_hz is None else
                f"over the band the modes are fitted in, {rec.band_hz[0]:.0f}-{rec.band_hz[1]:.0f} Hz")
        drawn = frf_drawn(rec.frf, chosen)[2]  # where the record determines it, said as the figure says it
        figs = [_img(tmp / f"frf-{tag}.png", f"{rec.experiment}: FRF of the {what} to the hammer force "
                     f"(magnitude on log-log axes, phase where the coherence is good, coherence) {band}"
                     + (f", {drawn}" if drawn else "") + "; "
                     + ("black dashed: the model's FRF; " if model_H else "") + "dotted: model modes")]
        if rec.mac is not None:
            _draw(project, "mac", rec.experiment, tmp / f"mac-{tag}.png", mac=rec.mac,
                  labels_a=[f"{f:.1f} Hz" for f in rec.measured_hz], labels_b=[f"{f:.1f} Hz" for f in rec.model_hz],
                  xlabel="model mode", ylabel="measured mode",
                  title=f"{rec.experiment}: MAC, measured against model modes", dpi=FIGURE_DPI)
            figs.append(_img(tmp / f"mac-{tag}.png", f"{rec.experiment}: MAC of the measured modes (rows) against "
                             "the model's (columns) at the record's accelerometers"))
        elif not rec.measured_hz.size:
            figs.append("<p>No MAC: no measured modes in this record (see the notes above).</p>")
        else:
            figs.append("<p>No MAC: the record has fewer than two rig accelerometers, so no shape.</p>")
        figs.append(_stabilisation_html(project, rec, tag, tmp))
        if model_for is not None:
            figs.insert(1, _missed_suspension_html(rec, model_for(rec.experiment)))
        parts.append(f"<h3 id='modal-{_esc(rec.experiment)}'>{_esc(rec.experiment)}</h3>"
                     f"<div class='modal-figs'>{''.join(figs)}</div>")
    return "".join(parts)


def _draw(project, name: str, experiment: str | None, path: Path, **options) -> None:
    """Draw with the figure renderer ``name`` of the project's registries, as the command line does."""
    from odsuite.contracts.renderers import RenderRequest

    project.registries.renderers.get(name).render(RenderRequest(project.path, experiment, path, options,
                                                                progress=False, registries=project.registries))


def _page(title: str, sections: Sequence[tuple[str, str, str]], notes: Sequence[str]) -> str:
    nav = "".join(f'<a href="#{key}">{_esc(heading)}</a>' for key, heading, _ in sections)
    body = "".join(f'<section id="{key}"><h2>{_esc(heading)}</h2>{content}</section>'
                   for key, heading, content in sections)
    note = "".join(f"<li>{_esc(n)}</li>" for n in notes)
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{_esc(title)}</title>'
            f"<style>{CSS}</style></head><body><h1>{_esc(title)}</h1><nav>{nav}</nav>"
            + (f'<ul class="notes">{note}</ul>' if note else "") + body + "</body></html>\n")


def _failures_section(doc: Mapping[str, Any], exps, preds: Mapping[str, np.ndarray], modes_hz: Sequence[float],
                      tmp: Path, coordinate_names: Sequence[str]) -> str:
    from .figures import residual_spectra_figure

    names = list(doc["channels"])
    # a row per channel, as `compare` prints it: a rig's 21 channels as columns ran off the page
    experiments = doc["experiments"]
    per_channel = _table(["channel", *experiments, "all"],
                         [[n, *(_fmt(d["channels"].get(n)) for d in experiments.values()), _fmt(doc["channels"][n])]
                          for n in names]
                         + [["all", *(_fmt(d["error"]) for d in experiments.values()), _fmt(doc["error"])]],
                         id="channel-errors", caption="error per channel and experiment (NRMSE, acceleration stage)")
    worst = _table(["kind", "name", "error (NRMSE)", "share of the residual", "error over its noise floor"],
                   [[w["kind"], w["name"], _fmt(w["error"]),
                     f"{100 * w['residual_share']:.1f} %" if "residual_share" in w else "–",
                     f"{w['to_floor']:.2f}x" if "to_floor" in w else "–"] for w in doc["worst"]],
                   id="worst", caption="worst channels (ranked by their error over their noise floor: near 1x a "
                   "channel holds noise alone), generalized coordinates and frequency bands")
    bands = doc["bands"]
    band_err = np.array([[np.nan if v is None else v for v in row] for row in bands["error"]], dtype=float)
    heat_bands = _heatmap(band_err.T, bands["channels"], bands["labels"], tmp / "bands.png",
                          xlabel="frequency band [Hz]", ylabel="channel",
                          title=f"revision {doc['revision']} against the records: error per channel and band")
    rows = [(en, body) for en, bd in doc["coordinates"].items() for body in bd]
    parts = [per_channel, worst, _img(heat_bands, f"NRMSE of model revision {doc['revision']} against each channel in "
                                      "each frequency band, pooled over the experiments (acceleration stage)")]
    if rows:
        # a coordinate outside the body's dofs has no error: a blank cell
        coord = np.array([[doc["coordinates"][en][body].get(c, np.nan) for c in coordinate_names]
                          for en, body in rows], dtype=float)
        labels = [en if len({b for _, b in rows}) == 1 else f"{en}/{body}" for en, body in rows]
        heat_coords = _heatmap(coord, labels, list(coordinate_names), tmp / "coords.png",
                               xlabel="generalized coordinate (x, y, z [m]; θ, φ, ψ [rad])", ylabel="experiment",
                               title=f"revision {doc['revision']} against the records: error per coordinate")
        parts.append(_img(heat_coords, f"NRMSE of model revision {doc['revision']} against each generalized coordinate "
                          "(displacements at G, integrated twice from the accelerometers) per experiment: the "
                          "integration lifts low-frequency noise and drift, so values near 1 persist for a right "
                          "model; the acceleration-stage errors above decide the fit"))
    e = max(exps, key=lambda x: doc["experiments"][x.name]["error"])
    r = residual_spectra_figure(e.fs, e.measured, preds[e.name], tmp / "spectra.png", names=[s.name for s in e.sensors], units=e.units,
                                title=f"{e.name} (the worst fit): measured and residual spectra", dpi=FIGURE_DPI,
                                before_save=lambda fig: _mark_peaks(fig, doc["residual_peaks"], modes_hz))
    parts.append(_img(r.path,
                      f"{e.name}: PSD of each channel and of its residual; dashed: peaks of the pooled residual "
                      "(red where the model has no mode within 5 %), dotted: model modes"))
    peaks = [[f"{p['frequency_hz']:.1f}", f"{100 * p['share']:.2f} %", ", ".join(p["channels"]),
              "–" if p["model_mode_hz"] is None else f"{p['model_mode_hz']:.1f}",
              ("raw", '<span class="lacking">yes: the model lacks it</span>') if p["lacking"] else "no"]
             for p in doc["residual_peaks"]]
    parts.append(_table(["frequency [Hz]", "share of the residual PSD", "strongest in", "model mode near [Hz]",
                         "lacking"], peaks, id="residual-peaks",
                        caption="peaks of the pooled residual spectrum (also marked on the spectra above)",
                        empty="No peak of the residual spectrum, pooled over experiments and channels, rises above "
                              "the noise floor's spectrum at a single line (1 % false alarm over all lines) with 2 % "
                              "of the residual's energy; a residual spread over a band shows in the diagnosis's "
                              "resolved cells instead."))
    rig_rows = [[en, body, ", ".join(f"{k}: {100 * v:.1f} %" for k, v in r["fractions"].items()),
                 ", ".join(r["flagged"]) or "none", r["worst"]]
                for en, bd in doc["rigidity"].items() for body, r in bd.items()]
    if rig_rows:  # only a solver with a rigidity check (the nine-accelerometer set's) gives rows
        parts.append("<h3>Rigidity check (thesis Eq. 4.12)</h3><p>Each angular acceleration follows from two sensor "
                     "pairs; on a rigid body they agree. The fractions are their disagreement relative to the RMS.</p>"
                     + _table(["experiment", "body", "disagreement", "flagged", "worst"], rig_rows, id="rigidity"))
    return "".join(parts)


def _candidates_section(diag: Mapping[str, Any] | None, revision: Any, notes: list[str], source: str = "") -> str:
    if diag is None:
        return "<p>Diagnosis not run (--no-diagnose); run <code>odsuite diagnose</code> or drop the option.</p>"
    text = (f"<p>{source + ' ' if source else ''}Baseline error {_fmt(diag.get('baseline_error'))} (noise floor {_fmt(diag.get('noise_floor_error'))}) "
            f"on revision {_esc(diag.get('revision'))}. Each physical effect is fitted and validated on data "
            "the fit did not see; significant ones are listed first.</p>")
    if diag.get("revision") != revision:
        notes.append(f"the diagnosis was made on revision {diag.get('revision')}, the current one is {revision}")
    from odsuite.api import moved_quantities, physical_text

    rows = []
    for rank, c in enumerate(diag["candidates"], start=1):
        units = c.get("units") or {}
        # an effect's physical quantities where it reports them (a stiffness per spring in N/m, not
        # the factors per axis and per spring the data cannot separate); "1" marks a dimensionless
        # factor: no unit to print
        params = (physical_text(moved_quantities(c["physical"], limit=6)) if c.get("physical") else
                  ", ".join(f"{k} = {_fmt(v, '.4g')}" + (f" {unit_text(units[k])}" if units.get(k) not in (None, "", "1") else "")
                            for k, v in (c.get("parameters") or {}).items()))
        decided = c.get("significance_decided", True)  # false: nothing the diagnosis reads turned on it
        rows.append([rank, c["effect"], ("yes" if c.get("significant") else "no") if decided else "not decided",
                     _fmt(c.get("error_after")),
                     _fmt(c.get("validated_error")), params or "–", c.get("evidence", "")])
    return text + _table(["rank", "effect", "significant", "error after", "validated error", "parameters",
                          "evidence"], rows, id="candidates")


def _window(exp) -> tuple[float, float]:
    """The hit's window: from just before the contact to MOVIE_AFTER_S after it."""
    start = max(0.0, exp.trigger / exp.fs - MOVIE_BEFORE_S)
    return start, min((exp.n_samples - 1) / exp.fs, start + MOVIE_AFTER_S)


def _model_modes_words(rmodel, exps, modes_hz: Sequence[float]) -> str:
    """The model's modes up to the records' Nyquist frequency, its suspension modes named as such
    (rigid-body modes on the mounts), and how many lie above it: a finite-element beam's 98 modes
    reach 3 MHz, which no 50 kHz record sees."""
    from .mode_kinds import mode_words, suspension_modes

    nyquist = max(e.fs for e in exps) / 2
    flags = suspension_modes(rmodel.for_experiment(exps[0].name))
    seen = [k for k, f in enumerate(modes_hz) if f <= nyquist]
    words = mode_words([modes_hz[k] for k in seen], None if flags is None else np.asarray(flags)[seen])
    above = len(modes_hz) - len(seen)
    return (words or "none") + (f" ({above} more above {nyquist:g} Hz, the records' Nyquist frequency)" if above else "")


def _fault(exps, preds: Mapping[str, np.ndarray], floor):
    """The band where the model fails most (the resolved residual's strongest cell) and, per
    experiment, the window in which that band's residual rings; (None, {}) when no cell is above
    its floor (the pictures then show the hit)."""
    from odsuite.api import resolve

    from .fault_window import fault_windows, strongest_band

    resolved = resolve(exps, [preds[e.name] for e in exps], floor) if floor is not None else None
    band = strongest_band(resolved)
    return band, fault_windows(exps, preds, band)


def _fault_words(fault) -> str:
    if fault is None:
        return ("<p>No frequency band's residual is above its noise floor: the pictures show the "
                f"{1e3 * MOVIE_AFTER_S:.0f} ms after each hit.</p>")
    return (f"<p>The model fails most in {_esc(fault.words())}. The pictures below show where that band's "
            "residual rings: from a quarter of its period before the hit until 95 % of its energy has "
            f"gone, at least three periods; in {_esc(fault.experiment)} the {1e3 * MOVIE_AFTER_S:.0f} ms after "
            "the hit follow as a second view.</p>")


def _window_words(window: tuple[float, float], exp, fault) -> str:
    at = exp.trigger / exp.fs
    return (f"; {1e3 * (window[0] - at):+.0f} to {1e3 * (window[1] - at):+.0f} ms around the hit"
            + (f" (where the {fault.band_hz[0]:.0f}-{fault.band_hz[1]:.0f} Hz residual rings)" if fault else ""))


def _hit_view(e, pred: np.ndarray, names: Sequence[str], tmp: Path) -> tuple[str, Path, dict, str]:
    """The accelerometers over the hit's own window, the second view beside the fault's: as a figure
    to draw (see ``_overlay_figures``)."""
    window = _window(e)
    return (e.name, tmp / f"{e.name}-hit.png",
            dict(t=np.arange(e.n_samples) / e.fs, measured=e.measured, model=pred, names=names, units=e.units,
                 title=f"{e.name}: accelerometers around the hit", window=window),
            f"{e.name}: every accelerometer after filter 1 around the hit, model (solid) and measured (dashed)"
            + _window_words(window, e, None))


def _corrected_series(project, rig, exp, rev, series: Mapping[str, tuple]) -> tuple[Mapping[str, tuple], Any]:
    """The recorded and model motion to draw with the corrected one, and the corrected one with
    what was undone (None when `process --corrected` stored none for this revision). With
    corrections the model is the revision's structure seen by an ideal chain: the motion the
    corrected one should match."""
    from odsuite.api import coordinate_series, ideal_chain_model, stored_correction

    stored = stored_correction(project, exp.name)
    if stored is None or not series:
        return series, None
    coords, applied = stored
    if applied["revision"] != rev.get("revision") or set(coords) != set(series):
        return series, None
    if applied["corrections"]:
        ideal = coordinate_series(rig, exp, ideal_chain_model(project, rev).for_experiment(exp.name))
        series = {b: (gm, ideal[b][1], cols) for b, (gm, _, cols) in series.items()}
    return series, (coords, applied)


def _corrections_html(corrected) -> str:
    """The list of the measurement corrections undone in the corrected motion."""
    coords, applied = corrected
    rows = [[c["effect"], c["stage"], ", ".join(f"{k} {_fmt(v, '.4g')}" + (
        f" ± {_fmt(c['uncertainties'][k], '.2g')}" if k in c.get("uncertainties", {}) else "")
        for k, v in c["values"].items()) or "–"] for c in applied["corrections"]]
    head = (f"<p>Corrected motion (green): model revision {_esc(applied['revision'])}'s measurement corrections "
            f"undone on the records, drift removed below {_fmt(applied['cutoff_hz'], '.1f')} Hz"
            + ("; no measurement effect to undo (structure only), so it is the drift-corrected motion.</p>"
               if not rows else ":</p>"))
    return head + (_table(["effect", "stage", "values undone (± standard error)"], rows, id="corrections")
                   if rows else "")


def _movie_section(rig, exp, series: Mapping[str, tuple], tmp: Path, corrected=None, window=None,
                   fault=None, why: str = "the chains give no displacements") -> str:
    from .motion import magnification_words, speed_words
    from .movie import mp4_available, render_movie
    from .scene import Hammer, Style

    if not series:
        return f"<p>No movie: {_esc(why)}, so there are no generalized coordinates.</p>"
    start, stop = window or _window(exp)
    step = max(1, round((stop - start) * exp.fs / MOVIE_FRAMES))
    body = rig.force_body(exp.point, exp.force_body)
    hammer = Hammer(body if body in series else next(iter(series)), exp.point, exp.direction, exp.force)
    res = render_movie(rig, {b: gm for b, (gm, _, _) in series.items()}, exp.fs,
                       tmp / ("movie.mp4" if mp4_available() else "movie.gif"),
                       model_coords={b: gp for b, (_, gp, _) in series.items()}, size=MOVIE_SIZE, fps=MOVIE_FPS,
                       start=start, stop=stop, frame_step=step, workers=1, progress=False, hammer=hammer,
                       corrected_coords=corrected[0] if corrected else None,
                       title=f"{exp.name}: measured (blue), " + ("corrected (green) " if corrected else "")
                       + "and model (orange band)", time_zero=exp.trigger / exp.fs,
                       style=Style(font_size=10, line_width=1.5, model_width=5.0))
    # no GIF copy inside <video>: a browser shows that fallback only when it has no <video> at all
    poster = _poster(res.path, res.n_frames, tmp / "poster.png") if res.format != "gif" else None
    shown = (f'<img src="{_data_uri(res.path, "image/gif")}" alt="movie of {_esc(exp.name)}">'
             if res.format == "gif" else
             f'<video controls loop muted playsinline preload="auto" width="{MOVIE_SIZE[0]}" '
             + (f'poster="{_data_uri(_palette_png(poster), "image/png")}"' if poster else "") + '>'
             f'<source src="{_data_uri(res.path, "video/mp4")}" type="video/mp4">movie of {_esc(exp.name)} '
             f'(MP4, H.264)</video>')
    return (f"<figure>{shown}<figcaption>{_esc(exp.name)}: measured motion (blue)"
            + (" and corrected motion (green)" if corrected else "") + " with the model's (orange band), "
            f"{res.n_frames} frames at {res.fps:.4g} fps from {1e3 * (start - exp.trigger / exp.fs):+.1f} ms to "
            f"{1e3 * (stop - exp.trigger / exp.fs):+.1f} ms around the hit"
            + (f" (where the {fault.band_hz[0]:.0f}-{fault.band_hz[1]:.0f} Hz residual rings)" if fault and window else "")
            + f", {speed_words(res.slowdown)}, {_esc(magnification_words(res.magnify))}.</figcaption></figure>")


def _poster(mp4: Path, n_frames: int, path: Path) -> Path | None:
    """A still of the movie (a frame a third of the way in, when the plates have moved) for the
    <video>'s poster: what a printed page and a player that has not started show."""
    import imageio_ffmpeg
    from PIL import Image

    reader = imageio_ffmpeg.read_frames(str(mp4))
    try:
        width, height = next(reader)["size"]
        still = None
        # the last frame decoded where the file holds fewer than a third of them
        for k, still in enumerate(reader):
            if k == n_frames // 3:
                break
    finally:
        reader.close()
    if still is None:
        return None  # a player shows the first frame instead
    Image.frombytes("RGB", (width, height), still).save(path)
    return path


def _mode_view_section(project, records, notes: list[str]) -> str:
    """The measured (EMA) mode shapes of the hammer records moving the rig's plates, one selector
    entry per mode: each mode's sensor values solved for the bodies' motion like an ODS."""
    from odsuite.api import mpc
    from odsuite.contracts.solvers import harmonic_shapes

    from .mode_view import mode_label, mode_view_data, mode_view_html, rig_modes

    rig, coords, labels = project.rig, [], []
    failed: dict[str, list[str]] = {}  # why a mode cannot be drawn -> the modes: said once, not per mode
    for rec in records:
        res = rec.modes
        if res is None or not len(res.frequency_hz):
            continue
        channel_of = {n: k for k, n in enumerate(project.experiment(rec.experiment).channel_names)}
        sensors = [rig.sensor_on_channel(channel_of[n]) if n in channel_of else None for n in res.output_names]
        for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio)):
            values = {s.name: complex(v) for s, v in zip(sensors, res.shapes[:, k]) if s is not None}
            where = f"{project.path}: {rec.experiment} mode {k + 1}"
            try:
                coords.append(harmonic_shapes(rig, values, project.registries.coordinate_solvers, where))
            except ConfigError as exc:
                text = str(exc)
                failed.setdefault(text.removeprefix(f"{where}: "), []).append(f"{rec.experiment} mode {k + 1}")
                continue
            labels.append(mode_label("EMA", rec.experiment, k + 1, f, z, mpc(res.shapes[:, k])))
    for reason, modes in failed.items():
        notes.append(f"mode view: {project.path}: {', '.join(modes)}: {reason}")
    if not coords and failed:
        return ("<h3>Measured mode shapes</h3><p>No measured mode shape to show: the modes identified cannot "
                "be drawn on the plates (see the notes above).</p>")
    if not coords:
        return "<h3>Measured mode shapes</h3><p>No measured mode shape to show (no hammer record's modes identified).</p>"
    nodes, lines, modes = rig_modes(rig, coords, labels)
    e1, _ = rig.horizontal_axes()
    data = mode_view_data(nodes, lines, modes, up=rig.up, e1=e1)
    return "<h3>Measured mode shapes</h3>" + mode_view_html(data)


def _view_section(rig, exp, series: Mapping[str, tuple], corrected=None, window=None,
                  why: str = "the chains give no displacements") -> str:
    from .viewer import viewer_data, viewer_html

    if not series:
        return f"<p>No 3-D view: {_esc(why)}, so there are no generalized coordinates.</p>"
    start, stop = _window(exp)
    if window is not None:  # the hit and the fault's band ringing after it: scrub through both
        start, stop = min(start, window[0]), max(stop, window[1])
    data = viewer_data(rig, {b: gm for b, (gm, _, _) in series.items()}, exp.fs,
                       model_coords={b: gp for b, (_, gp, _) in series.items()},
                       start=int(round(start * exp.fs)), stop=int(round(stop * exp.fs)) + 1,
                       time_zero=exp.trigger / exp.fs, corrected_coords=corrected[0] if corrected else None)
    return viewer_html(data) + (_corrections_html(corrected) if corrected else "")
